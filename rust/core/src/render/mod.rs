//! Rendering a scene description: compiles the scene for the resolved settings' grid
//! and hands it to the pass loop ([`driver`]). The settings and their schema are in
//! [`settings`], the quality presets that resolve them in [`quality`]; a render split
//! into tasks (distributed rendering) is added up in [`tasks`]. Adaptive sampling lives in [`adaptive`], AUTO's wavelength grid in
//! [`auto_grid`].

use crate::color::RgbSpace;
use crate::film::FilmImages;
use crate::scene::{AsBufferView, BuildOptions, Scene, SceneDesc};
use crate::spectrum::WavelengthGrid;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub mod adaptive;
pub mod auto_grid;
pub mod driver;
pub mod quality;
pub mod settings;
pub mod tasks;
pub use driver::{Driver, PassesDone, Timing};
pub use quality::Quality;
pub use settings::{RenderSettings, ResolvedSettings};
pub use tasks::Merge;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Method {
    /// Whole-spectrum rays (the paper's method 3).
    #[default]
    Polychromatic,
    /// Every path carries one wavelength, stratified over the grid across a pixel's
    /// samples and weighted by 1/its selection probability (method 2).
    MonochromaticRays,
    /// The whole image rendered once per wavelength by a single-wavelength tracer, the
    /// results summed (method 1).
    MonochromaticScenes,
    /// The same transport with three channels holding scene RGB (comparison only).
    Rgb,
    /// Every path carries four stratified hero wavelengths importance-sampled over the
    /// visible range, with spectral MIS (Wilkie et al. 2014; `integrator/hero.rs`).
    Hero,
}

/// How a path that carries several wavelengths samples a free-flight distance in a
/// scattering medium whose extinction depends on wavelength (docs/media.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum MediumSampling {
    /// Spectral MIS: the distance is sampled with one lane's σt chosen ∝ throughput and
    /// weighted by the balance heuristic over all lanes (Wilkie et al. 2014); the path
    /// keeps every wavelength.
    #[default]
    SpectralMis,
    /// The paper's way (eq. 9): the path collapses to one wavelength chosen ∝ its
    /// energy and flies as a monochromatic path.
    Collapse,
}

/// How a whole-spectrum path chooses the wavelength it continues with at a dispersive
/// surface (the paper's eq. 9; docs/methods.md, "Wavelength choice at the collapse").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Collapse {
    /// The measured winner for the scene (see [`Collapse::resolved`]).
    #[default]
    Auto,
    /// One wavelength ∝ the ray's energy, from an independent uniform number (eq. 9).
    Energy,
    /// One wavelength ∝ energy, the uniform number stratified across the pixel's samples
    /// (a base-2 (0,1) sequence over the sample index, shuffled per bounce, with a
    /// Cranley–Patterson rotation per pixel and bounce).
    Stratified,
    /// `collapse_k` wavelengths, stratified over the energy CDF, each weighted 1/(k·p).
    Split,
}

impl Collapse {
    /// The setting's value as written in JSON, Python, the CLI and Blender.
    pub fn name(self) -> &'static str {
        match self {
            Collapse::Auto => "AUTO",
            Collapse::Energy => "ENERGY",
            Collapse::Stratified => "STRATIFIED",
            Collapse::Split => "SPLIT",
        }
    }
    /// What AUTO stands for: ENERGY until bench/caustics.py has measured a winner
    /// (docs/BENCHMARKS.md, "Dispersive glass").
    pub fn resolved(self) -> Collapse {
        match self {
            Collapse::Auto => Collapse::Energy,
            c => c,
        }
    }
}

/// Where paths start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Direction {
    /// From the camera: path tracing with next-event estimation and MIS.
    #[default]
    Backward,
    /// From the lights: light tracing, every smooth vertex splatted onto the film.
    Forward,
    /// Backward paths for everything they can sample, plus forward light paths for the
    /// paths backward tracing cannot sample (delta light → specular first vertex:
    /// caustics of point lights). A partition of path space (weights 0/1), not MIS.
    Bidirectional,
}

/// Shared between the renderer and whoever watches it (another thread, Python).
#[derive(Debug, Default)]
pub struct RenderControl {
    cancel: AtomicBool,
    done: AtomicU64,
    total: AtomicU64,
    /// Progressive display: publish [`Preview`]s (off by default, so renders that do
    /// not ask pay nothing).
    previews: AtomicBool,
    preview: Mutex<Option<Preview>>,
}

/// A snapshot of the image being rendered, converted exactly as the final image's RGBA.
#[derive(Clone, Debug)]
pub struct Preview {
    /// Row 0 at the top, RGBA (alpha 1), `width * height * 4` values.
    pub rgba: Arc<Vec<f32>>,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel in the snapshot.
    pub samples_per_pixel: u32,
    /// Counts up with every published snapshot of this control (1, 2, ...).
    pub serial: u64,
    /// The render has ended: this is the final image.
    pub last: bool,
}

/// Previews are published after a pass at most this often (plus the final image).
pub const PREVIEW_INTERVAL: Duration = Duration::from_millis(100);

impl RenderControl {
    pub fn new() -> Self {
        Self::default()
    }
    /// Asks the render to stop as soon as possible; it returns what it has.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
    /// (pixel samples done, pixel samples planned).
    pub fn progress(&self) -> (u64, u64) {
        (self.done.load(Ordering::Relaxed), self.total.load(Ordering::Relaxed))
    }
    /// Announces the pixel samples a render will take before it starts (while its
    /// settings are resolved, see [`RenderSettings::planned_pixel_samples`]), so progress
    /// shows the plan at once; the render refines it.
    pub fn plan(&self, pixel_samples: u64) {
        self.total.store(pixel_samples, Ordering::Relaxed);
    }
    /// A control whose render publishes previews (see [`RenderControl::latest_preview`]).
    pub fn with_previews() -> Self {
        let c = Self::default();
        c.previews.store(true, Ordering::Relaxed);
        c
    }
    pub fn previews_requested(&self) -> bool {
        self.previews.load(Ordering::Relaxed)
    }
    /// The newest snapshot: after the first pass, then after a pass at most every
    /// [`PREVIEW_INTERVAL`], and the final image (`last`) when the render ends. None
    /// unless previews were requested.
    pub fn latest_preview(&self) -> Option<Preview> {
        self.preview.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
    fn publish_preview(&self, rgba: Vec<f32>, width: u32, height: u32, samples_per_pixel: u32, last: bool) {
        let mut slot = self.preview.lock().unwrap_or_else(|e| e.into_inner());
        let serial = slot.as_ref().map_or(0, |p| p.serial) + 1;
        *slot = Some(Preview { rgba: Arc::new(rgba), width, height, samples_per_pixel, serial, last });
    }
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    pub samples_per_pixel: u32,
    pub seconds: f64,
    pub build_seconds: f64,
    pub method: Method,
    pub direction: Direction,
    /// MONOCHROMATIC_SCENES only: the render stopped before every wavelength's image was
    /// done, so the colour is missing part of the spectrum.
    pub incomplete_spectrum: bool,
    pub wavelengths: usize,
    pub threads: usize,
    /// Samples dropped because their value was NaN or infinite.
    pub nonfinite_samples: u64,
    pub cancelled: bool,
    pub time_limited: bool,
    pub lights: usize,
    pub triangles: usize,
    /// Bytes held by textures and HDRIs (RGB texels + environment sampling tables).
    pub texture_bytes: usize,
    /// The quality preset and what it (AUTO: the scene) chose, in short sentences.
    pub quality: Quality,
    pub auto_reason: Vec<String>,
    /// Camera samples taken over all pixels (adaptive sampling stops pixels early).
    pub total_samples: u64,
    /// The adaptive target used (0: off) and the pixels that reached it.
    pub noise_threshold: f32,
    pub converged_pixels: u64,
    /// The resolved samples per pixel (the maximum when adaptive) and max_bounces.
    pub max_samples: u32,
    pub max_bounces: u32,
    /// Largest reflectance round-trip error of the RGB → spectrum map on this grid: 0
    /// normally; a few percent (more on 4–5 samples) on grids that needed the
    /// cell-averaged fallback basis (see color/uplift/linear.rs).
    pub uplift_round_trip_error: f32,
    /// What this render left out, one sentence each naming the object and the feature
    /// (the Python API and the add-on show them as warnings).
    pub warnings: Vec<String>,
}

pub struct RenderOutput {
    pub width: u32,
    pub height: u32,
    pub images: FilmImages,
    pub wavelengths: Vec<f32>,
    pub stats: RenderStats,
}

/// Renders a scene description with settings resolved for it
/// ([`RenderSettings::resolve`] with the same `desc`). Cancelling returns the samples
/// finished so far.
pub fn render<B: AsBufferView + Sync>(
    desc: &SceneDesc,
    buffers: &[B],
    settings: &ResolvedSettings,
    control: &RenderControl,
) -> Result<RenderOutput> {
    // The plan as soon as it is known (the render refines it for other methods).
    control.total.store(settings.width as u64 * settings.height as u64 * settings.samples as u64, Ordering::Relaxed);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::setting("threads", e.to_string()))?;
    let threads = pool.current_num_threads();
    let mut out = pool.install(|| render_in_pool(desc, buffers, settings, control, threads))?;
    out.stats.auto_reason.splice(0..0, settings.notes.iter().cloned());
    Ok(out)
}

fn render_in_pool<B: AsBufferView>(
    desc: &SceneDesc,
    buffers: &[B],
    settings: &ResolvedSettings,
    control: &RenderControl,
    threads: usize,
) -> Result<RenderOutput> {
    let start = Instant::now();
    let scene = compile(desc, buffers, settings)?;
    let build_seconds = start.elapsed().as_secs_f64();
    render_built(&scene, settings, control, threads, start, build_seconds)
}

/// Compiles a scene description for resolved `settings`: their image size and grid
/// (for the RGB method, the three-channel grid of [`WavelengthGrid::rgb_channels`]).
pub fn compile<B: AsBufferView>(desc: &SceneDesc, buffers: &[B], settings: &ResolvedSettings) -> Result<Scene> {
    let grid = match settings.method {
        Method::Rgb => WavelengthGrid::rgb_channels(&settings.grid, &RgbSpace::rec709())?,
        _ => settings.grid.clone(),
    };
    let opts = BuildOptions {
        grid,
        space: RgbSpace::rec709(),
        uplift: settings.uplift,
        width: settings.width,
        height: settings.height,
    };
    Scene::build(desc, buffers, &opts)
}

/// Renders an already compiled scene (built for `settings.width`×`settings.height`; for
/// the RGB method on a grid from [`WavelengthGrid::rgb_channels`]). Lets tests and tools
/// swap in their own materials or lights.
pub fn render_scene(scene: &Scene, settings: &ResolvedSettings, control: &RenderControl) -> Result<RenderOutput> {
    if scene.camera.width() != settings.width || scene.camera.height() != settings.height {
        return Err(Error::setting(
            "width",
            format!(
                "the scene was built for {}×{} pixels, settings ask for {}×{}",
                scene.camera.width(),
                scene.camera.height(),
                settings.width,
                settings.height
            ),
        ));
    }
    if (settings.method == Method::Rgb) != scene.grid.is_rgb() {
        return Err(Error::setting(
            "method",
            "RGB renders need a scene built on an RGB grid, spectral methods a spectral one",
        ));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::setting("threads", e.to_string()))?;
    let threads = pool.current_num_threads();
    let mut out = pool.install(|| render_built(scene, settings, control, threads, Instant::now(), 0.0))?;
    out.stats.auto_reason.splice(0..0, settings.notes.iter().cloned());
    Ok(out)
}

/// Renders a compiled scene with resolved settings on the current thread pool.
fn render_built(
    scene: &Scene,
    settings: &ResolvedSettings,
    control: &RenderControl,
    threads: usize,
    start: Instant,
    build_seconds: f64,
) -> Result<RenderOutput> {
    let driver = Driver::new(scene, settings)?;
    let (film, done) = driver.run(control, start);
    Ok(driver.output(&film, done, control, Timing { start, build_seconds, threads }))
}
