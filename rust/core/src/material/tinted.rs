//! A BSDF scaled per wavelength by a colour: Blender's Glass BSDF Color, which Cycles
//! applies as the closure's weight (`svm_node_closure_bsdf`, CLOSURE_BSDF_MICROFACET_*_GLASS_ID:
//! the node's colour is `sd->svm_closure_weight`, and the glass closure's Fresnel has white
//! reflection and transmission tints), so it tints reflection and transmission alike.

use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

pub struct Tinted {
    pub color: SpectralParam,
    pub inner: Box<dyn Bsdf>,
}

impl Bsdf for Tinted {
    fn lobe_kinds(&self) -> u8 {
        self.inner.lobe_kinds()
    }
    fn flags(&self) -> BsdfFlags {
        self.inner.flags()
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let pdf = self.inner.eval(ctx, wo, wi, out);
        self.color.multiply_into(ctx, out);
        pdf
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        self.inner.pdf(ctx, wo, wi)
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        let s = self.inner.sample(ctx, wo, u, uc, throughput)?;
        self.color.multiply_into(ctx, throughput);
        Some(s)
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.inner.albedo(ctx, out);
        self.color.multiply_into(ctx, out);
    }
    fn specular_weights(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        wi: Vec3A,
        throughput: &SampledSpectrum,
        out: &mut SampledSpectrum,
    ) -> bool {
        let known = self.inner.specular_weights(ctx, wo, wi, throughput, out);
        if known {
            self.color.multiply_into(ctx, out);
        }
        known
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::testing::{chi_square, dir, sampled_albedo};
    use crate::material::Diffuse;
    use crate::spectrum::WavelengthGrid;

    #[test]
    fn scales_eval_sample_and_albedo_by_its_colour() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let tint = [0.2f32, 0.4, 0.6, 0.8];
        let t = Tinted {
            color: SpectralParam::Constant(SampledSpectrum::from_slice(&tint)),
            inner: Box::new(Diffuse { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 1.0)) }),
        };
        // A tinted white Lambertian: albedo = tint exactly, per lane.
        for lane in 0..4 {
            let (mean, se) = sampled_albedo(&t, &ctx, dir(0.6, 0.2), 4000, 1, lane);
            assert!((mean - f64::from(tint[lane])).abs() < 1e-5 && se < 1e-6, "{lane}: {mean}");
        }
        let (wo, wi) = (dir(0.6, 0.2), dir(0.3, 1.0));
        let mut f = SampledSpectrum::zeros(4);
        let pdf = t.eval(&ctx, wo, wi, &mut f);
        assert!((pdf - t.pdf(&ctx, wo, wi)).abs() < 1e-7);
        for (lane, &c) in tint.iter().enumerate() {
            assert!((f.get(lane) - c * wi.z * std::f32::consts::FRAC_1_PI).abs() < 1e-6);
        }
        chi_square(&t, &ctx, wo, 50_000, 3);
    }
}
