//! Blender's Noise Texture node (Cycles `kernel/svm/noisetex.h`, `svm_node_tex_noise`).

use super::math::{clamp, finite_or_zero, finite_or_zero3};
use super::noise::{fbm, hetero_terrain, hybrid_multi_fractal, multi_fractal, ridged_multi_fractal, NoisePoint};
use super::Dimensions;
use glam::{Vec2, Vec3, Vec4};
use serde::Deserialize;

/// The fractal that sums the octaves (Blender's `noise_type`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum NoiseType {
    Multifractal,
    #[default]
    Fbm,
    HybridMultifractal,
    RidgedMultifractal,
    HeteroTerrain,
}

/// Options and unlinked inputs of a Noise Texture, with Blender 4.5's defaults. The
/// shading graph copies it per hit and overwrites the inputs that are linked.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseTexture {
    #[serde(alias = "noise_dimensions")]
    pub dimensions: Dimensions,
    pub noise_type: NoiseType,
    pub normalize: bool,
    pub scale: f32,
    /// Octaves beyond the first, 0–15 (clamped, as Cycles does).
    pub detail: f32,
    pub roughness: f32,
    pub lacunarity: f32,
    /// Hybrid/ridged multifractal and hetero terrain only.
    pub offset: f32,
    /// Hybrid and ridged multifractal only.
    pub gain: f32,
    pub distortion: f32,
}

impl Default for NoiseTexture {
    fn default() -> Self {
        Self {
            dimensions: Dimensions::D3,
            noise_type: NoiseType::Fbm,
            normalize: true,
            scale: 5.0,
            detail: 2.0,
            roughness: 0.5,
            lacunarity: 2.0,
            offset: 0.0,
            gain: 1.0,
            distortion: 0.0,
        }
    }
}

/// The node's outputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseOutput {
    pub fac: f32,
    pub color: Vec3,
}

/// The fractal settings after the node's clamping (`svm_node_tex_noise`).
struct Fractal {
    noise_type: NoiseType,
    normalize: bool,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    offset: f32,
    gain: f32,
}

impl Fractal {
    /// Cycles `noise_select`.
    fn eval<P: NoisePoint>(&self, p: P) -> f32 {
        let (d, r, l) = (self.detail, self.roughness, self.lacunarity);
        match self.noise_type {
            NoiseType::Multifractal => multi_fractal(p, d, r, l),
            NoiseType::Fbm => fbm(p, d, r, l, self.normalize),
            NoiseType::HybridMultifractal => hybrid_multi_fractal(p, d, r, l, self.offset, self.gain),
            NoiseType::RidgedMultifractal => ridged_multi_fractal(p, d, r, l, self.offset, self.gain),
            NoiseType::HeteroTerrain => hetero_terrain(p, d, r, l, self.offset),
        }
    }
}

/// Cycles `noise_texture_{1,2,3,4}d`: distorts `p` by noise at seeds 0..N-1, then the
/// value at `p` and, for the colour, at `p` shifted by the seeds N and N+1.
fn texture<P: NoisePoint>(
    p: P,
    fractal: &Fractal,
    distortion: f32,
    distort: impl Fn(P, f32) -> P,
    first_colour_seed: f32,
    colour: bool,
) -> (f32, Vec3) {
    let p = if distortion != 0.0 { distort(p, distortion) } else { p };
    let fac = fractal.eval(p);
    let color = if colour {
        Vec3::new(
            fac,
            fractal.eval(p + P::random_offset(first_colour_seed)),
            fractal.eval(p + P::random_offset(first_colour_seed + 1.0)),
        )
    } else {
        Vec3::ZERO
    };
    (fac, color)
}

impl NoiseTexture {
    /// Fac and Color at `vector` (Blender's Vector input) and `w` (the W input, used by
    /// 1D and 4D). Non-finite results become 0.
    pub fn evaluate(&self, vector: Vec3, w: f32) -> NoiseOutput {
        let (fac, color) = self.eval(vector, w, true);
        NoiseOutput { fac: finite_or_zero(fac), color: finite_or_zero3(color) }
    }

    /// Fac alone: a third of the cost of [`Self::evaluate`], which also computes Color.
    pub fn fac(&self, vector: Vec3, w: f32) -> f32 {
        finite_or_zero(self.eval(vector, w, false).0)
    }

    fn eval(&self, vector: Vec3, w: f32, colour: bool) -> (f32, Vec3) {
        let fractal = Fractal {
            noise_type: self.noise_type,
            normalize: self.normalize,
            detail: clamp(self.detail, 0.0, 15.0),
            roughness: self.roughness.max(0.0),
            lacunarity: self.lacunarity,
            offset: self.offset,
            gain: self.gain,
        };
        let v = vector * self.scale;
        let w = w * self.scale;
        let d = self.distortion;
        match self.dimensions {
            Dimensions::D1 => {
                texture(w, &fractal, d, |p, d| p + (p + f32::random_offset(0.0)).snoise() * d, 1.0, colour)
            }
            Dimensions::D2 => texture(
                Vec2::new(v.x, v.y),
                &fractal,
                d,
                |p, d| {
                    p + Vec2::new(
                        (p + Vec2::random_offset(0.0)).snoise() * d,
                        (p + Vec2::random_offset(1.0)).snoise() * d,
                    )
                },
                2.0,
                colour,
            ),
            Dimensions::D3 => texture(
                v,
                &fractal,
                d,
                |p, d| {
                    p + Vec3::new(
                        (p + Vec3::random_offset(0.0)).snoise() * d,
                        (p + Vec3::random_offset(1.0)).snoise() * d,
                        (p + Vec3::random_offset(2.0)).snoise() * d,
                    )
                },
                3.0,
                colour,
            ),
            Dimensions::D4 => texture(
                v.extend(w),
                &fractal,
                d,
                |p, d| {
                    p + Vec4::new(
                        (p + Vec4::random_offset(0.0)).snoise() * d,
                        (p + Vec4::random_offset(1.0)).snoise() * d,
                        (p + Vec4::random_offset(2.0)).snoise() * d,
                        (p + Vec4::random_offset(3.0)).snoise() * d,
                    )
                },
                4.0,
                colour,
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_red_channel_is_fac() {
        let t = NoiseTexture { distortion: 0.7, ..Default::default() };
        let o = t.evaluate(Vec3::new(0.3, -1.2, 2.5), 0.0);
        assert_eq!(o.color.x, o.fac);
        assert_eq!(t.fac(Vec3::new(0.3, -1.2, 2.5), 0.0), o.fac);
    }

    #[test]
    fn non_finite_inputs_give_zero() {
        for dimensions in [Dimensions::D1, Dimensions::D2, Dimensions::D3, Dimensions::D4] {
            for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                let t = NoiseTexture { dimensions, detail: bad, roughness: bad, distortion: 1.0, ..Default::default() };
                let o = t.evaluate(Vec3::splat(bad), bad);
                assert!(o.fac.is_finite() && o.color.is_finite());
                let o = NoiseTexture { dimensions, ..Default::default() }.evaluate(Vec3::new(1e38, -1e38, 0.5), 3e38);
                assert!(o.fac.is_finite() && o.color.is_finite());
            }
        }
    }
}
