//! The scene description every front end produces (Python API, Blender, USD): plain
//! values plus numbered buffers for bulk mesh data. It is independent of the render's
//! wavelength grid; [`super::Scene::build`] compiles it for one.

use crate::camera::CameraDesc;
use crate::spectrum::SpectrumDesc;
use serde::{Deserialize, Serialize};

/// Bulk data handed over without per-element parsing (numpy arrays on the Python side).
#[derive(Clone, Debug)]
pub enum Buffer {
    F32(Vec<f32>),
    U32(Vec<u32>),
    /// Bytes (8-bit sRGB texture pixels).
    U8(Vec<u8>),
}

/// A buffer the build reads in place: a [`Buffer`]'s data, or a caller's memory (the
/// Python bindings lend numpy arrays for the length of a render instead of copying them).
#[derive(Clone, Copy, Debug)]
pub enum BufferView<'a> {
    F32(&'a [f32]),
    U32(&'a [u32]),
    U8(&'a [u8]),
}

/// What [`super::Scene::build`] and the render entry points accept as buffers: owned
/// [`Buffer`]s or borrowed [`BufferView`]s.
pub trait AsBufferView {
    fn view(&self) -> BufferView<'_>;
}

impl AsBufferView for Buffer {
    fn view(&self) -> BufferView<'_> {
        match self {
            Buffer::F32(v) => BufferView::F32(v),
            Buffer::U32(v) => BufferView::U32(v),
            Buffer::U8(v) => BufferView::U8(v),
        }
    }
}

impl AsBufferView for BufferView<'_> {
    fn view(&self) -> BufferView<'_> {
        *self
    }
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneDesc {
    pub camera: CameraDesc,
    pub materials: Vec<MaterialDesc>,
    pub meshes: Vec<MeshDesc>,
    /// Placements of meshes; when absent every mesh is placed once, untransformed.
    pub instances: Option<Vec<InstanceDesc>>,
    pub lights: Vec<LightDesc>,
    pub world: Option<WorldDesc>,
    /// RGB images, kept RGB and converted to spectra when a ray hits them (docs/design.md#rgb-data).
    /// Referenced by index: `{"type": "texture", "texture": i}` in a diffuse
    /// reflectance, `world.texture` for an HDRI environment.
    pub textures: Vec<TextureDesc>,
    /// Cycles' Film > Transparent: the background seen directly makes the Combined
    /// pass's alpha 0 there (Holdout closures do whatever this says,
    /// docs/materials.md#holdout).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub film_transparent: bool,
}

/// How a texture's pixels are encoded in its buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextureEncoding {
    /// f32 linear RGB(A) values (an F32 buffer).
    #[default]
    Linear,
    /// 8-bit sRGB-encoded RGB(A) bytes (a U8 buffer), decoded on lookup.
    Srgb,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureDesc {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// 3 (RGB) or 4 (RGBA; alpha is ignored).
    #[serde(default = "three")]
    pub channels: u32,
    /// Buffer of height × width × channels values, top row first.
    pub buffer: usize,
    #[serde(default)]
    pub encoding: TextureEncoding,
    /// REPEAT, CLIP or EXTEND (Blender's names).
    #[serde(default)]
    pub wrap: crate::material::texture::Wrap,
}

fn three() -> u32 {
    3
}

/// A material: a fixed `bsdf`/`emission` description (docs/materials.md), or a node
/// graph `nodes` + `output` (docs/shading.md), which is held as [`BsdfDesc::Graph`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "RawMaterialDesc")]
pub struct MaterialDesc {
    pub name: String,
    #[serde(default)]
    pub bsdf: BsdfDesc,
    /// Emitted radiance (both faces, or the front one with `one_sided`); makes every
    /// triangle using it an area light.
    #[serde(default)]
    pub emission: Option<SpectrumDesc>,
    /// A homogeneous medium filling the inside of every closed mesh with this material
    /// (docs/media.md).
    #[serde(default)]
    pub volume: Option<VolumeDesc>,
    /// Emission from the front face only (the side the triangle's winding normal
    /// points to), as Cycles' and UsdLux's area lights; the back face emits nothing.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub one_sided: bool,
    /// Rays pass through the surface after gathering its emission, as Cycles treats its
    /// lights (a transparent bounce); it never blocks shadow rays.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub see_through: bool,
}

/// A homogeneous participating medium (Blender's Volume output). Coefficients are per
/// scene unit of length: a spectrum, or an RGB colour in [0, 1] uplifted as a
/// reflectance, times its `scale` (the density).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeDesc {
    /// Absorption coefficient σa(λ).
    #[serde(default)]
    pub absorption: Option<SpectrumDesc>,
    /// Scattering coefficient σs(λ).
    #[serde(default)]
    pub scattering: Option<SpectrumDesc>,
    /// Henyey–Greenstein asymmetry g in (−1, 1).
    #[serde(default)]
    pub anisotropy: f32,
    /// Emitted radiance per unit length (an RGB colour is uplifted as an illuminant).
    #[serde(default)]
    pub emission: Option<SpectrumDesc>,
    /// A heterogeneous medium: σa and σs times the density of this voxel grid, which
    /// fills a box in the object space of each mesh with the material (docs/media.md,
    /// "Grid media"). Not with `emission`, nor on the world.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_grid: Option<DensityGridDesc>,
}

/// A dense voxel grid of densities (`medium::grid`): `dims` voxels along x, y, z,
/// `values` x fastest, then y, then z (dims[0]·dims[1]·dims[2] of them, finite and
/// non-negative), filling the object-space box `bounds` = [min, max]; the density is
/// trilinear between voxel centres and 0 outside the box.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DensityGridDesc {
    pub dims: [u32; 3],
    pub values: Vec<f32>,
    pub bounds: [[f32; 3]; 2],
}

/// A material as written, before checking that it is either fixed or a graph.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterialDesc {
    name: String,
    #[serde(default)]
    bsdf: Option<BsdfDesc>,
    #[serde(default)]
    emission: Option<SpectrumDesc>,
    #[serde(default)]
    nodes: Option<Vec<crate::shading::NodeDesc>>,
    #[serde(default)]
    output: Option<crate::shading::OutputDesc>,
    #[serde(default)]
    volume: Option<VolumeDesc>,
    #[serde(default)]
    one_sided: bool,
    #[serde(default)]
    see_through: bool,
}

impl TryFrom<RawMaterialDesc> for MaterialDesc {
    type Error = String;
    fn try_from(r: RawMaterialDesc) -> Result<Self, String> {
        let name = r.name;
        match (r.nodes, r.output) {
            (None, None) => Ok(Self {
                name,
                bsdf: r.bsdf.unwrap_or_default(),
                emission: r.emission,
                volume: r.volume,
                one_sided: r.one_sided,
                see_through: r.see_through,
            }),
            (Some(nodes), output) => {
                if r.bsdf.is_some() || r.emission.is_some() {
                    return Err(format!(
                        "material '{name}': give either a node graph (nodes, output) or bsdf/emission, not both"
                    ));
                }
                let output = output.ok_or_else(|| format!("material '{name}': nodes without an output"))?;
                Ok(Self {
                    name,
                    bsdf: BsdfDesc::Graph(Box::new(crate::shading::GraphDesc { nodes, output })),
                    emission: None,
                    volume: r.volume,
                    one_sided: r.one_sided,
                    see_through: r.see_through,
                })
            }
            (None, Some(_)) => Err(format!("material '{name}': an output without nodes")),
        }
    }
}

// The Principled variant is the largest by far (its many inputs); a description is built
// once per material, or once per hit of a varying graph and dropped after the BSDF is built.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum BsdfDesc {
    Diffuse {
        reflectance: SpectrumDesc,
    },
    /// Reflects nothing (an emission-only surface).
    None,
    /// No surface at all: rays pass straight through without scattering or counting a
    /// bounce (Blender's material with only a Volume output: a medium's boundary).
    Null,
    /// Glass: smooth (roughness 0) or GGX-rough; dispersive when the index varies.
    Dielectric {
        #[serde(default)]
        ior: crate::material::IorDesc,
        #[serde(default)]
        roughness: f32,
    },
    /// Blender's Refraction BSDF: transmission only, no reflection and no Fresnel factor
    /// (as Cycles; it does not conserve energy), smooth or rough on GGX (`beckmann`:
    /// Beckmann, the node's default). See `material::refraction`.
    Refraction {
        #[serde(default)]
        ior: crate::material::IorDesc,
        #[serde(default)]
        roughness: f32,
        #[serde(default)]
        beckmann: bool,
    },
    /// Blender's Metallic BSDF in Physical Conductor mode: GGX with the exact conductor
    /// Fresnel of `eta` + i`k` (spectra, or RGB triples uplifted per wavelength as
    /// unbounded data), with Multiscatter GGX's energy compensation when `multiscatter`
    /// (`material::metallic`).
    Metallic {
        eta: SpectrumDesc,
        k: SpectrumDesc,
        #[serde(default)]
        roughness: f32,
        #[serde(default = "yes")]
        multiscatter: bool,
    },
    /// A metal: a named measured metal ("gold", "silver", "copper", "aluminium") or
    /// a user complex index η + ik; GGX roughness as Blender's (alpha = roughness²).
    Conductor {
        #[serde(default)]
        metal: Option<String>,
        #[serde(default)]
        eta: Option<SpectrumDesc>,
        #[serde(default)]
        k: Option<SpectrumDesc>,
        #[serde(default)]
        roughness: f32,
    },
    /// Blender's Glossy BSDF: GGX with Schlick's Fresnel tinted by `reflectance`.
    Glossy {
        reflectance: SpectrumDesc,
        #[serde(default)]
        roughness: f32,
        /// Blender's Glossy Anisotropy (−1..1, clamped to ±0.99; 0: isotropic).
        #[serde(default)]
        anisotropy: f32,
        /// Blender's Rotation of the tangent about the normal, in turns (1 = 360°).
        #[serde(default)]
        rotation: f32,
        /// The tangent at a hit of a graph, in the lobe's shading frame (None: the
        /// frame's first axis; not part of the scene format).
        #[serde(skip)]
        tangent: Option<[f32; 3]>,
    },
    /// Blender's Principled BSDF: a diffuse base (`base_color`) under a dielectric GGX
    /// specular layer (Fresnel at `ior`, optional thin film), blended towards a metal
    /// (`metallic`, base colour as F0, F82 `specular_tint`) and a rough glass
    /// (`transmission`, tinted by the base colour). See `material::principled`.
    Principled {
        #[serde(default = "default_base_color")]
        base_color: SpectrumDesc,
        #[serde(default)]
        metallic: f32,
        #[serde(default = "half")]
        roughness: f32,
        #[serde(default)]
        ior: crate::material::IorDesc,
        #[serde(default)]
        transmission: f32,
        /// The metal's tint at ~82° (Blender's Specular Tint); white when absent.
        #[serde(default)]
        specular_tint: Option<SpectrumDesc>,
        /// Thin film on the specular interface (nm; 0: none).
        #[serde(default)]
        thin_film_thickness: f32,
        #[serde(default = "default_thin_film_ior")]
        thin_film_ior: f32,
        /// Blender's Specular IOR Level (0.5: F0 from `ior`; F0 scales by 2·level).
        #[serde(default = "half")]
        specular_ior_level: f32,
        /// Blender's Diffuse Roughness of the base (0: Lambertian, else Oren–Nayar).
        #[serde(default)]
        diffuse_roughness: f32,
        /// Blender's Anisotropic (0..1) of the specular and metal lobes, along the
        /// tangent (a graph's Tangent input at a hit; else the shading frame's first axis).
        #[serde(default)]
        anisotropic: f32,
        /// Blender's Anisotropic Rotation of the tangent about the normal, in turns.
        #[serde(default)]
        anisotropic_rotation: f32,
        /// Blender's Coat: a dielectric layer over everything else (absent: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        coat: Option<CoatDesc>,
        /// Blender's Sheen: the microfibre sheen on top of the coat (absent: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sheen: Option<SheenLayerDesc>,
        /// Blender's Subsurface: a random walk under the base (absent: none).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        subsurface: Option<Box<SubsurfaceDesc>>,
        /// Its lobes' own normals at a hit of a graph (not part of the scene format).
        #[serde(skip)]
        normals: Option<Box<PrincipledNormals>>,
    },
    /// Blender's Mix Shader: (1 − factor)·a + factor·b; `factor_from` (a Fresnel or
    /// Layer Weight node on Fac) replaces the constant by a function of the view angle.
    Mix {
        a: Box<BsdfDesc>,
        b: Box<BsdfDesc>,
        #[serde(default = "half")]
        factor: f32,
        #[serde(default)]
        factor_from: Option<MixFactorDesc>,
    },
    /// Blender's Add Shader: a + b.
    Add {
        a: Box<BsdfDesc>,
        b: Box<BsdfDesc>,
    },
    /// Blender's Diffuse BSDF with Roughness > 0 (energy-preserving Oren–Nayar).
    RoughDiffuse {
        reflectance: SpectrumDesc,
        roughness: f32,
    },
    /// Blender's Translucent BSDF: Lambertian transmission tinted by `color`.
    Translucent {
        color: SpectrumDesc,
    },
    /// Blender's Transparent BSDF: the ray passes straight on, tinted by `color`
    /// (Cycles' `bsdf_transparent_setup`). At the top of a material, alone or as one
    /// side of a constant Mix (Principled Alpha), it is stochastic transparency:
    /// paths pass with the Mix's weight, shadow rays are attenuated by weight × colour.
    /// Nested deeper it reflects nothing (warned).
    Transparent {
        color: SpectrumDesc,
    },
    /// `bsdf` scaled per wavelength by `color` (a reflectance): Blender's Glass BSDF
    /// Color, which Cycles applies as the closure weight (reflection and transmission).
    Tint {
        color: SpectrumDesc,
        bsdf: Box<BsdfDesc>,
    },
    /// Blender's Sheen BSDF (microfiber LTC).
    Sheen {
        color: SpectrumDesc,
        #[serde(default = "half")]
        roughness: f32,
    },
    /// A node graph (docs/shading.md); written as the material's `nodes` and `output`.
    Graph(Box<crate::shading::GraphDesc>),
    /// `bsdf` about its own unit `normal`, given in the vertex's shading frame (a
    /// graph's per-lobe Normal at a hit, `material::Oriented`; not part of the scene format).
    #[serde(skip)]
    Oriented {
        normal: [f32; 3],
        bsdf: Box<BsdfDesc>,
        /// A diffuse lobe's smooth normal (Cycles' bump shadowing term).
        smooth: Option<[f32; 3]>,
    },
}

impl BsdfDesc {
    /// Splits a top-level Transparent BSDF off: `(probability a path passes, its tint)`
    /// and the opaque rest, weighted 1 (it is shaded with probability 1 − p, which
    /// cancels its Mix weight 1 − p). A Transparent alone passes always.
    pub fn split_transparent(&self) -> Option<(f32, SpectrumDesc, BsdfDesc)> {
        match self {
            BsdfDesc::Transparent { color } => Some((1.0, color.clone(), BsdfDesc::None)),
            BsdfDesc::Mix { a, b, factor, factor_from: None } => match (a.as_ref(), b.as_ref()) {
                (BsdfDesc::Transparent { color }, rest) => Some((1.0 - factor, color.clone(), rest.clone())),
                (rest, BsdfDesc::Transparent { color }) => Some((*factor, color.clone(), rest.clone())),
                _ => None,
            },
            _ => None,
        }
    }

    /// Whether a subsurface lobe is anywhere in this description (a Principled with a
    /// subsurface, or a graph's Principled with a Subsurface Weight set or linked).
    pub fn has_subsurface(&self) -> bool {
        match self {
            BsdfDesc::Principled { subsurface, .. } => subsurface.as_ref().is_some_and(|s| s.weight > 0.0),
            BsdfDesc::Mix { a, b, .. } | BsdfDesc::Add { a, b } => a.has_subsurface() || b.has_subsurface(),
            BsdfDesc::Tint { bsdf, .. } | BsdfDesc::Oriented { bsdf, .. } => bsdf.has_subsurface(),
            BsdfDesc::Graph(g) => g.nodes.iter().any(|n| {
                n.kind == "ShaderNodeBsdfPrincipled"
                    && match n.inputs.get("Subsurface Weight") {
                        Some(crate::shading::InputDesc::Number(x)) => *x > 0.0,
                        Some(crate::shading::InputDesc::Link { .. }) => true,
                        _ => false,
                    }
            }),
            _ => false,
        }
    }

    /// Whether a Transparent BSDF is anywhere in this description.
    pub fn has_transparent(&self) -> bool {
        match self {
            BsdfDesc::Transparent { .. } => true,
            BsdfDesc::Mix { a, b, .. } | BsdfDesc::Add { a, b } => a.has_transparent() || b.has_transparent(),
            BsdfDesc::Tint { bsdf, .. } | BsdfDesc::Oriented { bsdf, .. } => bsdf.has_transparent(),
            _ => false,
        }
    }
}

/// The Principled BSDF's Coat (Cycles' `svm_node_closure_bsdf`, second layer): a GGX
/// dielectric reflection of index `ior` and `roughness` with weight `weight`, whose
/// `tint` absorbs the light reaching the layers below (Beer's law along the refracted
/// view ray, the tint being the transmittance at normal incidence).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoatDesc {
    #[serde(default = "one")]
    pub weight: f32,
    #[serde(default = "default_coat_roughness")]
    pub roughness: f32,
    #[serde(default = "default_coat_ior")]
    pub ior: f32,
    /// White when absent.
    #[serde(default)]
    pub tint: Option<SpectrumDesc>,
}

/// The Principled BSDF's lobes' own normals in the vertex's shading frame (a graph's
/// Normal and Coat Normal at a hit; None: the frame's own normal): specular, metal,
/// glass and subsurface are oriented about `base` (the valid Normal), the diffuse about
/// `diffuse` (the Normal as given), the coat and the sheen about theirs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PrincipledNormals {
    pub base: Option<[f32; 3]>,
    pub diffuse: Option<[f32; 3]>,
    /// The smooth normal, when the diffuse's is not it (Cycles' bump shadowing term).
    pub smooth: Option<[f32; 3]>,
    pub coat: Option<[f32; 3]>,
    pub sheen: Option<[f32; 3]>,
    /// The anisotropic lobes' tangent (a graph's Tangent input, in the vertex's frame).
    pub tangent: Option<[f32; 3]>,
}

/// The Principled BSDF's Sheen (Cycles' first layer): the microfibre sheen of
/// `roughness`, scaled by `weight` × `tint`, over the coat and everything else.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SheenLayerDesc {
    #[serde(default = "one")]
    pub weight: f32,
    #[serde(default = "half")]
    pub roughness: f32,
    /// White when absent.
    #[serde(default)]
    pub tint: Option<SpectrumDesc>,
}

/// The Principled BSDF's Subsurface (Cycles' random-walk BSSRDF, docs/materials.md):
/// `weight` of the base scatters inside the mesh with mean free path from `radius`
/// (per Rec.709 channel, made a spectrum by the uplift) × `scale` (scene units), base
/// colour as its multiple-scattering albedo, Henyey–Greenstein `anisotropy` inside.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SubsurfaceDesc {
    #[serde(default = "one")]
    pub weight: f32,
    #[serde(default = "default_subsurface_radius")]
    pub radius: [f32; 3],
    #[serde(default = "default_subsurface_scale")]
    pub scale: f32,
    /// The entry's index for `random_walk_skin` (`random_walk` enters through the
    /// Principled's `ior`, as Cycles).
    #[serde(default = "default_subsurface_ior")]
    pub ior: f32,
    #[serde(default)]
    pub anisotropy: f32,
    /// `random_walk` (Blender's default) or `random_walk_skin`.
    #[serde(default = "default_subsurface_method")]
    pub method: String,
}

fn default_subsurface_radius() -> [f32; 3] {
    [1.0, 0.2, 0.1]
}

fn default_subsurface_scale() -> f32 {
    0.05
}

fn default_subsurface_ior() -> f32 {
    1.4
}

fn default_subsurface_method() -> String {
    "random_walk".into()
}

impl Default for SubsurfaceDesc {
    fn default() -> Self {
        Self {
            weight: 1.0,
            radius: default_subsurface_radius(),
            scale: default_subsurface_scale(),
            ior: default_subsurface_ior(),
            anisotropy: 0.0,
            method: default_subsurface_method(),
        }
    }
}

fn one() -> f32 {
    1.0
}

fn default_coat_roughness() -> f32 {
    0.03
}

fn default_coat_ior() -> f32 {
    1.5
}

/// A view-dependent Mix Shader factor, as Blender's nodes compute it.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MixFactorDesc {
    /// Fresnel node: dielectric reflectance at `ior`.
    Fresnel { ior: f32 },
    /// Layer Weight node, Fresnel output.
    LayerWeightFresnel { blend: f32 },
    /// Layer Weight node, Facing output.
    LayerWeightFacing { blend: f32 },
}

fn default_base_color() -> SpectrumDesc {
    SpectrumDesc::constant(0.8)
}

fn half() -> f32 {
    0.5
}

fn default_thin_film_ior() -> f32 {
    1.33
}

impl Default for BsdfDesc {
    fn default() -> Self {
        BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.8) }
    }
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    pub name: String,
    /// Buffer of V×3 f32 positions.
    pub vertices: usize,
    /// Buffer of T×3 u32 vertex indices.
    pub triangles: usize,
    /// Buffer of V×3 f32 per-vertex normals.
    #[serde(default)]
    pub normals: Option<usize>,
    /// Buffer of V×2 f32 per-vertex texture coordinates.
    #[serde(default)]
    pub uvs: Option<usize>,
    /// Buffer of T u32 material indices, one per triangle...
    #[serde(default)]
    pub material_ids: Option<usize>,
    /// ...or one material for the whole mesh (default: material 0).
    #[serde(default)]
    pub material: Option<u32>,
    /// A deforming mesh (motion blur): buffers of V×3 f32 positions at keys evenly
    /// spaced over the shutter, open to close (at least 2; empty: rigid).
    #[serde(default)]
    pub motion_vertices: Vec<usize>,
    /// Per-vertex normals at the same keys (optional).
    #[serde(default)]
    pub motion_normals: Vec<usize>,
    /// Named UV maps (V×2 f32 buffers) for shading graphs (docs/shading.md).
    #[serde(default)]
    pub uv_maps: std::collections::BTreeMap<String, usize>,
    /// Colour attributes (V×4 or V×3 f32 linear RGBA).
    #[serde(default)]
    pub colors: std::collections::BTreeMap<String, usize>,
    /// Generic attributes (V×1, V×3 or V×4 f32).
    #[serde(default)]
    pub attributes: std::collections::BTreeMap<String, usize>,
    /// V×4 f32: tangent xyz and bitangent sign (MikkTSpace) of the default UV map.
    #[serde(default)]
    pub tangents: Option<usize>,
    /// V×4 f32 tangent sets of named UV maps (what a Normal Map's or Tangent node's UV
    /// map reads; a map without one reads the default `tangents`).
    #[serde(default)]
    pub tangent_maps: std::collections::BTreeMap<String, usize>,
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstanceDesc {
    #[serde(default)]
    pub name: String,
    pub mesh: u32,
    /// Object → world, row-major 4×4.
    pub transform: [[f32; 4]; 4],
    /// Motion blur: object → world at keys evenly spaced over the shutter, open to
    /// close (at least 2; empty: the instance stands still at `transform`).
    #[serde(default)]
    pub motion: Vec<[[f32; 4]; 4]>,
    /// The kinds of rays that see it (Cycles' ray visibility; all when absent).
    #[serde(default)]
    pub visibility: crate::geometry::visibility::VisibilityDesc,
    /// Object Info › Random in 0..1 (default: Cycles' hash of `name`).
    #[serde(default)]
    pub random: Option<f32>,
    /// Cycles' object holdout (Object › Visibility › Holdout, a view layer's holdout
    /// collections): camera paths that reach it with only transparent bounces make the
    /// pixel transparent there, as a Holdout closure of weight 1 would; every other ray
    /// sees its material (docs/materials.md#holdout).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub holdout: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightDesc {
    /// Radiant intensity per wavelength (W·sr⁻¹·nm⁻¹ in scene units) from a point, or
    /// with `radius` > 0 from a sphere of uniform radiance intensity / (π r²) (soft
    /// shadows; Blender's point light radius, UsdLux SphereLight).
    Point {
        name: String,
        position: [f32; 3],
        intensity: SpectrumDesc,
        #[serde(default)]
        radius: f32,
        /// The kinds of rays that see it and whose bounces it lights (Cycles' light ray
        /// visibility): diffuse, glossy, transmission (on by default); camera (off by
        /// default: rays from the camera see a sun's disk or a sphere light only with
        /// it); shadow does not apply.
        #[serde(default)]
        visibility: crate::geometry::visibility::LightVisibilityDesc,
        /// Scales the intensity per direction (an IES profile).
        #[serde(default)]
        profile: Option<ProfileDesc>,
        /// Light → world keys evenly spaced over the shutter (motion blur, as an
        /// instance's `motion`; empty: it stands still). The light as described is where
        /// it is at the current frame; it moves rigidly with the keys' rotation and
        /// translation (their scale is dropped).
        #[serde(default)]
        motion: Vec<[[f32; 4]; 4]>,
    },
    /// Blender's spot light: radiant intensity on the axis, cone of full angle
    /// `spot_size` (radians, default 45°), edge softened over `spot_blend` (default 0.15).
    Spot {
        name: String,
        position: [f32; 3],
        /// The direction light travels (the lamp's −Z axis in Blender).
        direction: [f32; 3],
        intensity: SpectrumDesc,
        #[serde(default = "default_spot_size")]
        spot_size: f32,
        #[serde(default = "default_spot_blend")]
        spot_blend: f32,
        /// Radius of the emitting sphere (0: a point), as for `Point`.
        #[serde(default)]
        radius: f32,
        /// The kinds of rays that see it and whose bounces it lights (Cycles' light ray
        /// visibility): diffuse, glossy, transmission (on by default); camera (off by
        /// default: rays from the camera see a sun's disk or a sphere light only with
        /// it); shadow does not apply.
        #[serde(default)]
        visibility: crate::geometry::visibility::LightVisibilityDesc,
        /// Scales the intensity per direction (an IES profile).
        #[serde(default)]
        profile: Option<ProfileDesc>,
        /// Light → world keys evenly spaced over the shutter (motion blur, as an
        /// instance's `motion`; empty: it stands still). The light as described is where
        /// it is at the current frame; it moves rigidly with the keys' rotation and
        /// translation (their scale is dropped).
        #[serde(default)]
        motion: Vec<[[f32; 4]; 4]>,
    },
    /// A sun: light travelling along `direction` with spectral irradiance on a surface
    /// facing it, from a disk of directions of angular diameter `angle` (radians, 0:
    /// parallel rays; Blender's sun angle).
    Distant {
        name: String,
        direction: [f32; 3],
        irradiance: SpectrumDesc,
        #[serde(default)]
        angle: f32,
        /// The kinds of rays that see it and whose bounces it lights (Cycles' light ray
        /// visibility): diffuse, glossy, transmission (on by default); camera (off by
        /// default: rays from the camera see a sun's disk or a sphere light only with
        /// it); shadow does not apply.
        #[serde(default)]
        visibility: crate::geometry::visibility::LightVisibilityDesc,
        /// Light → world keys evenly spaced over the shutter, as a point light's: the
        /// sun turns with their rotation (its −Z axis the direction at each time; the
        /// translation does nothing to a light at infinity).
        #[serde(default)]
        motion: Vec<[[f32; 4]; 4]>,
    },
}

/// A goniometric profile (`light::Profile`): Cycles' processed IES table, angles in
/// radians (h ∈ [0, 2π], v ∈ [0, π] from the light's −Z), `values[i · len(v) + j]` at
/// (h[i], v[j]), and the light's orientation as the rows of the rotation from world to
/// the light's frame (identity: the light shines down world −Z).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileDesc {
    pub h_angles: Vec<f32>,
    pub v_angles: Vec<f32>,
    pub values: Vec<f32>,
    #[serde(default = "identity3")]
    pub to_local: [[f32; 3]; 3],
}

fn identity3() -> [[f32; 3]; 3] {
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
}

impl ProfileDesc {
    /// The profile, or an error naming the light.
    pub fn build(&self, light: &str) -> crate::error::Result<crate::light::Profile> {
        let m = glam::Mat3A::from_cols_array_2d(&self.to_local).transpose(); // rows given
        crate::light::Profile::new(self.h_angles.clone(), self.v_angles.clone(), self.values.clone(), m)
            .map_err(|e| crate::error::Error::object("light", light, e))
    }
}

fn default_spot_size() -> f32 {
    std::f32::consts::FRAC_PI_4
}

fn default_spot_blend() -> f32 {
    0.15
}

impl LightDesc {
    pub fn name(&self) -> &str {
        match self {
            LightDesc::Point { name, .. } => name,
            LightDesc::Spot { name, .. } => name,
            LightDesc::Distant { name, .. } => name,
        }
    }

    /// The light's motion keys over the shutter (empty: it stands still).
    pub fn motion(&self) -> &[[[f32; 4]; 4]] {
        match self {
            LightDesc::Point { motion, .. } | LightDesc::Spot { motion, .. } | LightDesc::Distant { motion, .. } => {
                motion
            }
        }
    }

    /// The light → world transform the description stands for (at the frame): its
    /// position, turned as its profile is (a spot without one: −Z along its direction;
    /// its turn about that axis changes nothing then).
    pub fn frame(&self) -> glam::Affine3A {
        use glam::{Affine3A, Mat3A, Vec3A};
        let (position, direction, profile) = match self {
            LightDesc::Point { position, profile, .. } => (*position, None, profile),
            LightDesc::Spot { position, direction, profile, .. } => (*position, Some(*direction), profile),
            LightDesc::Distant { direction, .. } => ([0.0; 3], Some(*direction), &None),
        };
        // `to_local`'s rows are the light's axes in world space.
        let rotation = match (profile, direction) {
            (Some(p), _) => Mat3A::from_cols_array_2d(&p.to_local),
            (None, Some(d)) => {
                let z = -Vec3A::from(d).normalize_or(Vec3A::NEG_Z);
                let (x, y) = z.any_orthonormal_pair();
                let x = if x.cross(y).dot(z) < 0.0 { -x } else { x };
                Mat3A::from_cols(x, y, z)
            }
            (None, None) => Mat3A::IDENTITY,
        };
        Affine3A { matrix3: rotation, translation: Vec3A::from(position) }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldDesc {
    /// Radiance arriving from every direction not blocked by geometry...
    #[serde(default)]
    pub radiance: Option<SpectrumDesc>,
    /// ...or an equirectangular RGB image (index into `textures`), Blender's
    /// Environment Texture in a Z-up world, which takes precedence.
    #[serde(default)]
    pub texture: Option<usize>,
    /// Multiplies the image's radiance (Blender's Background strength).
    #[serde(default = "one_f32")]
    pub strength: f32,
    /// Rotation of the image lookup about +Z in radians (Blender's Mapping node Z).
    #[serde(default)]
    pub rotation: f32,
    /// Sample the image ∝ luminance × sin θ (default); false samples uniformly.
    #[serde(default = "yes")]
    pub importance_sampling: bool,
    /// A homogeneous medium filling all space (Blender's World > Volume): it adds to the
    /// media of closed meshes, as Cycles keeps the world's volume on every path's stack.
    #[serde(default)]
    pub volume: Option<VolumeDesc>,
}

fn one_f32() -> f32 {
    1.0
}

fn yes() -> bool {
    true
}

/// How a spectrum of the scene description is used, for walks over all of them
/// ([`SceneDesc::for_each_spectrum`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// Emitted: a light's intensity or irradiance, a material's or medium's emission,
    /// the world's radiance.
    Emitter,
    /// A surface colour (reflectance, tint, base colour) or a colour input of a node graph.
    Surface,
    /// A medium's absorption or scattering coefficient.
    Coefficient,
    /// A conductor's complex index η or k.
    Index,
}

/// One item of a walk over a scene description's spectral data.
#[derive(Clone, Copy, Debug)]
pub enum SpectralItem<'a> {
    Spectrum(SpectrumUse, &'a SpectrumDesc),
    /// The index of refraction of a surface that refracts (a `dielectric`, a Principled
    /// with transmission, a graph's Glass or Refraction node).
    DielectricIor(&'a crate::material::IorDesc),
    /// RGB data that is not a spectrum of the description: an image (the world's HDRI),
    /// or a node graph's RGB colours (constants, Blender's defaults, computed values).
    RgbData,
}

impl SceneDesc {
    /// Calls `f` on every spectrum (and dielectric index) of the scene: materials, lights,
    /// world. Every variant is matched exhaustively, so a new one must say what it holds.
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        let SceneDesc {
            camera: _,
            materials,
            meshes: _,
            instances: _,
            lights,
            world,
            textures: _,
            film_transparent: _,
        } = self;
        for m in materials {
            m.for_each_spectrum(f);
        }
        for l in lights {
            l.for_each_spectrum(f);
        }
        if let Some(w) = world {
            w.for_each_spectrum(f);
        }
    }
}

impl MaterialDesc {
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        let MaterialDesc { name: _, bsdf, emission, volume, one_sided: _, see_through: _ } = self;
        bsdf.for_each_spectrum(f);
        if let Some(e) = emission {
            f(SpectralItem::Spectrum(SpectrumUse::Emitter, e));
        }
        if let Some(v) = volume {
            v.for_each_spectrum(f);
        }
    }
}

impl VolumeDesc {
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        let VolumeDesc { absorption, scattering, anisotropy: _, emission, density_grid: _ } = self;
        for s in [absorption, scattering].into_iter().flatten() {
            f(SpectralItem::Spectrum(SpectrumUse::Coefficient, s));
        }
        if let Some(e) = emission {
            f(SpectralItem::Spectrum(SpectrumUse::Emitter, e));
        }
    }
}

impl BsdfDesc {
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        use SpectralItem::Spectrum;
        use SpectrumUse::{Index, Surface};
        match self {
            BsdfDesc::Diffuse { reflectance }
            | BsdfDesc::Glossy { reflectance, .. }
            | BsdfDesc::RoughDiffuse { reflectance, roughness: _ } => f(Spectrum(Surface, reflectance)),
            BsdfDesc::Translucent { color }
            | BsdfDesc::Transparent { color }
            | BsdfDesc::Sheen { color, roughness: _ } => f(Spectrum(Surface, color)),
            BsdfDesc::Oriented { bsdf, .. } => bsdf.for_each_spectrum(f),
            BsdfDesc::Tint { color, bsdf } => {
                f(Spectrum(Surface, color));
                bsdf.for_each_spectrum(f);
            }
            BsdfDesc::None | BsdfDesc::Null => {}
            BsdfDesc::Dielectric { ior, roughness: _ } | BsdfDesc::Refraction { ior, .. } => {
                f(SpectralItem::DielectricIor(ior))
            }
            BsdfDesc::Metallic { eta, k, .. } => {
                f(Spectrum(Index, eta));
                f(Spectrum(Index, k));
            }
            BsdfDesc::Conductor { metal: _, eta, k, roughness: _ } => {
                for s in [eta, k].into_iter().flatten() {
                    f(Spectrum(Index, s));
                }
            }
            BsdfDesc::Principled { base_color, specular_tint, ior, transmission, coat, sheen, .. } => {
                f(Spectrum(Surface, base_color));
                let coat_tint = coat.as_ref().and_then(|c| c.tint.as_ref());
                let sheen_tint = sheen.as_ref().and_then(|s| s.tint.as_ref());
                for t in [specular_tint.as_ref(), coat_tint, sheen_tint].into_iter().flatten() {
                    f(Spectrum(Surface, t));
                }
                if *transmission > 0.0 {
                    f(SpectralItem::DielectricIor(ior));
                }
            }
            BsdfDesc::Mix { a, b, .. } | BsdfDesc::Add { a, b } => {
                a.for_each_spectrum(f);
                b.for_each_spectrum(f);
            }
            BsdfDesc::Graph(g) => g.for_each_spectrum(f),
        }
    }
}

impl crate::shading::GraphDesc {
    /// The graph's spectra (the compiler takes them on closure inputs only): as
    /// [`SpectrumUse::Emitter`] on an emission colour (Emission, Background, Principled
    /// Emission Color), as [`SpectrumUse::Surface`] elsewhere; the index of a refracting
    /// node (Glass, Refraction, Principled with transmission); and
    /// [`SpectralItem::RgbData`] once if any colour input is RGB (a constant, Blender's
    /// default, or a link: computed colours are RGB until the hit uplifts them) or a node
    /// is unknown.
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        use crate::shading::sockets::{spec, SocketType};
        use crate::shading::InputDesc;
        let mut rgb = false;
        for n in &self.nodes {
            match spec(&n.kind) {
                None => rgb = true,
                Some(ns) => {
                    for s in ns.inputs.iter().filter(|s| s.ty == SocketType::Color) {
                        rgb |= !matches!(n.inputs.get(s.id), Some(InputDesc::Spectrum { .. }));
                    }
                }
            }
            for (id, input) in &n.inputs {
                match input {
                    InputDesc::Spectrum { spectrum } => {
                        let emits = matches!(
                            (n.kind.as_str(), id.as_str()),
                            ("ShaderNodeEmission", "Color")
                                | ("ShaderNodeBackground", "Color")
                                | ("ShaderNodeBsdfPrincipled", "Emission Color")
                        );
                        let usage = if emits { SpectrumUse::Emitter } else { SpectrumUse::Surface };
                        f(SpectralItem::Spectrum(usage, spectrum));
                    }
                    InputDesc::Ior { ior } if refracts(n) => f(SpectralItem::DielectricIor(ior)),
                    InputDesc::Ior { .. } | InputDesc::Number(_) | InputDesc::Array(_) | InputDesc::Link { .. } => {}
                }
            }
        }
        if rgb {
            f(SpectralItem::RgbData);
        }
    }
}

/// Whether a graph node refracts, so a dispersive index on it collapses paths.
fn refracts(n: &crate::shading::NodeDesc) -> bool {
    use crate::shading::InputDesc;
    match n.kind.as_str() {
        "ShaderNodeBsdfGlass" | "ShaderNodeBsdfRefraction" => true,
        // Blender's default Transmission Weight is 0.
        "ShaderNodeBsdfPrincipled" => match n.inputs.get("Transmission Weight") {
            None => false,
            Some(InputDesc::Number(w)) => *w > 0.0,
            Some(_) => true,
        },
        _ => false,
    }
}

impl LightDesc {
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        let s = match self {
            LightDesc::Point { intensity, .. } | LightDesc::Spot { intensity, .. } => intensity,
            LightDesc::Distant { irradiance, .. } => irradiance,
        };
        f(SpectralItem::Spectrum(SpectrumUse::Emitter, s));
    }
}

impl WorldDesc {
    /// The world's radiance, its image (an HDRI) as RGB data, and its medium.
    pub fn for_each_spectrum(&self, f: &mut dyn FnMut(SpectralItem)) {
        let WorldDesc { radiance, texture, strength: _, rotation: _, importance_sampling: _, volume } = self;
        if let Some(r) = radiance {
            f(SpectralItem::Spectrum(SpectrumUse::Emitter, r));
        }
        if let Some(v) = volume {
            v.for_each_spectrum(f);
        }
        if texture.is_some() {
            f(SpectralItem::RgbData);
        }
    }
}
