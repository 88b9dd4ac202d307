//! Blender's White Noise Texture node (Cycles `kernel/svm/white_noise.h`): the hash of
//! the coordinates' bits, so every distinct float input gives an unrelated value.

use super::hash::{
    hash_float2_to_float, hash_float2_to_float3, hash_float3_to_float, hash_float3_to_float3, hash_float4_to_float,
    hash_float4_to_float3, hash_float_to_float, hash_float_to_float3,
};
use super::Dimensions;
use glam::Vec3;
use serde::Deserialize;

/// Options of a White Noise Texture.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WhiteNoiseTexture {
    #[serde(alias = "noise_dimensions")]
    pub dimensions: Dimensions,
}

/// The node's outputs, each component in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhiteNoiseOutput {
    pub value: f32,
    pub color: Vec3,
}

impl WhiteNoiseTexture {
    /// Value and Color at `vector` and `w` (1D uses only `w`, 2D only x and y). Any
    /// input, NaN and infinity included, hashes to a finite value, as in Cycles.
    pub fn evaluate(&self, v: Vec3, w: f32) -> WhiteNoiseOutput {
        let (value, color) = match self.dimensions {
            Dimensions::D1 => (hash_float_to_float(w), hash_float_to_float3(w)),
            Dimensions::D2 => (hash_float2_to_float(v.x, v.y), hash_float2_to_float3(v.x, v.y)),
            Dimensions::D3 => (hash_float3_to_float(v.x, v.y, v.z), hash_float3_to_float3(v.x, v.y, v.z)),
            Dimensions::D4 => (hash_float4_to_float(v.x, v.y, v.z, w), hash_float4_to_float3(v.x, v.y, v.z, w)),
        };
        WhiteNoiseOutput { value, color: Vec3::from(color) }
    }
}
