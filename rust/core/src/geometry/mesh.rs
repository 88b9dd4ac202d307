//! Triangle meshes (object space) and their instances (object → world transforms).

use super::motion::{TransformMotion, VertexMotion};
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
    /// A deforming mesh: vertex positions (and normals) at keys over the shutter.
    pub motion: Option<VertexMotion>,
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
            motion: None,
        })
    }

    /// Makes the mesh deform over the shutter: `keys` are vertex positions (V×3 floats
    /// each) evenly spaced from shutter open to close, `normal_keys` optionally the
    /// normals at the same keys. Errors name the mesh.
    pub fn set_motion(&mut self, keys: &[&[f32]], normal_keys: Option<&[&[f32]]>) -> Result<()> {
        let bad = |p: String| Error::object("mesh", &self.name, p);
        if keys.len() < 2 {
            return Err(bad(format!("vertex motion needs at least 2 keys, got {}", keys.len())));
        }
        let nv = self.positions.len();
        let read = |k: usize, v: &[f32], what: &str| -> Result<Vec<Vec3A>> {
            if v.len() != nv * 3 {
                return Err(bad(format!("{what} key {k} has {} floats for {nv} vertices", v.len())));
            }
            if let Some(i) = v.iter().position(|x| !(x.is_finite() && x.abs() <= MAX_COORDINATE)) {
                return Err(bad(format!(
                    "{what} key {k}: vertex {} is not finite or beyond ±{MAX_COORDINATE:e}",
                    i / 3
                )));
            }
            Ok(v.chunks_exact(3).map(|c| Vec3A::new(c[0], c[1], c[2])).collect())
        };
        let positions = keys.iter().enumerate().map(|(k, v)| read(k, v, "vertex motion")).collect::<Result<_>>()?;
        let normals = match normal_keys {
            None => None,
            Some(n) if n.len() != keys.len() => {
                return Err(bad(format!("{} normal keys for {} vertex motion keys", n.len(), keys.len())));
            }
            Some(n) => Some(
                n.iter()
                    .enumerate()
                    .map(|(k, v)| {
                        read(k, v, "normal motion").map(|n| n.into_iter().map(|x| x.normalize_or_zero()).collect())
                    })
                    .collect::<Result<_>>()?,
            ),
        };
        self.motion = Some(VertexMotion { positions, normals });
        Ok(())
    }

    /// Triangle `i` at shutter time `time` (its rest position when it does not deform).
    #[inline]
    pub fn triangle_at(&self, i: usize, time: f32) -> [Vec3A; 3] {
        match &self.motion {
            None => self.triangle(i),
            Some(m) => self.indices[i].map(|v| m.position(v as usize, time)),
        }
    }

    /// Every position any vertex takes (the rest positions, or all motion keys: linear
    /// interpolation stays inside their hull).
    pub fn all_positions(&self) -> Box<dyn Iterator<Item = Vec3A> + '_> {
        match &self.motion {
            None => Box::new(self.positions.iter().copied()),
            Some(m) => Box::new(m.positions.iter().flatten().copied()),
        }
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
    /// Object → world over the shutter, when the instance moves (then `to_world` is its
    /// transform at the frame itself, for what needs one placement).
    pub motion: Option<TransformMotion>,
    /// The kinds of rays that see it (`visibility::ALL` unless the scene says otherwise).
    pub visibility: u8,
    /// Object Info › Random: Cycles' `hash_uint2(hash_string(name), 0)` over 2³² − 1
    /// (scene/object.cpp `random_number`), unless the scene gives one (Blender's
    /// instances: their `random_id`).
    pub random: f32,
    /// Cycles' object holdout (`SD_OBJECT_HOLDOUT_MASK`): camera paths with only
    /// transparent bounces hold out where they reach it.
    pub holdout: bool,
}

/// Cycles' `hash_string` (util/hash.h): i = 37·i + byte.
fn hash_string(s: &str) -> u32 {
    s.bytes().fold(0u32, |i, c| i.wrapping_mul(37).wrapping_add(c as u32))
}

/// Cycles' object random number of an object named `name` (see [`Instance::random`]).
pub fn object_random(name: &str) -> f32 {
    (crate::procedural::hash::hash_uint2(hash_string(name), 0) as f64 / u32::MAX as f64) as f32
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
        Ok(Self {
            name: name.to_string(),
            mesh,
            to_world,
            to_object,
            normal_to_world: to_object.matrix3.transpose(),
            motion: None,
            visibility: super::visibility::ALL,
            random: object_random(name),
            holdout: false,
        })
    }

    /// An instance moving through transform `keys` evenly spaced over the shutter;
    /// `to_world` is its placement at the frame.
    pub fn with_motion(name: &str, mesh: u32, to_world: Affine3A, keys: &[Affine3A]) -> Result<Self> {
        let mut inst = Self::new(name, mesh, to_world)?;
        inst.motion = Some(TransformMotion::new("instance", name, keys)?);
        Ok(inst)
    }

    /// Object → world, world → object and the normal transform at shutter time `time`.
    #[inline]
    pub fn transforms_at(&self, time: f32) -> (Affine3A, Affine3A, Mat3A) {
        match &self.motion {
            None => (self.to_world, self.to_object, self.normal_to_world),
            Some(m) => {
                let w = m.at(time);
                let o = w.inverse();
                (w, o, o.matrix3.transpose())
            }
        }
    }

    /// World → object at shutter time `time`.
    #[inline]
    pub fn to_object_at(&self, time: f32) -> Affine3A {
        match &self.motion {
            None => self.to_object,
            Some(m) => m.at(time).inverse(),
        }
    }
}
