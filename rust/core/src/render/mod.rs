//! The render driver: compiles the scene for the settings' grid, then renders passes of
//! samples over tiles in parallel (rayon) until the sample count, the time limit or a
//! cancel request ends it. Every pixel sample draws from its own random stream seeded by
//! (seed, pixel, sample index), so the image does not depend on the thread count.

use crate::color::uplift::UpliftMethod;
use crate::color::RgbSpace;
use crate::film::{Film, FilmBuffer, FilmImages, PixelSample};
use crate::integrator::path::PathTracer;
use crate::integrator::Integrator;
use crate::sampling::Rng;
use crate::scene::{Buffer, BuildOptions, Scene, SceneDesc};
use crate::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};
use crate::spectrum::named::{SpectrumKind, SpectrumRole};
use crate::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Method {
    /// Whole-spectrum rays (the paper's method 3).
    #[default]
    Polychromatic,
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
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 64,
            height: 64,
            samples: 16,
            method: Method::Polychromatic,
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
        }
    }
}

impl RenderSettings {
    pub fn grid(&self) -> Result<WavelengthGrid> {
        match &self.wavelengths {
            Some(l) => WavelengthGrid::from_wavelengths(l.clone()),
            None => WavelengthGrid::uniform(self.wavelength_count, self.wavelength_min, self.wavelength_max),
        }
    }

    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 || self.width > 65536 || self.height > 65536 {
            return Err(Error::setting("width", format!("image size {}×{} must be 1..65536 on each side", self.width, self.height)));
        }
        if self.samples == 0 {
            return Err(Error::setting("samples", "must be at least 1"));
        }
        if !(self.time_limit.is_finite() && self.time_limit >= 0.0) {
            return Err(Error::setting("time_limit", format!("{} s must be 0 (none) or positive", self.time_limit)));
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
}

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
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    pub samples_per_pixel: u32,
    pub seconds: f64,
    pub build_seconds: f64,
    pub method: Method,
    pub wavelengths: usize,
    pub threads: usize,
    /// Samples dropped because their value was NaN or infinite.
    pub nonfinite_samples: u64,
    pub cancelled: bool,
    pub time_limited: bool,
    pub lights: usize,
    pub triangles: usize,
}

pub struct RenderOutput {
    pub width: u32,
    pub height: u32,
    pub images: FilmImages,
    pub wavelengths: Vec<f32>,
    pub stats: RenderStats,
}

const TILE: u32 = 16;

/// Renders a scene description. Cancelling returns the samples finished so far.
pub fn render(desc: &SceneDesc, buffers: &[Buffer], settings: &RenderSettings, control: &RenderControl) -> Result<RenderOutput> {
    settings.validate()?;
    let grid = settings.grid()?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::setting("threads", e.to_string()))?;
    let threads = pool.current_num_threads();
    pool.install(|| render_in_pool(desc, buffers, settings, grid, control, threads))
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
    let opts = BuildOptions { grid, space: RgbSpace::rec709(), uplift: settings.uplift, width: settings.width, height: settings.height };
    let scene = Scene::build(desc, buffers, &opts)?;
    let build_seconds = start.elapsed().as_secs_f64();
    let n = scene.grid.len();
    let (w, h) = (settings.width, settings.height);
    control.total.store(w as u64 * h as u64 * settings.samples as u64, Ordering::Relaxed);
    control.done.store(0, Ordering::Relaxed);

    // A reflectance of 1 under D65 of luminance 1 reads as albedo (1,1,1).
    let d65 = SpectrumDesc::new(SpectrumKind::D65).evaluate(&scene.grid, SpectrumRole::Illuminant, &scene.uplift).map_err(|e| Error::Description(e))?;
    let mut albedo_white = SampledSpectrum::from_slice(&d65);
    albedo_white.scale(1.0 / scene.observer.xyz(&d65)[1] as f32);

    let integrator = PathTracer { max_bounces: settings.max_bounces, ..Default::default() };
    let tiles: Vec<(u32, u32, u32, u32)> = (0..h.div_ceil(TILE))
        .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .map(|(x0, y0)| (x0, y0, TILE.min(w - x0), TILE.min(h - y0)))
        .collect();
    let mut film = Film::new(w, h, settings.spectral_output.then_some(n));
    let mut done_spp = 0u32;
    let mut time_limited = false;
    while done_spp < settings.samples && !control.is_cancelled() {
        if settings.time_limit > 0.0 && done_spp > 0 && start.elapsed().as_secs_f64() >= settings.time_limit {
            time_limited = true;
            break;
        }
        // Passes grow so progress stays smooth early and overhead stays low later.
        let pass = (done_spp / 4).clamp(1, 16).min(settings.samples - done_spp);
        let results: Vec<Option<FilmBuffer>> = tiles
            .par_iter()
            .map(|&(x0, y0, tw, th)| {
                render_tile(&scene, &integrator, settings.seed, (x0, y0, tw, th), done_spp..done_spp + pass, &albedo_white, settings.spectral_output, control)
            })
            .collect();
        if results.iter().any(|r| r.is_none()) {
            break; // cancelled mid-pass: the pass is discarded so every pixel has the same count
        }
        for (&(x0, y0, tw, th), r) in tiles.iter().zip(results) {
            film.merge_tile(x0, y0, tw, th, &r.expect("checked above"));
        }
        done_spp += pass;
    }
    let stats = RenderStats {
        samples_per_pixel: done_spp,
        seconds: start.elapsed().as_secs_f64(),
        build_seconds,
        method: settings.method,
        wavelengths: n,
        threads,
        nonfinite_samples: film.buffer.nonfinite,
        cancelled: control.is_cancelled(),
        time_limited,
        lights: scene.lights.len(),
        triangles: scene.meshes.iter().map(|m| m.indices.len()).sum(),
    };
    Ok(RenderOutput { width: w, height: h, images: film.images(&scene.space), wavelengths: scene.grid.lambdas().to_vec(), stats })
}

fn render_tile(
    scene: &Scene,
    integrator: &dyn Integrator,
    seed: u64,
    (x0, y0, tw, th): (u32, u32, u32, u32),
    samples: std::ops::Range<u32>,
    albedo_white: &SampledSpectrum,
    spectral: bool,
    control: &RenderControl,
) -> Option<FilmBuffer> {
    let n = scene.grid.len();
    let mut buf = FilmBuffer::new((tw * th) as usize, spectral.then_some(n));
    let mut ps = PixelSample::new(n);
    let width = scene.camera.width() as u64;
    for ty in 0..th {
        if control.is_cancelled() {
            return None;
        }
        for tx in 0..tw {
            let (x, y) = (x0 + tx, y0 + ty);
            let pixel = y as u64 * width + x as u64;
            for s in samples.clone() {
                let mut rng = Rng::for_sample(seed, pixel, s as u64);
                let jitter = rng.uniform2();
                ps.reset();
                integrator.sample(scene, x as f32 + jitter.x, y as f32 + jitter.y, &mut rng, &mut ps);
                buf.add((ty * tw + tx) as usize, &ps, &scene.observer, albedo_white);
            }
        }
        control.done.fetch_add(tw as u64 * samples.len() as u64, Ordering::Relaxed);
    }
    Some(buf)
}

