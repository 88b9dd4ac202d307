//! A light tree for next-event estimation: lights with bounds (positions and emission
//! directions) are chosen at each shading point in proportion to an estimate of what
//! they contribute there, not only to their power (eq. 7 is the tree's root: a node's
//! weight is the spectral power of the lights below it). The bounds and the importance
//! follow pbrt-v4's `LightBounds` and `BVHLightSampler` (src/pbrt/lights.cpp,
//! lightsamplers.cpp), Cycles' light tree the anchor (kernel/light/tree.h); unlike
//! pbrt-v4 the importance leaves out the receiver's normal (a vertex's BSDF may
//! transmit, and medium vertices have none), so the choice depends on the point alone.
//! Lights without bounds (a sun, an environment, a moving light) are chosen beside the
//! tree in proportion to their power.

use crate::sampling::Distribution1D;
use glam::Vec3A;
use std::f32::consts::PI;

/// Where a light is and where it emits: an axis-aligned box of its positions, a cone
/// of its normals (axis `w`, half-angle θo as cos), the spread θe (as cos) of emission
/// about those normals, and its power `phi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub lo: Vec3A,
    pub hi: Vec3A,
    pub phi: f32,
    pub w: Vec3A,
    pub cos_theta_o: f32,
    pub cos_theta_e: f32,
    /// Emits from both sides of its normals.
    pub two_sided: bool,
}

impl LightBounds {
    /// A light emitting in every direction from the box (a point or sphere light, or a
    /// shape whose normals are not tracked): never zero importance.
    pub fn omni(lo: Vec3A, hi: Vec3A) -> Self {
        Self { lo, hi, phi: 0.0, w: Vec3A::Z, cos_theta_o: -1.0, cos_theta_e: 0.0, two_sided: false }
    }

    fn centroid(&self) -> Vec3A {
        0.5 * (self.lo + self.hi)
    }

    /// An estimate of the light's contribution at `p` (pbrt-v4 `LightBounds::Importance`
    /// without its normal term): phi cos θ' / d², θ' the smallest angle between the
    /// emission cone and the direction to `p` allowed by the box; 0 where no emission
    /// can reach `p`.
    pub fn importance(&self, p: Vec3A) -> f32 {
        let pc = self.centroid();
        let d2 = p.distance_squared(pc).max(0.5 * (self.hi - self.lo).length());
        let to_p = p - pc;
        let len = to_p.length();
        let mut cos_w = if len > 0.0 { self.w.dot(to_p / len) } else { 1.0 };
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        // θb: the half-angle the box's bounding sphere subtends at p (π inside it).
        let radius2 = 0.25 * (self.hi - self.lo).length_squared();
        let dc2 = p.distance_squared(pc);
        let cos_b = if dc2 < radius2 { -1.0 } else { (1.0 - radius2 / dc2).max(0.0).sqrt() };
        let sin_b = (1.0 - cos_b * cos_b).max(0.0).sqrt();
        let sin_o = (1.0 - self.cos_theta_o * self.cos_theta_o).max(0.0).sqrt();
        // θx = max(0, θw − θo), then θ' = max(0, θx − θb).
        let (cos_x, sin_x) = sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let (cos_p, _) = sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        let v = self.phi * cos_p / d2;
        if v.is_finite() {
            v.max(0.0)
        } else {
            0.0
        }
    }

    /// The bounds of both (pbrt-v4 `Union(LightBounds, LightBounds)`).
    pub fn union(&self, b: &LightBounds) -> LightBounds {
        if self.phi <= 0.0 {
            return *b;
        }
        if b.phi <= 0.0 {
            return *self;
        }
        let (w, cos_theta_o) = cone_union(self.w, self.cos_theta_o, b.w, b.cos_theta_o);
        LightBounds {
            lo: self.lo.min(b.lo),
            hi: self.hi.max(b.hi),
            phi: self.phi + b.phi,
            w,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(b.cos_theta_e),
            two_sided: self.two_sided || b.two_sided,
        }
    }
}

/// cos and sin of max(0, a − b) from those of a and b (angles in [0, π]).
#[inline]
fn sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> (f32, f32) {
    if cos_a > cos_b {
        (1.0, 0.0)
    } else {
        (cos_a * cos_b + sin_a * sin_b, sin_a * cos_b - cos_a * sin_b)
    }
}

/// The smallest cone holding two cones (axes unit, half-angles as cos), as pbrt-v4's
/// `DirectionCone::Union`: the whole sphere (cos −1) when they span more than π.
pub fn cone_union(wa: Vec3A, cos_a: f32, wb: Vec3A, cos_b: f32) -> (Vec3A, f32) {
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = wa.dot(wb).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (wa, cos_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (wb, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= PI {
        return (wa, -1.0);
    }
    let axis = wa.cross(wb);
    if axis.length_squared() == 0.0 {
        return (wa, -1.0);
    }
    // wa rotated by θr = θo − θa towards wb, about their common normal.
    let theta_r = theta_o - theta_a;
    let towards = axis.normalize().cross(wa);
    let w = (wa * theta_r.cos() + towards * theta_r.sin()).normalize();
    (w, theta_o.cos())
}

#[derive(Clone, Copy, Debug)]
enum Node {
    Leaf { light: u32 },
    Inner { second: u32 },
}

/// The tree over the bounded lights and the power distribution over the others.
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    /// Depth-first: an inner node's first child follows it, `second` is the other.
    nodes: Vec<(LightBounds, Node)>,
    /// Per light: the branch taken at each level from the root to its leaf (bit i set:
    /// the second child at depth i) and the depth; None for lights outside the tree.
    trails: Vec<Option<(u64, u32)>>,
    /// Over all lights, the bounded ones at weight 0.
    unbounded: Distribution1D,
    /// Probability that a sample comes from `unbounded`, ∝ its power.
    p_unbounded: f32,
}

impl LightTree {
    /// A trail holds 64 branches; a median split of n lights is only ⌈log2 n⌉ deep.
    const MAX_DEPTH: u32 = 63;

    /// `bounds[l]`: light `l`'s bounds (None: no bounds); `powers[l]`: its weight for
    /// next-event estimation (0: never sampled).
    pub fn new(bounds: &[Option<LightBounds>], powers: &[f64]) -> Self {
        let n = powers.len();
        let trails = vec![None; n];
        let mut bounded: Vec<(u32, LightBounds)> = Vec::new();
        let mut rest = powers.to_vec();
        for (l, b) in bounds.iter().enumerate().take(n) {
            let phi = powers[l].max(0.0) as f32;
            if let Some(b) = b.filter(|_| phi > 0.0 && phi.is_finite()) {
                bounded.push((l as u32, LightBounds { phi, ..b }));
                rest[l] = 0.0;
            }
        }
        let unbounded = Distribution1D::new(&rest);
        let tree_power: f64 = bounded.iter().map(|(_, b)| b.phi as f64).sum();
        let total = tree_power + unbounded.total();
        let p_unbounded = if total > 0.0 { (unbounded.total() / total) as f32 } else { 0.0 };
        let mut tree = Self { nodes: Vec::with_capacity(2 * bounded.len()), trails, unbounded, p_unbounded };
        if !bounded.is_empty() {
            tree.build(&mut bounded, 0, 0);
        }
        tree
    }

    /// Appends the subtree over `lights` (median split along the widest axis of their
    /// centroids); returns its bounds.
    fn build(&mut self, lights: &mut [(u32, LightBounds)], trail: u64, depth: u32) -> LightBounds {
        if lights.len() == 1 || depth >= Self::MAX_DEPTH {
            let (l, b) = lights[0];
            debug_assert!(lights.len() == 1, "light tree too deep");
            self.nodes.push((b, Node::Leaf { light: l }));
            self.trails[l as usize] = Some((trail, depth));
            return b;
        }
        let (lo, hi) =
            lights.iter().fold((Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)), |(lo, hi), (_, b)| {
                (lo.min(b.centroid()), hi.max(b.centroid()))
            });
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = lights.len() / 2;
        lights.select_nth_unstable_by(mid, |a, b| a.1.centroid()[axis].total_cmp(&b.1.centroid()[axis]));
        let me = self.nodes.len();
        self.nodes.push((LightBounds::omni(Vec3A::ZERO, Vec3A::ZERO), Node::Inner { second: 0 }));
        let (first, second) = lights.split_at_mut(mid);
        let a = self.build(first, trail, depth + 1);
        let second_index = self.nodes.len() as u32;
        let b = self.build(second, trail | (1u64 << depth), depth + 1);
        self.nodes[me] = (a.union(&b), Node::Inner { second: second_index });
        self.nodes[me].0
    }

    /// A light for shading point `p` and its probability; None when no light can
    /// reach `p` (or there are none).
    pub fn sample(&self, p: Vec3A, u: f32) -> Option<(usize, f32)> {
        let mut u = u;
        if u < self.p_unbounded {
            let l = self.unbounded.sample(u / self.p_unbounded)?;
            return Some((l, self.p_unbounded * self.unbounded.pmf(l)));
        }
        if self.nodes.is_empty() {
            return None;
        }
        u = ((u - self.p_unbounded) / (1.0 - self.p_unbounded)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        let mut pmf = 1.0 - self.p_unbounded;
        let mut i = 0usize;
        loop {
            match self.nodes[i].1 {
                Node::Leaf { light } => return (pmf > 0.0).then_some((light as usize, pmf)),
                Node::Inner { second } => {
                    let ia = self.nodes[i + 1].0.importance(p);
                    let ib = self.nodes[second as usize].0.importance(p);
                    let sum = ia + ib;
                    if !(sum > 0.0) {
                        return None;
                    }
                    let pa = ia / sum;
                    if u < pa {
                        u = (u / pa).min(1.0 - f32::EPSILON / 2.0);
                        pmf *= pa;
                        i += 1;
                    } else {
                        u = ((u - pa) / (1.0 - pa)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
                        pmf *= 1.0 - pa;
                        i = second as usize;
                    }
                }
            }
        }
    }

    /// The probability with which [`LightTree::sample`] at `p` returns light `l`.
    pub fn pmf(&self, p: Vec3A, l: usize) -> f32 {
        let Some((trail, depth)) = self.trails.get(l).copied().flatten() else {
            return if l < self.trails.len() { self.p_unbounded * self.unbounded.pmf(l) } else { 0.0 };
        };
        let mut pmf = 1.0 - self.p_unbounded;
        let mut i = 0usize;
        for level in 0..depth {
            let Node::Inner { second } = self.nodes[i].1 else {
                return 0.0;
            };
            let ia = self.nodes[i + 1].0.importance(p);
            let ib = self.nodes[second as usize].0.importance(p);
            let sum = ia + ib;
            if !(sum > 0.0) {
                return 0.0;
            }
            if trail & (1u64 << level) == 0 {
                pmf *= ia / sum;
                i += 1;
            } else {
                pmf *= ib / sum;
                i = second as usize;
            }
        }
        pmf
    }
}

/// Where next-event estimation takes its light from: eq. 7's choice ∝ power, or the
/// light tree.
#[derive(Clone, Copy)]
pub enum LightChoice<'s> {
    Power(&'s Distribution1D),
    Tree(&'s LightTree),
}

impl LightChoice<'_> {
    /// A light for a vertex at `p` and its probability.
    #[inline]
    pub fn sample(&self, p: Vec3A, u: f32) -> Option<(usize, f32)> {
        match self {
            LightChoice::Power(d) => d.sample(u).map(|l| (l, d.pmf(l))),
            LightChoice::Tree(t) => t.sample(p, u),
        }
    }
    /// The probability that [`LightChoice::sample`] at `p` returns `l`.
    #[inline]
    pub fn pmf(&self, p: Vec3A, l: usize) -> f32 {
        match self {
            LightChoice::Power(d) => d.pmf(l),
            LightChoice::Tree(t) => t.pmf(p, l),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn point(at: Vec3A) -> Option<LightBounds> {
        Some(LightBounds::omni(at, at))
    }

    fn facing(at: Vec3A, n: Vec3A) -> Option<LightBounds> {
        let half = Vec3A::splat(0.1);
        Some(LightBounds { w: n, cos_theta_o: 1.0, ..LightBounds::omni(at - half, at + half) })
    }

    /// A mix of point lights, one-sided emitters and unbounded lights.
    fn lights() -> (Vec<Option<LightBounds>>, Vec<f64>) {
        let mut b = Vec::new();
        let mut p = Vec::new();
        let mut rng = Rng::for_sample(3, 1, 0);
        for i in 0..37 {
            let at = Vec3A::new(rng.uniform() * 10.0 - 5.0, rng.uniform() * 10.0 - 5.0, rng.uniform() * 3.0);
            b.push(match i % 3 {
                0 => point(at),
                1 => facing(at, Vec3A::new(rng.uniform() - 0.5, rng.uniform() - 0.5, -1.0).normalize()),
                _ => None,
            });
            p.push(if i == 7 { 0.0 } else { 0.5 + rng.uniform() as f64 * 4.0 });
        }
        (b, p)
    }

    /// pmf() is the probability sample() returns a light with; the probabilities sum
    /// to one less the chance that sample() finds no light, which happens only where
    /// some node's lights all face away; a light has pmf 0 only where its own bounds
    /// give it no importance (it cannot light the point).
    #[test]
    fn pmf_matches_sample() {
        let (b, p) = lights();
        let tree = LightTree::new(&b, &p);
        let mut rng = Rng::for_sample(9, 2, 0);
        for _ in 0..20 {
            let x = Vec3A::new(rng.uniform() * 12.0 - 6.0, rng.uniform() * 12.0 - 6.0, rng.uniform() * 4.0 - 1.0);
            let pmfs: Vec<f32> = (0..p.len()).map(|l| tree.pmf(x, l)).collect();
            let sum: f32 = pmfs.iter().sum();
            assert!(sum <= 1.0 + 1e-5, "pmfs sum to {sum} at {x}");
            for (l, &q) in pmfs.iter().enumerate() {
                if q == 0.0 && p[l] > 0.0 {
                    let own = b[l].map_or(1.0, |b| LightBounds { phi: 1.0, ..b }.importance(x));
                    assert_eq!(own, 0.0, "light {l} has pmf 0 at {x} though it may light it");
                }
            }
            assert_eq!(pmfs[7], 0.0, "a light of no power is never chosen");
            let n = 20000;
            let mut counts = vec![0u32; p.len()];
            let mut none = 0u32;
            for _ in 0..n {
                let Some((l, pmf)) = tree.sample(x, rng.uniform()) else {
                    none += 1;
                    continue;
                };
                assert!((pmf - pmfs[l]).abs() <= 1e-5 * pmf.max(1e-3), "sample's pmf {pmf} vs pmf()");
                counts[l] += 1;
            }
            let within = |c: u32, q: f64| {
                let sd = (n as f64 * q * (1.0 - q)).sqrt();
                (c as f64 - n as f64 * q).abs() <= 5.0 * sd + 2.0
            };
            for (l, &c) in counts.iter().enumerate() {
                assert!(within(c, pmfs[l] as f64), "light {l}: {c} of {n}, pmf {}", pmfs[l]);
            }
            assert!(within(none, (1.0 - sum as f64).max(0.0)), "{none} of {n} found no light, pmfs sum to {sum}");
        }
    }

    /// Behind a one-sided emitter (all of whose light faces away) the tree never picks it.
    #[test]
    fn one_sided_emitters_are_not_chosen_from_behind() {
        let b = vec![facing(Vec3A::new(0.0, 0.0, 2.0), -Vec3A::Z), point(Vec3A::new(5.0, 0.0, 2.0))];
        let tree = LightTree::new(&b, &[1.0, 1.0]);
        assert_eq!(tree.pmf(Vec3A::new(0.0, 0.0, 5.0), 0), 0.0);
        assert!(tree.pmf(Vec3A::new(0.0, 0.0, 0.0), 0) > 0.85, "below it, it dominates");
        assert!((tree.pmf(Vec3A::new(0.0, 0.0, 5.0), 1) - 1.0).abs() < 1e-6);
    }

    /// The union of two cones holds both axes' cones.
    #[test]
    fn cone_union_holds_both() {
        let a = Vec3A::Z;
        let b = Vec3A::new(1.0, 0.0, 0.0);
        let (w, c) = cone_union(a, 0.9f32, b, 0.95f32);
        let theta = c.acos();
        assert!(w.dot(a).acos() + 0.9f32.acos() <= theta + 1e-4);
        assert!(w.dot(b).acos() + 0.95f32.acos() <= theta + 1e-4);
        assert_eq!(cone_union(a, 0.0, -a, 0.0).1, -1.0);
    }
}
