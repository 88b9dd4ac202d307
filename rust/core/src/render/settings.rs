//! Render settings from one schema.
//!
//! The [`settings!`] table below is the only place a setting is declared: its name, Rust
//! type, default, whether a quality preset fills it, and its [`Spec`] (UI label, help
//! text, range or enum items, group, how Blender shows it). From it come
//! * [`RenderSettings`], what users give (JSON from Python, the CLI, USD, Blender); the
//!   settings a quality preset fills are `Option`s, `None` meaning "not set";
//! * [`ResolvedSettings`], what the renderer takes: every setting with its value, the
//!   preset and AUTO's scene analysis applied ([`super::quality::resolve`]), the grid
//!   built, all validated once;
//! * [`schema`] / [`schema_json`], which `polychrome._core.settings_schema()` exports and
//!   from which the Python `RenderSettings` dataclass, the `polychrome render` flags, the
//!   Blender `scene.polychrome` properties and panel, and `docs/settings.md`'s table are
//!   generated (see `docs/architecture.md`, "Where a new setting goes").

use super::quality::{self, Quality};
use super::{Collapse, Direction, MediumSampling, Method};
use crate::color::uplift::UpliftMethod;
use crate::sampling::Sampler;
use crate::scene::SceneDesc;
use crate::spectrum::grid::{LAMBDA_MAX, LAMBDA_MIN, MAX_SAMPLES, MIN_SAMPLES};
use crate::spectrum::WavelengthGrid;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

/// What values a setting takes.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Kind {
    /// Whole numbers in `min..=max`; `soft_*` bound what UI sliders offer.
    Int {
        min: i64,
        max: i64,
        soft_min: Option<i64>,
        soft_max: Option<i64>,
    },
    /// Finite numbers in `min..=max` (`max` None: unbounded), in `unit`.
    Float {
        min: f64,
        max: Option<f64>,
        soft_min: Option<f64>,
        soft_max: Option<f64>,
        unit: Option<&'static str>,
    },
    Bool,
    /// One of `items` (their `name`s, as JSON, Python, the CLI and Blender write them).
    Enum {
        items: Vec<Item>,
    },
    /// Free text.
    String,
    /// A list of `min_len..=max_len` numbers in `min..=max`, in `unit`. On the command
    /// line a single whole number instead sets `count_setting`.
    FloatList {
        min: f64,
        max: f64,
        min_len: usize,
        max_len: usize,
        unit: Option<&'static str>,
        count_setting: Option<&'static str>,
    },
}

/// One value of an enum setting.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Item {
    pub name: String,
    pub label: &'static str,
    pub description: &'static str,
}

/// An enum value with its UI label and description; the name is the value's serde name.
fn item<T: Serialize>(value: T, label: &'static str, description: &'static str) -> Item {
    let name = match serde_json::to_value(value) {
        Ok(Value::String(s)) => s,
        other => panic!("enum setting items must serialise to strings, got {other:?}"),
    };
    Item { name, label, description }
}

/// How Blender's `scene.polychrome` shows a setting.
#[derive(Clone, Debug, PartialEq)]
pub enum Blender {
    /// A property with the schema's default. A setting a preset fills is passed only
    /// once the user has set it in the panel; `shown` is what the property shows until
    /// then (Blender properties cannot be unset).
    Property { shown: Option<Value> },
    /// A property that is always passed, with this default where Blender's differs from
    /// the schema's (e.g. samples is explicit there, as in Cycles).
    Explicit { default: Value },
    /// Not a property: where Blender takes the value from instead.
    Elsewhere(&'static str),
}

/// Everything about a setting except its name, type and default.
#[derive(Clone, Debug)]
pub struct Spec {
    /// The UI group (a panel column, a CLI help section, a docs heading).
    pub group: &'static str,
    pub label: &'static str,
    /// One or two sentences: the CLI help, the Blender tooltip, the docs' meaning column.
    pub help: &'static str,
    pub kind: Kind,
    pub blender: Blender,
    /// (setting, value): only meaningful when that enum setting has that value.
    pub applies_when: Option<(&'static str, &'static str)>,
    /// A docs page (under docs/) that says more.
    pub see: Option<&'static str>,
}

impl Spec {
    fn new(group: &'static str, label: &'static str, help: &'static str, kind: Kind) -> Self {
        Spec { group, label, help, kind, blender: Blender::Property { shown: None }, applies_when: None, see: None }
    }
    fn blender(self, blender: Blender) -> Self {
        Spec { blender, ..self }
    }
    fn applies_when(self, setting: &'static str, value: &'static str) -> Self {
        Spec { applies_when: Some((setting, value)), ..self }
    }
    fn see(self, page: &'static str) -> Self {
        Spec { see: Some(page), ..self }
    }
}

fn int(min: i64, max: i64) -> Kind {
    Kind::Int { min, max, soft_min: None, soft_max: None }
}
fn int_soft(min: i64, max: i64, soft_max: i64) -> Kind {
    Kind::Int { min, max, soft_min: None, soft_max: Some(soft_max) }
}
fn float(min: f64, max: Option<f64>, soft_max: Option<f64>, unit: Option<&'static str>) -> Kind {
    Kind::Float { min, max, soft_min: None, soft_max, unit }
}
fn shown(v: impl Serialize) -> Blender {
    Blender::Property { shown: Some(json!(v)) }
}

/// The largest seed and sample count every front end can hold (Blender's integer
/// properties are 32-bit).
const INT32_MAX: i64 = i32::MAX as i64;

/// Declares the settings; see the module documentation. Each entry is
/// `name: MODE Type = default => spec;` where MODE is
/// * `copy`: given and resolved as is;
/// * `preset`: an `Option` that [`super::quality::resolve`] fills from the quality
///   preset when unset (it must: the resolved value is a plain `Type`);
/// * `grid`, `grid_preset`: inputs of the wavelength grid (the latter an `Option` the
///   preset fills); the resolved settings hold the built [`WavelengthGrid`] instead.
macro_rules! settings {
    ($( $(#[doc = $doc:literal])* $name:ident : $mode:ident $ty:ty = $default:expr => $spec:expr ; )*) => {
        /// Render settings as given: the same names, defaults and ranges in the Python
        /// API, the CLI and Blender. `None` (JSON null or absent) leaves a setting to the
        /// quality preset. Turn them into [`ResolvedSettings`] with [`RenderSettings::resolve`].
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct RenderSettings {
            $( $(#[doc = $doc])* pub $name: settings!(@given $mode $ty), )*
        }

        impl Default for RenderSettings {
            fn default() -> Self {
                Self { $( $name: $default, )* }
            }
        }

        /// (name, filled by a quality preset, spec) in declaration order.
        fn declared() -> Vec<(&'static str, bool, Spec)> {
            vec![ $( (stringify!($name), settings!(@preset $mode), $spec), )* ]
        }

        settings!(@resolved [] [] [] $( $mode $name $ty ; )*);
    };

    (@given copy $t:ty) => { $t };
    (@given preset $t:ty) => { Option<$t> };
    (@given grid $t:ty) => { $t };
    (@given grid_preset $t:ty) => { Option<$t> };
    (@preset copy) => { false };
    (@preset preset) => { true };
    (@preset grid) => { false };
    (@preset grid_preset) => { true };

    // Accumulates the resolved fields, the copied names and the preset-filled fields.
    (@resolved [$($fields:tt)*] [$($copied:ident)*] [$($filled:ident : $fty:ty,)*] copy $name:ident $ty:ty ; $($rest:tt)*) => {
        settings!(@resolved [$($fields)* pub $name: $ty,] [$($copied)* $name] [$($filled : $fty,)*] $($rest)*);
    };
    (@resolved [$($fields:tt)*] [$($copied:ident)*] [$($filled:ident : $fty:ty,)*] preset $name:ident $ty:ty ; $($rest:tt)*) => {
        settings!(@resolved [$($fields)* pub $name: $ty,] [$($copied)*] [$($filled : $fty,)* $name : $ty,] $($rest)*);
    };
    (@resolved [$($fields:tt)*] [$($copied:ident)*] [$($filled:ident : $fty:ty,)*] $mode:ident $name:ident $ty:ty ; $($rest:tt)*) => {
        settings!(@resolved [$($fields)*] [$($copied)*] [$($filled : $fty,)*] $($rest)*);
    };
    (@resolved [$($fields:tt)*] [$($copied:ident)*] [$($filled:ident : $fty:ty,)*]) => {
        /// The settings a render runs with: every setting's value (quality preset and
        /// AUTO's scene analysis applied) and the wavelength grid built from the grid
        /// settings. Made by [`RenderSettings::resolve`], which validates them; the
        /// renderer takes nothing else. Rust code may also write one out in full
        /// (`..Default::default()` is the FINAL preset, see [`Default`]).
        #[derive(Clone, Debug)]
        pub struct ResolvedSettings {
            $($fields)*
            /// The wavelength grid (for the RGB method, the spectral grid its RGB
            /// channels are defined on).
            pub grid: WavelengthGrid,
            /// What the quality preset (and AUTO, from the scene) chose, in short sentences.
            pub notes: Vec<String>,
        }

        /// The values a quality preset fills (one per `preset` setting).
        pub(super) struct Filled {
            $( pub $filled: $fty, )*
        }

        impl RenderSettings {
            pub(super) fn assemble(&self, filled: Filled, grid: WavelengthGrid, notes: Vec<String>) -> ResolvedSettings {
                ResolvedSettings { $( $copied: self.$copied.clone(), )* $( $filled: filled.$filled, )* grid, notes }
            }
        }
    };
}

settings! {
    /// Image width in pixels.
    width: copy u32 = 320 => Spec::new("Image", "Width", "Image width in pixels", int_soft(1, 65536, 8192))
        .blender(Blender::Elsewhere("Output Properties > Format: Resolution X × %"));
    /// Image height in pixels.
    height: copy u32 = 240 => Spec::new("Image", "Height", "Image height in pixels", int_soft(1, 65536, 8192))
        .blender(Blender::Elsewhere("Output Properties > Format: Resolution Y × %"));
    /// Render region (Blender's border): only pixels `x0 ≤ x < x1`, `y0 ≤ y < y1` (from
    /// the image's top-left corner) are rendered; the rest stays black with alpha 0.
    region: copy Option<Vec<f32>> = None => Spec::new(
        "Image",
        "Region",
        "Render only the pixels x0 <= x < x1, y0 <= y < y1 (x0,y0,x1,y1 counted from the top-left corner); the rest stays black with alpha 0",
        Kind::FloatList { min: 0.0, max: 65536.0, min_len: 4, max_len: 4, unit: Some("px"), count_setting: None },
    )
    .blender(Blender::Elsewhere("Output Properties > Format: Render Region (the border, cropped or not)"))
    .see("camera.md");
    /// Fills every setting a preset fills that is not set.
    quality: copy Quality = Quality::Auto => Spec::new(
        "Sampling",
        "Quality",
        "Fills the samples, max bounces, noise threshold and wavelength grid that are not set; a value set explicitly wins",
        Kind::Enum { items: vec![
            item(Quality::Auto, "Auto", "Wavelength grid fitted to the scene's spectra, adaptive sampling to dE00 1 (at most 1024 samples)"),
            item(Quality::Preview, "Preview", "16 wavelengths, at most 32 samples stopping at dE00 3, 4 bounces"),
            item(Quality::Final, "Final", "41 wavelengths, 256 samples, 8 bounces, no adaptive stop"),
            item(Quality::Reference, "Reference", "81 wavelengths, 2048 samples, 16 bounces, no adaptive stop"),
        ]},
    ).see("quality.md");
    /// Samples per pixel (the maximum when `noise_threshold` > 0).
    samples: preset u32 = None => Spec::new(
        "Sampling",
        "Samples",
        "Samples per pixel (the maximum per pixel when the noise threshold is above 0)",
        int_soft(1, INT32_MAX, 4096),
    ).blender(Blender::Explicit { default: json!(64) });
    /// Adaptive sampling: a pixel stops once its estimated ΔE00 is at most this (0: off).
    noise_threshold: preset f32 = None => Spec::new(
        "Sampling",
        "Noise Threshold",
        "Adaptive sampling: a pixel stops once its estimated dE00 from the converged value is at most this (0: off, every pixel gets all samples)",
        float(0.0, Some(100.0), Some(10.0), Some("dE00")),
    ).blender(shown(0.0)).see("quality.md");
    /// Scattering events per path (0: only what the camera sees directly).
    max_bounces: preset u32 = None => Spec::new(
        "Sampling",
        "Max Bounces",
        "Scattering events per path (0: only what the camera sees directly)",
        int(0, 1024),
    ).blender(shown(8));
    /// Seconds after which no new pass of samples starts; 0 means no limit.
    time_limit: copy f64 = 0.0 => Spec::new(
        "Sampling",
        "Time Limit",
        "Seconds after which no new pass of samples starts (0: no limit); at least one pass is rendered",
        float(0.0, None, None, Some("s")),
    );
    /// The same settings and seed give the same pixels on any thread count.
    seed: copy u64 = 0 => Spec::new(
        "Sampling",
        "Seed",
        "Random seed: the same settings and seed give the same pixels on any thread count",
        int(0, INT32_MAX),
    );
    /// Which random numbers pixel samples draw.
    sampler: copy Sampler = Sampler::Sobol => Spec::new(
        "Sampling",
        "Sampler",
        "Which random numbers a pixel's samples draw",
        Kind::Enum { items: vec![
            item(Sampler::Sobol, "Sobol", "Owen-scrambled Sobol points stratified across a pixel's samples, a fresh set of dimensions per bounce (as Cycles)"),
            item(Sampler::Independent, "Independent", "Independent random numbers for every draw, for comparison"),
        ]},
    ).see("methods.md");
    /// Camera paths choose the light they sample by a light tree.
    light_tree: copy bool = true => Spec::new(
        "Sampling",
        "Light Tree",
        "Camera paths choose the light to sample by what it can contribute at the shading point (its power, distance and orientation: a light tree, as Cycles) instead of by its power alone; many-light scenes get less noise",
        Kind::Bool,
    ).see("methods.md");
    /// How spectra are traced.
    method: copy Method = Method::Polychromatic => Spec::new(
        "Spectrum",
        "Method",
        "How spectra are traced",
        Kind::Enum { items: vec![
            item(Method::Polychromatic, "Polychromatic Rays", "Every ray carries the whole sampled spectrum (the paper's method)"),
            item(Method::MonochromaticRays, "Monochromatic Rays", "Every ray carries one wavelength"),
            item(Method::MonochromaticScenes, "Monochromatic Scenes", "One render per wavelength, summed"),
            item(Method::Rgb, "RGB", "Three-channel rendering, for comparison with the spectral methods"),
            item(Method::Hero, "Hero Wavelengths", "Every ray carries four stratified wavelengths sampled over the visible range, with spectral MIS (as pbrt-v4 and Mitsuba 3)"),
        ]},
    ).see("methods.md");
    /// Where paths start.
    direction: copy Direction = Direction::Backward => Spec::new(
        "Spectrum",
        "Direction",
        "Where paths start",
        Kind::Enum { items: vec![
            item(Direction::Backward, "Backward", "Path tracing from the camera with next-event estimation"),
            item(Direction::Forward, "Forward", "Light tracing from the lights, splatted onto the film (caustics of small lights)"),
            item(Direction::Bidirectional, "Bidirectional", "Backward and forward tracing combined"),
        ]},
    ).see("methods.md");
    /// POLYCHROMATIC: at the first dispersive surface continue one monochromatic
    /// sub-path per wavelength instead of choosing one (deterministic mode).
    dispersion_splitting: copy bool = false => Spec::new(
        "Spectrum",
        "Dispersion Splitting",
        "At the first dispersive surface continue one monochromatic path per wavelength instead of choosing one (the paper's deterministic mode)",
        Kind::Bool,
    ).applies_when("method", "POLYCHROMATIC");
    /// How a whole-spectrum path chooses its wavelength at a dispersive surface (eq. 9).
    collapse: copy Collapse = Collapse::Auto => Spec::new(
        "Spectrum",
        "Collapse",
        "How a path carrying the whole spectrum chooses the wavelength it continues with at a dispersive surface (the paper's eq. 9)",
        Kind::Enum { items: vec![
            item(Collapse::Auto, "Auto", "The measured fastest to converge (docs/BENCHMARKS.md, Dispersive glass): Energy"),
            item(Collapse::Energy, "Energy", "One wavelength chosen in proportion to the ray's energy with an independent random number (the paper's eq. 9)"),
            item(Collapse::Stratified, "Stratified", "One wavelength chosen in proportion to energy, each of a pixel's samples drawing from a different stratum of the distribution"),
            item(Collapse::Split, "Split", "Continue with Collapse Split Count wavelengths, stratified over the energy distribution, each weighted by 1/(k p)"),
        ]},
    ).applies_when("method", "POLYCHROMATIC").see("methods.md");
    /// SPLIT: how many wavelengths a path continues with at a dispersive surface.
    collapse_k: copy u32 = 4 => Spec::new(
        "Spectrum",
        "Collapse Split Count",
        "Wavelengths a path continues with at a dispersive surface when Collapse is Split (stratified over the energy distribution)",
        int(2, MAX_SAMPLES as i64),
    ).applies_when("collapse", "SPLIT");
    /// How whole-spectrum paths sample free-flight distances in scattering media.
    medium_sampling: copy MediumSampling = MediumSampling::SpectralMis => Spec::new(
        "Spectrum",
        "Medium Sampling",
        "How a path carrying many wavelengths picks a free-flight distance in a scattering medium whose extinction depends on wavelength",
        Kind::Enum { items: vec![
            item(MediumSampling::SpectralMis, "Spectral MIS", "Sample the distance with one wavelength's extinction and weight by the average density over all wavelengths; the path keeps its whole spectrum (Wilkie et al. 2014)"),
            item(MediumSampling::Collapse, "Collapse", "Collapse the path to one wavelength chosen in proportion to its energy and continue monochromatic (the paper's eq. 9)"),
        ]},
    ).see("media.md");
    /// Samples of a uniform grid over `wavelength_min..wavelength_max`.
    wavelength_count: grid_preset usize = None => Spec::new(
        "Spectrum",
        "Wavelengths",
        "Samples of a uniform wavelength grid from the wavelength minimum to the maximum",
        int(MIN_SAMPLES as i64, MAX_SAMPLES as i64),
    ).blender(shown(41));
    /// Start of the uniform grid (nm).
    wavelength_min: grid f32 = 380.0 => Spec::new(
        "Spectrum",
        "Wavelength Min",
        "Start of the uniform wavelength grid in nm",
        float(LAMBDA_MIN as f64, Some(LAMBDA_MAX as f64), None, Some("nm")),
    );
    /// End of the uniform grid (nm).
    wavelength_max: grid f32 = 780.0 => Spec::new(
        "Spectrum",
        "Wavelength Max",
        "End of the uniform wavelength grid in nm",
        float(LAMBDA_MIN as f64, Some(LAMBDA_MAX as f64), None, Some("nm")),
    );
    /// An explicit, strictly ascending list of wavelengths (nm); overrides the three above.
    wavelengths: grid_preset Vec<f32> = None => Spec::new(
        "Spectrum",
        "Wavelength List",
        "An explicit strictly ascending (possibly non-uniform) list of wavelengths in nm; overrides the count, minimum and maximum",
        Kind::FloatList {
            min: LAMBDA_MIN as f64,
            max: LAMBDA_MAX as f64,
            min_len: MIN_SAMPLES,
            max_len: MAX_SAMPLES,
            unit: Some("nm"),
            count_setting: Some("wavelength_count"),
        },
    ).blender(Blender::Elsewhere("not a property (a list): the Python API, the CLI or a USD stage"));
    /// The RGB → spectrum map for RGB colours and textures.
    uplift: copy UpliftMethod = UpliftMethod::Linear => Spec::new(
        "Spectrum",
        "RGB Uplift",
        "How RGB colours and textures become spectra",
        Kind::Enum { items: vec![
            item(UpliftMethod::Linear, "Linear", "The paper's linear RGB to spectrum map (eq. 10)"),
            item(UpliftMethod::Smooth, "Smooth", "A smooth bounded non-linear uplift (Jakob & Hanika 2019)"),
        ]},
    ).see("uplift.md");
    /// Keep the per-pixel spectrum (spectral EXR output, Blender's spectral passes).
    spectral_output: copy bool = false => Spec::new(
        "Spectrum",
        "Spectral Passes",
        "Keep each pixel's spectrum: .exr output then uses the spectral EXR layout; Blender gets one pass per wavelength",
        Kind::Bool,
    );
    /// Denoise the final image with Intel Open Image Denoise (done by the Python package,
    /// `polychrome[denoise]`); the core renders the same samples either way.
    denoise: copy bool = false => Spec::new(
        "Denoising",
        "Denoise",
        "Denoise the final image with Intel Open Image Denoise, guided by the albedo and normal passes (needs the pyoidn package: pip install polychrome[denoise]); the noisy image is kept as a pass",
        Kind::Bool,
    ).see("denoise.md");
    /// Denoise the progressive previews too (Blender's viewport, `RenderJob` previews).
    denoise_previews: copy bool = false => Spec::new(
        "Denoising",
        "Denoise Previews",
        "Denoise the progressive previews too (Blender's viewport, RenderJob previews), as Cycles' viewport denoising",
        Kind::Bool,
    ).see("denoise.md");
    /// Worker threads; 0 uses every core.
    threads: copy usize = 0 => Spec::new("System", "Threads", "Worker threads (0: every core)", int(0, 1024));
    /// A Dask scheduler to render on (docs/distributed.md); empty renders on this
    /// machine. The core never reads it: the Python front end splits the render into
    /// tasks for the cluster.
    scheduler: copy String = String::new() => Spec::new(
        "System",
        "Scheduler",
        "Address of a Dask scheduler (tcp://host:8786) whose workers render the sample passes and frames; empty renders on this machine",
        Kind::String,
    ).see("distributed.md");
    /// A file that keeps the finished sample passes while rendering, so that an
    /// interrupted render can continue (`resume`). The core never reads it: the Python
    /// front end renders in tasks and writes the file (docs/distributed.md).
    checkpoint: copy String = String::new() => Spec::new(
        "System",
        "Checkpoint",
        "File that keeps the finished sample passes while rendering (rewritten atomically after finished passes, at most every 10 s, and when interrupted), so that Resume can continue an interrupted render; empty: none (the CLI uses OUTPUT.checkpoint.npz)",
        Kind::String,
    ).see("distributed.md");
    /// Continue from the checkpoint file if it exists.
    resume: copy bool = false => Spec::new(
        "System",
        "Resume",
        "Continue from the Checkpoint file if there is one (it must come from the same scene and settings); the result equals an uninterrupted render",
        Kind::Bool,
    ).see("distributed.md");
}

impl RenderSettings {
    /// Parses settings JSON; unknown names are an error, null leaves a setting unset.
    /// Values are checked against the schema first, so that e.g. a negative count is
    /// reported with the setting's name and range rather than as a type error.
    pub fn from_json(json: &str) -> Result<Self> {
        let value: Value = serde_json::from_str(json).map_err(|e| Error::setting("settings", e.to_string()))?;
        if value.is_object() {
            check_all(&value)?;
        }
        serde_json::from_value(value).map_err(|e| Error::setting("settings", e.to_string()))
    }

    /// Checks every setting that has a value against its range in the schema; the error
    /// names the setting.
    pub fn validate(&self) -> Result<()> {
        check_all(&serde_json::to_value(self).map_err(|e| Error::setting("settings", e.to_string()))?)
    }

    /// Width × height × samples (the quality preset's when unset): what a render of
    /// these settings plans, known before they are resolved.
    pub fn planned_pixel_samples(&self) -> u64 {
        let samples = self.samples.unwrap_or(self.quality.preset().samples);
        self.width as u64 * self.height as u64 * samples as u64
    }

    /// The settings the render runs with: validated, the unset settings filled by the
    /// quality preset (AUTO: the grid fitted to `desc`'s spectra; without a scene the
    /// 41-sample grid), the grid built.
    pub fn resolve(&self, desc: Option<&SceneDesc>) -> Result<ResolvedSettings> {
        quality::resolve(self, desc)
    }
}

impl ResolvedSettings {
    /// The rendered rectangle `[x0, y0, x1, y1)`: the region, or the whole image.
    pub fn region_rect(&self) -> [u32; 4] {
        match &self.region {
            Some(r) if r.len() == 4 => [r[0] as u32, r[1] as u32, r[2] as u32, r[3] as u32],
            _ => [0, 0, self.width, self.height],
        }
    }
}

/// The region (whole pixels, a non-empty rectangle inside the image), named in the error.
pub(super) fn check_region(s: &RenderSettings) -> Result<()> {
    let Some(r) = &s.region else { return Ok(()) };
    let whole = r.iter().all(|v| v.fract() == 0.0);
    if !(whole && r.len() == 4 && r[0] < r[2] && r[1] < r[3] && r[2] <= s.width as f32 && r[3] <= s.height as f32) {
        return Err(Error::setting(
            "region",
            format!(
                "{r:?} must be whole pixels x0, y0, x1, y1 of a non-empty rectangle inside the {}×{} image",
                s.width, s.height
            ),
        ));
    }
    Ok(())
}

impl Default for ResolvedSettings {
    /// The schema's defaults with the FINAL preset (it needs no scene): 320×240, 256
    /// samples, 8 bounces, 41 wavelengths, no adaptive stop.
    fn default() -> Self {
        RenderSettings { quality: Quality::Final, ..Default::default() }
            .resolve(None)
            .expect("the default settings are valid")
    }
}

/// A number as messages write it: whole numbers without a decimal point (as Python's
/// check in polychrome/settings.py writes them).
fn num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// Every setting of a JSON object of settings (absent or null: unset) against its range.
fn check_all(values: &Value) -> Result<()> {
    for (name, _, spec) in declared() {
        check(name, &spec.kind, values.get(name).unwrap_or(&Value::Null))?;
    }
    Ok(())
}

/// `value` (JSON; null is unset) against `kind`'s range.
fn check(name: &'static str, kind: &Kind, value: &Value) -> Result<()> {
    if value.is_null() {
        return Ok(());
    }
    let number = |v: &Value| v.as_f64().ok_or_else(|| Error::setting(name, format!("{v} is not a number")));
    match kind {
        Kind::Int { min, max, .. } => {
            let v = number(value)?;
            if v < *min as f64 {
                return Err(Error::setting(name, format!("{value} is below the minimum {min}")));
            }
            if v > *max as f64 {
                return Err(Error::setting(name, format!("{value} is above the maximum {max}")));
            }
        }
        Kind::Float { min, max, .. } => {
            let v = number(value)?;
            if !v.is_finite() {
                return Err(Error::setting(name, format!("{value} is not finite")));
            }
            if v < *min {
                return Err(Error::setting(name, format!("{} is below the minimum {}", num(v), num(*min))));
            }
            if let Some(max) = max {
                if v > *max {
                    return Err(Error::setting(name, format!("{} is above the maximum {}", num(v), num(*max))));
                }
            }
        }
        Kind::FloatList { min, max, min_len, max_len, .. } => {
            let list = value.as_array().map(Vec::as_slice).unwrap_or_default();
            if !(*min_len..=*max_len).contains(&list.len()) {
                return Err(Error::setting(name, format!("{} values given, need {min_len}..{max_len}", list.len())));
            }
            for (i, x) in list.iter().enumerate() {
                let v = number(x)?;
                if !(v.is_finite() && *min <= v && v <= *max) {
                    return Err(Error::setting(
                        name,
                        format!("value {i} = {} is outside {}..{}", num(v), num(*min), num(*max)),
                    ));
                }
            }
        }
        Kind::Bool | Kind::Enum { .. } | Kind::String => {} // the type itself (serde) checks these
    }
    Ok(())
}

/// One setting of the schema.
#[derive(Clone, Debug)]
pub struct Setting {
    pub name: &'static str,
    /// The default as JSON (null: filled by the quality preset).
    pub default: Value,
    /// Whether a quality preset fills it when it is not set.
    pub from_quality: bool,
    pub spec: Spec,
}

/// The settings in declaration order.
pub fn schema() -> Vec<Setting> {
    let defaults = serde_json::to_value(RenderSettings::default()).expect("settings serialise");
    declared()
        .into_iter()
        .map(|(name, from_quality, spec)| Setting { name, default: defaults[name].clone(), from_quality, spec })
        .collect()
}

/// The schema as JSON (`polychrome._core.settings_schema()`): `settings` (each with name,
/// group, label, help, kind, range or items, default, from_quality, blender,
/// applies_when, see) and the quality `presets` (what each fills; `wavelength_count`
/// null: fitted to the scene).
pub fn schema_json() -> String {
    let settings: Vec<Value> = schema()
        .into_iter()
        .map(|s| {
            let blender = match &s.spec.blender {
                Blender::Property { shown } => {
                    json!({"property": true, "always": false, "default": shown.clone().unwrap_or(s.default.clone())})
                }
                Blender::Explicit { default } => json!({"property": true, "always": true, "default": default}),
                Blender::Elsewhere(where_) => json!({"property": false, "elsewhere": where_}),
            };
            json!({
                "name": s.name,
                "group": s.spec.group,
                "label": s.spec.label,
                "help": s.spec.help,
                "kind": s.spec.kind,
                "default": s.default,
                "from_quality": s.from_quality,
                "blender": blender,
                "applies_when": s.spec.applies_when.map(|(k, v)| json!({"setting": k, "value": v})),
                "see": s.spec.see,
            })
        })
        .collect();
    let presets: Vec<Value> = [Quality::Auto, Quality::Preview, Quality::Final, Quality::Reference]
        .into_iter()
        .map(|q| {
            let p = q.preset();
            json!({
                "quality": q.name(),
                "samples": p.samples,
                "noise_threshold": p.noise_threshold,
                "max_bounces": p.max_bounces,
                "wavelength_count": p.wavelength_count,
            })
        })
        .collect();
    json!({"settings": settings, "presets": presets}).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_in_range_and_names_match_the_struct() {
        RenderSettings::default().validate().unwrap();
        let names: Vec<&str> = schema().iter().map(|s| s.name).collect();
        let value = serde_json::to_value(RenderSettings::default()).unwrap();
        let fields: Vec<&str> = value.as_object().unwrap().keys().map(String::as_str).collect();
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, fields); // serde_json's map is ordered by key
    }

    #[test]
    fn enum_items_are_every_variant_and_nothing_else() {
        // Exhaustive matches: a new variant fails to compile here until it is listed.
        let all = |s: &str| -> Vec<String> {
            let spec = declared().into_iter().find(|(n, _, _)| *n == s).unwrap().2;
            let Kind::Enum { items } = spec.kind else { panic!("{s} is not an enum") };
            items.into_iter().map(|i| i.name).collect()
        };
        let name = |v: Value| v.as_str().unwrap().to_string();
        for m in
            [Method::Polychromatic, Method::MonochromaticRays, Method::MonochromaticScenes, Method::Rgb, Method::Hero]
        {
            match m {
                Method::Polychromatic
                | Method::MonochromaticRays
                | Method::MonochromaticScenes
                | Method::Rgb
                | Method::Hero => {}
            }
            assert!(all("method").contains(&name(json!(m))));
        }
        for d in [Direction::Backward, Direction::Forward, Direction::Bidirectional] {
            match d {
                Direction::Backward | Direction::Forward | Direction::Bidirectional => {}
            }
            assert!(all("direction").contains(&name(json!(d))));
        }
        for q in [Quality::Auto, Quality::Preview, Quality::Final, Quality::Reference] {
            match q {
                Quality::Auto | Quality::Preview | Quality::Final | Quality::Reference => {}
            }
            assert!(all("quality").contains(&name(json!(q))));
        }
        for u in [UpliftMethod::Linear, UpliftMethod::Smooth] {
            match u {
                UpliftMethod::Linear | UpliftMethod::Smooth => {}
            }
            assert!(all("uplift").contains(&name(json!(u))));
        }
        for c in [Collapse::Auto, Collapse::Energy, Collapse::Stratified, Collapse::Split] {
            match c {
                Collapse::Auto | Collapse::Energy | Collapse::Stratified | Collapse::Split => {}
            }
            assert!(all("collapse").contains(&name(json!(c))));
            assert_eq!(name(json!(c)), c.name());
        }
        assert_eq!(
            (all("method").len(), all("direction").len(), all("quality").len(), all("uplift").len()),
            (5, 3, 4, 2)
        );
        assert_eq!(all("collapse").len(), 4);
    }

    #[test]
    fn presets_fill_values_within_the_schema_ranges() {
        for q in [Quality::Auto, Quality::Preview, Quality::Final, Quality::Reference] {
            let p = q.preset();
            let s = RenderSettings {
                samples: Some(p.samples),
                noise_threshold: Some(p.noise_threshold),
                max_bounces: Some(p.max_bounces),
                wavelength_count: p.wavelength_count,
                ..Default::default()
            };
            s.validate().unwrap_or_else(|e| panic!("{q:?}: {e}"));
        }
    }

    #[test]
    fn out_of_range_values_name_the_setting() {
        let cases = [
            (r#"{"samples": 0}"#, "setting 'samples': 0 is below the minimum 1"),
            (r#"{"max_bounces": 1025}"#, "setting 'max_bounces': 1025 is above the maximum 1024"),
            (r#"{"width": 0}"#, "setting 'width': 0 is below the minimum 1"),
            (r#"{"noise_threshold": -1.5}"#, "setting 'noise_threshold': -1.5 is below the minimum 0"),
            (r#"{"wavelength_min": 200}"#, "setting 'wavelength_min': 200 is below the minimum 360"),
            (r#"{"wavelengths": [300, 400, 500, 600]}"#, "setting 'wavelengths': value 0 = 300 is outside 360..830"),
            (r#"{"seed": 4294967296}"#, "setting 'seed': 4294967296 is above the maximum 2147483647"),
            (r#"{"max_bounces": -1}"#, "setting 'max_bounces': -1 is below the minimum 0"),
        ];
        for (json, message) in cases {
            let err = RenderSettings::from_json(json).and_then(|s| s.resolve(None)).unwrap_err().to_string();
            assert_eq!(err, message, "{json}");
        }
        assert!(RenderSettings::from_json(r#"{"quality": "ULTRA"}"#).is_err());
        assert!(RenderSettings::from_json(r#"{"no_such_setting": 1}"#).is_err());
    }

    #[test]
    fn schema_json_lists_every_setting_with_its_default() {
        let v: Value = serde_json::from_str(&schema_json()).unwrap();
        let settings = v["settings"].as_array().unwrap();
        assert_eq!(settings.len(), schema().len());
        let samples = settings.iter().find(|s| s["name"] == "samples").unwrap();
        assert_eq!(samples["default"], Value::Null);
        assert_eq!(samples["from_quality"], true);
        assert_eq!(samples["blender"]["default"], 64);
        assert_eq!(samples["kind"]["min"], 1);
        let width = settings.iter().find(|s| s["name"] == "width").unwrap();
        assert_eq!((width["default"].as_i64(), width["blender"]["property"].as_bool()), (Some(320), Some(false)));
        assert_eq!(
            (v["presets"][1]["quality"].as_str(), v["presets"][1]["wavelength_count"].as_u64()),
            (Some("PREVIEW"), Some(16))
        );
    }
}
