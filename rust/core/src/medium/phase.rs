//! Phase functions: the angular distribution of light scattered in a medium. Directions
//! follow the propagation convention: `cos θ` is between the incoming travel direction
//! and the outgoing one (forward scattering: cos θ = 1).

use crate::geometry::Frame;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Henyey & Greenstein 1941, with Cycles' isotropic cutoff |g| < 1e-3
/// (`phase_henyey_greenstein`, intern/cycles/kernel/closure/volume_util.h).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    pub g: f32,
}

impl HenyeyGreenstein {
    /// Asymmetry g, clamped to (−1, 1).
    pub fn new(g: f32) -> Self {
        Self { g: if g.is_finite() { g.clamp(-0.999, 0.999) } else { 0.0 } }
    }
    /// Density per steradian at `cos θ`.
    pub fn eval(&self, cos: f32) -> f32 {
        let g = self.g;
        if g.abs() < 1e-3 {
            return 0.25 / PI;
        }
        let fac = 1.0 + g * (g - 2.0 * cos);
        (1.0 - g * g) / (4.0 * PI * fac * fac.max(0.0).sqrt())
    }
    /// A cosine distributed as [`Self::eval`] (inverse CDF).
    pub fn sample_cos(&self, u: f32) -> f32 {
        let g = self.g;
        let mut c = 1.0 - 2.0 * u;
        if g.abs() >= 1e-3 {
            let k = (1.0 - g * g) / (1.0 - g * c);
            c = (1.0 + g * g - k * k) / (2.0 * g);
        }
        c.clamp(-1.0, 1.0)
    }
    /// A new travel direction around `d` (unit) and its pdf.
    pub fn sample(&self, d: Vec3A, u: Vec2) -> (Vec3A, f32) {
        let c = self.sample_cos(u.x);
        (around(d, c, u.y), self.eval(c))
    }
}

/// The direction at cosine `cos` from `d` and azimuth 2π·`u`.
pub fn around(d: Vec3A, cos: f32, u: f32) -> Vec3A {
    let s = (1.0 - cos * cos).max(0.0).sqrt();
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    Frame::from_normal(d).to_world(Vec3A::new(s * cp, s * sp, cos)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Normalised, mean cosine g (its defining moment), and sampling distributed as eval
    /// (the sampled cosines' histogram against the integrated density).
    #[test]
    fn normalised_with_mean_cosine_g_and_sampled_exactly() {
        for &g in &[0.0f32, 0.3, -0.5, 0.9] {
            let hg = HenyeyGreenstein::new(g);
            let n = 200_000;
            let (mut norm, mut mean) = (0.0f64, 0.0f64);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let p = hg.eval(c as f32) as f64 * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
                norm += p;
                mean += p * c;
            }
            assert!((norm - 1.0).abs() < 1e-3, "g {g}: ∫p = {norm}");
            assert!((mean - g as f64).abs() < 2e-3, "g {g}: ⟨cos⟩ = {mean}");
            // Inverse CDF: stratified u gives cosines whose mean is g too.
            let m = 100_000;
            let s: f64 = (0..m).map(|i| hg.sample_cos((i as f32 + 0.5) / m as f32) as f64).sum::<f64>() / m as f64;
            assert!((s - g as f64).abs() < 2e-3, "g {g}: sampled ⟨cos⟩ = {s}");
            let (w, pdf) = hg.sample(Vec3A::new(0.0, 0.6, 0.8), Vec2::new(0.3, 0.7));
            assert!((w.length() - 1.0).abs() < 1e-5);
            assert!((pdf - hg.eval(w.dot(Vec3A::new(0.0, 0.6, 0.8)))).abs() < 1e-3 * pdf);
        }
    }
}
