//! The float helpers of Cycles' kernel (Cycles `util/math_base.h`, `math_float{2,3,4}.h`)
//! with the rounding of its x86-64 SSE4.2 build, so the textures agree with Cycles to
//! the last bit where the compiler leaves Cycles' operation order alone.
//!
//! Cycles' vector types are SSE registers, and a few of their operations round
//! differently from the obvious scalar code: `dot` of a float4 sums pairs
//! (`_mm_dp_ps`), `float3 / float` divides each lane while `float2 / float` and
//! `float4 / float` multiply by the reciprocal, and `fmod` of a float3/float4 is
//! `a - trunc(a / b) * b` (not C's exact `fmodf`). [`Point`] reproduces each of them.

use glam::{Vec2, Vec3, Vec4};

/// Cycles `float_to_int` (`(int)f`) as x86-64 executes it: truncation, and the
/// "integer indefinite" `i32::MIN` for NaN and out-of-range values (`cvttss2si`),
/// where Rust's `as` would saturate.
#[inline]
pub fn float_to_int(f: f32) -> i32 {
    if (-2147483648.0..2147483648.0).contains(&f) {
        f as i32
    } else {
        i32::MIN
    }
}

/// Cycles `floor_to_int`.
#[inline]
pub fn floor_to_int(f: f32) -> i32 {
    float_to_int(f.floor())
}

/// Cycles `floorfrac`: the integer cell (as [`float_to_int`]) and the fraction `x - floor(x)`.
#[inline]
pub fn floorfrac(x: f32) -> (f32, i32) {
    let f = x.floor();
    (x - f, float_to_int(f))
}

/// Cycles `mix`/`interp`: `a + t * (b - a)`.
#[inline]
pub fn mix(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// Cycles `min(float, float)`: `a < b ? a : b` (NaN in `a` gives `b`).
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// Cycles `max(float, float)`: `a > b ? a : b`.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// Cycles `clamp`: `min(max(a, lo), hi)`, so NaN clamps to `lo`.
#[inline]
pub fn clamp(a: f32, lo: f32, hi: f32) -> f32 {
    min(max(a, lo), hi)
}

/// Cycles `saturatef` on the CPU: `clamp(a, 0, 1)` (NaN gives 0).
#[inline]
pub fn saturate(a: f32) -> f32 {
    clamp(a, 0.0, 1.0)
}

/// Cycles `smoothstep(0, 1, x)`: `(3 - 2t) t²`, with `t = x` once the constant edges fold.
#[inline]
pub fn smoothstep01(x: f32) -> f32 {
    if x < 0.0 {
        0.0
    } else if x >= 1.0 {
        1.0
    } else {
        (3.0 - 2.0 * x) * (x * x)
    }
}

/// Cycles `smoothstepf`: `3f² - 2f³` on `[0, 1]`.
#[inline]
pub fn smoothstepf(f: f32) -> f32 {
    if f <= 0.0 {
        0.0
    } else if f >= 1.0 {
        1.0
    } else {
        let ff = f * f;
        3.0 * ff - 2.0 * ff * f
    }
}

/// Cycles' SSE4.2 `fmod(float3/float4, float)`: `a - trunc(a / b) * b`.
#[inline]
pub fn fmod_sse(a: f32, b: f32) -> f32 {
    a - (a / b).trunc() * b
}

/// A value that cannot reach a pass: non-finite becomes 0 (see docs/procedural.md).
#[inline]
pub fn finite_or_zero(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// [`finite_or_zero`] per component.
#[inline]
pub fn finite_or_zero3(v: Vec3) -> Vec3 {
    Vec3::new(finite_or_zero(v.x), finite_or_zero(v.y), finite_or_zero(v.z))
}

/// Cycles' 2-, 3- and 4-component float vectors, with Cycles' rounding where it differs
/// from component-wise arithmetic (which glam's `+ - *` reproduce exactly).
pub trait Point:
    Copy + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> + std::ops::Mul<f32, Output = Self>
{
    fn splat(v: f32) -> Self;
    /// `make_floatN(i, j, k, u)` of a cell offset.
    fn offset(i: i32, j: i32, k: i32, u: i32) -> Self;
    /// Calls `f` for each cell offset in `[-r, r]^N`, in Cycles' loop order (the first
    /// component varies fastest), which decides ties between equidistant points.
    fn for_each_offset(r: i32, f: impl FnMut(Self));
    fn floor(self) -> Self;
    fn abs(self) -> Self;
    fn powf(self, e: f32) -> Self;
    /// Component-wise product.
    fn mul_elem(self, o: Self) -> Self;
    /// Cycles `dot`.
    fn cycles_dot(self, o: Self) -> f32;
    /// Cycles `reduce_add`.
    fn reduce_add(self) -> f32;
    /// Cycles `reduce_max`.
    fn reduce_max(self) -> f32;
    /// Cycles `floatN / float`.
    fn cycles_div(self, f: f32) -> Self;
    /// Cycles `len`.
    fn cycles_len(self) -> f32 {
        self.cycles_dot(self).sqrt()
    }
    /// Cycles `normalize`.
    fn cycles_normalize(self) -> Self;
    /// Cycles `mix(floatN, floatN, float)`: `a + t * (b - a)`.
    fn mix(self, b: Self, t: f32) -> Self {
        self + (b - self) * t
    }
    /// Cycles `fmod(floatN, float)`.
    fn fmod(self, b: f32) -> Self;
    /// Cycles `mask(fabs(p) >= t, one) * 0.5`: 0.5 where |component| >= t, else 0.
    fn half_where_abs_ge(self, t: f32) -> Self;
    /// Cycles `hash_floatN_to_floatN`.
    fn hash_to_point(self) -> Self;
    /// Cycles `hash_floatN_to_float3`.
    fn hash_to_color(self) -> Vec3;
    /// Cycles `voronoi_position`: the point as a float4, zero-padded.
    fn to_vec4(self) -> Vec4;
}

impl Point for Vec2 {
    fn splat(v: f32) -> Self {
        Vec2::splat(v)
    }
    fn offset(i: i32, j: i32, _: i32, _: i32) -> Self {
        Vec2::new(i as f32, j as f32)
    }
    fn for_each_offset(r: i32, mut f: impl FnMut(Self)) {
        for j in -r..=r {
            for i in -r..=r {
                f(Self::offset(i, j, 0, 0));
            }
        }
    }
    fn floor(self) -> Self {
        Vec2::new(self.x.floor(), self.y.floor())
    }
    fn abs(self) -> Self {
        Vec2::new(self.x.abs(), self.y.abs())
    }
    fn powf(self, e: f32) -> Self {
        Vec2::new(self.x.powf(e), self.y.powf(e))
    }
    fn mul_elem(self, o: Self) -> Self {
        Vec2::new(self.x * o.x, self.y * o.y)
    }
    fn cycles_dot(self, o: Self) -> f32 {
        self.x * o.x + self.y * o.y
    }
    fn reduce_add(self) -> f32 {
        self.x + self.y
    }
    fn reduce_max(self) -> f32 {
        max(self.x, self.y)
    }
    fn cycles_div(self, f: f32) -> Self {
        let inv = 1.0 / f;
        Vec2::new(self.x * inv, self.y * inv)
    }
    fn cycles_normalize(self) -> Self {
        self.cycles_div(self.cycles_len())
    }
    fn fmod(self, b: f32) -> Self {
        // float2 has no SSE path: C's exact fmodf per component.
        Vec2::new(self.x % b, self.y % b)
    }
    fn half_where_abs_ge(self, t: f32) -> Self {
        Vec2::new(half_if(self.x.abs() >= t), half_if(self.y.abs() >= t))
    }
    fn hash_to_point(self) -> Self {
        Vec2::from(super::hash::hash_float2_to_float2(self.x, self.y))
    }
    fn hash_to_color(self) -> Vec3 {
        Vec3::from(super::hash::hash_float2_to_float3(self.x, self.y))
    }
    fn to_vec4(self) -> Vec4 {
        Vec4::new(self.x, self.y, 0.0, 0.0)
    }
}

impl Point for Vec3 {
    fn splat(v: f32) -> Self {
        Vec3::splat(v)
    }
    fn offset(i: i32, j: i32, k: i32, _: i32) -> Self {
        Vec3::new(i as f32, j as f32, k as f32)
    }
    fn for_each_offset(r: i32, mut f: impl FnMut(Self)) {
        for k in -r..=r {
            for j in -r..=r {
                for i in -r..=r {
                    f(Self::offset(i, j, k, 0));
                }
            }
        }
    }
    fn floor(self) -> Self {
        Vec3::new(self.x.floor(), self.y.floor(), self.z.floor())
    }
    fn abs(self) -> Self {
        Vec3::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    fn powf(self, e: f32) -> Self {
        Vec3::new(self.x.powf(e), self.y.powf(e), self.z.powf(e))
    }
    fn mul_elem(self, o: Self) -> Self {
        Vec3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    fn cycles_dot(self, o: Self) -> f32 {
        // _mm_dp_ps(a, b, 0x7F): (x + y) + (z + 0).
        (self.x * o.x + self.y * o.y) + self.z * o.z
    }
    fn reduce_add(self) -> f32 {
        self.x + self.y + self.z
    }
    fn reduce_max(self) -> f32 {
        max(max(self.x, self.y), self.z)
    }
    fn cycles_div(self, f: f32) -> Self {
        // float3 / float is _mm_div_ps: a true division per lane.
        Vec3::new(self.x / f, self.y / f, self.z / f)
    }
    fn cycles_normalize(self) -> Self {
        self.cycles_div(self.cycles_len())
    }
    fn fmod(self, b: f32) -> Self {
        Vec3::new(fmod_sse(self.x, b), fmod_sse(self.y, b), fmod_sse(self.z, b))
    }
    fn half_where_abs_ge(self, t: f32) -> Self {
        Vec3::new(half_if(self.x.abs() >= t), half_if(self.y.abs() >= t), half_if(self.z.abs() >= t))
    }
    fn hash_to_point(self) -> Self {
        Vec3::from(super::hash::hash_float3_to_float3(self.x, self.y, self.z))
    }
    fn hash_to_color(self) -> Vec3 {
        self.hash_to_point()
    }
    fn to_vec4(self) -> Vec4 {
        self.extend(0.0)
    }
}

impl Point for Vec4 {
    fn splat(v: f32) -> Self {
        Vec4::splat(v)
    }
    fn offset(i: i32, j: i32, k: i32, u: i32) -> Self {
        Vec4::new(i as f32, j as f32, k as f32, u as f32)
    }
    fn for_each_offset(r: i32, mut f: impl FnMut(Self)) {
        for u in -r..=r {
            for k in -r..=r {
                for j in -r..=r {
                    for i in -r..=r {
                        f(Self::offset(i, j, k, u));
                    }
                }
            }
        }
    }
    fn floor(self) -> Self {
        Vec4::new(self.x.floor(), self.y.floor(), self.z.floor(), self.w.floor())
    }
    fn abs(self) -> Self {
        Vec4::new(self.x.abs(), self.y.abs(), self.z.abs(), self.w.abs())
    }
    fn powf(self, e: f32) -> Self {
        Vec4::new(self.x.powf(e), self.y.powf(e), self.z.powf(e), self.w.powf(e))
    }
    fn mul_elem(self, o: Self) -> Self {
        Vec4::new(self.x * o.x, self.y * o.y, self.z * o.z, self.w * o.w)
    }
    fn cycles_dot(self, o: Self) -> f32 {
        // _mm_dp_ps(a, b, 0xFF): (x + y) + (z + w).
        (self.x * o.x + self.y * o.y) + (self.z * o.z + self.w * o.w)
    }
    fn reduce_add(self) -> f32 {
        // Two _mm_hadd_ps: (x + y) + (z + w).
        (self.x + self.y) + (self.z + self.w)
    }
    fn reduce_max(self) -> f32 {
        max(max(self.x, self.y), max(self.z, self.w))
    }
    fn cycles_div(self, f: f32) -> Self {
        // float4 / float is a * (1 / f).
        let inv = 1.0 / f;
        Vec4::new(self.x * inv, self.y * inv, self.z * inv, self.w * inv)
    }
    fn cycles_normalize(self) -> Self {
        self.cycles_div(self.cycles_len())
    }
    fn fmod(self, b: f32) -> Self {
        Vec4::new(fmod_sse(self.x, b), fmod_sse(self.y, b), fmod_sse(self.z, b), fmod_sse(self.w, b))
    }
    fn half_where_abs_ge(self, t: f32) -> Self {
        Vec4::new(
            half_if(self.x.abs() >= t),
            half_if(self.y.abs() >= t),
            half_if(self.z.abs() >= t),
            half_if(self.w.abs() >= t),
        )
    }
    fn hash_to_point(self) -> Self {
        Vec4::from(super::hash::hash_float4_to_float4(self.x, self.y, self.z, self.w))
    }
    fn hash_to_color(self) -> Vec3 {
        Vec3::from(super::hash::hash_float4_to_float3(self.x, self.y, self.z, self.w))
    }
    fn to_vec4(self) -> Vec4 {
        self
    }
}

#[inline]
fn half_if(c: bool) -> f32 {
    if c {
        0.5
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_to_int_follows_x86_for_nan_and_out_of_range() {
        assert_eq!(float_to_int(-1.5), -1);
        assert_eq!(float_to_int(2147483520.0), 2147483520);
        assert_eq!(float_to_int(2147483648.0), i32::MIN);
        assert_eq!(float_to_int(-3e9), i32::MIN);
        assert_eq!(float_to_int(f32::NAN), i32::MIN);
        assert_eq!(floorfrac(-0.25), (0.75, -1));
    }

    #[test]
    fn sse_fmod_matches_fmodf_where_exact_and_stays_finite() {
        for a in [-123456.75f32, -0.5, 0.0, 99999.0, 100000.0, 250000.5, 9.9e5] {
            assert_eq!(fmod_sse(a, 100000.0), a % 100000.0, "{a}");
        }
        assert!(fmod_sse(1e30, 100000.0).is_finite());
    }

    #[test]
    fn clamp_and_saturate_send_nan_to_the_lower_bound() {
        assert_eq!(saturate(f32::NAN), 0.0);
        assert_eq!(saturate(2.0), 1.0);
        assert_eq!(clamp(f32::NAN, 0.0, 15.0), 0.0);
    }
}
