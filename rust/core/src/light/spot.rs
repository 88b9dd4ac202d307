//! A spot light as Blender defines one: a point at `position` shining down `direction`
//! within a cone of full angle `spot_size`, with the edge softened over the fraction
//! `spot_blend` by a smoothstep (Cycles' `spot_attenuation`). Inside the cone's hard
//! core the radiant intensity is the full spectral intensity I(λ); no cosine falloff.
//! With a radius (Blender's `shadow_soft_size`) it is a sphere light as
//! [`super::point`] describes, its radiance scaled by the falloff towards the shading
//! point seen from the centre (Cycles' spot lights are spheres too, Blender 4.x),
//! reached by camera and BSDF rays as a sphere light is.

use super::{EmissionSample, Light, LightBounds, LightSample, Profile};
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct SpotLight {
    pub position: Vec3A,
    /// Unit axis of the cone (the direction light travels).
    pub direction: Vec3A,
    /// Radiant intensity per wavelength on the axis (W·sr⁻¹·nm⁻¹ in scene units).
    pub intensity: SampledSpectrum,
    /// cos(spot_size / 2).
    pub cos_half_angle: f32,
    /// Width in cosine of the blended edge: (1 − cos_half_angle) · spot_blend.
    pub smooth: f32,
    /// Radius of the emitting sphere (0: a point).
    pub radius: f32,
    /// Scales the intensity per direction (an IES profile), on top of the cone.
    pub profile: Option<Profile>,
}

impl SpotLight {
    /// `spot_size` is the cone's full angle in radians (Blender: 0..π), `spot_blend`
    /// in [0, 1]. The caller checks that the values are finite.
    pub fn new(position: Vec3A, direction: Vec3A, intensity: SampledSpectrum, spot_size: f32, spot_blend: f32) -> Self {
        let cos_half_angle = (0.5 * spot_size.clamp(0.0, PI)).cos();
        let smooth = (1.0 - cos_half_angle) * spot_blend.clamp(0.0, 1.0);
        Self {
            position,
            direction: direction.normalize(),
            intensity,
            cos_half_angle,
            smooth,
            radius: 0.0,
            profile: None,
        }
    }

    /// The same spot as a sphere light of `radius` (≥ 0).
    pub fn with_radius(mut self, radius: f32) -> Self {
        self.radius = radius.max(0.0);
        self
    }

    /// The same spot with its intensity scaled per direction by `profile`.
    pub fn with_profile(mut self, profile: Option<Profile>) -> Self {
        self.profile = profile;
        self
    }

    /// The cone's falloff times the profile along unit direction `w` (from the light).
    fn emitted(&self, w: Vec3A) -> f32 {
        let f = self.falloff(w);
        match &self.profile {
            Some(p) if f > 0.0 => f * p.eval(w),
            _ => f,
        }
    }

    /// Fraction of the axis intensity emitted along unit direction `w` (from the light).
    pub fn falloff(&self, w: Vec3A) -> f32 {
        let c = w.dot(self.direction);
        if c <= self.cos_half_angle {
            return 0.0;
        }
        if self.smooth <= 0.0 {
            return 1.0;
        }
        let x = ((c - self.cos_half_angle) / self.smooth).clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    }
}

impl Light for SpotLight {
    /// The sphere's box and the cone: `sample_li` weighs by the falloff of the
    /// direction from the centre, zero outside the cone (with a radius or a profile too).
    fn bounds(&self) -> Option<LightBounds> {
        let r = Vec3A::splat(self.radius.max(0.0));
        Some(LightBounds {
            w: self.direction,
            cos_theta_o: 1.0,
            cos_theta_e: self.cos_half_angle,
            ..LightBounds::omni(self.position - r, self.position + r)
        })
    }
    fn power(&self, weights: &[f32]) -> f64 {
        // The cone's solid angle (the blended edge counted in full: an upper bound
        // that is only used to choose lights).
        // A profile counts with its mean over the sphere (it may gather inside the cone).
        let mean = self.profile.as_ref().map_or(1.0, |p| p.mean()) as f64;
        2.0 * PI as f64 * (1.0 - self.cos_half_angle as f64) * self.intensity.dot(weights) as f64 * mean
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let (wi, _, _) = super::direction_to(p, self.position)?;
        let fall = self.emitted(-wi);
        if fall <= 0.0 {
            return None;
        }
        super::point::sample_point_or_sphere(self.position, self.radius, &self.intensity, fall, p, u, le)
    }
    fn pdf_li(&self, p: Vec3A, wi: Vec3A, _distance: f32) -> f32 {
        // sample_li samples nothing where the falloff towards p is 0.
        match super::direction_to(self.position, p) {
            Some((w, _, _)) if self.radius > 0.0 && self.emitted(w) > 0.0 => {
                super::sphere_cone_pdf(self.position, self.radius, p, wi)
            }
            _ => 0.0,
        }
    }
    fn hittable(&self) -> bool {
        self.radius > 0.0
    }
    fn hit(&self, p: Vec3A, wi: Vec3A, le: &mut SampledSpectrum) -> Option<f32> {
        // The falloff towards p seen from the centre, as `sample_li`.
        let (w, _, _) = super::direction_to(self.position, p)?;
        super::point::sphere_hit(self.position, self.radius, &self.intensity, self.emitted(w), p, wi, le)
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        if self.radius > 0.0 {
            // From the sphere, uniform: the falloff is the receiver's (`receiver_factor_at`).
            return super::point::sphere_le(self.position, self.radius, &self.intensity, u_pos, u_dir, le);
        }
        // Uniform in the cone.
        let one_minus = 1.0 - self.cos_half_angle;
        if one_minus <= 0.0 {
            return None;
        }
        let cos = 1.0 - u_dir.x * one_minus;
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u_dir.y;
        let local = Vec3A::new(sin * phi.cos(), sin * phi.sin(), cos);
        let direction = Frame::from_normal(self.direction).to_world(local);
        le.copy_from(&self.intensity);
        le.scale(self.emitted(direction));
        Some(EmissionSample {
            origin: self.position,
            direction,
            normal: None,
            pdf_pos: 1.0,
            pdf_dir: 1.0 / (2.0 * PI * one_minus),
            delta_position: true,
            part: 0,
        })
    }
    fn receiver_dependent(&self) -> bool {
        self.radius > 0.0
    }
    /// The falloff (and profile) towards `receiver` seen from the centre, as `sample_li`.
    fn receiver_factor_at(&self, receiver: Vec3A, _time: f32) -> f32 {
        if self.radius <= 0.0 {
            return 1.0;
        }
        super::direction_to(self.position, receiver).map_or(0.0, |(w, _, _)| self.emitted(w))
    }
    fn pdf_le(&self, _origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
        // A sphere's light paths are no strategy of the bidirectional MIS (None): their
        // radiance depends on the receiver (`receiver_factor_at`), which the densities
        // of a light vertex cannot express.
        if self.radius > 0.0 {
            return None;
        }
        // Uniform in the cone (sample_le).
        let one_minus = 1.0 - self.cos_half_angle;
        (self.radius <= 0.0 && one_minus > 0.0 && self.direction.dot(dir) >= self.cos_half_angle)
            .then(|| super::LeDensity { pos: 1.0, dir: 1.0 / (2.0 * PI * one_minus), cos: 1.0, directional: false })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn falloff_is_blenders_smoothstep() {
        let s = SpotLight::new(Vec3A::ZERO, -Vec3A::Z, SampledSpectrum::splat(4, 1.0), 1.0, 0.5);
        assert_eq!(s.falloff(-Vec3A::Z), 1.0);
        let at = |theta: f32| s.falloff(Vec3A::new(theta.sin(), 0.0, -theta.cos()));
        assert_eq!(at(0.51), 0.0);
        let c0 = 0.5f32.cos();
        let x = |theta: f32| ((theta.cos() - c0) / ((1.0 - c0) * 0.5)).clamp(0.0, 1.0);
        for &t in &[0.1f32, 0.3, 0.4, 0.45, 0.49] {
            let xx = x(t);
            assert!((at(t) - xx * xx * (3.0 - 2.0 * xx)).abs() < 1e-6);
        }
        // Hard edge without blend.
        let h = SpotLight::new(Vec3A::ZERO, -Vec3A::Z, SampledSpectrum::splat(4, 1.0), 1.0, 0.0);
        assert_eq!(h.falloff(Vec3A::new(0.49f32.sin(), 0.0, -0.49f32.cos())), 1.0);
    }
}
