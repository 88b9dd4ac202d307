//! Blender's Mix Shader and Add Shader as BSDFs of two BSDFs:
//!
//! * mix: f = (1 − factor)·f_a + factor·f_b (factor 0 → a, 1 → b), energy conserving
//!   whenever a and b are;
//! * add: f = f_a + f_b (as Cycles; may reflect more than it receives if a and b
//!   together do).
//!
//! `sample` picks a or b stochastically (mix: with probabilities 1 − factor and factor;
//! add: in proportion to their albedos seen from the normal) and samples it. A delta or
//! wavelength-collapsing sample is weighted by its own BSDF over its selection
//! probability; any other sample by the weighted sum of both BSDFs' eval over the
//! mixture pdf, so `sample`, `eval` and `pdf` agree for MIS. The mixture is dispersive
//! if either part is.

use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

pub struct MixBsdf {
    pub a: Box<dyn Bsdf>,
    pub b: Box<dyn Bsdf>,
    /// f = weight_a·f_a + weight_b·f_b.
    pub weight_a: f32,
    pub weight_b: f32,
    /// Add shader: choose by albedo instead of by weight.
    pub by_albedo: bool,
}

impl MixBsdf {
    /// Blender's Mix Shader (factor clamped to 0..1).
    pub fn mix(a: Box<dyn Bsdf>, b: Box<dyn Bsdf>, factor: f32) -> Self {
        let f = if factor.is_finite() {
            factor.clamp(0.0, 1.0)
        } else {
            0.5
        };
        Self {
            a,
            b,
            weight_a: 1.0 - f,
            weight_b: f,
            by_albedo: false,
        }
    }
    /// Blender's Add Shader.
    pub fn add(a: Box<dyn Bsdf>, b: Box<dyn Bsdf>) -> Self {
        Self {
            a,
            b,
            weight_a: 1.0,
            weight_b: 1.0,
            by_albedo: true,
        }
    }

    /// Probability of choosing `a`.
    fn prob_a(&self, ctx: &ShadingContext) -> f32 {
        let (wa, wb) = if self.by_albedo {
            let n = ctx.grid.len();
            let mut s = SampledSpectrum::zeros(n);
            self.a.albedo(ctx, &mut s);
            let aa = s.sum().max(0.0);
            self.b.albedo(ctx, &mut s);
            let ab = s.sum().max(0.0);
            // Keep both choosable: a lobe whose albedo is 0 from the normal may still
            // reflect elsewhere.
            (
                self.weight_a * (aa + 1e-3 * n as f32),
                self.weight_b * (ab + 1e-3 * n as f32),
            )
        } else {
            (self.weight_a, self.weight_b)
        };
        let t = wa + wb;
        if t > 0.0 && t.is_finite() {
            wa / t
        } else {
            0.5
        }
    }
}

impl Bsdf for MixBsdf {
    fn flags(&self) -> BsdfFlags {
        let (fa, fb) = (self.a.flags(), self.b.flags());
        let (ua, ub) = (self.weight_a > 0.0, self.weight_b > 0.0);
        BsdfFlags {
            smooth: (ua && fa.smooth) || (ub && fb.smooth),
            specular: (ua && fa.specular) || (ub && fb.specular),
            dispersive: (ua && fa.dispersive) || (ub && fb.dispersive),
        }
    }

    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let pa = self.prob_a(ctx);
        let mut fb = SampledSpectrum::zeros(out.len());
        let (mut pdf, mut pdf_b) = (0.0, 0.0);
        if self.weight_a > 0.0 {
            pdf = self.a.eval(ctx, wo, wi, out);
            out.scale(self.weight_a);
        } else {
            out.fill(0.0);
        }
        if self.weight_b > 0.0 {
            pdf_b = self.b.eval(ctx, wo, wi, &mut fb);
            out.add_scaled(&fb, self.weight_b);
        }
        let p = pa * pdf + (1.0 - pa) * pdf_b;
        if !(out.is_finite() && p.is_finite()) {
            out.fill(0.0);
            return 0.0;
        }
        p
    }

    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        let pa = self.prob_a(ctx);
        let a = if self.weight_a > 0.0 {
            self.a.pdf(ctx, wo, wi)
        } else {
            0.0
        };
        let b = if self.weight_b > 0.0 {
            self.b.pdf(ctx, wo, wi)
        } else {
            0.0
        };
        pa * a + (1.0 - pa) * b
    }

    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        let pa = self.prob_a(ctx);
        let (chosen, p, w, uc2) = if uc < pa {
            (
                &self.a,
                pa,
                self.weight_a,
                (uc / pa).clamp(0.0, 0.999_999_9),
            )
        } else {
            (
                &self.b,
                1.0 - pa,
                self.weight_b,
                ((uc - pa) / (1.0 - pa)).clamp(0.0, 0.999_999_9),
            )
        };
        if !(p > 0.0) {
            return None;
        }
        let mut tp = throughput.clone();
        let bs = chosen.sample(ctx, wo, u, uc2, &mut tp)?;
        if bs.specular || bs.collapsed_to.is_some() {
            tp.scale(w / p);
            if !tp.is_finite() {
                return None;
            }
            throughput.copy_from(&tp);
            return Some(BsdfSample {
                pdf: bs.pdf * p,
                ..bs
            });
        }
        let mut f = SampledSpectrum::zeros(throughput.len());
        let pdf = self.eval(ctx, wo, bs.wi, &mut f);
        if !(pdf > 0.0 && pdf.is_finite()) || f.is_black() {
            return None;
        }
        f.scale(1.0 / pdf);
        if !f.is_finite() {
            return None;
        }
        throughput.mul_assign(&f);
        Some(BsdfSample {
            wi: bs.wi,
            pdf,
            specular: false,
            collapsed_to: None,
        })
    }

    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        let mut b = SampledSpectrum::zeros(out.len());
        self.a.albedo(ctx, out);
        out.scale(self.weight_a);
        self.b.albedo(ctx, &mut b);
        out.add_scaled(&b, self.weight_b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::conductor::SchlickFresnel;
    use crate::material::{Diffuse, Glossy, SpectralParam};
    use crate::sampling::Rng;
    use crate::spectrum::WavelengthGrid;
    use std::f32::consts::FRAC_1_PI;

    fn diffuse(v: &[f32]) -> Box<dyn Bsdf> {
        Box::new(Diffuse {
            reflectance: SpectralParam::Constant(SampledSpectrum::from_slice(v)),
        })
    }

    /// Mix of two diffuse BSDFs = diffuse of the mixed albedo: eval equals
    /// ((1 − t)ρa + tρb)/π·cos θ exactly and every sample's weight equals that albedo.
    #[test]
    fn mix_of_two_diffuse_is_diffuse_of_mixed_albedo() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let ra = [0.9f32, 0.1, 0.1, 0.5];
        let rb = [0.1f32, 0.2, 0.9, 0.0];
        for &t in &[0.0f32, 0.25, 0.5, 1.0] {
            let m = MixBsdf::mix(diffuse(&ra), diffuse(&rb), t);
            let mixed: Vec<f32> = (0..4).map(|k| (1.0 - t) * ra[k] + t * rb[k]).collect();
            let mut rng = Rng::new(3, t.to_bits() as u64);
            let mut f = SampledSpectrum::zeros(4);
            for _ in 0..200 {
                let wo = crate::sampling::cosine_hemisphere(rng.uniform2());
                let wi = crate::sampling::cosine_hemisphere(rng.uniform2());
                let pdf = m.eval(&ctx, wo, wi, &mut f);
                assert!((pdf - wi.z * FRAC_1_PI).abs() < 1e-5);
                for k in 0..4 {
                    assert!((f.get(k) - mixed[k] * FRAC_1_PI * wi.z).abs() < 1e-6);
                }
                let mut tp = SampledSpectrum::splat(4, 1.0);
                let s = m
                    .sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp)
                    .unwrap();
                assert!(!s.specular && s.wi.z > 0.0);
                assert!((s.pdf - s.wi.z * FRAC_1_PI).abs() < 1e-5);
                for k in 0..4 {
                    assert!(
                        (tp.get(k) - mixed[k]).abs() < 1e-5,
                        "t {t} lane {k}: {} vs {}",
                        tp.get(k),
                        mixed[k]
                    );
                }
            }
            let mut a = SampledSpectrum::zeros(4);
            m.albedo(&ctx, &mut a);
            for k in 0..4 {
                assert!((a.get(k) - mixed[k]).abs() < 1e-6);
            }
        }
    }

    /// Add of diffuse and glossy: sampled estimate matches a quadrature of eval (so the
    /// albedo-based choice and the weights agree), and add = mix(…, 0.5) × 2.
    #[test]
    fn add_shader_sampling_matches_eval() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let glossy = || -> Box<dyn Bsdf> {
            Box::new(Glossy::new(
                SchlickFresnel {
                    reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 0.3)),
                },
                0.4,
            ))
        };
        let m = MixBsdf::add(diffuse(&[0.5; 4]), glossy());
        let half = MixBsdf::mix(diffuse(&[0.5; 4]), glossy(), 0.5);
        let wo = Vec3A::new(0.6f32.sin(), 0.0, 0.6f32.cos());
        let (mut f, mut g) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        let wi = Vec3A::new(-0.5, 0.1, 0.86).normalize();
        m.eval(&ctx, wo, wi, &mut f);
        half.eval(&ctx, wo, wi, &mut g);
        assert!((f.get(0) - 2.0 * g.get(0)).abs() < 1e-5);
        let mut rng = Rng::new(8, 8);
        let n = 40_000;
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let mut tp = SampledSpectrum::splat(4, 1.0);
            if let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                assert!((m.pdf(&ctx, wo, s.wi) - s.pdf).abs() < 1e-3 * s.pdf.max(1.0));
                let v = tp.get(0) as f64;
                s1 += v;
                s2 += v * v;
            }
        }
        let mean = s1 / n as f64;
        let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        let (nt, np) = (1000, 200);
        let mut q = 0.0f64;
        for i in 0..nt {
            let c = (i as f32 + 0.5) / nt as f32;
            let s = (1.0 - c * c).sqrt();
            for j in 0..np {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
                m.eval(
                    &ctx,
                    wo,
                    Vec3A::new(s * phi.cos(), s * phi.sin(), c),
                    &mut f,
                );
                q += f.get(0) as f64;
            }
        }
        q *= 2.0 * std::f64::consts::PI / (nt * np) as f64;
        assert!(
            (q - mean).abs() < 5.0 * se + 0.01,
            "sampled {mean} ± {se} vs quadrature {q}"
        );
    }
}
