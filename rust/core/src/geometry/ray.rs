//! Rays and self-intersection-free ray origins.

use glam::Vec3A;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3A,
    /// Unit length in world space.
    pub direction: Vec3A,
    pub tmin: f32,
    pub tmax: f32,
    /// When in the shutter the ray travels, 0 (open) … 1 (closed): moving geometry is
    /// intersected where it is then (geometry/motion.rs). One time per path, shared by
    /// all its rays and wavelengths.
    pub time: f32,
    /// What kind of ray this is (`visibility::CAMERA`, ...): instances it does not see
    /// are passed through. `visibility::ALL` unless set.
    pub kind: u8,
}

impl Ray {
    pub fn new(origin: Vec3A, direction: Vec3A) -> Self {
        Self { origin, direction, tmin: 0.0, tmax: f32::INFINITY, time: 0.5, kind: super::visibility::ALL }
    }
    pub fn segment(origin: Vec3A, direction: Vec3A, tmax: f32) -> Self {
        Self { origin, direction, tmin: 0.0, tmax, time: 0.5, kind: super::visibility::ALL }
    }
    /// The same ray as a ray of `kind` (`visibility::CAMERA`, ...).
    #[inline]
    pub fn with_kind(mut self, kind: u8) -> Self {
        self.kind = kind;
        self
    }
    /// The same ray at shutter time `time`.
    #[inline]
    pub fn with_time(mut self, time: f32) -> Self {
        self.time = time;
        self
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

/// The shadow ray from `origin` (the shading point `p` moved off its surface by
/// [`offset_ray_origin`]) to the light point `distance` along `wi` from `p`, ending just
/// short of it. Far from the world origin two things matter (found by the
/// scene-translated-by-1e6 test, where area lights shadowed themselves on 20–35 % of
/// shadow rays): the ray must aim from the offset origin at the light point itself (the
/// offset is 256 ulps of the coordinates — 0.25 units at 1e4, 16 at 1e6 — so keeping
/// `wi` from `p` reaches the light's plane up to 0.25·(1/cos − cos) units early), and the
/// margin must grow with the coordinates (16 ulps of the larger end) besides the
/// relative 1e-4. Infinitely distant lights keep `wi` and an unbounded ray.
/// `time` is the path's shutter time.
pub fn shadow_ray(p: Vec3A, origin: Vec3A, wi: Vec3A, distance: f32, time: f32) -> Ray {
    let shadow = super::visibility::SHADOW;
    if !distance.is_finite() {
        return Ray::new(origin, wi).with_time(time).with_kind(shadow);
    }
    let end = p + wi * distance;
    let d = end - origin;
    let len = d.length();
    if !(len > 0.0 && len.is_finite()) {
        return Ray::segment(origin, wi, 0.0).with_time(time).with_kind(shadow);
    }
    let magnitude = origin.abs().max_element().max(end.abs().max_element());
    Ray::segment(origin, d / len, (len * (1.0 - 1e-4) - magnitude * (16.0 * f32::EPSILON)).max(0.0))
        .with_time(time)
        .with_kind(shadow)
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
        for &s in &[0.0f32, 1.0, 1e3, 1e4, 1e5, 1e6] {
            let p = Vec3A::new(s, -s, s);
            let origin = offset_ray_origin(p, Vec3A::Z);
            for wi in [Vec3A::Z, Vec3A::new(0.6, 0.0, 0.8), Vec3A::new(-0.3, 0.3, 0.2).normalize()] {
                // The light is a plane 200 units above p (its normal along z).
                let distance = 200.0 / wi.z;
                let r = shadow_ray(p, origin, wi, distance, 0.5);
                let hit_plane = (p.z + 200.0 - r.origin.z) / r.direction.z;
                // Short of the light's plane by more than its rounding...
                assert!(
                    r.tmax < hit_plane - 2.0 * (s + 200.0) * f32::EPSILON / r.direction.z,
                    "{s} {wi}: {} vs {hit_plane}",
                    r.tmax
                );
                // ...but by no more than 1e-3 of the distance plus 32 ulps of the coordinates.
                let slack = 1e-3 * hit_plane + 32.0 * f32::EPSILON * (s + 200.0) / r.direction.z;
                assert!(r.tmax > hit_plane - slack, "{s} {wi}: {} vs {hit_plane}", r.tmax);
            }
        }
        assert_eq!(shadow_ray(Vec3A::ZERO, Vec3A::ZERO, Vec3A::Z, f32::INFINITY, 0.5).tmax, f32::INFINITY);
    }
}
