//! Blender's Wave Texture node (Cycles `kernel/svm/wave.h`, `svm_wave`).

use super::gradient::INV_TWO_PI;
use super::math::{finite_or_zero, Point};
use super::noise::fbm;
use glam::Vec3;
use serde::Deserialize;

/// Blender's `wave_type`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum WaveType {
    #[default]
    Bands,
    Rings,
}

/// Blender's `bands_direction`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum BandsDirection {
    #[default]
    X,
    Y,
    Z,
    Diagonal,
}

/// Blender's `rings_direction`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum RingsDirection {
    #[default]
    X,
    Y,
    Z,
    Spherical,
}

/// Blender's `wave_profile`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum WaveProfile {
    #[default]
    Sin,
    Saw,
    Tri,
}

/// Options and unlinked inputs of a Wave Texture, with Blender 4.5's defaults.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WaveTexture {
    pub wave_type: WaveType,
    pub bands_direction: BandsDirection,
    pub rings_direction: RingsDirection,
    pub wave_profile: WaveProfile,
    pub scale: f32,
    pub distortion: f32,
    /// fBM octaves of the distortion noise. Cycles does not clamp it; it is clamped to
    /// [0, 15] here (Blender's slider range) so a linked value cannot loop for ever.
    pub detail: f32,
    pub detail_scale: f32,
    pub detail_roughness: f32,
    pub phase_offset: f32,
}

impl Default for WaveTexture {
    fn default() -> Self {
        Self {
            wave_type: WaveType::Bands,
            bands_direction: BandsDirection::X,
            rings_direction: RingsDirection::X,
            wave_profile: WaveProfile::Sin,
            scale: 5.0,
            distortion: 0.0,
            detail: 2.0,
            detail_scale: 1.0,
            detail_roughness: 0.5,
            phase_offset: 0.0,
        }
    }
}

/// The node's outputs: Color is Fac in every channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveOutput {
    pub color: Vec3,
    pub fac: f32,
}

impl WaveTexture {
    /// Color and Fac at `vector`; non-finite results become 0.
    pub fn evaluate(&self, vector: Vec3) -> WaveOutput {
        let fac = finite_or_zero(self.wave(vector * self.scale));
        WaveOutput { color: Vec3::splat(fac), fac }
    }

    /// Cycles `svm_wave`.
    fn wave(&self, p: Vec3) -> f32 {
        // Keeps unit coordinates off the band edges.
        let p = (p + Vec3::splat(0.000001)) * 0.999999;
        let mut n = match self.wave_type {
            WaveType::Bands => match self.bands_direction {
                BandsDirection::X => p.x * 20.0,
                BandsDirection::Y => p.y * 20.0,
                BandsDirection::Z => p.z * 20.0,
                BandsDirection::Diagonal => (p.x + p.y + p.z) * 10.0,
            },
            WaveType::Rings => {
                let keep = match self.rings_direction {
                    RingsDirection::X => Vec3::new(0.0, 1.0, 1.0),
                    RingsDirection::Y => Vec3::new(1.0, 0.0, 1.0),
                    RingsDirection::Z => Vec3::new(1.0, 1.0, 0.0),
                    RingsDirection::Spherical => Vec3::ONE,
                };
                let rp = if self.rings_direction == RingsDirection::Spherical { p } else { p.mul_elem(keep) };
                rp.cycles_len() * 20.0
            }
        };
        n += self.phase_offset;
        if self.distortion != 0.0 {
            let detail = super::math::clamp(self.detail, 0.0, 15.0);
            let noise = fbm(p * self.detail_scale, detail, self.detail_roughness, 2.0, true);
            n += self.distortion * (noise * 2.0 - 1.0);
        }
        match self.wave_profile {
            WaveProfile::Sin => 0.5 + 0.5 * (n - std::f32::consts::FRAC_PI_2).sin(),
            WaveProfile::Saw => {
                let n = n * INV_TWO_PI;
                n - n.floor()
            }
            WaveProfile::Tri => {
                let n = n * INV_TWO_PI;
                (n - (n + 0.5).floor()).abs() * 2.0
            }
        }
    }
}
