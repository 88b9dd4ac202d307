//! Multiple-scattering energy compensation of GGX lobes, as Cycles does it
//! (`microfacet_ggx_preserve_energy`, intern/cycles/kernel/closure/bsdf_microfacet.h):
//! a single-scattering lobe of directional albedo E(μ) loses 1 − E(μ) to light that
//! bounces more than once between the microfacets. Scaling the lobe by
//!
//! ```text
//! 1 + F_ms·(1 − E(μ))/E(μ),   F_ms = F_ss·E_avg / (1 − F_ss·(1 − E_avg))
//! ```
//!
//! gives that light back (Kulla & Conty 2017, "Revisiting Physically Based Shading at
//! Imageworks"): with F_ss = 1 (a white metal, a clear glass) the lobe becomes 1/E and
//! reflects everything; a coloured F_ss (the average Fresnel of a metal, a glass's tint)
//! darkens and saturates the extra light as repeated Fresnel events do. μ is the cosine
//! of the direction towards the camera (the view direction on camera paths, the sampled
//! direction on light paths), so both directions of tracing render the same image.
//!
//! The tables ([`super::energy_tables`]) come from `tools/gen_energy_tables.py` with
//! Cycles' axes; [`lookup_2d`]/[`lookup_3d`] interpolate them as Cycles'
//! `lookup_table_read_2D/3D` do (intern/cycles/kernel/util/lookup_table.h).

use super::energy_tables as t;

/// Linear interpolation on `n` samples of [0, 1] at `x` (clamped): (i0, i1, weight of i1).
#[inline]
fn cell(x: f32, n: usize) -> (usize, usize, f32) {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 } * (n - 1) as f32;
    let i = (x as usize).min(n - 1);
    (i, (i + 1).min(n - 1), x - i as f32)
}

/// Bilinear lookup: x fastest (`nx` samples), then y (`ny` rows).
#[inline]
pub fn lookup_2d(table: &[f32], nx: usize, ny: usize, x: f32, y: f32) -> f32 {
    let (x0, x1, tx) = cell(x, nx);
    let (y0, y1, ty) = cell(y, ny);
    let row = |j: usize| table[j * nx + x0] * (1.0 - tx) + table[j * nx + x1] * tx;
    row(y0) * (1.0 - ty) + row(y1) * ty
}

/// Trilinear lookup: x fastest, then y, then z (`nz` slabs of `nx`·`ny`).
#[inline]
pub fn lookup_3d(table: &[f32], n: usize, x: f32, y: f32, z: f32) -> f32 {
    let (z0, z1, tz) = cell(z, n);
    let a = lookup_2d(&table[z0 * n * n..(z0 + 1) * n * n], n, n, x, y);
    let b = lookup_2d(&table[z1 * n * n..(z1 + 1) * n * n], n, n, x, y);
    a * (1.0 - tz) + b * tz
}

#[inline]
fn lookup_1d(table: &[f32], x: f32) -> f32 {
    let (i0, i1, tx) = cell(x, table.len());
    table[i0] * (1.0 - tx) + table[i1] * tx
}

/// The tables' index coordinate z = √|(η − 1)/(η + 1)| (F0 = z⁴).
#[inline]
pub fn ior_coordinate(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).abs().sqrt()
}

/// E(μ) of a GGX reflection lobe with Fresnel 1 (Blender's roughness).
pub fn ggx_e(roughness: f32, mu: f32) -> f32 {
    lookup_2d(&t::GGX_E, 32, 32, roughness, mu)
}

/// 2∫E(μ)μ dμ of [`ggx_e`].
pub fn ggx_e_avg(roughness: f32) -> f32 {
    lookup_1d(&t::GGX_E_AVG, roughness)
}

/// The glass E tables' axes: [`GLASS_NZ`] index slabs of [`GLASS_NMU`] rows of
/// [`GLASS_NR`] roughness, the rows at √μ = j/(n − 1) (tools/gen_energy_tables.py).
pub const GLASS_NR: usize = 16;
pub const GLASS_NMU: usize = 32;
pub const GLASS_NZ: usize = 32;

/// Trilinear lookup of a glass E table at (roughness, √μ, z).
#[inline]
fn lookup_glass(table: &[f32], roughness: f32, mu: f32, z: f32) -> f32 {
    let y = if mu.is_finite() { mu.clamp(0.0, 1.0).sqrt() } else { 0.0 };
    let slab = GLASS_NR * GLASS_NMU;
    let (z0, z1, tz) = cell(z, GLASS_NZ);
    let a = lookup_2d(&table[z0 * slab..(z0 + 1) * slab], GLASS_NR, GLASS_NMU, roughness, y);
    let b = lookup_2d(&table[z1 * slab..(z1 + 1) * slab], GLASS_NR, GLASS_NMU, roughness, y);
    a * (1.0 - tz) + b * tz
}

/// E(μ) of a rough dielectric interface (reflection + refraction, energy) seen from the
/// side of relative index `eta` (far side over near side; below 1 from inside).
///
/// Unlike Cycles' 16³ `ggx_glass_E`, the tables have 32 index slabs and 32 rows in √μ,
/// and never read below the lobe's true albedo by more than 0.2 % at the generator's
/// check points (it raises the nodes where they would): near grazing view and η ≈ 1 the
/// albedo changes within a fraction of one of Cycles' cells, and a lookup below it makes
/// the compensated lobe gain energy (η 1.01 from inside, roughness 0.95, μ 0.01: Cycles'
/// axes read E 0.099 where the lobe's is 0.254, albedo 2.58).
pub fn glass_e(roughness: f32, mu: f32, eta: f32) -> f32 {
    if eta < 1.0 {
        lookup_glass(&t::GLASS_INV_E, roughness, mu, ior_coordinate(1.0 / eta))
    } else {
        lookup_glass(&t::GLASS_E, roughness, mu, ior_coordinate(eta))
    }
}

/// 2∫E(μ)μ dμ of [`glass_e`].
pub fn glass_e_avg(roughness: f32, eta: f32) -> f32 {
    if eta < 1.0 {
        lookup_2d(&t::GLASS_INV_E_AVG, 16, 16, roughness, ior_coordinate(1.0 / eta))
    } else {
        lookup_2d(&t::GLASS_E_AVG, 16, 16, roughness, ior_coordinate(eta))
    }
}

/// E(μ) of the reflection off a rough dielectric of index `eta` ≥ 1 (a coat, the
/// Principled specular layer), single scattering.
pub fn dielectric_e(roughness: f32, mu: f32, eta: f32) -> f32 {
    lookup_3d(&t::DIELECTRIC_E, 16, roughness, mu, ior_coordinate(eta.max(1.0)))
}

/// 2∫E(μ)μ dμ of [`dielectric_e`].
pub fn dielectric_e_avg(roughness: f32, eta: f32) -> f32 {
    lookup_2d(&t::DIELECTRIC_E_AVG, 16, 16, roughness, ior_coordinate(eta.max(1.0)))
}

/// 2∫F(μ)μ dμ of a smooth dielectric of relative index `eta`.
pub fn fresnel_avg(eta: f32) -> f32 {
    if eta < 1.0 {
        lookup_1d(&t::FRESNEL_INV_AVG, ior_coordinate(1.0 / eta))
    } else {
        lookup_1d(&t::FRESNEL_AVG, ior_coordinate(eta))
    }
}

/// F_ms = F_ss·E_avg / (1 − F_ss·(1 − E_avg)): the colour of the light that scattered
/// more than once, per unit of lost energy.
#[inline]
pub fn multiscatter_color(f_ss: f32, e_avg: f32) -> f32 {
    let d = 1.0 - f_ss * (1.0 - e_avg);
    if d > 1e-6 {
        (f_ss * e_avg / d).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The factor 1 + F_ms·(1 − E)/E that turns a single-scattering lobe of albedo `e` into
/// one with its multiple scattering (1 when nothing is lost or E is degenerate).
#[inline]
pub fn compensation(e: f32, e_avg: f32, f_ss: f32) -> f32 {
    if !(e > 1e-4 && e < 1.0) {
        return 1.0;
    }
    1.0 + multiscatter_color(f_ss, e_avg) * (1.0 - e) / e
}

/// The factor of a rough dielectric interface with its multiple scattering (Blender's
/// Multiscatter GGX glass), seen from cosine `mu` on the side of relative index
/// `eta_rel`; `f_ss` is the colour the repeated events take (Cycles uses the glass's
/// transmission tint; 1 for clear glass).
pub fn glass_compensation(roughness: f32, mu: f32, eta_rel: f32, f_ss: f32) -> f32 {
    compensation(glass_e(roughness, mu, eta_rel), glass_e_avg(roughness, eta_rel), f_ss)
}

/// The factor of a GGX reflection lobe of average Fresnel `f_ss` (Multiscatter GGX
/// metals and Glossy), seen from cosine `mu`.
pub fn reflection_compensation(roughness: f32, mu: f32, f_ss: f32) -> f32 {
    compensation(ggx_e(roughness, mu), ggx_e_avg(roughness), f_ss)
}

/// 2∫F(μ)μ dμ of Blender's F82-tint Fresnel F0 + (1 − F0)(1 − μ)⁵ − b·μ(1 − μ)⁶ (Cycles'
/// `bsdf_microfacet_setup_fresnel_f82_tint`): F0 + (1 − F0)/21 − b/126; b = 0 is
/// Schlick's average.
pub fn f82_average(f0: f32, b: f32) -> f32 {
    (f0 + (1.0 - f0) / 21.0 - b / 126.0).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::fresnel::fresnel_dielectric_f64;

    #[test]
    fn lookups_hit_the_table_samples_and_interpolate_between_them() {
        // At sample points the lookup returns the stored value.
        assert_eq!(ggx_e(1.0, 1.0), t::GGX_E[32 * 31 + 31]);
        assert_eq!(ggx_e(0.0, 0.0), t::GGX_E[0]);
        let mid = ggx_e(0.5 / 31.0, 1.0);
        assert!((mid - 0.5 * (t::GGX_E[32 * 31] + t::GGX_E[32 * 31 + 1])).abs() < 1e-6);
        // Out of range and NaN inputs stay inside the table.
        for v in [ggx_e(f32::NAN, 2.0), glass_e(-1.0, f32::INFINITY, 0.0), dielectric_e(3.0, -1.0, f32::NAN)] {
            assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{v}");
        }
    }

    /// Smooth limits in closed form: a nearly smooth interface conserves energy, its
    /// reflection is Fresnel's, and a rough one loses energy (E < 1) most at grazing.
    #[test]
    fn tables_match_closed_forms_in_the_smooth_limit() {
        for &eta in &[1.33f32, 1.5, 2.4] {
            assert!((glass_e(0.0, 0.6, eta) - 1.0).abs() < 2e-3);
            assert!((glass_e(0.0, 0.6, 1.0 / eta) - 1.0).abs() < 2e-3);
            let z = ior_coordinate(eta);
            // Between z samples the interpolated Fresnel is close to the exact one.
            let f = fresnel_dielectric_f64(1.0, eta as f64) as f32;
            assert!((dielectric_e(0.0, 1.0, eta) - f).abs() < 0.01 * f + 2e-3, "η {eta} z {z}");
        }
        assert!(ggx_e(0.0, 0.5) > 0.999);
        // Cycles' own tabulation (shader.tables, table_ggx_E) at r = 12/31, 28/31, μ = 1.
        assert!((ggx_e(12.0 / 31.0, 1.0) - 0.971982).abs() < 2e-3);
        assert!((ggx_e(28.0 / 31.0, 1.0) - 0.415925).abs() < 2e-3);
        assert!(ggx_e_avg(1.0) < ggx_e_avg(0.5) && ggx_e_avg(0.5) < 1.0);
        // The average Fresnel of n = 1.5 glass from outside (Stern 1964: 0.0918) and
        // from inside 1 − (1 − 0.0918)/n² (energy conservation across the interface).
        assert!((fresnel_avg(1.5) - 0.0918).abs() < 3e-3, "{}", fresnel_avg(1.5));
        let inside = 1.0 - (1.0 - 0.0918) / (1.5 * 1.5);
        assert!((fresnel_avg(1.0 / 1.5) - inside).abs() < 5e-3, "{} vs {inside}", fresnel_avg(1.0 / 1.5));
    }

    /// F82's average against a quadrature of Blender's F82-tint Fresnel
    /// (principled::f82_tint), with b chosen as Cycles does from the tint.
    #[test]
    fn f82_average_is_the_cosine_weighted_mean() {
        for &(f0, tint) in &[(0.9f32, 1.0f32), (0.5, 0.6), (0.04, 0.6), (0.95, 0.9)] {
            let f = 6.0f32 / 7.0;
            let f5 = f.powi(5);
            let b = (f0 + (1.0 - f0) * f5) * (7.0 / (f5 * f)) * (1.0 - tint);
            let n = 20_000;
            let q: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f32 + 0.5) / n as f32;
                    2.0 * (crate::material::principled::f82_tint(mu, f0, tint) * mu) as f64 / n as f64
                })
                .sum();
            assert!((f82_average(f0, b) as f64 - q).abs() < 1e-3, "F0 {f0} tint {tint}: {} vs {q}", f82_average(f0, b));
        }
    }

    #[test]
    fn compensation_restores_the_lost_energy() {
        // White: the lobe's albedo E becomes 1.
        for &e in &[0.3f32, 0.7, 0.95] {
            assert!((e * compensation(e, 0.6, 1.0) - 1.0).abs() < 1e-6);
        }
        // Coloured: between E and 1, and darker for darker F_ss.
        let a = 0.7 * compensation(0.7, 0.6, 0.9);
        let b = 0.7 * compensation(0.7, 0.6, 0.5);
        assert!(0.7 < b && b < a && a < 1.0);
        assert_eq!(compensation(1.0, 1.0, 0.5), 1.0);
        assert_eq!(compensation(0.0, 0.0, 0.5), 1.0);
    }

    /// The tables (computed in Python by tools/gen_energy_tables.py) agree with the Rust
    /// BSDFs' own sampled albedo: GGX reflection with F = 1, and the rough dielectric's
    /// reflection + refraction from both sides and its reflection alone.
    #[test]
    fn tables_agree_with_the_rust_bsdfs() {
        use crate::material::conductor::{Glossy, SchlickFresnel};
        use crate::material::microfacet::Ggx;
        use crate::material::testing::dir;
        use crate::material::{IndexOfRefraction, RoughDielectric, SpectralParam, TransportMode};
        use crate::sampling::Rng;
        use crate::spectrum::{SampledSpectrum, WavelengthGrid};
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let mut ctx = crate::material::ShadingContext::new(&grid);
        ctx.mode = TransportMode::Importance;
        let n = 40_000;
        let mean = |bsdf: &dyn crate::material::Bsdf, ctx: &crate::material::ShadingContext, wo, reflect_only: bool| {
            let mut rng = Rng::new(5, 5);
            let (mut s1, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let mut tp = SampledSpectrum::splat(4, 1.0);
                if let Some(s) = bsdf.sample(ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                    if !reflect_only || s.wi.z > 0.0 {
                        let v = tp.get(0) as f64;
                        s1 += v;
                        s2 += v * v;
                    }
                }
            }
            let m = s1 / n as f64;
            (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
        };
        // Table nodes: r = i/15 (or /31), μ = j/15, z = k/15.
        for &(ri, mj) in &[(8usize, 8usize), (15, 4), (5, 12), (12, 2)] {
            let (r, mu) = (ri as f32 / 15.0, mj as f32 / 15.0);
            let white = SpectralParam::Constant(SampledSpectrum::splat(4, 1.0));
            let g = Glossy::new(SchlickFresnel { reflectance: white }, r);
            let (m, se) = mean(&g, &ctx, dir(mu, 0.0), false);
            let e = ggx_e(r, mu) as f64;
            assert!((m - e).abs() < 4.0 * se + 3e-3, "GGX r {r} μ {mu}: Rust {m} ± {se} vs table {e}");
            for &zk in &[5usize, 9] {
                let z = zk as f32 / 15.0;
                let eta = (1.0 + z * z) / (1.0 - z * z);
                let glass = RoughDielectric {
                    ior: IndexOfRefraction::constant(4, eta),
                    distribution: Ggx::from_roughness(r),
                    multiscatter: false,
                };
                for &front in &[true, false] {
                    ctx.front_face = front;
                    let rel = if front { eta } else { 1.0 / eta };
                    let (m, se) = mean(&glass, &ctx, dir(mu, 0.0), false);
                    let e = glass_e(r, mu, rel) as f64;
                    assert!(
                        (m - e).abs() < 4.0 * se + 3e-3,
                        "glass r {r} μ {mu} η {rel}: Rust {m} ± {se} vs table {e}"
                    );
                }
                ctx.front_face = true;
                let (m, se) = mean(&glass, &ctx, dir(mu, 0.0), true);
                let e = dielectric_e(r, mu, eta) as f64;
                assert!(
                    (m - e).abs() < 4.0 * se + 3e-3,
                    "reflection r {r} μ {mu} η {eta}: Rust {m} ± {se} vs table {e}"
                );
            }
        }
    }
}
