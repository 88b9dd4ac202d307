//! Metals: microfacet (GGX) reflection with a Fresnel term per wavelength.
//!
//! * [`Conductor`]: the exact conductor Fresnel of a complex index η + ik (measured
//!   metals from `spectrum::measured`, or given by the user);
//! * [`Glossy`]: Blender's Glossy BSDF, a reflectance colour tinting Schlick's Fresnel.
//!
//! Roughness 0 (alpha below [`SMOOTH_ALPHA`](super::microfacet::SMOOTH_ALPHA)) is a
//! perfect mirror (a delta lobe). Reflection never depends on λ in direction, so these
//! never collapse a polychromatic ray.

use super::fresnel::{fresnel_conductor, reflect, schlick};
use super::microfacet::{AnisotropicGgx, Ggx, TangentRotation};
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// The per-wavelength Fresnel reflectance of a metal.
pub trait MetalFresnel: Send + Sync {
    /// `out[λ]` = F(cos θ, λ).
    fn eval(&self, ctx: &ShadingContext, cos: f32, out: &mut SampledSpectrum);
}

/// Exact conductor Fresnel with a spectral complex index.
pub struct ComplexFresnel {
    pub eta: SampledSpectrum,
    pub k: SampledSpectrum,
}

impl MetalFresnel for ComplexFresnel {
    fn eval(&self, _ctx: &ShadingContext, cos: f32, out: &mut SampledSpectrum) {
        for i in 0..out.len() {
            out.set(i, fresnel_conductor(cos, self.eta.get(i), self.k.get(i)));
        }
    }
}

/// Schlick's approximation tinted by a reflectance (the colour at normal incidence).
pub struct SchlickFresnel {
    pub reflectance: SpectralParam,
}

impl MetalFresnel for SchlickFresnel {
    fn eval(&self, ctx: &ShadingContext, cos: f32, out: &mut SampledSpectrum) {
        self.reflectance.evaluate_into(ctx, out);
        for v in out.values_mut() {
            *v = schlick(cos, *v);
        }
    }
}

/// GGX reflection with a Fresnel term `F`, isotropic or anisotropic (alpha_x along
/// `tangent`'s direction, Cycles' `make_orthonormals_tangent(N, T)` frame in
/// `bsdf_microfacet_eval`).
pub struct MicrofacetReflection<F: MetalFresnel> {
    pub fresnel: F,
    pub ggx: AnisotropicGgx,
}

pub type Conductor = MicrofacetReflection<ComplexFresnel>;
pub type Glossy = MicrofacetReflection<SchlickFresnel>;

impl<F: MetalFresnel> MicrofacetReflection<F> {
    pub fn new(fresnel: F, roughness: f32) -> Self {
        Self { fresnel, ggx: AnisotropicGgx::new(Ggx::from_roughness(roughness), TangentRotation::default()) }
    }
    /// With an anisotropic distribution whose tangent is `tangent`.
    pub fn with_distribution(self, distribution: Ggx, tangent: TangentRotation) -> Self {
        Self { ggx: AnisotropicGgx::new(distribution, tangent), ..self }
    }
    fn smooth(&self) -> bool {
        self.ggx.distribution.effectively_smooth()
    }
    /// The pdf of `wi` for directions already in the distribution's frame.
    fn pdf_lobe(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let wm = (wo + wi).normalize_or_zero();
        let c = wo.dot(wm);
        if wm == Vec3A::ZERO || c <= 0.0 {
            return 0.0;
        }
        let p = self.ggx.distribution.d_visible(wo, wm) / (4.0 * c);
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }
}

impl<F: MetalFresnel> Bsdf for MicrofacetReflection<F> {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::GLOSSY
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: !self.smooth(), specular: self.smooth(), dispersive: false }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        if self.smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            out.fill(0.0);
            return 0.0;
        }
        let (wo, wi) = (self.ggx.to_lobe(wo), self.ggx.to_lobe(wi));
        let wm = (wo + wi).normalize_or_zero();
        if wm == Vec3A::ZERO {
            out.fill(0.0);
            return 0.0;
        }
        let g = &self.ggx.distribution;
        // f·cos θi = D G F / (4 cos θo).
        self.fresnel.eval(ctx, wo.dot(wm), out);
        let s = g.d(wm) * g.g(wo, wi) / (4.0 * wo.z);
        out.scale(if s.is_finite() { s } else { 0.0 });
        self.pdf_lobe(wo, wi)
    }
    fn pdf(&self, _ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        if self.smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.pdf_lobe(self.ggx.to_lobe(wo), self.ggx.to_lobe(wi))
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        _uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let mut f = SampledSpectrum::zeros(throughput.len());
        if self.smooth() {
            let wi = Vec3A::new(-wo.x, -wo.y, wo.z);
            self.fresnel.eval(ctx, wo.z, &mut f);
            throughput.mul_assign(&f);
            return Some(BsdfSample { wi, pdf: 1.0, specular: true, collapsed_to: None });
        }
        let g = &self.ggx.distribution;
        let wo = self.ggx.to_lobe(wo);
        let wm = g.sample_wm(wo, u);
        let wi = reflect(wo, wm);
        if wi.z <= 0.0 {
            return None;
        }
        let c = wo.dot(wm);
        let pdf = g.d_visible(wo, wm) / (4.0 * c);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        // f·cos/pdf = F · G(wo, wi) / G1(wo) for visible-normal sampling.
        self.fresnel.eval(ctx, c, &mut f);
        f.scale(g.g(wo, wi) / g.g1(wo));
        throughput.mul_assign(&f);
        Some(BsdfSample { wi: self.ggx.lobe_to_shading(wi), pdf, specular: false, collapsed_to: None })
    }
    /// A smooth metal reflects every wavelength the same way: F_λ (chosen with probability 1).
    fn specular_weights(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        _wi: Vec3A,
        _throughput: &SampledSpectrum,
        out: &mut SampledSpectrum,
    ) -> bool {
        if !self.smooth() || wo.z <= 0.0 {
            return false;
        }
        self.fresnel.eval(ctx, wo.z, out);
        true
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.fresnel.eval(ctx, 1.0, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::spectrum::WavelengthGrid;

    fn gold(grid: &WavelengthGrid, roughness: f32) -> Conductor {
        use crate::spectrum::measured::{AU_ETA, AU_K};
        use crate::spectrum::named::interpolate;
        let table = |t: &[(f32, f32)]| {
            let xs: Vec<f32> = t.iter().map(|p| p.0).collect();
            let ys: Vec<f32> = t.iter().map(|p| p.1).collect();
            SampledSpectrum::from_slice(&grid.lambdas().iter().map(|&l| interpolate(&xs, &ys, l)).collect::<Vec<_>>())
        };
        Conductor::new(ComplexFresnel { eta: table(AU_ETA), k: table(AU_K) }, roughness)
    }

    fn dir(theta: f32, phi: f32) -> Vec3A {
        Vec3A::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    #[test]
    fn rough_conductor_eval_is_reciprocal() {
        let grid = WavelengthGrid::uniform(8, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let m = gold(&grid, 0.5);
        let (mut a, mut b) = (SampledSpectrum::zeros(8), SampledSpectrum::zeros(8));
        let mut rng = Rng::new(5, 5);
        for _ in 0..200 {
            let wo = dir(rng.uniform() * 1.5, rng.uniform() * std::f32::consts::TAU);
            let wi = dir(rng.uniform() * 1.5, rng.uniform() * std::f32::consts::TAU);
            m.eval(&ctx, wo, wi, &mut a);
            m.eval(&ctx, wi, wo, &mut b);
            // f(wo, wi) = f(wi, wo): eval returns f·cos θi.
            for k in 0..8 {
                let fa = a.get(k) / wi.z;
                let fb = b.get(k) / wo.z;
                assert!((fa - fb).abs() <= 1e-4 * fa.abs().max(1e-3), "{fa} vs {fb}");
            }
        }
    }

    /// White furnace: with F = 1 the directional albedo is ≤ 1 and, estimated by
    /// sampling, agrees with a quadrature of eval (the sampler's weights match f/pdf).
    #[test]
    fn white_furnace_albedo_at_most_one() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &roughness in &[0.1f32, 0.3, 0.6, 1.0] {
            let m = Glossy::new(
                SchlickFresnel { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 1.0)) },
                roughness,
            );
            for &theta in &[0.0f32, 0.7, 1.2, 1.5] {
                let wo = dir(theta, 0.3);
                let mut rng = Rng::new(11, theta.to_bits() as u64);
                let n = 40_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    let mut tp = SampledSpectrum::splat(4, 1.0);
                    if let Some(s) = m.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                        assert!(s.pdf > 0.0 && tp.is_finite());
                        let v = tp.get(0) as f64;
                        sum += v;
                        sum2 += v * v;
                    }
                }
                let mean = sum / n as f64;
                let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
                assert!(mean <= 1.0 + 4.0 * se + 1e-4, "roughness {roughness} θ {theta}: albedo {mean}");
                // Independent estimate: uniform hemisphere quadrature of eval.
                let (nt, np) = (1000, 400);
                let mut q = 0.0f64;
                let mut f = SampledSpectrum::zeros(4);
                for i in 0..nt {
                    let c = (i as f32 + 0.5) / nt as f32;
                    for j in 0..np {
                        let phi = 6.2831855 * (j as f32 + 0.5) / np as f32;
                        let wi = Vec3A::new((1.0 - c * c).sqrt() * phi.cos(), (1.0 - c * c).sqrt() * phi.sin(), c);
                        m.eval(&ctx, wo, wi, &mut f);
                        q += f.get(0) as f64 / (nt * np) as f64 * 2.0 * std::f64::consts::PI;
                    }
                }
                assert!(q <= 1.0 + 0.01, "quadrature albedo {q}");
                if roughness >= 0.3 {
                    assert!(
                        (q - mean).abs() < 5.0 * se + 0.01,
                        "roughness {roughness} θ {theta}: sampled {mean} ± {se} vs quadrature {q}"
                    );
                }
            }
        }
    }

    #[test]
    fn smooth_gold_reflects_normal_incidence_fresnel() {
        let grid = WavelengthGrid::default();
        let ctx = ShadingContext::new(&grid);
        let m = gold(&grid, 0.0);
        assert!(m.flags().specular && !m.flags().smooth);
        let mut tp = SampledSpectrum::splat(grid.len(), 1.0);
        let s = m.sample(&ctx, Vec3A::Z, Vec2::new(0.3, 0.3), 0.5, &mut tp).unwrap();
        assert!((s.wi - Vec3A::Z).length() < 1e-6);
        let i = grid.nearest(660.0);
        let (n, k) = (0.14f32, 3.697f32);
        let r = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((tp.get(i) - r).abs() < 2e-3, "{} vs {r}", tp.get(i));
        // Gold is yellow: more red than blue.
        assert!(tp.get(grid.nearest(650.0)) > tp.get(grid.nearest(450.0)) + 0.3);
    }

    fn white_glossy(roughness: f32) -> Glossy {
        Glossy::new(SchlickFresnel { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 1.0)) }, roughness)
    }

    /// The anisotropic Glossy/metal lobe (Cycles' anisotropic GGX: alpha_x along the
    /// tangent): white furnace ≤ 1 with the sampled albedo equal to a quadrature of eval,
    /// compared with the isotropic lobe of the same √√(alpha_x·alpha_y) (the roughness
    /// Cycles' energy compensation reads for it), χ² of sample() against pdf(),
    /// reciprocity, and anisotropy 0 the isotropic lobe exactly.
    #[test]
    fn anisotropic_lobe_furnace_chi_square_and_reciprocity() {
        use crate::material::testing::{assert_reciprocal, chi_square, dir, quadrature_albedo, sampled_albedo};
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &(roughness, aniso, turns) in &[(0.5f32, 1.0f32, 0.0f32), (0.3, 0.7, 0.15), (0.8, 0.5, 0.6)] {
            let g = Ggx::principled_anisotropic(roughness, aniso);
            let t = TangentRotation::new(Vec3A::new(0.6, 0.8, 0.0), turns);
            let m = white_glossy(roughness).with_distribution(g, t);
            let iso = white_glossy(g.roughness());
            for (k, cos) in [1.0f32, 0.6, 0.25].into_iter().enumerate() {
                for phi in [0.0f32, 1.1] {
                    let wo = dir(cos, phi);
                    let (a, se) = sampled_albedo(&m, &ctx, wo, 40_000, 3 + k as u64, 0);
                    assert!(a <= 1.0 + 4.0 * se + 1e-3, "r {roughness} a {aniso} cos {cos}: albedo {a} ± {se}");
                    let q = quadrature_albedo(&m, &ctx, wo, 0);
                    assert!((a - q).abs() <= 4.0 * se + 0.01, "sampled {a} ± {se} vs quadrature {q}");
                    let qi = quadrature_albedo(&iso, &ctx, wo, 0);
                    // Stretching one axis loses more to masking than the isotropic lobe
                    // Cycles compensates with (up to 30 % at Anisotropic 1, roughness 0.5,
                    // head-on), and gains at most a little at grazing angles.
                    assert!(
                        q > 0.65 * qi && q < qi + 0.03,
                        "r {roughness} a {aniso} cos {cos} φ {phi}: {q} vs isotropic {qi}"
                    );
                }
            }
            chi_square(&m, &ctx, dir(0.7, 0.4), 100_000, 9);
            chi_square(&m, &ctx, dir(0.2, 2.5), 100_000, 10);
            assert_reciprocal(&m, &ctx, 400, 11);
        }
        // Anisotropy 0 is the isotropic lobe, bit for bit.
        let a = white_glossy(0.4)
            .with_distribution(Ggx::principled_anisotropic(0.4, 0.0), TangentRotation::new(Vec3A::Y, 0.3));
        let b = white_glossy(0.4);
        let (mut fa, mut fb) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        let mut rng = Rng::new(2, 2);
        for _ in 0..100 {
            let wo = dir(rng.uniform(), rng.uniform() * 6.0);
            let wi = dir(rng.uniform(), rng.uniform() * 6.0);
            assert_eq!(a.eval(&ctx, wo, wi, &mut fa), b.eval(&ctx, wo, wi, &mut fb));
            assert_eq!(fa.get(0), fb.get(0));
            let u = rng.uniform2();
            let (mut ta, mut tb) = (SampledSpectrum::splat(4, 1.0), SampledSpectrum::splat(4, 1.0));
            let (sa, sb) = (a.sample(&ctx, wo, u, 0.5, &mut ta), b.sample(&ctx, wo, u, 0.5, &mut tb));
            assert_eq!(sa.map(|s| s.wi), sb.map(|s| s.wi));
        }
    }

    /// The highlight stretches along the tangent: seen head-on, light tilted along the
    /// rough axis (the tangent) is reflected more than light tilted across it, and turning
    /// the tangent by a quarter turn swaps the two.
    #[test]
    fn anisotropic_highlight_follows_the_tangent() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let g = Ggx::principled_anisotropic(0.4, 1.0);
        let t = Vec3A::new(1.0, 1.0, 0.0).normalize();
        let m = white_glossy(0.4).with_distribution(g, TangentRotation::new(t, 0.0));
        let turned = white_glossy(0.4).with_distribution(g, TangentRotation::new(t, 0.25));
        let b = Vec3A::Z.cross(t);
        let along = (Vec3A::Z * 0.8 + t * 0.6).normalize();
        let across = (Vec3A::Z * 0.8 + b * 0.6).normalize();
        let mut f = SampledSpectrum::zeros(4);
        let v = |m: &Glossy, wi: Vec3A, f: &mut SampledSpectrum| {
            m.eval(&ctx, Vec3A::Z, wi, f);
            f.get(0)
        };
        let (a, c) = (v(&m, along, &mut f), v(&m, across, &mut f));
        assert!(a > 3.0 * c, "along the tangent {a}, across {c}");
        assert!((v(&turned, across, &mut f) - a).abs() < 1e-4 * a, "a quarter turn swaps the axes");
    }
}
