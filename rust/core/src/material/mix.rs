//! Blender's Mix Shader and Add Shader as BSDFs of two BSDFs:
//!
//! * mix: f = (1 − t)·f_a + t·f_b (t 0 → a, 1 → b), energy conserving whenever a and b
//!   are. The factor t is a constant or, as Blender's Fresnel and Layer Weight nodes on
//!   the Fac input, a function of the viewing angle ([`MixFactor`]);
//! * add: f = f_a + f_b (as Cycles; may reflect more than it receives if a and b
//!   together do).
//!
//! `sample` picks a or b stochastically (mix: with probabilities 1 − t and t at the
//! viewing direction; add: in proportion to their albedos seen from the normal) and
//! samples it. A delta or wavelength-collapsing sample is weighted by its own BSDF over
//! its selection probability; any other sample by the weighted sum of both BSDFs' eval
//! over the mixture pdf, so `sample`, `eval` and `pdf` agree for MIS. The mixture is
//! dispersive if either part is.
//!
//! A view-dependent factor is evaluated at the direction towards the camera: `wo` on
//! camera paths, `wi` on light paths (the adjoint BSDF), so both directions of tracing
//! render the same image (Cycles' factor is not reciprocal either).

use super::fresnel::fresnel_dielectric;
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, TransportMode};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// The Mix Shader's factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MixFactor {
    Constant(f32),
    /// Blender's Fresnel node: dielectric Fresnel reflectance at index `ior` (1/ior seen
    /// from a back face).
    Fresnel {
        ior: f32,
    },
    /// Layer Weight node, Fresnel output: Fresnel with η = 1/(1 − blend) (front faces).
    LayerWeightFresnel {
        blend: f32,
    },
    /// Layer Weight node, Facing output: 1 − |cos θ|^b, b = 2·blend below 0.5 and
    /// 0.5/(1 − blend) above.
    LayerWeightFacing {
        blend: f32,
    },
}

impl MixFactor {
    /// The factor seen at `cos` (the cosine between the view direction and the shading
    /// normal), as Cycles' `svm_node_fresnel` / `svm_node_layer_weight`.
    pub fn at(&self, cos: f32, front_face: bool) -> f32 {
        let c = cos.abs().min(1.0);
        let t = match *self {
            MixFactor::Constant(t) => t,
            MixFactor::Fresnel { ior } => {
                let eta = ior.max(1e-5);
                fresnel_dielectric(c, if front_face { eta } else { 1.0 / eta })
            }
            MixFactor::LayerWeightFresnel { blend } => {
                let eta = (1.0 - blend).max(1e-5);
                fresnel_dielectric(c, if front_face { 1.0 / eta } else { eta })
            }
            MixFactor::LayerWeightFacing { blend } => {
                let mut f = c;
                if blend != 0.5 {
                    let b = blend.clamp(0.0, 1.0 - 1e-5);
                    let b = if b < 0.5 { 2.0 * b } else { 0.5 / (1.0 - b) };
                    f = f.powf(b);
                }
                1.0 - f
            }
        };
        if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.5
        }
    }
    pub fn is_constant(&self) -> bool {
        matches!(self, MixFactor::Constant(_))
    }
}

pub struct MixBsdf {
    pub a: Box<dyn Bsdf>,
    pub b: Box<dyn Bsdf>,
    /// Mix: f = (1 − t)·f_a + t·f_b; None: add, f = f_a + f_b.
    pub factor: Option<MixFactor>,
}

impl MixBsdf {
    /// Blender's Mix Shader with a constant factor (clamped to 0..1).
    pub fn mix(a: Box<dyn Bsdf>, b: Box<dyn Bsdf>, factor: f32) -> Self {
        let f = if factor.is_finite() { factor.clamp(0.0, 1.0) } else { 0.5 };
        Self::mix_with(a, b, MixFactor::Constant(f))
    }
    /// Blender's Mix Shader with any factor.
    pub fn mix_with(a: Box<dyn Bsdf>, b: Box<dyn Bsdf>, factor: MixFactor) -> Self {
        Self { a, b, factor: Some(factor) }
    }
    /// Blender's Add Shader.
    pub fn add(a: Box<dyn Bsdf>, b: Box<dyn Bsdf>) -> Self {
        Self { a, b, factor: None }
    }

    /// Weights (w_a, w_b) of f = w_a·f_a + w_b·f_b for the pair (wo, wi).
    fn weights(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> (f32, f32) {
        match self.factor {
            None => (1.0, 1.0),
            Some(f) => {
                let view = match ctx.mode {
                    TransportMode::Radiance => wo,
                    TransportMode::Importance => wi,
                };
                let t = f.at(view.z, ctx.front_face);
                (1.0 - t, t)
            }
        }
    }

    /// Whether a part can contribute at all.
    fn used(&self) -> (bool, bool) {
        match self.factor {
            Some(MixFactor::Constant(t)) => (t < 1.0, t > 0.0),
            _ => (true, true),
        }
    }

    /// Probability of choosing `a` (depends on wo only).
    fn prob_a(&self, ctx: &ShadingContext, wo: Vec3A) -> f32 {
        let (wa, wb) = match self.factor {
            None => {
                let n = ctx.grid.len();
                let mut s = SampledSpectrum::zeros(n);
                self.a.albedo(ctx, &mut s);
                let aa = s.sum().max(0.0);
                self.b.albedo(ctx, &mut s);
                let ab = s.sum().max(0.0);
                // Keep both choosable: a lobe whose albedo is 0 from the normal may still
                // reflect elsewhere.
                (aa + 1e-3 * n as f32, ab + 1e-3 * n as f32)
            }
            Some(f) => {
                let t = f.at(wo.z, ctx.front_face);
                if !f.is_constant() && ctx.mode == TransportMode::Importance {
                    // The weights depend on wi here: keep both parts choosable.
                    let t = t.clamp(0.05, 0.95);
                    (1.0 - t, t)
                } else {
                    (1.0 - t, t)
                }
            }
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
    fn lobe_kinds(&self) -> u8 {
        {
            let (ua, ub) = self.used();
            (if ua { self.a.lobe_kinds() } else { 0 }) | (if ub { self.b.lobe_kinds() } else { 0 })
        }
    }
    fn flags(&self) -> BsdfFlags {
        let (fa, fb) = (self.a.flags(), self.b.flags());
        let (ua, ub) = self.used();
        BsdfFlags {
            smooth: (ua && fa.smooth) || (ub && fb.smooth),
            specular: (ua && fa.specular) || (ub && fb.specular),
            dispersive: (ua && fa.dispersive) || (ub && fb.dispersive),
        }
    }

    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let pa = self.prob_a(ctx, wo);
        let (wa, wb) = self.weights(ctx, wo, wi);
        let (ua, ub) = self.used();
        let mut fb = SampledSpectrum::zeros(out.len());
        let (mut pdf, mut pdf_b) = (0.0, 0.0);
        if ua {
            pdf = self.a.eval(ctx, wo, wi, out);
            out.scale(wa);
        } else {
            out.fill(0.0);
        }
        if ub {
            pdf_b = self.b.eval(ctx, wo, wi, &mut fb);
            out.add_scaled(&fb, wb);
        }
        let p = pa * pdf + (1.0 - pa) * pdf_b;
        if !(out.is_finite() && p.is_finite()) {
            out.fill(0.0);
            return 0.0;
        }
        p
    }

    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        let pa = self.prob_a(ctx, wo);
        let (ua, ub) = self.used();
        let a = if ua { self.a.pdf(ctx, wo, wi) } else { 0.0 };
        let b = if ub { self.b.pdf(ctx, wo, wi) } else { 0.0 };
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
        let pa = self.prob_a(ctx, wo);
        let (chosen, p, is_a, uc2) = if uc < pa {
            (&self.a, pa, true, (uc / pa).clamp(0.0, 0.999_999_9))
        } else {
            (&self.b, 1.0 - pa, false, ((uc - pa) / (1.0 - pa)).clamp(0.0, 0.999_999_9))
        };
        if !(p > 0.0) {
            return None;
        }
        let mut tp = throughput.clone();
        let bs = chosen.sample(ctx, wo, u, uc2, &mut tp)?;
        if bs.specular || bs.collapsed_to.is_some() {
            let (wa, wb) = self.weights(ctx, wo, bs.wi);
            tp.scale(if is_a { wa } else { wb } / p);
            if !tp.is_finite() {
                return None;
            }
            throughput.copy_from(&tp);
            return Some(BsdfSample { pdf: bs.pdf * p, ..bs });
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
        Some(BsdfSample { wi: bs.wi, pdf, specular: false, collapsed_to: None })
    }

    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        // Seen from the normal.
        let (wa, wb) = self.weights(ctx, Vec3A::Z, Vec3A::Z);
        let mut b = SampledSpectrum::zeros(out.len());
        self.a.albedo(ctx, out);
        out.scale(wa);
        self.b.albedo(ctx, &mut b);
        out.add_scaled(&b, wb);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::conductor::SchlickFresnel;
    use crate::material::{Diffuse, Glossy, SpectralParam, TransportMode};
    use crate::sampling::Rng;
    use crate::spectrum::WavelengthGrid;
    use std::f32::consts::FRAC_1_PI;

    fn diffuse(v: &[f32]) -> Box<dyn Bsdf> {
        Box::new(Diffuse { reflectance: SpectralParam::Constant(SampledSpectrum::from_slice(v)) })
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
                let s = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp).unwrap();
                assert!(!s.specular && s.wi.z > 0.0);
                assert!((s.pdf - s.wi.z * FRAC_1_PI).abs() < 1e-5);
                for k in 0..4 {
                    assert!((tp.get(k) - mixed[k]).abs() < 1e-5, "t {t} lane {k}: {} vs {}", tp.get(k), mixed[k]);
                }
            }
            let mut a = SampledSpectrum::zeros(4);
            m.albedo(&ctx, &mut a);
            for k in 0..4 {
                assert!((a.get(k) - mixed[k]).abs() < 1e-6);
            }
        }
    }

    /// The view-dependent factors follow Cycles' node formulas (closed forms here).
    #[test]
    fn view_dependent_factors_match_blender_nodes() {
        let r0 = |n: f32| ((n - 1.0) / (n + 1.0)).powi(2);
        assert!((MixFactor::Fresnel { ior: 1.5 }.at(1.0, true) - r0(1.5)).abs() < 1e-6);
        assert!((MixFactor::Fresnel { ior: 1.5 }.at(1.0, false) - r0(1.5)).abs() < 1e-6);
        // Seen from inside at grazing angles: total internal reflection.
        assert_eq!(MixFactor::Fresnel { ior: 1.5 }.at(0.3, false), 1.0);
        // Layer Weight Fresnel, blend 0.5: η = 2.
        assert!((MixFactor::LayerWeightFresnel { blend: 0.5 }.at(1.0, true) - 1.0 / 9.0).abs() < 1e-6);
        for &c in &[0.0f32, 0.3, 0.7, 1.0] {
            let facing = |blend: f32| MixFactor::LayerWeightFacing { blend }.at(c, true);
            assert!((facing(0.5) - (1.0 - c)).abs() < 1e-6);
            assert!((facing(0.25) - (1.0 - c.sqrt())).abs() < 1e-6);
            assert!((facing(0.75) - (1.0 - c * c)).abs() < 1e-5);
        }
    }

    /// Mix of red and blue diffuse by a Fresnel factor: seen from wo, the BSDF is the
    /// diffuse of (1 − F(θo))ρa + F(θo)ρb (every sample's weight equals it exactly); on
    /// light paths the factor follows wi (the adjoint), so the sampled albedo is
    /// ∫((1 − F(μ))ρa + F(μ)ρb)·2μ dμ.
    #[test]
    fn fresnel_mix_of_diffuse_is_view_dependent_and_adjoint_on_light_paths() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ra = [0.9f32, 0.1, 0.1, 0.5];
        let rb = [0.1f32, 0.2, 0.9, 0.0];
        let factor = MixFactor::Fresnel { ior: 1.45 };
        let m = MixBsdf::mix_with(diffuse(&ra), diffuse(&rb), factor);
        let mut ctx = ShadingContext::new(&grid);
        let mut rng = Rng::new(21, 4);
        for &theta in &[0.1f32, 0.8, 1.3, 1.55] {
            let wo = Vec3A::new(theta.sin(), 0.0, theta.cos());
            let t = crate::material::fresnel::fresnel_dielectric(theta.cos(), 1.45);
            for _ in 0..50 {
                let mut tp = SampledSpectrum::splat(4, 1.0);
                let s = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp).unwrap();
                assert!((s.pdf - s.wi.z * FRAC_1_PI).abs() < 1e-5);
                for k in 0..4 {
                    let mixed = (1.0 - t) * ra[k] + t * rb[k];
                    assert!((tp.get(k) - mixed).abs() < 1e-5, "θ {theta} lane {k}: {} vs {mixed}", tp.get(k));
                }
            }
        }
        ctx.mode = TransportMode::Importance;
        let wo = Vec3A::new(0.5f32.sin(), 0.0, 0.5f32.cos());
        let n = 100_000;
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let mut tp = SampledSpectrum::splat(4, 1.0);
            if let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                assert!((m.pdf(&ctx, wo, s.wi) - s.pdf).abs() < 1e-4);
                let v = tp.get(2) as f64;
                s1 += v;
                s2 += v * v;
            }
        }
        let mean = s1 / n as f64;
        let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        let steps = 20_000;
        let mut expected = 0.0f64;
        for i in 0..steps {
            let mu = (i as f64 + 0.5) / steps as f64;
            let t = crate::material::fresnel::fresnel_dielectric_f64(mu, 1.45);
            expected += ((1.0 - t) * ra[2] as f64 + t * rb[2] as f64) * 2.0 * mu / steps as f64;
        }
        assert!((mean - expected).abs() < 4.0 * se + 1e-4, "light paths: {mean} ± {se} vs {expected}");
    }

    /// Add of diffuse and glossy: sampled estimate matches a quadrature of eval (so the
    /// albedo-based choice and the weights agree), and add = mix(…, 0.5) × 2.
    #[test]
    fn add_shader_sampling_matches_eval() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let glossy = || -> Box<dyn Bsdf> {
            Box::new(Glossy::new(
                SchlickFresnel { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 0.3)) },
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
                m.eval(&ctx, wo, Vec3A::new(s * phi.cos(), s * phi.sin(), c), &mut f);
                q += f.get(0) as f64;
            }
        }
        q *= 2.0 * std::f64::consts::PI / (nt * np) as f64;
        assert!((q - mean).abs() < 5.0 * se + 0.01, "sampled {mean} ± {se} vs quadrature {q}");
    }
}
