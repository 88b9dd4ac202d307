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
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    pub name: String,
    #[serde(default)]
    pub bsdf: BsdfDesc,
    /// Emitted radiance (both faces); makes every triangle using it an area light.
    #[serde(default)]
    pub emission: Option<SpectrumDesc>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum BsdfDesc {
    Diffuse { reflectance: SpectrumDesc },
    /// Reflects nothing (an emission-only surface).
    None,
}

impl Default for BsdfDesc {
    fn default() -> Self {
        BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.8) }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
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
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstanceDesc {
    #[serde(default)]
    pub name: String,
    pub mesh: u32,
    /// Object → world, row-major 4×4.
    pub transform: [[f32; 4]; 4],
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightDesc {
    /// Radiant intensity per wavelength (W·sr⁻¹·nm⁻¹ in scene units) from a point.
    Point { name: String, position: [f32; 3], intensity: SpectrumDesc },
}

impl LightDesc {
    pub fn name(&self) -> &str {
        match self {
            LightDesc::Point { name, .. } => name,
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldDesc {
    /// Radiance arriving from every direction not blocked by geometry.
    pub radiance: SpectrumDesc,
}
