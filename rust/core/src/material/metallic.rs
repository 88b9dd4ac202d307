//! Blender's Metallic BSDF in Physical Conductor mode: GGX reflection with the exact
//! conductor Fresnel of a complex index η + ik per wavelength, and — with Multiscatter
//! GGX, the node's default — Cycles' energy compensation (`microfacet_ggx_preserve_energy`,
//! intern/cycles/kernel/closure/bsdf_microfacet.h): the single-scattering lobe scaled per
//! wavelength by 1 + F_ms·(1 − E(μ))/E(μ), E the GGX albedo for F = 1 at the view cosine μ,
//! F_ms = F_ss·E_avg/(1 − F_ss(1 − E_avg)) and F_ss Cycles' `fresnel_conductor_Fss`: the
//! hemispherical average of the F82 model fitted to the conductor at 0° and at cos θ = 1/7.
//! The pdf is unchanged (the factor is not sampled). As for rough glass, the view cosine
//! is `wo`'s on camera paths and `wi`'s on light paths, so both directions agree.

use super::conductor::Conductor;
use super::energy::{compensation, f82_average, ggx_e, ggx_e_avg};
use super::fresnel::fresnel_conductor;
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, TransportMode};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// Cycles' `fresnel_conductor_Fss`: the F82 model through F(0°) and F(cos θ = 1/7) of
/// the conductor, averaged over the hemisphere in closed form.
pub fn conductor_f_ss(eta: f32, k: f32) -> f32 {
    let f0 = fresnel_conductor(1.0, eta, k);
    let f82 = fresnel_conductor(1.0 / 7.0, eta, k);
    let f = 6.0f32 / 7.0;
    let f5 = f.powi(5);
    let b = 7.0 / (f5 * f) * (f0 + (1.0 - f0) * f5 - f82);
    f82_average(f0, b)
}

/// A conductor with Multiscatter GGX's energy compensation.
pub struct MultiscatterConductor {
    pub inner: Conductor,
    /// F_ss per grid lane.
    pub f_ss: SampledSpectrum,
}

impl MultiscatterConductor {
    pub fn new(inner: Conductor) -> Self {
        let n = inner.fresnel.eta.len();
        let f_ss = SampledSpectrum::from_slice(
            &(0..n).map(|i| conductor_f_ss(inner.fresnel.eta.get(i), inner.fresnel.k.get(i))).collect::<Vec<_>>(),
        );
        Self { inner, f_ss }
    }

    /// Multiplies `out` by the compensation seen from the view side of (wo, wi).
    fn compensate(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) {
        let g = &self.inner.ggx.distribution;
        if g.effectively_smooth() {
            return;
        }
        let view = match ctx.mode {
            TransportMode::Radiance => wo,
            TransportMode::Importance => wi,
        };
        let r = g.roughness();
        let (e, e_avg) = (ggx_e(r, view.z.abs().min(1.0)), ggx_e_avg(r));
        for i in 0..out.len() {
            out.set(i, out.get(i) * compensation(e, e_avg, self.f_ss.get(i)));
        }
    }
}

impl Bsdf for MultiscatterConductor {
    fn lobe_kinds(&self) -> u8 {
        self.inner.lobe_kinds()
    }
    fn flags(&self) -> BsdfFlags {
        self.inner.flags()
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let pdf = self.inner.eval(ctx, wo, wi, out);
        self.compensate(ctx, wo, wi, out);
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
        self.compensate(ctx, wo, s.wi, throughput);
        Some(s)
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.inner.albedo(ctx, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::conductor::ComplexFresnel;
    use crate::material::testing::{chi_square, dir, sampled_albedo};
    use crate::spectrum::WavelengthGrid;

    /// A conductor of η = 1e-4, k = 1e4 reflects everything (F = 1 at every angle): with
    /// the compensation it is a white furnace (albedo 1 within noise and the tables'
    /// accuracy) at every roughness and view angle; without it, it loses the multiple
    /// scattering. F_ss of a real metal lies between F0 and 1.
    #[test]
    fn a_perfect_conductor_with_multiscatter_is_a_white_furnace() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for r in [0.3f32, 0.6, 1.0] {
            let c = || {
                Conductor::new(
                    ComplexFresnel { eta: SampledSpectrum::splat(4, 1e-4), k: SampledSpectrum::splat(4, 1e4) },
                    r,
                )
            };
            let m = MultiscatterConductor::new(c());
            assert!((m.f_ss.get(0) - 1.0).abs() < 1e-3, "{:?}", m.f_ss);
            for cos in [0.9f32, 0.5, 0.2] {
                let wo = dir(cos, 0.3);
                let (e, se) = sampled_albedo(&m, &ctx, wo, 40_000, 3, 0);
                assert!((e - 1.0).abs() < 0.02 + 4.0 * se, "r {r} cos {cos}: {e} ± {se}");
                let (single, _) = sampled_albedo(&c(), &ctx, wo, 40_000, 3, 0);
                if r >= 0.6 {
                    assert!(single < 0.97, "r {r} cos {cos}: single scattering {single}");
                }
            }
            chi_square(&m, &ctx, dir(0.6, 0.3), 50_000, 7);
        }
        // Cycles' F_ss (the fitted F82 model's average) against a quadrature of the exact
        // conductor Fresnel's hemispherical average 2∫F(μ)μ dμ, for gold-, copper- and
        // aluminium-like indices and the node's default.
        for (eta, k) in [(0.2f32, 3.6f32), (1.1, 2.6), (1.2, 7.0), (2.757, 3.867)] {
            let n = 4000;
            let avg: f64 = (0..n)
                .map(|j| {
                    let mu = (j as f64 + 0.5) / n as f64;
                    2.0 * fresnel_conductor(mu as f32, eta, k) as f64 * mu / n as f64
                })
                .sum();
            let fss = conductor_f_ss(eta, k) as f64;
            assert!((fss - avg).abs() < 0.01, "η {eta} k {k}: F_ss {fss} vs quadrature {avg}");
        }
    }
}
