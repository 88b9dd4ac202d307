//! Free flights through homogeneous media (docs/media.md): what happens to a path
//! between two surfaces when it travels inside media whose coefficients depend on
//! wavelength.
//!
//! * Pure absorption needs no distance sampling: every lane is multiplied by its own
//!   Beer–Lambert transmittance exp(−σa(λ)·d) and the path stays polychromatic.
//! * Scattering needs a free-flight distance, and one distance does not serve lanes of
//!   different extinction — the volumetric twin of dispersion. Two answers
//!   ([`MediumSampling`]): COLLAPSE, the paper's (eq. 9): the path collapses to one
//!   wavelength chosen ∝ its energy and flies as a monochromatic path; SPECTRAL_MIS
//!   (Wilkie et al. 2014, "Hero Wavelength Spectral Sampling"; pbrt-v4's volpath keeps
//!   the same ratios as `r_u`): the distance is sampled from one lane chosen ∝
//!   throughput and every lane is weighted by its own density over the average density
//!   of all lanes (one-sample MIS, balance heuristic), so the path keeps every
//!   wavelength. When σt is the same on every carried lane neither is needed: the
//!   sampled distance is exact for all.
//! * Emission (per unit length) is integrated analytically along the segment,
//!   ∫₀ᵈ T(t)·E dt, before the distance is sampled.

use super::throughput::Throughput;
use crate::medium::homogeneous::{emission_integral, transmittance};
use crate::render::MediumSampling;
use crate::sampling::Rng;
use crate::scene::media::Coefficients;
use crate::spectrum::SampledSpectrum;

/// The outcome of a free flight over a segment of length `d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// The path reached the segment's end (the next surface, or escaped); its
    /// throughput carries the transmittance (over its probability).
    Through,
    /// It scattered at distance `t`; the throughput carries σs·T over the pdf.
    Scattered { t: f32 },
    /// Nothing carries on.
    Absorbed,
}

/// The extinction differs between carried lanes: one distance cannot serve them all.
fn chromatic<T: Throughput>(c: &Coefficients, beta: &T) -> bool {
    let mut first = None;
    for j in 0..beta.lanes() {
        if beta.lane(j) == 0.0 {
            continue;
        }
        let s = c.sigma_t.get(beta.lane_index(j));
        match first {
            None => first = Some(s),
            Some(f) if f != s => return true,
            _ => {}
        }
    }
    false
}

/// COLLAPSE: the grid wavelength a whole-spectrum path collapses to before a flight in a
/// scattering medium whose extinction depends on wavelength, chosen with probability
/// p(λi) ∝ βi·wi (its denormalised energy, eq. 9, `weights` the grid's quadrature);
/// `beta` keeps that lane only, divided by p. None: no collapse needed (another
/// setting, a single-wavelength or hero path, no scattering, or a grey medium).
pub fn collapse<T: Throughput>(
    c: &Coefficients,
    beta: &mut T,
    sampling: MediumSampling,
    weights: &[f32],
    rng: &mut Rng,
) -> Option<usize> {
    if sampling != MediumSampling::Collapse || !c.scatters || beta.lanes() < 2 || beta.hero().is_some() {
        return None;
    }
    if !chromatic(c, beta) {
        return None;
    }
    let energy = |j: usize| (beta.lane(j) * weights[beta.lane_index(j)]).max(0.0);
    let total: f32 = (0..beta.lanes()).map(energy).sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut pick = rng.uniform() * total;
    let mut chosen = beta.lanes() - 1;
    for j in 0..beta.lanes() {
        let e = energy(j);
        if pick < e && e > 0.0 {
            chosen = j;
            break;
        }
        pick -= e;
    }
    while energy(chosen) == 0.0 && chosen > 0 {
        chosen -= 1; // rounding left the pick past the last lane with energy
    }
    let p = energy(chosen) / total;
    for j in 0..beta.lanes() {
        let v = if j == chosen { beta.lane(j) / p } else { 0.0 };
        beta.set_lane(j, v);
    }
    Some(beta.lane_index(chosen))
}

/// The radiance a segment of length `d` emits towards its start, per grid lane, into
/// `out`: E(λ)·∫₀ᵈ exp(−σt(λ)·t) dt (zero where that is not finite: an emitting medium
/// that never ends).
pub fn segment_emission(c: &Coefficients, d: f32, out: &mut SampledSpectrum) {
    for i in 0..out.len() {
        let e = c.emission.get(i);
        let v = if e > 0.0 { e * emission_integral(c.sigma_t.get(i), d) } else { 0.0 };
        out.set(i, if v.is_finite() { v } else { 0.0 });
    }
}

/// A free flight over a segment of length `d` (∞: the ray escapes) inside media `c`,
/// multiplying `beta` by its weight (see the module's notes; a whole-spectrum path has
/// been collapsed by [`collapse`] first when the setting says so).
pub fn fly<T: Throughput>(c: &Coefficients, d: f32, beta: &mut T, rng: &mut Rng) -> Flight {
    let n = beta.lanes();
    let sigma_t = |j: usize, b: &T| c.sigma_t.get(b.lane_index(j));
    if !c.scatters {
        // Beer–Lambert per lane, no distance to sample.
        let mut alive = false;
        for j in 0..n {
            let v = beta.lane(j) * transmittance(sigma_t(j, beta), d);
            alive |= v != 0.0;
            beta.set_lane(j, v);
        }
        return if alive { Flight::Through } else { Flight::Absorbed };
    }
    // The lane whose extinction samples the distance, ∝ throughput.
    let total: f32 = (0..n).map(|j| beta.lane(j).abs()).sum();
    if !(total > 0.0 && total.is_finite()) {
        return Flight::Absorbed;
    }
    let mut pick = rng.uniform() * total;
    let mut lane = n - 1;
    for j in 0..n {
        let q = beta.lane(j).abs();
        if pick < q && q > 0.0 {
            lane = j;
            break;
        }
        pick -= q;
    }
    let u = rng.uniform();
    let s = sigma_t(lane, beta);
    let t = if s > 0.0 { -(1.0 - u).ln() / s } else { f32::INFINITY };
    let q = |j: usize, b: &T| b.lane(j).abs() / total;
    if t < d {
        // Scattered: lane j's density of t is σt·exp(−σt·t); the weight σs·T over the
        // lanes' average density (balance heuristic).
        let denom: f32 = (0..n)
            .map(|j| {
                let st = sigma_t(j, beta);
                q(j, beta) * st * transmittance(st, t)
            })
            .sum();
        if !(denom > 0.0 && denom.is_finite()) {
            return Flight::Absorbed;
        }
        for j in 0..n {
            let i = beta.lane_index(j);
            let v = beta.lane(j) * c.sigma_s.get(i) * transmittance(c.sigma_t.get(i), t) / denom;
            beta.set_lane(j, v);
        }
        Flight::Scattered { t }
    } else {
        // Through: lane j's probability of flying past d is T(d).
        let denom: f32 = (0..n).map(|j| q(j, beta) * transmittance(sigma_t(j, beta), d)).sum();
        if !(denom > 0.0 && denom.is_finite()) {
            return Flight::Absorbed;
        }
        for j in 0..n {
            let v = beta.lane(j) * transmittance(sigma_t(j, beta), d) / denom;
            beta.set_lane(j, v);
        }
        Flight::Through
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::throughput::SingleWavelength;

    fn coefficients(sigma_a: &[f32], sigma_s: &[f32]) -> Coefficients {
        let mut c = Coefficients::new(sigma_a.len());
        c.sigma_s = SampledSpectrum::from_slice(sigma_s);
        c.sigma_t = SampledSpectrum::from_slice(sigma_a);
        c.sigma_t.add_assign(&c.sigma_s);
        c.scatters = !c.sigma_s.is_black();
        c.scattering_media = c.scatters as usize;
        c
    }

    /// The expected weight of flying through a slab of thickness d without scattering is
    /// exp(−σt·d) per lane, and of scattering inside it is (σs/σt)(1 − exp(−σt·d)) — the
    /// closed forms — for spectral MIS on lanes of very different extinction, and for
    /// single-wavelength paths (what COLLAPSE flies).
    #[test]
    fn flight_weights_are_unbiased_per_lane() {
        let sa = [0.1f32, 1.0, 3.0, 0.0];
        let ss = [0.5f32, 0.2, 1.0, 0.0];
        let c = coefficients(&sa, &ss);
        let d = 0.8f32;
        let n = 200_000;
        let mut rng = Rng::new(11, 0);
        let (mut through, mut scattered) = ([0.0f64; 4], [0.0f64; 4]);
        let (mut single_through, mut single_scattered) = ([0.0f64; 4], [0.0f64; 4]);
        for _ in 0..n {
            let mut b = SampledSpectrum::splat(4, 1.0);
            match fly(&c, d, &mut b, &mut rng) {
                Flight::Through => (0..4).for_each(|i| through[i] += b.get(i) as f64),
                Flight::Scattered { t } => {
                    assert!(t < d);
                    (0..4).for_each(|i| scattered[i] += b.get(i) as f64)
                }
                Flight::Absorbed => {}
            }
            for i in 0..4 {
                let mut s = SingleWavelength { index: i, value: 1.0 };
                match fly(&c, d, &mut s, &mut rng) {
                    Flight::Through => single_through[i] += s.value as f64,
                    Flight::Scattered { .. } => single_scattered[i] += s.value as f64,
                    Flight::Absorbed => {}
                }
            }
        }
        for i in 0..4 {
            let st = (sa[i] + ss[i]) as f64;
            let tr = (-st * d as f64).exp();
            let sc = if st > 0.0 { ss[i] as f64 / st * (1.0 - tr) } else { 0.0 };
            for (what, t, s) in [("MIS", through[i], scattered[i]), ("single", single_through[i], single_scattered[i])]
            {
                let (t, s) = (t / n as f64, s / n as f64);
                assert!((t - tr).abs() < 0.01 * tr.max(0.1), "{what} lane {i}: through {t} vs {tr}");
                assert!((s - sc).abs() < 0.01 * sc.max(0.1), "{what} lane {i}: scattered {s} vs {sc}");
            }
        }
    }

    /// COLLAPSE keeps one lane with weight β/p, unbiased per lane; grey media, hero and
    /// single-wavelength paths never collapse.
    #[test]
    fn collapse_is_unbiased_and_only_where_needed() {
        let c = coefficients(&[0.1, 1.0, 3.0], &[0.5, 0.5, 0.5]);
        let w = [10.0f32, 20.0, 10.0];
        let beta0 = SampledSpectrum::from_slice(&[0.2, 1.0, 0.5]);
        let mut rng = Rng::new(2, 2);
        let n = 100_000;
        let mut sum = [0.0f64; 3];
        for _ in 0..n {
            let mut b = beta0.clone();
            let i = collapse(&c, &mut b, MediumSampling::Collapse, &w, &mut rng).expect("chromatic");
            for k in 0..3 {
                assert!(k == i || b.get(k) == 0.0);
                sum[k] += b.get(k) as f64;
            }
        }
        for k in 0..3 {
            let m = sum[k] / n as f64;
            assert!((m - beta0.get(k) as f64).abs() < 0.02 * beta0.get(k) as f64 + 1e-3, "lane {k}: {m}");
        }
        let mut b = beta0.clone();
        assert_eq!(collapse(&c, &mut b, MediumSampling::SpectralMis, &w, &mut rng), None);
        let grey = coefficients(&[1.0, 1.0, 1.0], &[0.5, 0.5, 0.5]);
        assert_eq!(collapse(&grey, &mut b, MediumSampling::Collapse, &w, &mut rng), None);
        let mut s = SingleWavelength { index: 1, value: 1.0 };
        assert_eq!(collapse(&c, &mut s, MediumSampling::Collapse, &w, &mut rng), None);
    }

    /// Pure absorption is Beer–Lambert exactly, per lane, with no random numbers; huge
    /// and zero coefficients, infinite segments give finite weights.
    #[test]
    fn absorption_is_exact_and_extremes_are_finite() {
        let c = coefficients(&[0.0, 0.5, 1e30], &[0.0, 0.0, 0.0]);
        let mut rng = Rng::new(1, 1);
        let mut b = SampledSpectrum::splat(3, 1.0);
        assert_eq!(fly(&c, 2.0, &mut b, &mut rng), Flight::Through);
        assert_eq!(b.values(), &[1.0, (-1.0f32).exp(), 0.0]);
        let mut b = SampledSpectrum::splat(3, 1.0);
        assert_eq!(fly(&c, f32::INFINITY, &mut b, &mut rng), Flight::Through);
        assert_eq!(b.values(), &[1.0, 0.0, 0.0]);
        let huge = coefficients(&[1e30, 0.0], &[1e30, 1e30]);
        for _ in 0..100 {
            let mut b = SampledSpectrum::splat(2, 1.0);
            let f = fly(&huge, 1.0, &mut b, &mut rng);
            assert!(b.is_finite() && f != Flight::Through, "{f:?} {b:?}");
        }
        let mut e = SampledSpectrum::zeros(2);
        let mut em = coefficients(&[0.0, 1e30], &[0.0, 0.0]);
        em.emission = SampledSpectrum::splat(2, 1.0);
        segment_emission(&em, f32::INFINITY, &mut e);
        assert_eq!(e.values(), &[0.0, 1e-30]);
    }
}
