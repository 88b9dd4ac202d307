//! Blender's Magic Texture node (Cycles `kernel/svm/magic.h`, `svm_magic`): nested
//! sines and cosines, `depth` levels deep.

use super::math::{finite_or_zero, finite_or_zero3, Point};
use glam::Vec3;
use serde::Deserialize;

/// Options and unlinked inputs of a Magic Texture, with Blender 4.5's defaults.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MagicTexture {
    /// Blender's `turbulence_depth`, 0–10.
    pub turbulence_depth: i32,
    pub scale: f32,
    pub distortion: f32,
}

impl Default for MagicTexture {
    fn default() -> Self {
        Self { turbulence_depth: 2, scale: 5.0, distortion: 1.0 }
    }
}

/// The node's outputs: Fac is the mean of Color.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagicOutput {
    pub color: Vec3,
    pub fac: f32,
}

/// Cycles `svm_magic`.
pub fn magic(p: Vec3, scale: f32, depth: i32, mut distortion: f32) -> Vec3 {
    // Cycles wraps each coordinate into one period of the sines first, against
    // precision loss and the NaN of sin(inf) for large inputs.
    let two_pi = std::f32::consts::TAU;
    let (px, py, pz) = (p.x % two_pi, p.y % two_pi, p.z % two_pi);
    let mut x = ((px + py + pz) * 5.0 * scale).sin();
    let mut y = ((-px + py - pz) * 5.0 * scale).cos();
    let mut z = -((-px - py + pz) * 5.0 * scale).cos();
    let d = distortion;
    if depth > 0 {
        x *= d;
        y *= d;
        z *= d;
        y = -(x - y + z).cos();
        y *= d;
        if depth > 1 {
            x = (x - y - z).cos() * d;
            if depth > 2 {
                z = (-x - y - z).sin() * d;
                if depth > 3 {
                    x = -(-x + y - z).cos() * d;
                    if depth > 4 {
                        y = -(-x + y + z).sin() * d;
                        if depth > 5 {
                            y = -(-x + y + z).cos() * d;
                            if depth > 6 {
                                x = (x + y + z).cos() * d;
                                if depth > 7 {
                                    z = (x + y - z).sin() * d;
                                    if depth > 8 {
                                        x = -(-x - y + z).cos() * d;
                                        if depth > 9 {
                                            y = -(x - y + z).sin() * d;
                                        }
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    if distortion != 0.0 {
        distortion *= 2.0;
        // Three divisions by one value: under -freciprocal-math GCC computes the
        // reciprocal once and multiplies.
        let inv = 1.0 / distortion;
        x *= inv;
        y *= inv;
        z *= inv;
    }
    Vec3::new(0.5 - x, 0.5 - y, 0.5 - z)
}

impl MagicTexture {
    /// Color and Fac at `vector`; non-finite results become 0.
    pub fn evaluate(&self, vector: Vec3) -> MagicOutput {
        // Cycles passes the depth through a byte of the node.
        let depth = self.turbulence_depth.clamp(0, 255);
        let color = magic(vector, self.scale, depth, self.distortion);
        // Cycles `average`: reduce_add * (1/3).
        let fac = color.reduce_add() * (1.0 / 3.0);
        MagicOutput { color: finite_or_zero3(color), fac: finite_or_zero(fac) }
    }
}
