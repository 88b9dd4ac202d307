//! The LINEAR uplift's basis (the paper's eq. 10): the minimum-variation bounded
//! reversible basis curves, a convex QP solved by ADMM and an exact active-set polish,
//! and the cell-averaged fallback for grids on which it is infeasible.

// Index loops mirror the maths (several arrays indexed together); `!(a > b)` is used on
// purpose so that NaN counts as failure.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::*;
use crate::numeric::{project_simplex, solve_dense, Band};

// ---------------------------------------------------------------------------------
// LINEAR: the minimum-variation bounded reversible basis (a convex QP).
//
//   minimise   Σ_c Σ_k h_k (w_c[k+1] − w_c[k])²          (h_k = 1/Δλ_k: ∫ (dw/dλ)² dλ)
//   subject to A w_c = e_c  (c = R, G, B; A the normalised reflectance → RGB map)
//              w_ic ≥ 0, Σ_c w_ic = 1 at every sample i.
//
// Stage 1, ADMM: x-block = the smoothness term + the equalities A x_c = e_c (per channel
// a tridiagonal solve plus a rank-3 correction), z-block = the per-sample probability
// simplex (a projection). Stage 2, polish: with the set of zero entries guessed from
// ADMM, solve the equality-constrained QP exactly (banded Cholesky + Schur complement on
// the 6 remaining equalities, iterative refinement) and update the set by a primal–dual
// active-set rule until the KKT conditions hold.
// ---------------------------------------------------------------------------------

/// The smoothness energy Σ_c Σ_k h_k (w_c[k+1] − w_c[k])².
#[cfg(test)]
pub(super) fn energy(w: &[Vec<f64>; 3], h: &[f64]) -> f64 {
    w.iter().map(|wc| h.iter().enumerate().map(|(k, &hk)| hk * (wc[k + 1] - wc[k]).powi(2)).sum::<f64>()).sum()
}

/// (L v)_i for the path Laplacian with edge weights h: the gradient of Σ h_k (v[k+1]−v[k])² is 2 L v.
pub(super) fn laplacian_mul(h: &[f64], v: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for (k, &hk) in h.iter().enumerate() {
        let d = hk * (v[k] - v[k + 1]);
        out[k] += d;
        out[k + 1] -= d;
    }
}

/// Fallback basis for grids on which the bounded reversible problem is infeasible: solve
/// it on a fine uniform grid (41, else 81, else 161 samples) over the grid's own range,
/// then average each fine basis curve (piecewise linear) over each coarse sample's cell
/// (midpoints between samples; half cells at the ends). Averaging is linear, so `w ≥ 0`
/// and `Σ_c w_c = 1` survive exactly (white stays flat 1, every RGB in [0,1]³ stays a
/// reflectance in [0,1]); reversibility becomes approximate
/// ([`Uplift::round_trip_error`]). Returns the basis and the fine grid's size.
pub(super) fn fallback_basis(grid: &WavelengthGrid, space: &RgbSpace) -> Option<([Vec<f64>; 3], usize)> {
    let coarse = grid.lambdas();
    let n = coarse.len();
    let (lo, hi) = (coarse[0], coarse[n - 1]);
    for m in [41usize, 81, 161] {
        let Ok(fine) = WavelengthGrid::uniform(m, lo, hi) else { continue };
        let Ok((_, k, _)) = reflectance_rows(&fine, space) else { continue };
        let sums: Vec<f64> = k.iter().map(|row| row.iter().sum()).collect();
        if sums.iter().any(|&s| !(s > 0.0)) {
            continue;
        }
        let a: [Vec<f64>; 3] = std::array::from_fn(|c| k[c].iter().map(|v| v / sums[c]).collect());
        let x: Vec<f64> = fine.lambdas().iter().map(|&l| l as f64).collect();
        let h: Vec<f64> = x.windows(2).map(|p| 1.0 / (p[1] - p[0])).collect();
        let Ok(wf) = solve_basis(&a, &h) else { continue };
        let c: Vec<f64> = coarse.iter().map(|&l| l as f64).collect();
        let mut w: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        for i in 0..n {
            let a0 = if i == 0 { c[0] } else { 0.5 * (c[i - 1] + c[i]) };
            let b0 = if i + 1 == n { c[n - 1] } else { 0.5 * (c[i] + c[i + 1]) };
            for ch in 0..3 {
                w[ch][i] = cell_average(&x, &wf[ch], a0, b0);
            }
        }
        // Re-impose Σ = 1 against rounding (the averages of a partition of unity are one).
        for i in 0..n {
            let s: f64 = (0..3).map(|ch| w[ch][i].max(0.0)).sum();
            for ch in 0..3 {
                w[ch][i] = w[ch][i].max(0.0) / s;
            }
        }
        return Some((w, m));
    }
    None
}

/// Mean of the piecewise-linear function (x, y) over [a, b] (b > a, inside x's range).
pub(super) fn cell_average(x: &[f64], y: &[f64], a: f64, b: f64) -> f64 {
    let lerp = |k: usize, t: f64| y[k] + (y[k + 1] - y[k]) * (t - x[k]) / (x[k + 1] - x[k]);
    let mut integral = 0.0;
    for k in 0..x.len() - 1 {
        let (s0, s1) = (a.max(x[k]), b.min(x[k + 1]));
        if s1 > s0 {
            integral += (s1 - s0) * 0.5 * (lerp(k, s0) + lerp(k, s1));
        }
    }
    if b > a {
        integral / (b - a)
    } else {
        y[0]
    }
}

/// Emission basis that round-trips exactly although the reflectance basis does not:
/// `G[d][c] = RGB_d(emission_c) = sums_d/sums_c · (A w_c)_d`; the curves are remixed by
/// G⁻¹ so that RGB(emission_c) = e_c, or, where that would make a curve negative (no
/// negative radiance), only rescaled so that each unit colour keeps its own channel.
pub(super) fn exact_emission(em: &[Vec<f32>; 3], aw: &[[f64; 3]; 3], sums: &[f64]) -> ([Vec<f32>; 3], bool) {
    let g: [[f64; 3]; 3] = std::array::from_fn(|d| std::array::from_fn(|c| sums[d] / sums[c] * aw[c][d]));
    let det = g[0][0] * (g[1][1] * g[2][2] - g[1][2] * g[2][1]) - g[0][1] * (g[1][0] * g[2][2] - g[1][2] * g[2][0])
        + g[0][2] * (g[1][0] * g[2][1] - g[1][1] * g[2][0]);
    if det.is_finite() && det.abs() > 1e-12 {
        // Inverse by cofactors.
        let inv: [[f64; 3]; 3] = std::array::from_fn(|r| {
            std::array::from_fn(|c| {
                let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
                let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
                (g[r1][c1] * g[r2][c2] - g[r1][c2] * g[r2][c1]) / det
            })
        });
        let mixed: [Vec<f32>; 3] = std::array::from_fn(|c| {
            (0..em[0].len()).map(|i| (0..3).map(|d| em[d][i] as f64 * inv[d][c]).sum::<f64>() as f32).collect()
        });
        if mixed.iter().all(|curve| curve.iter().all(|&v| v >= 0.0 && v.is_finite())) {
            return (mixed, true);
        }
    }
    (
        std::array::from_fn(|c| {
            em[c].iter().map(|&v| if g[c][c] > 0.0 { (v as f64 / g[c][c]) as f32 } else { v }).collect()
        }),
        false,
    )
}

/// Minimum-variation bounded reversible basis for the 3 × n map `a` and edge weights `h`.
pub(super) fn solve_basis(a: &[Vec<f64>; 3], h: &[f64]) -> std::result::Result<[Vec<f64>; 3], String> {
    let n = h.len() + 1;
    let mut admm = Admm::new(a, h);
    let mut tol = 1e-7;
    let mut last_err = String::new();
    for _round in 0..4 {
        let converged = admm.run(tol, 50_000);
        match polish(a, h, &admm.z) {
            Ok(w) => return Ok(w),
            Err(e) => last_err = e,
        }
        if !converged {
            // ADMM did not reach a feasible point: the constraints are (numerically) infeasible.
            let (p, _) = admm.residuals();
            return Err(format!(
                "the curves cannot be both reversible and bounded in [0,1] on these {n} samples \
                 (the closest the optimiser got leaves a violation of {p:.1e})"
            ));
        }
        tol *= 1e-2;
    }
    Err(format!("the optimiser did not converge ({last_err})"))
}

/// ADMM for the basis QP (see above). Variables are stored per channel.
pub(super) struct Admm<'a> {
    a: &'a [Vec<f64>; 3],
    h: &'a [f64],
    n: usize,
    rho: f64,
    q: Band,
    /// M = Q⁻¹ Aᵀ (3 columns of length n) and S⁻¹ = (A M)⁻¹ (3×3).
    m: [Vec<f64>; 3],
    s_inv: [[f64; 3]; 3],
    x: [Vec<f64>; 3],
    z: [Vec<f64>; 3],
    z_prev: [Vec<f64>; 3],
    u: [Vec<f64>; 3],
}

impl<'a> Admm<'a> {
    pub(super) fn new(a: &'a [Vec<f64>; 3], h: &'a [f64]) -> Self {
        let n = h.len() + 1;
        let mean_h = h.iter().sum::<f64>() / h.len() as f64;
        let z: [Vec<f64>; 3] = std::array::from_fn(|_| vec![1.0 / 3.0; n]);
        let mut s = Self {
            a,
            h,
            n,
            rho: mean_h,
            q: Band::new(n, 1),
            m: std::array::from_fn(|_| vec![0.0; n]),
            s_inv: [[0.0; 3]; 3],
            x: z.clone(),
            z_prev: z.clone(),
            z,
            u: std::array::from_fn(|_| vec![0.0; n]),
        };
        s.factor();
        s
    }

    pub(super) fn factor(&mut self) {
        let n = self.n;
        let mut q = Band::new(n, 1);
        for i in 0..n {
            q.add(i, i, self.rho);
        }
        for (k, &hk) in self.h.iter().enumerate() {
            q.add(k, k, 2.0 * hk);
            q.add(k + 1, k + 1, 2.0 * hk);
            q.add(k + 1, k, -2.0 * hk);
        }
        let ok = q.cholesky();
        debug_assert!(ok, "2L + ρI is positive definite for ascending wavelengths");
        let mut s = [0.0f64; 9];
        for r in 0..3 {
            let mut col = self.a[r].clone();
            q.solve(&mut col);
            for c in 0..3 {
                s[c * 3 + r] = self.a[c].iter().zip(&col).map(|(x, y)| x * y).sum();
            }
            self.m[r] = col;
        }
        for j in 0..3 {
            let mut e = [0.0; 3];
            e[j] = 1.0;
            let mut mm = s;
            let ok = solve_dense(&mut mm, 3, &mut e);
            debug_assert!(ok);
            for i in 0..3 {
                self.s_inv[i][j] = e[i];
            }
        }
        self.q = q;
    }

    /// (primal residual max|x − z|, dual residual relative to the gradient scale).
    pub(super) fn residuals(&self) -> (f64, f64) {
        let mut p = 0.0f64;
        let mut d = 0.0f64;
        let mut g = 0.0f64;
        let mut lv = vec![0.0; self.n];
        for c in 0..3 {
            laplacian_mul(self.h, &self.x[c], &mut lv);
            for i in 0..self.n {
                p = p.max((self.x[c][i] - self.z[c][i]).abs());
                d = d.max(self.rho * (self.z[c][i] - self.z_prev[c][i]).abs());
                g = g.max((2.0 * lv[i]).abs()).max((self.rho * self.u[c][i]).abs());
            }
        }
        (p, d / g.max(1e-300))
    }

    /// Iterate until both residuals are below `tol` (true) or `max_iter` is reached (false).
    pub(super) fn run(&mut self, tol: f64, max_iter: usize) -> bool {
        const ALPHA: f64 = 1.6;
        let n = self.n;
        let mut v = vec![0.0; n];
        for it in 0..max_iter {
            for c in 0..3 {
                // x_c = argmin x_cᵀ L x_c + ρ/2 |x_c − (z_c − u_c)|²  s.t. A x_c = e_c
                for i in 0..n {
                    v[i] = self.rho * (self.z[c][i] - self.u[c][i]);
                }
                self.q.solve(&mut v);
                let mut r = [0.0; 3];
                for (row, rr) in r.iter_mut().enumerate() {
                    *rr =
                        self.a[row].iter().zip(&v).map(|(x, y)| x * y).sum::<f64>() - if row == c { 1.0 } else { 0.0 };
                }
                let nu: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| self.s_inv[i][j] * r[j]).sum());
                for i in 0..n {
                    self.x[c][i] = v[i] - self.m[0][i] * nu[0] - self.m[1][i] * nu[1] - self.m[2][i] * nu[2];
                }
            }
            std::mem::swap(&mut self.z_prev, &mut self.z);
            for i in 0..n {
                let xh: [f64; 3] = std::array::from_fn(|c| ALPHA * self.x[c][i] + (1.0 - ALPHA) * self.z_prev[c][i]);
                let zi = project_simplex(std::array::from_fn(|c| xh[c] + self.u[c][i]));
                for c in 0..3 {
                    self.z[c][i] = zi[c];
                    self.u[c][i] += xh[c] - zi[c];
                }
            }
            if it % 25 == 24 {
                let (p, d) = self.residuals();
                if p < tol && d < tol {
                    return true;
                }
                // Balance the residuals by adapting ρ (OSQP style).
                let ratio = (p / d.max(1e-300)).sqrt();
                if it % 100 == 99 && !(0.2..=5.0).contains(&ratio) {
                    let new_rho = (self.rho * ratio.clamp(1e-3, 1e3)).clamp(1e-8, 1e8);
                    for uc in self.u.iter_mut() {
                        for ui in uc.iter_mut() {
                            *ui *= self.rho / new_rho;
                        }
                    }
                    self.rho = new_rho;
                    self.factor();
                }
            }
        }
        false
    }
}

/// Exact solution of the basis QP for the zero pattern suggested by `guess`, refined by
/// primal–dual active-set iterations until the KKT conditions hold.
pub(super) fn polish(
    a: &[Vec<f64>; 3],
    h: &[f64],
    guess: &[Vec<f64>; 3],
) -> std::result::Result<[Vec<f64>; 3], String> {
    let n = h.len() + 1;
    // free[i]: bit c set if w_ic is free (not fixed at 0).
    let mut free: Vec<u8> = (0..n)
        .map(|i| {
            let mut m = 0u8;
            for c in 0..3 {
                if guess[c][i] > 1e-9 {
                    m |= 1 << c;
                }
            }
            if m == 0 {
                let c = (0..3).max_by(|&p, &q| guess[p][i].total_cmp(&guess[q][i])).unwrap();
                m = 1 << c;
            }
            m
        })
        .collect();
    let mut lv = vec![0.0; n];
    for _ in 0..200 {
        let (w, nu) = solve_reduced(a, h, &free)?;
        // G_ic = ∂/∂w_ic of the Lagrangian without the bound and sum terms.
        let mut g: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
        let mut gscale = 1e-300f64;
        for c in 0..3 {
            laplacian_mul(h, &w[c], &mut lv);
            for i in 0..n {
                let mut v = 2.0 * lv[i];
                if c < 2 {
                    v += (0..3).map(|r| nu[3 * c + r] * a[r][i]).sum::<f64>();
                }
                g[c][i] = v;
                gscale = gscale.max(v.abs());
            }
        }
        let tol_mu = 1e-11 * gscale;
        let tol_w = 1e-12;
        let mut changed = false;
        for i in 0..n {
            let m = free[i];
            let fc: Vec<usize> = (0..3).filter(|&c| m & (1 << c) != 0).collect();
            let g_free = fc.iter().map(|&c| g[c][i]).sum::<f64>() / fc.len() as f64;
            let mut nm = 0u8;
            for c in 0..3 {
                let keep = if m & (1 << c) != 0 { w[c][i] >= -tol_w } else { g[c][i] - g_free < -tol_mu };
                if keep {
                    nm |= 1 << c;
                }
            }
            if nm == 0 {
                let c = (0..3).max_by(|&p, &q| w[p][i].total_cmp(&w[q][i])).unwrap();
                nm = 1 << c;
            }
            if nm != m {
                changed = true;
                free[i] = nm;
            }
        }
        if !changed {
            let mut w = w;
            for wc in w.iter_mut() {
                for v in wc.iter_mut() {
                    *v = v.max(0.0);
                }
            }
            // Verify the result independently of the algebra above.
            for c in 0..3 {
                for r in 0..3 {
                    let got: f64 = a[r].iter().zip(&w[c]).map(|(x, y)| x * y).sum();
                    let want = if r == c { 1.0 } else { 0.0 };
                    if (got - want).abs() > 1e-10 {
                        return Err(format!("reversibility residual {:.2e} after polishing", (got - want).abs()));
                    }
                }
            }
            for i in 0..n {
                let s = w[0][i] + w[1][i] + w[2][i];
                if (s - 1.0).abs() > 1e-10 {
                    return Err(format!("sum residual {:.2e} after polishing", (s - 1.0).abs()));
                }
            }
            return Ok(w);
        }
    }
    Err("active-set polish did not settle".into())
}

/// Solve the basis QP with the entries outside `free` fixed at 0 and the bounds otherwise
/// ignored: returns w (3 × n) and the multipliers ν of A w_R = e_R, A w_G = e_G (6).
///
/// Per sample i the free channels F_i are parametrised so that Σ_c w_ic = 1 holds
/// identically: |F| = 1 → w = e_a (no unknown); |F| = 2 → w = t·(e_a − e_b) + e_b;
/// |F| = 3 → w = (t1, t2, 1 − t1 − t2). A w_B = e_B then follows from the other two
/// channels' equalities (the rows of A sum to 1).
pub(super) fn solve_reduced(
    a: &[Vec<f64>; 3],
    h: &[f64],
    free: &[u8],
) -> std::result::Result<([Vec<f64>; 3], [f64; 6]), String> {
    let n = free.len();
    // Columns of P_i (each a 3-vector) and q_i.
    let mut cols: Vec<Vec<[f64; 3]>> = Vec::with_capacity(n);
    let mut q: Vec<[f64; 3]> = Vec::with_capacity(n);
    let mut off = Vec::with_capacity(n + 1);
    let mut nv = 0;
    for &m in free {
        let fc: Vec<usize> = (0..3).filter(|&c| m & (1 << c) != 0).collect();
        let unit = |c: usize| -> [f64; 3] { std::array::from_fn(|k| if k == c { 1.0 } else { 0.0 }) };
        let (p, qi) = match fc.len() {
            1 => (vec![], unit(fc[0])),
            2 => {
                let (ea, eb) = (unit(fc[0]), unit(fc[1]));
                (vec![std::array::from_fn(|k| ea[k] - eb[k])], eb)
            }
            _ => (vec![[1.0, 0.0, -1.0], [0.0, 1.0, -1.0]], unit(2)),
        };
        off.push(nv);
        nv += p.len();
        cols.push(p);
        q.push(qi);
    }
    off.push(nv);
    // L entries: L_ii = h_{i−1} + h_i, L_{i,i+1} = −h_i.
    let l = |i: usize, j: usize| -> f64 {
        if i == j {
            (if i > 0 { h[i - 1] } else { 0.0 }) + (if i + 1 < n { h[i] } else { 0.0 })
        } else {
            -h[i.min(j)]
        }
    };
    let dot3 = |x: &[f64; 3], y: &[f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    // Reduced Hessian H (band, p = 3), gradient g, constraints C (6 × nv), rhs d.
    let mut hb = Band::new(nv.max(1), 3);
    let mut g = vec![0.0; nv];
    let mut cm: Vec<Vec<f64>> = vec![vec![0.0; nv]; 6];
    let mut d = [0.0f64; 6];
    for c in 0..2 {
        for r in 0..3 {
            d[3 * c + r] = if r == c { 1.0 } else { 0.0 };
        }
    }
    for i in 0..n {
        for j in i.saturating_sub(1)..(i + 2).min(n) {
            let lij = l(i, j);
            for (s, pi) in cols[i].iter().enumerate() {
                g[off[i] + s] += 2.0 * lij * dot3(pi, &q[j]);
                if j <= i {
                    for (t, pj) in cols[j].iter().enumerate() {
                        let (ri, rj) = (off[i] + s, off[j] + t);
                        if rj <= ri {
                            hb.add(ri, rj, 2.0 * lij * dot3(pi, pj));
                        }
                    }
                }
            }
        }
        for c in 0..2 {
            for r in 0..3 {
                d[3 * c + r] -= a[r][i] * q[i][c];
                for (s, pi) in cols[i].iter().enumerate() {
                    cm[3 * c + r][off[i] + s] = a[r][i] * pi[c];
                }
            }
        }
    }
    let h_true = hb.clone();
    let maxdiag = (0..nv).map(|i| hb.get(i, i)).fold(0.0f64, f64::max).max(1e-300);
    let delta = 1e-8 * maxdiag;
    for i in 0..nv {
        hb.add(i, i, delta);
    }
    if nv > 0 && !hb.cholesky() {
        return Err("reduced Hessian is not positive definite".into());
    }
    // Y = H_δ⁻¹ Cᵀ, S = C Y.
    let y_cols: Vec<Vec<f64>> = cm
        .iter()
        .map(|row| {
            let mut v = row.clone();
            if nv > 0 {
                hb.solve(&mut v);
            }
            v
        })
        .collect();
    let mut s = [0.0f64; 36];
    for r in 0..6 {
        for k in 0..6 {
            s[r * 6 + k] = cm[r].iter().zip(&y_cols[k]).map(|(x, y)| x * y).sum();
        }
    }
    // Solve the regularised KKT system for rhs (r1, r2), as a closure for refinement.
    let kkt_solve = |r1: &[f64], r2: &[f64; 6]| -> Option<(Vec<f64>, [f64; 6])> {
        let mut y0 = r1.to_vec();
        if nv > 0 {
            hb.solve(&mut y0);
        }
        let mut rhs: [f64; 6] = std::array::from_fn(|r| cm[r].iter().zip(&y0).map(|(x, y)| x * y).sum::<f64>() - r2[r]);
        let mut ss = s;
        if !solve_dense(&mut ss, 6, &mut rhs) {
            return None;
        }
        for (k, yk) in y_cols.iter().enumerate() {
            for (v, &t) in y0.iter_mut().zip(yk) {
                *v -= rhs[k] * t;
            }
        }
        Some((y0, rhs))
    };
    let neg_g: Vec<f64> = g.iter().map(|v| -v).collect();
    let (mut y, mut nu) =
        kkt_solve(&neg_g, &d).ok_or("the equality constraints are degenerate for this zero pattern")?;
    let mut hy = vec![0.0; nv];
    for _ in 0..30 {
        h_true.mul(&y, &mut hy);
        let r1: Vec<f64> = (0..nv).map(|i| neg_g[i] - hy[i] - (0..6).map(|r| cm[r][i] * nu[r]).sum::<f64>()).collect();
        let r2: [f64; 6] = std::array::from_fn(|r| d[r] - cm[r].iter().zip(&y).map(|(x, v)| x * v).sum::<f64>());
        let size = r1.iter().chain(r2.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
        if size < 1e-15 * (1.0 + maxdiag) {
            break;
        }
        let Some((dy, dnu)) = kkt_solve(&r1, &r2) else { break };
        for (v, dv) in y.iter_mut().zip(&dy) {
            *v += dv;
        }
        for (v, dv) in nu.iter_mut().zip(&dnu) {
            *v += dv;
        }
    }
    let mut w: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
    for i in 0..n {
        let mut wi = q[i];
        for (s, pi) in cols[i].iter().enumerate() {
            for k in 0..3 {
                wi[k] += pi[k] * y[off[i] + s];
            }
        }
        for c in 0..3 {
            w[c][i] = wi[c];
        }
    }
    Ok((w, nu))
}
