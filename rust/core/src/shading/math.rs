//! Math, Vector Math, Clamp and Map Range, as Cycles computes them
//! (Cycles `kernel/svm/math_util.h`, `kernel/svm/map_range.h`, `util/math_base.h`).

use super::props::Props;
use crate::Result;
use glam::Vec3;

/// Blender's Math node operations (`ShaderNodeMath.operation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MathOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Power,
    Logarithm,
    Sqrt,
    InverseSqrt,
    Absolute,
    Exponent,
    Minimum,
    Maximum,
    LessThan,
    GreaterThan,
    Sign,
    Compare,
    SmoothMin,
    SmoothMax,
    Round,
    Floor,
    Ceil,
    Trunc,
    Fract,
    Modulo,
    FlooredModulo,
    Wrap,
    Snap,
    Pingpong,
    Sine,
    Cosine,
    Tangent,
    Arcsine,
    Arccosine,
    Arctangent,
    Arctan2,
    Sinh,
    Cosh,
    Tanh,
    Radians,
    Degrees,
}

const MATH_OPS: &[(&str, MathOp)] = &[
    ("ADD", MathOp::Add),
    ("SUBTRACT", MathOp::Subtract),
    ("MULTIPLY", MathOp::Multiply),
    ("DIVIDE", MathOp::Divide),
    ("MULTIPLY_ADD", MathOp::MultiplyAdd),
    ("POWER", MathOp::Power),
    ("LOGARITHM", MathOp::Logarithm),
    ("SQRT", MathOp::Sqrt),
    ("INVERSE_SQRT", MathOp::InverseSqrt),
    ("ABSOLUTE", MathOp::Absolute),
    ("EXPONENT", MathOp::Exponent),
    ("MINIMUM", MathOp::Minimum),
    ("MAXIMUM", MathOp::Maximum),
    ("LESS_THAN", MathOp::LessThan),
    ("GREATER_THAN", MathOp::GreaterThan),
    ("SIGN", MathOp::Sign),
    ("COMPARE", MathOp::Compare),
    ("SMOOTH_MIN", MathOp::SmoothMin),
    ("SMOOTH_MAX", MathOp::SmoothMax),
    ("ROUND", MathOp::Round),
    ("FLOOR", MathOp::Floor),
    ("CEIL", MathOp::Ceil),
    ("TRUNC", MathOp::Trunc),
    ("FRACT", MathOp::Fract),
    ("MODULO", MathOp::Modulo),
    ("FLOORED_MODULO", MathOp::FlooredModulo),
    ("WRAP", MathOp::Wrap),
    ("SNAP", MathOp::Snap),
    ("PINGPONG", MathOp::Pingpong),
    ("SINE", MathOp::Sine),
    ("COSINE", MathOp::Cosine),
    ("TANGENT", MathOp::Tangent),
    ("ARCSINE", MathOp::Arcsine),
    ("ARCCOSINE", MathOp::Arccosine),
    ("ARCTANGENT", MathOp::Arctangent),
    ("ARCTAN2", MathOp::Arctan2),
    ("SINH", MathOp::Sinh),
    ("COSH", MathOp::Cosh),
    ("TANH", MathOp::Tanh),
    ("RADIANS", MathOp::Radians),
    ("DEGREES", MathOp::Degrees),
];

/// Cycles `safe_divide`: 0 where b is 0.
#[inline]
pub fn safe_divide(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        a / b
    } else {
        0.0
    }
}

/// Cycles `safe_powf`: 0 for a negative base with a non-integer exponent.
#[inline]
pub fn safe_powf(a: f32, b: f32) -> f32 {
    if a < 0.0 && b != (b as i32) as f32 {
        return 0.0;
    }
    a.powf(b)
}

/// Cycles `safe_logf`: log of `a` in base `b`, 0 outside the domain.
#[inline]
fn safe_logf(a: f32, b: f32) -> f32 {
    if a <= 0.0 || b <= 0.0 {
        return 0.0;
    }
    safe_divide(a.ln(), b.ln())
}

/// Cycles `wrapf(value, max, min)`.
#[inline]
pub fn wrapf(value: f32, max: f32, min: f32) -> f32 {
    let range = max - min;
    if range != 0.0 {
        value - range * ((value - min) / range).floor()
    } else {
        min
    }
}

#[inline]
fn fractf(a: f32) -> f32 {
    a - a.floor()
}

/// Cycles `pingpongf`.
#[inline]
fn pingpongf(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        (fractf((a - b) / (b * 2.0)) * b * 2.0 - b).abs()
    } else {
        0.0
    }
}

/// Cycles `smoothminf` (polynomial smooth minimum of distance k).
#[inline]
fn smoothminf(a: f32, b: f32, k: f32) -> f32 {
    if k != 0.0 {
        let h = (k - (a - b).abs()).max(0.0) / k;
        a.min(b) - h * h * h * k * (1.0 / 6.0)
    } else {
        a.min(b)
    }
}

/// Cycles `compatible_signf`.
#[inline]
fn signf(a: f32) -> f32 {
    if a == 0.0 {
        0.0
    } else if a < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Cycles `safe_modulo` (fmodf, 0 where b is 0).
#[inline]
fn safe_modulo(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        a % b
    } else {
        0.0
    }
}

/// Cycles `svm_math`.
pub fn math(op: MathOp, a: f32, b: f32, c: f32) -> f32 {
    use MathOp::*;
    match op {
        Add => a + b,
        Subtract => a - b,
        Multiply => a * b,
        Divide => safe_divide(a, b),
        MultiplyAdd => a * b + c,
        Power => safe_powf(a, b),
        Logarithm => safe_logf(a, b),
        Sqrt => a.max(0.0).sqrt(),
        InverseSqrt => {
            if a > 0.0 {
                1.0 / a.sqrt()
            } else {
                0.0
            }
        }
        Absolute => a.abs(),
        Exponent => a.exp(),
        Minimum => a.min(b),
        Maximum => a.max(b),
        LessThan => (a < b) as u8 as f32,
        GreaterThan => (a > b) as u8 as f32,
        Sign => signf(a),
        Compare => ((a == b) || (a - b).abs() <= c.max(f32::EPSILON)) as u8 as f32,
        SmoothMin => smoothminf(a, b, c),
        SmoothMax => -smoothminf(-a, -b, c),
        Round => (a + 0.5).floor(),
        Floor => a.floor(),
        Ceil => a.ceil(),
        Trunc => a.trunc(),
        Fract => fractf(a),
        Modulo => safe_modulo(a, b),
        FlooredModulo => {
            if b != 0.0 {
                a - (a / b).floor() * b
            } else {
                0.0
            }
        }
        Wrap => wrapf(a, b, c),
        Snap => safe_divide(a, b).floor() * b,
        Pingpong => pingpongf(a, b),
        Sine => a.sin(),
        Cosine => a.cos(),
        Tangent => a.tan(),
        Arcsine => a.clamp(-1.0, 1.0).asin(),
        Arccosine => a.clamp(-1.0, 1.0).acos(),
        Arctangent => a.atan(),
        Arctan2 => a.atan2(b),
        Sinh => a.sinh(),
        Cosh => a.cosh(),
        Tanh => a.tanh(),
        Radians => a * (std::f32::consts::PI / 180.0),
        Degrees => a * (180.0 / std::f32::consts::PI),
    }
}

/// The Math node: inputs Value, Value_001, Value_002; output Value.
#[derive(Clone, Copy, Debug)]
pub struct Math {
    pub op: MathOp,
    pub clamp: bool,
}

impl Math {
    pub fn parse(p: &Props) -> Result<Self> {
        Ok(Self { op: p.enumeration("operation", MATH_OPS, MathOp::Add)?, clamp: p.boolean("use_clamp", false)? })
    }
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let r = math(self.op, i[0].x, i[1].x, i[2].x);
        o[0].x = if self.clamp { r.clamp(0.0, 1.0) } else { r };
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VectorOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    CrossProduct,
    Project,
    Reflect,
    Refract,
    Faceforward,
    DotProduct,
    Distance,
    Length,
    Scale,
    Normalize,
    Absolute,
    Power,
    Sign,
    Minimum,
    Maximum,
    Floor,
    Ceil,
    Fraction,
    Modulo,
    Wrap,
    Snap,
    Sine,
    Cosine,
    Tangent,
}

const VECTOR_OPS: &[(&str, VectorOp)] = &[
    ("ADD", VectorOp::Add),
    ("SUBTRACT", VectorOp::Subtract),
    ("MULTIPLY", VectorOp::Multiply),
    ("DIVIDE", VectorOp::Divide),
    ("MULTIPLY_ADD", VectorOp::MultiplyAdd),
    ("CROSS_PRODUCT", VectorOp::CrossProduct),
    ("PROJECT", VectorOp::Project),
    ("REFLECT", VectorOp::Reflect),
    ("REFRACT", VectorOp::Refract),
    ("FACEFORWARD", VectorOp::Faceforward),
    ("DOT_PRODUCT", VectorOp::DotProduct),
    ("DISTANCE", VectorOp::Distance),
    ("LENGTH", VectorOp::Length),
    ("SCALE", VectorOp::Scale),
    ("NORMALIZE", VectorOp::Normalize),
    ("ABSOLUTE", VectorOp::Absolute),
    ("POWER", VectorOp::Power),
    ("SIGN", VectorOp::Sign),
    ("MINIMUM", VectorOp::Minimum),
    ("MAXIMUM", VectorOp::Maximum),
    ("FLOOR", VectorOp::Floor),
    ("CEIL", VectorOp::Ceil),
    ("FRACTION", VectorOp::Fraction),
    ("MODULO", VectorOp::Modulo),
    ("WRAP", VectorOp::Wrap),
    ("SNAP", VectorOp::Snap),
    ("SINE", VectorOp::Sine),
    ("COSINE", VectorOp::Cosine),
    ("TANGENT", VectorOp::Tangent),
];

/// Cycles `safe_normalize`: zero stays zero.
#[inline]
pub fn safe_normalize(v: Vec3) -> Vec3 {
    let l = v.length();
    if l != 0.0 {
        v / l
    } else {
        Vec3::ZERO
    }
}

fn map3(a: Vec3, f: impl Fn(f32) -> f32) -> Vec3 {
    Vec3::new(f(a.x), f(a.y), f(a.z))
}

fn zip3(a: Vec3, b: Vec3, f: impl Fn(f32, f32) -> f32) -> Vec3 {
    Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z))
}

/// Cycles `refract(I, N, eta)`.
fn refract(i: Vec3, n: Vec3, eta: f32) -> Vec3 {
    let d = n.dot(i);
    let k = 1.0 - eta * eta * (1.0 - d * d);
    if k < 0.0 {
        Vec3::ZERO
    } else {
        eta * i - (eta * d + k.sqrt()) * n
    }
}

/// Cycles `svm_vector_math`: (vector, value) results.
pub fn vector_math(op: VectorOp, a: Vec3, b: Vec3, c: Vec3, scale: f32) -> (Vec3, f32) {
    use VectorOp::*;
    match op {
        Add => (a + b, 0.0),
        Subtract => (a - b, 0.0),
        Multiply => (a * b, 0.0),
        Divide => (zip3(a, b, safe_divide), 0.0),
        MultiplyAdd => (a * b + c, 0.0),
        CrossProduct => (a.cross(b), 0.0),
        Project => {
            let len_sq = b.dot(b);
            (if len_sq != 0.0 { (a.dot(b) / len_sq) * b } else { Vec3::ZERO }, 0.0)
        }
        Reflect => {
            let n = safe_normalize(b);
            (a - 2.0 * n.dot(a) * n, 0.0)
        }
        Refract => (refract(a, safe_normalize(b), scale), 0.0),
        Faceforward => (if c.dot(b) < 0.0 { a } else { -a }, 0.0),
        DotProduct => (Vec3::ZERO, a.dot(b)),
        Distance => (Vec3::ZERO, a.distance(b)),
        Length => (Vec3::ZERO, a.length()),
        Scale => (a * scale, 0.0),
        Normalize => (safe_normalize(a), 0.0),
        Absolute => (a.abs(), 0.0),
        Power => (zip3(a, b, safe_powf), 0.0),
        Sign => (map3(a, signf), 0.0),
        Minimum => (a.min(b), 0.0),
        Maximum => (a.max(b), 0.0),
        Floor => (a.floor(), 0.0),
        Ceil => (a.ceil(), 0.0),
        Fraction => (map3(a, fractf), 0.0),
        Modulo => (zip3(a, b, safe_modulo), 0.0),
        Wrap => (Vec3::new(wrapf(a.x, b.x, c.x), wrapf(a.y, b.y, c.y), wrapf(a.z, b.z, c.z)), 0.0),
        Snap => (zip3(a, b, |a, b| safe_divide(a, b).floor() * b), 0.0),
        Sine => (map3(a, f32::sin), 0.0),
        Cosine => (map3(a, f32::cos), 0.0),
        Tangent => (map3(a, f32::tan), 0.0),
    }
}

/// The Vector Math node: inputs Vector, Vector_001, Vector_002, Scale; outputs Vector, Value.
#[derive(Clone, Copy, Debug)]
pub struct VectorMath {
    pub op: VectorOp,
}

impl VectorMath {
    pub fn parse(p: &Props) -> Result<Self> {
        Ok(Self { op: p.enumeration("operation", VECTOR_OPS, VectorOp::Add)? })
    }
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let (v, f) = vector_math(self.op, i[0], i[1], i[2], i[3].x);
        o[0] = v;
        o[1] = Vec3::new(f, 0.0, 0.0);
    }
}

/// The Clamp node (Cycles `svm_node_clamp`): inputs Value, Min, Max; output Result.
#[derive(Clone, Copy, Debug)]
pub struct Clamp {
    /// RANGE: min and max may be given in either order.
    pub range: bool,
}

impl Clamp {
    pub fn parse(p: &Props) -> Result<Self> {
        Ok(Self { range: p.enumeration("clamp_type", &[("MINMAX", false), ("RANGE", true)], false)? })
    }
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let (v, lo, hi) = (i[0].x, i[1].x, i[2].x);
        o[0].x = if self.range && lo > hi { v.max(hi).min(lo) } else { v.max(lo).min(hi) };
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapRangeType {
    Linear,
    Stepped,
    Smoothstep,
    Smootherstep,
}

/// Cycles `smoothstep` (util/math_float.h).
#[inline]
pub fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    if x < edge0 {
        0.0
    } else if x >= edge1 {
        1.0
    } else {
        let t = (x - edge0) / (edge1 - edge0);
        (3.0 - 2.0 * t) * (t * t)
    }
}

/// Cycles `smootherstep` (map_range.h).
#[inline]
fn smootherstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let x = safe_divide(x - edge0, edge1 - edge0).clamp(0.0, 1.0);
    x * x * x * (x * (x * 6.0 - 15.0) + 10.0)
}

/// Cycles `svm_node_map_range` for one component.
pub fn map_range(ty: MapRangeType, clamp: bool, value: f32, from: (f32, f32), to: (f32, f32), steps: f32) -> f32 {
    let (from_min, from_max) = from;
    let (to_min, to_max) = to;
    let factor = match ty {
        MapRangeType::Linear => safe_divide(value - from_min, from_max - from_min),
        MapRangeType::Stepped => {
            let f = safe_divide(value - from_min, from_max - from_min);
            if steps > 0.0 {
                (f * (steps + 1.0)).floor() / steps
            } else {
                0.0
            }
        }
        MapRangeType::Smoothstep => {
            if from_min > from_max {
                1.0 - smoothstep(from_max, from_min, value)
            } else {
                smoothstep(from_min, from_max, value)
            }
        }
        MapRangeType::Smootherstep => {
            if from_min > from_max {
                1.0 - smootherstep(from_max, from_min, value)
            } else {
                smootherstep(from_min, from_max, value)
            }
        }
    };
    let mut result = to_min + factor * (to_max - to_min);
    if clamp && matches!(ty, MapRangeType::Linear | MapRangeType::Stepped) {
        result = if to_min > to_max { result.clamp(to_max, to_min) } else { result.clamp(to_min, to_max) };
    }
    result
}

/// The Map Range node: inputs Value, From Min, From Max, To Min, To Max, Steps, then the
/// vector versions; outputs Result, Vector.
#[derive(Clone, Copy, Debug)]
pub struct MapRange {
    pub ty: MapRangeType,
    pub vector: bool,
    pub clamp: bool,
}

impl MapRange {
    pub fn parse(p: &Props) -> Result<Self> {
        use MapRangeType::*;
        let ty = p.enumeration(
            "interpolation_type",
            &[("LINEAR", Linear), ("STEPPED", Stepped), ("SMOOTHSTEP", Smoothstep), ("SMOOTHERSTEP", Smootherstep)],
            Linear,
        )?;
        let vector = p.enumeration("data_type", &[("FLOAT", false), ("FLOAT_VECTOR", true)], false)?;
        Ok(Self { ty, vector, clamp: p.boolean("clamp", true)? })
    }
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        if self.vector {
            let c =
                |k: usize| map_range(self.ty, self.clamp, i[6][k], (i[7][k], i[8][k]), (i[9][k], i[10][k]), i[11][k]);
            o[1] = Vec3::new(c(0), c(1), c(2));
        } else {
            o[0].x = map_range(self.ty, self.clamp, i[0].x, (i[1].x, i[2].x), (i[3].x, i[4].x), i[5].x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use MathOp::*;

    #[test]
    fn power_of_a_negative_base_is_zero_unless_the_exponent_is_an_integer() {
        assert_eq!(math(Power, -2.0, 3.0, 0.0), -8.0);
        assert_eq!(math(Power, -2.0, 0.5, 0.0), 0.0);
        assert_eq!(math(Power, 4.0, 0.5, 0.0), 2.0);
    }

    #[test]
    fn safe_ops_return_zero_outside_their_domain() {
        assert_eq!(math(Divide, 1.0, 0.0, 0.0), 0.0);
        assert_eq!(math(Logarithm, -1.0, 2.0, 0.0), 0.0);
        assert_eq!(math(Logarithm, 8.0, 2.0, 0.0), 3.0);
        assert_eq!(math(Sqrt, -4.0, 0.0, 0.0), 0.0);
        assert_eq!(math(InverseSqrt, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(math(InverseSqrt, 4.0, 0.0, 0.0), 0.5);
        assert_eq!(math(Modulo, 5.0, 0.0, 0.0), 0.0);
        assert_eq!(math(Arcsine, 2.0, 0.0, 0.0), std::f32::consts::FRAC_PI_2);
        assert_eq!(math(Arccosine, -3.0, 0.0, 0.0), std::f32::consts::PI);
    }

    #[test]
    fn modulo_truncates_and_floored_modulo_floors() {
        assert_eq!(math(Modulo, -1.0, 3.0, 0.0), -1.0);
        assert_eq!(math(FlooredModulo, -1.0, 3.0, 0.0), 2.0);
        assert_eq!(math(Trunc, -1.5, 0.0, 0.0), -1.0);
        assert_eq!(math(Round, -1.5, 0.0, 0.0), -1.0);
        assert_eq!(math(Fract, -0.25, 0.0, 0.0), 0.75);
        assert_eq!(math(Snap, 7.3, 2.0, 0.0), 6.0);
    }

    #[test]
    fn wrap_maps_into_min_max_and_pingpong_bounces() {
        // WRAP(a, max=b, min=c)
        assert!((math(Wrap, 5.5, 2.0, 0.0) - 1.5).abs() < 1e-6);
        assert!((math(Wrap, -0.5, 1.0, 0.0) - 0.5).abs() < 1e-6);
        assert_eq!(math(Wrap, 3.0, 1.0, 1.0), 1.0);
        // PINGPONG with scale 1: 0 → 0, 1 → 1, 1.5 → 0.5, 2 → 0, 2.25 → 0.25
        for (a, want) in [(0.0, 0.0), (1.0, 1.0), (1.5, 0.5), (2.0, 0.0), (2.25, 0.25)] {
            assert!((math(Pingpong, a, 1.0, 0.0) - want).abs() < 1e-6, "pingpong({a})");
        }
        assert_eq!(math(Pingpong, 3.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn smooth_min_is_min_far_apart_and_dips_by_k_over_6_when_equal() {
        assert_eq!(math(SmoothMin, 0.0, 5.0, 1.0), 0.0);
        assert!((math(SmoothMin, 1.0, 1.0, 0.6) - (1.0 - 0.1)).abs() < 1e-6);
        assert!((math(SmoothMax, 1.0, 1.0, 0.6) - 1.1).abs() < 1e-6);
        assert_eq!(math(SmoothMin, 2.0, 1.0, 0.0), 1.0);
    }

    #[test]
    fn compare_sign_and_comparisons() {
        assert_eq!(math(Compare, 1.0, 1.05, 0.1), 1.0);
        assert_eq!(math(Compare, 1.0, 1.2, 0.1), 0.0);
        assert_eq!(math(Sign, -3.0, 0.0, 0.0), -1.0);
        assert_eq!(math(Sign, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(math(LessThan, 1.0, 2.0, 0.0), 1.0);
        assert_eq!(math(GreaterThan, 1.0, 2.0, 0.0), 0.0);
        assert!((math(Degrees, std::f32::consts::PI, 0.0, 0.0) - 180.0).abs() < 1e-4);
    }

    #[test]
    fn vector_ops_match_their_closed_forms() {
        let a = Vec3::new(1.0, 2.0, 3.0);
        let b = Vec3::new(0.0, 0.0, 2.0);
        assert_eq!(vector_math(VectorOp::Project, a, b, Vec3::ZERO, 1.0).0, Vec3::new(0.0, 0.0, 3.0));
        assert_eq!(vector_math(VectorOp::Reflect, a, b, Vec3::ZERO, 1.0).0, Vec3::new(1.0, 2.0, -3.0));
        assert_eq!(vector_math(VectorOp::Divide, a, b, Vec3::ZERO, 1.0).0, Vec3::new(0.0, 0.0, 1.5));
        assert_eq!(vector_math(VectorOp::Length, Vec3::new(3.0, 4.0, 0.0), b, b, 1.0).1, 5.0);
        assert_eq!(vector_math(VectorOp::Faceforward, a, b, b, 1.0).0, -a);
        assert_eq!(vector_math(VectorOp::Normalize, Vec3::ZERO, b, b, 1.0).0, Vec3::ZERO);
        // Refract straight through at eta 1 keeps the direction.
        let d = Vec3::new(0.0, 0.0, -1.0);
        let r = vector_math(VectorOp::Refract, d, Vec3::Z, Vec3::ZERO, 1.0).0;
        assert!((r - d).length() < 1e-6);
        // Total internal reflection gives zero.
        let g = Vec3::new(0.99, 0.0, -(1.0f32 - 0.99 * 0.99).sqrt());
        assert_eq!(vector_math(VectorOp::Refract, g, Vec3::Z, Vec3::ZERO, 1.5).0, Vec3::ZERO);
        assert_eq!(vector_math(VectorOp::Power, Vec3::splat(-2.0), Vec3::splat(0.5), b, 1.0).0, Vec3::ZERO);
    }

    #[test]
    fn clamp_range_accepts_swapped_bounds() {
        let mut o = [Vec3::ZERO];
        Clamp { range: true }.eval(&[Vec3::splat(5.0), Vec3::splat(3.0), Vec3::splat(1.0)], &mut o);
        assert_eq!(o[0].x, 3.0);
        Clamp { range: false }.eval(&[Vec3::splat(5.0), Vec3::splat(3.0), Vec3::splat(1.0)], &mut o);
        assert_eq!(o[0].x, 1.0);
    }

    #[test]
    fn map_range_modes() {
        use MapRangeType::*;
        assert_eq!(map_range(Linear, false, 0.75, (0.5, 1.0), (10.0, 20.0), 4.0), 15.0);
        assert_eq!(map_range(Linear, true, 2.0, (0.0, 1.0), (10.0, 20.0), 4.0), 20.0);
        assert_eq!(map_range(Linear, true, 2.0, (0.0, 1.0), (20.0, 10.0), 4.0), 10.0);
        // Stepped with 4 steps: floor(0.3·5)/4 = 0.25
        assert_eq!(map_range(Stepped, false, 0.3, (0.0, 1.0), (0.0, 1.0), 4.0), 0.25);
        assert_eq!(map_range(Smoothstep, false, 0.5, (0.0, 1.0), (0.0, 1.0), 4.0), 0.5);
        assert!((map_range(Smoothstep, false, 0.25, (0.0, 1.0), (0.0, 1.0), 0.0) - 0.15625).abs() < 1e-6);
        assert!((map_range(Smootherstep, false, 0.25, (0.0, 1.0), (0.0, 1.0), 0.0) - 0.103515625).abs() < 1e-6);
        // Reversed source range flips smoothstep.
        assert!((map_range(Smoothstep, false, 0.25, (1.0, 0.0), (0.0, 1.0), 0.0) - (1.0 - 0.15625)).abs() < 1e-6);
        // Smoothstep results are never clamped (they are already in range).
        assert_eq!(map_range(Linear, false, 1.0, (1.0, 1.0), (0.0, 1.0), 0.0), 0.0);
    }
}
