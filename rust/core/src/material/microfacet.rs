//! The Trowbridge–Reitz (GGX) microfacet distribution, isotropic or anisotropic, with
//! Smith shadowing and sampling of visible normals (Heitz 2018, "Sampling the GGX
//! Distribution of Visible Normals", JCGT 7(4)), in the form of pbrt-v4 §9.6. Directions
//! are in the distribution's own frame: normal +z, the anisotropy's tangent +x (a BSDF
//! whose tangent is elsewhere rotates into it with [`TangentRotation`]). Roughness is
//! Blender's: alpha = roughness²; anisotropy stretches it along the tangent as Cycles
//! does (`svm_node_closure_bsdf`, intern/cycles/kernel/svm/closure.h).

use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Below this alpha a surface is treated as perfectly smooth (a delta lobe).
pub const SMOOTH_ALPHA: f32 = 1e-3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    /// Roughness along the tangent (+x) and the bitangent (+y).
    pub alpha_x: f32,
    pub alpha_y: f32,
}

#[inline]
fn clamp_unit(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

impl Ggx {
    /// Isotropic, from Blender's roughness (alpha = roughness², clamped to a usable range).
    pub fn from_roughness(roughness: f32) -> Self {
        let r = clamp_unit(roughness);
        let a = (r * r).max(1e-4);
        Self { alpha_x: a, alpha_y: a }
    }
    /// Isotropic with a given alpha.
    pub fn isotropic(alpha: f32) -> Self {
        Self { alpha_x: alpha, alpha_y: alpha }
    }
    /// The Principled BSDF's and Metallic BSDF's anisotropy (0..1): alpha_x = r²/k,
    /// alpha_y = r²·k with k = √(1 − 0.9·anisotropy) (Cycles, `svm_node_closure_bsdf`).
    pub fn principled_anisotropic(roughness: f32, anisotropy: f32) -> Self {
        let r = clamp_unit(roughness);
        let a = r * r;
        let k = (1.0 - 0.9 * clamp_unit(anisotropy)).sqrt();
        Self { alpha_x: (a / k).clamp(1e-4, 1.0), alpha_y: (a * k).max(1e-4) }
    }
    /// The Glossy BSDF's anisotropy (−1..1, clamped to ±0.99 as Cycles): alpha_x = r²(1 − a),
    /// alpha_y = r²/(1 − a) for a ≥ 0, and alpha_x = r²/(1 + a), alpha_y = r²(1 + a) below.
    pub fn glossy_anisotropic(roughness: f32, anisotropy: f32) -> Self {
        let r = clamp_unit(roughness);
        let a = r * r;
        let an = if anisotropy.is_finite() { anisotropy.clamp(-0.99, 0.99) } else { 0.0 };
        if an.abs() <= 1e-4 {
            return Self::from_roughness(r);
        }
        let (x, y) = if an < 0.0 { (a / (1.0 + an), a * (1.0 + an)) } else { (a * (1.0 - an), a / (1.0 - an)) };
        Self { alpha_x: x.clamp(1e-4, 1.0), alpha_y: y.clamp(1e-4, 1.0) }
    }
    pub fn is_isotropic(&self) -> bool {
        self.alpha_x == self.alpha_y
    }
    /// Blender's roughness of an equivalent isotropic lobe, √√(alpha_x·alpha_y) (what
    /// Cycles looks its albedo tables up with).
    pub fn roughness(&self) -> f32 {
        (self.alpha_x * self.alpha_y).sqrt().sqrt()
    }
    /// The isotropic lobe whose albedo tables stand in for this one in energy
    /// compensation: alpha = √(alpha_x·alpha_y), as Cycles reads its E(μ, roughness)
    /// tables at roughness √√(alpha_x·alpha_y) (`microfacet_ggx_preserve_energy`,
    /// intern/cycles/kernel/closure/bsdf_microfacet.h). An isotropic lobe is itself.
    pub fn energy_equivalent(&self) -> Self {
        if self.is_isotropic() {
            *self
        } else {
            Self::isotropic((self.alpha_x * self.alpha_y).sqrt())
        }
    }
    /// Whether the lobe is so narrow it should be handled as a mirror.
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x * self.alpha_y < SMOOTH_ALPHA * SMOOTH_ALPHA
    }
    /// Distribution of normals D(wm) (projected-area normalised: ∫ D cos θm dω = 1).
    pub fn d(&self, wm: Vec3A) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        let (x, y) = (wm.x / self.alpha_x, wm.y / self.alpha_y);
        let l = x * x + y * y + wm.z * wm.z;
        let d = 1.0 / (PI * self.alpha_x * self.alpha_y * l * l);
        if d.is_finite() {
            d
        } else {
            0.0
        }
    }
    /// Smith's auxiliary function Λ(w).
    pub fn lambda(&self, w: Vec3A) -> f32 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f32::INFINITY;
        }
        let t = ((self.alpha_x * w.x).powi(2) + (self.alpha_y * w.y).powi(2)) / z2;
        ((1.0 + t).sqrt() - 1.0) * 0.5
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
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let mut wh = Vec3A::new(ax * w.x, ay * w.y, w.z).normalize_or_zero();
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 { Vec3A::Z.cross(wh).normalize() } else { Vec3A::X };
        let t2 = wh.cross(t1);
        // Uniform disk (polar), warped to the visible half.
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let (px, mut py) = (r * phi.cos(), r * phi.sin());
        let h = (1.0 - px * px).max(0.0).sqrt();
        let s = 0.5 * (1.0 + wh.z);
        py = (1.0 - s) * h + s * py;
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = t1 * px + t2 * py + wh * pz;
        Vec3A::new(ax * nh.x, ay * nh.y, nh.z.max(1e-6)).normalize()
    }
}

/// A rotation about the normal that takes the shading frame's +x to an anisotropic
/// lobe's tangent (Blender's Tangent input, turned by Anisotropic Rotation × 2π).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentRotation {
    cos: f32,
    sin: f32,
}

impl Default for TangentRotation {
    fn default() -> Self {
        Self { cos: 1.0, sin: 0.0 }
    }
}

impl TangentRotation {
    /// From the tangent in the shading frame (its component along the normal is dropped)
    /// and a further rotation in turns (Blender's Anisotropic Rotation, 1 = 360°).
    pub fn new(tangent: Vec3A, turns: f32) -> Self {
        let (tx, ty) = (tangent.x, tangent.y);
        let l = (tx * tx + ty * ty).sqrt();
        let (c0, s0) = if l > 1e-12 && l.is_finite() { (tx / l, ty / l) } else { (1.0, 0.0) };
        let t = if turns.is_finite() { turns } else { 0.0 };
        let (s1, c1) = (2.0 * PI * t).sin_cos();
        Self { cos: c0 * c1 - s0 * s1, sin: s0 * c1 + c0 * s1 }
    }
    /// Shading frame → lobe frame (the tangent becomes +x).
    #[inline]
    pub fn to_lobe(&self, v: Vec3A) -> Vec3A {
        Vec3A::new(self.cos * v.x + self.sin * v.y, -self.sin * v.x + self.cos * v.y, v.z)
    }
    /// Lobe frame → shading frame.
    #[inline]
    pub fn from_lobe(&self, v: Vec3A) -> Vec3A {
        Vec3A::new(self.cos * v.x - self.sin * v.y, self.sin * v.x + self.cos * v.y, v.z)
    }
}

/// The microfacet distribution of a rough transmission lobe (Blender's Refraction BSDF
/// offers both; the rough glass is GGX).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Distribution {
    Ggx(Ggx),
    /// Beckmann with this alpha (Blender's roughness²), Smith Λ by Walter's rational
    /// approximation, as Cycles' `bsdf_lambda<BECKMANN>`.
    Beckmann(f32),
}

impl Distribution {
    pub(super) fn d(&self, wm: Vec3A) -> f32 {
        match self {
            Distribution::Ggx(g) => g.d(wm),
            Distribution::Beckmann(a) => {
                if wm.z <= 0.0 {
                    return 0.0;
                }
                let c2 = wm.z * wm.z;
                let tan2 = (1.0 - c2).max(0.0) / c2;
                let d = (-tan2 / (a * a)).exp() / (PI * a * a * c2 * c2);
                if d.is_finite() {
                    d
                } else {
                    0.0
                }
            }
        }
    }
    pub(super) fn lambda(&self, w: Vec3A) -> f32 {
        match self {
            Distribution::Ggx(g) => g.lambda(w),
            Distribution::Beckmann(alpha) => {
                let c2 = w.z * w.z;
                if c2 == 0.0 {
                    return f32::INFINITY;
                }
                let tan = ((1.0 - c2).max(0.0) / c2).sqrt();
                if tan == 0.0 {
                    return 0.0;
                }
                let a = 1.0 / (alpha * tan);
                if a < 1.6 {
                    (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
                } else {
                    0.0
                }
            }
        }
    }
    pub(super) fn g(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }
    /// A microfacet normal for `wo` (wo.z > 0) and its density.
    pub(super) fn sample_wm(&self, wo: Vec3A, u: Vec2) -> Vec3A {
        match self {
            Distribution::Ggx(g) => g.sample_wm(wo, u),
            Distribution::Beckmann(a) => {
                let tan2 = -a * a * (1.0 - u.x).max(1e-12).ln();
                let c = 1.0 / (1.0 + tan2).sqrt();
                let s = (1.0 - c * c).max(0.0).sqrt();
                let phi = 2.0 * PI * u.y;
                Vec3A::new(s * phi.cos(), s * phi.sin(), c)
            }
        }
    }
    /// The density of [`Self::sample_wm`] over microfacet normals.
    pub(super) fn pdf_wm(&self, wo: Vec3A, wm: Vec3A) -> f32 {
        match self {
            Distribution::Ggx(g) => g.d_visible(wo, wm),
            Distribution::Beckmann(_) => self.d(wm) * wm.z.max(0.0),
        }
    }
    /// [`Self::pdf_wm`] for `wo` on either side of the surface (`wo·wm` and `wo.z` of
    /// one sign; `wo.z` ≠ 0): GGX's visible normals G1(wo)/|cos θo|·D(wm)·|wo·wm|.
    pub(super) fn pdf_wm_two_sided(&self, wo: Vec3A, wm: Vec3A) -> f32 {
        match self {
            Distribution::Ggx(g) => g.g1(wo) / wo.z.abs() * g.d(wm) * wo.dot(wm).abs(),
            Distribution::Beckmann(_) => self.d(wm) * wm.z.max(0.0),
        }
    }
}

/// A GGX distribution with the rotation into its frame: what an anisotropic reflection
/// lobe carries (the Glossy/Conductor's and the Principled's specular and metal lobes).
/// An isotropic distribution ignores the tangent, so its lobe is evaluated in the
/// shading frame itself, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisotropicGgx {
    pub distribution: Ggx,
    /// Shading frame → the distribution's frame (used only when anisotropic).
    pub tangent: TangentRotation,
}

impl AnisotropicGgx {
    pub fn new(distribution: Ggx, tangent: TangentRotation) -> Self {
        Self { distribution, tangent }
    }

    /// A shading-frame direction in the distribution's frame (itself when isotropic).
    #[inline]
    pub fn to_lobe(&self, v: Vec3A) -> Vec3A {
        if self.distribution.is_isotropic() {
            v
        } else {
            self.tangent.to_lobe(v)
        }
    }

    /// A direction in the distribution's frame back in the shading frame.
    #[inline]
    pub fn lobe_to_shading(&self, v: Vec3A) -> Vec3A {
        if self.distribution.is_isotropic() {
            v
        } else {
            self.tangent.from_lobe(v)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// ∫ D(wm) cos θm dωm = 1 (numerical quadrature over the hemisphere).
    #[test]
    fn distribution_is_normalised() {
        for &(ax, ay) in &[(0.05f32, 0.05f32), (0.2, 0.2), (0.5, 0.5), (1.0, 1.0), (0.1, 0.4), (0.6, 0.15)] {
            let g = Ggx { alpha_x: ax, alpha_y: ay };
            let alpha = (ax, ay);
            let np = if g.is_isotropic() { 8usize } else { 256 };
            let nt = 4000usize;
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
            assert!((sum - 1.0).abs() < 0.01, "alpha {alpha:?}: {sum}");
        }
    }

    /// χ² test of visible-normal sampling against its pdf (as pbrt and Mitsuba test
    /// their samplers): bins in (cos θ, φ), expected counts integrated numerically.
    #[test]
    fn visible_normal_sampling_matches_its_pdf_chi_square() {
        let (nt, np) = (10usize, 20usize);
        let samples = 200_000usize;
        for &(ax, ay, theta_o, phi_o) in &[
            (0.2f32, 0.2f32, 0.3f32, 0.0f32),
            (0.3, 0.3, 1.0, 0.0),
            (0.6, 0.6, 1.4, 0.0),
            (1.0, 1.0, 0.0, 0.0),
            (0.1, 0.5, 0.9, 0.7),
            (0.6, 0.15, 1.2, 2.0),
        ] {
            let g = Ggx { alpha_x: ax, alpha_y: ay };
            let alpha = (ax, ay);
            let wo = Vec3A::new(theta_o.sin() * phi_o.cos(), theta_o.sin() * phi_o.sin(), theta_o.cos());
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
            assert!(chi2 < crit, "alpha {alpha:?} θo {theta_o}: χ² {chi2:.1} > {crit:.1} (dof {dof})");
        }
    }

    /// Blender's anisotropy mappings (Cycles, svm/closure.h) and the tangent rotation.
    #[test]
    fn anisotropy_mappings_and_tangent_rotation() {
        let g = Ggx::principled_anisotropic(0.5, 0.0);
        assert_eq!(g, Ggx::from_roughness(0.5));
        let g = Ggx::principled_anisotropic(0.5, 1.0);
        let k = 0.1f32.sqrt();
        assert!((g.alpha_x - 0.25 / k).abs() < 1e-6 && (g.alpha_y - 0.25 * k).abs() < 1e-6);
        assert!((g.roughness() - 0.5).abs() < 1e-6, "the geometric mean keeps the roughness");
        let g = Ggx::glossy_anisotropic(0.5, 0.5);
        assert!((g.alpha_x - 0.125).abs() < 1e-6 && (g.alpha_y - 0.5).abs() < 1e-6);
        let g = Ggx::glossy_anisotropic(0.5, -0.5);
        assert!((g.alpha_x - 0.5).abs() < 1e-6 && (g.alpha_y - 0.125).abs() < 1e-6);
        assert!(Ggx::glossy_anisotropic(f32::NAN, f32::NAN).alpha_x.is_finite());
        // The tangent (0, 1, 0) turned by a quarter turn is −x.
        let r = TangentRotation::new(Vec3A::new(0.0, 2.0, 0.3), 0.25);
        let t = r.from_lobe(Vec3A::X);
        assert!((t - Vec3A::new(-1.0, 0.0, 0.0)).length() < 1e-6, "{t:?}");
        let v = Vec3A::new(0.3, -0.4, 0.866);
        assert!((r.from_lobe(r.to_lobe(v)) - v).length() < 1e-6);
        // A degenerate tangent keeps the frame.
        assert_eq!(TangentRotation::new(Vec3A::Z, 0.0), TangentRotation::default());
    }

    /// Anisotropic D falls off faster along the less rough axis, and the
    /// masking function is reciprocal: G(wo, wi) = G(wi, wo).
    #[test]
    fn anisotropic_lobe_is_stretched_along_its_rough_axis() {
        let g = Ggx { alpha_x: 0.5, alpha_y: 0.1 };
        let along_x = Vec3A::new(0.3, 0.0, 1.0).normalize();
        let along_y = Vec3A::new(0.0, 0.3, 1.0).normalize();
        assert!(g.d(along_x) > 5.0 * g.d(along_y));
        let a = Vec3A::new(0.5, 0.2, 0.8).normalize();
        let b = Vec3A::new(-0.1, 0.6, 0.5).normalize();
        assert_eq!(g.g(a, b), g.g(b, a));
    }
}
