//! Two-level acceleration structure: one compressed-wide BVH (obvhs CwBvh) per mesh in
//! object space, and one over the instances in world space. Instances of one mesh
//! share its BVH and triangles. Rays walk them with obvhs's traversal loop and our own
//! node test (`traverse`: obvhs 0.4's culls boxes left before t = 1e-4).
//!
//! Motion blur (docs/camera.md): a moving instance's box in the top level bounds it over
//! the whole shutter and rays are taken into its object space as it is at their time; a
//! deforming mesh's boxes bound each triangle over all its motion keys (linear
//! interpolation stays inside them) and the triangle is interpolated at the ray's time.

use crate::geometry::triangle::WatertightRay;
use crate::geometry::visibility;
use crate::geometry::{Instance, Mesh, Ray};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::CwBvh;
use obvhs::ploc::PlocBuilder;
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use std::sync::Mutex;

mod balanced;
mod convert;
mod traverse;

#[cfg(test)]
mod degenerate_tests;

use traverse::TRay;

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

/// One BVH over (a chunk of) a mesh's triangles. Traversal reads the triangles from
/// the mesh itself (its index and position arrays), so the structure keeps no copy of
/// them: 12 bytes per triangle (wide nodes and leaf order) instead of 60.
struct MeshBvh {
    /// `bvh.primitive_indices` holds the mesh's triangle index of each leaf slot.
    bvh: CwBvh,
}

impl MeshBvh {
    /// The BVH over the mesh's triangles `ids` (all of them when None), built with
    /// `params` in the buffers of `ws`.
    fn build(ws: &mut Workspace, m: &Mesh, ids: Option<&[u32]>, params: BvhBuildParams) -> Self {
        let count = ids.map_or(m.indices.len(), |v| v.len());
        let mesh_index = |k: usize| ids.map_or(k, |v| v[k] as usize);
        let keys = m.motion.as_ref().map_or(0, |v| v.key_count());
        ws.aabbs.clear();
        ws.aabbs.extend((0..count).map(|k| {
            let i = mesh_index(k);
            let [a, b, c] = m.triangle(i);
            let mut bb = Aabb::new(a.min(b).min(c), a.max(b).max(c));
            for k in 0..keys {
                for p in m.triangle_at(i, k as f32 / (keys - 1) as f32) {
                    bb.extend(p);
                }
            }
            bb
        }));
        let mut bvh = ws.build(count, params);
        if ids.is_some() {
            for p in &mut bvh.primitive_indices {
                *p = mesh_index(*p as usize) as u32;
            }
        }
        MeshBvh { bvh }
    }
}

/// Deepest wide BVH the traversal's stack holds (`traverse::STACK` entries; a wide BVH
/// n levels deep pushes at most n − 1 node groups), obvhs's own limit.
const MAX_DEPTH: u32 = 31;

impl Workspace {
    /// The wide BVH over the first `count` boxes of `self.aabbs`: what obvhs's
    /// `build_cwbvh` does (PLOC, reinsertion, wide conversion), with the builder's, binary
    /// BVH's and conversion's buffers reused across builds, and a balanced tree of median
    /// splits instead when PLOC's is deeper than the traversal can walk ([`balanced`]:
    /// coincident or collapsed triangles).
    fn build(&mut self, count: usize, params: BvhBuildParams) -> CwBvh {
        self.ploc.build_with_bvh(
            &mut self.bvh2,
            params.ploc_search_distance,
            &self.aabbs,
            (0..count as u32).collect(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        self.reinsertion.run(&mut self.bvh2, params.reinsertion_batch_ratio, None);
        let mut bvh = self.convert.convert(&self.bvh2, params.max_prims_per_leaf);
        if self.convert.depth() > MAX_DEPTH {
            balanced::build(&mut self.bvh2, &self.aabbs);
            bvh = self.convert.convert(&self.bvh2, params.max_prims_per_leaf);
            // ceil(log2 n) + 1 binary levels, at most as many wide ones.
            assert!(self.convert.depth() <= MAX_DEPTH, "BVH {} levels deep over {count} boxes", self.convert.depth());
        }
        // obvhs's own checks, which its `build_cwbvh` runs in debug builds.
        #[cfg(debug_assertions)]
        {
            self.bvh2.validate(&self.aabbs, false, false);
            bvh.validate(&self.aabbs, false);
        }
        bvh
    }
}

/// Build buffers of one thread, reused by its next build (fresh ones per build cost
/// page faults and zeroing: a fifth of the conversion). They live only during
/// [`Accel::build_chunked`].
#[derive(Default)]
struct Workspace {
    aabbs: Vec<Aabb>,
    ploc: PlocBuilder,
    bvh2: Bvh2,
    reinsertion: ReinsertionOptimizer,
    convert: convert::Converter,
}

/// Workspaces for the builds in flight: each build takes one (or makes one) and gives
/// it back.
#[derive(Default)]
struct Workspaces(Mutex<Vec<Workspace>>);

impl Workspaces {
    fn build(&self, m: &Mesh, ids: Option<&[u32]>, params: BvhBuildParams) -> MeshBvh {
        let mut ws = self.0.lock().unwrap_or_else(|e| e.into_inner()).pop().unwrap_or_default();
        let out = MeshBvh::build(&mut ws, m, ids, params);
        self.0.lock().unwrap_or_else(|e| e.into_inner()).push(ws);
        out
    }
}

pub struct Accel {
    /// Per mesh, its BVHs: one, or one per chunk of [`CHUNK`] triangles for larger meshes.
    meshes: Vec<Vec<MeshBvh>>,
    /// Over (instance, chunk) pairs whose mesh has triangles; leaf ids index `tlas_instances`.
    tlas: Option<CwBvh>,
    tlas_instances: Vec<Leaf>,
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

/// Meshes of more than this many triangles get one BVH per chunk of [`CHUNK`]
/// triangles. obvhs's build holds about 250 bytes per triangle while it runs (boxes,
/// the binary BVH, the wide-BVH conversion's 7 cost decisions per binary node) on top
/// of the 12 it keeps, so a large mesh is cut into chunks of consecutive centroid
/// Morton order and each chunk gets its own BVH, a few at a time: the transient memory
/// stays bounded by the chunk size, and the top-level BVH sees each chunk as an
/// instance. Meshes up to this size build as one BVH, exactly as before chunking.
pub const CHUNK_ABOVE: usize = 1 << 19;

/// Triangles per chunk of a mesh of more than [`CHUNK_ABOVE`]: two builds of 2^16 at
/// once hold about 33 MB of transient memory (2^19, the size before, held 260 MB, more
/// than one BVH over a whole 1M-triangle mesh, and made 1M cost more, not less).
pub const CHUNK: usize = 1 << 17;

/// The mesh's triangles in runs of at most `chunk`, in the Morton order of their
/// centroids (10 bits per axis over the mesh's bounding cube), so each run is spatially compact.
fn chunks(m: &Mesh, chunk: usize) -> Vec<Vec<u32>> {
    let n = m.indices.len();
    let (mut lo, mut hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
    for p in &m.positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    // One scale for all axes, so the Morton cells are cubes: scaled per axis, a thin
    // mesh's (a displaced grid's) height got as many bits as its width, and runs cut
    // along it were spread over the whole grid, their boxes overlapping (closest-hit
    // rays 30 % slower than one BVH over a 1M-triangle grid in chunks of 2^16).
    let scale = Vec3A::splat(1023.0 / (hi - lo).max_element().max(f32::MIN_POSITIVE));
    let spread = |v: u32| {
        // Bits of a 10-bit integer spread to every third bit.
        let mut x = v & 0x3ff;
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    let mut keys: Vec<u64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let [a, b, c] = m.triangle(i);
            let q = ((a + b + c) * (1.0 / 3.0) - lo) * scale;
            let code = spread(q.x as u32) | (spread(q.y as u32) << 1) | (spread(q.z as u32) << 2);
            ((code as u64) << 32) | i as u64
        })
        .collect();
    keys.par_sort_unstable();
    keys.chunks(chunk).map(|c| c.iter().map(|&k| k as u32).collect()).collect()
}

impl Accel {
    pub fn build(meshes: &[Mesh], instances: &[Instance]) -> Self {
        Self::build_chunked(meshes, instances, CHUNK_ABOVE, CHUNK)
    }

    /// [`Accel::build`] with meshes of more than `above` triangles cut into chunks of
    /// `chunk`: for tests (chunks of small meshes) and benchmarks (other sizes).
    pub fn build_chunked(meshes: &[Mesh], instances: &[Instance], above: usize, chunk: usize) -> Self {
        let threads = rayon::current_num_threads().max(1);
        let workspaces = Workspaces::default();
        let mesh_bvhs: Vec<Vec<MeshBvh>> = meshes
            .par_iter()
            .map(|m| {
                let n = m.indices.len();
                let params = build_params_for(n);
                if n == 0 {
                    return Vec::new();
                }
                if n <= above {
                    return vec![workspaces.build(m, None, params)];
                }
                let mut parts = chunks(m, chunk);
                let mut out = Vec::with_capacity(parts.len());
                // A few chunks at a time, so at most `threads` builds hold their transient
                // memory; each chunk's id list is freed once its BVH holds the ids.
                while !parts.is_empty() {
                    let batch: Vec<Vec<u32>> = parts.drain(..threads.min(parts.len())).collect();
                    out.extend(
                        batch.into_par_iter().map(|ids| workspaces.build(m, Some(&ids), params)).collect::<Vec<_>>(),
                    );
                }
                out
            })
            .collect();
        drop(workspaces);
        let mut tlas_instances = Vec::new();
        let mut boxes = Vec::new();
        for (k, inst) in instances.iter().enumerate() {
            for (c, mb) in mesh_bvhs[inst.mesh as usize].iter().enumerate() {
                let identity = inst.motion.is_none() && inst.to_object == glam::Affine3A::IDENTITY;
                tlas_instances.push(Leaf { instance: k as u32, chunk: c as u32, identity });
                boxes.push(transform_aabb(&mb.bvh.total_aabb, inst));
            }
        }
        let tlas = if boxes.is_empty() {
            None
        } else {
            let mut ws = Workspace { aabbs: boxes, ..Workspace::default() };
            Some(ws.build(ws.aabbs.len(), build_params_for(ws.aabbs.len())))
        };
        let tlas_instances = match &tlas {
            Some(t) => t.primitive_indices.iter().map(|&i| tlas_instances[i as usize]).collect(),
            None => Vec::new(),
        };
        Self { meshes: mesh_bvhs, tlas, tlas_instances }
    }

    /// Bytes the structure holds (nodes and leaf order), for benchmarks.
    pub fn bytes(&self) -> usize {
        let bvh = |b: &CwBvh| {
            b.nodes.len() * std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>() + b.primitive_indices.len() * 4
        };
        let meshes: usize = self.meshes.iter().flatten().map(|m| bvh(&m.bvh)).sum();
        meshes + self.tlas.as_ref().map_or(0, bvh) + self.tlas_instances.len() * std::mem::size_of::<Leaf>()
    }

    /// Closest hit along `ray` within (tmin, tmax), among `instances` of `meshes` (those
    /// the structure was built over).
    pub fn intersect(&self, meshes: &[Mesh], instances: &[Instance], ray: &Ray) -> Option<Hit> {
        self.closest(meshes, instances, ray, None, None)
    }

    /// Closest hit along `ray` on instance `only` alone, whatever its ray visibility,
    /// never on its triangle `skip` (Cycles' `scene_intersect_local` with `ray.self`: a
    /// subsurface walk sees its own object, its first ray not the entry triangle).
    pub fn intersect_instance(
        &self,
        meshes: &[Mesh],
        instances: &[Instance],
        ray: &Ray,
        only: u32,
        skip: Option<u32>,
    ) -> Option<Hit> {
        self.closest(meshes, instances, ray, Some(only), skip)
    }

    fn closest(
        &self,
        meshes: &[Mesh],
        instances: &[Instance],
        ray: &Ray,
        only: Option<u32>,
        skip: Option<u32>,
    ) -> Option<Hit> {
        let tlas = self.tlas.as_ref()?;
        let mut best: Option<Hit> = None;
        let world = TRay::of(ray);
        // The world ray's triangle test, for instances placed by the identity.
        let world_wt = WatertightRay::new(world.origin, world.direction);
        traverse::closest(tlas, world, |r, slot| {
            let leaf = self.tlas_instances[slot];
            let inst = &instances[leaf.instance as usize];
            match only {
                Some(o) if o != leaf.instance => return f32::INFINITY,
                Some(_) => {}
                None if !visibility::sees(inst.visibility, ray.kind) => {
                    return f32::INFINITY; // the ray goes on through instances its kind does not see
                }
                None => {}
            }
            let (mesh, mb) = (&meshes[inst.mesh as usize], &self.meshes[inst.mesh as usize][leaf.chunk as usize]);
            let (local, wt) = object_ray(inst, leaf.identity, r, &world_wt, ray.time);
            let mut bary = (0.0, 0.0);
            let local = traverse::closest(&mb.bvh, local, |lr, tri| {
                let id = mb.bvh.primitive_indices[tri];
                if skip == Some(id) {
                    return f32::INFINITY;
                }
                let [a, b, c] = mesh.triangle_at(id as usize, ray.time);
                match wt.intersect(a, b, c, lr.tmin, lr.tmax) {
                    Some((t, b1, b2)) => {
                        bary = (b1, b2);
                        t
                    }
                    None => f32::INFINITY,
                }
            });
            match local {
                // `bary` belongs to the last accepted hit, which is the closest.
                Some((t, tri)) => {
                    best = Some(Hit {
                        t,
                        instance: leaf.instance,
                        triangle: mb.bvh.primitive_indices[tri as usize],
                        b1: bary.0,
                        b2: bary.1,
                    });
                    t
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    /// Whether anything blocks `ray` within (tmin, tmax): for shadow rays.
    pub fn occluded(&self, meshes: &[Mesh], instances: &[Instance], ray: &Ray) -> bool {
        let Some(tlas) = self.tlas.as_ref() else { return false };
        let world = TRay::of(ray);
        let world_wt = WatertightRay::new(world.origin, world.direction);
        traverse::any(tlas, world, |r, slot| {
            let leaf = self.tlas_instances[slot];
            let inst = &instances[leaf.instance as usize];
            if !visibility::sees(inst.visibility, ray.kind) {
                return f32::INFINITY;
            }
            let (mesh, mb) = (&meshes[inst.mesh as usize], &self.meshes[inst.mesh as usize][leaf.chunk as usize]);
            let (local, wt) = object_ray(inst, leaf.identity, r, &world_wt, ray.time);
            let blocked = traverse::any(&mb.bvh, local, |lr, tri| {
                let [a, b, c] = mesh.triangle_at(mb.bvh.primitive_indices[tri] as usize, ray.time);
                wt.intersect(a, b, c, lr.tmin, lr.tmax).map_or(f32::INFINITY, |h| h.0)
            });
            if blocked {
                r.tmin.max(0.0)
            } else {
                f32::INFINITY
            }
        })
    }
}

/// One leaf of the top-level BVH: a chunk of an instance's mesh.
#[derive(Clone, Copy, Debug)]
struct Leaf {
    instance: u32,
    chunk: u32,
    /// The instance is placed by the identity and does not move: its object space is
    /// world space.
    identity: bool,
}

/// The world ray `r` (its current interval) in the object space of `inst` at `time`,
/// and its triangle test; the direction is not renormalised, so t is the same in both
/// spaces. For an identity instance that is the world ray itself (an identity
/// transform returns the same numbers, −0.0 as +0.0, which `TRay` already makes of
/// them): the world ray's test `world_wt` is reused.
#[inline(always)]
fn object_ray(inst: &Instance, identity: bool, r: &TRay, world_wt: &WatertightRay, time: f32) -> (TRay, WatertightRay) {
    if identity {
        return (*r, *world_wt);
    }
    let to_object = inst.to_object_at(time);
    let o = to_object.transform_point3a(r.origin);
    let d = to_object.transform_vector3a(r.direction);
    (TRay::new(o, d, r.tmin, r.tmax), WatertightRay::new(o, d))
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
        let h = accel.intersect(&meshes, &instances, &ray).unwrap();
        assert_eq!(h.instance, 0);
        assert!((h.t - 4.0).abs() < 1e-5);
        // Outside the near quad but inside the scaled far one.
        let ray = Ray::new(Vec3A::new(2.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0));
        let h = accel.intersect(&meshes, &instances, &ray).unwrap();
        assert_eq!(h.instance, 1);
        assert!((h.t - 7.0).abs() < 1e-5);
        assert!(accel.occluded(
            &meshes,
            &instances,
            &Ray::segment(Vec3A::new(2.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0), 8.0)
        ));
        assert!(!accel.occluded(
            &meshes,
            &instances,
            &Ray::segment(Vec3A::new(2.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0), 6.0)
        ));
        assert!(accel
            .intersect(&meshes, &instances, &Ray::new(Vec3A::new(9.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, -1.0)))
            .is_none());
    }

    #[test]
    fn negative_zero_direction_components_still_hit() {
        let meshes = vec![quad("q")];
        let instances = vec![Instance::new("q", 0, Affine3A::IDENTITY).unwrap()];
        let accel = Accel::build(&meshes, &instances);
        let ray = Ray::new(Vec3A::new(0.1, 0.2, 5.0), Vec3A::new(-0.0, -0.0, -1.0));
        assert!(accel.intersect(&meshes, &instances, &ray).is_some());
        assert!(accel.occluded(&meshes, &instances, &ray));
    }

    #[test]
    fn a_mesh_cut_into_chunks_gives_the_same_hits() {
        // A displaced 40 × 40 grid (3042 triangles), placed twice; chunks of 500.
        let n = 40;
        let mut pos = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
                pos.extend_from_slice(&[x * 2.0 - 1.0, y * 2.0 - 1.0, 0.1 * (7.0 * x).sin() * (5.0 * y).cos()]);
            }
        }
        let mut idx = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (i + n * j) as u32;
                let n = n as u32;
                idx.extend_from_slice(&[a, a + 1, a + n + 1, a, a + n + 1, a + n]);
            }
        }
        let ids = vec![0; idx.len() / 3];
        let meshes = vec![Mesh::from_buffers("grid", &pos, &idx, None, None, &ids).unwrap()];
        let instances = vec![
            Instance::new("a", 0, Affine3A::IDENTITY).unwrap(),
            Instance::new("b", 0, Affine3A::from_translation(glam::Vec3::new(0.5, 0.0, -0.5))).unwrap(),
        ];
        let whole = Accel::build_chunked(&meshes, &instances, usize::MAX, usize::MAX);
        let cut = Accel::build_chunked(&meshes, &instances, 500, 500);
        assert_eq!(whole.tlas_instances.len(), 2);
        assert_eq!(cut.tlas_instances.len(), 2 * 7);
        let mut state = 12345u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3A::new(rnd() * 3.0 - 1.5, rnd() * 3.0 - 1.5, 2.0);
            let d = (Vec3A::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, -0.5) - o).normalize();
            let ray = Ray::new(o, d);
            let (a, b) = (whole.intersect(&meshes, &instances, &ray), cut.intersect(&meshes, &instances, &ray));
            assert_eq!(a.is_some(), b.is_some());
            if let (Some(a), Some(b)) = (a, b) {
                hits += 1;
                assert_eq!((a.t, a.instance, a.triangle), (b.t, b.instance, b.triangle));
                assert_eq!((a.b1, a.b2), (b.b1, b.b2));
            }
            let seg = Ray::segment(o, d, 1.5);
            assert_eq!(whole.occluded(&meshes, &instances, &seg), cut.occluded(&meshes, &instances, &seg));
        }
        assert!(hits > 500, "{hits}");
    }

    /// A displaced n × n vertex grid, 2 (n − 1)² triangles.
    fn grid(name: &str, n: usize, phase: f32) -> Mesh {
        let mut pos = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
                pos.extend_from_slice(&[x * 2.0 - 1.0, y * 2.0 - 1.0, 0.1 * (7.0 * x + phase).sin() * (5.0 * y).cos()]);
            }
        }
        let mut idx = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (i + n * j) as u32;
                let n = n as u32;
                idx.extend_from_slice(&[a, a + 1, a + n + 1, a, a + n + 1, a + n]);
            }
        }
        Mesh::from_buffers(name, &pos, &idx, None, None, &vec![0; idx.len() / 3]).unwrap()
    }

    /// The closest hit over every triangle of every instance, without a BVH: t, and the
    /// (instance, triangle, b1, b2) of each triangle hit at that t (several on a shared
    /// edge, where either is right).
    fn brute_force(meshes: &[Mesh], instances: &[Instance], ray: &Ray) -> Option<(f32, Vec<(u32, u32, f32, f32)>)> {
        let mut best: Option<(f32, Vec<(u32, u32, f32, f32)>)> = None;
        for (k, inst) in instances.iter().enumerate() {
            let m = &meshes[inst.mesh as usize];
            let to_object = inst.to_object_at(ray.time);
            let o = to_object.transform_point3a(ray.origin);
            let d = to_object.transform_vector3a(ray.direction + Vec3A::ZERO);
            let wt = WatertightRay::new(o, d);
            for i in 0..m.indices.len() {
                let [a, b, c] = m.triangle_at(i, ray.time);
                let Some((t, b1, b2)) = wt.intersect(a, b, c, ray.tmin, ray.tmax) else { continue };
                let hit = (k as u32, i as u32, b1, b2);
                match &mut best {
                    Some((bt, hits)) if t == *bt => hits.push(hit),
                    Some((bt, _)) if t > *bt => {}
                    _ => best = Some((t, vec![hit])),
                }
            }
        }
        best
    }

    #[test]
    fn chunked_meshes_hit_what_brute_force_hits() {
        // A grid (3042 triangles) placed twice, once rotated and scaled, and a deforming
        // grid (1250 triangles, two motion keys) on a moving instance; chunks of 200
        // triangles for meshes of more than 100, so every mesh is cut.
        let mut moving = grid("moving", 26, 1.0);
        let keys: Vec<Vec<f32>> = (0..2)
            .map(|k| {
                moving.positions.iter().flat_map(|p| [p.x, p.y, p.z + 0.3 * k as f32 + 0.2 * p.x * k as f32]).collect()
            })
            .collect();
        moving.set_motion(&[&keys[0], &keys[1]], None).unwrap();
        let meshes = vec![grid("still", 40, 0.0), moving];
        let turn = Affine3A::from_scale_rotation_translation(
            glam::Vec3::splat(0.7),
            glam::Quat::from_rotation_x(0.4) * glam::Quat::from_rotation_z(0.3),
            glam::Vec3::new(0.4, -0.2, -0.6),
        );
        let (from, to) = (glam::Vec3::new(-0.3, 0.5, 0.2), glam::Vec3::new(0.1, 0.4, 0.3));
        let keys = [Affine3A::from_translation(from), Affine3A::from_translation(to)];
        let shifted = Instance::with_motion("moving", 1, keys[0], &keys).unwrap();
        let instances =
            vec![Instance::new("a", 0, Affine3A::IDENTITY).unwrap(), Instance::new("b", 0, turn).unwrap(), shifted];
        let accel = Accel::build_chunked(&meshes, &instances, 100, 200);
        assert_eq!(accel.tlas_instances.len(), 2 * 3042_usize.div_ceil(200) + 1250_usize.div_ceil(200));
        let mut state = 987654321u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let (mut hits, mut shadowed) = (0, 0);
        for _ in 0..3000 {
            let o = Vec3A::new(rnd() * 3.0 - 1.5, rnd() * 3.0 - 1.5, 1.5 + rnd());
            let d = (Vec3A::new(rnd() * 2.4 - 1.2, rnd() * 2.4 - 1.2, rnd() - 1.0) - o).normalize();
            let ray = Ray::new(o, d).with_time(rnd());
            let reference = brute_force(&meshes, &instances, &ray);
            let got = accel.intersect(&meshes, &instances, &ray);
            assert_eq!(got.is_some(), reference.is_some(), "{ray:?}");
            if let (Some(h), Some((t, candidates))) = (got, &reference) {
                hits += 1;
                assert_eq!(h.t, *t, "{ray:?}");
                assert!(candidates.contains(&(h.instance, h.triangle, h.b1, h.b2)), "{h:?} not in {candidates:?}");
            }
            let seg = Ray { tmax: 2.0, ..ray };
            let blocked = reference.is_some_and(|(t, _)| t < seg.tmax);
            shadowed += blocked as u32;
            assert_eq!(accel.occluded(&meshes, &instances, &seg), blocked, "{seg:?}");
        }
        assert!(hits > 1000 && shadowed > 300, "{hits} hits, {shadowed} shadowed");
    }

    /// Closest hits and shadow rays against geometry closer than 1e-4 along the ray:
    /// obvhs 0.4's own box test culls every box the ray leaves before t = 1e-4
    /// (cwbvh/node.rs, `EPSILON`), whatever the ray's tmin, so a scene modelled at
    /// 1e-5 units (or instanced at that scale) lost most of its hits.
    #[test]
    fn tiny_scenes_hit_what_brute_force_hits() {
        const S: f32 = 1e-5;
        let big = grid("big", 30, 0.5);
        let mut tiny = big.clone();
        tiny.positions.iter_mut().for_each(|p| *p *= S);
        // The tiny mesh as it is, and the normal-sized one instanced at scale S.
        let meshes = vec![tiny, big];
        let scaled = Affine3A::from_scale_rotation_translation(
            glam::Vec3::splat(S),
            glam::Quat::from_rotation_y(0.2),
            glam::Vec3::new(0.0, 0.0, -0.5 * S),
        );
        let instances =
            vec![Instance::new("tiny", 0, Affine3A::IDENTITY).unwrap(), Instance::new("scaled", 1, scaled).unwrap()];
        let accel = Accel::build(&meshes, &instances);
        let mut state = 24680u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let (mut hits, mut shadowed) = (0, 0);
        for _ in 0..2000 {
            let o = Vec3A::new(rnd() * 3.0 - 1.5, rnd() * 3.0 - 1.5, 0.5 + rnd()) * S;
            let d = (Vec3A::new(rnd() * 2.4 - 1.2, rnd() * 2.4 - 1.2, rnd() - 1.0) * S - o).normalize();
            let ray = Ray::new(o, d);
            let reference = brute_force(&meshes, &instances, &ray);
            let got = accel.intersect(&meshes, &instances, &ray);
            assert_eq!(got.is_some(), reference.is_some(), "{ray:?}");
            if let (Some(h), Some((t, candidates))) = (got, &reference) {
                hits += 1;
                assert_eq!(h.t, *t, "{ray:?}");
                assert!(candidates.contains(&(h.instance, h.triangle, h.b1, h.b2)), "{h:?} not in {candidates:?}");
            }
            let seg = Ray { tmax: 2.0 * S, ..ray };
            let blocked = reference.is_some_and(|(t, _)| t < seg.tmax);
            shadowed += blocked as u32;
            assert_eq!(accel.occluded(&meshes, &instances, &seg), blocked, "{seg:?}");
        }
        assert!(hits > 1000 && shadowed > 300, "{hits} hits, {shadowed} shadowed");
    }

    /// A shadow ray from a point 5e-5 below a unit-sized occluder (thin contact).
    #[test]
    fn an_occluder_closer_than_1e_4_blocks_a_shadow_ray() {
        let meshes = vec![quad("q")];
        let instances = vec![Instance::new("q", 0, Affine3A::IDENTITY).unwrap()];
        let accel = Accel::build(&meshes, &instances);
        for d in [Vec3A::Z, Vec3A::new(0.3, -0.2, 1.0).normalize()] {
            let seg = Ray::segment(Vec3A::new(0.1, 0.2, -5e-5), d, 1.0);
            assert!(accel.occluded(&meshes, &instances, &seg), "{d}");
            let h = accel.intersect(&meshes, &instances, &seg).expect("a hit");
            assert!((h.t * d.z - 5e-5).abs() < 1e-9, "{}", h.t);
        }
    }

    /// Rays along an axis whose origin lies exactly on a box plane, and axis-aligned
    /// rays (an orthographic camera), hit what brute force hits.
    #[test]
    fn axis_aligned_rays_on_box_planes_hit_what_brute_force_hits() {
        let meshes = vec![grid("g", 20, 0.0)];
        let instances = vec![Instance::new("g", 0, Affine3A::IDENTITY).unwrap()];
        let accel = Accel::build(&meshes, &instances);
        let mut hits = 0;
        for j in 0..=40 {
            for i in 0..=40 {
                // x, y on the grid's vertex lines (and its outer edges) every other step.
                let (x, y) = (i as f32 / 20.0 - 1.0, j as f32 / 20.0 - 1.0);
                for d in [Vec3A::NEG_Z, Vec3A::new(-0.0, 0.0, -1.0), Vec3A::new(0.0, -0.0, -1.0)] {
                    let ray = Ray::new(Vec3A::new(x, y, 1.0), d);
                    let reference = brute_force(&meshes, &instances, &ray);
                    let got = accel.intersect(&meshes, &instances, &ray);
                    assert_eq!(got.is_some(), reference.is_some(), "{ray:?}");
                    if let (Some(h), Some((t, _))) = (got, &reference) {
                        hits += 1;
                        assert_eq!(h.t, *t, "{ray:?}");
                    }
                    assert_eq!(accel.occluded(&meshes, &instances, &ray), reference.is_some(), "{ray:?}");
                }
            }
        }
        assert!(hits > 3000, "{hits}");
    }

    #[test]
    fn empty_scene_has_no_hits() {
        let accel = Accel::build(&[], &[]);
        assert!(accel.intersect(&[], &[], &Ray::new(Vec3A::ZERO, Vec3A::Z)).is_none());
        assert!(!accel.occluded(&[], &[], &Ray::new(Vec3A::ZERO, Vec3A::Z)));
    }
}
