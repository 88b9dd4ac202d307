//! The isotropic Trowbridge–Reitz (GGX) microfacet distribution with Smith shadowing
//! and sampling of visible normals (Heitz 2018, "Sampling the GGX Distribution of
//! Visible Normals", JCGT 7(4)), in the form of pbrt-v4 §9.6. Directions are in the
//! local frame (normal +z). Roughness is Blender's: alpha = roughness².

use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Below this alpha a surface is treated as perfectly smooth (a delta lobe).
pub const SMOOTH_ALPHA: f32 = 1e-3;

#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    pub alpha: f32,
}

#[inline]
fn tan2_theta(w: Vec3A) -> f32 {
    let cos2 = w.z * w.z;
    (1.0 - cos2).max(0.0) / cos2
}

impl Ggx {
    /// From Blender's roughness (alpha = roughness², clamped to a usable range).
    pub fn from_roughness(roughness: f32) -> Self {
        let r = if roughness.is_finite() { roughness.clamp(0.0, 1.0) } else { 0.0 };
        Self { alpha: (r * r).max(1e-4) }
    }
    /// Whether the lobe is so narrow it should be handled as a mirror.
    pub fn effectively_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }
    /// Distribution of normals D(wm) (projected-area normalised: ∫ D cos θm dω = 1).
    pub fn d(&self, wm: Vec3A) -> f32 {
        let cos2 = wm.z * wm.z;
        if cos2 <= 0.0 {
            return 0.0;
        }
        let t2 = tan2_theta(wm);
        if !t2.is_finite() {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let e = 1.0 + t2 / a2;
        1.0 / (PI * a2 * cos2 * cos2 * e * e)
    }
    /// Smith's auxiliary function Λ(w).
    pub fn lambda(&self, w: Vec3A) -> f32 {
        let t2 = tan2_theta(w);
        if !t2.is_finite() {
            return f32::INFINITY;
        }
        ((1.0 + self.alpha * self.alpha * t2).sqrt() - 1.0) * 0.5
    }
    pub fn g1(&self, w: Vec3A) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }
    /// Height-correlated masking-shadowing.
    pub fn g(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }
    /// Distribution of visible normals from `w`: D_w(wm) = G1(w)/|cos θ| · D(wm) · max(0, w·wm).
    pub fn d_visible(&self, w: Vec3A, wm: Vec3A) -> f32 {
        let cos = w.z.abs();
        if cos == 0.0 {
            return 0.0;
        }
        self.g1(w) / cos * self.d(wm) * w.dot(wm).max(0.0)
    }
    /// Samples a visible normal from `w` (on the +z side after flipping); pdf is
    /// [`Self::d_visible`].
    pub fn sample_wm(&self, w: Vec3A, u: Vec2) -> Vec3A {
        let a = self.alpha;
        let mut wh = Vec3A::new(a * w.x, a * w.y, w.z).normalize_or_zero();
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 { Vec3A::Z.cross(wh).normalize() } else { Vec3A::X };
        let t2 = wh.cross(t1);
        // Uniform disk (polar), warped to the visible half.
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let (mut px, mut py) = (r * phi.cos(), r * phi.sin());
        let h = (1.0 - px * px).max(0.0).sqrt();
        let s = 0.5 * (1.0 + wh.z);
        py = (1.0 - s) * h + s * py;
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = t1 * px + t2 * py + wh * pz;
        px = a * nh.x;
        py = a * nh.y;
        Vec3A::new(px, py, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// ∫ D(wm) cos θm dωm = 1 (numerical quadrature over the hemisphere).
    #[test]
    fn distribution_is_normalised() {
        for &alpha in &[0.05f32, 0.2, 0.5, 1.0] {
            let g = Ggx { alpha };
            let (nt, np) = (4000usize, 8usize);
            let mut sum = 0.0f64;
            for i in 0..nt {
                // Substitute cos θ = c to resolve the sharp peak at θ = 0.
                let c = (i as f64 + 0.5) / nt as f64;
                let s = (1.0 - c * c).sqrt();
                for j in 0..np {
                    let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                    let wm = Vec3A::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
                    sum += g.d(wm) as f64 * c * (1.0 / nt as f64) * (2.0 * std::f64::consts::PI / np as f64);
                }
            }
            assert!((sum - 1.0).abs() < 0.01, "alpha {alpha}: {sum}");
        }
    }

    /// χ² test of visible-normal sampling against its pdf (as pbrt and Mitsuba test
    /// their samplers): bins in (cos θ, φ), expected counts integrated numerically.
    #[test]
    fn visible_normal_sampling_matches_its_pdf_chi_square() {
        let (nt, np) = (10usize, 20usize);
        let samples = 200_000usize;
        for &(alpha, theta_o) in &[(0.2f32, 0.3f32), (0.3, 1.0), (0.6, 1.4), (1.0, 0.0)] {
            let g = Ggx { alpha };
            let wo = Vec3A::new(theta_o.sin(), 0.0, theta_o.cos());
            let mut hist = vec![0f64; nt * np];
            let mut rng = Rng::new(12345, 7);
            let bin = |wm: Vec3A| -> usize {
                let c = wm.z.clamp(0.0, 0.999_999);
                let phi = wm.y.atan2(wm.x).rem_euclid(2.0 * PI);
                let i = ((c * nt as f32) as usize).min(nt - 1);
                let j = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
                i * np + j
            };
            for _ in 0..samples {
                let wm = g.sample_wm(wo, rng.uniform2());
                assert!(wm.is_finite() && (wm.length() - 1.0).abs() < 1e-4 && wm.z > 0.0);
                hist[bin(wm)] += 1.0;
            }
            // Expected counts: ∫ over each bin of D_wo(wm) dωm, with dω = dcosθ dφ.
            let sub = 32usize;
            let mut expected = vec![0f64; nt * np];
            for i in 0..nt {
                for j in 0..np {
                    let mut acc = 0.0f64;
                    for a in 0..sub {
                        for b in 0..sub {
                            let c = (i as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64;
                            let phi =
                                2.0 * std::f64::consts::PI * (j as f64 + (b as f64 + 0.5) / sub as f64) / np as f64;
                            let s = (1.0 - c * c).max(0.0).sqrt();
                            let wm = Vec3A::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
                            acc += g.d_visible(wo, wm) as f64;
                        }
                    }
                    let area = (1.0 / nt as f64) * (2.0 * std::f64::consts::PI / np as f64);
                    expected[i * np + j] = acc / (sub * sub) as f64 * area * samples as f64;
                }
            }
            let total: f64 = expected.iter().sum();
            assert!((total / samples as f64 - 1.0).abs() < 0.02, "pdf integrates to {}", total / samples as f64);
            // Pool bins with tiny expectations, as the standard test does.
            let (mut chi2, mut dof, mut pool_e, mut pool_o) = (0.0f64, 0usize, 0.0f64, 0.0f64);
            for k in 0..nt * np {
                if expected[k] < 5.0 {
                    pool_e += expected[k];
                    pool_o += hist[k];
                } else {
                    chi2 += (hist[k] - expected[k]).powi(2) / expected[k];
                    dof += 1;
                }
            }
            if pool_e >= 5.0 {
                chi2 += (pool_o - pool_e).powi(2) / pool_e;
                dof += 1;
            }
            let dof = (dof - 1) as f64;
            // Wilson–Hilferty: the 1e-4 upper quantile of χ²(dof).
            let z = 3.719;
            let crit = dof * (1.0 - 2.0 / (9.0 * dof) + z * (2.0 / (9.0 * dof)).sqrt()).powi(3);
            assert!(chi2 < crit, "alpha {alpha} θo {theta_o}: χ² {chi2:.1} > {crit:.1} (dof {dof})");
        }
    }
}
