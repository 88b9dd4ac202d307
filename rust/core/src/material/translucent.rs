//! Blender's Translucent BSDF: Lambertian transmission, light leaving cosine-weighted
//! on the far side (Cycles' `bsdf_translucent_eval/sample`,
//! intern/cycles/kernel/closure/bsdf_diffuse.h). f = ρ/π for wo and wi on opposite
//! sides: reciprocal, and a white one transmits everything.

use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam};
use crate::sampling::cosine_hemisphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

pub struct Translucent {
    pub color: SpectralParam,
}

impl Bsdf for Translucent {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::TRANSMISSION
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: true, ..Default::default() }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        if wo.z * wi.z >= 0.0 {
            out.fill(0.0);
            return 0.0;
        }
        let p = wi.z.abs() * FRAC_1_PI;
        self.color.evaluate_into(ctx, out);
        out.scale(p);
        p
    }
    fn pdf(&self, _: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        if wo.z * wi.z >= 0.0 {
            0.0
        } else {
            wi.z.abs() * FRAC_1_PI
        }
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        _uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        let mut wi = cosine_hemisphere(u);
        if wo.z > 0.0 {
            wi.z = -wi.z;
        }
        let pdf = wi.z.abs() * FRAC_1_PI;
        if !(pdf > 0.0) || wo.z == 0.0 {
            return None;
        }
        self.color.multiply_into(ctx, throughput);
        Some(BsdfSample { wi, pdf, specular: false, collapsed_to: None })
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.color.evaluate_into(ctx, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::testing::{assert_reciprocal, chi_square, dir, quadrature_albedo, sampled_albedo};
    use crate::spectrum::WavelengthGrid;

    #[test]
    fn transmits_its_colour_reciprocally_and_samples_its_pdf() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let white = Translucent { color: SpectralParam::Constant(SampledSpectrum::splat(4, 1.0)) };
        for &c in &[0.1f32, 0.6, 1.0, -0.5] {
            let wo = dir(c, 0.3);
            let (mean, se) = sampled_albedo(&white, &ctx, wo, 5000, 1, 0);
            assert!((mean - 1.0).abs() < 1e-5 && se < 1e-6, "{mean}");
            let q = quadrature_albedo(&white, &ctx, wo, 0);
            assert!((q - 1.0).abs() < 2e-3, "{q}");
        }
        let tinted = Translucent { color: SpectralParam::Constant(SampledSpectrum::from_slice(&[0.2, 0.4, 0.6, 0.8])) };
        assert_reciprocal(&tinted, &ctx, 400, 4);
        chi_square(&tinted, &ctx, dir(0.7, 0.0), 50_000, 3);
        // Nothing is reflected.
        let mut f = SampledSpectrum::zeros(4);
        assert_eq!(tinted.eval(&ctx, dir(0.5, 0.0), dir(0.5, 1.0), &mut f), 0.0);
        assert!(f.is_black());
    }
}
