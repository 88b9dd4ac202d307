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

/// Length of a shadow ray that leaves from `origin` (the shading point `p` moved off its
/// surface by [`offset_ray_origin`]) along `wi` towards a light point `distance` from `p`,
/// stopping just short of the light's surface. Two things matter far from the origin
/// (found by the scene-translated-by-1e6 test, where area lights shadowed themselves):
/// the distance is measured from the offset origin (the offset is 256 ulps of the
/// coordinates: 0.25 units at 1e4, 16 at 1e6, far more than a relative 1e-4 of the
/// distance), and the margin grows with the coordinates (16 ulps of the larger end).
pub fn shadow_ray_tmax(p: Vec3A, origin: Vec3A, wi: Vec3A, distance: f32) -> f32 {
    if !distance.is_finite() {
        return f32::INFINITY;
    }
    let end = p + wi * distance;
    let along = (end - origin).dot(wi);
    let magnitude = origin.abs().max_element().max(end.abs().max_element());
    (along * (1.0 - 1e-4) - magnitude * (16.0 * f32::EPSILON)).max(0.0)
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

    #[test]
    fn shadow_rays_stop_short_of_the_light_at_any_scale() {
        for &s in &[0.0f32, 1.0, 1e3, 1e6, 1e7] {
            let o = Vec3A::splat(s);
            let t = shadow_ray_tmax(o, o, Vec3A::Z, 100.0);
            // Short of the end by more than the end point's own rounding (a few ulps)...
            assert!(t < 100.0 && (o.z + 100.0) - (o.z + t) >= 4.0 * (s + 100.0) * f32::EPSILON, "{s}: {t}");
            // ...but not by more than a few percent at 1e6 units and nothing at the origin.
            assert!(t > 100.0 * (1.0 - 1e-4) - 1e-3 * s.max(1.0), "{s}: {t}");
        }
        assert_eq!(shadow_ray_tmax(Vec3A::ZERO, Vec3A::ZERO, Vec3A::Z, f32::INFINITY), f32::INFINITY);
        // From an offset origin the ray still ends before the light, at any scale.
        for &s in &[1.0f32, 1e4, 1e6] {
            let p = Vec3A::new(s, -s, s);
            let origin = offset_ray_origin(p, Vec3A::Z);
            let t = shadow_ray_tmax(p, origin, Vec3A::Z, 200.0);
            assert!(origin.z + t < p.z + 200.0, "{s}: {t}");
        }
    }
}
