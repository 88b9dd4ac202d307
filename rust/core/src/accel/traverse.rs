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
use obvhs::faststack::FastStack;
use std::mem::MaybeUninit;

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
        // +0.0 turns −0.0 into +0.0: the reciprocal's sign is the slab order's. (The
        // origin too: then the ray is exactly what an identity transform makes of it.)
        let (origin, direction) = (origin + Vec3A::ZERO, direction + Vec3A::ZERO);
        Self { origin, direction, inv: direction.recip(), tmin, tmax }
    }

    pub fn of(ray: &Ray) -> Self {
        Self::new(ray.origin, ray.direction, ray.tmin, ray.tmax)
    }
}

/// A node's quantized child planes of one axis as floats: (min of children 0..4,
/// min of 4..8, max of 0..4, max of 4..8). SSE2 widens the 16 bytes in six
/// unpacks and four conversions (obvhs's `_mm_set_ps` of four `u8 as f32` per vector
/// took a scalar conversion and a shuffle per byte: a fifth of the node test).
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
#[inline(always)]
fn planes(min: &[u8; 8], max: &[u8; 8]) -> [Vec4; 4] {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is enabled for this build (the cfg above; it is x86-64's baseline),
    // and these intrinsics only compute on values: no memory access.
    unsafe {
        let v = _mm_set_epi64x(u64::from_le_bytes(*max) as i64, u64::from_le_bytes(*min) as i64);
        let z = _mm_setzero_si128();
        let (lo, hi) = (_mm_unpacklo_epi8(v, z), _mm_unpackhi_epi8(v, z));
        let f = |w: __m128i| Vec4::from(_mm_cvtepi32_ps(w));
        [
            f(_mm_unpacklo_epi16(lo, z)),
            f(_mm_unpackhi_epi16(lo, z)),
            f(_mm_unpacklo_epi16(hi, z)),
            f(_mm_unpackhi_epi16(hi, z)),
        ]
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
#[inline(always)]
fn planes(min: &[u8; 8], max: &[u8; 8]) -> [Vec4; 4] {
    let q = |v: &[u8; 8], i: usize| {
        Vec4::new(v[i * 4] as f32, v[i * 4 + 1] as f32, v[i * 4 + 2] as f32, v[i * 4 + 3] as f32)
    };
    [q(min, 0), q(min, 1), q(max, 0), q(max, 1)]
}

/// The children of `node` that `ray` enters within (tmin, tmax), as obvhs's hit mask
/// (internal children in the top byte by traversal priority, leaf primitives below).
#[inline(always)]
fn intersect_node(node: &CwBvhNode, ray: &TRay, oct_inv4: u32) -> u32 {
    let e = node.compute_extent();
    let po = Vec3A::from(node.p) - ray.origin;
    // (plane − origin) / d for the quantized planes q of one axis: q·e is exact (e is a
    // power of two, q < 256), so the only roundings are the sum and the product.
    // `t.max(acc)` returns acc when t is NaN (SSE's maxps returns its second operand,
    // f32::max the number): a NaN slab leaves the interval as it is. Per axis, the
    // (near, far) planes of children 0..4 and of 4..8, by the direction's sign.
    let axis = |min: &[u8; 8], max: &[u8; 8], e: f32, po: f32, inv: f32| {
        let [min_a, min_b, max_a, max_b] = planes(min, max);
        let t = |q: Vec4| (q * e + Vec4::splat(po)) * inv;
        let (min_a, min_b, max_a, max_b) = (t(min_a), t(min_b), t(max_a), t(max_b));
        if inv < 0.0 {
            [max_a, max_b, min_a, min_b]
        } else {
            [min_a, min_b, max_a, max_b]
        }
    };
    let x = axis(&node.child_min_x, &node.child_max_x, e.x, po.x, ray.inv.x);
    let y = axis(&node.child_min_y, &node.child_max_y, e.y, po.y, ray.inv.y);
    let z = axis(&node.child_min_z, &node.child_max_z, e.z, po.z, ray.inv.z);
    let (tmin, tmax) = (Vec4::splat(ray.tmin), Vec4::splat(ray.tmax));
    let mask = |i: usize| {
        let near = z[i].max(y[i].max(x[i].max(tmin)));
        let far = z[i + 2].min(y[i + 2].min(x[i + 2].min(Vec4::INFINITY)));
        near.cmple((far * EXIT_SCALE).min(tmax)).bitmask()
    };
    let mut hits = mask(0) | mask(1) << 4;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hit_mask = 0u32;
    while hits != 0 {
        let k = hits.trailing_zeros() * 8;
        hits &= hits - 1;
        let child_bits = ((child_bits8 >> k) as u32) & 0xff;
        let bit_index = ((bit_index8 >> k) as u32) & 0xff;
        hit_mask |= child_bits << bit_index;
    }
    hit_mask
}

/// The traversal state `obvhs::traverse!` reads (its fields by name), as obvhs's
/// `Traversal` but with a stack that is not zeroed: a fresh `Traversal` clears its
/// 32-entry stack (256 bytes) on every call, which was a tenth of a closest-hit query on
/// small scenes (two traversals per instance visited).
struct Walk<'s> {
    stack: Stack<'s>,
    current_group: UVec2,
    primitive_group: UVec2,
    oct_inv4: u32,
    primitive_id: u32,
    hitmask: u32,
}

impl<'s> Walk<'s> {
    /// The state at the root for a ray along `direction`, its stack in `slots` (a local
    /// of the caller's: moving a 256-byte array into the state cost more than the walk
    /// of a small BVH).
    #[inline(always)]
    fn new(direction: Vec3A, slots: &'s mut Slots) -> Self {
        // obvhs's `ray_get_octant_inv4`: the child order for the ray's octant.
        let oct_inv4 = (if direction.x < 0.0 { 0 } else { 0x0404_0404 })
            | (if direction.y < 0.0 { 0 } else { 0x0202_0202 })
            | (if direction.z < 0.0 { 0 } else { 0x0101_0101 });
        Self {
            stack: Stack { data: slots, len: 0 },
            current_group: UVec2::new(0, 0x8000_0000),
            primitive_group: UVec2::ZERO,
            oct_inv4,
            primitive_id: 0,
            hitmask: 0,
        }
    }
}

/// obvhs's traversal stack depth (`TRAVERSAL_STACK_SIZE`; its `CwBvh::validate` checks
/// the tree is shallower). A tree n levels deep pushes at most n − 1 groups; the build
/// keeps every tree within `super::MAX_DEPTH` = 31 levels (a balanced tree replaces a
/// deeper one: `super::balanced`), so the clamp in `push` never drops a group.
const STACK: usize = 32;

/// Stack storage, left uninitialised.
type Slots = [MaybeUninit<UVec2>; STACK];

/// Fresh stack storage (no code: nothing is written).
#[inline(always)]
fn slots() -> Slots {
    [const { MaybeUninit::uninit() }; STACK]
}

/// A stack of node groups whose free slots are left uninitialised. Like obvhs's
/// `StackStack`, a push onto a full stack overwrites the top slot.
struct Stack<'s> {
    data: &'s mut Slots,
    /// Slots `..len` (and slot `len` itself when the stack is full) hold pushed values.
    len: usize,
}

impl FastStack<UVec2> for Stack<'_> {
    #[inline(always)]
    fn push(&mut self, v: UVec2) {
        self.data[self.len].write(v);
        self.len = (self.len + 1).min(STACK - 1);
    }
    #[inline(always)]
    fn pop_fast(&mut self) -> UVec2 {
        if self.len == 0 {
            return UVec2::ZERO;
        }
        self.len -= 1;
        // SAFETY: every slot below the old `len` was written by `push` (it writes slot
        // `len` before moving `len` past it), and nothing else moves `len` up.
        unsafe { self.data[self.len].assume_init() }
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<UVec2> {
        (self.len > 0).then(|| self.pop_fast())
    }
    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.len == 0
    }
    #[inline(always)]
    fn clear(&mut self) {
        self.len = 0;
    }
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
    let mut slots = slots();
    let mut state = Walk::new(ray.direction, &mut slots);
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
    let mut slots = slots();
    let mut state = Walk::new(ray.direction, &mut slots);
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

    #[test]
    fn planes_are_the_bytes_as_floats() {
        let (min, max) = ([0, 1, 2, 127, 128, 200, 254, 255], [255, 9, 0, 17, 33, 250, 128, 64]);
        let [a, b, c, d] = planes(&min, &max);
        let as_f32 = |v: &[u8]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
        assert_eq!([a.to_array(), b.to_array()].concat(), as_f32(&min));
        assert_eq!([c.to_array(), d.to_array()].concat(), as_f32(&max));
    }

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
                    any(&bvh, ray, |_, slot| {
                        if enters(&boxes[bvh.primitive_indices[slot] as usize]) {
                            0.0
                        } else {
                            f32::INFINITY
                        }
                    }),
                    expected > 0
                );
            }
        }
    }
}
