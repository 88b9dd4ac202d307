//! Blender's microfibre sheen (the Sheen BSDF's "Microfiber" model and the Principled
//! BSDF's sheen layer): the multiple-scattering sheen of Zeltner, Burley & Chiang 2022,
//! "Practical Multiple-Scattering Sheen Using Linearly Transformed Cosines", as Cycles
//! implements it (`bsdf_sheen_setup/eval/sample`, intern/cycles/kernel/closure/bsdf_sheen.h).
//!
//! The lobe is a cosine distribution warped by the linear transform M = [[a, 0, b],
//! [0, a, 0], [0, 0, 1]] in the frame whose +x is the view direction's azimuth; a, b and
//! the lobe's albedo are fitted per (roughness, cos θo) ([`super::sheen_ltc`]). So
//!
//! ```text
//! f(wo, wi)·cos θi = albedo(θo) · D(wi),   D(w) = w_z a² / (π ((a w_x + b w_z)² + a² w_y² + w_z²)²)
//! ```
//!
//! with D normalised over the hemisphere and sampled exactly (pdf = D, weight = albedo).
//! The fit depends on the view direction only, so the lobe is not reciprocal; light
//! paths use its adjoint f*(wo, wi) = f(wi, wo) (the fit at the camera-side direction)
//! and still sample D from wo.

use super::energy::lookup_2d;
use super::microfacet::TangentRotation;
use super::sheen_ltc::{SHEEN_LTC_A, SHEEN_LTC_ALBEDO, SHEEN_LTC_B};
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam, TransportMode};
use crate::sampling::concentric_disk;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// The sheen lobe seen from one direction: its transform and albedo.
#[derive(Clone, Copy, Debug)]
pub struct SheenLtc {
    a: f32,
    b: f32,
    pub albedo: f32,
    /// Rotates the shading frame so that the view direction's azimuth is +x.
    frame: TangentRotation,
}

impl SheenLtc {
    /// The fit for `roughness` (clamped to 1e-3..1 as Cycles) seen from `view` (local
    /// frame, upper hemisphere). None where the fit is degenerate (no sheen).
    pub fn new(roughness: f32, view: Vec3A) -> Option<Self> {
        let r = if roughness.is_finite() { roughness.clamp(1e-3, 1.0) } else { 1e-3 };
        let mu = view.z.clamp(0.0, 1.0);
        let a = lookup_2d(&SHEEN_LTC_A, 32, 32, mu, r);
        let b = lookup_2d(&SHEEN_LTC_B, 32, 32, mu, r);
        let albedo = lookup_2d(&SHEEN_LTC_ALBEDO, 32, 32, mu, r);
        if a.abs() < 1e-5 || albedo < 1e-5 {
            return None;
        }
        Some(Self { a, b, albedo, frame: TangentRotation::new(view, 0.0) })
    }

    /// The albedo of the lobe alone, for layering (Cycles' `bsdf_albedo` of the closure).
    pub fn albedo(roughness: f32, cos_view: f32) -> f32 {
        Self::new(roughness, Vec3A::new((1.0 - cos_view * cos_view).max(0.0).sqrt(), 0.0, cos_view))
            .map_or(0.0, |l| l.albedo)
    }

    /// D(w): the lobe's density (its pdf, and f·cos/albedo) at local direction `w`.
    pub fn density(&self, w: Vec3A) -> f32 {
        let l = self.frame.to_lobe(w);
        if l.z <= 0.0 {
            return 0.0;
        }
        let (a, b) = (self.a, self.b);
        let len2 = (a * l.x + b * l.z).powi(2) + (a * l.y).powi(2) + l.z * l.z;
        let d = FRAC_1_PI * l.z * (a / len2).powi(2);
        if d.is_finite() {
            d
        } else {
            0.0
        }
    }

    /// A direction distributed as D (the transformed cosine-distributed direction).
    pub fn sample(&self, u: Vec2) -> Vec3A {
        let d = concentric_disk(u);
        let z = (1.0 - d.dot(d)).max(0.0).sqrt();
        let l = Vec3A::new(d.x - z * self.b, d.y, z * self.a).normalize_or_zero();
        self.frame.from_lobe(l)
    }
}

/// Blender's Sheen BSDF (Microfiber): a colour times the microfibre sheen lobe.
pub struct Sheen {
    pub color: SpectralParam,
    pub roughness: f32,
}

/// `w` mirrored into the upper hemisphere.
#[inline]
fn upper(w: Vec3A) -> Vec3A {
    Vec3A::new(w.x, w.y, w.z.abs())
}

impl Sheen {
    /// f·|cos θi| of the grey lobe (before the colour) and the pdf of sampling `wi`.
    fn eval_scalar(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> (f32, f32) {
        if wo.z * wi.z <= 0.0 {
            return (0.0, 0.0);
        }
        let (o, i) = (upper(wo), upper(wi));
        let Some(from_o) = SheenLtc::new(self.roughness, o) else {
            return (0.0, 0.0);
        };
        let pdf = from_o.density(i);
        let f = match ctx.mode {
            TransportMode::Radiance => from_o.albedo * pdf,
            // The adjoint: the fit seen from wi (the camera side), evaluated at wo.
            TransportMode::Importance => match SheenLtc::new(self.roughness, i) {
                Some(from_i) => from_i.albedo * from_i.density(o) * i.z / o.z,
                None => 0.0,
            },
        };
        (if f.is_finite() { f } else { 0.0 }, pdf)
    }
}

impl Bsdf for Sheen {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::DIFFUSE
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: true, ..Default::default() }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let (f, pdf) = self.eval_scalar(ctx, wo, wi);
        self.color.evaluate_into(ctx, out);
        out.scale(f);
        pdf
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        self.eval_scalar(ctx, wo, wi).1
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        _uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let lobe = SheenLtc::new(self.roughness, upper(wo))?;
        let mut wi = lobe.sample(u);
        let pdf = lobe.density(wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let weight = match ctx.mode {
            TransportMode::Radiance => lobe.albedo,
            TransportMode::Importance => self.eval_scalar(ctx, upper(wo), wi).0 / pdf,
        };
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        if !(weight > 0.0 && weight.is_finite()) {
            return None;
        }
        self.color.multiply_into(ctx, throughput);
        throughput.scale(weight);
        Some(BsdfSample { wi, pdf, specular: false, collapsed_to: None })
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.color.evaluate_into(ctx, out);
        out.scale(SheenLtc::albedo(self.roughness, 1.0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::testing::{chi_square, dir, pdf_integral, quadrature_albedo, sampled_albedo};
    use crate::spectrum::WavelengthGrid;

    fn sheen(grid: &WavelengthGrid, roughness: f32) -> Sheen {
        Sheen { color: SpectralParam::Constant(SampledSpectrum::splat(grid.len(), 1.0)), roughness }
    }

    /// D is a normalised density over the hemisphere for every fit (the LTC's defining
    /// property), so the lobe's albedo is exactly the fitted one.
    #[test]
    fn ltc_is_normalised_and_albedo_at_most_one() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &r in &[0.15f32, 0.3, 0.5, 1.0] {
            for &c in &[0.15f32, 0.5, 0.9, 1.0] {
                let m = sheen(&grid, r);
                let wo = dir(c, 0.7);
                let p = pdf_integral(&m, &ctx, wo);
                assert!((p - 1.0).abs() < 0.01, "r {r} cos {c}: ∫D = {p}");
                let albedo = SheenLtc::albedo(r, c);
                assert!((0.0..=1.0).contains(&albedo));
                let q = quadrature_albedo(&m, &ctx, wo, 0);
                assert!((q - albedo as f64).abs() < 0.01 * albedo as f64 + 1e-4, "r {r} cos {c}: {q} vs {albedo}");
                let (mean, se) = sampled_albedo(&m, &ctx, wo, 4000, 3, 0);
                assert!((mean - albedo as f64).abs() < 1e-4 + 4.0 * se, "weight {mean} vs albedo {albedo}");
            }
        }
        // Rougher fibres scatter more (Zeltner et al., fig. 8); very smooth fibres have no
        // valid fit away from grazing and no sheen at all (Cycles skips the closure).
        assert!(SheenLtc::albedo(1.0, 0.5) > SheenLtc::albedo(0.2, 0.5));
        assert_eq!(SheenLtc::albedo(0.05, 0.5), 0.0);
        let mut f = SampledSpectrum::zeros(4);
        assert_eq!(sheen(&grid, 0.05).eval(&ctx, dir(0.5, 0.0), dir(0.5, 2.0), &mut f), 0.0);
        assert!(f.is_black());
    }

    #[test]
    fn sampling_matches_pdf_chi_square() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &(r, c, phi) in &[(0.2f32, 0.8f32, 0.0f32), (0.5, 0.3, 1.0), (1.0, 0.95, 2.5), (0.3, 0.1, 4.0)] {
            chi_square(&sheen(&grid, r), &ctx, dir(c, phi), 100_000, 7);
        }
    }

    /// Not reciprocal; light paths see the adjoint: f*(wo, wi) = f(wi, wo).
    #[test]
    fn importance_transport_sees_the_adjoint() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let rad = ShadingContext::new(&grid);
        let mut imp = ShadingContext::new(&grid);
        imp.mode = TransportMode::Importance;
        let m = sheen(&grid, 0.4);
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        for &(wo, wi) in &[(dir(0.3, 0.0), dir(0.8, 2.0)), (dir(0.9, 1.0), dir(0.2, 4.0))] {
            m.eval(&imp, wo, wi, &mut a);
            m.eval(&rad, wi, wo, &mut b);
            let (fa, fb) = (a.get(0) / wi.z, b.get(0) / wo.z);
            assert!((fa - fb).abs() < 1e-5 * fa.max(fb), "{fa} vs {fb}");
        }
        // Sampling in importance mode weighs the adjoint correctly: the mean weight is
        // ∫ f(wi, wo) cos θi dωi, a quadrature of eval.
        let wo = dir(0.6, 0.0);
        let (mean, se) = sampled_albedo(&m, &imp, wo, 40_000, 5, 0);
        let q = quadrature_albedo(&m, &imp, wo, 0);
        assert!((mean - q).abs() < 4.0 * se + 2e-3, "{mean} ± {se} vs {q}");
    }

    #[test]
    fn back_side_mirrors_and_degenerate_inputs_give_nothing() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let m = sheen(&grid, 0.5);
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        let (wo, wi) = (dir(0.5, 0.3), dir(0.7, 2.0));
        m.eval(&ctx, wo, wi, &mut a);
        m.eval(&ctx, -wo, -wi, &mut b);
        assert!((a.get(0) - b.get(0)).abs() < 1e-6 && a.get(0) > 0.0);
        m.eval(&ctx, wo, -wi, &mut a);
        assert_eq!(a.get(0), 0.0);
        let bad = sheen(&grid, f32::NAN);
        let mut tp = SampledSpectrum::splat(4, 1.0);
        if bad.sample(&ctx, wo, Vec2::new(0.3, 0.3), 0.5, &mut tp).is_some() {
            assert!(tp.is_finite());
        }
    }
}
