//! Rays and self-intersection-free ray origins.

use glam::Vec3A;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3A,
    /// Unit length in world space.
    pub direction: Vec3A,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(origin: Vec3A, direction: Vec3A) -> Self {
        Self { origin, direction, tmin: 0.0, tmax: f32::INFINITY }
    }
    pub fn segment(origin: Vec3A, direction: Vec3A, tmax: f32) -> Self {
        Self { origin, direction, tmin: 0.0, tmax }
    }
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.direction * t
    }
}

/// Moves a hit point off its surface along the geometric normal `n` (pointing to the
/// side the new ray leaves from) by a few ULPs of the point's own magnitude, so that
/// neither a scene at the origin nor one 1e6 units away intersects itself.
/// Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
/// Ray Tracing Gems (2019), ch. 6.
pub fn offset_ray_origin(p: Vec3A, n: Vec3A) -> Vec3A {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i = [(INT_SCALE * n.x) as i32, (INT_SCALE * n.y) as i32, (INT_SCALE * n.z) as i32];
    let shift = |v: f32, o: i32| -> f32 {
        let bits = v.to_bits() as i32;
        f32::from_bits((bits + if v < 0.0 { -o } else { o }) as u32)
    };
    let pi = [shift(p.x, of_i[0]), shift(p.y, of_i[1]), shift(p.z, of_i[2])];
    let pick = |v: f32, pi: f32, nv: f32| if v.abs() < ORIGIN { v + FLOAT_SCALE * nv } else { pi };
    Vec3A::new(pick(p.x, pi[0], n.x), pick(p.y, pi[1], n.y), pick(p.z, pi[2], n.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_normal_side_at_any_scale() {
        for &s in &[0.0f32, 1e-3, 1.0, 1e3, 1e6] {
            let p = Vec3A::new(s, -s, 0.5 * s);
            let n = Vec3A::new(0.0, 0.0, 1.0);
            let q = offset_ray_origin(p, n);
            assert!(q.z > p.z, "scale {s}");
            assert!((q - p).length() <= 1e-4f32.max(s * 1e-4));
        }
    }
}
