//! Watertight ray/triangle intersection: Woop, Benthin & Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1), 2013. Rays through a shared edge or vertex
//! hit exactly one of the triangles that share it, so light never leaks through seams.

use glam::{Mat3A, Vec3A};

/// Per-ray constants of the watertight test (computed once per ray and space).
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3A,
    /// The paper's permutation and shear as one matrix: for a vertex p, M (p − origin)
    /// = (p[kx] − sx p[kz], p[ky] − sy p[kz], sz p[kz]). Its columns are unit vectors
    /// and (−sx, −sy, sz), so each component is the paper's expression with zeros added
    /// (the same numbers), in three vector products instead of nine lane picks by index.
    shear: Mat3A,
}

impl WatertightRay {
    pub fn new(origin: Vec3A, dir: Vec3A) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = dir[kz];
        let mut cols = [Vec3A::ZERO; 3];
        cols[kx] = Vec3A::X;
        cols[ky] = Vec3A::Y;
        cols[kz] = Vec3A::new(-(dir[kx] / dz), -(dir[ky] / dz), 1.0 / dz);
        Self { origin, shear: Mat3A::from_cols(cols[0], cols[1], cols[2]) }
    }

    /// Distance along the ray and barycentrics (b1, b2) of the hit, or None.
    /// Hits outside (tmin, tmax) are rejected.
    #[inline]
    pub fn intersect(&self, p0: Vec3A, p1: Vec3A, p2: Vec3A, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let a = self.shear * (p0 - self.origin);
        let b = self.shear * (p1 - self.origin);
        let c = self.shear * (p2 - self.origin);
        let (ax, ay, bx, by, cx, cy) = (a.x, a.y, b.x, b.y, c.x, c.y);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Edge cases are decided in double precision, as the paper prescribes.
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            v = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let t_scaled = u * a.z + v * b.z + w * c.z;
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t > tmin && t < tmax) {
            return None;
        }
        // b1 weights p1, b2 weights p2.
        Some((t, v * inv, w * inv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_inside_misses_outside() {
        let (p0, p1, p2) = (Vec3A::new(-1.0, -1.0, 0.0), Vec3A::new(1.0, -1.0, 0.0), Vec3A::new(0.0, 1.0, 0.0));
        let r = WatertightRay::new(Vec3A::new(0.0, 0.0, 2.0), Vec3A::new(0.0, 0.0, -1.0));
        let (t, b1, b2) = r.intersect(p0, p1, p2, 0.0, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        let p = p0 * (1.0 - b1 - b2) + p1 * b1 + p2 * b2;
        assert!(p.length() < 1e-6);
        let miss = WatertightRay::new(Vec3A::new(2.0, 0.0, 2.0), Vec3A::new(0.0, 0.0, -1.0));
        assert!(miss.intersect(p0, p1, p2, 0.0, f32::INFINITY).is_none());
        assert!(r.intersect(p0, p1, p2, 0.0, 1.0).is_none());
    }

    #[test]
    fn shared_edge_is_hit_exactly_once() {
        // Two triangles sharing the diagonal of a quad; rays along the diagonal.
        let q = [
            Vec3A::new(0.0, 0.0, 0.0),
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(1.0, 1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ];
        for i in 1..50 {
            let s = i as f32 / 50.0;
            let r = WatertightRay::new(Vec3A::new(s, s, 1.0), Vec3A::new(0.0, 0.0, -1.0));
            let h1 = r.intersect(q[0], q[1], q[2], 0.0, f32::INFINITY).is_some();
            let h2 = r.intersect(q[0], q[2], q[3], 0.0, f32::INFINITY).is_some();
            assert!(h1 || h2, "leak at {s}");
        }
    }

    #[test]
    fn degenerate_triangle_is_never_hit() {
        let p = Vec3A::new(0.0, 0.0, 0.0);
        let r = WatertightRay::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(0.0, 0.0, -1.0));
        assert!(r.intersect(p, p, p, 0.0, f32::INFINITY).is_none());
        assert!(r.intersect(p, Vec3A::X, Vec3A::X * 2.0, 0.0, f32::INFINITY).is_none());
    }
}
