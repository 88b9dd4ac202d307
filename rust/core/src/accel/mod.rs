//! Two-level acceleration structure: one compressed-wide BVH (obvhs CwBvh) per mesh in
//! object space, and one over the instances in world space. Instances of one mesh
//! share its BVH and triangles.
//!
//! Motion blur (docs/camera.md): a moving instance's box in the top level bounds it over
//! the whole shutter and rays are taken into its object space as it is at their time; a
//! deforming mesh's boxes bound each triangle over all its motion keys (linear
//! interpolation stays inside them) and the triangle is interpolated at the ray's time.

use crate::geometry::motion::key_span;
use crate::geometry::triangle::WatertightRay;
use crate::geometry::visibility;
use crate::geometry::{Instance, Mesh, Ray};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use std::time::Duration;

/// The closest intersection of a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub instance: u32,
    /// Triangle index in the mesh (the caller's numbering, not the BVH's).
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third vertex.
    pub b1: f32,
    pub b2: f32,
}

struct MeshBvh {
    bvh: CwBvh,
    /// Triangles in BVH leaf order, so traversal reads them without indirection.
    triangles: Vec<[Vec3A; 3]>,
    /// A deforming mesh: the triangles at each motion key, in leaf order.
    motion: Option<Vec<Vec<[Vec3A; 3]>>>,
}

impl MeshBvh {
    /// Leaf triangle `i` at shutter time `time`.
    #[inline]
    fn triangle(&self, i: usize, time: f32) -> [Vec3A; 3] {
        match &self.motion {
            None => self.triangles[i],
            Some(keys) => {
                let (a, b, w) = key_span(keys.len(), time);
                let (ta, tb) = (keys[a][i], keys[b][i]);
                [ta[0].lerp(tb[0], w), ta[1].lerp(tb[1], w), ta[2].lerp(tb[2], w)]
            }
        }
    }
}

pub struct Accel {
    meshes: Vec<Option<MeshBvh>>,
    /// Over instances whose mesh has triangles; leaf ids index `tlas_instances`.
    tlas: Option<CwBvh>,
    tlas_instances: Vec<u32>,
}

/// Large meshes use obvhs's fast preset: on 1M triangles it builds about twice as fast
/// as the medium one for a few percent of traversal speed, which keeps interactive
/// re-exports (Blender's viewport) responsive.
fn build_params_for(primitives: usize) -> BvhBuildParams {
    if primitives > 200_000 {
        BvhBuildParams::fast_build()
    } else {
        BvhBuildParams::medium_build()
    }
}

impl Accel {
    pub fn build(meshes: &[Mesh], instances: &[Instance]) -> Self {
        let mesh_bvhs: Vec<Option<MeshBvh>> = meshes
            .par_iter()
            .map(|m| {
                if m.indices.is_empty() {
                    return None;
                }
                let keys = m.motion.as_ref().map_or(0, |v| v.key_count());
                let aabbs: Vec<Aabb> = (0..m.indices.len())
                    .map(|i| {
                        let [a, b, c] = m.triangle(i);
                        let mut bb = Aabb::new(a.min(b).min(c), a.max(b).max(c));
                        for k in 0..keys {
                            for p in m.triangle_at(i, k as f32 / (keys - 1) as f32) {
                                bb.extend(p);
                            }
                        }
                        bb
                    })
                    .collect();
                let bvh = build_cwbvh(&aabbs, build_params_for(aabbs.len()), &mut Duration::default());
                let triangles = bvh.primitive_indices.iter().map(|&i| m.triangle(i as usize)).collect();
                let motion = m.motion.as_ref().map(|v| {
                    (0..v.key_count())
                        .map(|k| {
                            bvh.primitive_indices
                                .iter()
                                .map(|&i| m.indices[i as usize].map(|j| v.positions[k][j as usize]))
                                .collect()
                        })
                        .collect()
                });
                Some(MeshBvh { bvh, triangles, motion })
            })
            .collect();
        let mut tlas_instances = Vec::new();
        let mut boxes = Vec::new();
        for (k, inst) in instances.iter().enumerate() {
            if let Some(mb) = &mesh_bvhs[inst.mesh as usize] {
                tlas_instances.push(k as u32);
                boxes.push(transform_aabb(&mb.bvh.total_aabb, inst));
            }
        }
        let tlas = if boxes.is_empty() {
            None
        } else {
            Some(build_cwbvh(&boxes, build_params_for(boxes.len()), &mut Duration::default()))
        };
        let tlas_instances = match &tlas {
            Some(t) => t.primitive_indices.iter().map(|&i| tlas_instances[i as usize]).collect(),
            None => Vec::new(),
        };
        Self { meshes: mesh_bvhs, tlas, tlas_instances }
    }

    /// Closest hit along `ray` within (tmin, tmax).
    pub fn intersect(&self, instances: &[Instance], ray: &Ray) -> Option<Hit> {
        let tlas = self.tlas.as_ref()?;
        let mut best: Option<Hit> = None;
        let mut hit = RayHit::none();
        let world_ray = bvh_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        tlas.ray_traverse(world_ray, &mut hit, |r, slot| {
            let inst_id = self.tlas_instances[slot];
            let inst = &instances[inst_id as usize];
            if !visibility::sees(inst.visibility, ray.kind) {
                return f32::INFINITY; // the ray goes on through instances its kind does not see
            }
            let mb = self.meshes[inst.mesh as usize].as_ref().expect("tlas holds meshes with triangles");
            // Object space: the direction is not renormalised, so t is the same in both spaces.
            let to_object = inst.to_object_at(ray.time);
            let o = to_object.transform_point3a(r.origin);
            let d = to_object.transform_vector3a(r.direction);
            let wt = WatertightRay::new(o, d);
            let local = bvh_ray(o, d, r.tmin, r.tmax);
            let mut local_hit = RayHit::none();
            let mut bary = (0.0, 0.0);
            mb.bvh.ray_traverse(local, &mut local_hit, |lr, tri| {
                let [a, b, c] = mb.triangle(tri, ray.time);
                match wt.intersect(a, b, c, lr.tmin, lr.tmax) {
                    Some((t, b1, b2)) => {
                        bary = (b1, b2);
                        t
                    }
                    None => f32::INFINITY,
                }
            });
            if local_hit.t < r.tmax {
                // `bary` belongs to the last accepted hit, which is the closest.
                best = Some(Hit {
                    t: local_hit.t,
                    instance: inst_id,
                    triangle: mb.bvh.primitive_indices[local_hit.primitive_id as usize],
                    b1: bary.0,
                    b2: bary.1,
                });
                local_hit.t
            } else {
                f32::INFINITY
            }
        });
        best
    }

    /// Whether anything blocks `ray` within (tmin, tmax): for shadow rays.
    pub fn occluded(&self, instances: &[Instance], ray: &Ray) -> bool {
        let Some(tlas) = self.tlas.as_ref() else { return false };
        let world_ray = bvh_ray(ray.origin, ray.direction, ray.tmin, ray.tmax);
        !tlas.ray_traverse_miss(world_ray, |r, slot| {
            let inst = &instances[self.tlas_instances[slot] as usize];
            if !visibility::sees(inst.visibility, ray.kind) {
                return f32::INFINITY;
            }
            let mb = self.meshes[inst.mesh as usize].as_ref().expect("tlas holds meshes with triangles");
            let to_object = inst.to_object_at(ray.time);
            let o = to_object.transform_point3a(r.origin);
            let d = to_object.transform_vector3a(r.direction);
            let wt = WatertightRay::new(o, d);
            let local = bvh_ray(o, d, r.tmin, r.tmax);
            let miss = mb.bvh.ray_traverse_miss(local, |lr, tri| {
                let [a, b, c] = mb.triangle(tri, ray.time);
                wt.intersect(a, b, c, lr.tmin, lr.tmax).map_or(f32::INFINITY, |h| h.0)
            });
            if miss {
                f32::INFINITY
            } else {
                r.tmin.max(0.0)
            }
        })
    }
}

/// obvhs picks slab ends by `direction < 0` but inverts −0.0 to −1/ε, so a
/// component of −0.0 makes every box miss. Adding +0.0 turns −0.0 into +0.0.
fn bvh_ray(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> BvhRay {
    BvhRay::new(origin, direction + Vec3A::ZERO, tmin, tmax)
}

/// The world box of an instance's object-space box `b`, over the whole shutter when it
/// moves.
fn transform_aabb(b: &Aabb, inst: &Instance) -> Aabb {
    if let Some(m) = &inst.motion {
        let (lo, hi) = m.bounds(b.min, b.max);
        return Aabb::new(lo, hi);
    }
    let mut out = Aabb::empty();
    for k in 0..8 {
        let p = Vec3A::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        out.extend(inst.to_world.transform_point3a(p));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Affine3A;

    fn quad(name: &str) -> Mesh {
        Mesh::from_buffers(
            name,
            &[-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0],
            &[0, 1, 2, 0, 2, 3],
            None,
            None,
            &[0, 0],
        )
        .unwrap()
    }

    #[test]
    fn instances_share_a_mesh_and_are_hit_in_world_space() {
        let meshes = vec![quad("q")];
        let instances = vec![
            Instance::new("near", 0, Affine3A::from_translation(glam::Vec3::new(0.0, 0.0, 1.0))).unwrap(),
            Instance::new(
                "far",
                0,
                Affine3A::from_scale_rotation_translation(
                    glam::Vec3::splat(3.0),
                    glam::Quat::IDENTITY,
                    glam::Vec3::new(0.0, 0.0, -2.0),
                ),
            )
            .unwrap(),
        ];
        let accel = Accel::build(&meshes, &instances);
        let ray = Ray::new(Vec3A::new(0.2, 0.3, 5.0), Vec3A::new(0.0, 0.0, -1.0));
        let h = accel.intersect(&instances, &ray).unwrap();
        assert_eq!(h.instance, 0);
        assert!((h.t - 4.0).abs() < 1e-5);
        // Outside the near quad but inside the scaled far one.
        let ray = Ray::new(Vec3A::new(2.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0));
        let h = accel.intersect(&instances, &ray).unwrap();
        assert_eq!(h.instance, 1);
        assert!((h.t - 7.0).abs() < 1e-5);
        assert!(accel.occluded(&instances, &Ray::segment(Vec3A::new(2.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0), 8.0)));
        assert!(!accel.occluded(&instances, &Ray::segment(Vec3A::new(2.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0), 6.0)));
        assert!(accel
            .intersect(&instances, &Ray::new(Vec3A::new(9.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0)))
            .is_none());
    }

    #[test]
    fn negative_zero_direction_components_still_hit() {
        let meshes = vec![quad("q")];
        let instances = vec![Instance::new("q", 0, Affine3A::IDENTITY).unwrap()];
        let accel = Accel::build(&meshes, &instances);
        let ray = Ray::new(Vec3A::new(0.1, 0.2, 5.0), Vec3A::new(-0.0, -0.0, -1.0));
        assert!(accel.intersect(&instances, &ray).is_some());
        assert!(accel.occluded(&instances, &ray));
    }

    #[test]
    fn empty_scene_has_no_hits() {
        let accel = Accel::build(&[], &[]);
        assert!(accel.intersect(&[], &Ray::new(Vec3A::ZERO, Vec3A::Z)).is_none());
        assert!(!accel.occluded(&[], &Ray::new(Vec3A::ZERO, Vec3A::Z)));
    }
}
