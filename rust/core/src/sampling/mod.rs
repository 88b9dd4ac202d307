//! Random numbers and the sampling routines shared by integrators, materials and lights.

use glam::{Vec2, Vec3A};
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;

/// Which numbers a pixel sample's [`Rng`] hands out (the `sampler` setting).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Sampler {
    /// Owen-scrambled Sobol points stratified across a pixel's samples ([`Sobol`]).
    #[default]
    Sobol,
    /// Independent PCG32 numbers for every draw.
    Independent,
}

/// The random numbers of one path: PCG32 (O'Neill 2014) — small, fast, and seekable by
/// stream, so every pixel sample gets its own deterministic sequence whatever thread
/// renders it — or, for a pixel sample of the SOBOL sampler, stratified points
/// ([`Sobol`]) with the same calls, so integrators do not know which they draw from.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
    sobol: Option<Sobol>,
}

const PCG_MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: decorrelates nearby seeds.
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^ (z >> 31)
}

/// Salt of a pixel's Sobol scrambling key, apart from the PCG streams of the same seed.
const SOBOL_SALT: u64 = 0x736f_626f_6c5f_6275;

impl Rng {
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Self { state: 0, inc: (stream << 1) | 1, sobol: None };
        r.next_pcg();
        r.state = r.state.wrapping_add(mix64(seed));
        r.next_pcg();
        r
    }
    /// The numbers of pixel (x, y), sample `s` of a render with `seed`: stratified
    /// across the pixel's samples (the SOBOL sampler).
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        Self::for_sampler(Sampler::Sobol, seed, pixel, sample)
    }
    /// As [`Rng::for_sample`] with the given sampler; INDEPENDENT: a PCG stream per
    /// pixel sample.
    pub fn for_sampler(sampler: Sampler, seed: u64, pixel: u64, sample: u64) -> Self {
        if sampler == Sampler::Sobol {
            // The key has no sample in it: a pixel's samples are points of one sequence.
            // Every draw comes from the Sobol points: the PCG state is never read.
            let key = mix64(seed ^ mix64(pixel ^ SOBOL_SALT));
            return Self { state: 0, inc: 1, sobol: Some(Sobol::new(key, sample as u32)) };
        }
        Self::new(mix64(seed ^ mix64(sample.wrapping_add(0x9e3779b97f4a7c15))), pixel)
    }
    /// A path reached a new vertex: its draws start a fresh block of dimensions, so
    /// the draws of vertex k line up across a pixel's samples however many numbers
    /// earlier vertices took (as Cycles' per-bounce dimensions). No-op for PCG.
    pub fn start_vertex(&mut self) {
        if let Some(s) = &mut self.sobol {
            s.block += 1;
            s.call = 0;
        }
    }
    fn next_pcg(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }
    pub fn next_u32(&mut self) -> u32 {
        match &mut self.sobol {
            Some(s) => s.next_1d(),
            None => self.next_pcg(),
        }
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f32 {
        to_unit(self.next_u32())
    }
    pub fn uniform2(&mut self) -> Vec2 {
        match &mut self.sobol {
            Some(s) => {
                let [x, y] = s.next_2d();
                Vec2::new(to_unit(x), to_unit(y))
            }
            None => Vec2::new(self.uniform(), self.uniform()),
        }
    }
}

/// 32 random bits to [0, 1) (24 bits: every value exactly representable, never 1).
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Stratified numbers of one pixel sample: sample `index` of a pixel draws, at the
/// `call`-th draw of its vertex `block`, the `index`-th point of the first one or two
/// dimensions of the Sobol sequence (Sobol 1967; dimension 0 is van der Corput, 1 is
/// the Pascal matrix), index-shuffled and Owen-scrambled with seeds hashed from the
/// pixel, block and call — Burley 2020, "Practical Hash-based Owen Scrambling", JCGT
/// 9(4), sec. 3–4 ("padding" by shuffling), as Cycles' kernel/sample/sobol_burley.h.
/// Every 2^m samples of a pixel put one point of each draw in each interval of width
/// 2^-m, and each 2D draw is a (0,m,2)-net; draws of different calls are decorrelated
/// by their seeds. Each point of a nested uniform scramble is uniform on [0,1)^d on
/// its own, and different seeds are independent, so every estimator stays unbiased
/// whichever draw a call lands on. The hash seeds have no dimension limit and the
/// 32-bit matrices cover 2^32 samples (the sample index is a u32), so nothing falls
/// back to independent numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sobol {
    pub key: u64,
    pub index: u32,
    /// The path's vertex (0: the camera's draws: pixel jitter, lens, time).
    pub block: u32,
    /// Draws so far at this vertex.
    pub call: u32,
    /// `index` with its bits reversed, as every draw's index shuffle starts.
    index_reversed: u32,
}

impl Sobol {
    pub fn new(key: u64, index: u32) -> Self {
        Self { key, index, block: 0, call: 0, index_reversed: index.reverse_bits() }
    }
    fn seeds(&mut self) -> u64 {
        let h = mix64(self.key ^ mix64(((self.block as u64) << 32) | self.call as u64));
        self.call += 1;
        h
    }
    /// One stratified draw (32 bits of a uniform in [0, 1)).
    pub fn next_1d(&mut self) -> u32 {
        let h = self.seeds();
        let i = owen_reversed(self.index_reversed, h as u32);
        owen(i.reverse_bits(), (h >> 32) as u32)
    }
    /// One stratified 2D draw: Sobol dimensions 0 and 1 of the shuffled index.
    pub fn next_2d(&mut self) -> [u32; 2] {
        let h = self.seeds();
        let i = owen_reversed(self.index_reversed, h as u32);
        let h2 = mix64(h);
        [owen(i.reverse_bits(), (h >> 32) as u32), owen(sobol_dim1(i), h2 as u32)]
    }
}

/// Dimension 1 of Sobol's sequence: the XOR of the direction numbers of `i`'s set bits,
/// from primitive polynomial x + 1 (m_1 = 1, m_k = 2m_{k-1} ⊕ m_{k-1}; Joe & Kuo 2008's
/// first entry), as 32-bit binary fractions. Direction number k is the polynomial
/// (1 + x)^k over GF(2) (bit j: C(k, j) mod 2) shifted to the top, so with the bits
/// reversed the result is the Taylor shift p(x) ↦ p(x + 1) of `i`'s bits as a
/// polynomial: the Pascal matrix mod 2, the Kronecker power of [[1, 1], [0, 1]], one
/// masked xor-shift per factor (they commute) instead of a loop over `i`'s 32 bits
/// ([`SOBOL_DIM1`] is the table it equals; a test checks both). Inlined, its final
/// bit reversal cancels the first one of the Owen scramble that follows it.
#[inline]
pub fn sobol_dim1(i: u32) -> u32 {
    let mut y = i;
    y ^= (y >> 1) & 0x5555_5555;
    y ^= (y >> 2) & 0x3333_3333;
    y ^= (y >> 4) & 0x0f0f_0f0f;
    y ^= (y >> 8) & 0x00ff_00ff;
    y ^= (y >> 16) & 0x0000_ffff;
    y.reverse_bits()
}

/// The direction numbers of [`sobol_dim1`] as 32-bit binary fractions (the definition
/// the closed form is tested against).
#[cfg(test)]
const SOBOL_DIM1: [u32; 32] = {
    let mut v = [0u32; 32];
    let mut m: u64 = 1;
    let mut k = 0;
    while k < 32 {
        // v_k = m_k / 2^(k+1); m_k < 2^(k+1).
        v[k] = (m << (31 - k)) as u32;
        m ^= m << 1;
        k += 1;
    }
    v
};

/// Burley's nested uniform (Owen) scramble of a 32-bit binary fraction, with the
/// improved Laine–Karras hash (Burley 2020 sec. 4, as Cycles' `reversed_bit_owen`):
/// each output bit depends on that bit and the more significant ones, so aligned
/// power-of-two blocks of fractions (or of indices, when applied to an index) map to
/// blocks — stratification survives, and each point is uniform.
#[inline]
fn owen(x: u32, seed: u32) -> u32 {
    owen_reversed(x.reverse_bits(), seed)
}

/// [`owen`] of the 32-bit fraction whose bits reversed are `n`.
#[inline]
fn owen_reversed(mut n: u32, seed: u32) -> u32 {
    n ^= n.wrapping_mul(0x3d20_adea);
    n = n.wrapping_add(seed);
    n = n.wrapping_mul((seed >> 16) | 1);
    n ^= n.wrapping_mul(0x0552_6c56);
    n ^= n.wrapping_mul(0x53a2_2864);
    n.reverse_bits()
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

    /// The 2^m samples of a pixel, for the draws of a few blocks and calls: in [0, 1),
    /// one point per interval of width 2^-m in each dimension, and 2D draws a
    /// (0,m,2)-net (one point in each of the 2^m elementary boxes of every shape
    /// 2^-a × 2^-(m-a)).
    #[test]
    fn sobol_draws_are_stratified_and_2d_draws_are_nets() {
        fn strata(xs: &[f64]) -> bool {
            let n = xs.len();
            let mut seen = vec![false; n];
            xs.iter().all(|&x| (0.0..1.0).contains(&x) && !std::mem::replace(&mut seen[(x * n as f64) as usize], true))
        }
        for (seed, pixel) in [(0u64, 0u64), (7, 1234), (99, 5)] {
            for m in 0..=10u32 {
                let n = 1u32 << m;
                let draws: Vec<Vec<(f32, f32, f32)>> = (0..n)
                    .map(|i| {
                        let mut r = Rng::for_sample(seed, pixel, i as u64);
                        let mut out = Vec::new();
                        for _ in 0..3 {
                            let a = r.uniform();
                            let b = r.uniform2();
                            out.push((a, b.x, b.y));
                            r.start_vertex();
                        }
                        out
                    })
                    .collect();
                for d in 0..3 {
                    let col =
                        |f: fn(&(f32, f32, f32)) -> f32| draws.iter().map(|v| f(&v[d]) as f64).collect::<Vec<_>>();
                    let (a, x, y) = (col(|t| t.0), col(|t| t.1), col(|t| t.2));
                    assert!(strata(&a) && strata(&x) && strata(&y), "seed {seed} m {m} block {d}");
                    for ax in 0..=m {
                        let (nx, ny) = (1u64 << ax, 1u64 << (m - ax));
                        let mut seen = vec![false; n as usize];
                        for (&px, &py) in x.iter().zip(&y) {
                            let b = ((px * nx as f64) as u64 * ny + (py * ny as f64) as u64) as usize;
                            assert!(!seen[b], "seed {seed} m {m} block {d}: box {nx}x{ny} twice");
                            seen[b] = true;
                        }
                    }
                }
            }
        }
        // Draws differ between calls, blocks and pixels; INDEPENDENT is the old PCG stream.
        let first = |seed, pixel| {
            let mut r = Rng::for_sample(seed, pixel, 3);
            let a = [r.uniform(), r.uniform()];
            r.start_vertex();
            [a[0], a[1], r.uniform()]
        };
        let a = first(1, 2);
        assert!(a[0] != a[1] && a[1] != a[2] && a != first(1, 3) && a != first(2, 2));
        let mut p = Rng::for_sampler(Sampler::Independent, 1, 2, 3);
        let mut q = Rng::new(mix64(1 ^ mix64(3u64.wrapping_add(0x9e3779b97f4a7c15))), 2);
        assert_eq!(p.uniform2(), q.uniform2());
        // Over many pixels a draw is uniform: mean 1/2, variance 1/12.
        let n = 20_000;
        let v: Vec<f64> = (0..n).map(|k| Rng::for_sample(5, k, 6).uniform2().y as f64).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.01 && (var - 1.0 / 12.0).abs() < 0.003, "{mean} {var}");
    }

    /// Dimension 1's first points are those of Sobol's second dimension (Joe & Kuo).
    #[test]
    fn sobol_dimension_one_matches_the_sequence() {
        let x: Vec<f64> = (0..8).map(|i| sobol_dim1(i) as f64 / 4_294_967_296.0).collect();
        assert_eq!(x, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
        // The closed form is the XOR of the direction numbers of the index's set bits.
        let by_table = |mut i: u32| {
            let (mut x, mut k) = (0, 0);
            while i != 0 {
                if i & 1 != 0 {
                    x ^= SOBOL_DIM1[k];
                }
                i >>= 1;
                k += 1;
            }
            x
        };
        let mut r = Rng::new(11, 3);
        for i in (0..4096).chain((0..100_000).map(|_| r.next_u32())).chain([u32::MAX, 1 << 31]) {
            assert_eq!(sobol_dim1(i), by_table(i), "{i}");
        }
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
