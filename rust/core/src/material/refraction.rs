//! Blender's Refraction BSDF: transmission only, with no reflection lobe and no Fresnel
//! factor, as Cycles' refraction closures (`bsdf_microfacet_ggx_refraction_setup` and
//! `bsdf_microfacet_beckmann_refraction_setup`, intern/cycles/kernel/closure/
//! bsdf_microfacet.h, with `MicrofacetFresnel::NONE`: reflectance 0, transmittance 1).
//! Smooth (roughness ≈ 0) it is a delta refraction; rough, a Walter et al. (2007)
//! microfacet transmission lobe over GGX (visible normals sampled) or Beckmann (normals
//! sampled ∝ D·cos θm). Where the refracted direction does not exist (total internal
//! reflection) the light is lost, and the light Fresnel would have reflected is
//! transmitted: the lobe does not conserve energy, exactly as Cycles' does not (no
//! multiple-scattering compensation either: Cycles gives the refraction closures none).
//!
//! Conventions as [`super::dielectric`]: the frame's +z is the side the ray arrived
//! from, the relative index crossed is `n` from outside (`ctx.front_face`) and `1/n`
//! from inside, radiance crossing is scaled by 1/η². A dispersive index collapses a
//! polychromatic ray to one wavelength (eq. 9), chosen ∝ β_i·w_i among the wavelengths
//! that refract at the sampled microfacet.

use super::dielectric::{common_index, microfacet_transmission, pick_lane, radiance_scale, relative};
use super::dispersion::IndexOfRefraction;
use super::fresnel::refract;
use super::microfacet::{Distribution, Ggx};
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// Transmission only; `distribution` None: smooth (a delta refraction).
pub struct Refraction {
    pub ior: IndexOfRefraction,
    pub distribution: Option<Distribution>,
}

impl Refraction {
    /// Blender's roughness on `distribution` ("GGX" or "BECKMANN"); smooth below
    /// [`Ggx::effectively_smooth`]'s alpha.
    pub fn new(ior: IndexOfRefraction, roughness: f32, beckmann: bool) -> Self {
        let g = Ggx::from_roughness(roughness);
        let d = if beckmann { Distribution::Beckmann(g.alpha_x) } else { Distribution::Ggx(g) };
        let distribution = (!g.effectively_smooth()).then_some(d);
        Self { ior, distribution }
    }

    /// f·|cos θi| and the pdf of a transmitted `wi` for relative index `eta` (wo.z > 0):
    /// the rough glass' transmission with weight 1 in place of Fresnel's.
    fn eval_eta(&self, ctx: &ShadingContext, m: &Distribution, eta: f32, wo: Vec3A, wi: Vec3A) -> (f32, f32) {
        if wo.z <= 0.0 {
            return (0.0, 0.0);
        }
        let (fc, pdf) = microfacet_transmission(ctx, m, eta, wo, wi, |_| 1.0);
        if fc.is_finite() && pdf.is_finite() {
            (fc, pdf)
        } else {
            (0.0, 0.0)
        }
    }
}

impl Bsdf for Refraction {
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::TRANSMISSION
    }
    fn flags(&self) -> BsdfFlags {
        let rough = self.distribution.is_some();
        BsdfFlags { smooth: rough, specular: !rough, dispersive: self.ior.dispersive }
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let (Some(m), Some(n)) = (&self.distribution, common_index(&self.ior, ctx)) else {
            out.fill(0.0);
            return 0.0;
        };
        let (f, pdf) = self.eval_eta(ctx, m, relative(n, ctx), wo, wi);
        out.fill(f);
        pdf
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        match (&self.distribution, common_index(&self.ior, ctx)) {
            (Some(m), Some(n)) => self.eval_eta(ctx, m, relative(n, ctx), wo, wi).1,
            _ => 0.0,
        }
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (wm, pdf_wm) = match &self.distribution {
            Some(m) => {
                let wm = m.sample_wm(wo, u);
                (wm, m.pdf_wm(wo, wm))
            }
            None => (Vec3A::Z, 1.0),
        };
        let c = wo.dot(wm);
        if !(c > 0.0 && pdf_wm > 0.0 && pdf_wm.is_finite()) {
            return None;
        }
        // The refracted direction at relative index `eta` and its weight f·|cos|/pdf and
        // pdf (delta: the radiance scale, pdf 1).
        let through = |eta: f32| -> Option<(Vec3A, f32, f32)> {
            let (wi, etap) = refract(wo, wm, eta)?;
            if wi.z >= 0.0 {
                return None;
            }
            let Some(m) = &self.distribution else { return Some((wi, radiance_scale(ctx, etap), 1.0)) };
            // f and pdf as eval() and pdf() have them at wi (the same half vector up to
            // rounding), so a sample's pdf is pdf()'s exactly (MIS) for narrow lobes too.
            let (f, pdf) = self.eval_eta(ctx, m, etap, wo, wi);
            let w = f / pdf;
            (pdf > 0.0 && pdf.is_finite() && w.is_finite()).then_some((wi, w, pdf))
        };
        let specular = self.distribution.is_none();
        if let Some(n) = common_index(&self.ior, ctx) {
            let (wi, w, pdf) = through(relative(n, ctx))?;
            throughput.scale(w);
            return Some(BsdfSample { wi, pdf, specular, collapsed_to: None });
        }
        // Dispersive, polychromatic: one wavelength ∝ its energy among those that refract.
        let weights = ctx.grid.weights();
        let energy: Vec<f32> = (0..throughput.len())
            .map(|i| {
                let refracts = refract(wo, wm, relative(self.ior.at(i), ctx)).is_some_and(|(wi, _)| wi.z < 0.0);
                if refracts {
                    throughput.get(i).max(0.0) * weights[i]
                } else {
                    0.0
                }
            })
            .collect();
        let uc = ctx.collapse_u.unwrap_or(uc);
        let (i, p) = pick_lane(&energy, uc.clamp(0.0, 0.999_999_9))?;
        let (wi, w, pdf) = through(relative(self.ior.at(i), ctx))?;
        throughput.keep_only(i);
        throughput.set(i, throughput.get(i) * w / p);
        // As RoughDielectric: a dispersive rough lobe reports its sample specular (no MIS:
        // the direction's density differs per wavelength).
        Some(BsdfSample { wi, pdf: pdf * p, specular: true, collapsed_to: Some(i) })
    }
    fn albedo(&self, _: &ShadingContext, out: &mut SampledSpectrum) {
        out.fill(1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::dispersion::IorDesc;
    use crate::material::testing::{chi_square, dir, quadrature_albedo, sampled_albedo};
    use crate::material::TransportMode;
    use crate::sampling::Rng;
    use crate::spectrum::WavelengthGrid;

    fn lobe(grid: &WavelengthGrid, ior: f64, roughness: f32, beckmann: bool) -> Refraction {
        let ior = IndexOfRefraction::build(&IorDesc::Constant { ior }, grid, "glass").unwrap();
        Refraction::new(ior, roughness, beckmann)
    }

    /// Importance mode (no 1/η² radiance scale): the transmitted energy alone.
    fn ctx(grid: &WavelengthGrid, front: bool) -> ShadingContext<'_> {
        let mut c = ShadingContext::new(grid);
        c.front_face = front;
        c.mode = TransportMode::Importance;
        c
    }

    /// White furnace: the transmitted energy is at most 1 (no Fresnel loss, but
    /// shadowing and total internal reflection lose light), equals the quadrature of
    /// eval over the sphere, and nothing is reflected; smooth refraction transmits 1
    /// where it can and nothing past the critical angle.
    #[test]
    fn refraction_only_energy_is_at_most_one_and_sampling_matches_eval() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        for beckmann in [false, true] {
            for (ior, front) in [(1.5, true), (1.5, false), (1.33, true)] {
                for r in [0.1f32, 0.3, 0.6, 1.0] {
                    let b = lobe(&grid, ior, r, beckmann);
                    let c = ctx(&grid, front);
                    for cos in [0.95f32, 0.6, 0.3] {
                        let wo = dir(cos, 0.4);
                        let (e, se) = sampled_albedo(&b, &c, wo, 40_000, 5, 0);
                        assert!(e <= 1.0 + 4.0 * se, "beckmann {beckmann} η {ior} front {front} r {r} cos {cos}: {e}");
                        // Smooth-ish, looking in along the normal from outside: almost all.
                        if front && r <= 0.1 && cos > 0.9 {
                            assert!(e > 0.97, "{e}");
                        }
                        if r < 0.3 {
                            continue; // a lobe narrower than the quadrature's cells
                        }
                        let q = quadrature_albedo(&b, &c, wo, 0);
                        assert!(
                            (e - q).abs() < 5.0 * se + 0.01 * q.max(0.05),
                            "beckmann {beckmann} η {ior} front {front} r {r} cos {cos}: sampled {e} ± {se} vs quadrature {q}"
                        );
                    }
                }
            }
        }
        // Smooth: weight 1 (importance) below the critical angle from inside, else no sample.
        let b = lobe(&grid, 1.5, 0.0, false);
        assert!(b.flags().specular && !b.flags().smooth);
        let mut rng = Rng::new(1, 2);
        for (cos, refracts) in [(0.9f32, true), (0.5, false)] {
            let mut tp = SampledSpectrum::splat(grid.len(), 1.0);
            let s = b.sample(&ctx(&grid, false), dir(cos, 0.0), rng.uniform2(), rng.uniform(), &mut tp);
            assert_eq!(s.is_some(), refracts, "cos {cos}");
            if let Some(s) = s {
                assert!(s.wi.z < 0.0 && (tp.get(0) - 1.0).abs() < 1e-6);
            }
        }
        // Radiance mode: the 1/η² of crossing into glass.
        let mut tp = SampledSpectrum::splat(grid.len(), 1.0);
        let mut rc = ctx(&grid, true);
        rc.mode = TransportMode::Radiance;
        b.sample(&rc, dir(1.0, 0.0), Vec2::splat(0.5), 0.5, &mut tp).unwrap();
        assert!((tp.get(0) - 1.0 / 2.25).abs() < 1e-5);
    }

    #[test]
    fn refraction_only_sampling_matches_pdf_chi_square() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        for beckmann in [false, true] {
            for (front, r) in [(true, 0.3f32), (false, 0.5), (true, 0.8)] {
                let b = lobe(&grid, 1.5, r, beckmann);
                for cos in [0.9f32, 0.4] {
                    chi_square(&b, &ctx(&grid, front), dir(cos, 1.0), 100_000, 11);
                }
            }
        }
    }

    /// A dispersive index collapses a polychromatic ray to one wavelength, unbiased per
    /// wavelength: the mean weight at each lane equals the single-wavelength lobe's.
    #[test]
    fn dispersive_refraction_collapses_unbiased() {
        let grid = WavelengthGrid::uniform(8, 400.0, 700.0).unwrap();
        let ior = IndexOfRefraction::build(&IorDesc::Named { name: "N-SF11".into() }, &grid, "flint").unwrap();
        let b = Refraction::new(ior, 0.4, false);
        let c = ctx(&grid, true);
        let wo = dir(0.7, 0.3);
        let n = 200_000;
        let mut rng = Rng::new(3, 4);
        let mut sums = vec![0.0f64; grid.len()];
        for _ in 0..n {
            let mut tp = SampledSpectrum::splat(grid.len(), 1.0);
            if let Some(s) = b.sample(&c, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                let i = s.collapsed_to.expect("collapsed");
                sums[i] += tp.get(i) as f64;
            }
        }
        for i in 0..grid.len() {
            let mut one = ctx(&grid, true);
            one.single_wavelength = Some(i);
            let (e, se) = sampled_albedo(&b, &one, wo, 40_000, 9, i);
            let got = sums[i] / n as f64;
            // The collapse keeps lane i with weight 1/p_i: its mean is lane i's albedo.
            assert!((got - e).abs() < 0.03 * e + 4.0 * se, "lane {i}: {got} vs {e}");
        }
    }
}
