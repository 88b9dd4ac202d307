//! The random walk of subsurface scattering: a path inside a homogeneous medium bounded
//! by the object's surface, from the entry point until it crosses the surface again.
//! The model and its sampling are Cycles' (`subsurface_random_walk`,
//! intern/cycles/kernel/integrator/subsurface_random_walk.h), written for any number of
//! wavelengths: every lane of the path's spectrum walks the same path, the distance is
//! sampled from one lane chosen ∝ throughput × single-scattering albedo (Chiang, Kutz &
//! Burley 2016, "Practical and Controllable Subsurface Scattering for Production Path
//! Tracing") and weighted by the balance heuristic over all lanes, so a polychromatic
//! path keeps its whole spectrum and the colour shift with depth comes out per
//! wavelength.
//!
//! * Coefficients ([`SubsurfaceMedium::from_albedo`]): the single-scattering albedo α
//!   that makes a semi-infinite medium reflect the surface albedo A (Cycles' fit in g),
//!   σt = 1/(d(1 − g)) for the mean free path d.
//! * Directions: Henyey–Greenstein, mixed with Dwivedi sampling guided towards the entry
//!   plane or, when the first ray found an opposite side nearby, away from it
//!   (Křivánek & d'Eon 2014; Meng, Hanika & Dachsbacher 2016; d'Eon & Křivánek 2020),
//!   weighted by the balance heuristic between classic and guided sampling.

use super::phase::{around, HenyeyGreenstein};
use crate::sampling::Rng;
use crate::spectrum::SampledSpectrum;
use glam::Vec3A;
use std::f32::consts::TAU;

/// Scattering events after which a walk gives up (Cycles' BSSRDF_MAX_BOUNCES).
pub const MAX_BOUNCES: usize = 256;
/// Below this single-scattering albedo the walk raises α and lowers the weight instead
/// (Cycles: avoids infinite guided phase functions as A → 0).
const MIN_ALPHA: f32 = 0.2;
/// A walk whose throughput falls below this in every lane stops (absorbed).
const THROUGHPUT_EPSILON: f32 = 1e-6;

/// The medium: extinction and single-scattering albedo per wavelength lane, one phase
/// function.
#[derive(Clone, Debug)]
pub struct SubsurfaceMedium {
    pub sigma_t: SampledSpectrum,
    pub alpha: SampledSpectrum,
    pub phase: HenyeyGreenstein,
}

/// Where a walk left the medium.
#[derive(Clone, Copy, Debug)]
pub struct WalkExit<H> {
    /// What the boundary reported for the crossing.
    pub hit: H,
    pub position: Vec3A,
    /// The travel direction at the crossing (leaving the medium).
    pub direction: Vec3A,
}

/// The surface around the medium, as the walk sees it.
pub trait Boundary {
    type Hit: Copy;
    /// The first crossing of the boundary along `origin + t·dir` with 0 < t ≤ `tmax`.
    /// `first`: the ray starts on the surface it entered through.
    fn intersect(&mut self, origin: Vec3A, dir: Vec3A, tmax: f32, first: bool) -> Option<(f32, Self::Hit)>;
}

/// Cycles' fit of the single-scattering albedo α that gives a semi-infinite,
/// index-matched medium under diffuse light the multiple-scattering albedo `albedo`, for
/// asymmetry `g` (`subsurface_random_walk_remap`;
/// coefficients fitted by the Cycles developers, Blender 2.9x).
#[allow(clippy::excessive_precision)] // the published coefficients, as published
pub fn single_scattering_albedo(albedo: f32, g: f32) -> f32 {
    let g2 = g * g;
    let g3 = g2 * g;
    let g4 = g3 * g;
    let g5 = g4 * g;
    let g6 = g5 * g;
    let g7 = g6 * g;
    let a = 1.8260523782
        + -1.28451056436 * g
        + -1.79904629312 * g2
        + 9.19393289202 * g3
        + -22.8215585862 * g4
        + 32.0234874259 * g5
        + -23.6264803333 * g6
        + 7.21067002658 * g7;
    let b = 4.98511194385
        + 0.127355959438
            * (31.1491581433 * g
                + -201.847017512 * g2
                + 841.576016723 * g3
                + -2018.09288505 * g4
                + 2731.71560286 * g5
                + -1935.41424244 * g6
                + 559.009054474 * g7)
                .exp();
    let c = 1.09686102424
        + -0.394704063468 * g
        + 1.05258115941 * g2
        + -8.83963712726 * g3
        + 28.8643230661 * g4
        + -46.8802913581 * g5
        + 38.5402837518 * g6
        + -12.7181042538 * g7;
    let d = 0.496310210422
        + 0.360146581622 * g
        + -2.15139309747 * g2
        + 17.8896899217 * g3
        + -55.2984010333 * g4
        + 82.065982243 * g5
        + -58.5106008578 * g6
        + 15.8478295021 * g7;
    let e = 4.23190299701
        + 0.00310603949088
            * (76.7316253952 * g
                + -594.356773233 * g2
                + 2448.8834203 * g3
                + -5576.68528998 * g4
                + 7116.60171912 * g5
                + -4763.54467887 * g6
                + 1303.5318055 * g7)
                .exp();
    let f = 2.40602999408
        + -2.51814844609 * g
        + 9.18494908356 * g2
        + -79.2191708682 * g3
        + 259.082868209 * g4
        + -403.613804597 * g5
        + 302.85712436 * g6
        + -87.4370473567 * g7;
    let blend = albedo.powf(0.25);
    let alpha = (1.0 - blend) * a * (b * albedo).atan().powf(c) + blend * d * (e * albedo).atan().powf(f);
    alpha.clamp(0.0, 0.999_999)
}

/// Dwivedi's diffusion length for single-scattering albedo α (d'Eon & Křivánek 2020,
/// eq. 67).
fn diffusion_length(alpha: f32) -> f32 {
    1.0 / (1.0 - alpha.powf(2.44294 - 0.0215813 * alpha + 0.578637 / alpha)).sqrt()
}

/// The guided phase function's density over cos θ about the guiding axis, with
/// `log` = ln((v + 1)/(v − 1)) (Meng et al. 2016, eq. 9), and its inverse CDF (eq. 10).
fn dwivedi_eval(v: f32, log: f32, cos: f32) -> f32 {
    1.0 / ((v - cos) * log)
}
fn dwivedi_sample(v: f32, log: f32, u: f32) -> f32 {
    (v - (v + 1.0) * (-u * log).exp()).clamp(-1.0, 1.0)
}

impl SubsurfaceMedium {
    /// The medium that makes a surface of albedo `albedo` with mean free path `mfp`
    /// (scene units, per lane) and asymmetry `g` (clamped to 0..0.9 as Cycles). The path
    /// weight `throughput` (which already carries the albedo as the closure's weight) is
    /// divided by the albedo, which the walk's scattering gives back, and lowered where α
    /// is raised to [`MIN_ALPHA`].
    pub fn from_albedo(
        albedo: &SampledSpectrum,
        mfp: &SampledSpectrum,
        g: f32,
        throughput: &mut SampledSpectrum,
    ) -> Self {
        let g = if g.is_finite() { g.clamp(0.0, 0.9) } else { 0.0 };
        let n = albedo.len();
        let mut sigma_t = SampledSpectrum::zeros(n);
        let mut alpha = SampledSpectrum::zeros(n);
        for i in 0..n {
            let a = albedo.get(i);
            let a = if a.is_finite() { a.clamp(0.0, 1.0) } else { 0.0 };
            let d = mfp.get(i);
            let d = if d.is_finite() { d.max(1e-16) } else { 1e-16 };
            sigma_t.set(i, 1.0 / d / (1.0 - g));
            let mut al = single_scattering_albedo(a, g);
            let mut w = if a > 0.0 { throughput.get(i) / a } else { 0.0 };
            if al < MIN_ALPHA {
                w *= al / MIN_ALPHA;
                al = MIN_ALPHA;
            }
            alpha.set(i, al);
            throughput.set(i, w);
        }
        Self { sigma_t, alpha, phase: HenyeyGreenstein::new(g) }
    }

    /// Walks from `p` (on the surface) along `d` (into the medium) until the path leaves
    /// through `boundary`; `n` is the entry surface's outward normal. Multiplies
    /// `throughput` by the walk's weight. None: absorbed, or no way out within
    /// [`MAX_BOUNCES`].
    pub fn walk<B: Boundary>(
        &self,
        boundary: &mut B,
        p: Vec3A,
        n: Vec3A,
        d: Vec3A,
        rng: &mut Rng,
        throughput: &mut SampledSpectrum,
    ) -> Option<WalkExit<B::Hit>> {
        let lanes = throughput.len();
        let live = |i: usize, tp: &SampledSpectrum| tp.get(i) != 0.0;
        // The guiding strength follows the highest albedo among the lanes still carried.
        let max_alpha = (0..lanes).filter(|&i| live(i, throughput)).map(|i| self.alpha.get(i)).fold(0.0f32, f32::max);
        if !(max_alpha > 0.0) {
            return None;
        }
        let v = diffusion_length(max_alpha);
        if !(v > 1.0 && v.is_finite()) {
            return None;
        }
        let log = ((v + 1.0) / (v - 1.0)).ln();
        let g = self.phase.g;
        let guided_fraction = 1.0 - g.abs().powf(0.125).max(0.5);
        let min_sigma_t = (0..lanes).map(|i| self.sigma_t.get(i)).fold(f32::INFINITY, f32::min);

        let mut pos = p;
        let mut dir = d;
        let mut opposite: Option<f32> = None;
        let mut channel_pdf = vec![0.0f32; lanes];
        let mut factors = vec![0.0f32; lanes];
        for bounce in 0..MAX_BOUNCES {
            // Lane whose distance distribution this step samples, ∝ |β·α|.
            let mut sum = 0.0f32;
            for (i, c) in channel_pdf.iter_mut().enumerate() {
                *c = (throughput.get(i) * self.alpha.get(i)).abs();
                sum += *c;
            }
            if !(sum > 0.0 && sum.is_finite()) {
                return None;
            }
            let mut pick = rng.uniform() * sum;
            let mut lane = lanes - 1;
            for (i, c) in channel_pdf.iter_mut().enumerate() {
                if pick < *c && lane == lanes - 1 {
                    lane = i;
                }
                pick -= *c;
                *c /= sum;
            }
            let mut sample_sigma_t = self.sigma_t.get(lane);
            let u_t = rng.uniform();

            // Direction (the first ray keeps the entry direction).
            let (mut backward_fraction, mut fwd_factor, mut bwd_factor, mut fwd_stretch, mut bwd_stretch) =
                (0.0f32, 0.0f32, 0.0f32, 1.0f32, 1.0f32);
            if bounce > 0 {
                let guided = rng.uniform() < guided_fraction;
                let mut guide_backward = false;
                if let Some(dist) = opposite {
                    // Cycles' clamp, min(max(x, 0), dist): the first ray can find the
                    // opposite side a hair behind the entry plane (dist < 0, a grazing
                    // entry about a shading normal), where f32::clamp panics.
                    let x = (pos - p).dot(-n).max(0.0).min(dist);
                    backward_fraction = 1.0 / (1.0 + ((dist - 2.0 * x) / v).exp());
                    guide_backward = rng.uniform() < backward_fraction;
                }
                let u = rng.uniform2();
                let (new_dir, cos, hg_pdf) = if guided {
                    let mut cos = dwivedi_sample(v, log, u.x);
                    if guide_backward {
                        cos = -cos;
                    }
                    let w = around(n, cos, u.y);
                    (w, cos, self.phase.eval(dir.dot(w)))
                } else {
                    let (w, pdf) = self.phase.sample(dir, u);
                    (w, w.dot(n), pdf)
                };
                dir = new_dir;
                fwd_factor = dwivedi_eval(v, log, cos) / (TAU * hg_pdf);
                bwd_factor = dwivedi_eval(v, log, -cos) / (TAU * hg_pdf);
                fwd_stretch = 1.0 - cos / v;
                bwd_stretch = 1.0 + cos / v;
                if guided {
                    sample_sigma_t *= if guide_backward { bwd_stretch } else { fwd_stretch };
                }
            }

            // Distance, and the boundary along it.
            let mut t = -(1.0 - u_t).ln() / sample_sigma_t;
            let tmax = if bounce == 0 { t.max(10.0 / min_sigma_t) } else { t };
            let found = boundary.intersect(pos, dir, tmax, bounce == 0);
            let mut hit = found.filter(|(th, _)| *th <= t);
            if bounce == 0 {
                if let Some((th, _)) = found {
                    opposite = Some((pos + dir * th - p).dot(-n));
                }
                hit = found.filter(|(th, _)| *th < t);
            }
            if let Some((th, _)) = hit {
                t = th;
            }
            pos += dir * t;

            // Weight: balance heuristic over lanes × {classic, guided, backward guided}.
            let mut denom = 0.0f32;
            for i in 0..lanes {
                let st = self.sigma_t.get(i);
                let pdf_of = |s: f32| {
                    let tr = (-s * t).exp();
                    if hit.is_some() {
                        tr
                    } else {
                        s * tr
                    }
                };
                let mut pdf = pdf_of(st);
                if bounce > 0 {
                    let mut guided = pdf_of(fwd_stretch * st) * fwd_factor;
                    if opposite.is_some() {
                        let back = pdf_of(bwd_stretch * st) * bwd_factor;
                        guided = guided * (1.0 - backward_fraction) + back * backward_fraction;
                    }
                    pdf = pdf * (1.0 - guided_fraction) + guided * guided_fraction;
                }
                let tr = (-st * t).exp();
                factors[i] = if hit.is_some() { tr } else { st * self.alpha.get(i) * tr };
                denom += channel_pdf[i] * pdf;
            }
            if !(denom > 0.0 && denom.is_finite()) {
                return None;
            }
            let mut max_tp = 0.0f32;
            for (i, f) in factors.iter().enumerate() {
                let w = throughput.get(i) * f / denom;
                throughput.set(i, w);
                max_tp = max_tp.max(w.abs());
            }
            if let Some((_, h)) = hit {
                return throughput.is_finite().then_some(WalkExit { hit: h, position: pos, direction: dir });
            }
            if max_tp < THROUGHPUT_EPSILON || !max_tp.is_finite() {
                return None;
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A medium filling z < 0 (a semi-infinite slab), or 0 > z > −thickness.
    struct Slab {
        thickness: f32,
    }

    impl Boundary for Slab {
        type Hit = bool;
        fn intersect(&mut self, o: Vec3A, d: Vec3A, tmax: f32, first: bool) -> Option<(f32, bool)> {
            // The top plane (not on the first ray, which starts on it), then the bottom.
            let mut best: Option<(f32, bool)> = None;
            if d.z > 0.0 && !first {
                let t = -o.z / d.z;
                if t > 0.0 && t <= tmax {
                    best = Some((t, true));
                }
            }
            if self.thickness.is_finite() && d.z < 0.0 {
                let t = (-self.thickness - o.z) / d.z;
                if t > 0.0 && t <= tmax && best.is_none_or(|b| t < b.0) {
                    best = Some((t, false));
                }
            }
            best
        }
    }

    /// Expected weight leaving through the top (reflected) and bottom (transmitted) for
    /// diffuse (cosine-distributed) incidence, with the albedo given back (the weight
    /// starts at A).
    fn run(albedo: f32, g: f32, thickness: f32, lanes: usize, n: usize, guided: bool) -> (f64, f64, f64) {
        let a = SampledSpectrum::splat(lanes, albedo);
        let mfp = SampledSpectrum::splat(lanes, 1.0);
        let mut rng = Rng::new(7, (albedo * 1000.0) as u64 + lanes as u64);
        let (mut r, mut t, mut r2) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..n {
            let mut tp = a.clone();
            let m = SubsurfaceMedium::from_albedo(&a, &mfp, g, &mut tp);
            let mut d = crate::sampling::cosine_hemisphere(rng.uniform2());
            d.z = -d.z;
            let exit = if guided {
                m.walk(&mut Slab { thickness }, Vec3A::ZERO, Vec3A::Z, d, &mut rng, &mut tp)
            } else {
                classic_walk(&m, &mut Slab { thickness }, d, &mut rng, &mut tp)
            };
            if let Some(e) = exit {
                let w = tp.get(0) as f64;
                if e.hit {
                    r += w;
                    r2 += w * w;
                } else {
                    t += w;
                }
            }
        }
        let rm = r / n as f64;
        (rm, t / n as f64, ((r2 / n as f64 - rm * rm).max(0.0) / n as f64).sqrt())
    }

    /// An analogue walk (no guiding, no lane MIS), written independently as a reference.
    fn classic_walk(
        m: &SubsurfaceMedium,
        b: &mut Slab,
        d: Vec3A,
        rng: &mut Rng,
        tp: &mut SampledSpectrum,
    ) -> Option<WalkExit<bool>> {
        let (st, al) = (m.sigma_t.get(0), m.alpha.get(0));
        let (mut pos, mut dir) = (Vec3A::ZERO, d);
        for bounce in 0..MAX_BOUNCES {
            if bounce > 0 {
                dir = m.phase.sample(dir, rng.uniform2()).0;
            }
            let t = -(1.0 - rng.uniform()).ln() / st;
            if let Some((th, h)) = b.intersect(pos, dir, t, bounce == 0) {
                return Some(WalkExit { hit: h, position: pos + dir * th, direction: dir });
            }
            pos += dir * t;
            let w = tp.get(0) * al;
            tp.set(0, w);
        }
        None
    }

    /// The fit's defining property: a semi-infinite, index-matched medium lit diffusely
    /// reflects its albedo A (within the fit's accuracy, a few percent), for isotropic and
    /// forward scattering. (A normally incident beam penetrates deeper and comes back
    /// ~12 % darker at A = 0.4.)
    #[test]
    fn semi_infinite_medium_reflects_the_albedo() {
        for &(a, g) in &[(0.8f32, 0.0f32), (0.4, 0.0), (0.9, 0.5), (0.2, 0.0)] {
            let (r, t, se) = run(a, g, f32::INFINITY, 3, 20_000, true);
            assert_eq!(t, 0.0);
            assert!((r - a as f64).abs() < 0.04 * a as f64 + 4.0 * se, "A {a} g {g}: reflects {r} ± {se}");
        }
    }

    /// Guided sampling with MIS over lanes is unbiased: it agrees with an analogue walk
    /// through a finite slab (reflection and transmission), and with no absorption the
    /// medium conserves energy, R + T = 1.
    #[test]
    fn guided_walk_agrees_with_an_analogue_walk_and_conserves_energy() {
        for &(a, g, thick) in &[(0.7f32, 0.0f32, 1.5f32), (0.95, 0.3, 4.0)] {
            let (r1, t1, se1) = run(a, g, thick, 3, 20_000, true);
            let (r2, t2, se2) = run(a, g, thick, 1, 40_000, false);
            let tol = 4.0 * (se1 * se1 + se2 * se2).sqrt() + 0.01;
            assert!((r1 - r2).abs() < tol, "A {a}: guided R {r1} vs analogue {r2}");
            assert!((t1 - t2).abs() < 0.03, "A {a}: guided T {t1} vs analogue {t2}");
        }
        let (r, t, _) = run(1.0, 0.0, 2.0, 2, 10_000, true);
        assert!((r + t - 1.0).abs() < 0.02, "R {r} + T {t}");
    }

    /// Lanes of different albedo walk together and each comes out with its own colour;
    /// zero-throughput lanes (a collapsed path) stay zero.
    #[test]
    fn lanes_keep_their_own_albedo() {
        let a = SampledSpectrum::from_slice(&[0.9, 0.5, 0.2, 0.7]);
        let mfp = SampledSpectrum::from_slice(&[1.0, 0.5, 2.0, 1.0]);
        let mut rng = Rng::new(3, 3);
        let n = 20_000;
        let mut sum = [0.0f64; 4];
        for _ in 0..n {
            let mut tp = a.clone();
            tp.set(3, 0.0);
            let m = SubsurfaceMedium::from_albedo(&a, &mfp, 0.0, &mut tp);
            let mut d = crate::sampling::cosine_hemisphere(rng.uniform2());
            d.z = -d.z;
            if m.walk(&mut Slab { thickness: f32::INFINITY }, Vec3A::ZERO, Vec3A::Z, d, &mut rng, &mut tp).is_some() {
                for (k, s) in sum.iter_mut().enumerate() {
                    *s += tp.get(k) as f64;
                }
                assert_eq!(tp.get(3), 0.0);
            }
        }
        for k in 0..3 {
            let r = sum[k] / n as f64;
            assert!((r - a.get(k) as f64).abs() < 0.06 * a.get(k) as f64 + 0.01, "lane {k}: {r} vs {}", a.get(k));
        }
    }

    /// The first ray (along a grazing entry about a shading normal, a hair outwards of
    /// the entry plane) finds the far side slightly behind that plane: the guiding's
    /// opposite distance is then negative, which must not panic (Cycles clamps with
    /// min(max(x, 0), d)).
    #[test]
    fn an_opposite_side_behind_the_entry_plane_walks_on() {
        struct Grazing(Slab);
        impl Boundary for Grazing {
            type Hit = bool;
            fn intersect(&mut self, o: Vec3A, d: Vec3A, tmax: f32, first: bool) -> Option<(f32, bool)> {
                if first {
                    (0.5 <= tmax).then_some((0.5, false))
                } else {
                    self.0.intersect(o, d, tmax, first)
                }
            }
        }
        let a = SampledSpectrum::splat(3, 0.8);
        let mfp = SampledSpectrum::splat(3, 0.1);
        let d = Vec3A::new(1.0, 0.0, 1e-4).normalize();
        for seed in 0..64 {
            let mut tp = SampledSpectrum::splat(3, 1.0);
            let m = SubsurfaceMedium::from_albedo(&a, &mfp, 0.0, &mut tp);
            let mut rng = Rng::new(seed, 3);
            if m.walk(&mut Grazing(Slab { thickness: 1.0 }), Vec3A::ZERO, Vec3A::Z, d, &mut rng, &mut tp).is_some() {
                assert!(tp.is_finite());
            }
        }
    }

    #[test]
    fn bad_inputs_give_finite_results() {
        let a = SampledSpectrum::from_slice(&[f32::NAN, -1.0, 2.0, 0.0]);
        let mfp = SampledSpectrum::from_slice(&[-1.0, f32::INFINITY, 0.0, 1.0]);
        let mut tp = SampledSpectrum::splat(4, 1.0);
        let m = SubsurfaceMedium::from_albedo(&a, &mfp, f32::NAN, &mut tp);
        assert!(m.sigma_t.is_finite() && m.alpha.is_finite() && tp.is_finite());
        let mut rng = Rng::new(1, 1);
        if m.walk(&mut Slab { thickness: 1.0 }, Vec3A::ZERO, Vec3A::Z, -Vec3A::Z, &mut rng, &mut tp).is_some() {
            assert!(tp.is_finite());
        }
    }
}
