//! Blender's Diffuse Roughness (Diffuse BSDF Roughness, Principled Diffuse Roughness):
//! the improved Oren–Nayar model of Yasuhiro Fujii ("A tiny improvement of Oren-Nayar
//! reflectance model", https://mimosa-pudica.net/improved-oren-nayar.html) with the
//! energy-preserving multiple-scattering term of the OpenPBR specification (the EON
//! form), exactly as Cycles builds it (`bsdf_oren_nayar_setup/get_intensity`,
//! intern/cycles/kernel/closure/bsdf_oren_nayar.h):
//!
//! ```text
//! f·cos θi = ρ cos θi [A + B·s/t  +  F_ms(ρ)·(1 − E(θi))(1 − E(θo))]
//! A = 1/(π + σ(π/2 − 2/3)),  B = σA,  s = wi·wo − cos θi cos θo,  t = max(cos θi, cos θo) if s > 0 else 1
//! E(θ) = πA + B·G(θ),  E_avg = πA + B(2π − 5.6)/3,  F_ms(ρ) = ρ E_avg / (π (1 − E_avg)(1 − ρ(1 − E_avg)))
//! ```
//!
//! (σ = roughness). E(θ) is the single-scattering term's directional albedo, so a white
//! surface reflects everything at every angle and roughness; every term is symmetric in
//! wo and wi (reciprocal). Roughness 0 is Lambertian. Sampled cosine-weighted.

use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam};
use crate::sampling::cosine_hemisphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, PI};

/// The model's constants for one roughness.
#[derive(Clone, Copy, Debug)]
pub struct OrenNayarLobe {
    a: f32,
    b: f32,
    e_avg: f32,
}

/// Fujii's G(θ): E(θ) = πA + B·G(θ) (with its Taylor expansion at grazing, as Cycles).
fn g(cos: f32) -> f32 {
    if cos < 1e-6 {
        return (FRAC_PI_2 - 2.0 / 3.0) - cos;
    }
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let theta = cos.clamp(-1.0, 1.0).acos();
    sin * (theta - 2.0 / 3.0 - sin * cos) + 2.0 / 3.0 * (sin / cos) * (1.0 - sin * sin * sin)
}

impl OrenNayarLobe {
    pub fn new(roughness: f32) -> Self {
        let sigma = if roughness.is_finite() { roughness.clamp(0.0, 1.0) } else { 0.0 };
        let a = 1.0 / (PI + sigma * (FRAC_PI_2 - 2.0 / 3.0));
        let b = sigma * a;
        Self { a, b, e_avg: a * PI + (2.0 * PI - 5.6) / 3.0 * b }
    }
    /// Directional albedo of the single-scattering term at cos θ.
    pub fn e(&self, cos: f32) -> f32 {
        self.a * PI + self.b * g(cos)
    }
    /// F_ms(ρ): the multiple-scattering term's colour per unit (1 − E)(1 − E).
    pub fn multiscatter(&self, rho: f32) -> f32 {
        let rho = rho.clamp(0.0, 1.0);
        let d = 1.0 - self.e_avg;
        if self.b <= 0.0 || d <= 1e-6 {
            return 0.0;
        }
        FRAC_1_PI * rho * (self.e_avg / d) / (1.0 - rho * d)
    }
    /// (single-scattering f·cos θi per unit ρ, (1 − E(θi))(1 − E(θo))·cos θi): both
    /// directions in the upper hemisphere.
    pub fn terms(&self, wo: Vec3A, wi: Vec3A) -> (f32, f32) {
        let (nl, nv) = (wi.z.max(0.0), wo.z.max(0.0));
        if self.b <= 0.0 {
            return (nl * FRAC_1_PI, 0.0);
        }
        let mut t = wi.dot(wo) - nl * nv;
        if t > 0.0 {
            t /= nl.max(nv) + f32::MIN_POSITIVE;
        }
        (nl * (self.a + self.b * t), nl * (1.0 - self.e(nl)) * (1.0 - self.e(nv)))
    }
}

/// Blender's Diffuse BSDF with roughness (or the Principled BSDF's diffuse base).
pub struct OrenNayar {
    pub reflectance: SpectralParam,
    pub lobe: OrenNayarLobe,
}

impl OrenNayar {
    pub fn new(reflectance: SpectralParam, roughness: f32) -> Self {
        Self { reflectance, lobe: OrenNayarLobe::new(roughness) }
    }
    fn eval_into(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) {
        let flip = |w: Vec3A| Vec3A::new(w.x, w.y, w.z.abs());
        let (single, multi) = self.lobe.terms(flip(wo), flip(wi));
        self.reflectance.evaluate_into(ctx, out);
        for v in out.values_mut() {
            let rho = *v;
            *v = rho * (single + self.lobe.multiscatter(rho) * multi);
        }
    }
}

impl Bsdf for OrenNayar {
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
        self.eval_into(ctx, wo, wi, out);
        wi.z.abs() * FRAC_1_PI
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
        if !(pdf > 0.0) || wo.z == 0.0 {
            return None;
        }
        let mut f = SampledSpectrum::zeros(throughput.len());
        self.eval_into(ctx, wo, wi, &mut f);
        f.scale(1.0 / pdf);
        throughput.mul_assign(&f);
        Some(BsdfSample { wi, pdf, specular: false, collapsed_to: None })
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        // Seen from the normal: ρ(E(0) + F_ms(ρ)(1 − E(0))·π(1 − E_avg)).
        self.reflectance.evaluate_into(ctx, out);
        let e0 = self.lobe.e(1.0);
        let ms = PI * (1.0 - self.lobe.e_avg) * (1.0 - e0);
        for v in out.values_mut() {
            let rho = *v;
            *v = (rho * (e0 + self.lobe.multiscatter(rho) * ms)).clamp(0.0, 1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::testing::{assert_reciprocal, chi_square, dir, quadrature_albedo, sampled_albedo};
    use crate::spectrum::WavelengthGrid;

    fn on(grid: &WavelengthGrid, rho: f32, r: f32) -> OrenNayar {
        OrenNayar::new(SpectralParam::Constant(SampledSpectrum::splat(grid.len(), rho)), r)
    }

    /// E(θ) is the directional albedo of the single-scattering term (Fujii's G checked
    /// against a quadrature of the model), and E_avg = 2∫E(μ)μ dμ.
    #[test]
    fn single_scattering_albedo_is_fujiis_e() {
        for &r in &[0.2f32, 0.6, 1.0] {
            let lobe = OrenNayarLobe::new(r);
            for &c in &[0.05f32, 0.4, 0.8, 1.0] {
                let wo = dir(c, 0.0);
                let (nt, np) = (600, 400);
                let mut q = 0.0f64;
                for i in 0..nt {
                    let ci = (i as f32 + 0.5) / nt as f32;
                    for j in 0..np {
                        let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
                        q += lobe.terms(wo, dir(ci, phi)).0 as f64;
                    }
                }
                q *= std::f64::consts::TAU / (nt * np) as f64;
                assert!((q - lobe.e(c) as f64).abs() < 2e-3, "σ {r} cos {c}: quadrature {q} vs E {}", lobe.e(c));
            }
            let n = 2000;
            let avg: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f32 + 0.5) / n as f32;
                    2.0 * (lobe.e(mu) * mu) as f64 / n as f64
                })
                .sum();
            assert!((avg - lobe.e_avg as f64).abs() < 2e-3, "σ {r}: E_avg {} vs {avg}", lobe.e_avg);
        }
    }

    /// White furnace: a white rough diffuse reflects everything at every angle; a grey
    /// one matches the quadrature of eval; roughness 0 is Lambertian.
    #[test]
    fn white_furnace_and_lambert_limit() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &r in &[0.0f32, 0.3, 0.7, 1.0] {
            for &c in &[0.1f32, 0.5, 0.9] {
                let wo = dir(c, 0.2);
                let (mean, se) = sampled_albedo(&on(&grid, 1.0, r), &ctx, wo, 20_000, 9, 0);
                assert!((mean - 1.0).abs() < 4.0 * se + 4e-3, "σ {r} cos {c}: {mean} ± {se}");
                let grey = on(&grid, 0.5, r);
                let (m2, se2) = sampled_albedo(&grey, &ctx, wo, 20_000, 10, 0);
                let q = quadrature_albedo(&grey, &ctx, wo, 0);
                assert!((m2 - q).abs() < 4.0 * se2 + 2e-3, "{m2} vs {q}");
                assert!(m2 < 0.5 + 4.0 * se2 + 0.01 && m2 > 0.35, "a grey rough diffuse darkens a little: {m2}");
            }
        }
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        on(&grid, 0.7, 0.0).eval(&ctx, dir(0.3, 0.0), dir(0.8, 2.0), &mut a);
        crate::material::Diffuse { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 0.7)) }.eval(
            &ctx,
            dir(0.3, 0.0),
            dir(0.8, 2.0),
            &mut b,
        );
        assert!((a.get(0) - b.get(0)).abs() < 1e-6);
    }

    #[test]
    fn reciprocal_and_sampling_matches_pdf() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let m = on(&grid, 0.6, 0.8);
        assert_reciprocal(&m, &ctx, 400, 1);
        chi_square(&m, &ctx, dir(0.4, 1.0), 50_000, 2);
        // Retro-reflection: rough diffuse is brighter towards the light than Lambert.
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        m.eval(&ctx, dir(0.3, 0.0), dir(0.3, 0.0), &mut a);
        m.eval(&ctx, dir(0.3, 0.0), dir(0.3, std::f32::consts::PI), &mut b);
        assert!(a.get(0) > 1.5 * b.get(0));
    }
}
