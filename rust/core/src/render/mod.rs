//! The render driver: compiles the scene for the settings' grid, then renders passes of
//! samples over tiles in parallel (rayon) until the sample count, the time limit or a
//! cancel request ends it. Every pixel sample draws from its own random stream seeded by
//! (seed, pixel, sample index), so the image does not depend on the thread count.

use crate::color::uplift::UpliftMethod;
use crate::color::RgbSpace;
use crate::film::{Film, FilmBuffer, FilmImages, PixelSample};
use crate::integrator::bidir::{MisLightTracer, MisPathTracer};
use crate::integrator::forward::{ForwardPart, LightTracer, Splat};
use crate::integrator::monochromatic::{stratified_wavelength, wavelength_distribution, MonochromaticTracer, Scratch};
use crate::integrator::path::PathTracer;
use crate::integrator::Integrator;
use crate::sampling::Rng;
use crate::scene::{Buffer, BuildOptions, Scene, SceneDesc};
use crate::spectrum::named::{RgbToSpectrum, SpectrumKind, SpectrumRole};
use crate::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};
use crate::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub mod quality;
pub use quality::Quality;

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

/// Render settings; the same names are used by the Python API, the CLI and Blender.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    pub method: Method,
    /// Backward (camera), forward (light) or bidirectional tracing.
    pub direction: Direction,
    /// POLYCHROMATIC: at the first dispersive surface continue one monochromatic
    /// sub-path per wavelength instead of choosing one (deterministic mode).
    pub dispersion_splitting: bool,
    /// Uniform grid size over [wavelength_min, wavelength_max]...
    pub wavelength_count: usize,
    pub wavelength_min: f32,
    pub wavelength_max: f32,
    /// ...or an explicit ascending list of wavelengths (nm), which takes precedence.
    pub wavelengths: Option<Vec<f32>>,
    pub max_bounces: u32,
    pub seed: u64,
    /// Worker threads; 0 uses every core.
    pub threads: usize,
    /// Seconds after which no new pass starts; 0 means no limit.
    pub time_limit: f64,
    pub uplift: UpliftMethod,
    /// Keep the per-pixel spectrum (for spectral EXR output).
    pub spectral_output: bool,
    /// AUTO (default), PREVIEW, FINAL or REFERENCE: fills every setting not given
    /// explicitly (samples, max_bounces, noise_threshold, the grid); see [`quality`].
    pub quality: Quality,
    /// Adaptive sampling target: a pixel stops once its estimated error (ΔE, see
    /// [`quality::pixel_error`]) is at most this; 0 renders every pixel `samples` times.
    pub noise_threshold: f32,
    /// The fields the user set (keys of the settings JSON, see [`Self::from_json`]);
    /// None means every field is explicit (a struct built in Rust).
    #[serde(skip)]
    pub explicit: Option<std::collections::BTreeSet<String>>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 64,
            height: 64,
            samples: 16,
            method: Method::Polychromatic,
            direction: Direction::Backward,
            dispersion_splitting: false,
            wavelength_count: 41,
            wavelength_min: 380.0,
            wavelength_max: 780.0,
            wavelengths: None,
            max_bounces: 8,
            seed: 0,
            threads: 0,
            time_limit: 0.0,
            uplift: UpliftMethod::Linear,
            spectral_output: false,
            quality: Quality::Auto,
            noise_threshold: 0.0,
            explicit: None,
        }
    }
}

impl RenderSettings {
    /// Parses settings JSON, recording its keys as the explicitly set fields (the
    /// quality preset fills the others).
    pub fn from_json(json: &str) -> Result<Self> {
        let value: serde_json::Value =
            serde_json::from_str(json).map_err(|e| Error::setting("settings", e.to_string()))?;
        let keys = value.as_object().map(|m| m.keys().cloned().collect()).unwrap_or_default();
        let mut s: Self = serde_json::from_value(value).map_err(|e| Error::setting("settings", e.to_string()))?;
        s.explicit = Some(keys);
        Ok(s)
    }
    /// Settings with nothing explicit: everything comes from `quality` (and the scene).
    pub fn with_quality(quality: Quality) -> Self {
        Self { quality, explicit: Some(Default::default()), ..Self::default() }
    }
    /// Whether `field` was set by the user (always true when `explicit` is None).
    pub fn is_explicit(&self, field: &str) -> bool {
        self.explicit.as_ref().is_none_or(|e| e.contains(field))
    }

    pub fn grid(&self) -> Result<WavelengthGrid> {
        match &self.wavelengths {
            Some(l) => WavelengthGrid::from_wavelengths(l.clone()),
            None => WavelengthGrid::uniform(self.wavelength_count, self.wavelength_min, self.wavelength_max),
        }
    }

    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 || self.width > 65536 || self.height > 65536 {
            return Err(Error::setting(
                "width",
                format!("image size {}×{} must be 1..65536 on each side", self.width, self.height),
            ));
        }
        if self.samples == 0 {
            return Err(Error::setting("samples", "must be at least 1"));
        }
        if !(self.time_limit.is_finite() && self.time_limit >= 0.0) {
            return Err(Error::setting("time_limit", format!("{} s must be 0 (none) or positive", self.time_limit)));
        }
        if !(self.noise_threshold.is_finite() && self.noise_threshold >= 0.0) {
            return Err(Error::setting(
                "noise_threshold",
                format!("{} must be 0 (off) or a positive ΔE", self.noise_threshold),
            ));
        }
        if self.max_bounces > 1024 {
            return Err(Error::setting("max_bounces", format!("{} exceeds 1024", self.max_bounces)));
        }
        Ok(())
    }
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
    /// cell-averaged fallback basis (see color/uplift.rs).
    pub uplift_round_trip_error: f32,
}

pub struct RenderOutput {
    pub width: u32,
    pub height: u32,
    pub images: FilmImages,
    pub wavelengths: Vec<f32>,
    pub stats: RenderStats,
}

const TILE: u32 = 16;

/// For evaluating named spectra that never ask for RGB conversion.
struct NoRgb;
impl RgbToSpectrum for NoRgb {
    fn convert(&self, _: [f32; 3], _: SpectrumRole) -> Vec<f32> {
        Vec::new()
    }
}

/// Renders a scene description. Cancelling returns the samples finished so far.
pub fn render(
    desc: &SceneDesc,
    buffers: &[Buffer],
    settings: &RenderSettings,
    control: &RenderControl,
) -> Result<RenderOutput> {
    settings.validate()?;
    // The plan as soon as it is known (the render refines it for other methods).
    let planned = if settings.is_explicit("samples") { settings.samples } else { settings.quality.preset().samples };
    control.total.store(settings.width as u64 * settings.height as u64 * planned as u64, Ordering::Relaxed);
    let (resolved, reasons) = quality::resolve(settings, Some(desc))?;
    let settings = &resolved;
    settings.validate()?;
    let grid = settings.grid()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::setting("threads", e.to_string()))?;
    let threads = pool.current_num_threads();
    let mut out = pool.install(|| render_in_pool(desc, buffers, settings, grid, control, threads))?;
    out.stats.auto_reason.splice(0..0, reasons);
    Ok(out)
}

fn render_in_pool(
    desc: &SceneDesc,
    buffers: &[Buffer],
    settings: &RenderSettings,
    grid: WavelengthGrid,
    control: &RenderControl,
    threads: usize,
) -> Result<RenderOutput> {
    let start = Instant::now();
    let grid = match settings.method {
        Method::Rgb => WavelengthGrid::rgb_channels(&grid, &RgbSpace::rec709())?,
        _ => grid,
    };
    let opts = BuildOptions {
        grid,
        space: RgbSpace::rec709(),
        uplift: settings.uplift,
        width: settings.width,
        height: settings.height,
    };
    let scene = Scene::build(desc, buffers, &opts)?;
    let build_seconds = start.elapsed().as_secs_f64();
    render_built(&scene, settings, control, threads, start, build_seconds)
}

/// Renders an already compiled scene (built for `settings.width`×`settings.height`; for
/// the RGB method on a grid from [`WavelengthGrid::rgb_channels`]). Lets tests and tools
/// swap in their own materials or lights.
pub fn render_scene(scene: &Scene, settings: &RenderSettings, control: &RenderControl) -> Result<RenderOutput> {
    settings.validate()?;
    let (resolved, reasons) = quality::resolve(settings, None)?;
    let settings = &resolved;
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
    out.stats.auto_reason.splice(0..0, reasons);
    Ok(out)
}

/// Light paths per parallel work item of a forward pass (fixed, so the image does not
/// depend on the thread count).
const LIGHT_CHUNK: u64 = 1024;

fn render_built(
    scene: &Scene,
    settings: &RenderSettings,
    control: &RenderControl,
    threads: usize,
    start: Instant,
    build_seconds: f64,
) -> Result<RenderOutput> {
    let n = scene.grid.len();
    let (w, h) = (settings.width, settings.height);
    let mono_scenes = settings.method == Method::MonochromaticScenes;
    let spectral_method = !matches!(settings.method, Method::Rgb);
    if settings.dispersion_splitting && settings.method != Method::Polychromatic {
        return Err(Error::setting("dispersion_splitting", "applies to the POLYCHROMATIC method only"));
    }
    if !spectral_method && scene.grid.len() != 3 {
        return Err(Error::setting("method", "RGB needs the three-channel grid"));
    }
    if settings.direction == Direction::Forward && !scene.camera.is_perspective() {
        return Err(Error::setting(
            "direction",
            "FORWARD (light tracing) needs a perspective camera: light paths cannot connect to an orthographic one",
        ));
    }
    // Outer rounds: one per wavelength for monochromatic scenes, else one.
    let rounds = if mono_scenes { n } else { 1 };
    let backward = settings.direction != Direction::Forward;
    let forward = settings.direction != Direction::Backward;
    let per_round = w as u64 * h as u64 * settings.samples as u64 * (backward as u64 + forward as u64);
    control.total.store(per_round * rounds as u64, Ordering::Relaxed);
    control.done.store(0, Ordering::Relaxed);

    // A reflectance of 1 under D65 of luminance 1 reads as albedo (1,1,1).
    let d65 = SpectrumDesc::new(SpectrumKind::D65)
        .evaluate(&scene.grid, SpectrumRole::Illuminant, &NoRgb)
        .map_err(Error::Description)?;
    let mut albedo_white = SampledSpectrum::from_slice(&d65);
    albedo_white.scale(1.0 / scene.observer.xyz(&d65)[1] as f32);

    let integrator = PathTracer {
        max_bounces: settings.max_bounces,
        dispersion_splitting: settings.dispersion_splitting,
        ..Default::default()
    };
    let mono = MonochromaticTracer { max_bounces: settings.max_bounces, ..Default::default() };
    let light_tracer = LightTracer {
        max_bounces: settings.max_bounces,
        rr_depth: 3,
        part: if settings.direction == Direction::Forward {
            ForwardPart::All
        } else {
            ForwardPart::BackwardUnreachable
        },
    };
    // BIDIRECTIONAL with MIS for the whole-spectrum methods (integrator/bidir.rs); the
    // monochromatic methods keep the 0/1 partition.
    let mis = settings.direction == Direction::Bidirectional
        && matches!(settings.method, Method::Polychromatic | Method::Rgb);
    let mis_camera = MisPathTracer {
        max_bounces: settings.max_bounces,
        rr_depth: 3,
        dispersion_splitting: settings.dispersion_splitting,
    };
    let mis_light = MisLightTracer { max_bounces: settings.max_bounces, rr_depth: 3 };
    let lambda_dist = wavelength_distribution(scene);
    let samples = settings.samples;
    let seed = settings.seed;
    let tiles: Vec<(u32, u32, u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .map(|(x0, y0)| (x0, y0, TILE.min(w - x0), TILE.min(h - y0)))
        .collect();
    let mut film = Film::new(w, h, settings.spectral_output.then_some(n));
    let mut done_spp = 0u32;
    // Adaptive sampling (quality.rs): each pass's samples are split into two halves;
    // the first half's sums per pixel and the film's sums give the error estimate.
    let adaptive = settings.noise_threshold > 0.0 && quality::adaptive_supported(settings);
    let pixels = (w * h) as usize;
    let mut active: Vec<bool> = if adaptive { vec![true; pixels] } else { Vec::new() };
    let mut half_xyz: Vec<[f64; 3]> = if adaptive { vec![[0.0; 3]; pixels] } else { Vec::new() };
    let mut half_count: Vec<u32> = if adaptive { vec![0; pixels] } else { Vec::new() };
    let mut pixel_err: Vec<f64> = if adaptive { vec![f64::INFINITY; pixels] } else { Vec::new() };
    let mut last_preview: Option<Instant> = None;
    let mut time_limited = false;
    // MONOCHROMATIC_SCENES stopped (cancel, time limit) after some wavelength images.
    let mut incomplete_spectrum = false;
    'rounds: for round in 0..rounds {
        let mut round_spp = 0u32;
        while round_spp < samples {
            if control.is_cancelled() {
                incomplete_spectrum = mono_scenes && (round > 0 || round_spp > 0);
                break 'rounds;
            }
            if settings.time_limit > 0.0
                && (done_spp > 0 || round_spp > 0)
                && start.elapsed().as_secs_f64() >= settings.time_limit
            {
                time_limited = true;
                incomplete_spectrum = mono_scenes;
                break 'rounds;
            }
            // Passes grow so progress stays smooth early and overhead stays low later.
            let pass = (round_spp / 4).clamp(if adaptive { 2 } else { 1 }, 16).min(samples - round_spp);
            let range = round_spp..round_spp + pass;
            if adaptive && !active.iter().any(|&a| a) {
                break 'rounds;
            }
            // Tiles of camera paths; merged after the light paths of the same pass so a
            // cancel during either discards the whole pass.
            let mut camera_tiles: Vec<Option<FilmBuffer>> = Vec::new();
            if backward {
                let sampler = |x: u32, y: u32, pixel: u64, s: u32, ps: &mut PixelSample, scratch: &mut Scratch| {
                    // Each (round, sample) pair has its own stream.
                    let mut rng = Rng::for_sample(seed, pixel, s as u64 + round as u64 * samples as u64);
                    let jitter = rng.uniform2();
                    let (fx, fy) = (x as f32 + jitter.x, y as f32 + jitter.y);
                    match settings.method {
                        Method::Polychromatic | Method::Rgb if mis => mis_camera.sample(scene, fx, fy, &mut rng, ps),
                        Method::Polychromatic | Method::Rgb => integrator.sample(scene, fx, fy, &mut rng, ps),
                        Method::MonochromaticRays => {
                            let lambda = stratified_wavelength(&lambda_dist, seed, pixel, s, samples);
                            let l = mono.sample_camera(scene, fx, fy, lambda, &mut rng, ps, scratch);
                            ps.radiance.set(lambda, l / lambda_dist.pmf(lambda));
                        }
                        Method::MonochromaticScenes => {
                            // Every wavelength gets all samples; averaging n·L over n·spp
                            // entries sums the wavelengths.
                            let l = mono.sample_camera(scene, fx, fy, round, &mut rng, ps, scratch);
                            ps.radiance.set(round, l * n as f32);
                        }
                    }
                };
                if adaptive {
                    // First half of the pass: also summed into the half buffer.
                    let mid = range.start + pass / 2;
                    let first: Vec<Option<FilmBuffer>> = tiles
                        .par_iter()
                        .map(|&t| {
                            render_tile_masked(
                                scene,
                                &sampler,
                                t,
                                range.start..mid,
                                &albedo_white,
                                settings.spectral_output,
                                control,
                                Some(&active),
                            )
                        })
                        .collect();
                    if first.iter().all(|r| r.is_some()) {
                        for (&(x0, y0, tw, _), r) in tiles.iter().zip(&first) {
                            let b = r.as_ref().expect("checked above");
                            for (t, (xyz, c)) in b.xyz.iter().zip(&b.count).enumerate() {
                                let i = ((y0 + t as u32 / tw) * w + x0 + t as u32 % tw) as usize;
                                for k in 0..3 {
                                    half_xyz[i][k] += xyz[k];
                                }
                                half_count[i] += c;
                            }
                        }
                        for (&(x0, y0, tw, th), r) in tiles.iter().zip(first) {
                            film.merge_tile(x0, y0, tw, th, &r.expect("checked above"));
                        }
                        camera_tiles = tiles
                            .par_iter()
                            .map(|&t| {
                                render_tile_masked(
                                    scene,
                                    &sampler,
                                    t,
                                    mid..range.end,
                                    &albedo_white,
                                    settings.spectral_output,
                                    control,
                                    Some(&active),
                                )
                            })
                            .collect();
                    } else {
                        camera_tiles = first;
                    }
                } else {
                    camera_tiles = tiles
                        .par_iter()
                        .map(|&t| {
                            render_tile(
                                scene,
                                &sampler,
                                t,
                                range.clone(),
                                &albedo_white,
                                settings.spectral_output,
                                control,
                            )
                        })
                        .collect();
                }
                if camera_tiles.iter().any(|r| r.is_none()) {
                    incomplete_spectrum = mono_scenes && (round > 0 || round_spp > 0);
                    break 'rounds; // cancelled mid-pass: the pass is discarded so every pixel has the same count
                }
            }
            let mut light_splats: Vec<Vec<Splat>> = Vec::new();
            if forward {
                let paths = w as u64 * h as u64 * pass as u64;
                let base = (round as u64 * samples as u64 + round_spp as u64) * w as u64 * h as u64;
                let chunks: Vec<u64> = (0..paths.div_ceil(LIGHT_CHUNK)).collect();
                let results: Vec<Option<Vec<Splat>>> = chunks
                    .par_iter()
                    .map(|&c| {
                        if control.is_cancelled() {
                            return None;
                        }
                        let mut splats = Vec::new();
                        let end = ((c + 1) * LIGHT_CHUNK).min(paths);
                        for k in c * LIGHT_CHUNK..end {
                            let mut rng = Rng::for_sample(seed ^ 0x4c49_4748_545f_5041, base + k, 0);
                            let wavelength = match settings.method {
                                Method::Polychromatic | Method::Rgb => None,
                                Method::MonochromaticRays => {
                                    let i = lambda_dist.sample(rng.uniform()).unwrap_or(0);
                                    Some((i, 1.0 / lambda_dist.pmf(i)))
                                }
                                Method::MonochromaticScenes => Some((round, n as f32)),
                            };
                            if mis {
                                mis_light.trace(scene, &mut rng, &mut splats);
                            } else {
                                light_tracer.trace(scene, &mut rng, wavelength, &mut splats);
                            }
                        }
                        control.done.fetch_add(end - c * LIGHT_CHUNK, Ordering::Relaxed);
                        Some(splats)
                    })
                    .collect();
                if results.iter().any(|r| r.is_none()) {
                    incomplete_spectrum = mono_scenes && (round > 0 || round_spp > 0);
                    break 'rounds;
                }
                light_splats = results.into_iter().flatten().collect();
            }
            for (&(x0, y0, tw, th), r) in tiles.iter().zip(camera_tiles) {
                film.merge_tile(x0, y0, tw, th, &r.expect("checked above"));
            }
            // Merged in chunk order: the same sums on any thread count.
            for splats in &light_splats {
                add_splats(&mut film, splats, &scene.observer);
            }
            if forward && !backward {
                for c in film.buffer.count.iter_mut() {
                    *c += pass;
                }
            }
            round_spp += pass;
            if round == 0 || !mono_scenes {
                done_spp += pass;
            }
            if adaptive {
                quality::update_active(
                    &mut active,
                    &mut pixel_err,
                    &half_xyz,
                    &half_count,
                    &film.buffer.xyz,
                    &film.buffer.count,
                    w,
                    h,
                    settings.noise_threshold as f64,
                    done_spp >= quality::ADAPTIVE_MIN_SAMPLES.min(samples),
                );
            }
            if control.previews_requested() && last_preview.is_none_or(|t| t.elapsed() >= PREVIEW_INTERVAL) {
                control.publish_preview(film.rgba(&scene.space), w, h, done_spp, false);
                last_preview = Some(Instant::now());
            }
        }
    }
    let stats = RenderStats {
        samples_per_pixel: done_spp,
        seconds: start.elapsed().as_secs_f64(),
        build_seconds,
        method: settings.method,
        direction: settings.direction,
        incomplete_spectrum,
        wavelengths: n,
        threads,
        nonfinite_samples: film.buffer.nonfinite,
        cancelled: control.is_cancelled(),
        time_limited,
        lights: scene.lights.len(),
        triangles: scene.meshes.iter().map(|m| m.indices.len()).sum(),
        texture_bytes: scene.texture_bytes,
        quality: settings.quality,
        auto_reason: Vec::new(),
        total_samples: film.buffer.count.iter().map(|&c| c as u64).sum(),
        noise_threshold: if adaptive { settings.noise_threshold } else { 0.0 },
        converged_pixels: if adaptive { active.iter().filter(|&&a| !a).count() as u64 } else { 0 },
        max_samples: settings.samples,
        max_bounces: settings.max_bounces,
        uplift_round_trip_error: scene.uplift.as_ref().map_or(0.0, |u| u.round_trip_error()),
    };
    let images = film.images(&scene.space);
    if control.previews_requested() {
        control.publish_preview(images.rgba.clone(), w, h, done_spp, true);
    }
    Ok(RenderOutput { width: w, height: h, images, wavelengths: scene.grid.lambdas().to_vec(), stats })
}

/// Adds light-path splats (radiance at a pixel, per light path per pixel) to the film.
fn add_splats(film: &mut Film, splats: &[Splat], observer: &crate::color::Observer) {
    for sp in splats {
        let xyz = observer.xyz(sp.radiance.values());
        if !(xyz.iter().all(|v| v.is_finite()) && sp.radiance.is_finite()) {
            film.buffer.nonfinite += 1;
            continue;
        }
        let i = sp.pixel as usize;
        for k in 0..3 {
            film.buffer.xyz[i][k] += xyz[k];
        }
        if let (Some(dst), Some(n)) = (&mut film.buffer.spectral, film.spectral_len) {
            for (d, &v) in dst[i * n..(i + 1) * n].iter_mut().zip(sp.radiance.values()) {
                *d += v as f64;
            }
        }
    }
}

/// One camera sample: (x, y, pixel index, sample index, output, scratch).
type Sampler<'a> = dyn Fn(u32, u32, u64, u32, &mut PixelSample, &mut Scratch) + Sync + 'a;

fn render_tile(
    scene: &Scene,
    sampler: &Sampler,
    tile: (u32, u32, u32, u32),
    samples: std::ops::Range<u32>,
    albedo_white: &SampledSpectrum,
    spectral: bool,
    control: &RenderControl,
) -> Option<FilmBuffer> {
    render_tile_masked(scene, sampler, tile, samples, albedo_white, spectral, control, None)
}

/// [`render_tile`] that skips the pixels whose `active` entry is false (adaptive sampling).
#[allow(clippy::too_many_arguments)]
fn render_tile_masked(
    scene: &Scene,
    sampler: &Sampler,
    (x0, y0, tw, th): (u32, u32, u32, u32),
    samples: std::ops::Range<u32>,
    albedo_white: &SampledSpectrum,
    spectral: bool,
    control: &RenderControl,
    active: Option<&[bool]>,
) -> Option<FilmBuffer> {
    let n = scene.grid.len();
    let mut buf = FilmBuffer::new((tw * th) as usize, spectral.then_some(n));
    let mut ps = PixelSample::new(n);
    let mut scratch = Scratch::new(n);
    let width = scene.camera.width() as u64;
    for ty in 0..th {
        if control.is_cancelled() {
            return None;
        }
        for tx in 0..tw {
            let (x, y) = (x0 + tx, y0 + ty);
            let pixel = y as u64 * width + x as u64;
            if active.is_some_and(|a| !a[pixel as usize]) {
                continue;
            }
            for s in samples.clone() {
                ps.reset();
                sampler(x, y, pixel, s, &mut ps, &mut scratch);
                buf.add((ty * tw + tx) as usize, &ps, &scene.observer, albedo_white);
            }
        }
        control.done.fetch_add(tw as u64 * samples.len() as u64, Ordering::Relaxed);
    }
    Some(buf)
}
