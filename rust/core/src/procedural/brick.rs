//! Blender's Brick Texture node (Cycles `kernel/svm/brick.h`, `svm_brick`).

use super::math::{finite_or_zero, finite_or_zero3, floor_to_int, min, saturate, smoothstepf};
use glam::Vec3;
use serde::Deserialize;

/// Options and unlinked inputs of a Brick Texture, with Blender 4.5's defaults.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BrickTexture {
    /// Shift of every `offset_frequency`-th row, as a fraction of the brick width.
    pub offset: f32,
    pub offset_frequency: i32,
    /// Width factor of every `squash_frequency`-th row.
    pub squash: f32,
    pub squash_frequency: i32,
    #[serde(deserialize_with = "super::vec3_from_array")]
    pub color1: Vec3,
    #[serde(deserialize_with = "super::vec3_from_array")]
    pub color2: Vec3,
    #[serde(deserialize_with = "super::vec3_from_array")]
    pub mortar: Vec3,
    pub scale: f32,
    pub mortar_size: f32,
    pub mortar_smooth: f32,
    pub bias: f32,
    pub brick_width: f32,
    pub row_height: f32,
}

impl Default for BrickTexture {
    fn default() -> Self {
        Self {
            offset: 0.5,
            offset_frequency: 2,
            squash: 1.0,
            squash_frequency: 2,
            color1: Vec3::splat(0.8),
            color2: Vec3::splat(0.2),
            mortar: Vec3::ZERO,
            scale: 5.0,
            mortar_size: 0.02,
            mortar_smooth: 0.1,
            bias: 0.0,
            brick_width: 0.5,
            row_height: 0.25,
        }
    }
}

/// The node's outputs: Fac is the mortar mask (1 in the mortar).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrickOutput {
    pub color: Vec3,
    pub fac: f32,
}

/// Cycles `brick_noise`: a fast integer hash in [0, 1) giving each brick its tint.
fn brick_noise(n: u32) -> f32 {
    let n = n.wrapping_add(1013) & 0x7fffffff;
    let n = (n >> 13) ^ n;
    let nn = n.wrapping_mul(n.wrapping_mul(n).wrapping_mul(60493).wrapping_add(19990303)).wrapping_add(1376312589)
        & 0x7fffffff;
    0.5 * (nn as f32 / 1073741824.0)
}

impl BrickTexture {
    /// Cycles `svm_brick`: (tint, mortar) at the scaled point.
    fn brick(&self, p: Vec3) -> (f32, f32) {
        let (row_height, mortar_size, mortar_smooth) = (self.row_height, self.mortar_size, self.mortar_smooth);
        // Cycles packs both frequencies into bytes of the node.
        let offset_frequency = self.offset_frequency.clamp(0, 255);
        let squash_frequency = self.squash_frequency.clamp(0, 255);
        let mut brick_width = self.brick_width;
        let mut offset = 0.0f32;
        let rownum = floor_to_int(p.y / row_height);
        if offset_frequency != 0 && squash_frequency != 0 {
            brick_width *= if rownum.wrapping_rem(squash_frequency) != 0 { 1.0 } else { self.squash };
            offset = if rownum.wrapping_rem(offset_frequency) != 0 { 0.0 } else { brick_width * self.offset };
        }
        let bricknum = floor_to_int((p.x + offset) / brick_width);
        let x = (p.x + offset) - brick_width * bricknum as f32;
        let y = p.y - row_height * rownum as f32;
        let seed = ((rownum as u32) << 16).wrapping_add((bricknum & 0xFFFF) as u32);
        let tint = saturate(brick_noise(seed) + self.bias);
        let mut min_dist = min(min(x, y), min(brick_width - x, row_height - y));
        let mortar = if min_dist >= mortar_size {
            0.0
        } else if mortar_smooth == 0.0 {
            1.0
        } else {
            min_dist = 1.0 - min_dist / mortar_size;
            smoothstepf(min_dist / mortar_smooth)
        };
        (tint, mortar)
    }

    /// Color and Fac at `vector`; non-finite results become 0.
    pub fn evaluate(&self, vector: Vec3) -> BrickOutput {
        let (tint, f) = self.brick(vector * self.scale);
        let mut color1 = self.color1;
        if f != 1.0 {
            let facm = 1.0 - tint;
            color1 = color1 * facm + self.color2 * tint;
        }
        let color = color1 * (1.0 - f) + self.mortar * f;
        BrickOutput { color: finite_or_zero3(color), fac: finite_or_zero(f) }
    }
}
