//! A light that moves over the shutter (motion blur of Blender point and spot lights;
//! docs/camera.md). The light is built where it is at the current frame; at shutter
//! time t it is carried by the rigid displacement D(t) = M(t) · M₀⁻¹, M(t) its
//! light → world transform interpolated between keys as objects' are
//! ([`TransformMotion`]) and M₀ the transform it was built at. Scale is dropped from
//! the keys (the light's size and power are the frame's): D is a rotation and a
//! translation, so distances, solid angles and their pdfs, radiance and power are the
//! built light's. A query at time t asks the built light from D(t)⁻¹ p and turns the
//! answer back by D(t).
//!
//! A light at infinity (a sun) only turns: D(t) is the keys' rotation about the centre
//! of the scene's bounding sphere ([`MovingLight::turning_only`]), which maps that
//! sphere onto itself, so the disk its light paths start on still covers the scene.

use super::{EmissionSample, LeDensity, Light, LightBounds, LightSample};
use crate::geometry::motion::TransformMotion;
use crate::spectrum::SampledSpectrum;
use crate::Result;
use glam::{Affine3A, Mat3A, Vec2, Vec3A};

pub struct MovingLight {
    inner: Box<dyn Light>,
    motion: TransformMotion,
    frame_inverse: Affine3A,
    /// Rotation only, about this point (the scene's centre, from `preprocess`).
    turn_about: Option<Vec3A>,
}

/// The rotation and translation of a transform whose columns may be scaled (Blender's
/// T·R·S): the columns normalised, a mirroring undone on X.
fn rigid(m: &Affine3A) -> Affine3A {
    let (x, y, z) = (m.matrix3.x_axis.normalize(), m.matrix3.y_axis.normalize(), m.matrix3.z_axis.normalize());
    let x = if x.cross(y).dot(z) < 0.0 { -x } else { x };
    Affine3A { matrix3: Mat3A::from_cols(x, y, z), translation: m.translation }
}

impl MovingLight {
    /// `inner` as built at the frame, where its light → world transform is `frame`;
    /// `keys` its transforms evenly spaced over the shutter (at least 2).
    pub fn new(name: &str, inner: Box<dyn Light>, frame: Affine3A, keys: &[Affine3A]) -> Result<Self> {
        if !frame.is_finite() || frame.matrix3.determinant() == 0.0 {
            return Err(crate::Error::object("light", name, "its transform is not finite or is singular"));
        }
        let keys: Vec<Affine3A> = keys.iter().map(rigid).collect();
        let motion = TransformMotion::new("light", name, &keys)?;
        Ok(Self { inner, motion, frame_inverse: rigid(&frame).inverse(), turn_about: None })
    }

    /// An emitter built in world space at `frame` that moves with an instance's
    /// `motion`, which must carry it rigidly (`moves_rigidly`): D(t) = M(t) · frame⁻¹.
    pub fn carried(inner: Box<dyn Light>, motion: TransformMotion, frame: Affine3A) -> Self {
        Self { inner, motion, frame_inverse: frame.inverse(), turn_about: None }
    }

    /// Whether `motion` moves what `frame` placed by rotations and translations only
    /// (D(t) = M(t) · frame⁻¹ orthonormal at every key, to 1e-3): then distances, areas
    /// and solid angles of a light built at the frame hold at every time.
    pub fn moves_rigidly(motion: &TransformMotion, frame: &Affine3A) -> bool {
        let inv = frame.inverse();
        let n = motion.key_count();
        (0..n).all(|k| {
            let d = (motion.at(k as f32 / (n - 1).max(1) as f32) * inv).matrix3;
            let gram = d.transpose() * d;
            d.determinant() > 0.0 && (gram - Mat3A::IDENTITY).to_cols_array().iter().all(|e| e.abs() < 1e-3)
        })
    }

    /// The keys' rotation only, about the scene's centre: for lights at infinity.
    pub fn turning_only(mut self) -> Self {
        self.turn_about = Some(Vec3A::ZERO);
        self
    }

    /// D(t): where the built light is carried at shutter time `time`.
    fn at(&self, time: f32) -> Affine3A {
        let d = self.motion.at(time) * self.frame_inverse;
        match self.turn_about {
            Some(c) => {
                let r = Affine3A { matrix3: d.matrix3, translation: Vec3A::ZERO };
                Affine3A::from_translation(c.into()) * r * Affine3A::from_translation((-c).into())
            }
            None => d,
        }
    }
}

impl Light for MovingLight {
    fn preprocess(&mut self, center: Vec3A, radius: f32) {
        if self.turn_about.is_some() {
            self.turn_about = Some(center);
        }
        self.inner.preprocess(center, radius);
    }
    fn power(&self, weights: &[f32]) -> f64 {
        self.inner.power(weights)
    }
    /// The built light's box carried over the whole shutter, emitting every way (the
    /// motion turns its emission cone): the light tree still finds it near where it
    /// moves. A turning sun has none.
    fn bounds(&self) -> Option<LightBounds> {
        if self.turn_about.is_some() {
            return None;
        }
        let b = self.inner.bounds()?;
        // D(t) x = M(t) (frame⁻¹ x): the box in the keys' object space, then over the shutter.
        let (mut lo, mut hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for c in 0..8 {
            let p = Vec3A::new(
                if c & 1 == 0 { b.lo.x } else { b.hi.x },
                if c & 2 == 0 { b.lo.y } else { b.hi.y },
                if c & 4 == 0 { b.lo.z } else { b.hi.z },
            );
            let q = self.frame_inverse.transform_point3a(p);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let (lo, hi) = self.motion.bounds(lo, hi);
        Some(LightBounds::omni(lo, hi))
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        self.sample_li_at(p, 0.5, u, le)
    }
    fn sample_li_at(&self, p: Vec3A, time: f32, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let d = self.at(time);
        let mut ls = self.inner.sample_li(d.inverse().transform_point3a(p), u, le)?;
        ls.wi = d.transform_vector3a(ls.wi).normalize();
        Some(ls)
    }
    fn pdf_li(&self, p: Vec3A, wi: Vec3A, distance: f32) -> f32 {
        self.pdf_li_at(p, wi, distance, 0.5)
    }
    fn pdf_li_at(&self, p: Vec3A, wi: Vec3A, distance: f32, time: f32) -> f32 {
        let inv = self.at(time).inverse();
        self.inner.pdf_li(inv.transform_point3a(p), inv.transform_vector3a(wi).normalize(), distance)
    }
    fn pdf_li_part_at(&self, part: u32, p: Vec3A, wi: Vec3A, distance: f32, time: f32) -> f32 {
        let inv = self.at(time).inverse();
        self.inner.pdf_li_part(part, inv.transform_point3a(p), inv.transform_vector3a(wi).normalize(), distance)
    }
    fn hittable(&self) -> bool {
        self.inner.hittable()
    }
    fn hit(&self, p: Vec3A, wi: Vec3A, le: &mut SampledSpectrum) -> Option<f32> {
        self.hit_at(p, wi, 0.5, le)
    }
    fn hit_at(&self, p: Vec3A, wi: Vec3A, time: f32, le: &mut SampledSpectrum) -> Option<f32> {
        let inv = self.at(time).inverse();
        self.inner.hit(inv.transform_point3a(p), inv.transform_vector3a(wi).normalize(), le)
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        self.sample_le_at(0.5, u_pos, u_dir, le)
    }
    fn sample_le_at(&self, time: f32, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let d = self.at(time);
        let mut es = self.inner.sample_le(u_pos, u_dir, le)?;
        es.origin = d.transform_point3a(es.origin);
        es.direction = d.transform_vector3a(es.direction).normalize();
        es.normal = es.normal.map(|n| d.transform_vector3a(n).normalize());
        Some(es)
    }
    fn pdf_le(&self, origin: Vec3A, dir: Vec3A) -> Option<LeDensity> {
        self.pdf_le_at(origin, dir, 0.5)
    }
    fn receiver_dependent(&self) -> bool {
        self.inner.receiver_dependent()
    }
    fn receiver_factor_at(&self, receiver: Vec3A, time: f32) -> f32 {
        self.inner.receiver_factor_at(self.at(time).inverse().transform_point3a(receiver), time)
    }
    fn pdf_le_at(&self, origin: Vec3A, dir: Vec3A, time: f32) -> Option<LeDensity> {
        let inv = self.at(time).inverse();
        self.inner.pdf_le(inv.transform_point3a(origin), inv.transform_vector3a(dir).normalize())
    }
    fn pdf_le_part_at(&self, part: u32, origin: Vec3A, dir: Vec3A, time: f32) -> Option<LeDensity> {
        let inv = self.at(time).inverse();
        self.inner.pdf_le_part(part, inv.transform_point3a(origin), inv.transform_vector3a(dir).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::PointLight;

    /// The light tree's bounds of a moving light hold it at every time of the shutter.
    #[test]
    fn bounds_hold_the_light_over_the_shutter() {
        let inner =
            PointLight { position: Vec3A::X, intensity: SampledSpectrum::splat(1, 2.0), radius: 0.1, profile: None };
        let key =
            |a: f32| Affine3A::from_rotation_translation(glam::Quat::from_rotation_z(a), glam::Vec3::new(a, 1.0, 0.0));
        let light = MovingLight::new("l", Box::new(inner), key(1.0), &[key(0.0), key(1.0), key(2.0)]).unwrap();
        let b = light.bounds().expect("bounds");
        assert_eq!(b.cos_theta_o, -1.0, "emits every way");
        for i in 0..=64 {
            let t = i as f32 / 64.0;
            // Where the centre is at t: the built light's position carried by D(t).
            let c = light.at(t).transform_point3a(Vec3A::X);
            for d in [Vec3A::X, Vec3A::Y, Vec3A::Z, -Vec3A::X, -Vec3A::Y, -Vec3A::Z] {
                let p = c + 0.1 * d;
                assert!(p.cmpge(b.lo - 1e-5).all() && p.cmple(b.hi + 1e-5).all(), "{p} at t {t} outside {b:?}");
            }
        }
        assert!(light.turning_only().bounds().is_none());
    }

    #[test]
    fn a_point_light_is_where_its_keys_put_it() {
        // Built at x = 1 (the frame, the middle key); keys at x = 0, 1, 2 (and a scale
        // that must not matter): at t = 0.25 it stands at x = 0.5.
        let inner =
            PointLight { position: Vec3A::X, intensity: SampledSpectrum::splat(1, 2.0), radius: 0.0, profile: None };
        let key = |x: f32| {
            Affine3A::from_scale_rotation_translation(
                glam::Vec3::splat(3.0),
                glam::Quat::from_rotation_z(x),
                glam::Vec3::new(x, 0.0, 0.0),
            )
        };
        let light = MovingLight::new("l", Box::new(inner), key(1.0), &[key(0.0), key(1.0), key(2.0)]).unwrap();
        let mut le = SampledSpectrum::splat(1, 0.0);
        let p = Vec3A::new(0.5, 0.0, -2.0);
        let ls = light.sample_li_at(p, 0.25, Vec2::splat(0.5), &mut le).unwrap();
        assert!((ls.wi - Vec3A::Z).length() < 1e-5 && (ls.distance - 2.0).abs() < 1e-5, "{ls:?}");
        assert!((le.get(0) - 0.5).abs() < 1e-5);
        let ls = light.sample_li_at(p, 1.0, Vec2::splat(0.5), &mut le).unwrap();
        assert!((ls.wi - Vec3A::new(1.5, 0.0, 2.0).normalize()).length() < 1e-5, "{ls:?}");
    }
}
