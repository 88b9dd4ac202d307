//! Glass: smooth and rough (GGX) dielectrics, with or without dispersion.
//!
//! The local frame's normal points to the side the ray arrived from; the relative
//! index crossed is `n` when the ray arrives from outside the object
//! (`ctx.front_face`) and `1/n` from inside.
//!
//! Polychromatic rays (docs/design.md#methods, eq. 9): reflection sends every wavelength the same
//! way, so the lobe is chosen by the energy-weighted spectral mean of the Fresnel
//! reflectance R̄ and the ray keeps all its wavelengths (weight R_λ/R̄). Refraction
//! through a dispersive glass has no common direction: the ray collapses to one grid
//! wavelength i chosen with probability p_i ∝ β_i·w_i·T_i (the denormalised energy the
//! refracted ray carries at λi: throughput × quadrature weight × transmittance),
//! keeps lane i only with weight T_i/((1 − R̄)·p_i), and reports `collapsed_to`.
//! A non-dispersive glass (index constant over the grid) never collapses. With
//! `ctx.single_wavelength = Some(i)` only n(λi) is used.
//!
//! Radiance crossing an interface is scaled by 1/η² (TransportMode::Radiance, Veach
//! 1997 §5.2); importance is not.

use super::dispersion::IndexOfRefraction;
use super::energy::glass_compensation;
use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::microfacet::{Distribution, Ggx};
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, TransportMode};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// Relative index crossed from the arriving side.
#[inline]
pub(super) fn relative(n: f32, ctx: &ShadingContext) -> f32 {
    if ctx.front_face {
        n
    } else {
        1.0 / n
    }
}

#[inline]
pub(super) fn radiance_scale(ctx: &ShadingContext, etap: f32) -> f32 {
    match ctx.mode {
        TransportMode::Radiance => 1.0 / (etap * etap),
        TransportMode::Importance => 1.0,
    }
}

/// The transmission term of a rough dielectric (Walter et al. 2007; pbrt-v4
/// DielectricBxDF::f/PDF) from `wo` to `wi` on opposite sides, `etap` the relative index
/// crossed from `wo`'s side, over distribution `m`: f·|cos θi| and the pdf of `wi`,
/// both times `weight(wo·wm)` at the generalised half vector wm (the Fresnel
/// transmittance 1 − F for glass, 1 for Blender's Refraction BSDF). Zero for back-facing
/// microfacets and a degenerate half vector; radiance is scaled by 1/η².
pub(super) fn microfacet_transmission(
    ctx: &ShadingContext,
    m: &Distribution,
    etap: f32,
    wo: Vec3A,
    wi: Vec3A,
    weight: impl FnOnce(f32) -> f32,
) -> (f32, f32) {
    let (cos_o, cos_i) = (wo.z, wi.z);
    if cos_o * cos_i >= 0.0 {
        return (0.0, 0.0);
    }
    let mut wm = wi * etap + wo;
    if wm.length_squared() == 0.0 {
        return (0.0, 0.0);
    }
    wm = wm.normalize();
    if wm.z < 0.0 {
        wm = -wm;
    }
    let (co, ci) = (wo.dot(wm), wi.dot(wm));
    // Discard back-facing microfacets.
    if ci * cos_i < 0.0 || co * cos_o < 0.0 {
        return (0.0, 0.0);
    }
    let denom = (ci + co / etap).powi(2);
    if denom == 0.0 {
        return (0.0, 0.0);
    }
    let t = weight(co);
    let f = m.d(wm) * t * m.g(wo, wi) * (ci * co / (cos_i * cos_o * denom)).abs() * radiance_scale(ctx, etap);
    let pdf = m.pdf_wm_two_sided(wo, wm) * ci.abs() / denom * t;
    (f * cos_i.abs(), pdf)
}

/// The index to use for every lane, or None when the ray must collapse.
pub(super) fn common_index(ior: &IndexOfRefraction, ctx: &ShadingContext) -> Option<f32> {
    match ctx.single_wavelength {
        Some(i) => Some(ior.at(i)),
        None if !ior.dispersive => Some(ior.at(0)),
        None => None,
    }
}

/// Picks a lane with probability ∝ `weights` using `u`; returns (lane, probability).
pub(super) fn pick_lane(weights: &[f32], u: f32) -> Option<(usize, f32)> {
    let total: f32 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let target = u * total;
    let mut acc = 0.0f32;
    let mut last = None;
    for (i, &w) in weights.iter().enumerate() {
        if w <= 0.0 {
            continue;
        }
        acc += w;
        last = Some(i);
        if target < acc {
            return Some((i, w / total));
        }
    }
    last.map(|i| (i, weights[i] / total))
}

/// A perfectly smooth dielectric interface.
pub struct Dielectric {
    pub ior: IndexOfRefraction,
}

impl Bsdf for Dielectric {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::GLOSSY | crate::geometry::visibility::TRANSMISSION
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: false, specular: true, dispersive: self.ior.dispersive }
    }
    fn eval(&self, _: &ShadingContext, _: Vec3A, _: Vec3A, out: &mut SampledSpectrum) -> f32 {
        out.fill(0.0);
        0.0
    }
    fn pdf(&self, _: &ShadingContext, _: Vec3A, _: Vec3A) -> f32 {
        0.0
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        _u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let mirror = Vec3A::new(-wo.x, -wo.y, wo.z);
        if let Some(n) = common_index(&self.ior, ctx) {
            let eta = relative(n, ctx);
            let r = fresnel_dielectric(wo.z, eta);
            if uc < r {
                return Some(BsdfSample { wi: mirror, pdf: r, specular: true, collapsed_to: None });
            }
            let (wi, etap) = refract(wo, Vec3A::Z, eta)?;
            throughput.scale(radiance_scale(ctx, etap));
            return Some(BsdfSample { wi, pdf: 1.0 - r, specular: true, collapsed_to: None });
        }
        // Dispersive glass, polychromatic ray.
        let len = throughput.len();
        let weights = ctx.grid.weights();
        let mut r = vec![0.0f32; len];
        let mut energy_r = 0.0f32;
        let mut energy = 0.0f32;
        let mut transmitted = vec![0.0f32; len];
        for i in 0..len {
            r[i] = fresnel_dielectric(wo.z, relative(self.ior.at(i), ctx));
            let e = throughput.get(i).max(0.0) * weights[i];
            energy += e;
            energy_r += e * r[i];
            transmitted[i] = e * (1.0 - r[i]);
        }
        if !(energy > 0.0) {
            return None;
        }
        let uc = ctx.collapse_u.unwrap_or(uc);
        let r_mean = (energy_r / energy).clamp(0.0, 1.0);
        if uc < r_mean {
            for (i, v) in throughput.values_mut().iter_mut().enumerate() {
                *v *= r[i] / r_mean;
            }
            return Some(BsdfSample { wi: mirror, pdf: r_mean, specular: true, collapsed_to: None });
        }
        let u2 = ((uc - r_mean) / (1.0 - r_mean)).clamp(0.0, 0.999_999_9);
        let (i, p) = pick_lane(&transmitted, u2)?;
        let (wi, etap) = refract(wo, Vec3A::Z, relative(self.ior.at(i), ctx))?;
        let w = (1.0 - r[i]) / ((1.0 - r_mean) * p) * radiance_scale(ctx, etap);
        throughput.keep_only(i);
        throughput.set(i, throughput.get(i) * w);
        Some(BsdfSample { wi, pdf: (1.0 - r_mean) * p, specular: true, collapsed_to: Some(i) })
    }
    fn albedo(&self, _: &ShadingContext, out: &mut SampledSpectrum) {
        out.fill(1.0);
    }
    /// Reflection: R_λ / p, refraction: T_λ/η_λ² / p, with each wavelength's own index;
    /// p is the event's probability in `sample`: R or 1 − R at the common index, the
    /// energy-weighted R̄ or 1 − R̄ for a polychromatic ray at a dispersive glass (the
    /// lane choice of the collapse is not part of it: every lane takes the event).
    fn specular_weights(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        wi: Vec3A,
        throughput: &SampledSpectrum,
        out: &mut SampledSpectrum,
    ) -> bool {
        if wo.z == 0.0 {
            return false;
        }
        let reflected = wi.z * wo.z > 0.0;
        let r_event = match common_index(&self.ior, ctx) {
            Some(n) => fresnel_dielectric(wo.z, relative(n, ctx)),
            None => {
                let weights = ctx.grid.weights();
                let (mut energy, mut energy_r) = (0.0f32, 0.0f32);
                for (i, w) in weights.iter().enumerate().take(throughput.len()) {
                    let e = throughput.get(i).max(0.0) * w;
                    energy += e;
                    energy_r += e * fresnel_dielectric(wo.z, relative(self.ior.at(i), ctx));
                }
                if !(energy > 0.0) {
                    return false;
                }
                (energy_r / energy).clamp(0.0, 1.0)
            }
        };
        let p = if reflected { r_event } else { 1.0 - r_event };
        if !(p > 0.0) {
            return false;
        }
        for i in 0..out.len() {
            let eta = relative(self.ior.at(i), ctx);
            let r = fresnel_dielectric(wo.z, eta);
            let v = if reflected {
                r
            } else {
                refract(wo, Vec3A::Z, eta).map_or(0.0, |(_, etap)| (1.0 - r) * radiance_scale(ctx, etap))
            };
            out.set(i, v / p);
        }
        true
    }
}

/// A rough dielectric interface (GGX microfacets; Walter et al. 2007, pbrt-v4 §9.7).
///
/// **Multiple scattering** (`multiscatter`, Blender's default Multiscatter GGX): the
/// single-scattering lobe loses the light that bounces more than once between the
/// microfacets (up to ~13 % at roughness 1 and grazing view). As Cycles'
/// `microfacet_ggx_preserve_energy` (intern/cycles/kernel/closure/bsdf_microfacet.h,
/// CLOSURE_BSDF_MICROFACET_GGX_GLASS_ID), reflection and refraction are both scaled by
/// `energy_scale` = 1/E(μ, η), E the tabulated directional albedo of the interface
/// (reflection + refraction, energy: [`super::energy::glass_e`], Cycles' `ggx_glass_E`
/// and `ggx_glass_inv_E` for η < 1), looked up with the relative index seen from the
/// view side and μ the cosine of the view direction: `wo` on camera paths, `wi` on light
/// paths (the adjoint, as [`super::layer`] does), so both tracing directions render the
/// same image. Dispersive glass takes the factor per wavelength at that wavelength's own
/// index. The pdf is unchanged (the scale is not sampled), so MIS and χ² still hold;
/// reciprocity holds for the single-scattering part only (the factor depends on the view
/// direction, as in Cycles).
///
/// When dispersive and carrying the whole spectrum, `eval` returns zero (no next-event
/// estimation through this vertex) and `sample` reports `specular: true`, so the
/// integrator counts light reached by the sampled direction in full without MIS: the
/// direction's density differs per wavelength and a single MIS weight would be biased.
/// Once collapsed, the path sees an ordinary single-wavelength rough dielectric.
pub struct RoughDielectric {
    pub ior: IndexOfRefraction,
    pub distribution: Ggx,
    /// Multiple-scattering energy compensation (Blender's Multiscatter GGX).
    pub multiscatter: bool,
}

/// The cosine of the view direction and the relative index seen from its side, for the
/// energy tables: `wo` on camera paths, `wi` on light paths; `eta` is the relative index
/// crossed from the local frame's +z side (as `refract` and `eval_eta` take it).
#[inline]
pub fn view_side(ctx: &ShadingContext, eta: f32, wo: Vec3A, wi: Vec3A) -> (f32, f32) {
    let view = match ctx.mode {
        TransportMode::Radiance => wo,
        TransportMode::Importance => wi,
    };
    (view.z.abs().min(1.0), if view.z >= 0.0 { eta } else { 1.0 / eta })
}

impl RoughDielectric {
    /// A rough dielectric with multiple-scattering compensation (Blender's default).
    pub fn new(ior: IndexOfRefraction, distribution: Ggx) -> Self {
        Self { ior, distribution, multiscatter: true }
    }

    /// 1/E(μ, η): Cycles' `energy_scale` of a white glass (F_ss = 1), for relative index
    /// `eta` from the +z side; 1 without `multiscatter`.
    #[inline]
    pub fn energy_scale(&self, ctx: &ShadingContext, eta: f32, wo: Vec3A, wi: Vec3A) -> f32 {
        if !self.multiscatter {
            return 1.0;
        }
        let (mu, eta_view) = view_side(ctx, eta, wo, wi);
        glass_compensation(self.distribution.roughness(), mu, eta_view, 1.0)
    }

    /// f·|cos θi| and the pdf for a relative index `eta` (pbrt-v4 DielectricBxDF::f/PDF).
    fn eval_eta(&self, ctx: &ShadingContext, eta: f32, wo: Vec3A, wi: Vec3A) -> (f32, f32) {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o == 0.0 || cos_i == 0.0 {
            return (0.0, 0.0);
        }
        let (fc, pdf) = if cos_o * cos_i > 0.0 {
            let mut wm = wi + wo;
            if wm.length_squared() == 0.0 {
                return (0.0, 0.0);
            }
            wm = wm.normalize();
            if wm.z < 0.0 {
                wm = -wm;
            }
            // Discard back-facing microfacets.
            if wm.dot(wi) * cos_i < 0.0 || wm.dot(wo) * cos_o < 0.0 {
                return (0.0, 0.0);
            }
            let g = &self.distribution;
            let r = fresnel_dielectric(wo.dot(wm), eta);
            let dvis = g.g1(wo) / cos_o.abs() * g.d(wm) * wo.dot(wm).abs();
            let f = g.d(wm) * g.g(wo, wi) * r / (4.0 * cos_i * cos_o).abs();
            (f * cos_i.abs(), dvis / (4.0 * wo.dot(wm).abs()) * r)
        } else {
            let etap = if cos_o > 0.0 { eta } else { 1.0 / eta };
            let m = Distribution::Ggx(self.distribution);
            microfacet_transmission(ctx, &m, etap, wo, wi, |c| 1.0 - fresnel_dielectric(c, eta))
        };
        let fc = fc * self.energy_scale(ctx, eta, wo, wi);
        if fc.is_finite() && pdf.is_finite() {
            (fc, pdf)
        } else {
            (0.0, 0.0)
        }
    }
}

impl Bsdf for RoughDielectric {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::GLOSSY | crate::geometry::visibility::TRANSMISSION
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: true, specular: false, dispersive: self.ior.dispersive }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let Some(n) = common_index(&self.ior, ctx) else {
            out.fill(0.0);
            return 0.0;
        };
        let (f, pdf) = self.eval_eta(ctx, relative(n, ctx), wo, wi);
        out.fill(f);
        pdf
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        match common_index(&self.ior, ctx) {
            Some(n) => self.eval_eta(ctx, relative(n, ctx), wo, wi).1,
            None => 0.0,
        }
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let g = &self.distribution;
        let wm = g.sample_wm(wo, u);
        let c = wo.dot(wm);
        let dvis = g.g1(wo) / wo.z.abs() * g.d(wm) * c.abs();
        if !(dvis > 0.0 && dvis.is_finite()) {
            return None;
        }
        if let Some(n) = common_index(&self.ior, ctx) {
            let eta = relative(n, ctx);
            let r = fresnel_dielectric(c, eta);
            if uc < r {
                let wi = reflect(wo, wm);
                if wi.z * wo.z <= 0.0 {
                    return None;
                }
                throughput.scale(g.g(wo, wi) / g.g1(wo) * self.energy_scale(ctx, eta, wo, wi));
                return Some(BsdfSample { wi, pdf: dvis / (4.0 * c.abs()) * r, specular: false, collapsed_to: None });
            }
            let (wi, etap) = refract(wo, wm, eta)?;
            if wi.z * wo.z >= 0.0 || wi.z == 0.0 {
                return None;
            }
            let denom = (wi.dot(wm) + c / etap).powi(2);
            let pdf = dvis * wi.dot(wm).abs() / denom * (1.0 - r);
            if !(pdf > 0.0 && pdf.is_finite()) {
                return None;
            }
            throughput.scale(g.g(wo, wi) / g.g1(wo) * radiance_scale(ctx, etap) * self.energy_scale(ctx, eta, wo, wi));
            return Some(BsdfSample { wi, pdf, specular: false, collapsed_to: None });
        }
        // Dispersive glass, polychromatic ray: same lobe choice as the smooth case, on
        // the sampled microfacet.
        let len = throughput.len();
        let weights = ctx.grid.weights();
        let mut r = vec![0.0f32; len];
        let mut transmitted = vec![0.0f32; len];
        let (mut energy, mut energy_r) = (0.0f32, 0.0f32);
        for i in 0..len {
            r[i] = fresnel_dielectric(c, relative(self.ior.at(i), ctx));
            let e = throughput.get(i).max(0.0) * weights[i];
            energy += e;
            energy_r += e * r[i];
            transmitted[i] = e * (1.0 - r[i]);
        }
        if !(energy > 0.0) {
            return None;
        }
        let uc = ctx.collapse_u.unwrap_or(uc);
        let r_mean = (energy_r / energy).clamp(0.0, 1.0);
        if uc < r_mean {
            let wi = reflect(wo, wm);
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            let gr = g.g(wo, wi) / g.g1(wo);
            for (i, v) in throughput.values_mut().iter_mut().enumerate() {
                let eta = relative(self.ior.at(i), ctx);
                *v *= gr * r[i] / r_mean * self.energy_scale(ctx, eta, wo, wi);
            }
            let pdf = dvis / (4.0 * c.abs()) * r_mean;
            return Some(BsdfSample { wi, pdf, specular: true, collapsed_to: None });
        }
        let u2 = ((uc - r_mean) / (1.0 - r_mean)).clamp(0.0, 0.999_999_9);
        let (i, p) = pick_lane(&transmitted, u2)?;
        let eta = relative(self.ior.at(i), ctx);
        let (wi, etap) = refract(wo, wm, eta)?;
        if wi.z * wo.z >= 0.0 || wi.z == 0.0 {
            return None;
        }
        let w = g.g(wo, wi) / g.g1(wo) * (1.0 - r[i]) / ((1.0 - r_mean) * p)
            * radiance_scale(ctx, etap)
            * self.energy_scale(ctx, eta, wo, wi);
        if !w.is_finite() {
            return None;
        }
        throughput.keep_only(i);
        throughput.set(i, throughput.get(i) * w);
        let denom = (wi.dot(wm) + c / etap).powi(2);
        let pdf = dvis * wi.dot(wm).abs() / denom * (1.0 - r_mean) * p;
        Some(BsdfSample { wi, pdf, specular: true, collapsed_to: Some(i) })
    }
    fn albedo(&self, _: &ShadingContext, out: &mut SampledSpectrum) {
        out.fill(1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::dispersion::IorDesc;
    use crate::sampling::Rng;
    use crate::spectrum::WavelengthGrid;

    fn glass(grid: &WavelengthGrid, desc: IorDesc) -> IndexOfRefraction {
        IndexOfRefraction::build(&desc, grid, "glass").unwrap()
    }

    /// Energy: reflected + transmitted importance (no 1/η² scaling) averages to 1 for
    /// a smooth interface, and the split matches Fresnel.
    #[test]
    fn smooth_split_matches_fresnel() {
        let grid = WavelengthGrid::default();
        let m = Dielectric { ior: glass(&grid, IorDesc::Constant { ior: 1.5 }) };
        assert!(!m.flags().dispersive);
        let mut ctx = ShadingContext::new(&grid);
        ctx.mode = TransportMode::Importance;
        let wo = Vec3A::new(0.6f32.sin(), 0.0, 0.6f32.cos());
        let r = fresnel_dielectric(wo.z, 1.5);
        let mut rng = Rng::new(1, 2);
        let (mut refl, n) = (0usize, 20_000usize);
        for _ in 0..n {
            let mut tp = SampledSpectrum::splat(grid.len(), 1.0);
            let s = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp).unwrap();
            assert!(s.collapsed_to.is_none());
            assert!((tp.get(3) - 1.0).abs() < 1e-6);
            if s.wi.z > 0.0 {
                refl += 1;
            }
        }
        let frac = refl as f64 / n as f64;
        let se = (r as f64 * (1.0 - r as f64) / n as f64).sqrt();
        assert!((frac - r as f64).abs() < 5.0 * se, "{frac} vs {r}");
    }

    /// Collapse at a dispersive glass keeps every lane's expected throughput equal to
    /// R_λ + T_λ/η_λ² (unbiased), and each collapse keeps one lane.
    #[test]
    fn collapse_is_unbiased_per_wavelength() {
        let grid = WavelengthGrid::uniform(9, 380.0, 780.0).unwrap();
        let ior = glass(&grid, IorDesc::Named { name: "N-SF11".into() });
        let m = Dielectric { ior: ior.clone() };
        assert!(m.flags().dispersive);
        let ctx = ShadingContext::new(&grid);
        let wo = Vec3A::new(0.8f32.sin(), 0.0, 0.8f32.cos());
        let beta: Vec<f32> = (0..9).map(|i| 0.2 + 0.1 * i as f32).collect();
        let mut sum = [0.0f64; 9];
        let mut rng = Rng::new(3, 4);
        let n = 200_000;
        let mut collapses = 0;
        for _ in 0..n {
            let mut tp = SampledSpectrum::from_slice(&beta);
            let s = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp).unwrap();
            if let Some(i) = s.collapsed_to {
                collapses += 1;
                assert!(tp.values().iter().enumerate().all(|(k, &v)| k == i || v == 0.0));
                assert!(s.wi.z < 0.0);
            } else {
                assert!(s.wi.z > 0.0);
            }
            for k in 0..9 {
                sum[k] += tp.get(k) as f64;
            }
        }
        assert!(collapses > n / 2);
        for k in 0..9 {
            let eta = ior.at(k);
            let r = fresnel_dielectric(wo.z, eta) as f64;
            let expected = beta[k] as f64 * (r + (1.0 - r) / (eta as f64 * eta as f64));
            let got = sum[k] / n as f64;
            assert!((got - expected).abs() < 0.02 * expected, "lane {k}: {got} vs {expected}");
        }
        // Single-wavelength mode refracts with that lane's index and never collapses.
        let mut ctx1 = ShadingContext::new(&grid);
        ctx1.single_wavelength = Some(2);
        let mut tp = SampledSpectrum::splat(9, 1.0);
        let s = m.sample(&ctx1, wo, Vec2::ZERO, 0.99, &mut tp).unwrap();
        assert!(s.collapsed_to.is_none());
        let sin_t = (s.wi.x * s.wi.x + s.wi.y * s.wi.y).sqrt();
        assert!((wo.x - ior.at(2) * sin_t).abs() < 1e-5);
    }

    /// The aux pass's per-wavelength weights of the event `sample` chose have the
    /// expectation R_λ + T_λ/η_λ² at every lane, each with its own index, whether the ray
    /// arrives with the whole spectrum (and collapses) or carries one wavelength, from
    /// outside or inside.
    #[test]
    fn specular_weights_are_unbiased_per_wavelength() {
        let grid = WavelengthGrid::uniform(9, 380.0, 780.0).unwrap();
        let ior = glass(&grid, IorDesc::Named { name: "N-SF11".into() });
        let m = Dielectric { ior: ior.clone() };
        let wo = Vec3A::new(0.5f32.sin(), 0.0, 0.5f32.cos());
        let beta: Vec<f32> = (0..9).map(|i| 0.2 + 0.1 * i as f32).collect();
        for single in [None, Some(6)] {
            for front in [true, false] {
                let mut ctx = ShadingContext::new(&grid);
                ctx.single_wavelength = single;
                ctx.front_face = front;
                let mut rng = Rng::new(5, 6);
                let n = 100_000;
                let mut sum = [0.0f64; 9];
                let mut w = SampledSpectrum::zeros(9);
                for _ in 0..n {
                    let before = SampledSpectrum::from_slice(&beta);
                    let mut tp = before.clone();
                    let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) else { continue };
                    assert!(m.specular_weights(&ctx, wo, s.wi, &before, &mut w));
                    for (k, acc) in sum.iter_mut().enumerate() {
                        *acc += w.get(k) as f64;
                    }
                }
                for (k, &got) in sum.iter().enumerate() {
                    let eta = if front { ior.at(k) } else { 1.0 / ior.at(k) };
                    let r = fresnel_dielectric(wo.z, eta) as f64;
                    let t = if r < 1.0 { (1.0 - r) / (eta as f64 * eta as f64) } else { 0.0 };
                    let (got, expected) = (got / n as f64, r + t);
                    assert!(
                        (got - expected).abs() < 0.01 * expected,
                        "{single:?} {front} lane {k}: {got} vs {expected}"
                    );
                }
            }
        }
    }

    /// White furnace for the single-scattering rough dielectric: reflected + transmitted
    /// importance ≤ 1; and, with and without the multiple-scattering compensation, the
    /// sampled estimate agrees with a quadrature of eval over the sphere (sample's weight
    /// is eval/pdf).
    #[test]
    fn rough_dielectric_energy_at_most_one_and_sampling_matches_eval() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        for (multiscatter, mode, roughnesses) in [
            (false, TransportMode::Importance, &[0.3f32, 0.7][..]),
            (true, TransportMode::Importance, &[0.7][..]),
            (true, TransportMode::Radiance, &[0.7][..]),
        ] {
            for &front in &[true, false] {
                let mut ctx = ShadingContext::new(&grid);
                ctx.mode = mode;
                ctx.front_face = front;
                for &roughness in roughnesses {
                    let m = RoughDielectric {
                        ior: IndexOfRefraction::constant(4, 1.5),
                        distribution: Ggx::from_roughness(roughness),
                        multiscatter,
                    };
                    for &theta in &[0.2f32, 0.9, 1.4] {
                        let wo = Vec3A::new(theta.sin(), 0.0, theta.cos());
                        let mut rng = Rng::new(9, theta.to_bits() as u64);
                        let n = 40_000;
                        let (mut s1, mut s2) = (0.0f64, 0.0f64);
                        for _ in 0..n {
                            let mut tp = SampledSpectrum::splat(4, 1.0);
                            if let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                                assert!(tp.is_finite() && s.pdf > 0.0);
                                // The returned pdf is the one pdf() reports.
                                let p = m.pdf(&ctx, wo, s.wi);
                                assert!((p - s.pdf).abs() <= 1e-3 * s.pdf.max(1.0), "{p} vs {}", s.pdf);
                                let v = tp.get(0) as f64;
                                s1 += v;
                                s2 += v * v;
                            }
                        }
                        let mean = s1 / n as f64;
                        let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
                        if !multiscatter {
                            assert!(mean <= 1.0 + 4.0 * se + 1e-3, "front {front} r {roughness} θ {theta}: {mean}");
                        }
                        let (nt, np) = (2000, 400);
                        let mut q = 0.0f64;
                        let mut f = SampledSpectrum::zeros(4);
                        for i in 0..nt {
                            let c = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
                            for j in 0..np {
                                let phi = 6.2831855 * (j as f32 + 0.5) / np as f32;
                                let s = (1.0 - c * c).max(0.0).sqrt();
                                let wi = Vec3A::new(s * phi.cos(), s * phi.sin(), c);
                                m.eval(&ctx, wo, wi, &mut f);
                                q += f.get(0) as f64 * 4.0 * std::f64::consts::PI / (nt * np) as f64;
                            }
                        }
                        assert!(
                            (q - mean).abs() < 5.0 * se + 0.02,
                            "front {front} r {roughness} θ {theta}: sampled {mean} ± {se}, quadrature {q}"
                        );
                    }
                }
            }
        }
    }

    /// Energy of one sampled event, in the radiance mode that camera paths use: the
    /// weight with a refraction's 1/η² undone (η the relative index crossed, per lane).
    fn energy_weight(
        ctx: &ShadingContext,
        ior: &IndexOfRefraction,
        wo: Vec3A,
        s: &BsdfSample,
        tp: &SampledSpectrum,
        k: usize,
    ) -> f64 {
        let v = tp.get(k) as f64;
        if s.wi.z * wo.z < 0.0 {
            let eta = relative(ior.at(k), ctx) as f64;
            v * eta * eta
        } else {
            v
        }
    }

    /// White furnace of rough glass with Multiscatter GGX (Cycles'
    /// `microfacet_ggx_preserve_energy`): reflected + transmitted energy is 1 within
    /// noise and the tables' interpolation, from outside and inside, over roughness
    /// 0.2..1 and IOR 1.1..2 at normal to grazing view; without the compensation the
    /// same lobe loses energy (the deficit it restores is asserted to be real, ≥ 5 % at
    /// roughness 1, grazing).
    #[test]
    fn rough_glass_white_furnace_is_one_with_multiscatter() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let n = 20_000;
        let mut worst = (0.0f64, String::new());
        let (mut max_loss, mut max_loss_outside) = (0.0f64, 0.0f64);
        for &ior in &[1.1f32, 1.5, 2.0] {
            for &roughness in &[0.2f32, 0.5, 0.8, 1.0] {
                for &front in &[true, false] {
                    for &cos in &[0.95f32, 0.5, 0.15] {
                        let mut ctx = ShadingContext::new(&grid);
                        ctx.front_face = front;
                        let wo = crate::material::testing::dir(cos, 0.3);
                        let mut means = [0.0f64; 2];
                        for (slot, multiscatter) in [(0usize, false), (1, true)] {
                            let m = RoughDielectric {
                                ior: IndexOfRefraction::constant(4, ior),
                                distribution: Ggx::from_roughness(roughness),
                                multiscatter,
                            };
                            let mut rng = Rng::new(21, (ior.to_bits() ^ roughness.to_bits() ^ cos.to_bits()) as u64);
                            let (mut s1, mut s2) = (0.0f64, 0.0f64);
                            for _ in 0..n {
                                let mut tp = SampledSpectrum::splat(4, 1.0);
                                if let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                                    let v = energy_weight(&ctx, &m.ior, wo, &s, &tp, 0);
                                    s1 += v;
                                    s2 += v * v;
                                }
                            }
                            let mean = s1 / n as f64;
                            let se = ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                            means[slot] = mean;
                            if multiscatter {
                                let err = (mean - 1.0).abs();
                                let label = format!("η {ior} r {roughness} front {front} μ {cos}: {mean:.4} ± {se:.4}");
                                assert!(err < 4.0 * se + 0.015, "{label}");
                                if err > worst.0 {
                                    worst = (err, label);
                                }
                            }
                        }
                        max_loss = max_loss.max(1.0 - means[0]);
                        if front {
                            max_loss_outside = max_loss_outside.max(1.0 - means[0]);
                        }
                        assert!(means[1] >= means[0] - 1e-9);
                    }
                }
            }
        }
        eprintln!(
            "worst furnace error with multiscatter: {worst:?}; largest single-scattering loss {max_loss:.4} \
             ({max_loss_outside:.4} from outside)"
        );
        assert!(max_loss > 0.05, "single scattering loses {max_loss}");
    }

    /// Dispersive rough glass (N-SF11, polychromatic rays that collapse on refraction):
    /// every wavelength's energy is 1 within noise, each compensated at its own index.
    #[test]
    fn dispersive_rough_glass_furnace_is_one_per_wavelength() {
        let grid = WavelengthGrid::uniform(9, 380.0, 780.0).unwrap();
        let ior = glass(&grid, IorDesc::Named { name: "N-SF11".into() });
        let m = RoughDielectric::new(ior.clone(), Ggx::from_roughness(0.8));
        assert!(m.flags().dispersive);
        for front in [true, false] {
            let mut ctx = ShadingContext::new(&grid);
            ctx.front_face = front;
            let wo = crate::material::testing::dir(0.4, 0.0);
            let n = 100_000;
            let (mut s1, mut s2) = ([0.0f64; 9], [0.0f64; 9]);
            let mut rng = Rng::new(7, 8);
            for _ in 0..n {
                let mut tp = SampledSpectrum::splat(9, 1.0);
                if let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                    for k in 0..9 {
                        let v = energy_weight(&ctx, &ior, wo, &s, &tp, k);
                        s1[k] += v;
                        s2[k] += v * v;
                    }
                }
            }
            for k in 0..9 {
                let mean = s1[k] / n as f64;
                let se = ((s2[k] / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(
                    (mean - 1.0).abs() < 4.0 * se + 0.015,
                    "front {front} lane {k} (n {}): {mean} ± {se}",
                    ior.at(k)
                );
            }
        }
    }

    /// Camera paths and light paths see the same compensated BSDF: f evaluated in
    /// radiance mode at (view wo, light wi) and in importance mode at (light, view) have
    /// the ratio of the single-scattering lobe's own reciprocity (1 for reflection, 1 or
    /// η^±2 for refraction: the 1/η² of radiance transport).
    #[test]
    fn compensated_glass_is_the_same_bsdf_in_both_directions() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let mut rng = Rng::new(31, 1);
        let mut checked = 0;
        for &front in &[true, false] {
            let eta = if front { 1.5f32 } else { 1.0 / 1.5 };
            let (mut cr, mut ci) = (ShadingContext::new(&grid), ShadingContext::new(&grid));
            cr.front_face = front;
            ci.front_face = front;
            ci.mode = TransportMode::Importance;
            let ms = RoughDielectric::new(IndexOfRefraction::constant(4, 1.5), Ggx::from_roughness(0.6));
            let ss = RoughDielectric {
                multiscatter: false,
                ..RoughDielectric::new(IndexOfRefraction::constant(4, 1.5), Ggx::from_roughness(0.6))
            };
            let mut f = SampledSpectrum::zeros(4);
            for _ in 0..400 {
                let wo =
                    crate::material::testing::dir(0.05 + 0.95 * rng.uniform(), rng.uniform() * std::f32::consts::TAU);
                let mut wi =
                    crate::material::testing::dir(0.05 + 0.95 * rng.uniform(), rng.uniform() * std::f32::consts::TAU);
                if rng.uniform() < 0.5 {
                    wi.z = -wi.z;
                }
                let mut fv = |m: &RoughDielectric, ctx: &ShadingContext, a: Vec3A, b: Vec3A| {
                    m.eval(ctx, a, b, &mut f);
                    f.get(0) / b.z.abs()
                };
                let (rad_ss, imp_ss) = (fv(&ss, &cr, wo, wi), fv(&ss, &ci, wi, wo));
                if !(rad_ss > 1e-4 && imp_ss > 1e-4) {
                    continue;
                }
                let ratio = rad_ss / imp_ss;
                let expected = if wi.z > 0.0 { [1.0f32, 1.0, 1.0] } else { [1.0, eta * eta, 1.0 / (eta * eta)] };
                assert!(
                    expected.iter().any(|e| (ratio - e).abs() < 1e-2 * e),
                    "single scattering ratio {ratio} (η {eta}, wi {wi:?})"
                );
                let (rad, imp) = (fv(&ms, &cr, wo, wi), fv(&ms, &ci, wi, wo));
                assert!(rad > rad_ss, "compensation raises the lobe");
                assert!((rad / imp - ratio).abs() < 2e-3 * ratio, "{} vs {ratio}", rad / imp);
                checked += 1;
            }
        }
        assert!(checked > 200, "{checked}");
    }

    /// χ² of sample() against pdf() with the compensation (the scale is not sampled,
    /// the directions and pdf are those of the single-scattering lobe).
    #[test]
    fn compensated_glass_sampling_matches_pdf_chi_square() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        for (front, r, cos) in [(true, 0.5f32, 0.7f32), (false, 0.9, 0.4)] {
            let mut ctx = ShadingContext::new(&grid);
            ctx.front_face = front;
            let m = RoughDielectric::new(IndexOfRefraction::constant(4, 1.5), Ggx::from_roughness(r));
            crate::material::testing::chi_square(&m, &ctx, crate::material::testing::dir(cos, 0.0), 100_000, 4);
        }
    }
}
