//! Blender's Checker Texture node (Cycles `kernel/svm/checker.h`, `svm_checker`).

use super::math::{finite_or_zero3, float_to_int};
use glam::Vec3;
use serde::Deserialize;

/// Inputs of a Checker Texture, with Blender 4.5's defaults.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CheckerTexture {
    #[serde(deserialize_with = "super::vec3_from_array")]
    pub color1: Vec3,
    #[serde(deserialize_with = "super::vec3_from_array")]
    pub color2: Vec3,
    pub scale: f32,
}

impl Default for CheckerTexture {
    fn default() -> Self {
        Self { color1: Vec3::splat(0.8), color2: Vec3::splat(0.2), scale: 5.0 }
    }
}

/// The node's outputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckerOutput {
    pub color: Vec3,
    pub fac: f32,
}

/// Cycles `svm_checker`: 1 on the cells where the parities of the three cell indices
/// make an even pattern, else 0. The tiny shift keeps unit coordinates inside a cell.
pub fn checker(p: Vec3) -> f32 {
    let cell = |c: f32| float_to_int(((c + 0.000001) * 0.999999).floor()).wrapping_abs() % 2;
    let (xi, yi, zi) = (cell(p.x), cell(p.y), cell(p.z));
    if ((xi == yi) as i32) == zi {
        1.0
    } else {
        0.0
    }
}

impl CheckerTexture {
    /// Color and Fac at `vector`. NaN or infinite coordinates fall in a cell like any
    /// other (Cycles' x86 integer conversion); non-finite colours become 0.
    pub fn evaluate(&self, vector: Vec3) -> CheckerOutput {
        let fac = checker(vector * self.scale);
        let color = if fac == 1.0 { self.color1 } else { self.color2 };
        CheckerOutput { color: finite_or_zero3(color), fac }
    }
}
