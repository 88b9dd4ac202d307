//! Small dense and banded linear algebra for the colour solvers (the linear uplift's QP,
//! the smooth uplift's Newton steps): a banded Cholesky factorisation, LU with partial
//! pivoting, a 3×3 Cramer solve and the projection onto the probability simplex. Kept
//! here, not behind a linear-algebra crate, because the systems are tiny (3×3, 6×6) or
//! banded with half-bandwidth 1..3 and the solvers run per grid, not per sample.

// Index loops mirror the maths (several arrays indexed together); `!(a > b)` is used on
// purpose so that NaN counts as failure.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

/// Symmetric positive definite band matrix (half-bandwidth `p`), lower part stored;
/// factorised in place by Cholesky.
#[derive(Clone)]
pub(crate) struct Band {
    n: usize,
    p: usize,
    a: Vec<f64>,
}

impl Band {
    pub(crate) fn new(n: usize, p: usize) -> Self {
        Self { n, p, a: vec![0.0; n * (p + 1)] }
    }
    #[inline]
    pub(crate) fn idx(&self, i: usize, j: usize) -> usize {
        debug_assert!(j <= i && i - j <= self.p);
        i * (self.p + 1) + (j + self.p - i)
    }
    pub(crate) fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        let k = self.idx(i, j);
        self.a[k] += v;
    }
    pub(crate) fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        if i - j > self.p {
            0.0
        } else {
            self.a[self.idx(i, j)]
        }
    }
    /// y = self · x (before factorisation).
    pub(crate) fn mul(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.n {
            let mut s = 0.0;
            for j in i.saturating_sub(self.p)..(i + self.p + 1).min(self.n) {
                s += self.get(i, j) * x[j];
            }
            y[i] = s;
        }
    }
    pub(crate) fn cholesky(&mut self) -> bool {
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
    pub(crate) fn solve(&self, b: &mut [f64]) {
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
pub(crate) fn solve_dense(mat: &mut [f64], m: usize, b: &mut [f64]) -> bool {
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
pub(crate) fn project_simplex(v: [f64; 3]) -> [f64; 3] {
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

/// Solve the 3×3 system j·d = r by Cramer's rule in f64; None if (nearly) singular.
#[inline]
pub(crate) fn solve3(j: [[f32; 3]; 3], r: [f32; 3]) -> Option<[f32; 3]> {
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
