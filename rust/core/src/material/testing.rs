//! Checks every lobe's tests share: the white furnace (the sampled directional albedo,
//! and a quadrature of eval over the sphere), a χ² test of `sample` against `pdf` (as
//! pbrt-v4 and Mitsuba 3 test their samplers), and reciprocity of eval.

use super::{Bsdf, ShadingContext};
use crate::sampling::Rng;
use crate::spectrum::SampledSpectrum;
use glam::Vec3A;
use std::f64::consts::TAU;

/// The direction at polar cosine `cos` and azimuth `phi` in the shading frame.
pub fn dir(cos: f32, phi: f32) -> Vec3A {
    let s = (1.0 - cos * cos).max(0.0).sqrt();
    Vec3A::new(s * phi.cos(), s * phi.sin(), cos)
}

/// Mean and standard error of the sampling weight f·|cos|/pdf in `lane` (the sampled
/// directional albedo), asserting every weight is finite and non-negative and that the
/// sampled pdf equals `pdf()` for non-delta samples.
pub fn sampled_albedo(
    bsdf: &dyn Bsdf,
    ctx: &ShadingContext,
    wo: Vec3A,
    n: usize,
    seed: u64,
    lane: usize,
) -> (f64, f64) {
    let mut rng = Rng::new(seed, 17);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let mut tp = SampledSpectrum::splat(ctx.grid.len(), 1.0);
        if let Some(s) = bsdf.sample(ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
            assert!(tp.is_finite() && tp.values().iter().all(|&v| v >= 0.0), "weight {tp:?} for {s:?}");
            assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{s:?}");
            if !s.specular {
                let p = bsdf.pdf(ctx, wo, s.wi);
                assert!((p - s.pdf).abs() <= 2e-3 * s.pdf.max(p) + 1e-6, "sampled pdf {} vs pdf() {p}", s.pdf);
            }
            let v = tp.get(lane) as f64;
            s1 += v;
            s2 += v * v;
        }
    }
    let mean = s1 / n as f64;
    (mean, ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

/// ∫ eval(wo, wi) dωi over the sphere in `lane` (midpoint rule in cos θ and φ).
pub fn quadrature_albedo(bsdf: &dyn Bsdf, ctx: &ShadingContext, wo: Vec3A, lane: usize) -> f64 {
    let (nt, np) = (1000usize, 160usize);
    let mut q = 0.0f64;
    let mut f = SampledSpectrum::zeros(ctx.grid.len());
    for i in 0..nt {
        let c = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
        for j in 0..np {
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
            bsdf.eval(ctx, wo, dir(c, phi), &mut f);
            q += f.get(lane) as f64;
        }
    }
    q * 2.0 * TAU / (nt * np) as f64
}

/// ∫ pdf(wo, wi) dωi over the sphere.
pub fn pdf_integral(bsdf: &dyn Bsdf, ctx: &ShadingContext, wo: Vec3A) -> f64 {
    let (nt, np) = (1000usize, 160usize);
    let mut q = 0.0f64;
    for i in 0..nt {
        let c = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
        for j in 0..np {
            let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
            q += bsdf.pdf(ctx, wo, dir(c, phi)) as f64;
        }
    }
    q * 2.0 * TAU / (nt * np) as f64
}

/// χ² test of `samples` sampled directions against `pdf()` over (cos θ, φ) bins of the
/// whole sphere, failed samples counted in one more bin whose expectation is 1 − ∫pdf;
/// bins expecting fewer than 5 are pooled. Fails at the 1e-4 level (Wilson–Hilferty).
pub fn chi_square(bsdf: &dyn Bsdf, ctx: &ShadingContext, wo: Vec3A, samples: usize, seed: u64) {
    let (nt, np) = (16usize, 16usize);
    let bin = |w: Vec3A| -> usize {
        let c = (w.z * 0.5 + 0.5).clamp(0.0, 0.999_999);
        let phi = w.y.atan2(w.x).rem_euclid(std::f32::consts::TAU);
        let i = ((c * nt as f32) as usize).min(nt - 1);
        let j = ((phi / std::f32::consts::TAU * np as f32) as usize).min(np - 1);
        i * np + j
    };
    let mut hist = vec![0f64; nt * np + 1];
    let mut rng = Rng::new(seed, 99);
    for _ in 0..samples {
        let mut tp = SampledSpectrum::splat(ctx.grid.len(), 1.0);
        match bsdf.sample(ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
            Some(s) => {
                assert!(!s.specular, "χ² needs non-delta lobes");
                hist[bin(s.wi)] += 1.0;
            }
            None => hist[nt * np] += 1.0,
        }
    }
    let sub = 24usize;
    let mut expected = vec![0f64; nt * np + 1];
    for i in 0..nt {
        for j in 0..np {
            let mut acc = 0.0f64;
            for a in 0..sub {
                for b in 0..sub {
                    let c = -1.0 + 2.0 * (i as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64;
                    let phi = TAU * (j as f64 + (b as f64 + 0.5) / sub as f64) / np as f64;
                    acc += bsdf.pdf(ctx, wo, dir(c as f32, phi as f32)) as f64;
                }
            }
            let area = (2.0 / nt as f64) * (TAU / np as f64);
            expected[i * np + j] = acc / (sub * sub) as f64 * area * samples as f64;
        }
    }
    let total: f64 = expected.iter().sum();
    assert!(total <= samples as f64 * 1.01, "pdf integrates to {}", total / samples as f64);
    expected[nt * np] = (samples as f64 - total).max(0.0);
    let (mut chi2, mut dof, mut pool_e, mut pool_o) = (0.0f64, 0usize, 0.0f64, 0.0f64);
    for k in 0..expected.len() {
        if expected[k] < 5.0 {
            pool_e += expected[k];
            pool_o += hist[k];
        } else {
            chi2 += (hist[k] - expected[k]).powi(2) / expected[k];
            dof += 1;
        }
    }
    if pool_e >= 5.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1;
    } else {
        assert!(pool_o < 20.0, "{pool_o} samples where the pdf expects {pool_e}");
    }
    let dof = (dof - 1) as f64;
    let z = 3.719;
    let crit = dof * (1.0 - 2.0 / (9.0 * dof) + z * (2.0 / (9.0 * dof)).sqrt()).powi(3);
    assert!(chi2 < crit, "wo {wo:?}: χ² {chi2:.1} > {crit:.1} (dof {dof})");
}

/// f(wo, wi) = f(wi, wo) per lane (eval returns f·|cos θi|) over random direction pairs.
pub fn assert_reciprocal(bsdf: &dyn Bsdf, ctx: &ShadingContext, pairs: usize, seed: u64) {
    let n = ctx.grid.len();
    let (mut a, mut b) = (SampledSpectrum::zeros(n), SampledSpectrum::zeros(n));
    let mut rng = Rng::new(seed, 3);
    let mut nonzero = 0;
    for _ in 0..pairs {
        let wo = dir(rng.uniform() * 2.0 - 1.0, rng.uniform() * std::f32::consts::TAU);
        let wi = dir(rng.uniform() * 2.0 - 1.0, rng.uniform() * std::f32::consts::TAU);
        if wo.z.abs() < 1e-3 || wi.z.abs() < 1e-3 {
            continue;
        }
        bsdf.eval(ctx, wo, wi, &mut a);
        bsdf.eval(ctx, wi, wo, &mut b);
        for k in 0..n {
            let fa = a.get(k) / wi.z.abs();
            let fb = b.get(k) / wo.z.abs();
            assert!((fa - fb).abs() <= 1e-3 * fa.abs().max(fb.abs()) + 1e-6, "wo {wo:?} wi {wi:?}: {fa} vs {fb}");
            if fa > 0.0 {
                nonzero += 1;
            }
        }
    }
    assert!(nonzero > pairs / 8, "only {nonzero} non-zero pairs");
}
