//! The Principled BSDF's subsurface lobe: what a path that enters it walks, after
//! Cycles 4.5's random-walk BSSRDF (intern/cycles/kernel/closure/bssrdf.h `bssrdf_setup`,
//! `bssrdf_setup_radius`; intern/cycles/kernel/integrator/subsurface.h
//! `subsurface_entry_bounce`, `subsurface_bounce`, `subsurface_shader_data_setup`).
//!
//! * The lobe takes `weight` of the base (Cycles' `svm_node_closure_bsdf`: the BSSRDF
//!   closure gets base colour × Subsurface Weight, the diffuse × (1 − weight)); under
//!   the dielectric specular layer both see the layer's transmission 1 − E(μo).
//! * Its radius is the Blender per-channel Radius × Scale, made a spectrum on the
//!   render's grid through the same RGB → spectrum map as the colours (eq. 10,
//!   docs/uplift.md: the reflectance map of radius/max(radius), times max(radius), so
//!   every wavelength gets a positive mean free path), then Cycles' `bssrdf_setup_radius`:
//!   ×1/(4π) for Random Walk, or the dipole fit of the albedo at the Subsurface IOR for
//!   Random Walk (Skin).
//! * Sampling it refracts the path into the surface through a GGX interface of the
//!   Principled's roughness and IOR (`subsurface_entry_bounce`: a visible normal, the
//!   refraction about it, no Fresnel or shadowing weight; Skin: roughness 1 and half the
//!   entries cosine-distributed), and hands the walk a [`SubsurfaceEvent`] through the
//!   shading context. The walk (`medium::random_walk`, `integrator::walk`) leaves through
//!   the same mesh, where the path continues from a white Lambertian, as Cycles'
//!   `subsurface_shader_data_setup`.
//! * The lobe is not evaluated towards lights (pdf 0), as Cycles' BSSRDF closures.

use super::microfacet::Ggx;
use crate::sampling::cosine_hemisphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// A radius below which the medium is not walked (Cycles' BSSRDF_MIN_RADIUS).
pub const MIN_RADIUS: f32 = 1e-8;

/// Which Cycles random walk (Blender's Principled "Subsurface Method").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SubsurfaceMethod {
    /// "Random Walk" (Blender 4.x's default): mean free path = radius/(4π), entry through
    /// the Principled's IOR and roughness.
    #[default]
    RandomWalk,
    /// "Random Walk (Skin)": mean free path from the dipole fit of the albedo at the
    /// Subsurface IOR, entry through roughness 1 at that IOR, half the entries diffuse.
    RandomWalkSkin,
}

/// The lobe, on the render's grid.
#[derive(Clone, Debug)]
pub struct SubsurfaceLobe {
    /// Subsurface Weight, 0..1.
    pub weight: f32,
    /// Radius × Scale per grid wavelength (scene units), before `bssrdf_setup_radius`.
    pub radius: SampledSpectrum,
    /// Henyey–Greenstein asymmetry inside (Subsurface Anisotropy, clamped to 0..0.9).
    pub anisotropy: f32,
    /// The entry interface's index (clamped to 1.01..3.8 as `bssrdf_setup`).
    pub ior: f32,
    pub method: SubsurfaceMethod,
}

/// What a path that entered a subsurface lobe walks, per grid wavelength.
#[derive(Clone, Debug)]
pub struct SubsurfaceEvent {
    /// The multiple-scattering albedo the walk is fitted to (the base colour).
    pub albedo: SampledSpectrum,
    /// The mean free path (scene units).
    pub mfp: SampledSpectrum,
    pub anisotropy: f32,
}

/// Cycles' `bssrdf_dipole_compute_Rd`.
fn dipole_rd(alpha_prime: f32, fourthird_a: f32) -> f32 {
    let s = (3.0 * (1.0 - alpha_prime)).sqrt();
    0.5 * alpha_prime * (1.0 + (-fourthird_a * s).exp()) * (-s).exp()
}

/// Cycles' `bssrdf_dipole_compute_alpha_prime`: bisection for Rd(α') = rd.
fn dipole_alpha_prime(rd: f32, fourthird_a: f32) -> f32 {
    if rd < 1e-4 {
        return 0.0;
    }
    if rd >= 0.995 {
        return 0.999_999;
    }
    let (mut x0, mut x1, mut xmid) = (0.0f32, 1.0f32, 0.5f32);
    for _ in 0..12 {
        xmid = 0.5 * (x0 + x1);
        if dipole_rd(xmid, fourthird_a) < rd {
            x0 = xmid;
        } else {
            x1 = xmid;
        }
    }
    xmid
}

impl SubsurfaceLobe {
    /// A lobe from validated inputs: `radius` per grid wavelength (radius × scale).
    /// Anisotropy and IOR are clamped as Cycles' `bssrdf_setup`. None when no wavelength
    /// has a radius of at least [`MIN_RADIUS`] or the weight is 0 (then the base is all
    /// diffuse, as Cycles turns such channels into a diffuse closure).
    pub fn new(
        weight: f32,
        radius: SampledSpectrum,
        anisotropy: f32,
        ior: f32,
        method: SubsurfaceMethod,
    ) -> Option<Self> {
        let weight = if weight.is_finite() { weight.clamp(0.0, 1.0) } else { 0.0 };
        if !(weight > 0.0) || !(radius.max_value() >= MIN_RADIUS) {
            return None;
        }
        let anisotropy = if anisotropy.is_finite() { anisotropy.clamp(0.0, 0.9) } else { 0.0 };
        let ior = if ior.is_finite() { ior.clamp(1.01, 3.8) } else { 1.4 };
        Some(Self { weight, radius, anisotropy, ior, method })
    }

    /// The walk's medium for base colour `albedo` (per grid wavelength): the mean free
    /// path of `bssrdf_setup_radius`.
    pub fn event(&self, albedo: &SampledSpectrum) -> SubsurfaceEvent {
        let n = albedo.len();
        let mut a = SampledSpectrum::zeros(n);
        let mut mfp = SampledSpectrum::zeros(n);
        let fourthird_a = {
            let inv = 1.0 / self.ior;
            let f_dr = inv * (-1.440 * inv + 0.710) + 0.668 + 0.0636 * self.ior;
            (4.0 / 3.0) * (1.0 + f_dr) / (1.0 - f_dr)
        };
        for k in 0..n {
            let rho = albedo.get(k);
            let rho = if rho.is_finite() { rho.clamp(0.0, 1.0) } else { 0.0 };
            a.set(k, rho);
            let r = self.radius.get(k.min(self.radius.len() - 1)).max(0.0);
            let d = match self.method {
                SubsurfaceMethod::RandomWalk => r * 0.25 * std::f32::consts::FRAC_1_PI,
                SubsurfaceMethod::RandomWalkSkin => r * (3.0 * (1.0 - dipole_alpha_prime(rho, fourthird_a))).sqrt(),
            };
            mfp.set(k, d);
        }
        SubsurfaceEvent { albedo: a, mfp, anisotropy: self.anisotropy }
    }

    /// The direction into the surface (z < 0) for `wo` (z > 0), by Cycles'
    /// `subsurface_entry_bounce` through a GGX interface `ggx` (the Principled's
    /// roughness; Skin: roughness 1, and half the entries cosine-distributed).
    pub fn entry(&self, ggx: &Ggx, wo: Vec3A, u: Vec2) -> Option<Vec3A> {
        let mut u = u;
        let mut g = *ggx;
        if self.method == SubsurfaceMethod::RandomWalkSkin {
            if u.x < 0.5 {
                let d = cosine_hemisphere(Vec2::new((2.0 * u.x).min(0.999_999_9), u.y));
                return Some(Vec3A::new(d.x, d.y, -d.z));
            }
            u.x = (2.0 * (u.x - 0.5)).min(0.999_999_9);
            g = Ggx::isotropic(1.0);
        }
        if !(wo.z > 0.0) {
            return None;
        }
        let h = g.sample_wm(wo, u);
        let neta = 1.0 / self.ior;
        let cos_hi = h.dot(wo);
        // The IOR is above 1: no total internal reflection.
        let arg = 1.0 - neta * neta * (1.0 - cos_hi * cos_hi);
        let dnp = arg.max(0.0).sqrt().max(1e-7);
        let wi = -neta * wo + (neta * cos_hi - dnp) * h;
        (wi.z < 0.0 && wi.is_finite()).then(|| wi.normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entry_refracts_into_the_surface() {
        let grid_radius = SampledSpectrum::splat(4, 0.1);
        let lobe = SubsurfaceLobe::new(1.0, grid_radius, 0.0, 1.5, SubsurfaceMethod::RandomWalk).unwrap();
        // Smooth: Snell's law about the normal.
        let g = Ggx::isotropic(1e-4);
        let s = 0.6f32;
        let wo = Vec3A::new(s, 0.0, (1.0 - s * s).sqrt());
        let wi = lobe.entry(&g, wo, Vec2::new(0.3, 0.7)).unwrap();
        assert!((wi.x + s / 1.5).abs() < 1e-3 && wi.z < 0.0, "{wi:?}");
        // Rough: always inside, unit length.
        let g = Ggx::isotropic(0.25);
        for i in 0..64 {
            let u = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.06);
            let wi = lobe.entry(&g, wo, u).unwrap();
            assert!(wi.z < 0.0 && (wi.length() - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn radius_setup_follows_cycles() {
        let albedo = SampledSpectrum::from_slice(&[0.8, 0.5, 0.1]);
        let r = SampledSpectrum::from_slice(&[1.0, 0.2, 0.1]);
        let rw = SubsurfaceLobe::new(1.0, r.clone(), 0.0, 1.5, SubsurfaceMethod::RandomWalk).unwrap();
        let e = rw.event(&albedo);
        assert!((e.mfp.get(0) - 1.0 / (4.0 * std::f32::consts::PI)).abs() < 1e-6);
        // Skin: radius·√(3(1 − α')) with Rd(α') = albedo.
        let skin = SubsurfaceLobe::new(1.0, r, 0.0, 1.4, SubsurfaceMethod::RandomWalkSkin).unwrap();
        let e = skin.event(&albedo);
        let inv = 1.0 / 1.4f32;
        let f_dr = inv * (-1.440 * inv + 0.710) + 0.668 + 0.0636 * 1.4;
        let a = (4.0 / 3.0) * (1.0 + f_dr) / (1.0 - f_dr);
        for k in 0..3 {
            let ap = 1.0 - (e.mfp.get(k) / [1.0, 0.2, 0.1][k]).powi(2) / 3.0;
            // Cycles bisects 12 times: Rd is steep near α′ = 1.
            assert!((dipole_rd(ap, a) - albedo.get(k)).abs() < 0.02, "lane {k}: {}", dipole_rd(ap, a));
        }
        // Nothing to walk: no lobe.
        assert!(
            SubsurfaceLobe::new(1.0, SampledSpectrum::splat(3, 0.0), 0.0, 1.4, SubsurfaceMethod::RandomWalk).is_none()
        );
        assert!(
            SubsurfaceLobe::new(0.0, SampledSpectrum::splat(3, 1.0), 0.0, 1.4, SubsurfaceMethod::RandomWalk).is_none()
        );
    }
}
