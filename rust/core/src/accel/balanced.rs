//! A balanced binary BVH by median splits, for boxes PLOC makes too deep a tree of.
//!
//! PLOC merges each cluster with its nearest neighbour by the area of their union. When
//! that area is the same for every pair (coincident triangles, triangles collapsed to a
//! point) or grows by one cluster at a time (triangles nested around one point), the
//! merges form a chain: 2000 copies of one triangle made a wide BVH deeper than the
//! traversal's 32-entry stack, 10k triangles at one point one 3500 wide nodes deep.
//! Median splits cut every range in halves by count, whatever the boxes, so n boxes
//! give a tree ceil(log2 n) + 1 levels deep (31 for a billion).

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;

/// Rebuilds `bvh` over `aabbs`: one primitive per leaf, each range split at its median
/// centroid along the axis over which its centroids spread most (by index when they all
/// coincide), children stored after their parents.
pub(super) fn build(bvh: &mut Bvh2, aabbs: &[Aabb]) {
    let n = aabbs.len();
    *bvh = Bvh2 { children_are_ordered_after_parents: true, ..Bvh2::default() };
    if n == 0 {
        return;
    }
    let mut ids: Vec<u32> = (0..n as u32).collect();
    let centre = |i: u32| aabbs[i as usize].center();
    bvh.nodes.reserve(2 * n - 1);
    bvh.nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
    // (node, first id, end)
    let mut todo = vec![(0usize, 0usize, n)];
    while let Some((node, start, end)) = todo.pop() {
        let range = &mut ids[start..end];
        let mut aabb = Aabb::empty();
        let (mut lo, mut hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for &i in range.iter() {
            aabb = aabb.union(&aabbs[i as usize]);
            lo = lo.min(centre(i));
            hi = hi.max(centre(i));
        }
        if range.len() == 1 {
            bvh.nodes[node] = Bvh2Node::new(aabb, 1, start as u32);
            continue;
        }
        let spread = hi - lo;
        let axis = if spread.x >= spread.y && spread.x >= spread.z {
            0
        } else if spread.y >= spread.z {
            1
        } else {
            2
        };
        let mid = range.len() / 2;
        if spread[axis] > 0.0 {
            range.select_nth_unstable_by(mid, |&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        }
        let first = bvh.nodes.len();
        bvh.nodes[node] = Bvh2Node::new(aabb, 0, first as u32);
        bvh.nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
        bvh.nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
        todo.push((first, start, start + mid));
        todo.push((first + 1, start + mid, end));
    }
    bvh.primitive_indices = ids;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Depth of a binary BVH (1: a single leaf).
    fn depth(bvh: &Bvh2) -> usize {
        let mut todo = vec![(0usize, 1usize)];
        let mut deepest = 0;
        while let Some((i, d)) = todo.pop() {
            deepest = deepest.max(d);
            let n = &bvh.nodes[i];
            if !n.is_leaf() {
                todo.extend([(n.first_index as usize, d + 1), (n.first_index as usize + 1, d + 1)]);
            }
        }
        deepest
    }

    #[test]
    fn coincident_boxes_give_a_tree_log2_n_deep_holding_each_box_once() {
        for n in [1usize, 2, 3, 1000, 10_000] {
            let boxes = vec![Aabb::new(Vec3A::splat(0.5), Vec3A::splat(0.5)); n];
            let mut bvh = Bvh2::default();
            build(&mut bvh, &boxes);
            assert_eq!(bvh.nodes.len(), 2 * n - 1);
            assert_eq!(depth(&bvh), (n as f64).log2().ceil() as usize + 1, "{n}");
            let mut seen = bvh.primitive_indices.clone();
            seen.sort_unstable();
            assert_eq!(seen, (0..n as u32).collect::<Vec<_>>());
            bvh.validate(&boxes, false, true);
        }
    }
}
