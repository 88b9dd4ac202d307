//! The Principled BSDF's upper layers, stacked as Cycles stacks its closures
//! (`svm_node_closure_bsdf`, intern/cycles/kernel/svm/closure.h, Blender 4.5): the sheen
//! on top, then the coat, then everything else. A layer does not trace light between the
//! layers; it scales the BSDF below by what it leaves over, seen from the view direction:
//!
//! ```text
//! f = f_top + T(μv) · f_bottom
//! T(μv) = 1 − w·max_λ A_top(μv)                       (closure_layering_weight)
//!       × mix(1, tint^(1/cos θt(μv)), w)              (coat only: Beer's law through a coat of
//!                                                      unit thickness, θt refracted by the coat)
//! ```
//!
//! with w the layer's weight and A_top the top lobe's directional albedo: the microfibre
//! sheen's fitted albedo ([`super::sheen`]) times its tint, or the coat's GGX reflection
//! with dielectric Fresnel at the coat's IOR (the [`super::energy`] tables) with its
//! multiple scattering: Cycles' `bsdf_microfacet_setup_fresnel_dielectric` always calls
//! `microfacet_ggx_preserve_energy` with F_ss = `fresnel_dielectric_Fss(ior)`, which
//! scales the single-scattering coat lobe by 1 + F_ms·(1 − E(μv))/E(μv) (E the GGX albedo
//! for F = 1), and `bsdf_albedo` (through `bsdf_microfacet_estimate_albedo`, whose
//! `ggx_gen_schlick_ior_s` table is the Fresnel-weighted albedo over E) is then the
//! compensated lobe's albedo. μv is the cosine of the direction
//! towards the camera: `wo` on camera paths, `wi` on light paths (the adjoint), so both
//! tracing directions render the same image. A white layer over a white Lambertian base
//! reflects everything (A + (1 − A)·1 = 1).
//!
//! Sampling picks the top or the bottom in proportion to their estimated albedos at wo;
//! a non-delta sample is weighted by the whole f over the mixture pdf (so `sample`,
//! `eval` and `pdf` agree for MIS), a delta or wavelength-collapsing sample by its own
//! lobe's weight over its selection probability.

use super::conductor::{MetalFresnel, MicrofacetReflection};
use super::energy::{dielectric_e, fresnel_avg, reflection_compensation};
use super::fresnel::fresnel_dielectric;
use super::oriented::{same_event, LobeFrame};
use super::sheen::{Sheen, SheenLtc};
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam, TransportMode};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// Dielectric Fresnel of a coat (light arrives from outside, relative index `eta`).
pub struct DielectricFresnel {
    pub eta: f32,
}

impl MetalFresnel for DielectricFresnel {
    fn eval(&self, _: &ShadingContext, cos: f32, out: &mut SampledSpectrum) {
        out.fill(fresnel_dielectric(cos.abs(), self.eta));
    }
}

#[inline]
fn clamp_unit(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The lobe on top of a [`Layered`] BSDF.
pub enum TopLobe {
    /// Principled Sheen: Weight, Tint, Roughness.
    Sheen { weight: f32, sheen: Sheen },
    /// Principled Coat: Weight, Roughness, IOR (≥ 1), Tint.
    Coat { weight: f32, ior: f32, roughness: f32, tint: SpectralParam, lobe: MicrofacetReflection<DielectricFresnel> },
}

impl TopLobe {
    pub fn sheen(weight: f32, tint: SpectralParam, roughness: f32) -> Self {
        let roughness = clamp_unit(roughness);
        TopLobe::Sheen { weight: weight_of(weight), sheen: Sheen { color: tint, roughness } }
    }
    pub fn coat(weight: f32, roughness: f32, ior: f32, tint: SpectralParam) -> Self {
        let ior = if ior.is_finite() { ior.max(1.0) } else { 1.5 };
        let roughness = clamp_unit(roughness);
        TopLobe::Coat {
            weight: weight_of(weight),
            ior,
            roughness,
            tint,
            lobe: MicrofacetReflection::new(DielectricFresnel { eta: ior }, roughness),
        }
    }
    fn weight(&self) -> f32 {
        match self {
            TopLobe::Sheen { weight, .. } | TopLobe::Coat { weight, .. } => *weight,
        }
    }
    fn bsdf(&self) -> &dyn Bsdf {
        match self {
            TopLobe::Sheen { sheen, .. } => sheen,
            TopLobe::Coat { lobe, .. } => lobe,
        }
    }
    /// What scales the top lobe's own BSDF seen from cosine `mu` (the view side): the
    /// coat's multiple-scattering compensation (Cycles' `microfacet_ggx_preserve_energy`:
    /// energy_scale·darkening = 1 + F_ms·(1 − E)/E), 1 for the sheen.
    fn lobe_scale(&self, mu: f32) -> f32 {
        match self {
            TopLobe::Sheen { .. } => 1.0,
            TopLobe::Coat { ior, roughness, .. } => {
                reflection_compensation(*roughness, mu.abs().min(1.0), fresnel_avg(*ior))
            }
        }
    }
    /// The top lobe's albedo per lane at cosine `mu` (before its weight) into `out`.
    fn albedo_at(&self, ctx: &ShadingContext, mu: f32, out: &mut SampledSpectrum) {
        match self {
            TopLobe::Sheen { sheen, .. } => {
                sheen.color.evaluate_into(ctx, out);
                out.scale(SheenLtc::albedo(sheen.roughness, mu));
            }
            TopLobe::Coat { ior, roughness, .. } => {
                out.fill((dielectric_e(*roughness, mu, *ior) * self.lobe_scale(mu)).min(1.0))
            }
        }
    }
    /// T(μ) per lane: what the layer leaves to the BSDF below, seen from `mu`.
    fn transmittance(&self, ctx: &ShadingContext, mu: f32, out: &mut SampledSpectrum) {
        let w = self.weight();
        let mu = mu.abs().min(1.0);
        self.albedo_at(ctx, mu, out);
        let keep = clamp_unit(1.0 - w * out.max_value());
        match self {
            TopLobe::Sheen { .. } => out.fill(keep),
            TopLobe::Coat { ior, tint, .. } => {
                tint.evaluate_into(ctx, out);
                let cos_t = (1.0 - (1.0 - mu * mu) / (ior * ior)).max(1e-6).sqrt();
                let depth = 1.0 / cos_t;
                for v in out.values_mut() {
                    let t = if v.is_finite() { v.max(0.0) } else { 0.0 };
                    let through = if t == 1.0 { 1.0 } else { t.powf(depth) };
                    *v = keep * (1.0 + w * (through - 1.0));
                }
            }
        }
    }
}

fn weight_of(w: f32) -> f32 {
    if w.is_finite() {
        w.max(0.0)
    } else {
        0.0
    }
}

/// A top lobe over a bottom BSDF (see the module documentation).
pub struct Layered {
    pub top: TopLobe,
    pub bottom: Box<dyn Bsdf>,
    /// The top lobe's own normal (Principled Coat Normal; the sheen's mix of it and the
    /// Normal, Cycles' svm_node_closure_bsdf), in this BSDF's frame: the top lobe, its
    /// albedo and its tint's path length are all taken about it (None: about +z).
    pub frame: Option<LobeFrame>,
}

impl Layered {
    pub fn new(top: TopLobe, bottom: Box<dyn Bsdf>) -> Self {
        Self { top, bottom, frame: None }
    }

    /// The top lobe oriented about `n` (this BSDF's frame).
    pub fn with_top_normal(mut self, n: Option<Vec3A>) -> Self {
        self.frame = n.map(LobeFrame::new);
        self
    }

    #[inline]
    fn top_view(&self, wo: Vec3A) -> Vec3A {
        self.frame.map_or(wo, |f| f.view_to_lobe(wo))
    }

    #[inline]
    fn top_dir(&self, wi: Vec3A) -> Vec3A {
        self.frame.map_or(wi, |f| f.to_lobe(wi))
    }

    /// The top lobe's pair in its frame, None when its frame and this one disagree
    /// about reflection and transmission (`oriented::same_event`).
    #[inline]
    fn top_pair(&self, wo: Vec3A, wi: Vec3A) -> Option<(Vec3A, Vec3A)> {
        let (a, b) = (self.top_view(wo), self.top_dir(wi));
        (self.frame.is_none() || same_event(wo, wi, a, b)).then_some((a, b))
    }

    /// The camera side's cosine about the top lobe's normal.
    #[inline]
    fn top_view_cos(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        match ctx.mode {
            TransportMode::Radiance => self.top_view(wo).z,
            TransportMode::Importance => self.top_dir(wi).z,
        }
    }

    /// Probability of sampling the top lobe from `wo`.
    fn top_probability(&self, ctx: &ShadingContext, wo: Vec3A) -> f32 {
        let w = self.top.weight();
        if w <= 0.0 {
            return 0.0;
        }
        let n = ctx.grid.len();
        let mut a = SampledSpectrum::zeros(n);
        let mu = self.top_view(wo).z.abs();
        self.top.albedo_at(ctx, mu, &mut a);
        let top = (w * mean(ctx, &a)).min(1.0);
        self.top.transmittance(ctx, mu, &mut a);
        let t = mean(ctx, &a);
        self.bottom.albedo(ctx, &mut a);
        let bottom = t * mean(ctx, &a);
        let total = top + bottom;
        if !(total > 0.0 && total.is_finite()) {
            return 0.5;
        }
        (top / total).clamp(0.05, 0.95)
    }

    /// f·|cos θi| into `out` and the mixture pdf, with the top chosen with `p_top`.
    fn eval_with(&self, ctx: &ShadingContext, p_top: f32, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let n = out.len();
        let mut f = SampledSpectrum::zeros(n);
        let pdf_b = self.bottom.eval(ctx, wo, wi, out);
        let mu = self.top_view_cos(ctx, wo, wi);
        self.top.transmittance(ctx, mu, &mut f);
        out.mul_assign(&f);
        let Some((a, b)) = self.top_pair(wo, wi) else { return (1.0 - p_top) * pdf_b };
        let pdf_t = self.top.bsdf().eval(ctx, a, b, &mut f);
        out.add_scaled(&f, self.top.weight() * self.top.lobe_scale(mu));
        p_top * pdf_t + (1.0 - p_top) * pdf_b
    }
}

/// Mean over the lanes the path carries.
fn mean(ctx: &ShadingContext, s: &SampledSpectrum) -> f32 {
    match ctx.single_wavelength {
        Some(i) => s.get(i),
        None => s.sum() / s.len().max(1) as f32,
    }
}

impl Bsdf for Layered {
    fn lobe_kinds(&self) -> u8 {
        self.top.bsdf().lobe_kinds() | self.bottom.lobe_kinds()
    }
    fn flags(&self) -> BsdfFlags {
        let (t, b) = (self.top.bsdf().flags(), self.bottom.flags());
        BsdfFlags { smooth: t.smooth || b.smooth, specular: t.specular || b.specular, dispersive: b.dispersive }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let p = self.top_probability(ctx, wo);
        self.eval_with(ctx, p, wo, wi, out)
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        let p = self.top_probability(ctx, wo);
        let pdf_t = match self.top_pair(wo, wi) {
            Some((a, b)) if p > 0.0 => self.top.bsdf().pdf(ctx, a, b),
            _ => 0.0,
        };
        p * pdf_t + (1.0 - p) * self.bottom.pdf(ctx, wo, wi)
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        let p = self.top_probability(ctx, wo);
        let n = throughput.len();
        let choose_top = uc < p;
        let (lobe, prob, uc) =
            if choose_top { (self.top.bsdf(), p, uc / p) } else { (&*self.bottom, 1.0 - p, (uc - p) / (1.0 - p)) };
        let mut tp = throughput.clone();
        let s = if choose_top && self.frame.is_some() {
            let a = self.top_view(wo);
            let s = lobe.sample(ctx, a, u, uc.clamp(0.0, 0.999_999), &mut tp)?;
            let wi = self.frame.map_or(s.wi, |f| f.to_vertex(s.wi));
            if !same_event(wo, wi, a, s.wi) {
                return None;
            }
            BsdfSample { wi, ..s }
        } else {
            lobe.sample(ctx, wo, u, uc.clamp(0.0, 0.999_999), &mut tp)?
        };
        if s.specular || s.collapsed_to.is_some() {
            // The lobe's own weight over its selection probability.
            let mut k = SampledSpectrum::zeros(n);
            let mu = self.top_view_cos(ctx, wo, s.wi);
            if choose_top {
                k.fill(self.top.weight() * self.top.lobe_scale(mu));
            } else {
                self.top.transmittance(ctx, mu, &mut k);
            }
            tp.mul_assign(&k);
            tp.scale(1.0 / prob);
            if !tp.is_finite() {
                return None;
            }
            throughput.copy_from(&tp);
            return Some(BsdfSample { pdf: s.pdf * prob, ..s });
        }
        let mut f = SampledSpectrum::zeros(n);
        let pdf = self.eval_with(ctx, p, wo, s.wi, &mut f);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        f.scale(1.0 / pdf);
        if !f.is_finite() {
            return None;
        }
        throughput.mul_assign(&f);
        Some(BsdfSample { pdf, ..s })
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        let n = out.len();
        let mut t = SampledSpectrum::zeros(n);
        self.bottom.albedo(ctx, out);
        self.top.transmittance(ctx, 1.0, &mut t);
        out.mul_assign(&t);
        self.top.albedo_at(ctx, 1.0, &mut t);
        out.add_scaled(&t, self.top.weight());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::testing::{chi_square, dir, quadrature_albedo, sampled_albedo};
    use crate::material::{Diffuse, OrenNayar};
    use crate::spectrum::WavelengthGrid;

    fn grey(grid: &WavelengthGrid, v: f32) -> SpectralParam {
        SpectralParam::Constant(SampledSpectrum::splat(grid.len(), v))
    }
    fn diffuse(grid: &WavelengthGrid, v: f32) -> Box<dyn Bsdf> {
        Box::new(Diffuse { reflectance: grey(grid, v) })
    }

    /// White furnace: a white sheen or coat (smooth or rough) over a white Lambertian
    /// base reflects everything at every angle.
    #[test]
    fn white_layers_over_white_diffuse_reflect_everything() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let layers = [
            Layered::new(TopLobe::sheen(1.0, grey(&grid, 1.0), 0.5), diffuse(&grid, 1.0)),
            Layered::new(TopLobe::sheen(1.0, grey(&grid, 1.0), 0.2), diffuse(&grid, 1.0)),
            Layered::new(TopLobe::coat(1.0, 0.3, 1.5, grey(&grid, 1.0)), diffuse(&grid, 1.0)),
            Layered::new(TopLobe::coat(1.0, 0.0, 1.5, grey(&grid, 1.0)), diffuse(&grid, 1.0)),
            Layered::new(TopLobe::coat(0.6, 0.8, 2.0, grey(&grid, 1.0)), diffuse(&grid, 1.0)),
        ];
        for (k, m) in layers.iter().enumerate() {
            for &c in &[0.15f32, 0.5, 0.95] {
                let (mean, se) = sampled_albedo(m, &ctx, dir(c, 0.4), 40_000, 11 + k as u64, 1);
                // The tables interpolate E between their nodes: ~0.5 % at most.
                assert!((mean - 1.0).abs() < 4.0 * se + 8e-3, "layer {k} cos {c}: {mean} ± {se}");
            }
        }
    }

    /// The coat's tint in closed form: a smooth coat of weight 1 and tint t over a white
    /// diffuse leaves (1 − F(μ))·t^(1/cos θt) to the diffuse, whose albedo is 1.
    #[test]
    fn coat_tint_follows_beers_law_through_the_refracted_path() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let tint = SpectralParam::Constant(SampledSpectrum::from_slice(&[0.2, 0.5, 0.8, 1.0]));
        let m = Layered::new(TopLobe::coat(1.0, 0.0, 1.5, tint), diffuse(&grid, 1.0));
        for &c in &[0.3f32, 0.7, 1.0] {
            let f = fresnel_dielectric(c, 1.5);
            let cos_t = (1.0 - (1.0 - c * c) / 2.25f32).sqrt();
            for (lane, t) in [0.2f32, 0.5, 0.8, 1.0].into_iter().enumerate() {
                let expected = (1.0 - dielectric_e(0.0, c, 1.5)) * t.powf(1.0 / cos_t);
                // The smooth table's E is Fresnel to table accuracy.
                assert!((dielectric_e(0.0, c, 1.5) - f).abs() < 0.01);
                let q = quadrature_albedo(&m, &ctx, dir(c, 0.0), lane);
                assert!((q - expected as f64).abs() < 2e-3, "cos {c} lane {lane}: {q} vs {expected}");
            }
        }
    }

    #[test]
    fn sampling_matches_pdf_chi_square() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let base = || Box::new(OrenNayar::new(grey(&grid, 0.7), 0.6)) as Box<dyn Bsdf>;
        let layers = [
            Layered::new(TopLobe::sheen(0.8, grey(&grid, 0.9), 0.4), base()),
            Layered::new(TopLobe::coat(1.0, 0.35, 1.5, grey(&grid, 0.7)), base()),
        ];
        for m in &layers {
            for &(c, phi) in &[(0.8f32, 0.3f32), (0.25, 2.0)] {
                chi_square(m, &ctx, dir(c, phi), 100_000, 5);
            }
        }
    }

    /// Light paths see the adjoint, f*(wo, wi) = f(wi, wo), and their sampled weight is
    /// unbiased (mean weight = quadrature of eval).
    #[test]
    fn importance_transport_sees_the_adjoint() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let rad = ShadingContext::new(&grid);
        let mut imp = ShadingContext::new(&grid);
        imp.mode = TransportMode::Importance;
        let tint = SpectralParam::Constant(SampledSpectrum::from_slice(&[0.3, 0.6, 0.9, 1.0]));
        let layers = [
            Layered::new(TopLobe::sheen(1.0, grey(&grid, 1.0), 0.4), diffuse(&grid, 0.5)),
            Layered::new(TopLobe::coat(0.8, 0.3, 1.6, tint), diffuse(&grid, 0.8)),
        ];
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        for m in &layers {
            for &(wo, wi) in &[(dir(0.3, 0.0), dir(0.8, 2.0)), (dir(0.9, 1.0), dir(0.2, 4.0))] {
                m.eval(&imp, wo, wi, &mut a);
                m.eval(&rad, wi, wo, &mut b);
                for k in 0..4 {
                    let (fa, fb) = (a.get(k) / wi.z, b.get(k) / wo.z);
                    assert!((fa - fb).abs() < 1e-4 * fa.max(fb), "{fa} vs {fb}");
                }
            }
            let wo = dir(0.6, 0.0);
            for lane in [0, 2] {
                let (mean, se) = sampled_albedo(m, &imp, wo, 40_000, 7, lane);
                let q = quadrature_albedo(m, &imp, wo, lane);
                assert!((mean - q).abs() < 4.0 * se + 3e-3, "{mean} ± {se} vs {q}");
            }
        }
    }

    #[test]
    fn bad_inputs_stay_finite() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let nan = SpectralParam::Constant(SampledSpectrum::splat(4, f32::NAN));
        let m = Layered::new(TopLobe::coat(f32::NAN, f32::NAN, f32::NAN, nan), diffuse(&grid, 0.5));
        let mut f = SampledSpectrum::zeros(4);
        m.eval(&ctx, dir(0.5, 0.0), dir(0.6, 1.0), &mut f);
        assert!(f.is_finite());
        let m = Layered::new(TopLobe::sheen(-1.0, grey(&grid, 1.0), 7.0), diffuse(&grid, 0.5));
        m.eval(&ctx, dir(0.5, 0.0), dir(0.6, 1.0), &mut f);
        assert!(f.is_finite() && (f.get(0) - 0.5 * 0.6 / std::f32::consts::PI).abs() < 1e-5);
    }
}
