//! A spectrum sampled on the render's wavelength grid.
//!
//! Values live in one contiguous buffer padded with zeros to a multiple of
//! [`LANES`], so every arithmetic loop runs over whole fixed-size chunks and the
//! compiler emits SIMD code without a scalar tail. Padding stays zero because the
//! only operations offered are ones that map zero to zero.

pub const LANES: usize = 8;

#[derive(Clone, Debug, PartialEq)]
pub struct SampledSpectrum {
    data: Vec<f32>,
    len: usize,
}

/// A chunk of [`LANES`] values as an array (the chunks of `chunks_exact(LANES)`).
#[inline(always)]
fn chunk(c: &[f32]) -> [f32; LANES] {
    let mut v = [0.0; LANES];
    v.copy_from_slice(c);
    v
}

#[inline]
fn padded(len: usize) -> usize {
    len.div_ceil(LANES) * LANES
}

impl SampledSpectrum {
    pub fn zeros(len: usize) -> Self {
        Self { data: vec![0.0; padded(len)], len }
    }
    pub fn splat(len: usize, v: f32) -> Self {
        let mut s = Self::zeros(len);
        s.data[..len].fill(v);
        s
    }
    pub fn from_slice(values: &[f32]) -> Self {
        let mut s = Self::zeros(values.len());
        s.data[..values.len()].copy_from_slice(values);
        s
    }
    pub fn len(&self) -> usize {
        self.len
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    pub fn values(&self) -> &[f32] {
        &self.data[..self.len]
    }
    pub fn values_mut(&mut self) -> &mut [f32] {
        &mut self.data[..self.len]
    }
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        self.data[i]
    }
    #[inline]
    pub fn set(&mut self, i: usize, v: f32) {
        debug_assert!(i < self.len);
        self.data[i] = v;
    }
    pub fn fill(&mut self, v: f32) {
        self.data[..self.len].fill(v);
    }
    pub fn copy_from(&mut self, other: &Self) {
        debug_assert_eq!(self.len, other.len);
        self.data.copy_from_slice(&other.data);
    }

    /// `f` on every pair of values. Each chunk is read whole into locals before it is
    /// written: the compiler cannot tell that `self` and `other`'s buffers do not
    /// overlap, and element by element in place it kept every load after the last store
    /// (scalar code, three instructions per wavelength).
    #[inline]
    fn zip_chunks(&mut self, other: &Self, f: impl Fn(&mut f32, f32)) {
        debug_assert_eq!(self.len, other.len);
        for (a, b) in self.data.chunks_exact_mut(LANES).zip(other.data.chunks_exact(LANES)) {
            let b: [f32; LANES] = chunk(b);
            let mut v: [f32; LANES] = chunk(a);
            for k in 0..LANES {
                f(&mut v[k], b[k]);
            }
            a.copy_from_slice(&v);
        }
    }

    /// self *= other, per wavelength.
    #[inline]
    pub fn mul_assign(&mut self, other: &Self) {
        self.zip_chunks(other, |a, b| *a *= b);
    }
    /// self += other, per wavelength.
    #[inline]
    pub fn add_assign(&mut self, other: &Self) {
        self.zip_chunks(other, |a, b| *a += b);
    }
    /// self += other · s.
    #[inline]
    pub fn add_scaled(&mut self, other: &Self, s: f32) {
        self.zip_chunks(other, |a, b| *a += b * s);
    }
    /// self += a · b · s, per wavelength (radiance += throughput · emission · weight).
    #[inline]
    pub fn add_product(&mut self, a: &Self, b: &Self, s: f32) {
        debug_assert_eq!(self.len, a.len);
        debug_assert_eq!(self.len, b.len);
        for ((o, x), y) in
            self.data.chunks_exact_mut(LANES).zip(a.data.chunks_exact(LANES)).zip(b.data.chunks_exact(LANES))
        {
            // Whole chunks into locals first, as in `zip_chunks`.
            let (x, y): ([f32; LANES], [f32; LANES]) = (chunk(x), chunk(y));
            let mut v: [f32; LANES] = chunk(o);
            for k in 0..LANES {
                v[k] += x[k] * y[k] * s;
            }
            o.copy_from_slice(&v);
        }
    }
    #[inline]
    pub fn scale(&mut self, s: f32) {
        for c in self.data.chunks_exact_mut(LANES) {
            for v in c.iter_mut() {
                *v *= s;
            }
        }
    }
    /// Largest value (over the real samples).
    pub fn max_value(&self) -> f32 {
        self.values().iter().copied().fold(0.0f32, f32::max)
    }
    pub fn sum(&self) -> f32 {
        self.data.iter().sum()
    }
    /// Σ self[i] · w[i]: an integral with the grid's quadrature weights.
    #[inline]
    pub fn dot(&self, w: &[f32]) -> f32 {
        self.values().iter().zip(w).map(|(a, b)| a * b).sum()
    }
    pub fn is_black(&self) -> bool {
        self.data.iter().all(|&v| v == 0.0)
    }
    /// No sample is NaN or infinite. Branch-free over whole chunks (v − v is 0 for a
    /// finite v and NaN otherwise), so it vectorises: it runs per sample and per bounce.
    #[inline]
    #[allow(clippy::eq_op)] // v - v is the point: 0 exactly when v is finite
    pub fn is_finite(&self) -> bool {
        let mut acc = [0.0f32; LANES];
        for c in self.data.chunks_exact(LANES) {
            for k in 0..LANES {
                acc[k] += c[k] - c[k];
            }
        }
        acc.iter().all(|&a| a == 0.0)
    }
    /// The values with the zero padding up to whole [`LANES`] chunks.
    #[inline]
    pub fn padded_values(&self) -> &[f32] {
        &self.data
    }
    /// Keep only sample `i` (a ray collapsed to one wavelength).
    pub fn keep_only(&mut self, i: usize) {
        let v = self.data[i];
        self.data.fill(0.0);
        self.data[i] = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_matches_scalar_loops_and_padding_stays_zero() {
        let a = SampledSpectrum::from_slice(&(0..13).map(|i| i as f32).collect::<Vec<_>>());
        let b = SampledSpectrum::splat(13, 2.0);
        let mut c = a.clone();
        c.mul_assign(&b);
        c.add_scaled(&a, 0.5);
        for i in 0..13 {
            assert_eq!(c.get(i), i as f32 * 2.5);
        }
        assert_eq!(c.data.len(), 16);
        assert!(c.data[13..].iter().all(|&v| v == 0.0));
        assert_eq!(c.max_value(), 30.0);
        let mut d = SampledSpectrum::zeros(13);
        d.add_product(&a, &b, 3.0);
        assert_eq!(d.get(4), 24.0);
        assert_eq!(a.dot(&[1.0; 13]), 78.0);
        d.keep_only(4);
        assert_eq!(d.sum(), 24.0);
    }
}
