//! Random numbers and the sampling routines shared by integrators, materials and lights.

use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// PCG32 (O'Neill 2014): small, fast, and seekable by stream, so every pixel sample
/// gets its own deterministic sequence whatever thread renders it.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: decorrelates nearby seeds.
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

impl Rng {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Self { state: 0, inc: (stream << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(mix64(seed));
        r.next_u32();
        r
    }
    /// The stream of pixel (x, y), sample `s` of a render with `seed`.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        Self::new(mix64(seed ^ mix64(sample.wrapping_add(0x9e3779b97f4a7c15))), pixel)
    }
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
    pub fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }
}

/// Laine–Karras style hash permutation (Burley 2020, "Practical Hash-based Owen
/// Scrambling", JCGT 9(4), listing 2): bit j of the result depends on bits ≤ j of `x`
/// only, so applied to reversed bits it permutes aligned power-of-two blocks.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Burley's nested uniform scramble of an index: indices `0..2^m` map to a permutation of
/// an aligned block of `2^m` indices.
#[inline]
fn shuffle_index(i: u32, seed: u32) -> u32 {
    laine_karras(i.reverse_bits(), seed).reverse_bits()
}

/// Stratification of one uniform number per dimension across a set of samples (a pixel's
/// samples, or a pass's light paths): sample `index` of the set `key` draws the
/// `index`-th point of the base-2 van der Corput sequence (a (0,1) sequence: every
/// prefix of 2^m samples has one point in each interval of width 2^-m), the index
/// shuffled per dimension (Burley 2020) so dimensions do not correlate, plus a
/// Cranley–Patterson rotation per set and dimension (Cranley & Patterson 1976). Each
/// draw is uniform on [0, 1) on its own, so estimators stay unbiased.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strata {
    pub key: u64,
    pub index: u32,
}

impl Strata {
    pub fn new(key: u64, index: u32) -> Self {
        Self { key, index }
    }
    /// The stratified uniform in [0, 1) of dimension `dim`.
    pub fn uniform(&self, dim: u32) -> f32 {
        let h = mix64(self.key ^ mix64(dim as u64 ^ 0x5851_f42d_4c95_7f2d));
        let i = shuffle_index(self.index, h as u32);
        let v = i.reverse_bits() as f64 / 4_294_967_296.0;
        let r = (h >> 32) as f64 / 4_294_967_296.0;
        let x = (v + r).fract() as f32;
        x.min(1.0 - f32::EPSILON / 2.0)
    }
}

/// Cosine-weighted direction about +z (Malley's method); pdf = cos θ / π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3A {
    let d = concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3A::new(d.x, d.y, z)
}

/// Shirley–Chiu concentric map from the unit square to the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, PI / 4.0 * (o.y / o.x)) } else { (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y)) };
    Vec2::new(r * theta.cos(), r * theta.sin())
}

pub fn uniform_sphere(u: Vec2) -> Vec3A {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3A::new(r * phi.cos(), r * phi.sin(), z)
}

/// A uniform point of triangle `p`: its barycentrics (b1, b2) and position.
pub fn uniform_triangle_point(p: &[Vec3A; 3], u: Vec2) -> (f32, f32, Vec3A) {
    let (b1, b2) = uniform_triangle(u);
    (b1, b2, p[0] * (1.0 - b1 - b2) + p[1] * b1 + p[2] * b2)
}

/// Uniform point on a triangle as barycentrics (b1, b2) (Heitz 2019, low distortion).
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    (b1, 1.0 - b0 - b1)
}

/// Veach's power heuristic (β = 2) for multiple importance sampling.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a == 0.0 {
        return 0.0;
    }
    if a.is_infinite() {
        return 1.0;
    }
    a / (a + b)
}

/// A discrete distribution over items with given non-negative weights.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    cdf: Vec<f64>,
    pmf: Vec<f32>,
    total: f64,
}

impl Distribution1D {
    pub fn new(weights: &[f64]) -> Self {
        let total: f64 = weights.iter().map(|w| w.max(0.0)).sum();
        let mut cdf = Vec::with_capacity(weights.len());
        let mut acc = 0.0;
        for w in weights {
            acc += w.max(0.0);
            cdf.push(if total > 0.0 { acc / total } else { 0.0 });
        }
        let pmf = weights.iter().map(|w| if total > 0.0 { (w.max(0.0) / total) as f32 } else { 0.0 }).collect();
        Self { cdf, pmf, total }
    }
    pub fn total(&self) -> f64 {
        self.total
    }
    pub fn is_empty(&self) -> bool {
        self.total <= 0.0
    }
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }
    /// An index with probability proportional to its weight, or None if all are zero.
    pub fn sample(&self, u: f32) -> Option<usize> {
        if self.total <= 0.0 {
            return None;
        }
        let i = self.cdf.partition_point(|&c| c <= u as f64).min(self.cdf.len() - 1);
        // Skip zero-weight entries that share the cdf value.
        let i = (i..self.pmf.len()).find(|&k| self.pmf[k] > 0.0).unwrap_or(i);
        Some(i)
    }
    /// As [`Distribution1D::sample`], and `u` rescaled to [0, 1) within the chosen
    /// item's interval of the cdf (one uniform number serves both choices).
    pub fn sample_remapped(&self, u: f32) -> Option<(usize, f32)> {
        let i = self.sample(u)?;
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let width = self.cdf[i] - lo;
        let r = if width > 0.0 { ((u as f64 - lo) / width) as f32 } else { 0.5 };
        Some((i, r.clamp(0.0, 1.0 - f32::EPSILON / 2.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = {
            let mut r = Rng::for_sample(7, 3, 0);
            (0..4).map(|_| r.next_u32()).collect()
        };
        let b: Vec<u32> = {
            let mut r = Rng::for_sample(7, 3, 0);
            (0..4).map(|_| r.next_u32()).collect()
        };
        let c: Vec<u32> = {
            let mut r = Rng::for_sample(7, 4, 0);
            (0..4).map(|_| r.next_u32()).collect()
        };
        let d: Vec<u32> = {
            let mut r = Rng::for_sample(7, 3, 1);
            (0..4).map(|_| r.next_u32()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
        let mut r = Rng::new(1, 1);
        let mean: f32 = (0..100_000).map(|_| r.uniform()).sum::<f32>() / 100_000.0;
        assert!((mean - 0.5).abs() < 0.005);
    }

    #[test]
    fn distribution_follows_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.sample(0.1), Some(0));
        assert_eq!(d.sample(0.25), Some(2));
        assert_eq!(d.sample(0.9999), Some(2));
        assert_eq!(d.pmf(2), 0.75);
        assert!(Distribution1D::new(&[0.0, 0.0]).sample(0.5).is_none());
    }

    /// Every prefix of 2^m samples of a set has one point in each interval of width
    /// 2^-m (rotated), per dimension; dimensions and sets differ; the mean is 1/2.
    #[test]
    fn strata_stratify_every_power_of_two_prefix() {
        for key in [0u64, 7, 123_456_789] {
            for dim in 0..6 {
                let u: Vec<f32> = (0..64).map(|i| Strata::new(key, i).uniform(dim)).collect();
                assert!(u.iter().all(|&x| (0.0..1.0).contains(&x)));
                for m in 0..=6u32 {
                    let n = 1usize << m;
                    // Undo the rotation: the first point's offset within its stratum.
                    let off = (u[0] as f64 * n as f64).fract();
                    let mut seen = vec![false; n];
                    for &x in &u[..n] {
                        let s = ((x as f64 * n as f64 - off + 1e-4).floor() as i64).rem_euclid(n as i64) as usize;
                        assert!(!seen[s], "key {key} dim {dim} prefix {n}: stratum {s} twice");
                        seen[s] = true;
                    }
                }
            }
        }
        let a: Vec<f32> = (0..8).map(|i| Strata::new(1, i).uniform(0)).collect();
        let b: Vec<f32> = (0..8).map(|i| Strata::new(1, i).uniform(1)).collect();
        let c: Vec<f32> = (0..8).map(|i| Strata::new(2, i).uniform(0)).collect();
        assert!(a != b && a != c);
        let n = 4096;
        let mean: f64 = (0..n).map(|k| Strata::new(k as u64, 3).uniform(2) as f64).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
    }

    #[test]
    fn cosine_hemisphere_is_normalised() {
        let mut r = Rng::new(3, 9);
        // E[cos θ] under pdf cos θ/π is 2/3.
        let n = 200_000;
        let m: f32 = (0..n).map(|_| cosine_hemisphere(r.uniform2()).z).sum::<f32>() / n as f32;
        assert!((m - 2.0 / 3.0).abs() < 0.003, "{m}");
    }
}
