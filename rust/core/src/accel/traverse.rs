//! Ray traversal of obvhs's compressed wide BVH with our own node test.
//!
//! obvhs 0.4's `CwBvhNode::intersect_ray` clamps every child's entry distance to
//! `EPSILON` = 1e-4 instead of the ray's tmin (cwbvh/node.rs, simd.rs), so it culls every
//! box the ray leaves before t = 1e-4: geometry that close along the ray (a scene
//! modelled at 1e-5 units, a shadow ray from a point touching its occluder, a subsurface
//! walk's short steps) was never found. Its `safe_inverse` also replaces direction
//! components below f32::EPSILON by ±1/ε, which bends near-axis rays at small scales.
//! The walk over the nodes is obvhs's own (the exported `traverse!` macro: child order,
//! hit masks, stack); only the node test is ours:
//!
//! - entry clamped to the ray's tmin, exit to its tmax;
//! - exact reciprocals of the direction (±∞ for ±0, the sign taken from +0-adjusted
//!   components, so −0.0 picks the same slab ends as +0.0), and the slab distance
//!   written as (plane − origin) / direction with the plane p + q·e exact in floats: a
//!   zero component gives ±∞ (a slab the ray never enters or never leaves), and NaN
//!   only when the origin lies on the plane itself, which the min/max order below
//!   ignores (the ray runs inside the plane: the slab does not cull it);
//! - the exit distance widened by 1 + 2γ₃ (Ize 2013, "Robust BVH Ray Traversal"), so the
//!   rounding of the slab distances never culls a box the ray grazes.

use crate::geometry::Ray;
use glam::{UVec2, Vec3A, Vec4};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;

/// 1 + 2γ₃ with γₙ = nε / (1 − nε) (Pharr, Jakob & Humphreys, pbrt-v3 §3.9), rounded up.
const EXIT_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5) + f32::EPSILON;

/// A ray prepared for box tests: origin, direction, the direction's reciprocal and
/// the (tmin, tmax) interval.
#[derive(Clone, Copy, Debug)]
pub(super) struct TRay {
    pub origin: Vec3A,
    pub direction: Vec3A,
    inv: Vec3A,
    pub tmin: f32,
    pub tmax: f32,
}

impl TRay {
    pub fn new(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Self {
        // +0.0 turns −0.0 into +0.0: the reciprocal's sign is the slab order's.
        let direction = direction + Vec3A::ZERO;
        Self { origin, direction, inv: direction.recip(), tmin, tmax }
    }

    pub fn of(ray: &Ray) -> Self {
        Self::new(ray.origin, ray.direction, ray.tmin, ray.tmax)
    }
}

/// The children of `node` that `ray` enters within (tmin, tmax), as obvhs's hit mask
/// (internal children in the top byte by traversal priority, leaf primitives below).
#[inline(always)]
fn intersect_node(node: &CwBvhNode, ray: &TRay, oct_inv4: u32) -> u32 {
    let e = node.compute_extent();
    let po = Vec3A::from(node.p) - ray.origin;
    let (neg_x, neg_y, neg_z) = (ray.inv.x < 0.0, ray.inv.y < 0.0, ray.inv.z < 0.0);
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let q = |v: &[u8; 8], i: usize| {
        Vec4::new(v[i * 4] as f32, v[i * 4 + 1] as f32, v[i * 4 + 2] as f32, v[i * 4 + 3] as f32)
    };
    // (plane − origin) / d for the quantized planes q of one axis: q·e is exact (e is a
    // power of two, q < 256), so the only roundings are the sum and the product.
    let slab = |q: Vec4, e: f32, po: f32, inv: f32| (q * e + Vec4::splat(po)) * inv;
    let mut hit_mask = 0u32;
    for i in 0..2 {
        let (lo, hi) = (q(&node.child_min_x, i), q(&node.child_max_x, i));
        let (near_x, far_x) = if neg_x { (hi, lo) } else { (lo, hi) };
        let (lo, hi) = (q(&node.child_min_y, i), q(&node.child_max_y, i));
        let (near_y, far_y) = if neg_y { (hi, lo) } else { (lo, hi) };
        let (lo, hi) = (q(&node.child_min_z, i), q(&node.child_max_z, i));
        let (near_z, far_z) = if neg_z { (hi, lo) } else { (lo, hi) };
        // `t.max(acc)` returns acc when t is NaN (SSE's maxps returns its second operand,
        // f32::max the number): a NaN slab leaves the interval as it is.
        let mut near = Vec4::splat(ray.tmin);
        near = slab(near_x, e.x, po.x, ray.inv.x).max(near);
        near = slab(near_y, e.y, po.y, ray.inv.y).max(near);
        near = slab(near_z, e.z, po.z, ray.inv.z).max(near);
        let mut far = Vec4::splat(f32::INFINITY);
        far = slab(far_x, e.x, po.x, ray.inv.x).min(far);
        far = slab(far_y, e.y, po.y, ray.inv.y).min(far);
        far = slab(far_z, e.z, po.z, ray.inv.z).min(far);
        let far = (far * EXIT_SCALE).min(Vec4::splat(ray.tmax));
        let mask = near.cmple(far).bitmask();
        for j in 0..4 {
            if mask & (1 << j) != 0 {
                let k = (i * 4 + j) * 8;
                let child_bits = ((child_bits8 >> k) as u32) & 0xff;
                let bit_index = ((bit_index8 >> k) as u32) & 0xff;
                hit_mask |= child_bits << bit_index;
            }
        }
    }
    hit_mask
}

/// Closest hit: `hit(ray, leaf slot)` returns the distance of a hit on that primitive
/// inside the ray's interval (∞ for none); the interval shrinks to each closer hit.
/// Returns the closest distance and its leaf slot.
#[inline]
pub(super) fn closest<F: FnMut(&TRay, usize) -> f32>(bvh: &CwBvh, ray: TRay, mut hit: F) -> Option<(f32, u32)> {
    if bvh.nodes.is_empty() {
        return None;
    }
    let mut r = ray;
    let mut best = None;
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    obvhs::traverse!(bvh, node, state, intersect_node(node, &r, state.oct_inv4), {
        let t = hit(&r, state.primitive_id as usize);
        if t < r.tmax {
            best = Some((t, state.primitive_id));
            r.tmax = t;
        }
    });
    best
}

/// Whether any primitive blocks the ray: `hit(ray, leaf slot)` as for [`closest`]; stops
/// at the first hit.
#[inline]
pub(super) fn any<F: FnMut(&TRay, usize) -> f32>(bvh: &CwBvh, ray: TRay, mut hit: F) -> bool {
    if bvh.nodes.is_empty() {
        return false;
    }
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    let mut found = false;
    'outer: {
        obvhs::traverse!(bvh, node, state, intersect_node(node, &ray, state.oct_inv4), {
            if hit(&ray, state.primitive_id as usize) < ray.tmax {
                found = true;
                break 'outer;
            }
        });
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::aabb::Aabb;
    use obvhs::cwbvh::builder::build_cwbvh;
    use obvhs::BvhBuildParams;
    use std::time::Duration;

    /// Boxes along x, each hit test reporting the ray's entry into the box by slab
    /// arithmetic in f64: the traversal must find every box a ray enters, at any scale.
    #[test]
    fn every_entered_box_is_found_at_any_scale() {
        for scale in [1e-6f32, 1e-5, 1e-3, 1.0, 1e4] {
            let boxes: Vec<Aabb> = (0..64)
                .map(|i| {
                    let lo = Vec3A::new(i as f32 * 1.5, (i % 4) as f32, (i % 3) as f32) * scale;
                    Aabb::new(lo, lo + Vec3A::splat(scale))
                })
                .collect();
            let bvh = build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut Duration::default());
            let mut state = 777u32;
            let mut rnd = || {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                state as f32 / u32::MAX as f32
            };
            for _ in 0..500 {
                // Origins inside or just next to a box: its entry and exit are within
                // a fraction of the box size.
                let k = (rnd() * 64.0) as usize % 64;
                let o = boxes[k].center() + Vec3A::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 1.4 * scale;
                let d = Vec3A::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize();
                let tmax = 0.3 * scale;
                let enters = |b: &Aabb| {
                    let (mut t0, mut t1) = (0.0f64, tmax as f64);
                    for a in 0..3 {
                        let (lo, hi, o, d) = (b.min[a] as f64, b.max[a] as f64, o[a] as f64, d[a] as f64);
                        let (u, v) = ((lo - o) / d, (hi - o) / d);
                        t0 = t0.max(u.min(v));
                        t1 = t1.min(u.max(v));
                    }
                    t0 <= t1
                };
                let expected = boxes.iter().filter(|b| enters(b)).count();
                let mut found = 0;
                let ray = TRay::new(o, d, 0.0, tmax);
                let _ = closest(&bvh, ray, |_, slot| {
                    found += enters(&boxes[bvh.primitive_indices[slot] as usize]) as usize;
                    f32::INFINITY
                });
                assert_eq!(found, expected, "scale {scale}, {o} {d}");
                assert_eq!(
                    any(&bvh, ray, |_, slot| if enters(&boxes[bvh.primitive_indices[slot] as usize]) {
                        0.0
                    } else {
                        f32::INFINITY
                    }),
                    expected > 0
                );
            }
        }
    }
}
