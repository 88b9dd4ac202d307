//! Degenerate geometry against brute force: coincident, zero-area, tiny and far-out
//! triangles, a mesh collapsed to one point, and nested triangles whose BVH is deeper
//! than a fixed 32-entry traversal stack. Each build must not panic, and every random
//! ray's closest hit and shadow query must agree with a loop over all triangles.

use super::*;
use crate::geometry::triangle::WatertightRay;
use glam::Affine3A;

/// xorshift32 in [0, 1).
struct Rnd(u32);

impl Rnd {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
}

fn mesh(name: &str, pos: &[Vec3A], idx: &[[u32; 3]]) -> Mesh {
    let flat: Vec<f32> = pos.iter().flat_map(|p| p.to_array()).collect();
    let ids: Vec<u32> = idx.iter().flatten().copied().collect();
    Mesh::from_buffers(name, &flat, &ids, None, None, &vec![0; idx.len()]).unwrap()
}

/// An n × n vertex grid over [-1, 1]² at z = 0.1 sin(7x) cos(5y), 2 (n − 1)² triangles.
fn grid(n: usize) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / (n - 1) as f32 * 2.0 - 1.0, j as f32 / (n - 1) as f32 * 2.0 - 1.0);
            pos.push(Vec3A::new(x, y, 0.1 * (7.0 * x).sin() * (5.0 * y).cos()));
        }
    }
    let mut idx = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (i + n * j) as u32;
            let n = n as u32;
            idx.push([a, a + 1, a + n + 1]);
            idx.push([a, a + n + 1, a + n]);
        }
    }
    (pos, idx)
}

/// Closest hit over every triangle of every instance: its t and every (instance,
/// triangle) hit within `rel` of it.
fn brute_force(meshes: &[Mesh], instances: &[Instance], ray: &Ray, rel: f32) -> Option<(f32, Vec<(u32, u32)>)> {
    let mut all = Vec::new();
    for (k, inst) in instances.iter().enumerate() {
        let m = &meshes[inst.mesh as usize];
        let o = inst.to_object.transform_point3a(ray.origin);
        let d = inst.to_object.transform_vector3a(ray.direction);
        let wt = WatertightRay::new(o, d);
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            if let Some((t, _, _)) = wt.intersect(a, b, c, ray.tmin, ray.tmax) {
                all.push((t, k as u32, i as u32));
            }
        }
    }
    let t = all.iter().map(|h| h.0).reduce(f32::min)?;
    Some((t, all.iter().filter(|h| h.0 <= t * (1.0 + rel)).map(|h| (h.1, h.2)).collect()))
}

/// `rays` random rays from around the world box [lo, hi] towards points inside it:
/// closest hits within 1e-5 relative of brute force's (on one of its triangles at that
/// distance), shadow rays to the target blocked exactly when brute force is. Returns
/// (closest hits, blocked shadow rays).
fn agrees_with_brute_force(meshes: &[Mesh], instances: &[Instance], lo: Vec3A, hi: Vec3A, rays: usize) -> (u32, u32) {
    let accel = Accel::build(meshes, instances);
    let deepest = accel.meshes.iter().flatten().map(|m| depth(&m.bvh)).chain(accel.tlas.iter().map(depth)).max();
    assert!(deepest.unwrap_or(0) <= MAX_DEPTH, "{deepest:?} levels");
    let mut rnd = Rnd(0x9e37_79b9);
    let (centre, size) = ((lo + hi) * 0.5, (hi - lo).max(Vec3A::splat((hi - lo).max_element() * 1e-3)));
    let (mut hits, mut blocked) = (0, 0);
    for _ in 0..rays {
        let mut at = |s: f32| centre + Vec3A::new(rnd.next() - 0.5, rnd.next() - 0.5, rnd.next() - 0.5) * size * s;
        let (o, target) = (at(3.0), at(1.0));
        let d = (target - o).normalize();
        if !d.is_finite() {
            continue;
        }
        let ray = Ray::new(o, d);
        let reference = brute_force(meshes, instances, &ray, 1e-5);
        let got = accel.intersect(meshes, instances, &ray);
        assert_eq!(got.is_some(), reference.is_some(), "{ray:?}: {got:?} vs {reference:?}");
        if let (Some(h), Some((t, on))) = (got, &reference) {
            hits += 1;
            assert!((h.t - t).abs() <= 1e-5 * t, "{ray:?}: t {} vs {t}", h.t);
            assert!(on.contains(&(h.instance, h.triangle)), "{ray:?}: {h:?} not among {on:?}");
        }
        let seg = Ray { tmax: (target - o).length(), ..ray };
        let expect = brute_force(meshes, instances, &seg, 0.0).is_some();
        blocked += expect as u32;
        assert_eq!(accel.occluded(meshes, instances, &seg), expect, "{seg:?}");
    }
    (hits, blocked)
}

fn one(m: Mesh) -> (Vec<Mesh>, Vec<Instance>) {
    (vec![m], vec![Instance::new("i", 0, Affine3A::IDENTITY).unwrap()])
}

#[test]
fn coincident_triangles() {
    // 2000 copies of one triangle, on top of a 20 × 20 grid, half of them with their
    // vertices in another order.
    let (mut pos, mut idx) = grid(20);
    let base = pos.len() as u32;
    pos.extend([Vec3A::new(-0.5, -0.5, 0.3), Vec3A::new(0.6, -0.4, 0.3), Vec3A::new(0.0, 0.7, 0.3)]);
    for k in 0..2000 {
        idx.push(if k % 2 == 0 { [base, base + 1, base + 2] } else { [base + 2, base, base + 1] });
    }
    let (meshes, instances) = one(mesh("coincident", &pos, &idx));
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-1.0), Vec3A::ONE, 3000);
    assert!(hits > 1000 && blocked > 300, "{hits} hits, {blocked} blocked");
}

#[test]
fn zero_area_triangles() {
    // A grid with 3000 degenerate triangles among its own: all three vertices one
    // point (its vertices, and new points), or three collinear points (along its edges
    // and across it).
    let (mut pos, mut idx) = grid(20);
    let n = pos.len() as u32;
    let mut rnd = Rnd(77);
    for k in 0..1000u32 {
        let v = (rnd.next() * n as f32) as u32 % n;
        idx.push([v, v, v]);
        let p = Vec3A::new(rnd.next() * 2.0 - 1.0, rnd.next() * 2.0 - 1.0, rnd.next() * 0.2 - 0.1);
        let (a, b) = (p, p + Vec3A::new(rnd.next(), rnd.next(), rnd.next()) * 0.3);
        let base = pos.len() as u32;
        pos.extend([a, a, a, a, (a + b) * 0.5, b]);
        idx.push([base, base + 1, base + 2]);
        idx.push([base + 3, base + 4 + k % 2, base + 5 - k % 2]);
    }
    let (meshes, instances) = one(mesh("zero area", &pos, &idx));
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-1.0), Vec3A::ONE, 3000);
    assert!(hits > 1000 && blocked > 300, "{hits} hits, {blocked} blocked");
}

#[test]
fn tiny_triangles() {
    // A grid scaled to 1e-12, and to 1e-18 and 1e-30, where the triangle test's
    // products of three coordinates (the distance, ~s³) underflow f32: no ray hits
    // those, in the BVH or in brute force.
    for (s, want) in [(1e-12f32, 1000), (1e-18, 0), (1e-30, 0)] {
        let (pos, idx) = grid(20);
        let pos: Vec<Vec3A> = pos.iter().map(|p| *p * s).collect();
        let (meshes, instances) = one(mesh("tiny", &pos, &idx));
        let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-s), Vec3A::splat(s), 3000);
        assert!(hits >= want && blocked >= want / 4, "scale {s:e}: {hits} hits, {blocked} blocked");
        eprintln!("tiny {s:e}: {hits} hits, {blocked} blocked");
    }
    // Triangles 1e-30 across scattered over a unit grid: their vertices round to one point.
    let (mut pos, mut idx) = grid(10);
    let mut rnd = Rnd(5);
    for _ in 0..2000 {
        let p = Vec3A::new(rnd.next(), rnd.next(), rnd.next()) * 2.0 - 1.0;
        let base = pos.len() as u32;
        pos.extend([p, p + Vec3A::X * 1e-30, p + Vec3A::Y * 1e-30]);
        idx.push([base, base + 1, base + 2]);
    }
    let (meshes, instances) = one(mesh("specks", &pos, &idx));
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-1.0), Vec3A::ONE, 3000);
    assert!(hits > 1000 && blocked > 300, "{hits} hits, {blocked} blocked");
}

#[test]
fn huge_coordinates() {
    // 1e30 is refused by the mesh (naming it); the largest accepted coordinate, 1e12,
    // builds and is hit: the grid scaled to 1e12, and a unit grid placed at 1e12.
    let e =
        Mesh::from_buffers("far out", &[0.0, 0.0, 0.0, 1e30, 0.0, 0.0, 0.0, 1.0, 0.0], &[0, 1, 2], None, None, &[0])
            .unwrap_err()
            .to_string();
    assert!(e.contains("far out") && e.contains("1e30"), "{e}");
    let (pos, idx) = grid(20);
    let s = crate::geometry::mesh::MAX_COORDINATE;
    let scaled: Vec<Vec3A> = pos.iter().map(|p| *p * s).collect();
    let (meshes, instances) = one(mesh("huge", &scaled, &idx));
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-s), Vec3A::splat(s), 3000);
    assert!(hits > 1000 && blocked > 300, "{hits} hits, {blocked} blocked");
    let at = Vec3A::new(0.999 * s, -0.999 * s, 0.5 * s);
    let moved: Vec<Vec3A> = pos.iter().map(|p| *p * 1e6 + at).collect();
    let (meshes, instances) = one(mesh("far", &moved, &idx));
    let (hits, _) = agrees_with_brute_force(&meshes, &instances, at - 1e6, at + 1e6, 3000);
    assert!(hits > 500, "{hits} hits");
}

#[test]
fn ten_thousand_triangles_at_one_point() {
    // Alone (nothing can be hit), and inside a grid whose vertex it is.
    let p = [Vec3A::new(0.1, 0.2, 0.3)];
    let (meshes, instances) = one(mesh("point", &p, &vec![[0, 0, 0]; 10_000]));
    let (hits, _) = agrees_with_brute_force(&meshes, &instances, p[0] - 1.0, p[0] + 1.0, 500);
    assert_eq!(hits, 0);
    let (pos, mut idx) = grid(21);
    idx.extend(std::iter::repeat_n([220, 220, 220], 10_000)); // the grid's centre vertex
    let (meshes, instances) = one(mesh("point in grid", &pos, &idx));
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-1.0), Vec3A::ONE, 3000);
    assert!(hits > 1000 && blocked > 300, "{hits} hits, {blocked} blocked");
}

/// Depth of a wide BVH: 1 for a root whose children are all leaves.
fn depth(bvh: &CwBvh) -> u32 {
    fn walk(bvh: &CwBvh, n: usize) -> u32 {
        let node = &bvh.nodes[n];
        1 + (0..8)
            .filter(|&c| !node.is_child_empty(c) && !node.is_leaf(c))
            .map(|c| walk(bvh, node.child_node_index(c) as usize))
            .max()
            .unwrap_or(0)
    }
    if bvh.nodes.is_empty() {
        0
    } else {
        walk(bvh, 0)
    }
}

#[test]
fn nested_triangles_deeper_than_32_levels() {
    // 600 triangles around one point, each 0.9 times the size of the one before (down
    // to 1e-27): every merge PLOC can make nests, and the tree is a chain.
    let mut pos = Vec::new();
    let mut idx = Vec::new();
    for k in 0..600 {
        let s = 0.9f32.powi(k);
        let base = pos.len() as u32;
        let turn = k as f32 * 0.7;
        pos.extend(
            [0.0f32, 2.1, 4.2].map(|a| Vec3A::new((a + turn).cos(), (a + turn).sin(), 0.3 * (k % 5) as f32) * s),
        );
        idx.push([base, base + 1, base + 2]);
    }
    let (meshes, instances) = one(mesh("nested", &pos, &idx));
    let accel = Accel::build(&meshes, &instances);
    let d = depth(&accel.meshes[0][0].bvh);
    eprintln!("nested: depth {d}");
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-1.0), Vec3A::ONE, 3000);
    assert!(hits > 500 && blocked > 100, "{hits} hits, {blocked} blocked");
}

#[test]
fn coincident_instances() {
    // 3000 instances of one grid at one place, and 1000 of a single triangle: the
    // top-level BVH over coincident boxes.
    let (pos, idx) = grid(6);
    let meshes = vec![mesh("grid", &pos, &idx), mesh("one", &pos[..3], &[[0, 1, 2]])];
    let mut instances: Vec<Instance> =
        (0..3000).map(|k| Instance::new(&format!("g{k}"), 0, Affine3A::IDENTITY).unwrap()).collect();
    let up = Affine3A::from_translation(glam::Vec3::new(0.0, 0.0, 0.2));
    instances.extend((0..1000).map(|k| Instance::new(&format!("t{k}"), 1, up).unwrap()));
    let (hits, blocked) = agrees_with_brute_force(&meshes, &instances, Vec3A::splat(-1.0), Vec3A::ONE, 300);
    assert!(hits > 100 && blocked > 50, "{hits} hits, {blocked} blocked");
}

/// The public scene builder refuses non-finite and out-of-range vertices with an error
/// naming the mesh (or the instance whose transform carries them out of range), before
/// the BVH sees them.
#[test]
fn scene_builder_refuses_non_finite_vertices_naming_the_mesh() {
    use crate::color::RgbSpace;
    use crate::scene::{Buffer, BuildOptions, InstanceDesc, MeshDesc, Scene, SceneDesc};
    use crate::spectrum::WavelengthGrid;
    let build = |bad: f32, scale: f32| {
        let mut desc = SceneDesc::default();
        desc.materials.push(serde_json::from_str(r#"{"name": "m0"}"#).unwrap());
        desc.meshes.push(MeshDesc {
            name: "bad mesh".into(),
            vertices: 0,
            triangles: 1,
            material: Some(0),
            ..Default::default()
        });
        let s = [scale, 0.0, 0.0, 0.0];
        desc.instances = Some(vec![InstanceDesc {
            name: "bad instance".into(),
            mesh: 0,
            transform: [s, [0.0, scale, 0.0, 0.0], [0.0, 0.0, scale, 0.0], [0.0, 0.0, 0.0, 1.0]],
            ..Default::default()
        }]);
        let buffers = [Buffer::F32(vec![0.0, 0.0, 0.0, 1.0, 0.0, bad, 0.0, 1.0, 0.0]), Buffer::U32(vec![0, 1, 2])];
        let opts = BuildOptions {
            grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
            space: RgbSpace::rec709(),
            uplift: Default::default(),
            width: 4,
            height: 3,
        };
        Scene::build(&desc, &buffers, &opts).err().map(|e| e.to_string())
    };
    assert_eq!(build(0.0, 1.0), None);
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30] {
        let e = build(bad, 1.0).expect("an error");
        assert!(e.contains("bad mesh") && e.contains("vertex 1"), "{bad}: {e}");
    }
    let e = build(0.0, 1e20).expect("an error");
    assert!(e.contains("bad instance"), "{e}");
}
