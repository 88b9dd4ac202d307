//! Blender's procedural texture nodes, computed as Cycles computes them, so a
//! procedural .blend shows the same pattern in Polychrome as in Cycles.
//!
//! Each texture is a plain struct of its options and unlinked inputs with Blender
//! 4.5's defaults, and a pure `evaluate(&self, vector, w) -> Output` in f32 that
//! follows Cycles' kernel operation by operation (Cycles `kernel/svm/*.h`,
//! `util/hash.h`), with the rounding of its x86-64 SSE4.2 build (see [`math`]).
//! A shading graph copies the struct per hit, overwrites the inputs that are linked,
//! and calls `evaluate`. No output is ever NaN or infinite (see docs/procedural.md).
//!
//! [`Procedural`] wraps them all for callers that pick the node at run time.

pub mod brick;
pub mod checker;
pub mod gradient;
pub mod hash;
pub mod magic;
pub mod math;
pub mod noise;
pub mod noise_texture;
pub mod voronoi;
pub mod wave;
pub mod white_noise;

pub use brick::{BrickOutput, BrickTexture};
pub use checker::{CheckerOutput, CheckerTexture};
pub use gradient::{GradientOutput, GradientTexture, GradientType};
pub use magic::{MagicOutput, MagicTexture};
pub use noise_texture::{NoiseOutput, NoiseTexture, NoiseType};
pub use voronoi::{VoronoiFeature, VoronoiMetric, VoronoiOutput, VoronoiTexture};
pub use wave::{BandsDirection, RingsDirection, WaveOutput, WaveProfile, WaveTexture, WaveType};
pub use white_noise::{WhiteNoiseOutput, WhiteNoiseTexture};

use glam::Vec3;
use serde::Deserialize;

/// Blender's `noise_dimensions` / `voronoi_dimensions`: which coordinates are used.
/// 1D uses only W, 2D the vector's x and y, 3D the vector, 4D the vector and W.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum Dimensions {
    #[serde(rename = "1D")]
    D1,
    #[serde(rename = "2D")]
    D2,
    #[default]
    #[serde(rename = "3D")]
    D3,
    #[serde(rename = "4D")]
    D4,
}

/// Reads a colour given as `[r, g, b]` (glam has no serde support here).
pub(crate) fn vec3_from_array<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    <[f32; 3]>::deserialize(d).map(Vec3::from)
}

/// Any of the procedural textures, tagged by Blender's node idname.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub enum Procedural {
    #[serde(rename = "ShaderNodeTexNoise")]
    Noise(NoiseTexture),
    #[serde(rename = "ShaderNodeTexVoronoi")]
    Voronoi(VoronoiTexture),
    #[serde(rename = "ShaderNodeTexChecker")]
    Checker(CheckerTexture),
    #[serde(rename = "ShaderNodeTexGradient")]
    Gradient(GradientTexture),
    #[serde(rename = "ShaderNodeTexWave")]
    Wave(WaveTexture),
    #[serde(rename = "ShaderNodeTexMagic")]
    Magic(MagicTexture),
    #[serde(rename = "ShaderNodeTexBrick")]
    Brick(BrickTexture),
    #[serde(rename = "ShaderNodeTexWhiteNoise")]
    WhiteNoise(WhiteNoiseTexture),
}

/// The value of one output socket.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SocketValue {
    Float(f32),
    /// A colour or a vector (Voronoi's Position).
    Vector(Vec3),
}

impl Procedural {
    /// Parses `{"<Blender idname>": {params}}`-free input: the idname and the params'
    /// JSON (missing fields take Blender's defaults, unknown fields are an error).
    pub fn from_json(idname: &str, params_json: &str) -> Result<Self, String> {
        let value: serde_json::Value =
            serde_json::from_str(params_json).map_err(|e| format!("{idname}: parameters: {e}"))?;
        let tagged = serde_json::json!({ idname: value });
        serde_json::from_value(tagged).map_err(|e| format!("{idname}: {e}"))
    }

    /// Blender's names of the node's output sockets, in Blender's order.
    pub fn output_names(&self) -> &'static [&'static str] {
        match self {
            Procedural::Noise(_) => &["Fac", "Color"],
            Procedural::Voronoi(_) => &["Distance", "Color", "Position", "W", "Radius"],
            Procedural::WhiteNoise(_) => &["Value", "Color"],
            _ => &["Color", "Fac"],
        }
    }

    /// Whether each output (in [`Self::output_names`] order) is a colour/vector.
    pub fn output_is_vector(&self) -> &'static [bool] {
        match self {
            Procedural::Noise(_) | Procedural::WhiteNoise(_) => &[false, true],
            Procedural::Voronoi(_) => &[false, true, true, false, false],
            _ => &[true, false],
        }
    }

    /// Blender's identifiers of the node's input sockets other than Vector and W, and
    /// whether each is a colour. A shading graph sets the linked ones per hit with
    /// [`Self::set_input`] (by index in this list) on a copy of the node.
    pub fn input_names(&self) -> &'static [(&'static str, bool)] {
        const NOISE: &[(&str, bool)] = &[
            ("Scale", false),
            ("Detail", false),
            ("Roughness", false),
            ("Lacunarity", false),
            ("Offset", false),
            ("Gain", false),
            ("Distortion", false),
        ];
        const VORONOI: &[(&str, bool)] = &[
            ("Scale", false),
            ("Detail", false),
            ("Roughness", false),
            ("Lacunarity", false),
            ("Smoothness", false),
            ("Exponent", false),
            ("Randomness", false),
        ];
        const WAVE: &[(&str, bool)] = &[
            ("Scale", false),
            ("Distortion", false),
            ("Detail", false),
            ("Detail Scale", false),
            ("Detail Roughness", false),
            ("Phase Offset", false),
        ];
        const BRICK: &[(&str, bool)] = &[
            ("Color1", true),
            ("Color2", true),
            ("Mortar", true),
            ("Scale", false),
            ("Mortar Size", false),
            ("Mortar Smooth", false),
            ("Bias", false),
            ("Brick Width", false),
            ("Row Height", false),
        ];
        match self {
            Procedural::Noise(_) => NOISE,
            Procedural::Voronoi(_) => VORONOI,
            Procedural::Checker(_) => &[("Color1", true), ("Color2", true), ("Scale", false)],
            Procedural::Gradient(_) | Procedural::WhiteNoise(_) => &[],
            Procedural::Wave(_) => WAVE,
            Procedural::Magic(_) => &[("Scale", false), ("Distortion", false)],
            Procedural::Brick(_) => BRICK,
        }
    }

    /// Sets input `index` of [`Self::input_names`]. A float given to a colour input
    /// becomes grey, a colour given to a float input its mean; an index out of range
    /// is ignored.
    pub fn set_input(&mut self, index: usize, value: SocketValue) {
        let f = match value {
            SocketValue::Float(f) => f,
            SocketValue::Vector(v) => (v.x + v.y + v.z) / 3.0,
        };
        let c = match value {
            SocketValue::Float(f) => Vec3::splat(f),
            SocketValue::Vector(v) => v,
        };
        match self {
            Procedural::Noise(t) => {
                let fields = [
                    &mut t.scale,
                    &mut t.detail,
                    &mut t.roughness,
                    &mut t.lacunarity,
                    &mut t.offset,
                    &mut t.gain,
                    &mut t.distortion,
                ];
                if let Some(x) = fields.into_iter().nth(index) {
                    *x = f;
                }
            }
            Procedural::Voronoi(t) => {
                let fields = [
                    &mut t.scale,
                    &mut t.detail,
                    &mut t.roughness,
                    &mut t.lacunarity,
                    &mut t.smoothness,
                    &mut t.exponent,
                    &mut t.randomness,
                ];
                if let Some(x) = fields.into_iter().nth(index) {
                    *x = f;
                }
            }
            Procedural::Checker(t) => match index {
                0 => t.color1 = c,
                1 => t.color2 = c,
                2 => t.scale = f,
                _ => {}
            },
            Procedural::Gradient(_) | Procedural::WhiteNoise(_) => {}
            Procedural::Wave(t) => {
                let fields = [
                    &mut t.scale,
                    &mut t.distortion,
                    &mut t.detail,
                    &mut t.detail_scale,
                    &mut t.detail_roughness,
                    &mut t.phase_offset,
                ];
                if let Some(x) = fields.into_iter().nth(index) {
                    *x = f;
                }
            }
            Procedural::Magic(t) => match index {
                0 => t.scale = f,
                1 => t.distortion = f,
                _ => {}
            },
            Procedural::Brick(t) => match index {
                0 => t.color1 = c,
                1 => t.color2 = c,
                2 => t.mortar = c,
                3 => t.scale = f,
                4 => t.mortar_size = f,
                5 => t.mortar_smooth = f,
                6 => t.bias = f,
                7 => t.brick_width = f,
                8 => t.row_height = f,
                _ => {}
            },
        }
    }

    fn dimensions(&self) -> Dimensions {
        match self {
            Procedural::Noise(t) => t.dimensions,
            Procedural::Voronoi(t) => t.dimensions,
            Procedural::WhiteNoise(t) => t.dimensions,
            _ => Dimensions::D3,
        }
    }

    /// Whether the node reads its Vector input (all but the 1D modes).
    pub fn reads_vector(&self) -> bool {
        self.dimensions() != Dimensions::D1
    }

    /// Whether the node reads its W input (1D and 4D Noise, Voronoi and White Noise).
    pub fn reads_w(&self) -> bool {
        matches!(self.dimensions(), Dimensions::D1 | Dimensions::D4)
    }

    /// Every output at `vector` and `w`, in the order of [`Self::output_names`].
    pub fn evaluate(&self, vector: Vec3, w: f32) -> Outputs {
        use SocketValue::{Float, Vector};
        let (values, len) = match self {
            Procedural::Noise(t) => {
                let o = t.evaluate(vector, w);
                ([Float(o.fac), Vector(o.color), Float(0.0), Float(0.0), Float(0.0)], 2)
            }
            Procedural::Voronoi(t) => {
                let o = t.evaluate(vector, w);
                ([Float(o.distance), Vector(o.color), Vector(o.position), Float(o.w), Float(o.radius)], 5)
            }
            Procedural::WhiteNoise(t) => {
                let o = t.evaluate(vector, w);
                ([Float(o.value), Vector(o.color), Float(0.0), Float(0.0), Float(0.0)], 2)
            }
            Procedural::Checker(t) => {
                let o = t.evaluate(vector);
                colour_fac(o.color, o.fac)
            }
            Procedural::Gradient(t) => {
                let o = t.evaluate(vector);
                colour_fac(o.color, o.fac)
            }
            Procedural::Wave(t) => {
                let o = t.evaluate(vector);
                colour_fac(o.color, o.fac)
            }
            Procedural::Magic(t) => {
                let o = t.evaluate(vector);
                colour_fac(o.color, o.fac)
            }
            Procedural::Brick(t) => {
                let o = t.evaluate(vector);
                colour_fac(o.color, o.fac)
            }
        };
        Outputs { values, len }
    }
}

fn colour_fac(color: Vec3, fac: f32) -> ([SocketValue; 5], usize) {
    use SocketValue::{Float, Vector};
    ([Vector(color), Float(fac), Float(0.0), Float(0.0), Float(0.0)], 2)
}

/// The outputs of one evaluation, without allocating: `as_slice()` follows
/// [`Procedural::output_names`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outputs {
    values: [SocketValue; 5],
    len: usize,
}

impl Outputs {
    pub fn as_slice(&self) -> &[SocketValue] {
        &self.values[..self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_blender_names_and_rejects_unknown_fields() {
        let p = Procedural::from_json("ShaderNodeTexNoise", r#"{"dimensions": "4D", "noise_type": "HETERO_TERRAIN"}"#)
            .unwrap();
        let Procedural::Noise(n) = p else { panic!("{p:?}") };
        assert_eq!((n.dimensions, n.noise_type, n.scale), (Dimensions::D4, NoiseType::HeteroTerrain, 5.0));
        let e = Procedural::from_json("ShaderNodeTexNoise", r#"{"detial": 3}"#).unwrap_err();
        assert!(e.contains("detial"), "{e}");
        assert!(Procedural::from_json("ShaderNodeTexSky", "{}").is_err());
        let v = Procedural::from_json("ShaderNodeTexVoronoi", "{}").unwrap();
        assert_eq!(v.evaluate(Vec3::ONE, 0.0).as_slice().len(), v.output_names().len());
    }

    #[test]
    fn set_input_reaches_every_listed_socket() {
        // Setting each listed input to an odd value must change the node's parameters,
        // and the lists match the sockets of the Blender node (their names, in order).
        for mut node in all_nodes(0.0).into_iter().step_by(3) {
            let before = node;
            for (i, &(name, colour)) in node.input_names().iter().enumerate() {
                let v = if colour { SocketValue::Vector(Vec3::new(0.1, 0.2, 0.3)) } else { SocketValue::Float(0.123) };
                let mut n = node;
                n.set_input(i, v);
                assert_ne!(n, before, "{name} of {node:?}");
            }
            node.set_input(99, SocketValue::Float(1.0));
            assert_eq!(node, before);
            assert_eq!(node.output_names().len(), node.output_is_vector().len());
        }
    }

    /// Every node with every float input set to `bad`, in every mode.
    fn all_nodes(bad: f32) -> Vec<Procedural> {
        let mut out = Vec::new();
        for dimensions in [Dimensions::D1, Dimensions::D2, Dimensions::D3, Dimensions::D4] {
            for noise_type in [
                NoiseType::Fbm,
                NoiseType::Multifractal,
                NoiseType::HybridMultifractal,
                NoiseType::RidgedMultifractal,
                NoiseType::HeteroTerrain,
            ] {
                for normalize in [false, true] {
                    let mut t = NoiseTexture { dimensions, noise_type, normalize, ..Default::default() };
                    out.push(Procedural::Noise(t));
                    (t.scale, t.detail, t.roughness, t.lacunarity) = (bad, bad, bad, bad);
                    (t.offset, t.gain, t.distortion) = (bad, bad, bad);
                    out.push(Procedural::Noise(t));
                }
            }
            for feature in [
                VoronoiFeature::F1,
                VoronoiFeature::F2,
                VoronoiFeature::SmoothF1,
                VoronoiFeature::DistanceToEdge,
                VoronoiFeature::NSphereRadius,
            ] {
                for distance in [
                    VoronoiMetric::Euclidean,
                    VoronoiMetric::Manhattan,
                    VoronoiMetric::Chebychev,
                    VoronoiMetric::Minkowski,
                ] {
                    let mut t = VoronoiTexture { dimensions, feature, distance, normalize: true, ..Default::default() };
                    out.push(Procedural::Voronoi(t));
                    (t.scale, t.detail, t.roughness, t.lacunarity) = (bad, bad.min(15.0), bad, bad);
                    (t.smoothness, t.exponent, t.randomness) = (bad, bad, bad);
                    out.push(Procedural::Voronoi(t));
                }
            }
            out.push(Procedural::WhiteNoise(WhiteNoiseTexture { dimensions }));
        }
        let c = Vec3::splat(bad);
        out.push(Procedural::Checker(CheckerTexture { color1: c, color2: c, scale: bad }));
        for gradient_type in [
            GradientType::Linear,
            GradientType::Quadratic,
            GradientType::Easing,
            GradientType::Diagonal,
            GradientType::Spherical,
            GradientType::QuadraticSphere,
            GradientType::Radial,
        ] {
            out.push(Procedural::Gradient(GradientTexture { gradient_type }));
        }
        for wave_type in [WaveType::Bands, WaveType::Rings] {
            for wave_profile in [WaveProfile::Sin, WaveProfile::Saw, WaveProfile::Tri] {
                let w = WaveTexture { wave_type, wave_profile, ..Default::default() };
                out.push(Procedural::Wave(w));
                out.push(Procedural::Wave(WaveTexture {
                    scale: bad,
                    distortion: bad,
                    detail: bad,
                    detail_scale: bad,
                    detail_roughness: bad,
                    phase_offset: bad,
                    ..w
                }));
            }
        }
        for turbulence_depth in [0, 5, 10, -3, 1000] {
            out.push(Procedural::Magic(MagicTexture { turbulence_depth, ..Default::default() }));
            out.push(Procedural::Magic(MagicTexture { turbulence_depth, scale: bad, distortion: bad }));
        }
        out.push(Procedural::Brick(BrickTexture::default()));
        out.push(Procedural::Brick(BrickTexture {
            offset: bad,
            offset_frequency: -7,
            squash: bad,
            squash_frequency: 1000,
            color1: c,
            color2: c,
            mortar: c,
            scale: bad,
            mortar_size: bad,
            mortar_smooth: bad,
            bias: bad,
            brick_width: bad,
            row_height: bad,
        }));
        out
    }

    #[test]
    fn no_output_is_ever_nan_or_infinite() {
        let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 1e30, 0.0, -0.0, 1e-40];
        let mut points: Vec<(Vec3, f32)> = Vec::new();
        for &a in &specials {
            points.push((Vec3::new(a, 0.3, -0.7), a));
            points.push((Vec3::splat(a), 0.25));
            points.push((Vec3::new(1e6 + 0.5, a, 2.5e6), -a));
        }
        for bad in [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e38, -1e38, 0.0, 1e-38] {
            for node in all_nodes(bad) {
                for &(p, w) in &points {
                    for &v in node.evaluate(p, w).as_slice() {
                        let ok = match v {
                            SocketValue::Float(f) => f.is_finite(),
                            SocketValue::Vector(c) => c.is_finite(),
                        };
                        assert!(ok, "{node:?} at {p} w {w}: {v:?}");
                    }
                }
            }
        }
    }
}
