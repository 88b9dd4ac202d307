//! RGB → spectrum maps (docs/design.md#rgb-data, the paper's eq. 10).
//!
//! Everything a scene gives as RGB becomes a spectrum on the render's grid:
//!
//! * [`UpliftMethod::Linear`] (the default, the paper's method): the fixed linear map
//!   `P(λi) = wR(λi)·r + wG(λi)·g + wB(λi)·b`. The three basis curves are computed once
//!   per grid as the smoothest curves (least ∫(dw/dλ)² dλ) that are *reversible* (each,
//!   as a reflectance under D65, gives exactly its unit RGB) and *bounded* (`w ≥ 0`,
//!   `wR + wG + wB = 1`, so white is flat 1 and any RGB in [0,1]³ gives a reflectance
//!   in [0,1]). The convex quadratic programme is solved here by ADMM followed by an
//!   exact primal–dual active-set polish (see `docs/uplift.md`).
//! * [`UpliftMethod::Smooth`]: Jakob & Hanika 2019, reflectance =
//!   `S(c0·x² + c1·x + c2)` with `S(z) = ½ + z/(2√(1+z²))` and `x` the wavelength
//!   normalised to the grid's range. The coefficients are fitted by Gauss–Newton in
//!   CIELAB on a 3 × 16³ lattice of RGB values when the [`Uplift`] is built (≈ 35 ms on
//!   the default grid), interpolated trilinearly per call and then refined by at most
//!   three Newton steps on the exact RGB (≈ 0.5 µs per call on 41 samples; round trip
//!   within 1e-5 instead of the table's 1.4e-2). Emission uses the same shape scaled by
//!   the largest component, plus a tiny linear-basis correction so it round-trips exactly.
//!
//! **White-point normalisation.** On a coarse grid, the reflectance 1 under the grid's
//! D65 seen through the grid's observer is not exactly the working space's white
//! (1,1,1). All reflectance ↔ RGB statements here use the *normalised* map
//! `rgb_c(ρ) = RGB_c[ρ·D65] / RGB_c[D65]` (per channel, both through the grid's
//! [`super::Observer`] and the working space), which gives exactly (1,1,1) for ρ = 1.
//! Emission is not normalised: an emission spectrum seen through the grid's observer
//! and the working space gives back exactly its RGB.

// Index loops mirror the maths (several arrays indexed together); `!(a > b)` is used on
// purpose so that NaN counts as failure.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::color::delta_e::lab_f;
use crate::color::{reflectance_rows, RgbSpace};
use crate::spectrum::named::{RgbToSpectrum, SpectrumRole};
use crate::spectrum::WavelengthGrid;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// Which RGB → spectrum map a render uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum UpliftMethod {
    /// The paper's eq. 10: a fixed linear map with minimum-variation basis curves.
    #[default]
    Linear,
    /// Jakob & Hanika 2019: a bounded, smooth, non-linear sigmoid-of-quadratic map.
    Smooth,
}

/// Precomputed per grid; cheap to apply per hit (deferred conversion of textures/HDRIs).
#[derive(Clone, Debug)]
pub struct Uplift {
    method: UpliftMethod,
    /// wR, wG, wB on the grid (eq. 10).
    basis: [Vec<f32>; 3],
    /// Emission basis: `w_c · D65 / RGB_c[D65]`, so that `Σ rgb_c · emission_c` seen
    /// through the observer gives exactly `rgb`.
    emission: [Vec<f32>; 3],
    /// `D65 / Y[D65]` on the grid: the emission whose reflectance factor is the shape.
    d65: Vec<f32>,
    /// `RGB[D65] / Y[D65]`: the grid's white in the working space (≈ (1,1,1)).
    white: [f32; 3],
    /// The normalised reflectance → RGB map (3 × n): `rgb_c = Σ_i to_rgb[c][i]·ρ_i`.
    to_rgb: [Vec<f32>; 3],
    /// Coefficient lattice of the smooth uplift (only for [`UpliftMethod::Smooth`]).
    smooth: Option<SmoothTable>,
    /// Largest |RGB(basis_c) − e_c| of the reflectance round trip (0 up to rounding when
    /// the basis was solved on the grid itself).
    round_trip_error: f32,
    /// When the bounded reversible problem is infeasible on the grid: the size of the
    /// fine auxiliary grid the basis was solved on and cell-averaged from.
    fallback_samples: Option<usize>,
    /// Whether the emission basis round-trips exactly (false only when the fallback's
    /// curves could merely be rescaled per channel).
    emission_exact: bool,
}

impl Uplift {
    pub fn new(grid: &WavelengthGrid, space: &RgbSpace, method: UpliftMethod) -> Result<Self> {
        let n = grid.len();
        if n < 4 || grid.lambdas().windows(2).any(|p| !(p[1] > p[0])) {
            // E.g. the RGB method's three-lane grid: RGB needs no conversion there.
            return Err(Error::setting(
                "wavelengths",
                format!(
                    "the RGB → spectrum map needs a spectral grid of at least 4 ascending wavelengths, not {:?}",
                    grid.lambdas()
                ),
            ));
        }
        let (lo, hi) = (grid.lambdas()[0], grid.lambdas()[n - 1]);
        let (e, k, y_e) = reflectance_rows(grid, space)?;
        let sums: Vec<f64> = k.iter().map(|row| row.iter().sum()).collect();
        let white_ok = !sums.iter().any(|&s| !(s > 1e-3 * y_e));
        // A grid too coarse to reproduce D65 white at all (4 samples over 380..780 nm: red
        // of white < 0) still gets the LINEAR fallback basis below, with the map
        // normalised by luminance instead of per channel (docs/design.md#spectra: 4..401 samples work).
        let coverage_fallback = !white_ok && method == UpliftMethod::Linear && y_e.is_finite() && y_e > 0.0 && n >= 4;
        if !(y_e.is_finite() && y_e > 0.0) || (!white_ok && !coverage_fallback) {
            return Err(Error::setting(
                "wavelength_count",
                format!(
                    "the {n} wavelengths over {lo}..{hi} nm do not cover enough of the visible \
                     range to reproduce D65 white (white RGB on this grid: {:.4}, {:.4}, {:.4}); \
                     use more wavelengths spread over 380..780 nm",
                    sums[0] / y_e,
                    sums[1] / y_e,
                    sums[2] / y_e
                ),
            ));
        }
        // The normalised reflectance → RGB map: each row sums to 1, so ρ = 1 gives (1,1,1).
        let sums: Vec<f64> = if coverage_fallback { vec![y_e; 3] } else { sums };
        let a: [Vec<f64>; 3] = std::array::from_fn(|c| k[c].iter().map(|v| v / sums[c]).collect());
        let lambdas: Vec<f64> = grid.lambdas().iter().map(|&l| l as f64).collect();
        let h: Vec<f64> = lambdas.windows(2).map(|p| 1.0 / (p[1] - p[0])).collect();
        let solved = if coverage_fallback {
            Err("the grid cannot reproduce D65 white".to_string())
        } else {
            solve_basis(&a, &h)
        };
        let (w, fallback_samples) = match solved {
            Ok(w) => (w, None),
            // Some small grids (4, 5, 7, 8, 9, 11 samples over 380..780 nm) admit no basis
            // that is both bounded and exactly reversible, yet docs/design.md#spectra wants 4..401 samples
            // to work: fall back to a basis solved on a fine grid over the same range and
            // averaged over each coarse sample's cell (see `fallback_basis`).
            Err(why) => match fallback_basis(grid, space) {
                Some((w, m)) => (w, Some(m)),
                None => {
                    return Err(Error::setting(
                        "wavelength_count",
                        format!(
                            "no bounded, reversible RGB → spectrum basis exists on the {n} wavelengths over \
                             {lo}..{hi} nm: {why}; use more wavelengths (any count from 12 up over 380..780 nm \
                             works; 41 is the default)"
                        ),
                    ))
                }
            },
        };
        // Reflectance round trip of the unit colours (exact unless the fallback was used).
        let aw: [[f64; 3]; 3] =
            std::array::from_fn(|c| std::array::from_fn(|d| a[d].iter().zip(&w[c]).map(|(x, y)| x * y).sum()));
        let round_trip_error = (0..3)
            .flat_map(|c| (0..3).map(move |d| (c, d)))
            .map(|(c, d)| (aw[c][d] - if c == d { 1.0 } else { 0.0 }).abs())
            .fold(0.0f64, f64::max) as f32;
        let basis: [Vec<f32>; 3] = std::array::from_fn(|c| w[c].iter().map(|&v| v as f32).collect());
        let mut emission: [Vec<f32>; 3] =
            std::array::from_fn(|c| w[c].iter().zip(&e).map(|(&wi, &ei)| (wi * ei / sums[c]) as f32).collect());
        let mut emission_exact = true;
        if fallback_samples.is_some() {
            (emission, emission_exact) = exact_emission(&emission, &aw, &sums);
        }
        let d65 = e.iter().map(|&v| (v / y_e) as f32).collect();
        let white = std::array::from_fn(|c| (sums[c] / y_e) as f32);
        let to_rgb = std::array::from_fn(|c| a[c].iter().map(|&v| v as f32).collect());
        let smooth = match method {
            UpliftMethod::Linear => None,
            UpliftMethod::Smooth => Some(SmoothTable::build(&lambdas, &a, space, SMOOTH_RES)),
        };
        Ok(Self {
            method,
            basis,
            emission,
            d65,
            white,
            to_rgb,
            smooth,
            round_trip_error,
            fallback_samples,
            emission_exact,
        })
    }

    /// Largest error of the reflectance round trip RGB(basis_c) − unit RGB_c: 0 (up to
    /// rounding) normally, a few percent on grids that needed the fallback.
    pub fn round_trip_error(&self) -> f32 {
        self.round_trip_error
    }

    /// Whether illuminant RGB round-trips exactly (false only for fallback curves that
    /// could merely be rescaled per channel without going negative).
    pub fn emission_round_trips_exactly(&self) -> bool {
        self.emission_exact
    }

    /// Some(fine grid size) when the grid needed the cell-averaged fallback basis.
    pub fn fallback_samples(&self) -> Option<usize> {
        self.fallback_samples
    }

    pub fn method(&self) -> UpliftMethod {
        self.method
    }

    /// Number of wavelength samples (the grid's length).
    pub fn len(&self) -> usize {
        self.basis[0].len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The three reflectance basis curves wR, wG, wB on the grid (eq. 10), for tests and docs.
    pub fn reflectance_basis(&self) -> [&[f32]; 3] {
        [&self.basis[0], &self.basis[1], &self.basis[2]]
    }

    /// The normalised reflectance → RGB map of the grid: RGB of a reflectance `s` (values
    /// at the grid's samples) lit by the grid's D65, seen through the grid's observer and
    /// the working space, divided per channel by the RGB of reflectance 1 (so flat 1
    /// gives exactly (1,1,1)). Both uplifts invert this map.
    pub fn reflectance_to_rgb(&self, s: &[f32]) -> [f64; 3] {
        std::array::from_fn(|c| s.iter().zip(&self.to_rgb[c]).map(|(&a, &b)| a as f64 * b as f64).sum())
    }

    /// Reflectance spectrum of rgb into `out` (values for the grid's samples). Hot path: no
    /// allocation. RGB is clamped to [0,1] first (a reflectance cannot exceed 1), so `out`
    /// is always in [0,1].
    pub fn reflectance_into(&self, rgb: [f32; 3], out: &mut [f32]) {
        assert_eq!(out.len(), self.len(), "output length must be the grid's");
        let c = rgb.map(clamp01);
        match &self.smooth {
            None => self.linear_into(c, out),
            Some(t) => t.reflectance_into(c, out),
        }
    }

    /// Radiance/emission spectrum of rgb into `out`: unbounded; the basis × D65 scaled so
    /// that this spectrum seen through the grid's Observer and `space` gives back exactly
    /// `rgb`. Negative components are clamped to 0 (emission cannot be negative).
    pub fn illuminant_into(&self, rgb: [f32; 3], out: &mut [f32]) {
        assert_eq!(out.len(), self.len(), "output length must be the grid's");
        // NaN → 0, +∞ → f32::MAX (the spectrum may overflow to +∞ but never becomes NaN).
        let rgb = rgb.map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
        match &self.smooth {
            None => {
                let [b0, b1, b2] = &self.emission;
                for (((o, &x), &y), &z) in out.iter_mut().zip(b0).zip(b1).zip(b2) {
                    *o = rgb[0] * x + rgb[1] * y + rgb[2] * z;
                }
            }
            Some(t) => {
                // Jakob–Hanika: shape of the normalised colour, scaled by its largest component.
                let m = rgb[0].max(rgb[1]).max(rgb[2]);
                if !(m > 0.0) {
                    out.fill(0.0);
                    return;
                }
                // Target reflectance RGB (normalised map) whose emission under D65 is rgb/m.
                let target: [f32; 3] = std::array::from_fn(|c| rgb[c] / m / self.white[c]);
                t.reflectance_into(target.map(clamp01), out);
                // Exact round trip: add the linear basis times the remaining RGB error.
                let got = self.reflectance_to_rgb(out);
                let corr: [f32; 3] = std::array::from_fn(|c| (target[c] as f64 - got[c]) as f32);
                let [b0, b1, b2] = &self.basis;
                for ((((o, &x), &y), &z), &d) in out.iter_mut().zip(b0).zip(b1).zip(b2).zip(&self.d65) {
                    let r = *o + corr[0] * x + corr[1] * y + corr[2] * z;
                    *o = m * r.max(0.0) * d;
                }
            }
        }
    }

    /// The linear map (eq. 10) without any clamping.
    fn linear_into(&self, rgb: [f32; 3], out: &mut [f32]) {
        let [b0, b1, b2] = &self.basis;
        for (((o, &x), &y), &z) in out.iter_mut().zip(b0).zip(b1).zip(b2) {
            *o = rgb[0] * x + rgb[1] * y + rgb[2] * z;
        }
    }
}

impl RgbToSpectrum for Uplift {
    /// Reflectance → [`Uplift::reflectance_into`], Illuminant → [`Uplift::illuminant_into`],
    /// Unbounded → the linear basis (eq. 10) without clamping, whatever the method (a
    /// flat grey RGB, e.g. an index of refraction, stays flat).
    fn convert(&self, rgb: [f32; 3], role: SpectrumRole) -> Vec<f32> {
        let mut out = vec![0.0; self.len()];
        match role {
            SpectrumRole::Reflectance => self.reflectance_into(rgb, &mut out),
            SpectrumRole::Illuminant => self.illuminant_into(rgb, &mut out),
            SpectrumRole::Unbounded => self.linear_into(rgb, &mut out),
        }
        out
    }
}

#[inline]
fn clamp01(v: f32) -> f32 {
    // NaN → 0.
    if v > 0.0 {
        v.min(1.0)
    } else {
        0.0
    }
}

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

/// Symmetric positive definite band matrix (half-bandwidth `p`), lower part stored;
/// factorised in place by Cholesky.
struct Band {
    n: usize,
    p: usize,
    a: Vec<f64>,
}

impl Band {
    fn new(n: usize, p: usize) -> Self {
        Self { n, p, a: vec![0.0; n * (p + 1)] }
    }
    #[inline]
    fn idx(&self, i: usize, j: usize) -> usize {
        debug_assert!(j <= i && i - j <= self.p);
        i * (self.p + 1) + (j + self.p - i)
    }
    fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        let k = self.idx(i, j);
        self.a[k] += v;
    }
    fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        if i - j > self.p {
            0.0
        } else {
            self.a[self.idx(i, j)]
        }
    }
    /// y = self · x (before factorisation).
    fn mul(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            let mut s = 0.0;
            for j in i.saturating_sub(self.p)..(i + self.p + 1).min(self.n) {
                s += self.get(i, j) * x[j];
            }
            y[i] = s;
        }
    }
    fn cholesky(&mut self) -> bool {
        for i in 0..self.n {
            let lo = i.saturating_sub(self.p);
            for j in lo..=i {
                let mut s = self.a[self.idx(i, j)];
                for k in lo..j {
                    s -= self.a[self.idx(i, k)] * self.a[self.idx(j, k)];
                }
                let ij = self.idx(i, j);
                if i == j {
                    if !(s > 0.0) {
                        return false;
                    }
                    self.a[ij] = s.sqrt();
                } else {
                    self.a[ij] = s / self.a[self.idx(j, j)];
                }
            }
        }
        true
    }
    /// Solve (L Lᵀ) x = b in place (after `cholesky`).
    fn solve(&self, b: &mut [f64]) {
        for i in 0..self.n {
            let mut s = b[i];
            for k in i.saturating_sub(self.p)..i {
                s -= self.a[self.idx(i, k)] * b[k];
            }
            b[i] = s / self.a[self.idx(i, i)];
        }
        for i in (0..self.n).rev() {
            let mut s = b[i];
            for k in i + 1..(i + self.p + 1).min(self.n) {
                s -= self.a[self.idx(k, i)] * b[k];
            }
            b[i] = s / self.a[self.idx(i, i)];
        }
    }
}

/// Solve the dense m×m system `mat · x = b` in place by LU with partial pivoting.
/// Returns false if the matrix is (numerically) singular.
fn solve_dense(mat: &mut [f64], m: usize, b: &mut [f64]) -> bool {
    let scale = mat.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    if !(scale > 0.0) || !scale.is_finite() {
        return false;
    }
    for col in 0..m {
        // unwrap: col < m, so the range is never empty (not user data).
        let piv = (col..m).max_by(|&r, &s| mat[r * m + col].abs().total_cmp(&mat[s * m + col].abs())).unwrap();
        if !(mat[piv * m + col].abs() > 1e-14 * scale) {
            return false;
        }
        if piv != col {
            for k in 0..m {
                mat.swap(piv * m + k, col * m + k);
            }
            b.swap(piv, col);
        }
        let d = mat[col * m + col];
        for r in col + 1..m {
            let f = mat[r * m + col] / d;
            if f != 0.0 {
                for k in col..m {
                    mat[r * m + k] -= f * mat[col * m + k];
                }
                b[r] -= f * b[col];
            }
        }
    }
    for r in (0..m).rev() {
        let mut s = b[r];
        for k in r + 1..m {
            s -= mat[r * m + k] * b[k];
        }
        b[r] = s / mat[r * m + r];
    }
    true
}

/// Euclidean projection of v onto {w ≥ 0, w0 + w1 + w2 = 1}.
fn project_simplex(v: [f64; 3]) -> [f64; 3] {
    let mut u = v;
    u.sort_by(|a, b| b.total_cmp(a));
    let mut cum = 0.0;
    let mut theta = 0.0;
    for (j, &uj) in u.iter().enumerate() {
        cum += uj;
        let t = (cum - 1.0) / (j + 1) as f64;
        if uj - t > 0.0 {
            theta = t;
        }
    }
    v.map(|x| (x - theta).max(0.0))
}

/// The smoothness energy Σ_c Σ_k h_k (w_c[k+1] − w_c[k])².
#[cfg(test)]
fn energy(w: &[Vec<f64>; 3], h: &[f64]) -> f64 {
    w.iter().map(|wc| h.iter().enumerate().map(|(k, &hk)| hk * (wc[k + 1] - wc[k]).powi(2)).sum::<f64>()).sum()
}

/// (L v)_i for the path Laplacian with edge weights h: the gradient of Σ h_k (v[k+1]−v[k])² is 2 L v.
fn laplacian_mul(h: &[f64], v: &[f64], out: &mut [f64]) {
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
fn fallback_basis(grid: &WavelengthGrid, space: &RgbSpace) -> Option<([Vec<f64>; 3], usize)> {
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
fn cell_average(x: &[f64], y: &[f64], a: f64, b: f64) -> f64 {
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
fn exact_emission(em: &[Vec<f32>; 3], aw: &[[f64; 3]; 3], sums: &[f64]) -> ([Vec<f32>; 3], bool) {
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
fn solve_basis(a: &[Vec<f64>; 3], h: &[f64]) -> std::result::Result<[Vec<f64>; 3], String> {
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
struct Admm<'a> {
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
    fn new(a: &'a [Vec<f64>; 3], h: &'a [f64]) -> Self {
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

    fn factor(&mut self) {
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
    fn residuals(&self) -> (f64, f64) {
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
    fn run(&mut self, tol: f64, max_iter: usize) -> bool {
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
fn polish(a: &[Vec<f64>; 3], h: &[f64], guess: &[Vec<f64>; 3]) -> std::result::Result<[Vec<f64>; 3], String> {
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
fn solve_reduced(a: &[Vec<f64>; 3], h: &[f64], free: &[u8]) -> std::result::Result<([Vec<f64>; 3], [f64; 6]), String> {
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
    let h_true = Band { n: hb.n, p: hb.p, a: hb.a.clone() };
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
const SMOOTH_RES: usize = 16;
/// Most Jacobian evaluations (so at most 3 Newton steps) per call from the interpolated
/// coefficients (0 = table only), and the normalised-RGB error at which they stop.
const SMOOTH_NEWTON_STEPS: usize = 4;
const SMOOTH_NEWTON_TOL: f32 = 1e-5;
/// Chunk width of the Jacobian loop (4 f32 = one SSE register: no spills).
const JL: usize = 4;
/// Largest coefficient magnitude the fit may use (x normalised to [0,1]).
const SMOOTH_COEFF_CAP: f64 = 1000.0;

/// The sigmoid S(z) = ½ + z / (2√(1+z²)) and its derivative.
#[inline]
fn sigmoid(z: f64) -> (f64, f64) {
    let r = 1.0 / (1.0 + z * z).sqrt();
    (0.5 + 0.5 * z * r, 0.5 * r * r * r)
}

#[derive(Clone, Debug)]
struct SmoothTable {
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
struct Fitter<'a> {
    x: Vec<f64>,
    a: &'a [Vec<f64>; 3],
    rgb_to_xyz: [[f64; 3]; 3],
    white: [f64; 3],
}

impl Fitter<'_> {
    /// CIELAB of an RGB of the normalised map and its Jacobian d Lab / d rgb.
    fn lab(&self, rgb: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
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
    fn eval(&self, c: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
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
    fn residual(&self, c: &[f64; 3], target_lab: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (rgb, jrgb) = self.eval(c);
        let (lab, jlab) = self.lab(rgb);
        let res = std::array::from_fn(|k| lab[k] - target_lab[k]);
        let jac = std::array::from_fn(|r| std::array::from_fn(|k| (0..3).map(|t| jlab[r][t] * jrgb[t][k]).sum()));
        (res, jac)
    }

    /// Gauss–Newton (with step halving) from `c` towards `target` rgb.
    fn fit(&self, target: [f64; 3], c: &mut [f64; 3]) {
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

fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

impl SmoothTable {
    fn build(lambdas: &[f64], a: &[Vec<f64>; 3], space: &RgbSpace, res: usize) -> Self {
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
    fn lookup(&self, rgb: [f32; 3]) -> ([f32; 3], f32) {
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
    fn reflectance_into(&self, rgb: [f32; 3], out: &mut [f32]) {
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
    fn direct_into(&self, rgb: [f32; 3], out: &mut [f32]) {
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
    fn fill(&self, [c0, c1, c2]: [f32; 3], factor: f32, out: &mut [f32]) {
        let half = 0.5 * factor;
        for (o, &x) in out.iter_mut().zip(&self.x) {
            let p = (c0 * x + c1) * x + c2;
            *o = half + half * p / (1.0 + p * p).sqrt();
        }
    }

    /// Normalised RGB of S(poly_c) and its derivative with respect to c. Runs over the
    /// zero-padded copies in chunks of JL with per-lane accumulators (vectorises).
    #[inline]
    fn jacobian(&self, [c0, c1, c2]: [f32; 3]) -> ([f32; 3], [[f32; 3]; 3]) {
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

/// Solve the 3×3 system j·d = r by Cramer's rule in f64; None if (nearly) singular.
#[inline]
fn solve3(j: [[f32; 3]; 3], r: [f32; 3]) -> Option<[f32; 3]> {
    let m = j.map(|row| row.map(|v| v as f64));
    let r = r.map(|v| v as f64);
    let det = |c0: [f64; 3], c1: [f64; 3], c2: [f64; 3]| {
        c0[0] * (c1[1] * c2[2] - c1[2] * c2[1]) - c1[0] * (c0[1] * c2[2] - c0[2] * c2[1])
            + c2[0] * (c0[1] * c1[2] - c0[2] * c1[1])
    };
    let col = |k: usize| [m[0][k], m[1][k], m[2][k]];
    let d = det(col(0), col(1), col(2));
    let scale = m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    if !(d.abs() > 1e-12 * scale * scale * scale) {
        return None;
    }
    Some([
        (det(r, col(1), col(2)) / d) as f32,
        (det(col(0), r, col(2)) / d) as f32,
        (det(col(0), col(1), r) / d) as f32,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Observer;
    use crate::spectrum::named::{SpectrumDesc, SpectrumKind};

    fn grids() -> Vec<(&'static str, WavelengthGrid)> {
        vec![
            ("default 41", WavelengthGrid::default()),
            ("8 samples", WavelengthGrid::uniform(8, 400.0, 700.0).unwrap()),
            ("401 samples", WavelengthGrid::uniform(401, 380.0, 780.0).unwrap()),
            (
                "non-uniform",
                WavelengthGrid::from_wavelengths(vec![
                    370.0, 395.0, 420.0, 440.0, 455.0, 470.0, 480.0, 490.0, 500.0, 505.0, 510.0, 520.0, 535.0, 545.0,
                    550.0, 555.0, 560.0, 570.0, 585.0, 600.0, 611.0, 620.0, 640.0, 670.0, 700.0, 740.0, 800.0,
                ])
                .unwrap(),
            ),
        ]
    }

    /// Independent reference: RGB of a reflectance under the grid's D65 through the
    /// grid's Observer and the space, normalised by the same for reflectance 1.
    struct Eye {
        obs: Observer,
        d65: Vec<f32>,
        space: RgbSpace,
        white: [f64; 3],
    }
    impl Eye {
        fn new(grid: &WavelengthGrid) -> Self {
            let space = RgbSpace::rec709();
            let d65 = crate::spectrum::named::d65(grid).unwrap();
            let obs = Observer::new(grid);
            let white = space.xyz_to_rgb(obs.xyz(&d65));
            Self { obs, d65, space, white }
        }
        fn reflectance(&self, s: &[f32]) -> [f64; 3] {
            let lit: Vec<f32> = s.iter().zip(&self.d65).map(|(a, b)| a * b).collect();
            let rgb = self.space.xyz_to_rgb(self.obs.xyz(&lit));
            std::array::from_fn(|c| rgb[c] / self.white[c])
        }
        fn emission(&self, s: &[f32]) -> [f64; 3] {
            self.space.xyz_to_rgb(self.obs.xyz(s))
        }
    }

    fn tv(w: &[f32], lambdas: &[f32]) -> f64 {
        (0..w.len() - 1)
            .map(|k| {
                let d = (w[k + 1] - w[k]) as f64;
                d * d / (lambdas[k + 1] - lambdas[k]) as f64
            })
            .sum()
    }

    #[test]
    fn linear_basis_meets_every_constraint() {
        for (name, grid) in grids() {
            let up = Uplift::new(&grid, &RgbSpace::rec709(), UpliftMethod::Linear).unwrap();
            let eye = Eye::new(&grid);
            let b = up.reflectance_basis();
            for c in 0..3 {
                assert_eq!(b[c].len(), grid.len());
                let rgb = eye.reflectance(b[c]);
                for k in 0..3 {
                    let want = if k == c { 1.0 } else { 0.0 };
                    assert!((rgb[k] - want).abs() < 1e-6, "{name}: basis {c} gives {rgb:?}");
                }
                let min = b[c].iter().copied().fold(f32::INFINITY, f32::min);
                assert!(min >= -1e-7, "{name}: basis {c} goes down to {min}");
            }
            for i in 0..grid.len() {
                let s = b[0][i] + b[1][i] + b[2][i];
                assert!((s - 1.0).abs() < 1e-6, "{name}: sum {s} at {} nm", grid.lambdas()[i]);
            }
            let mut white = vec![0.0; grid.len()];
            up.reflectance_into([1.0, 1.0, 1.0], &mut white);
            assert!(white.iter().all(|v| (v - 1.0).abs() < 1e-6), "{name}: white not flat: {white:?}");
            // The reference eye and the uplift's own map agree.
            let own = up.reflectance_to_rgb(b[1]);
            assert!((own[1] - 1.0).abs() < 1e-6 && own[0].abs() < 1e-6 && own[2].abs() < 1e-6, "{name}: {own:?}");
        }
    }

    fn lattice(steps: usize) -> impl Iterator<Item = [f32; 3]> {
        let s = steps - 1;
        (0..steps * steps * steps).map(move |k| {
            let (r, g, b) = (k % steps, (k / steps) % steps, k / (steps * steps));
            [r as f32 / s as f32, g as f32 / s as f32, b as f32 / s as f32]
        })
    }

    #[test]
    fn linear_round_trip_over_the_rgb_cube() {
        for (name, grid) in grids() {
            let up = Uplift::new(&grid, &RgbSpace::rec709(), UpliftMethod::Linear).unwrap();
            let eye = Eye::new(&grid);
            let mut out = vec![0.0; grid.len()];
            let mut worst = 0.0f64;
            for rgb in lattice(17) {
                up.reflectance_into(rgb, &mut out);
                assert!(out.iter().all(|&v| (-1e-7..=1.0 + 1e-6).contains(&v)), "{name}: {rgb:?} → {out:?}");
                let back = eye.reflectance(&out);
                for c in 0..3 {
                    worst = worst.max((back[c] - rgb[c] as f64).abs());
                }
            }
            assert!(worst < 1e-5, "{name}: worst round-trip error {worst:e}");
        }
    }

    /// Max RGB round-trip error of SMOOTH over the 17³ lattice; (all, excluding colours
    /// with two components at the lattice's extremes 0 and 1).
    fn smooth_round_trip(grid: &WavelengthGrid) -> (f64, f64) {
        let up = Uplift::new(grid, &RgbSpace::rec709(), UpliftMethod::Smooth).unwrap();
        let eye = Eye::new(grid);
        let mut out = vec![0.0; grid.len()];
        let (mut worst, mut worst_inner) = (0.0f64, 0.0f64);
        let mut worst_at = [0.0; 3];
        for rgb in lattice(17) {
            up.reflectance_into(rgb, &mut out);
            assert!(out.iter().all(|&v| (0.0..=1.0).contains(&v)), "{rgb:?} → {out:?}");
            let back = eye.reflectance(&out);
            let err = (0..3).map(|c| (back[c] - rgb[c] as f64).abs()).fold(0.0, f64::max);
            if err > worst {
                worst = err;
                worst_at = rgb;
            }
            let max = rgb[0].max(rgb[1]).max(rgb[2]);
            let min = rgb[0].min(rgb[1]).min(rgb[2]);
            // Saturated: the largest component at 1 and the smallest at 0.
            if !(max == 1.0 && min == 0.0) {
                worst_inner = worst_inner.max(err);
            }
        }
        println!(
            "SMOOTH round trip on {} samples: max {worst:.2e} (at {worst_at:?}), not saturated {worst_inner:.2e}",
            grid.len()
        );
        (worst, worst_inner)
    }

    #[test]
    fn smooth_round_trip_over_the_rgb_cube() {
        for (name, grid) in grids() {
            let (all, inner) = smooth_round_trip(&grid);
            assert!(inner < 3e-5, "{name}: not-saturated colours: {inner:e}");
            assert!(all < 3e-5, "{name}: all colours: {all:e}");
        }
    }

    #[test]
    fn illuminant_round_trip_for_large_values() {
        for method in [UpliftMethod::Linear, UpliftMethod::Smooth] {
            for (name, grid) in grids() {
                if method == UpliftMethod::Smooth && grid.len() > 100 {
                    continue; // keep the debug test fast; the default grid covers SMOOTH
                }
                let up = Uplift::new(&grid, &RgbSpace::rec709(), method).unwrap();
                let eye = Eye::new(&grid);
                let mut out = vec![0.0; grid.len()];
                for rgb in [[1e6f32, 2.0, 0.5], [1.0, 1.0, 1.0], [0.2, 3.0, 40.0], [0.0, 0.0, 7.0]] {
                    up.illuminant_into(rgb, &mut out);
                    assert!(out.iter().all(|&v| v >= 0.0 && v.is_finite()));
                    let back = eye.emission(&out);
                    let scale = rgb.iter().fold(0.0f32, |m, &v| m.max(v)) as f64;
                    for c in 0..3 {
                        let err = (back[c] - rgb[c] as f64).abs() / scale;
                        assert!(err < 1e-5, "{method:?} {name}: {rgb:?} → {back:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn white_emission_is_d65() {
        let grid = WavelengthGrid::default();
        let up = Uplift::new(&grid, &RgbSpace::rec709(), UpliftMethod::Linear).unwrap();
        let eye = Eye::new(&grid);
        let mut out = vec![0.0; grid.len()];
        up.illuminant_into([1.0, 1.0, 1.0], &mut out);
        let y_d65 = eye.obs.xyz(&eye.d65)[1];
        // The grid's white differs from (1,1,1) by a few 1e-3 (see the module docs), so
        // white emission is D65 within that.
        let w = eye.white.map(|v| v / y_d65);
        println!("white of the default grid: {w:?}");
        assert!(w.iter().all(|v| (v - 1.0).abs() < 5e-3));
        for i in 0..grid.len() {
            let want = eye.d65[i] as f64 / y_d65;
            assert!((out[i] as f64 - want).abs() < 5e-3 * want, "{} nm: {} vs {want}", grid.lambdas()[i], out[i]);
        }
    }

    /// Variational check of optimality: for the convex objective F, w is optimal iff
    /// F(w + s(v − w)) ≥ F(w) for every feasible v and s in (0, 1]. Feasible points v
    /// come from the same solver with other (random) interval weights, and random moves
    /// of the free entries inside the constraint set; their feasibility is checked here.
    #[test]
    fn linear_basis_is_optimal() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for (name, grid) in grids() {
            let n = grid.len();
            let (_, k, _) = reflectance_rows(&grid, &RgbSpace::rec709()).unwrap();
            let a: [Vec<f64>; 3] = std::array::from_fn(|c| {
                let s: f64 = k[c].iter().sum();
                k[c].iter().map(|v| v / s).collect()
            });
            let lam: Vec<f64> = grid.lambdas().iter().map(|&l| l as f64).collect();
            let h: Vec<f64> = lam.windows(2).map(|p| 1.0 / (p[1] - p[0])).collect();
            let w = solve_basis(&a, &h).unwrap();
            let f0 = energy(&w, &h);
            // The stored f32 curves are this solution.
            let up = Uplift::new(&grid, &RgbSpace::rec709(), UpliftMethod::Linear).unwrap();
            let tv32: f64 = up.reflectance_basis().iter().map(|b| tv(b, grid.lambdas())).sum();
            assert!((tv32 - f0).abs() < 1e-5 * f0, "{name}: {tv32} vs {f0}");
            let feasible = |v: &[Vec<f64>; 3]| {
                for c in 0..3 {
                    for r in 0..3 {
                        let got: f64 = a[r].iter().zip(&v[c]).map(|(x, y)| x * y).sum();
                        let err = (got - if r == c { 1.0 } else { 0.0 }).abs();
                        assert!(err < 1e-9, "{name}: infeasible v ({err:e})");
                    }
                }
                for i in 0..n {
                    assert!(v.iter().all(|vc| vc[i] >= -1e-12));
                    assert!((v[0][i] + v[1][i] + v[2][i] - 1.0).abs() < 1e-9);
                }
            };
            let check = |v: &[Vec<f64>; 3], what: &str| {
                for s in [1e-4, 1e-3, 1e-2, 0.1, 0.5, 1.0] {
                    let m: [Vec<f64>; 3] =
                        std::array::from_fn(|c| (0..n).map(|i| w[c][i] + s * (v[c][i] - w[c][i])).collect());
                    let f = energy(&m, &h);
                    assert!(f >= f0 * (1.0 - 1e-9) - 1e-15, "{name}: {what}, s = {s}: {f} < {f0}");
                }
            };
            for t in 0..6 {
                let h2: Vec<f64> = h.iter().map(|&x| x * (0.2 + 2.0 * rnd())).collect();
                let v = solve_basis(&a, &h2).unwrap();
                feasible(&v);
                check(&v, &format!("reweighted solution {t}"));
            }
            // Random moves inside the face of the constraint set that w lies on: at each
            // sample only the non-zero entries move, along differences of unit vectors (so
            // the sum stays 1), projected so that A d_R = A d_G = 0 (then A d_B = 0 too).
            let mut dirs: Vec<(usize, [f64; 3])> = Vec::new();
            for i in 0..n {
                let f: Vec<usize> = (0..3).filter(|&c| w[c][i] > 1e-7).collect();
                for k in 1..f.len() {
                    let mut v = [0.0; 3];
                    v[f[0]] = 1.0;
                    v[f[k]] = -1.0;
                    dirs.push((i, v));
                }
            }
            let cons = |y: &[f64]| -> [f64; 6] {
                let mut r = [0.0; 6];
                for (&(i, v), &yk) in dirs.iter().zip(y) {
                    for c in 0..2 {
                        for row in 0..3 {
                            r[3 * c + row] += a[row][i] * v[c] * yk;
                        }
                    }
                }
                r
            };
            // Columns of the 6 × m constraint matrix, for the projection y − Cᵀ(CCᵀ)⁻¹Cy.
            let cols: Vec<[f64; 6]> = (0..dirs.len())
                .map(|k| {
                    let mut e = vec![0.0; dirs.len()];
                    e[k] = 1.0;
                    cons(&e)
                })
                .collect();
            let mut cct = [0.0; 36];
            for col in &cols {
                for r in 0..6 {
                    for q in 0..6 {
                        cct[r * 6 + q] += col[r] * col[q];
                    }
                }
            }
            let mut tried = 0;
            for t in 0..40 {
                let mut y: Vec<f64> = dirs.iter().map(|_| rnd() - 0.5).collect();
                for _ in 0..2 {
                    let mut lam = cons(&y);
                    let mut m = cct;
                    if !solve_dense(&mut m, 6, &mut lam) {
                        break;
                    }
                    for (yk, col) in y.iter_mut().zip(&cols) {
                        *yk -= (0..6).map(|r| col[r] * lam[r]).sum::<f64>();
                    }
                }
                let mut d: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n]);
                for (&(i, v), &yk) in dirs.iter().zip(&y) {
                    for c in 0..3 {
                        d[c][i] += v[c] * yk;
                    }
                }
                let dn = d.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                if dn < 1e-12 {
                    continue;
                }
                // Largest step that stays feasible, capped at 1e-2 in value.
                let mut step = 1e-2 / dn;
                for c in 0..3 {
                    for i in 0..n {
                        if d[c][i] < 0.0 {
                            step = step.min(w[c][i] / -d[c][i]);
                        }
                    }
                }
                let v: [Vec<f64>; 3] =
                    std::array::from_fn(|c| (0..n).map(|i| (w[c][i] + step * d[c][i]).max(0.0)).collect());
                feasible(&v);
                check(&v, &format!("move in the face {t}"));
                tried += 1;
            }
            println!("{name}: energy {f0:.6e}, {} face directions, {tried} moves tried", dirs.len());
            assert!(tried > 0 || dirs.len() <= 6, "{name}: no move tried");
        }
    }

    #[test]
    fn unbounded_and_clamping() {
        let grid = WavelengthGrid::default();
        for method in [UpliftMethod::Linear, UpliftMethod::Smooth] {
            let up = Uplift::new(&grid, &RgbSpace::rec709(), method).unwrap();
            // Unbounded: the linear map without clamping; flat grey stays flat.
            let ior = up.convert([1.5, 1.5, 1.5], SpectrumRole::Unbounded);
            assert!(ior.iter().all(|v| (v - 1.5).abs() < 1e-5), "{ior:?}");
            let neg = up.convert([-0.5, 0.2, 0.3], SpectrumRole::Unbounded);
            assert!(neg.iter().any(|&v| v < 0.0));
            // Reflectance clamps to [0,1].
            let r = up.convert([2.0, -1.0, 0.5], SpectrumRole::Reflectance);
            assert!(r.iter().all(|v| (0.0..=1.0).contains(v)));
            let e = up.convert([-1.0, 0.0, 0.0], SpectrumRole::Illuminant);
            assert!(e.iter().all(|&v| v == 0.0));
            assert_eq!(up.convert([0.0; 3], SpectrumRole::Reflectance), vec![0.0; grid.len()]);
            // A named RGB spectrum goes through evaluate() without complaint.
            let d = SpectrumDesc::new(SpectrumKind::Rgb { rgb: [0.8, 0.1, 0.05] });
            assert!(d.evaluate(&grid, SpectrumRole::Reflectance, &up).is_ok());
            assert!(d.evaluate(&grid, SpectrumRole::Illuminant, &up).is_ok());
        }
    }

    #[test]
    fn smooth_is_smooth_and_bounded() {
        let grid = WavelengthGrid::default();
        let up = Uplift::new(&grid, &RgbSpace::rec709(), UpliftMethod::Smooth).unwrap();
        let mut out = vec![0.0; grid.len()];
        // Grey is flat (a constant sigmoid) and a mid colour is a single smooth bump/step.
        up.reflectance_into([0.5, 0.5, 0.5], &mut out);
        assert!(out.iter().all(|v| (v - 0.5).abs() < 2e-3), "{out:?}");
        up.reflectance_into([0.2, 0.6, 0.3], &mut out);
        let peaks = (1..out.len() - 1).filter(|&i| out[i] > out[i - 1] && out[i] > out[i + 1]).count();
        assert!(peaks <= 1, "{out:?}");
        assert!(out.iter().all(|v| *v > 0.0 && *v < 1.0));
    }

    #[test]
    fn impossible_grids_are_reported() {
        // Four samples in the ultraviolet end cannot reproduce white.
        let g = WavelengthGrid::from_wavelengths(vec![360.0, 361.0, 362.0, 363.0]).unwrap();
        let e = Uplift::new(&g, &RgbSpace::rec709(), UpliftMethod::Linear).unwrap_err();
        assert!(e.to_string().contains("wavelength_count"), "{e}");
        // 8 samples over 380..780 nm: the bounded reversible problem is infeasible (also
        // confirmed by an independent LP solver, HiGHS): the cell-averaged fallback is used.
        let g = WavelengthGrid::uniform(8, 380.0, 780.0).unwrap();
        let up = Uplift::new(&g, &RgbSpace::rec709(), UpliftMethod::Smooth).unwrap();
        assert_eq!(up.fallback_samples(), Some(41));
        // From 12 samples up every uniform count over 380..780 nm works (checked up to 401).
        for n in (12..=41).chain([6, 10, 57, 81]) {
            let g = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
            if let Err(e) = Uplift::new(&g, &RgbSpace::rec709(), UpliftMethod::Linear) {
                panic!("{n} samples: {e}");
            }
        }
    }

    #[test]
    fn small_infeasible_grids_use_the_cell_averaged_fallback() {
        let space = RgbSpace::rec709();
        for n in 4..=11 {
            let g = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
            let up = Uplift::new(&g, &space, UpliftMethod::Linear).unwrap_or_else(|e| panic!("{n}: {e}"));
            let [r, gr, b] = up.reflectance_basis();
            for i in 0..n {
                // Bounded and a partition of unity: white is flat 1.
                assert!(r[i] >= 0.0 && gr[i] >= 0.0 && b[i] >= 0.0, "{n}: {i}");
                assert!((r[i] + gr[i] + b[i] - 1.0).abs() < 1e-6, "{n}: {i}");
            }
            let mut out = vec![0.0; n];
            up.reflectance_into([1.0, 1.0, 1.0], &mut out);
            assert!(out.iter().all(|v| (v - 1.0).abs() < 1e-6), "{n}: {out:?}");
            // Reversibility is approximate on the fallback grids, and reported.
            let err = up.round_trip_error();
            eprintln!("{n} samples: fallback {:?}, round-trip error {err:.4}", up.fallback_samples());
            // (4 and 5 samples are too coarse for any colour round trip: only finiteness there.)
            assert!(err.is_finite() && (n <= 5 || err < 0.3), "{n}: round trip {err}");
            if up.fallback_samples().is_none() {
                assert!(err < 1e-4, "{n}: exact basis with round-trip error {err}");
            }
            // Emission still round-trips exactly through the grid's observer.
            let obs = Observer::new(&g);
            for c in 0..3 {
                let mut rgb = [0.0f32; 3];
                rgb[c] = 2.0;
                up.illuminant_into(rgb, &mut out);
                assert!(out.iter().all(|v| *v >= 0.0 && v.is_finite()), "{n}: {out:?}");
                let got = space.xyz_to_rgb(obs.xyz(&out));
                for d in 0..3 {
                    let want = if c == d { 2.0 } else { 0.0 };
                    let tol = if n <= 5 {
                        f64::INFINITY
                    } else if up.fallback_samples().is_some() && !up.emission_exact {
                        0.4
                    } else {
                        1e-3
                    };
                    assert!((got[d] - want).abs() < tol, "{n}: unit {c} channel {d}: {got:?} (round trip {err})");
                }
            }
        }
    }

    #[test]
    fn method_names_in_scene_files() {
        assert_eq!(serde_json::to_string(&UpliftMethod::Smooth).unwrap(), "\"SMOOTH\"");
        assert_eq!(serde_json::from_str::<UpliftMethod>("\"LINEAR\"").unwrap(), UpliftMethod::Linear);
        assert_eq!(UpliftMethod::default(), UpliftMethod::Linear);
    }
}
