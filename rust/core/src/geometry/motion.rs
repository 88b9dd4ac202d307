//! Motion over the shutter (motion blur; docs/camera.md, "Motion blur"). Time runs from
//! 0 (shutter open) to 1 (shutter closed); motion is given as keys evenly spaced over
//! that interval, as Cycles' motion steps are, and interpolated between the two keys
//! around a time:
//!
//! - transforms decomposed into rotation, scale/shear and translation, the rotation
//!   interpolated along the great arc (slerp) and the rest linearly — Cycles'
//!   `transform_motion_decompose` / `transform_motion_array_interpolate`;
//! - vertex positions (deforming meshes) linearly, as Cycles' motion triangles.

use crate::{Error, Result};
use glam::{Affine3A, Mat3A, Quat, Vec3A};

/// The two keys around `time` and the weight of the second.
pub fn key_span(keys: usize, time: f32) -> (usize, usize, f32) {
    let x = time.clamp(0.0, 1.0) * (keys - 1) as f32;
    let i = (x.floor() as usize).min(keys - 2);
    (i, i + 1, x - i as f32)
}

/// A transform split into rotation · (scale and shear) and translation.
#[derive(Clone, Copy, Debug)]
struct Decomposed {
    rotation: Quat,
    stretch: Mat3A,
    translation: Vec3A,
}

impl Decomposed {
    /// Polar decomposition M = R·S (R the nearest rotation, by Higham's iteration
    /// R ← (R + R⁻ᵀ)/2), so interpolating R and S separately never shears a rotation.
    fn new(m: &Affine3A) -> Self {
        let mut r = m.matrix3;
        let flip = r.determinant() < 0.0;
        if flip {
            r *= Mat3A::from_diagonal(glam::Vec3::new(-1.0, 1.0, 1.0));
        }
        for _ in 0..32 {
            let next = (r + r.inverse().transpose()) * 0.5;
            let done = (next - r).to_cols_array().iter().all(|d| d.abs() < 1e-7);
            r = next;
            if done {
                break;
            }
        }
        let stretch = r.transpose() * m.matrix3;
        Self { rotation: Quat::from_mat3a(&r).normalize(), stretch, translation: m.translation }
    }

    fn lerp(&self, other: &Self, w: f32) -> Affine3A {
        let rotation = self.rotation.slerp(other.rotation, w);
        let stretch = self.stretch * (1.0 - w) + other.stretch * w;
        Affine3A {
            matrix3: Mat3A::from_quat(rotation) * stretch,
            translation: self.translation.lerp(other.translation, w),
        }
    }
}

/// Transform keys evenly spaced over the shutter.
#[derive(Clone, Debug)]
pub struct TransformMotion {
    keys: Vec<Decomposed>,
}

impl TransformMotion {
    /// `keys`: at least two finite, invertible transforms; errors name `what`.
    pub fn new(kind: &'static str, name: &str, keys: &[Affine3A]) -> Result<Self> {
        if keys.len() < 2 {
            return Err(Error::object(kind, name, format!("motion needs at least 2 keys, got {}", keys.len())));
        }
        for (k, m) in keys.iter().enumerate() {
            let det = m.matrix3.determinant();
            if !m.is_finite() || det == 0.0 || !det.is_finite() {
                return Err(Error::object(kind, name, format!("motion key {k} is not finite or is singular")));
            }
        }
        // A negative determinant (a mirroring) is carried in the stretch; consecutive
        // quaternions take the short way round.
        let mut dec: Vec<Decomposed> = keys.iter().map(Decomposed::new).collect();
        for k in 1..dec.len() {
            if dec[k].rotation.dot(dec[k - 1].rotation) < 0.0 {
                dec[k].rotation = -dec[k].rotation;
            }
        }
        Ok(Self { keys: dec })
    }

    pub fn key_count(&self) -> usize {
        self.keys.len()
    }

    /// The transform at `time` ∈ [0, 1].
    pub fn at(&self, time: f32) -> Affine3A {
        let (a, b, w) = key_span(self.keys.len(), time);
        self.keys[a].lerp(&self.keys[b], w)
    }

    /// A box around object-space box `(lo, hi)` over the whole shutter: the box at many
    /// times, widened by the chord error of a rotation between two of them.
    pub fn bounds(&self, lo: Vec3A, hi: Vec3A) -> (Vec3A, Vec3A) {
        let steps = 16 * (self.keys.len() - 1);
        let (mut out_lo, mut out_hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        let mut max_angle = 0.0f32;
        for k in 1..self.keys.len() {
            max_angle = max_angle.max(self.keys[k - 1].rotation.angle_between(self.keys[k].rotation));
        }
        let mut radius = 0.0f32;
        for i in 0..=steps {
            let m = self.at(i as f32 / steps as f32);
            for c in 0..8 {
                let p = Vec3A::new(
                    if c & 1 == 0 { lo.x } else { hi.x },
                    if c & 2 == 0 { lo.y } else { hi.y },
                    if c & 4 == 0 { lo.z } else { hi.z },
                );
                let w = m.transform_point3a(p);
                out_lo = out_lo.min(w);
                out_hi = out_hi.max(w);
                radius = radius.max((w - m.translation).length());
            }
        }
        // Between two samples a point turns by at most max_angle/16 and leaves the chord
        // by at most r·(1 − cos(angle/2)).
        let pad = radius * (1.0 - (max_angle / 32.0).cos()) + 1e-6 * radius;
        (out_lo - Vec3A::splat(pad), out_hi + Vec3A::splat(pad))
    }
}

/// Vertex positions (and optionally normals) of a deforming mesh at keys evenly spaced
/// over the shutter.
#[derive(Clone, Debug)]
pub struct VertexMotion {
    pub positions: Vec<Vec<Vec3A>>,
    pub normals: Option<Vec<Vec<Vec3A>>>,
}

impl VertexMotion {
    pub fn key_count(&self) -> usize {
        self.positions.len()
    }

    /// Vertex `i` at `time`.
    #[inline]
    pub fn position(&self, i: usize, time: f32) -> Vec3A {
        let (a, b, w) = key_span(self.positions.len(), time);
        self.positions[a][i].lerp(self.positions[b][i], w)
    }

    /// Normal of vertex `i` at `time` (not normalised), if the keys carry normals.
    #[inline]
    pub fn normal(&self, i: usize, time: f32) -> Option<Vec3A> {
        let n = self.normals.as_ref()?;
        let (a, b, w) = key_span(n.len(), time);
        Some(n[a][i].lerp(n[b][i], w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn transforms_interpolate_rotation_on_the_arc_and_scale_linearly() {
        let a = Affine3A::from_scale_rotation_translation(Vec3::splat(1.0), Quat::IDENTITY, Vec3::ZERO);
        let b = Affine3A::from_scale_rotation_translation(
            Vec3::new(3.0, 1.0, 1.0),
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::new(2.0, 0.0, 0.0),
        );
        let m = TransformMotion::new("instance", "spin", &[a, b]).unwrap();
        let mid = m.at(0.5);
        // Half way: 45° about z, scale 2 along the (rotated) x axis, translation 1.
        let x = mid.transform_vector3a(Vec3A::X);
        assert!((x.length() - 2.0).abs() < 1e-5 && (x.y.atan2(x.x) - std::f32::consts::FRAC_PI_4).abs() < 1e-5, "{x}");
        assert!((mid.translation - Vec3A::new(1.0, 0.0, 0.0)).length() < 1e-6);
        // The ends are the keys, and a point stays on the arc (its radius is kept).
        assert!((m.at(1.0).transform_point3a(Vec3A::Y) - b.transform_point3a(Vec3A::Y)).length() < 1e-5);
        for i in 0..=10 {
            let p = m.at(i as f32 / 10.0).transform_vector3a(Vec3A::Y);
            assert!((p.length() - 1.0).abs() < 1e-5, "{p}");
        }
    }

    #[test]
    fn motion_bounds_contain_every_time() {
        let keys: Vec<Affine3A> = (0..3)
            .map(|k| {
                Affine3A::from_rotation_translation(
                    Quat::from_rotation_y(1.3 * k as f32),
                    Vec3::new(k as f32, 0.0, 0.0),
                )
            })
            .collect();
        let m = TransformMotion::new("instance", "turn", &keys).unwrap();
        let (lo, hi) = m.bounds(Vec3A::splat(-1.0), Vec3A::splat(1.0));
        for i in 0..=1000 {
            let t = m.at(i as f32 / 1000.0);
            for c in [Vec3A::new(1.0, 1.0, 1.0), Vec3A::new(-1.0, 1.0, 1.0), Vec3A::new(1.0, -1.0, -1.0)] {
                let p = t.transform_point3a(c);
                assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{p} outside {lo}..{hi}");
            }
        }
    }

    #[test]
    fn key_span_covers_the_shutter() {
        assert_eq!(key_span(3, 0.0), (0, 1, 0.0));
        assert_eq!(key_span(3, 1.0), (1, 2, 1.0));
        let (a, b, w) = key_span(3, 0.75);
        assert_eq!((a, b), (1, 2));
        assert!((w - 0.5).abs() < 1e-6);
        assert!(TransformMotion::new("instance", "x", &[Affine3A::IDENTITY]).is_err());
    }
}
