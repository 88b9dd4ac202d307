//! Blender's Gradient Texture node (Cycles `kernel/svm/gradient.h`, `svm_gradient`).

use super::math::{finite_or_zero, saturate};
use glam::Vec3;
use serde::Deserialize;

/// Blender's `gradient_type`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum GradientType {
    #[default]
    Linear,
    Quadratic,
    Easing,
    Diagonal,
    Spherical,
    QuadraticSphere,
    Radial,
}

/// Options of a Gradient Texture (it has no other inputs than the vector).
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GradientTexture {
    pub gradient_type: GradientType,
}

/// The node's outputs: Color is Fac in every channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientOutput {
    pub color: Vec3,
    pub fac: f32,
}

/// `1 / M_2PI_F`: Cycles is built with `-freciprocal-math`, which turns its division
/// by the constant 2π into this multiplication.
pub(crate) const INV_TWO_PI: f32 = 1.0 / std::f32::consts::TAU;

/// Cycles `svm_gradient`, before the node's saturation.
pub fn gradient(p: Vec3, kind: GradientType) -> f32 {
    let (x, y, z) = (p.x, p.y, p.z);
    match kind {
        GradientType::Linear => x,
        GradientType::Quadratic => {
            let r = x.max(0.0);
            r * r
        }
        GradientType::Easing => {
            // fminf(fmaxf(x, 0), 1): NaN becomes 0, where clamp would keep it.
            #[allow(clippy::manual_clamp)]
            let r = x.max(0.0).min(1.0);
            let t = r * r;
            3.0 * t - 2.0 * t * r
        }
        GradientType::Diagonal => (x + y) * 0.5,
        GradientType::Radial => y.atan2(x) * INV_TWO_PI + 0.5,
        GradientType::QuadraticSphere | GradientType::Spherical => {
            // The bias gives exactly 0 on the unit sphere instead of rounding noise.
            let r = (0.999999 - (x * x + y * y + z * z).sqrt()).max(0.0);
            if kind == GradientType::Spherical {
                r
            } else {
                r * r
            }
        }
    }
}

impl GradientTexture {
    /// Color and Fac at `vector`, saturated to [0, 1] as the node does (NaN gives 0).
    pub fn evaluate(&self, vector: Vec3) -> GradientOutput {
        let fac = finite_or_zero(saturate(gradient(vector, self.gradient_type)));
        GradientOutput { color: Vec3::splat(fac), fac }
    }
}
