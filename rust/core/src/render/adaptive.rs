//! Adaptive sampling: a pixel stops once the estimated CIELAB difference of its mean
//! from the converged value is within `noise_threshold` (ΔE00). Each pass's samples are
//! split into two halves; the first halves' sums per pixel and the film's sums give the
//! error estimate ([`pixel_error`]).

use super::{Direction, Method, ResolvedSettings};
use crate::color::delta_e::{de2000, lab};
use crate::film::FilmBuffer;

/// Samples a pixel takes before the adaptive test may stop it.
pub const ADAPTIVE_MIN_SAMPLES: u32 = 16;

/// Whether adaptive sampling applies: camera paths only (light paths are not per pixel),
/// and not image-per-wavelength rendering.
pub fn adaptive_supported(method: Method, direction: Direction) -> bool {
    direction == Direction::Backward && method != Method::MonochromaticScenes
}

/// What [`Adaptive`] keeps between groups of passes, per pixel (row-major): saved in a
/// checkpoint and restored on resume ([`Adaptive::restore`]).
#[derive(Clone, Debug)]
pub struct AdaptiveState {
    pub active: Vec<bool>,
    pub half_xyz: Vec<[f64; 3]>,
    pub half_count: Vec<u32>,
    /// The last error estimate (kept for stopped pixels: their neighbours' test reads it).
    pub err: Vec<f64>,
}

/// The adaptive state of a render: which pixels still take samples, and the sums their
/// error estimate needs.
pub struct Adaptive {
    threshold: f64,
    /// Samples per pixel before any pixel may stop.
    min_samples: u32,
    width: u32,
    height: u32,
    active: Vec<bool>,
    half_xyz: Vec<[f64; 3]>,
    half_count: Vec<u32>,
    err: Vec<f64>,
    /// Pixels outside the render region (inactive throughout, not converged).
    outside: u64,
}

impl Adaptive {
    /// The state for `settings` (its noise threshold, image size and sample count), or
    /// None when adaptive sampling is off or does not apply.
    pub fn new(settings: &ResolvedSettings) -> Option<Self> {
        if !(settings.noise_threshold > 0.0 && adaptive_supported(settings.method, settings.direction)) {
            return None;
        }
        let pixels = (settings.width * settings.height) as usize;
        // Pixels outside the render region take no samples from the start.
        let [x0, y0, x1, y1] = settings.region_rect();
        let active: Vec<bool> = (0..pixels as u32)
            .map(|i| (x0..x1).contains(&(i % settings.width)) && (y0..y1).contains(&(i / settings.width)))
            .collect();
        let outside = active.iter().filter(|&&a| !a).count() as u64;
        let err = active.iter().map(|&a| if a { f64::INFINITY } else { f64::NAN }).collect();
        Some(Self {
            outside,
            threshold: settings.noise_threshold as f64,
            min_samples: ADAPTIVE_MIN_SAMPLES.min(settings.samples),
            width: settings.width,
            height: settings.height,
            active,
            half_xyz: vec![[0.0; 3]; pixels],
            half_count: vec![0; pixels],
            err,
        })
    }
    /// Per pixel (row-major): still taking samples.
    pub fn active(&self) -> &[bool] {
        &self.active
    }
    pub fn any_active(&self) -> bool {
        self.active.iter().any(|&a| a)
    }
    /// Pixels that reached the target.
    pub fn converged_pixels(&self) -> u64 {
        self.active.iter().filter(|&&a| !a).count() as u64 - self.outside
    }
    /// A copy of the per-pixel state (for a checkpoint).
    pub fn state(&self) -> AdaptiveState {
        AdaptiveState {
            active: self.active.clone(),
            half_xyz: self.half_xyz.clone(),
            half_count: self.half_count.clone(),
            err: self.err.clone(),
        }
    }
    /// Replaces the per-pixel state with a saved one of the same image; the error names
    /// the array whose size does not match.
    pub fn restore(&mut self, s: AdaptiveState) -> Result<(), String> {
        let n = self.active.len();
        for (name, len) in [
            ("active", s.active.len()),
            ("half_xyz", s.half_xyz.len()),
            ("half_count", s.half_count.len()),
            ("err", s.err.len()),
        ] {
            if len != n {
                return Err(format!("adaptive '{name}' has {len} pixels, expected {n}"));
            }
        }
        (self.active, self.half_xyz, self.half_count, self.err) = (s.active, s.half_xyz, s.half_count, s.err);
        Ok(())
    }
    /// Adds pixel `i`'s sums of the first half of a pass.
    pub fn add_first_half(&mut self, i: usize, xyz: &[f64; 3], count: u32) {
        for k in 0..3 {
            self.half_xyz[i][k] += xyz[k];
        }
        self.half_count[i] += count;
    }
    /// After a pass (both halves in `film`, `samples_done` per pixel so far): refreshes
    /// the estimates and stops the pixels that reached the target.
    pub fn update(&mut self, film: &FilmBuffer, samples_done: u32) {
        update_active(
            &mut self.active,
            &mut self.err,
            &self.half_xyz,
            &self.half_count,
            &film.xyz,
            &film.count,
            self.width,
            self.height,
            self.threshold,
            samples_done >= self.min_samples,
        );
    }
}

/// Estimated ΔE00 of a pixel's mean from its converged value, from the sums of its
/// first half of samples `a` (count `na`) and of all samples `all` (count `n`): the two
/// halves' means differ by twice the full mean's error in distribution (A − B has 4× the
/// variance of the mean), so half their CIEDE2000 difference is one draw of the pixel's
/// error. CIELAB uses a D65 white of Y = 1, as `polychrome.colordiff.image_delta_e`.
pub fn pixel_error(a: [f64; 3], na: u32, all: [f64; 3], n: u32) -> f64 {
    if na == 0 || n <= na {
        return f64::INFINITY;
    }
    let ma = a.map(|v| v / na as f64);
    let mb = [0, 1, 2].map(|k| (all[k] - a[k]) / (n - na) as f64);
    let e = 0.5 * de2000(lab(ma), lab(mb));
    if e.is_finite() {
        e
    } else {
        f64::INFINITY
    }
}

/// After a pass: refreshes the error estimate of every active pixel and stops those
/// whose 3×3 neighbourhood's mean estimate is within `threshold` and whose own is within
/// twice it (one estimate is a single noisy draw; the neighbourhood averages nine). `ready`: enough samples for a decision.
#[allow(clippy::too_many_arguments)]
pub fn update_active(
    active: &mut [bool],
    err: &mut [f64],
    half: &[[f64; 3]],
    half_count: &[u32],
    all: &[[f64; 3]],
    count: &[u32],
    w: u32,
    h: u32,
    threshold: f64,
    ready: bool,
) {
    for i in 0..active.len() {
        if active[i] {
            err[i] = pixel_error(half[i], half_count[i], all[i], count[i]);
        }
    }
    if !ready {
        return;
    }
    let (w, h) = (w as i64, h as i64);
    let stop: Vec<usize> = (0..active.len())
        .filter(|&i| active[i])
        .filter(|&i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            let (mut sum, mut k) = (0.0f64, 0u32);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    // NaN: outside the render region, like outside the image.
                    if nx >= 0 && ny >= 0 && nx < w && ny < h && !err[(ny * w + nx) as usize].is_nan() {
                        sum += err[(ny * w + nx) as usize];
                        k += 1;
                    }
                }
            }
            sum / k as f64 <= threshold && err[i] <= 2.0 * threshold
        })
        .collect();
    for i in stop {
        active[i] = false;
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_error_is_half_the_halves_difference() {
        let x = [0.2, 0.3, 0.25];
        assert_eq!(pixel_error([0.2, 0.3, 0.25], 1, [0.4, 0.6, 0.5], 2), 0.0);
        let e = pixel_error(x, 1, [0.4, 0.62, 0.5], 2);
        let expected = 0.5 * de2000(lab(x), lab([0.2, 0.32, 0.25]));
        assert!((e - expected).abs() < 1e-12 && e > 0.0);
        assert!(pixel_error(x, 0, x, 0).is_infinite());
    }
}
