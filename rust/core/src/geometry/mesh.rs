//! Triangle meshes (object space) and their instances (object → world transforms).

use crate::{Error, Result};
use glam::{Affine3A, Mat3A, Vec2, Vec3A};

/// Largest coordinate magnitude a mesh vertex may have, in object or world space.
pub const MAX_COORDINATE: f32 = 1e12;

#[derive(Clone, Debug)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3A>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals, unit length (absent: flat shading).
    pub normals: Option<Vec<Vec3A>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<Vec2>>,
    /// Per-triangle index into the scene's materials.
    pub material_ids: Vec<u32>,
}

impl Mesh {
    /// Builds and validates a mesh from flat buffers; errors name the mesh.
    pub fn from_buffers(
        name: &str,
        positions: &[f32],
        indices: &[u32],
        normals: Option<&[f32]>,
        uvs: Option<&[f32]>,
        material_ids: &[u32],
    ) -> Result<Self> {
        let bad = |p: String| Error::object("mesh", name, p);
        if !positions.len().is_multiple_of(3) {
            return Err(bad(format!("vertices have {} floats, not a multiple of 3", positions.len())));
        }
        if !indices.len().is_multiple_of(3) {
            return Err(bad(format!("triangles have {} indices, not a multiple of 3", indices.len())));
        }
        let nv = positions.len() / 3;
        let nt = indices.len() / 3;
        if let Some(i) = positions.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("vertex {} has a non-finite coordinate ({})", i / 3, positions[i])));
        }
        // Beyond this magnitude the BVH's box extents and areas overflow f32 (obvhs then
        // panics building its compressed nodes: found by the scene-builder proptest), and
        // no ray could resolve the geometry anyway (one ulp at 1e12 is 65536 units).
        if let Some(i) = positions.iter().position(|v| v.abs() > MAX_COORDINATE) {
            return Err(bad(format!(
                "vertex {} has a coordinate {:e} beyond ±{MAX_COORDINATE:e}",
                i / 3,
                positions[i]
            )));
        }
        if let Some(i) = indices.iter().position(|&k| k as usize >= nv) {
            return Err(bad(format!(
                "triangle {} refers to vertex {} but the mesh has {nv} vertices",
                i / 3,
                indices[i]
            )));
        }
        if material_ids.len() != nt {
            return Err(bad(format!("{} material ids for {nt} triangles", material_ids.len())));
        }
        let positions: Vec<Vec3A> = positions.chunks_exact(3).map(|c| Vec3A::new(c[0], c[1], c[2])).collect();
        let normals = match normals {
            None => None,
            Some(n) => {
                if n.len() != nv * 3 {
                    return Err(bad(format!("{} normal floats for {nv} vertices", n.len())));
                }
                if let Some(i) = n.iter().position(|v| !v.is_finite()) {
                    return Err(bad(format!("normal {} is not finite", i / 3)));
                }
                // A zero normal cannot shade; such vertices fall back to the face normal.
                Some(n.chunks_exact(3).map(|c| Vec3A::new(c[0], c[1], c[2]).normalize_or_zero()).collect())
            }
        };
        let uvs = match uvs {
            None => None,
            Some(uv) => {
                if uv.len() != nv * 2 {
                    return Err(bad(format!("{} uv floats for {nv} vertices", uv.len())));
                }
                if let Some(i) = uv.iter().position(|v| !v.is_finite()) {
                    return Err(bad(format!("uv {} is not finite", i / 2)));
                }
                Some(uv.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect())
            }
        };
        Ok(Self {
            name: name.to_string(),
            positions,
            indices: indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            normals,
            uvs,
            material_ids: material_ids.to_vec(),
        })
    }

    pub fn triangle(&self, i: usize) -> [Vec3A; 3] {
        let [a, b, c] = self.indices[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }
}

/// A placement of a mesh in the world. Many instances share one mesh.
#[derive(Clone, Debug)]
pub struct Instance {
    pub name: String,
    pub mesh: u32,
    pub to_world: Affine3A,
    pub to_object: Affine3A,
    /// Transforms normals: the inverse transpose of the linear part.
    pub normal_to_world: Mat3A,
}

impl Instance {
    pub fn new(name: &str, mesh: u32, to_world: Affine3A) -> Result<Self> {
        let bad = |p: &str| Error::object("instance", name, p);
        if !to_world.is_finite() {
            return Err(bad("transform is not finite"));
        }
        let det = to_world.matrix3.determinant();
        if det == 0.0 || !det.is_finite() {
            return Err(bad("transform is singular (zero scale?)"));
        }
        let to_object = to_world.inverse();
        Ok(Self { name: name.to_string(), mesh, to_world, to_object, normal_to_world: to_object.matrix3.transpose() })
    }
}
