//! The pass loop: renders sample passes over tiles in parallel (rayon) until the sample
//! count, the time limit, adaptive convergence or a cancel request ends it.
//!
//! Sample passes are numbered `0 .. rounds × samples` ([`Integrator::rounds`]): pass `g`
//! is the g-th sample of every pixel, and its light paths are numbered
//! `g·pixels .. (g+1)·pixels`. Every pixel sample draws the numbers of (seed, pixel, g)
//! (SOBOL: point g of the pixel's scrambled sequence, `sampling::Sobol`), every light
//! path from a PCG stream seeded by (seed, its number),
//! so an image depends neither on the thread count nor on how the passes are grouped:
//! [`Driver::render_passes`] renders any range of passes into sums that add up
//! exactly to the sums of the whole render (up to float rounding of the additions).

use super::adaptive::Adaptive;
use super::{RenderControl, RenderOutput, RenderStats, ResolvedSettings, PREVIEW_INTERVAL};
use crate::film::{Film, FilmBuffer, PixelSample, PixelSums};
use crate::integrator::forward::Splat;
use crate::integrator::{self, CameraSample, Integrator, Scratch};
use crate::sampling::{mix64, Rng, Sampler, Strata};
use crate::scene::Scene;
use crate::spectrum::named;
use crate::spectrum::SampledSpectrum;
use crate::{Error, Result};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Tile side in pixels: the parallel work item of camera paths.
const TILE: u32 = 16;
/// Light paths per parallel work item (fixed, so the image does not depend on the thread
/// count).
const LIGHT_CHUNK: u64 = 1024;
/// Seeds light-path streams apart from the camera streams of the same seed.
const LIGHT_STREAM: u64 = 0x4c49_4748_545f_5041;
/// Salt of a pixel's stratified set of samples (`Scratch::strata`).
const PIXEL_STRATA: u64 = 0x5354_5241_5441_5f50;

/// A rectangle of pixels: (x0, y0, width, height).
#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
}

/// Renders one compiled scene with one set of resolved settings.
pub struct Driver<'a> {
    scene: &'a Scene,
    settings: &'a ResolvedSettings,
    integrator: Integrator,
    tiles: Vec<Tile>,
    /// A reflectance of 1 under D65 of luminance 1: makes the albedo pass read as a colour.
    albedo_white: SampledSpectrum,
}

/// What a range of sample passes adds to the image: camera tiles and light splats, kept
/// apart until [`PassSums::add_to`] adds them in one fixed order.
pub struct PassSums {
    tiles: Vec<(Tile, FilmBuffer)>,
    /// Splats of each light chunk, in chunk order.
    splats: Vec<Vec<Splat>>,
    /// Light paths only (FORWARD): every pixel counts one sample per pass.
    light_only_passes: Option<u32>,
}

impl PassSums {
    /// Adds the sums to `film` (tiles in order, then the splats in chunk order: the same
    /// sums on any thread count).
    pub fn add_to(&self, film: &mut Film, scene: &Scene) {
        for (t, b) in &self.tiles {
            film.merge_tile(t.x0, t.y0, t.w, t.h, b);
        }
        for splats in &self.splats {
            for sp in splats {
                film.buffer.add_light(sp.pixel as usize, &sp.radiance, &scene.observer);
            }
        }
        if let Some(p) = self.light_only_passes {
            for c in film.buffer.count.iter_mut() {
                *c += p;
            }
        }
    }

    /// Every pixel's camera-sample sums: (pixel index, XYZ sum, sample count).
    fn camera_pixels(&self, width: u32) -> impl Iterator<Item = (usize, &[f64; 3], u32)> {
        self.tiles.iter().flat_map(move |(t, b)| {
            b.xyz.iter().zip(&b.count).enumerate().map(move |(k, (xyz, &c))| {
                let (tx, ty) = (k as u32 % t.w, k as u32 / t.w);
                (((t.y0 + ty) * width + t.x0 + tx) as usize, xyz, c)
            })
        })
    }
}

/// How the pass loop ended.
#[derive(Clone, Copy, Debug, Default)]
pub struct PassesDone {
    /// Sample passes finished (and merged), counted from pass 0.
    pub passes: u32,
    /// The time limit stopped the render before its last pass.
    pub time_limited: bool,
    /// Adaptive sampling: pixels that reached the target (None: adaptive off).
    pub converged_pixels: Option<u64>,
}

impl<'a> Driver<'a> {
    /// A driver for `scene` (built for `settings`) with resolved `settings`; errors name
    /// a setting the scene cannot be rendered with.
    pub fn new(scene: &'a Scene, settings: &'a ResolvedSettings) -> Result<Self> {
        let integrator = integrator::from_settings(scene, settings)?;
        // Tiles cover the render region only: pixels outside it are never sampled.
        let [rx0, ry0, rx1, ry1] = settings.region_rect();
        let (w, h) = (rx1 - rx0, ry1 - ry0);
        let tiles = (0..h.div_ceil(TILE))
            .flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
            .map(|(x0, y0)| Tile { x0: rx0 + x0, y0: ry0 + y0, w: TILE.min(w - x0), h: TILE.min(h - y0) })
            .collect();
        let d65 = named::d65(&scene.grid).map_err(Error::Description)?;
        let mut albedo_white = SampledSpectrum::from_slice(&d65);
        albedo_white.scale(1.0 / scene.observer.xyz(&d65)[1] as f32);
        Ok(Self { scene, settings, integrator, tiles, albedo_white })
    }

    /// Sample passes of the whole render: `rounds × samples`.
    pub fn sample_passes(&self) -> u32 {
        self.integrator.rounds * self.settings.samples
    }

    /// The resolved settings this driver renders with.
    pub fn settings(&self) -> &ResolvedSettings {
        self.settings
    }

    /// Whether adaptive sampling applies to this render.
    pub fn adaptive(&self) -> bool {
        let s = self.settings;
        s.noise_threshold > 0.0 && super::adaptive::adaptive_supported(s.method, s.direction)
    }

    /// The groups of passes of the pass loop, in order (see [`super::tasks::Merge`]).
    pub fn groups(&self) -> Vec<Range<u32>> {
        self.schedule(self.adaptive()).collect()
    }

    /// An empty film for this render's image.
    pub fn new_film(&self) -> Film {
        let n = self.scene.grid.len();
        Film::new(self.settings.width, self.settings.height, self.settings.spectral_output.then_some(n))
    }

    /// Renders sample passes `passes` (a sub-range of `0..sample_passes()`) of the pixels
    /// whose `active` entry is true (all when None) into per-pixel sums, which merge with
    /// other ranges' sums by addition ([`FilmBuffer::merge`]). None when `control` was
    /// cancelled meanwhile. For distributed rendering: each worker renders its ranges,
    /// the client adds the sums and calls [`Driver::output`].
    pub fn render_passes(
        &self,
        passes: Range<u32>,
        active: Option<&[bool]>,
        control: &RenderControl,
    ) -> Option<FilmBuffer> {
        let sums = self.trace(passes, active, control)?;
        let mut film = self.new_film();
        sums.add_to(&mut film, self.scene);
        Some(film.buffer)
    }

    /// Whether a task may cover a rectangle of the image ([`Driver::render_rect`]):
    /// camera paths only, since a light path may land on any pixel.
    pub fn tileable(&self) -> bool {
        self.integrator.camera_paths && !self.integrator.light_paths
    }

    /// Renders sample passes `passes` of the pixels of `rect` (`[x0, y0, x1, y1)`, inside
    /// the image) that lie in the render region and are `active` (all when None) into
    /// sums of the rectangle's pixels (row-major in it). Every pixel sample has its own
    /// random stream, so the sums equal those pixels' sums of [`Driver::render_passes`]
    /// exactly. Only for [`Driver::tileable`] renders; None when cancelled.
    pub fn render_rect(
        &self,
        passes: Range<u32>,
        active: Option<&[bool]>,
        rect: [u32; 4],
        control: &RenderControl,
    ) -> Option<FilmBuffer> {
        assert!(self.tileable(), "render_rect with light paths");
        let [x0, y0, x1, y1] = rect;
        let [rx0, ry0, rx1, ry1] = self.settings.region_rect();
        let (cx0, cy0, cx1, cy1) = (x0.max(rx0), y0.max(ry0), x1.min(rx1), y1.min(ry1));
        let mut tiles = Vec::new();
        let mut y = cy0;
        while y < cy1 {
            let mut x = cx0;
            while x < cx1 {
                tiles.push(Tile { x0: x, y0: y, w: TILE.min(cx1 - x), h: TILE.min(cy1 - y) });
                x += TILE;
            }
            y += TILE;
        }
        let bufs: Vec<Option<FilmBuffer>> =
            tiles.par_iter().map(|&t| self.render_tile(t, passes.clone(), active, control)).collect();
        let n = self.scene.grid.len();
        let mut film = Film::new(x1 - x0, y1 - y0, self.settings.spectral_output.then_some(n));
        for (t, b) in tiles.iter().zip(bufs) {
            film.merge_tile(t.x0 - x0, t.y0 - y0, t.w, t.h, &b?);
        }
        Some(film.buffer)
    }

    /// Camera tiles and light paths of sample passes `passes`; None when cancelled.
    pub fn trace(&self, passes: Range<u32>, active: Option<&[bool]>, control: &RenderControl) -> Option<PassSums> {
        let tiles = if self.integrator.camera_paths {
            let tiles: Vec<Option<FilmBuffer>> =
                self.tiles.par_iter().map(|&t| self.render_tile(t, passes.clone(), active, control)).collect();
            tiles.into_iter().zip(&self.tiles).map(|(b, &t)| b.map(|b| (t, b))).collect::<Option<Vec<_>>>()?
        } else {
            Vec::new()
        };
        let splats = if self.integrator.light_paths { self.light_paths(passes.clone(), control)? } else { Vec::new() };
        let light_only_passes = (!self.integrator.camera_paths).then_some(passes.len() as u32);
        Some(PassSums { tiles, splats, light_only_passes })
    }

    /// The pass loop: renders every sample pass (or until cancelled, the time limit or
    /// adaptive convergence) into a film, publishing previews on the way.
    pub fn run(&self, control: &RenderControl, start: Instant) -> (Film, PassesDone) {
        let s = self.settings;
        let (w, h) = (s.width, s.height);
        let [rx0, ry0, rx1, ry1] = s.region_rect();
        let region_pixels = (rx1 - rx0) as u64 * (ry1 - ry0) as u64;
        let per_round = s.samples as u64
            * (self.integrator.camera_paths as u64 * region_pixels
                + self.integrator.light_paths as u64 * w as u64 * h as u64);
        control.total.store(per_round * self.integrator.rounds as u64, Ordering::Relaxed);
        control.done.store(0, Ordering::Relaxed);
        let mut film = self.new_film();
        let mut adaptive = Adaptive::new(s);
        let mut done = PassesDone::default();
        let mut last_preview: Option<Instant> = None;
        for passes in self.schedule(adaptive.is_some()) {
            if control.is_cancelled() {
                break;
            }
            if s.time_limit > 0.0 && done.passes > 0 && start.elapsed().as_secs_f64() >= s.time_limit {
                done.time_limited = true;
                break;
            }
            let merged = match &mut adaptive {
                None => self.trace(passes.clone(), None, control).map(|p| p.add_to(&mut film, self.scene)),
                Some(a) if !a.any_active() => break,
                Some(a) => self.adaptive_pass(passes.clone(), a, &mut film, control),
            };
            if merged.is_none() {
                break; // cancelled mid-pass: the pass is discarded so every pixel has whole passes
            }
            done.passes += passes.len() as u32;
            if let Some(a) = &mut adaptive {
                a.update(&film.buffer, self.samples_per_pixel(done.passes));
            }
            if control.previews_requested() && last_preview.is_none_or(|t| t.elapsed() >= PREVIEW_INTERVAL) {
                let spp = self.samples_per_pixel(done.passes);
                let mut rgba = film.rgba(&self.scene.space);
                self.clear_outside_region(&mut rgba);
                control.publish_preview(rgba, w, h, spp, false);
                last_preview = Some(Instant::now());
            }
        }
        done.converged_pixels = adaptive.map(|a| a.converged_pixels());
        (film, done)
    }

    /// The images and stats of a film that holds sample passes `0..done.passes` (in any
    /// grouping); publishes the final preview when previews were requested.
    pub fn output(&self, film: &Film, done: PassesDone, control: &RenderControl, timing: Timing) -> RenderOutput {
        let s = self.settings;
        let scene = self.scene;
        let spp = self.samples_per_pixel(done.passes);
        let stats = RenderStats {
            samples_per_pixel: spp,
            seconds: timing.start.elapsed().as_secs_f64(),
            build_seconds: timing.build_seconds,
            method: s.method,
            direction: s.direction,
            // MONOCHROMATIC_SCENES stopped (cancel, time limit) after some wavelength images.
            incomplete_spectrum: self.integrator.rounds > 1 && done.passes > 0 && done.passes < self.sample_passes(),
            wavelengths: scene.grid.len(),
            threads: timing.threads,
            nonfinite_samples: film.buffer.nonfinite,
            cancelled: control.is_cancelled(),
            time_limited: done.time_limited,
            lights: scene.lights.len(),
            triangles: scene.meshes.iter().map(|m| m.indices.len()).sum(),
            texture_bytes: scene.texture_bytes,
            quality: s.quality,
            auto_reason: Vec::new(),
            total_samples: film.buffer.count.iter().map(|&c| c as u64).sum(),
            noise_threshold: if done.converged_pixels.is_some() { s.noise_threshold } else { 0.0 },
            converged_pixels: done.converged_pixels.unwrap_or(0),
            max_samples: s.samples,
            max_bounces: s.max_bounces,
            uplift_round_trip_error: scene.uplift.as_ref().map_or(0.0, |u| u.round_trip_error()),
            warnings: self.warnings(),
        };
        let mut images = film.images(&scene.space);
        self.clear_outside_region(&mut images.rgba);
        if control.previews_requested() {
            control.publish_preview(images.rgba.clone(), s.width, s.height, spp, true);
        }
        RenderOutput { width: s.width, height: s.height, images, wavelengths: scene.grid.lambdas().to_vec(), stats }
    }

    /// What this render leaves out of the scene (motion blur with light paths).
    fn warnings(&self) -> Vec<String> {
        let scene = self.scene;
        let mut out = scene.warnings.clone();
        if self.settings.direction == super::Direction::Forward {
            for name in &scene.moving_emitters {
                out.push(format!(
                    "instance '{name}': an emitter that deforms or changes scale over the shutter is not a light \
                     that light paths start from, so FORWARD renders without its light (BACKWARD and \
                     BIDIRECTIONAL see it)"
                ));
            }
        }
        if self.integrator.light_paths && scene.camera.has_rolling_shutter() {
            out.push(format!(
                "camera '{}': light paths ignore the rolling shutter (they take times from the whole shutter)",
                scene.camera.name()
            ));
        }
        out
    }

    /// Outside the render region nothing was rendered: black with alpha 0.
    fn clear_outside_region(&self, rgba: &mut [f32]) {
        let [x0, y0, x1, y1] = self.settings.region_rect();
        if [x0, y0, x1, y1] == [0, 0, self.settings.width, self.settings.height] {
            return;
        }
        let w = self.settings.width;
        for (i, px) in rgba.chunks_exact_mut(4).enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            if !((x0..x1).contains(&x) && (y0..y1).contains(&y)) {
                px.fill(0.0);
            }
        }
    }

    /// Samples per pixel after `passes` sample passes: every pass counts, except that the
    /// rounds of MONOCHROMATIC_SCENES repeat the same samples for other wavelengths.
    pub fn samples_per_pixel(&self, passes: u32) -> u32 {
        if self.integrator.rounds > 1 {
            passes.min(self.settings.samples)
        } else {
            passes
        }
    }

    /// The passes in rendering order, grouped so progress stays smooth early and the
    /// overhead per group stays low later (adaptive sampling: at least two, for the two
    /// halves of its error estimate). Groups never straddle two rounds.
    fn schedule(&self, adaptive: bool) -> impl Iterator<Item = Range<u32>> {
        let samples = self.settings.samples;
        let least = if adaptive { 2 } else { 1 };
        (0..self.integrator.rounds).flat_map(move |round| {
            let mut s = 0u32;
            std::iter::from_fn(move || {
                (s < samples).then(|| {
                    let n = (s / 4).clamp(least, 16).min(samples - s);
                    let g = round * samples + s;
                    s += n;
                    g..g + n
                })
            })
        })
    }

    /// One adaptive pass: its first half is also summed for the error estimate; both
    /// halves sample the pixels active at the start of the pass.
    fn adaptive_pass(
        &self,
        passes: Range<u32>,
        adaptive: &mut Adaptive,
        film: &mut Film,
        control: &RenderControl,
    ) -> Option<()> {
        let mid = passes.start + passes.len() as u32 / 2;
        let first = self.trace(passes.start..mid, Some(adaptive.active()), control)?;
        let second = self.trace(mid..passes.end, Some(adaptive.active()), control)?;
        for (i, xyz, count) in first.camera_pixels(self.settings.width) {
            adaptive.add_first_half(i, xyz, count);
        }
        first.add_to(film, self.scene);
        second.add_to(film, self.scene);
        Some(())
    }

    /// Camera samples of `passes` for one tile, skipping inactive pixels; None when
    /// cancelled.
    fn render_tile(
        &self,
        tile: Tile,
        passes: Range<u32>,
        active: Option<&[bool]>,
        control: &RenderControl,
    ) -> Option<FilmBuffer> {
        let scene = self.scene;
        let n = scene.grid.len();
        let mut buf = FilmBuffer::new((tile.w * tile.h) as usize, self.settings.spectral_output.then_some(n));
        let mut ps = PixelSample::new(n);
        let mut sums = PixelSums::new(&scene.observer, &self.albedo_white);
        let mut scratch = Scratch::new(n);
        let width = scene.camera.width() as u64;
        for ty in 0..tile.h {
            if control.is_cancelled() {
                return None;
            }
            for tx in 0..tile.w {
                let (x, y) = (tile.x0 + tx, tile.y0 + ty);
                let pixel = y as u64 * width + x as u64;
                if active.is_some_and(|a| !a[pixel as usize]) {
                    continue;
                }
                for g in passes.clone() {
                    ps.reset();
                    let mut rng = Rng::for_sampler(self.settings.sampler, self.settings.seed, pixel, g as u64);
                    scratch.strata = Some(Strata::new(mix64(self.settings.seed ^ mix64(pixel ^ PIXEL_STRATA)), g));
                    let jitter = rng.uniform2();
                    let film = glam::Vec2::new(x as f32 + jitter.x, y as f32 + jitter.y);
                    let cs = CameraSample { film, pixel, row: y, pass: g };
                    self.integrator.technique.camera_sample(scene, cs, &mut rng, &mut ps, &mut scratch);
                    sums.add(&ps);
                }
                // The pixel's samples of these passes, folded to XYZ once.
                sums.fold_into(&mut buf, (ty * tile.w + tx) as usize);
            }
            control.done.fetch_add(tile.w as u64 * passes.len() as u64, Ordering::Relaxed);
        }
        Some(buf)
    }

    /// The light paths of `passes`, one per pixel per pass, in fixed chunks; the splats
    /// of each chunk in chunk order. None when cancelled.
    fn light_paths(&self, passes: Range<u32>, control: &RenderControl) -> Option<Vec<Vec<Splat>>> {
        let pixels = self.settings.width as u64 * self.settings.height as u64;
        let first = passes.start as u64 * pixels;
        let count = passes.len() as u64 * pixels;
        let chunks: Vec<u64> = (0..count.div_ceil(LIGHT_CHUNK)).collect();
        chunks
            .par_iter()
            .map(|&c| {
                if control.is_cancelled() {
                    return None;
                }
                let mut splats = Vec::new();
                let mut scratch = Scratch::new(self.scene.grid.len());
                let end = ((c + 1) * LIGHT_CHUNK).min(count);
                for k in c * LIGHT_CHUNK..end {
                    let path = first + k;
                    let mut rng = Rng::for_sampler(Sampler::Independent, self.settings.seed ^ LIGHT_STREAM, path, 0);
                    // A pass's light paths are one stratified set (COLLAPSE STRATIFIED).
                    let key = mix64(self.settings.seed ^ LIGHT_STREAM ^ mix64(path / pixels));
                    scratch.strata = Some(Strata::new(key, (path % pixels) as u32));
                    self.integrator.technique.light_path(
                        self.scene,
                        (path / pixels) as u32,
                        &mut rng,
                        &mut splats,
                        &mut scratch,
                    );
                }
                if self.settings.region.is_some() {
                    // Light paths reach the whole image; only the region is kept.
                    let [x0, y0, x1, y1] = self.settings.region_rect();
                    let w = self.settings.width;
                    splats.retain(|sp| {
                        let (x, y) = (sp.pixel % w, sp.pixel / w);
                        (x0..x1).contains(&x) && (y0..y1).contains(&y)
                    });
                }
                control.done.fetch_add(end - c * LIGHT_CHUNK, Ordering::Relaxed);
                Some(splats)
            })
            .collect()
    }
}

/// When the render started and what it ran on, for the stats.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    pub start: Instant,
    pub build_seconds: f64,
    pub threads: usize,
}
