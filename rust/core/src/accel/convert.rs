//! Binary BVH → compressed wide BVH (8 children, quantized boxes), with the buffers kept
//! for the next build.
//!
//! Adapted from obvhs 0.4's `cwbvh::bvh2_to_cwbvh` (MIT OR Apache-2.0, D. Griffin; after
//! Ylitie, Karras and Laine 2017, "Efficient incoherent ray traversal on GPUs through
//! compressed wide BVHs", and jan-van-bergen's GPU-Raytracer). The same SAH cost table and
//! the same nodes and leaf order for the same binary BVH (`tests::same_nodes_as_obvhs`),
//! but: the cost table is filled bottom-up in one backward pass over the binary nodes when
//! children follow their parents (PLOC's output) instead of recursively, the table is
//! reused across builds instead of allocated and zeroed per build (obvhs's `memset` and
//! its page faults were a fifth of a chunked build's conversion), and the output nodes are
//! collected in a reused buffer and copied out at their exact size (obvhs reserves one
//! 80-byte node per primitive and fills a quarter of them).

use glam::{UVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;

/// obvhs's leaf cost per primitive relative to a node test.
const PRIM_COST: f32 = 0.3;
/// 1 / 255: quantization steps of the child boxes.
const DENOM: f32 = 1.0 / 255.0;
const INVALID: u32 = u32::MAX;
const NONE: u8 = u8::MAX;

const LEAF: u8 = 0;
const INTERNAL: u8 = 1;
const DISTRIBUTE: u8 = 2;

/// One entry of the cost table: the best way to make binary node n into i + 1 children
/// of a wide node (entry 7n + i).
#[derive(Clone, Copy, Default)]
struct Decision {
    cost: f32,
    kind: u8,
    left: u8,
    right: u8,
    /// Primitives under the node, clamped to 255 (only compared with the leaf limit).
    count: u8,
}

/// Conversion buffers, reused by the builds of one thread.
#[derive(Default)]
pub(super) struct Converter {
    decisions: Vec<Decision>,
    nodes: Vec<CwBvhNode>,
    primitive_indices: Vec<u32>,
    depth: u32,
}

impl Converter {
    /// The wide BVH of `bvh2` (binary, one primitive per leaf), leaves of at most
    /// `max_prims_per_leaf` (1..=3) primitives, children ordered by ray octant.
    pub fn convert(&mut self, bvh2: &Bvh2, max_prims_per_leaf: u32) -> CwBvh {
        if bvh2.nodes.is_empty() {
            return CwBvh::default();
        }
        let max_prims_per_leaf = max_prims_per_leaf.clamp(1, 3);
        // Every entry is written before it is read: no need to clear the old contents.
        let len = bvh2.nodes.len() * 7;
        if self.decisions.len() < len {
            self.decisions.resize(len, Decision::default());
        }
        self.nodes.clear();
        self.primitive_indices.clear();
        let ordered = bvh2.nodes.iter().enumerate().all(|(i, n)| n.is_leaf() || n.first_index as usize > i);
        if ordered {
            for i in (0..bvh2.nodes.len()).rev() {
                self.cost(bvh2, i, max_prims_per_leaf);
            }
        } else {
            self.cost_recursive(bvh2, 0, max_prims_per_leaf);
        }
        self.nodes.push(CwBvhNode::default());
        // Depth-first from the root, children in slot order (a recursion's order, which
        // obvhs's is): an explicit stack, as a degenerate tree (10k triangles at one
        // point) is thousands of wide nodes deep and overflowed the thread's stack.
        self.depth = 0;
        let mut todo = vec![(0usize, 0usize, 1u32)];
        while let Some((wide, node, depth)) = todo.pop() {
            self.depth = self.depth.max(depth);
            let base = todo.len();
            self.emit(bvh2, wide, node, |w, n| todo.push((w, n, depth + 1)));
            todo[base..].reverse();
        }
        CwBvh {
            nodes: self.nodes.to_vec(),
            primitive_indices: self.primitive_indices.to_vec(),
            total_aabb: *bvh2.nodes[0].aabb(),
            exact_node_aabbs: None,
            uses_spatial_splits: bvh2.uses_spatial_splits,
        }
    }

    /// The cost table in post order (children before their parent) for trees whose
    /// children may come before their parents (after reinsertion): an explicit stack, as
    /// the binary tree of a degenerate mesh is a chain as deep as its triangle count.
    fn cost_recursive(&mut self, bvh2: &Bvh2, root: usize, max_prims_per_leaf: u32) {
        let mut todo = vec![(root, false)];
        while let Some((node, children_done)) = todo.pop() {
            let n = &bvh2.nodes[node];
            if children_done || n.is_leaf() {
                self.cost(bvh2, node, max_prims_per_leaf);
            } else {
                todo.extend([(node, true), (n.first_index as usize + 1, false), (n.first_index as usize, false)]);
            }
        }
    }

    /// Depth of the last converted tree in wide nodes (1: a root whose children are all
    /// leaves).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Fills node `node`'s 7 entries; its children's must be filled.
    #[inline]
    fn cost(&mut self, bvh2: &Bvh2, node: usize, max_prims_per_leaf: u32) {
        let n = &bvh2.nodes[node];
        let half_area = n.aabb().half_area();
        let at = node * 7;
        if n.is_leaf() {
            assert_eq!(n.prim_count, 1, "the wide-BVH conversion expects one primitive per binary leaf");
            let d = Decision { cost: half_area * PRIM_COST, kind: LEAF, left: NONE, right: NONE, count: 1 };
            self.decisions[at..at + 7].fill(d);
            return;
        }
        let (l, r) = (n.first_index as usize * 7, (n.first_index as usize + 1) * 7);
        let (left, right): ([Decision; 7], [Decision; 7]) = (
            self.decisions[l..l + 7].try_into().expect("7 entries"),
            self.decisions[r..r + 7].try_into().expect("7 entries"),
        );
        let count = left[0].count as u32 + right[0].count as u32;
        let out: &mut [Decision] = &mut self.decisions[at..at + 7];
        // One child (i = 0): a leaf, or an internal node whose children are distributed.
        let cost_leaf = if count <= max_prims_per_leaf { count as f32 * half_area * PRIM_COST } else { f32::INFINITY };
        let (mut best, mut bl, mut br) = (f32::INFINITY, NONE, NONE);
        for k in 0..7 {
            let c = left[k].cost + right[6 - k].cost;
            if c < best {
                (best, bl, br) = (c, k as u8, 6 - k as u8);
            }
        }
        let cost_internal = best + half_area;
        let (kind, cost) = if cost_leaf < cost_internal { (LEAF, cost_leaf) } else { (INTERNAL, cost_internal) };
        let count = count.min(255) as u8;
        out[0] = Decision { cost, kind, left: bl, right: br, count };
        // i + 1 children, i = 1..6: the best of i children and a split of the i + 1.
        for i in 1..7 {
            let mut best = out[i - 1].cost;
            let (mut bl, mut br) = (NONE, NONE);
            for k in 0..i {
                let c = left[k].cost + right[i - k - 1].cost;
                if c < best {
                    (best, bl, br) = (c, k as u8, (i - k - 1) as u8);
                }
            }
            out[i] = if bl != NONE {
                Decision { cost: best, kind: DISTRIBUTE, left: bl, right: br, count }
            } else {
                out[i - 1]
            };
        }
    }

    /// The binary nodes that become the children of the wide node made from `node`
    /// with entry `i`.
    fn children(&self, bvh2: &Bvh2, node: usize, children: &mut [u32; 8], count: &mut usize, i: usize) {
        let n = &bvh2.nodes[node];
        if n.is_leaf() {
            children[*count] = node as u32;
            *count += 1;
            return;
        }
        let d = self.decisions[node * 7 + i];
        for (child, entry) in [(n.first_index, d.left), (n.first_index + 1, d.right)] {
            if self.decisions[child as usize * 7 + entry as usize].kind == DISTRIBUTE {
                self.children(bvh2, child as usize, children, count, entry as usize);
            } else {
                children[*count] = child;
                *count += 1;
            }
        }
    }

    /// Leaf order of the primitives under `node`; returns their count.
    fn collect_primitives(&mut self, bvh2: &Bvh2, node: usize) -> u32 {
        let n = &bvh2.nodes[node];
        if n.is_leaf() {
            self.primitive_indices.push(bvh2.primitive_indices[n.first_index as usize]);
            return n.prim_count;
        }
        let first = n.first_index as usize;
        self.collect_primitives(bvh2, first) + self.collect_primitives(bvh2, first + 1)
    }

    /// Writes wide node `wide` from binary node `node`; `child(wide, node)` gets each of
    /// its internal children in slot order, to be written next (depth first).
    fn emit(&mut self, bvh2: &Bvh2, wide: usize, node: usize, mut child: impl FnMut(usize, usize)) {
        let aabb = *bvh2.nodes[node].aabb();
        let mut out = CwBvhNode { p: aabb.min.into(), ..Default::default() };
        // The quantization step per axis: the least power of two e with 255 e ≥ the
        // extent, from the float's bits (obvhs takes exp2(ceil(log2(extent / 255))): six
        // libm calls per node, and one step too small when log2 rounds down to an integer
        // just above a power of two, e.g. at 2^-60 (1 + 2^-23)).
        let y = (aabb.max - aabb.min).max(Vec3A::splat(1e-20)) * DENOM;
        let step = |y: f32| {
            let b = y.to_bits();
            (b >> 23) + u32::from(b & 0x7f_ffff != 0)
        };
        let bits = UVec3::new(step(y.x), step(y.y), step(y.z));
        let e = Vec3A::new(f32::from_bits(bits.x << 23), f32::from_bits(bits.y << 23), f32::from_bits(bits.z << 23));
        let rcp_e = 1.0 / e;
        out.e = [bits.x as u8, bits.y as u8, bits.z as u8];

        let mut children = [INVALID; 8];
        let mut count = 0;
        self.children(bvh2, node, &mut children, &mut count, 0);
        order_children(bvh2, aabb.center(), &mut children, count);

        out.primitive_base_idx = self.primitive_indices.len() as u32;
        out.child_base_idx = self.nodes.len() as u32;
        let (mut internal, mut primitives) = (0usize, 0u32);
        for (i, &child) in children.iter().enumerate() {
            if child == INVALID {
                continue;
            }
            let b: &Aabb = bvh2.nodes[child as usize].aabb();
            let lo = ((b.min - aabb.min) * rcp_e).floor().clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            let hi = ((b.max - aabb.min) * rcp_e).ceil().clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            out.child_min_x[i] = lo.x as u8;
            out.child_min_y[i] = lo.y as u8;
            out.child_min_z[i] = lo.z as u8;
            out.child_max_x[i] = hi.x as u8;
            out.child_max_y[i] = hi.y as u8;
            out.child_max_z[i] = hi.z as u8;
            if self.decisions[child as usize * 7].kind == LEAF {
                let n = self.collect_primitives(bvh2, child as usize);
                debug_assert!((1..=3).contains(&n));
                // The three highest bits hold the primitive count in unary.
                out.child_meta[i] = primitives as u8 | [0, 0b0010_0000, 0b0110_0000, 0b1110_0000][n as usize];
                primitives += n;
            } else {
                out.imask |= 1 << i;
                out.child_meta[i] = (24 + i as u8) | 0b0010_0000;
                internal += 1;
            }
        }
        self.nodes.resize(self.nodes.len() + internal, CwBvhNode::default());
        self.nodes[wide] = out;
        let mut offset = 0;
        for (i, &c) in children.iter().enumerate() {
            if c != INVALID && out.imask & (1 << i) != 0 {
                child((out.child_base_idx + offset) as usize, c as usize);
                offset += 1;
            }
        }
    }
}

/// Puts the children in the slots of the ray octants that should visit them first
/// (greedy assignment by the centroid offset from the parent's centre, as obvhs).
fn order_children(bvh2: &Bvh2, p: Vec3A, children: &mut [u32; 8], count: usize) {
    let mut cost = [[f32::MAX; 8]; 8];
    for c in 0..count {
        let v = bvh2.nodes[children[c] as usize].aabb().center() - p;
        for (s, slot) in cost[c].iter_mut().enumerate() {
            let d = Vec3A::new(
                if s & 0b100 != 0 { -1.0 } else { 1.0 },
                if s & 0b010 != 0 { -1.0 } else { 1.0 },
                if s & 0b001 != 0 { -1.0 } else { 1.0 },
            );
            *slot = d.dot(v);
        }
    }
    let mut assignment = [usize::MAX; 8];
    let mut filled = [false; 8];
    loop {
        let (mut min_cost, mut min_slot, mut min_index) = (f32::MAX, usize::MAX, usize::MAX);
        for c in 0..count {
            if assignment[c] == usize::MAX {
                for s in 0..8 {
                    if !filled[s] && cost[c][s] < min_cost {
                        (min_cost, min_slot, min_index) = (cost[c][s], s, c);
                    }
                }
            }
        }
        if min_slot == usize::MAX {
            break;
        }
        filled[min_slot] = true;
        assignment[min_index] = min_slot;
    }
    let original = std::mem::replace(children, [INVALID; 8]);
    for c in 0..count {
        children[assignment[c]] = original[c];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};

    fn random_boxes(n: usize, seed: u32) -> Vec<Aabb> {
        let mut state = seed;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3A::new(rnd(), rnd(), rnd() * 0.2) * 10.0;
                let h = Vec3A::new(rnd(), rnd(), rnd()) * 0.05;
                Aabb::new(c - h, c + h)
            })
            .collect()
    }

    #[test]
    fn same_nodes_as_obvhs() {
        for (n, reinsert) in [(1, false), (2, false), (7, false), (1000, false), (5000, true)] {
            let boxes = random_boxes(n, 1234 + n as u32);
            let mut bvh2 = PlocBuilder::new().build(
                PlocSearchDistance::Low,
                &boxes,
                (0..n as u32).collect(),
                SortPrecision::U64,
                2,
            );
            if reinsert {
                // Reinsertion breaks the children-after-parents order: the recursive path.
                obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut bvh2, 0.05, None);
            }
            let theirs = obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, 3, true, false);
            let mut conv = Converter::default();
            // Twice: the second reuses the first's buffers.
            for _ in 0..2 {
                let ours = conv.convert(&bvh2, 3);
                assert_eq!(ours.nodes, theirs.nodes, "{n} boxes");
                assert_eq!(ours.primitive_indices, theirs.primitive_indices, "{n} boxes");
                assert_eq!(ours.total_aabb, theirs.total_aabb);
            }
        }
    }
}
