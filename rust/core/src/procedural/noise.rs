//! Perlin noise and its fractal sums, as Cycles computes them
//! (Cycles `kernel/svm/noise.h`, `kernel/svm/fractal_noise.h`, adapted there from OSL).
//!
//! The 2D–4D Perlin functions follow Cycles' SSE implementation, which is the one its
//! x86-64 CPU kernels run: the corner gradients are interpolated along x first, then
//! y, z and w, each step as `a + t (b - a)`, and the fade curve is evaluated as
//! `(t t)(t (t (6 t - 15) + 10))`. Cycles' AVX2 kernel (chosen on CPUs with AVX2) fuses
//! some of these multiply-adds and interpolates 4D noise along w first, so it differs
//! from the SSE4.2 kernel, and from these functions, by float rounding only.

use super::hash::{hash_float2_to_float, hash_uint, hash_uint2, hash_uint3, hash_uint4};
use super::math::{float_to_int, floorfrac, mix, saturate, Point};
use glam::{Vec2, Vec3, Vec4};

/// Cycles' scalar `fade` (used by 1D noise): `6t⁵ - 15t⁴ + 10t³`.
#[inline]
fn fade1(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Cycles' SSE `fade(float4)`, which rounds differently from [`fade1`].
#[inline]
fn fade(t: f32) -> f32 {
    let a = t * 6.0 + -15.0;
    let b = t * a + 10.0;
    (t * t) * (t * b)
}

#[inline]
fn negate_if(v: f32, cond: u32) -> f32 {
    if cond != 0 {
        -v
    } else {
        v
    }
}

/// Cycles `grad1`: slopes ±1..±8.
#[inline]
fn grad1(hash: u32, x: f32) -> f32 {
    let h = hash & 15;
    let g = (1 + (h & 7)) as f32;
    negate_if(g, h & 8) * x
}

/// Cycles `grad2`/SSE `grad(hash, x, y)`.
#[inline]
fn grad2(hash: u32, x: f32, y: f32) -> f32 {
    let h = hash & 7;
    let u = if h < 4 { x } else { y };
    let v = 2.0 * if h < 4 { y } else { x };
    negate_if(u, h & 1) + negate_if(v, h & 2)
}

/// Cycles `grad3`: the 12 edge directions of a cube (16 with repeats).
#[inline]
fn grad3(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let vt = if h == 12 || h == 14 { x } else { z };
    let v = if h < 4 { y } else { vt };
    negate_if(u, h & 1) + negate_if(v, h & 2)
}

/// Cycles `grad4`.
#[inline]
fn grad4(hash: u32, x: f32, y: f32, z: f32, w: f32) -> f32 {
    let h = hash & 31;
    let u = if h < 24 { x } else { y };
    let v = if h < 16 { y } else { z };
    let s = if h < 8 { z } else { w };
    negate_if(u, h & 1) + negate_if(v, h & 2) + negate_if(s, h & 4)
}

/// Cycles `perlin_1d`.
pub fn perlin_1d(x: f32) -> f32 {
    let (fx, xi) = floorfrac(x);
    let u = fade1(fx);
    let xi = xi as u32;
    mix(grad1(hash_uint(xi), fx), grad1(hash_uint(xi.wrapping_add(1)), fx - 1.0), u)
}

/// Cycles `perlin_2d` (SSE).
pub fn perlin_2d(x: f32, y: f32) -> f32 {
    let (fx, xi) = floorfrac(x);
    let (fy, yi) = floorfrac(y);
    let (u, v) = (fade(fx), fade(fy));
    let (x0, y0) = (xi as u32, yi as u32);
    let (x1, y1) = (x0.wrapping_add(1), y0.wrapping_add(1));
    let g00 = grad2(hash_uint2(x0, y0), fx, fy);
    let g01 = grad2(hash_uint2(x0, y1), fx, fy - 1.0);
    let g10 = grad2(hash_uint2(x1, y0), fx - 1.0, fy);
    let g11 = grad2(hash_uint2(x1, y1), fx - 1.0, fy - 1.0);
    mix(mix(g00, g10, u), mix(g01, g11, u), v)
}

/// The 8 corner gradients of the cube at (x0, y0, z0) for 3D and 4D noise, already
/// interpolated along x, y and z as Cycles' SSE `tri_mix` does.
#[inline]
fn tri(c: [u32; 3], f: [f32; 3], fade: [f32; 3], grad: impl Fn([u32; 3], [f32; 3]) -> f32) -> f32 {
    let [x0, y0, z0] = c;
    let [fx, fy, fz] = f;
    let (x1, y1, z1) = (x0.wrapping_add(1), y0.wrapping_add(1), z0.wrapping_add(1));
    let (gx, gy, gz) = (fx - 1.0, fy - 1.0, fz - 1.0);
    // Lanes (y, z) = (0,0), (0,1), (1,0), (1,1), first at x0 then at x0 + 1.
    let s00 = mix(grad([x0, y0, z0], [fx, fy, fz]), grad([x1, y0, z0], [gx, fy, fz]), fade[0]);
    let s01 = mix(grad([x0, y0, z1], [fx, fy, gz]), grad([x1, y0, z1], [gx, fy, gz]), fade[0]);
    let s10 = mix(grad([x0, y1, z0], [fx, gy, fz]), grad([x1, y1, z0], [gx, gy, fz]), fade[0]);
    let s11 = mix(grad([x0, y1, z1], [fx, gy, gz]), grad([x1, y1, z1], [gx, gy, gz]), fade[0]);
    mix(mix(s00, s10, fade[1]), mix(s01, s11, fade[1]), fade[2])
}

/// Cycles `perlin_3d` (SSE).
pub fn perlin_3d(x: f32, y: f32, z: f32) -> f32 {
    let (fx, xi) = floorfrac(x);
    let (fy, yi) = floorfrac(y);
    let (fz, zi) = floorfrac(z);
    let fades = [fade(fx), fade(fy), fade(fz)];
    tri([xi as u32, yi as u32, zi as u32], [fx, fy, fz], fades, |c, f| {
        grad3(hash_uint3(c[0], c[1], c[2]), f[0], f[1], f[2])
    })
}

/// Cycles `perlin_4d` (SSE): two trilinear cubes, then w.
pub fn perlin_4d(x: f32, y: f32, z: f32, w: f32) -> f32 {
    let (fx, xi) = floorfrac(x);
    let (fy, yi) = floorfrac(y);
    let (fz, zi) = floorfrac(z);
    let (fw, wi) = floorfrac(w);
    let fades = [fade(fx), fade(fy), fade(fz)];
    let (w0, w1) = (wi as u32, (wi as u32).wrapping_add(1));
    let c = [xi as u32, yi as u32, zi as u32];
    let f = [fx, fy, fz];
    let at_w0 = tri(c, f, fades, |c, f| grad4(hash_uint4(c[0], c[1], c[2], w0), f[0], f[1], f[2], fw));
    let at_w1 = tri(c, f, fades, |c, f| grad4(hash_uint4(c[0], c[1], c[2], w1), f[0], f[1], f[2], fw - 1.0));
    mix(at_w0, at_w1, fade(fw))
}

/// Perlin noise's period in every axis: Cycles wraps coordinates with `fmod(p, 100000)`
/// against float precision loss, and shifts by half a cell beyond 1e6 (`snoise_*d`).
const PERIOD: f32 = 100000.0;
const PRECISION_LIMIT: f32 = 1000000.0;

/// Signed noise in about `[-1, 1]`: Cycles `snoise_1d`.
pub fn snoise_1d(p: f32) -> f32 {
    let correction = 0.5 * if p.abs() >= PRECISION_LIMIT { 1.0 } else { 0.0 };
    0.2500 * perlin_1d(p % PERIOD + correction)
}

/// Cycles `snoise_2d`.
pub fn snoise_2d(p: Vec2) -> f32 {
    let p = p.fmod(PERIOD) + p.half_where_abs_ge(PRECISION_LIMIT);
    0.6616 * perlin_2d(p.x, p.y)
}

/// Cycles `snoise_3d`.
pub fn snoise_3d(p: Vec3) -> f32 {
    let p = p.fmod(PERIOD) + p.half_where_abs_ge(PRECISION_LIMIT);
    0.9820 * perlin_3d(p.x, p.y, p.z)
}

/// Cycles `snoise_4d`.
pub fn snoise_4d(p: Vec4) -> f32 {
    let p = p.fmod(PERIOD) + p.half_where_abs_ge(PRECISION_LIMIT);
    0.8344 * perlin_4d(p.x, p.y, p.z, p.w)
}

/// Unsigned noise in about `[0, 1]`: Cycles `noise_1d` … `noise_4d`.
pub fn noise_1d(p: f32) -> f32 {
    0.5 * snoise_1d(p) + 0.5
}
pub fn noise_2d(p: Vec2) -> f32 {
    0.5 * snoise_2d(p) + 0.5
}
pub fn noise_3d(p: Vec3) -> f32 {
    0.5 * snoise_3d(p) + 0.5
}
pub fn noise_4d(p: Vec4) -> f32 {
    0.5 * snoise_4d(p) + 0.5
}

/// A coordinate Perlin noise can be evaluated at: f32 (1D), Vec2, Vec3, Vec4.
pub trait NoisePoint: Copy + std::ops::Add<Output = Self> + std::ops::Mul<f32, Output = Self> {
    /// Signed noise (`snoise_Nd`).
    fn snoise(self) -> f32;
    /// Cycles `random_floatN_offset(seed)`: a per-seed shift in `[100, 200]^N` that
    /// decorrelates the noise used for distortion and for the colour channels.
    fn random_offset(seed: f32) -> Self;
}

/// Cycles `random_float_offset` / `random_floatN_offset` component `i`.
#[inline]
fn offset_component(seed: f32, i: f32) -> f32 {
    100.0 + hash_float2_to_float(seed, i) * 100.0
}

impl NoisePoint for f32 {
    fn snoise(self) -> f32 {
        snoise_1d(self)
    }
    fn random_offset(seed: f32) -> Self {
        100.0 + super::hash::hash_float_to_float(seed) * 100.0
    }
}
impl NoisePoint for Vec2 {
    fn snoise(self) -> f32 {
        snoise_2d(self)
    }
    fn random_offset(seed: f32) -> Self {
        Vec2::new(offset_component(seed, 0.0), offset_component(seed, 1.0))
    }
}
impl NoisePoint for Vec3 {
    fn snoise(self) -> f32 {
        snoise_3d(self)
    }
    fn random_offset(seed: f32) -> Self {
        Vec3::new(offset_component(seed, 0.0), offset_component(seed, 1.0), offset_component(seed, 2.0))
    }
}
impl NoisePoint for Vec4 {
    fn snoise(self) -> f32 {
        snoise_4d(self)
    }
    fn random_offset(seed: f32) -> Self {
        Vec4::new(
            offset_component(seed, 0.0),
            offset_component(seed, 1.0),
            offset_component(seed, 2.0),
            offset_component(seed, 3.0),
        )
    }
}

/// Octave count of a fractal: Cycles loops `for (i = 0; i <= float_to_int(detail); i++)`.
#[inline]
fn octaves(detail: f32) -> i32 {
    float_to_int(detail)
}

/// Fractal Brownian motion: Cycles `noise_fbm`. A fractional `detail` blends in the next
/// octave; `normalize` maps the sum to about `[0, 1]`.
pub fn fbm<P: NoisePoint>(p: P, detail: f32, roughness: f32, lacunarity: f32, normalize: bool) -> f32 {
    let mut fscale = 1.0f32;
    let mut amp = 1.0f32;
    let mut maxamp = 0.0f32;
    let mut sum = 0.0f32;
    for _ in 0..=octaves(detail) {
        let t = (p * fscale).snoise();
        sum += t * amp;
        maxamp += amp;
        amp *= roughness;
        fscale *= lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        let t = (p * fscale).snoise();
        let sum2 = sum + t * amp;
        return if normalize {
            mix(0.5 * sum / maxamp + 0.5, 0.5 * sum2 / (maxamp + amp) + 0.5, rmd)
        } else {
            mix(sum, sum2, rmd)
        };
    }
    if normalize {
        0.5 * sum / maxamp + 0.5
    } else {
        sum
    }
}

/// Cycles `noise_multi_fractal`.
pub fn multi_fractal<P: NoisePoint>(mut p: P, detail: f32, roughness: f32, lacunarity: f32) -> f32 {
    let mut value = 1.0f32;
    let mut pwr = 1.0f32;
    for _ in 0..=octaves(detail) {
        value *= pwr * p.snoise() + 1.0;
        pwr *= roughness;
        p = p * lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        value *= rmd * pwr * p.snoise() + 1.0;
    }
    value
}

/// Cycles `noise_hetero_terrain`.
pub fn hetero_terrain<P: NoisePoint>(mut p: P, detail: f32, roughness: f32, lacunarity: f32, offset: f32) -> f32 {
    let mut pwr = roughness;
    // The first octave is unscaled; later ones are scaled by the value so far.
    let mut value = offset + p.snoise();
    p = p * lacunarity;
    for _ in 1..=octaves(detail) {
        let increment = (p.snoise() + offset) * pwr * value;
        value += increment;
        pwr *= roughness;
        p = p * lacunarity;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 {
        let increment = (p.snoise() + offset) * pwr * value;
        value += rmd * increment;
    }
    value
}

/// Cycles `noise_hybrid_multi_fractal`.
pub fn hybrid_multi_fractal<P: NoisePoint>(
    mut p: P,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    offset: f32,
    gain: f32,
) -> f32 {
    let mut pwr = 1.0f32;
    let mut value = 0.0f32;
    let mut weight = 1.0f32;
    let n = octaves(detail);
    let mut i = 0;
    while weight > 0.001 && i <= n {
        weight = weight.min(1.0);
        let signal = (p.snoise() + offset) * pwr;
        pwr *= roughness;
        value += weight * signal;
        weight *= gain * signal;
        p = p * lacunarity;
        i += 1;
    }
    let rmd = detail - detail.floor();
    if rmd != 0.0 && weight > 0.001 {
        weight = weight.min(1.0);
        let signal = (p.snoise() + offset) * pwr;
        value += rmd * weight * signal;
    }
    value
}

/// Cycles `noise_ridged_multi_fractal` (no fractional octave, as in Cycles).
pub fn ridged_multi_fractal<P: NoisePoint>(
    mut p: P,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    offset: f32,
    gain: f32,
) -> f32 {
    let mut pwr = roughness;
    let mut signal = offset - p.snoise().abs();
    signal *= signal;
    let mut value = signal;
    for _ in 1..=octaves(detail) {
        p = p * lacunarity;
        let weight = saturate(signal * gain);
        signal = offset - p.snoise().abs();
        signal *= signal;
        signal *= weight;
        value += signal * pwr;
        pwr *= roughness;
    }
    value
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perlin_is_zero_on_the_lattice_and_continuous_across_cells() {
        for c in [-3.0f32, 0.0, 1.0, 7.0] {
            assert_eq!(perlin_1d(c), 0.0);
            assert_eq!(perlin_2d(c, 2.0), 0.0);
            assert_eq!(perlin_3d(c, -1.0, 5.0), 0.0);
            assert_eq!(perlin_4d(c, 4.0, -2.0, 1.0), 0.0);
        }
        let e = 1e-3;
        for x in [-2.0f32, 1.0, 3.0] {
            assert!((perlin_3d(x - e, 0.3, 0.7) - perlin_3d(x + e, 0.3, 0.7)).abs() < 0.05);
            assert!((perlin_4d(0.2, x - e, 0.7, 0.1) - perlin_4d(0.2, x + e, 0.7, 0.1)).abs() < 0.05);
        }
    }

    #[test]
    fn fade_curves_agree_up_to_rounding() {
        for i in 0..=64 {
            let t = i as f32 / 64.0;
            assert!((fade(t) - fade1(t)).abs() <= 2.0 * f32::EPSILON);
        }
    }

    #[test]
    fn fbm_stays_finite_for_huge_finite_inputs() {
        // Coordinates that stay finite through 16 octaves give finite noise; beyond that
        // (p * lacunarity^k overflows) or for NaN/inf, Cycles gives NaN too, and the
        // texture nodes turn it into 0.
        for v in [1e30f32, -1e30, 1e12, -3.0e7, 3.4e38] {
            let detail = if v.abs() > 1e33 { 0.0 } else { 15.0 };
            for f in [
                fbm(Vec3::new(v, 0.5, 0.25), detail, 1.0, 2.0, true),
                fbm(Vec4::new(0.5, v, 0.25, v), detail, 1.0, 2.0, false),
                fbm(Vec2::new(v, v), detail, 1.0, 2.0, true),
                fbm(v, detail, 1.0, 2.0, true),
            ] {
                assert!(f.is_finite(), "{v}: {f}");
            }
        }
    }
}
