//! The SMOOTH uplift (Jakob & Hanika 2019): sigmoid-polynomial reflectances fitted in
//! CIELAB on a lattice of RGB values, interpolated and refined by Newton steps per call.

// Index loops mirror the maths (several arrays indexed together); `!(a > b)` is used on
// purpose so that NaN counts as failure.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;
use crate::color::delta_e::lab_f;
use crate::numeric::{solve3, solve_dense};

// ---------------------------------------------------------------------------------
// SMOOTH: Jakob & Hanika 2019.
//
// Table: for l = index of the largest component, z = its value on the nodes
// smoothstep(smoothstep(k/15)) (dense near 0 and 1), and the two other components / z on
// a uniform 16 × 16 lattice, the coefficients fitted by Gauss–Newton in CIELAB, warm-
// started along z from grey (Jakob–Hanika's scheme). Per call: trilinear interpolation of
// the coefficients, then Newton steps on the exact normalised RGB (a 3×3 solve each);
// colours with every component above ½ are evaluated through their complement; colours
// darker than the first non-zero z node are the node's shape scaled down (exact).
// ---------------------------------------------------------------------------------

/// Lattice resolution per axis (Jakob–Hanika use 64; 16 keeps the build fast: 3·16³
/// entries of 3 f32 = 144 KiB, ≈ 35 ms on the default grid, ≈ 200 ms on 401 samples).
pub(super) const SMOOTH_RES: usize = 16;
/// Most Jacobian evaluations (so at most 3 Newton steps) per call from the interpolated
/// coefficients (0 = table only), and the normalised-RGB error at which they stop.
pub(super) const SMOOTH_NEWTON_STEPS: usize = 4;
pub(super) const SMOOTH_NEWTON_TOL: f32 = 1e-5;
/// Chunk width of the Jacobian loop (4 f32 = one SSE register: no spills).
pub(super) const JL: usize = 4;
/// Largest coefficient magnitude the fit may use (x normalised to [0,1]).
pub(super) const SMOOTH_COEFF_CAP: f64 = 1000.0;

/// The sigmoid S(z) = ½ + z / (2√(1+z²)) and its derivative.
#[inline]
pub(super) fn sigmoid(z: f64) -> (f64, f64) {
    let r = 1.0 / (1.0 + z * z).sqrt();
    (0.5 + 0.5 * z * r, 0.5 * r * r * r)
}

#[derive(Clone, Debug)]
pub(super) struct SmoothTable {
    /// Normalised wavelength of each sample: (λ − λ_first) / (λ_last − λ_first).
    x: Vec<f32>,
    /// Values of the largest component at the lattice's z nodes (ascending, scale[0] = 0).
    scale: Vec<f32>,
    /// Coefficients at [l][k][j][i]: l = index of the largest component, k = z node,
    /// j, i = the other two components / the largest, on a uniform lattice over [0,1].
    coeffs: Vec<[f32; 3]>,
    /// `x` and the normalised reflectance → RGB map, zero-padded to whole chunks of JL;
    /// `a_pad` holds, per chunk, JL values of the R row, then JL of G, then JL of B.
    x_pad: Vec<f32>,
    a_pad: Vec<f32>,
    /// Newton steps per call from the interpolated coefficients.
    newton_steps: usize,
}

/// Gauss–Newton fitter of sigmoid-polynomial reflectances to a target RGB, in CIELAB.
pub(super) struct Fitter<'a> {
    x: Vec<f64>,
    a: &'a [Vec<f64>; 3],
    rgb_to_xyz: [[f64; 3]; 3],
    white: [f64; 3],
}

impl Fitter<'_> {
    /// CIELAB of an RGB of the normalised map and its Jacobian d Lab / d rgb.
    pub(super) fn lab(&self, rgb: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let m = &self.rgb_to_xyz;
        let xyz: [f64; 3] = std::array::from_fn(|r| (0..3).map(|k| m[r][k] * rgb[k]).sum());
        let f: [(f64, f64); 3] = std::array::from_fn(|k| lab_f(xyz[k] / self.white[k]));
        let lab = [116.0 * f[1].0 - 16.0, 500.0 * (f[0].0 - f[1].0), 200.0 * (f[1].0 - f[2].0)];
        // d f_k / d xyz_k = f'_k / white_k
        let dfx = [f[0].1 / self.white[0], f[1].1 / self.white[1], f[2].1 / self.white[2]];
        let dlab_dxyz = [
            [0.0, 116.0 * dfx[1], 0.0],
            [500.0 * dfx[0], -500.0 * dfx[1], 0.0],
            [0.0, 200.0 * dfx[1], -200.0 * dfx[2]],
        ];
        let j = std::array::from_fn(|r| std::array::from_fn(|k| (0..3).map(|t| dlab_dxyz[r][t] * m[t][k]).sum()));
        (lab, j)
    }

    /// RGB of the reflectance with coefficients c and d rgb / d c.
    pub(super) fn eval(&self, c: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut rgb = [0.0; 3];
        let mut jac = [[0.0; 3]; 3];
        for (i, &x) in self.x.iter().enumerate() {
            let (s, ds) = sigmoid((c[0] * x + c[1]) * x + c[2]);
            let basis = [x * x, x, 1.0];
            for r in 0..3 {
                let ar = self.a[r][i];
                rgb[r] += ar * s;
                for k in 0..3 {
                    jac[r][k] += ar * ds * basis[k];
                }
            }
        }
        (rgb, jac)
    }

    /// Lab residual and its Jacobian w.r.t. the coefficients.
    pub(super) fn residual(&self, c: &[f64; 3], target_lab: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (rgb, jrgb) = self.eval(c);
        let (lab, jlab) = self.lab(rgb);
        let res = std::array::from_fn(|k| lab[k] - target_lab[k]);
        let jac = std::array::from_fn(|r| std::array::from_fn(|k| (0..3).map(|t| jlab[r][t] * jrgb[t][k]).sum()));
        (res, jac)
    }

    /// Gauss–Newton (with step halving) from `c` towards `target` rgb.
    pub(super) fn fit(&self, target: [f64; 3], c: &mut [f64; 3]) {
        let target_lab = self.lab(target).0;
        let norm = |r: &[f64; 3]| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let (mut res, mut jac) = self.residual(c, &target_lab);
        let mut rn = norm(&res);
        for _ in 0..40 {
            if rn < 1e-6 {
                break;
            }
            let mut m: [f64; 9] = std::array::from_fn(|k| jac[k / 3][k % 3]);
            let mut step = res;
            if !solve_dense(&mut m, 3, &mut step) {
                break;
            }
            let mut t = 1.0;
            let mut improved = false;
            for _ in 0..12 {
                let mut trial: [f64; 3] = std::array::from_fn(|k| c[k] - t * step[k]);
                let mx = trial.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if mx > SMOOTH_COEFF_CAP {
                    trial = trial.map(|v| v * SMOOTH_COEFF_CAP / mx);
                }
                let (r2, j2) = self.residual(&trial, &target_lab);
                let n2 = norm(&r2);
                if n2 < rn {
                    *c = trial;
                    res = r2;
                    jac = j2;
                    rn = n2;
                    improved = true;
                    break;
                }
                t *= 0.5;
            }
            if !improved {
                break;
            }
        }
    }
}

pub(super) fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

impl SmoothTable {
    pub(super) fn build(lambdas: &[f64], a: &[Vec<f64>; 3], space: &RgbSpace, res: usize) -> Self {
        let n = lambdas.len();
        let (l0, l1) = (lambdas[0], lambdas[n - 1]);
        let x: Vec<f64> = lambdas.iter().map(|&l| (l - l0) / (l1 - l0)).collect();
        let fitter = Fitter { x: x.clone(), a, rgb_to_xyz: space.rgb_to_xyz, white: space.rgb_to_xyz([1.0, 1.0, 1.0]) };
        let scale: Vec<f64> = (0..res).map(|k| smoothstep(smoothstep(k as f64 / (res - 1) as f64))).collect();
        let mut coeffs = vec![[0.0f32; 3]; 3 * res * res * res];
        let at = |l: usize, k: usize, j: usize, i: usize| ((l * res + k) * res + j) * res + i;
        let start = res / 5;
        for l in 0..3 {
            for j in 0..res {
                let yb = j as f64 / (res - 1) as f64;
                for i in 0..res {
                    let xa = i as f64 / (res - 1) as f64;
                    let target = |k: usize| {
                        let z = scale[k];
                        let mut rgb = [0.0; 3];
                        rgb[l] = z;
                        rgb[(l + 1) % 3] = xa * z;
                        rgb[(l + 2) % 3] = yb * z;
                        rgb
                    };
                    // From a mid-dark value up to 1, then down to the darkest node, warm-started.
                    let mut c = [0.0f64; 3];
                    for k in start..res {
                        fitter.fit(target(k), &mut c);
                        coeffs[at(l, k, j, i)] = c.map(|v| v as f32);
                    }
                    let mut c = [0.0f64; 3];
                    if start < res {
                        let s = coeffs[at(l, start, j, i)];
                        c = s.map(|v| v as f64);
                    }
                    for k in (1..start).rev() {
                        fitter.fit(target(k), &mut c);
                        coeffs[at(l, k, j, i)] = c.map(|v| v as f32);
                    }
                }
            }
        }
        Self {
            x: x.iter().map(|&v| v as f32).collect(),
            scale: scale.iter().map(|&v| v as f32).collect(),
            coeffs,
            x_pad: {
                let mut v: Vec<f32> = x.iter().map(|&v| v as f32).collect();
                v.resize(n.div_ceil(JL) * JL, 0.0);
                v
            },
            a_pad: {
                let chunks = n.div_ceil(JL);
                let mut v = vec![0.0f32; chunks * 3 * JL];
                for i in 0..n {
                    for (c, row) in a.iter().enumerate() {
                        v[(i / JL) * 3 * JL + c * JL + i % JL] = row[i] as f32;
                    }
                }
                v
            },
            newton_steps: SMOOTH_NEWTON_STEPS,
        }
    }

    /// Interpolated coefficients for rgb in [0,1]³ with a positive largest component at
    /// a z of at least scale[1]; returns (coefficients, factor) where the reflectance is
    /// factor · S(poly) (factor < 1 only below the first non-zero z node).
    #[inline]
    pub(super) fn lookup(&self, rgb: [f32; 3]) -> ([f32; 3], f32) {
        let res = self.scale.len();
        let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let z = rgb[l];
        let xa = (rgb[(l + 1) % 3] / z).min(1.0);
        let yb = (rgb[(l + 2) % 3] / z).min(1.0);
        let (zz, factor) = if z < self.scale[1] { (self.scale[1], z / self.scale[1]) } else { (z, 1.0) };
        // Cell along z: scale[k] <= zz <= scale[k+1], k in 1..res-1.
        let k = (self.scale.partition_point(|&s| s <= zz).clamp(2, res) - 1).min(res - 2);
        let tz = ((zz - self.scale[k]) / (self.scale[k + 1] - self.scale[k])).clamp(0.0, 1.0);
        let fx = xa * (res - 1) as f32;
        let fy = yb * (res - 1) as f32;
        let ix = (fx as usize).min(res - 2);
        let iy = (fy as usize).min(res - 2);
        let tx = fx - ix as f32;
        let ty = fy - iy as f32;
        let at = |k: usize, j: usize, i: usize| &self.coeffs[((l * res + k) * res + j) * res + i];
        let mut c = [0.0f32; 3];
        for (dk, wk) in [(0, 1.0 - tz), (1, tz)] {
            for (dj, wj) in [(0, 1.0 - ty), (1, ty)] {
                for (di, wi) in [(0, 1.0 - tx), (1, tx)] {
                    let w = wk * wj * wi;
                    let v = at(k + dk, iy + dj, ix + di);
                    for m in 0..3 {
                        c[m] += w * v[m];
                    }
                }
            }
        }
        (c, factor)
    }

    /// Smooth reflectance of rgb (already clamped to [0,1]) into out.
    ///
    /// The model is closed under complement (S(−z) = 1 − S(z)) and the normalised map is
    /// affine-consistent (rgb(1 − ρ) = 1 − rgb(ρ)), so a light colour (all components
    /// above ½) is evaluated as 1 − the reflectance of 1 − rgb: this keeps lookups away
    /// from the white corner, where the coefficients diverge (white is S(+∞)).
    #[inline]
    pub(super) fn reflectance_into(&self, rgb: [f32; 3], out: &mut [f32]) {
        if rgb[0].min(rgb[1]).min(rgb[2]) > 0.5 {
            self.direct_into(rgb.map(|v| 1.0 - v), out);
            for o in out.iter_mut() {
                *o = 1.0 - *o;
            }
        } else {
            self.direct_into(rgb, out);
        }
    }

    #[inline]
    pub(super) fn direct_into(&self, rgb: [f32; 3], out: &mut [f32]) {
        let z = rgb[0].max(rgb[1]).max(rgb[2]);
        if !(z > 0.0) {
            out.fill(0.0);
            return;
        }
        let (c0, factor) = self.lookup(rgb);
        // Newton steps on the coefficients against the exact target, in the normalised
        // RGB, until the error is below SMOOTH_NEWTON_TOL; keep the best coefficients seen.
        let target = rgb.map(|v| v / factor);
        let (mut c, mut best, mut best_err) = (c0, c0, f32::INFINITY);
        for _ in 0..self.newton_steps {
            let (got, jac) = self.jacobian(c);
            let r: [f32; 3] = std::array::from_fn(|k| got[k] - target[k]);
            let err = r[0].abs().max(r[1].abs()).max(r[2].abs());
            if !(err < best_err) {
                break;
            }
            (best, best_err) = (c, err);
            if err < SMOOTH_NEWTON_TOL {
                break;
            }
            match solve3(jac, r) {
                Some(d) => c = std::array::from_fn(|k| c[k] - d[k]),
                None => break,
            }
        }
        self.fill(best, factor, out);
    }

    /// out = factor · S(poly_c(x)).
    #[inline]
    pub(super) fn fill(&self, [c0, c1, c2]: [f32; 3], factor: f32, out: &mut [f32]) {
        let half = 0.5 * factor;
        for (o, &x) in out.iter_mut().zip(&self.x) {
            let p = (c0 * x + c1) * x + c2;
            *o = half + half * p / (1.0 + p * p).sqrt();
        }
    }

    /// Normalised RGB of S(poly_c) and its derivative with respect to c. Runs over the
    /// zero-padded copies in chunks of JL with per-lane accumulators (vectorises).
    #[inline]
    pub(super) fn jacobian(&self, [c0, c1, c2]: [f32; 3]) -> ([f32; 3], [[f32; 3]; 3]) {
        // Per channel k: Σ a·S, Σ a·S'·x², Σ a·S'·x, Σ a·S'.
        let z = [0.0f32; JL];
        let (mut rs, mut r2, mut r1, mut r0) = (z, z, z, z);
        let (mut gs, mut g2, mut g1, mut g0) = (z, z, z, z);
        let (mut bs, mut b2, mut b1, mut b0) = (z, z, z, z);
        for (x, a) in self.x_pad.chunks_exact(JL).zip(self.a_pad.chunks_exact(3 * JL)) {
            let (ar, rest) = a.split_at(JL);
            let (ag, ab) = rest.split_at(JL);
            for l in 0..JL {
                let x = x[l];
                let p = (c0 * x + c1) * x + c2;
                let q = 1.0 / (1.0 + p * p).sqrt();
                let s = 0.5 + 0.5 * p * q;
                let d = 0.5 * q * q * q;
                let (dx, dxx) = (d * x, d * x * x);
                rs[l] += ar[l] * s;
                r2[l] += ar[l] * dxx;
                r1[l] += ar[l] * dx;
                r0[l] += ar[l] * d;
                gs[l] += ag[l] * s;
                g2[l] += ag[l] * dxx;
                g1[l] += ag[l] * dx;
                g0[l] += ag[l] * d;
                bs[l] += ab[l] * s;
                b2[l] += ab[l] * dxx;
                b1[l] += ab[l] * dx;
                b0[l] += ab[l] * d;
            }
        }
        let t = |v: [f32; JL]| v.iter().sum::<f32>();
        ([t(rs), t(gs), t(bs)], [[t(r2), t(r1), t(r0)], [t(g2), t(g1), t(g0)], [t(b2), t(b1), t(b0)]])
    }
}
