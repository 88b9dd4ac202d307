//! Lambertian reflection, seen the same from both faces.

use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam};
use crate::sampling::cosine_hemisphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

pub struct Diffuse {
    pub reflectance: SpectralParam,
}

impl Bsdf for Diffuse {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::DIFFUSE
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: true, ..Default::default() }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        if wo.z * wi.z <= 0.0 {
            out.fill(0.0);
            return 0.0;
        }
        let cos = wi.z.abs();
        self.reflectance.evaluate_into(ctx, out);
        out.scale(cos * FRAC_1_PI);
        cos * FRAC_1_PI
    }
    fn pdf(&self, _: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        if wo.z * wi.z <= 0.0 {
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
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        let pdf = wi.z.abs() * FRAC_1_PI;
        if pdf <= 0.0 {
            return None;
        }
        // f·cos/pdf = ρ for a cosine-sampled Lambertian lobe.
        self.reflectance.multiply_into(ctx, throughput);
        Some(BsdfSample { wi, pdf, specular: false, collapsed_to: None })
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.reflectance.evaluate_into(ctx, out);
    }
}
