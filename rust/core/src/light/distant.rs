//! A distant (sun) light: parallel rays travelling along `direction` with spectral
//! irradiance E(λ) on a surface facing them (Blender's sun strength, W/m²).
//!
//! With an angular diameter (Blender's sun `angle`, UsdLux DistantLight `angle`) the
//! sun is a disk of directions of half-angle h about `−direction` with the uniform
//! radiance L = E / (π sin² h), so that a surface facing it still receives E (Cycles:
//! scene/light.cpp, the distant light's area π sin² h; kernel/light/distant.h samples
//! the cone). Next-event estimation samples the cone uniformly: soft shadows. A ray
//! that leaves the scene inside the cone sees the disk ([`Light::hit`], Cycles'
//! `distant_light_intersect`): the sun shows in mirrors, its caustics through glass,
//! and light samples are MIS-weighted against BSDF sampling. Parallel rays (angle 0)
//! stay a delta light, reached by light sampling only.

use super::{EmissionSample, Light, LightSample};
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct DistantLight {
    /// Unit direction the light travels (Blender: the sun object's −Z axis).
    pub direction: Vec3A,
    /// Irradiance per wavelength on a plane perpendicular to the rays.
    pub irradiance: SampledSpectrum,
    /// A sphere bounding the scene: where light paths start and what power means.
    pub scene_center: Vec3A,
    pub scene_radius: f32,
    /// Half the angular diameter, radians in [0, π/2] (0: parallel rays).
    pub half_angle: f32,
}

impl DistantLight {
    /// 1 − cos h, or None for parallel rays.
    fn cone(&self) -> Option<f32> {
        let h = self.half_angle.min(std::f32::consts::FRAC_PI_2);
        let s = (0.5 * h).sin();
        let omc = 2.0 * s * s;
        (h > 0.0 && omc > 0.0).then_some(omc)
    }
    /// Radiance of the disk per unit irradiance: 1 / (π sin² h).
    fn radiance_scale(&self) -> f32 {
        let s = self.half_angle.min(std::f32::consts::FRAC_PI_2).sin();
        1.0 / (PI * s * s)
    }
    /// Unit `wi` lies in the disk of directions (θ ≤ h from −direction; compared by
    /// sin² θ = |wi × axis|², exact for the small angles of real suns).
    fn in_cone(&self, wi: Vec3A) -> bool {
        let axis = -self.direction;
        let s = self.half_angle.min(std::f32::consts::FRAC_PI_2).sin();
        wi.dot(axis) > 0.0 && wi.cross(axis).length_squared() <= s * s
    }
}

impl Light for DistantLight {
    fn preprocess(&mut self, center: Vec3A, radius: f32) {
        self.scene_center = center;
        self.scene_radius = radius;
    }
    fn power(&self, weights: &[f32]) -> f64 {
        // Flux through the disk the scene presents to the rays: π r² ∫E dλ.
        let r = super::infinite_light_radius(self.scene_radius) as f64;
        std::f64::consts::PI * r * r * self.irradiance.dot(weights) as f64
    }
    fn sample_li(&self, _p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        if let Some(omc) = self.cone() {
            let (local, pdf) = super::sample_uniform_cone(u, omc);
            le.copy_from(&self.irradiance);
            le.scale(self.radiance_scale());
            let wi = Frame::from_normal(-self.direction).to_world(local);
            // BSDF rays that escape in the cone see the disk too (`hit`): MIS.
            return Some(LightSample { wi, distance: f32::INFINITY, pdf, delta: false, part: 0 });
        }
        le.copy_from(&self.irradiance);
        Some(LightSample { wi: -self.direction, distance: f32::INFINITY, pdf: 1.0, delta: true, part: 0 })
    }
    /// Uniform over the disk of directions (Cycles' `distant_light_pdf`: 1/(2π(1−cos h))).
    fn pdf_li(&self, _p: Vec3A, wi: Vec3A, _distance: f32) -> f32 {
        match self.cone() {
            Some(omc) if self.in_cone(wi) => 1.0 / (2.0 * PI * omc),
            _ => 0.0,
        }
    }
    fn hittable(&self) -> bool {
        self.cone().is_some()
    }
    fn hit(&self, _p: Vec3A, wi: Vec3A, le: &mut SampledSpectrum) -> Option<f32> {
        if self.cone().is_none() || !self.in_cone(wi) {
            return None;
        }
        le.copy_from(&self.irradiance);
        le.scale(self.radiance_scale());
        Some(f32::INFINITY)
    }
    /// Light paths start on the disk of the bounding sphere facing the ray's direction
    /// ([`super::infinite_light_origin`]), `le/(pdf_pos·pdf_dir)` is the flux through
    /// the disk. Parallel rays: the direction is a delta (pdf_dir = 1) and `le` the
    /// irradiance. With an angle: a direction uniform in the cone (as `sample_li`
    /// draws it), `le` the disk's radiance, the start disk perpendicular to that
    /// direction (pbrt-v4's infinite lights), so every direction's rays cover the whole
    /// bounding sphere. No normal (the start disk is not a surface a camera could
    /// see). `delta_position` for parallel rays: like a point light, no camera or BSDF
    /// ray can reach them, so their caustics belong to forward tracing; a sun with an
    /// angle is reached by rays that escape in its cone ([`Light::hit`]).
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let r = super::infinite_light_radius(self.scene_radius);
        le.copy_from(&self.irradiance);
        let cone = self.cone();
        let (direction, pdf_dir) = match cone {
            Some(omc) => {
                let (local, pdf) = super::sample_uniform_cone(u_dir, omc);
                le.scale(self.radiance_scale());
                (Frame::from_normal(self.direction).to_world(local), pdf)
            }
            None => (self.direction, 1.0),
        };
        Some(EmissionSample {
            origin: super::infinite_light_origin(self.scene_center, r, direction, u_pos),
            direction,
            normal: None,
            pdf_pos: 1.0 / (PI * r * r),
            pdf_dir,
            delta_position: cone.is_none(),
            part: 0,
        })
    }
    /// Per unit area perpendicular to `dir` on the start disk; the direction's density
    /// is 1 for parallel rays (a delta) and the cone's uniform pdf with an angle (0
    /// outside the disk of directions: None).
    fn pdf_le(&self, _origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
        let r = super::infinite_light_radius(self.scene_radius);
        let pos = 1.0 / (PI * r * r);
        match self.cone() {
            None => Some(super::LeDensity { pos, dir: 1.0, cos: 1.0, directional: true }),
            Some(omc) if self.in_cone(-dir) => {
                Some(super::LeDensity { pos, dir: 1.0 / (2.0 * PI * omc), cos: 1.0, directional: true })
            }
            Some(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// A sun of angular diameter 2h: irradiance on a facing surface is E whatever the
    /// angle (the mean of L·cos/pdf of its light samples), and on a surface tilted by
    /// α (α + h ≤ π/2) E·cos α, the closed form of a uniform disk of directions.
    #[test]
    fn sun_disk_irradiance_is_the_strength() {
        for &h in &[0.0f32, 0.01, 0.2, 0.6] {
            let sun = DistantLight {
                direction: -Vec3A::Z,
                irradiance: SampledSpectrum::splat(1, 2.0),
                scene_center: Vec3A::ZERO,
                scene_radius: 1.0,
                half_angle: h,
            };
            for &alpha in &[0.0f32, 0.5] {
                let n = Vec3A::new(alpha.sin(), 0.0, alpha.cos());
                let mut rng = Rng::new(3, 2);
                let mut le = SampledSpectrum::zeros(1);
                let count = 100_000;
                let mut sum = 0.0f64;
                for _ in 0..count {
                    let ls = sun.sample_li(Vec3A::ZERO, rng.uniform2(), &mut le).unwrap();
                    assert!(ls.wi.z >= (h.cos() - 1e-5), "outside the cone");
                    sum += (le.get(0) * ls.wi.dot(n).max(0.0) / ls.pdf) as f64;
                }
                let e = sum / count as f64;
                let closed = 2.0 * alpha.cos() as f64;
                assert!((e / closed - 1.0).abs() < 2e-3, "h {h} alpha {alpha}: {e} vs {closed}");
            }
        }
    }

    /// What light sampling returns, a ray reaches ([`Light::hit`]) with the same
    /// radiance and `pdf_li`; directions outside the disk reach nothing. The pdf is
    /// normalised: the disk's solid angle 2π(1 − cos h) times it is 1.
    #[test]
    fn sampled_directions_hit_the_disk_with_their_pdf() {
        for &h in &[0.004_6f32, 0.2, 1.2] {
            let sun = DistantLight {
                direction: Vec3A::new(0.3, -0.2, -0.9).normalize(),
                irradiance: SampledSpectrum::splat(1, 2.0),
                scene_center: Vec3A::ZERO,
                scene_radius: 1.0,
                half_angle: h,
            };
            assert!(sun.hittable());
            let mut rng = Rng::new(9, 4);
            let (mut le, mut hit) = (SampledSpectrum::zeros(1), SampledSpectrum::zeros(1));
            for _ in 0..2000 {
                let ls = sun.sample_li(Vec3A::ZERO, rng.uniform2(), &mut le).unwrap();
                assert!(!ls.delta);
                let t = sun.hit(Vec3A::ZERO, ls.wi, &mut hit).expect("a sampled direction reaches the disk");
                assert!(t.is_infinite() && hit.get(0) == le.get(0));
                let pdf = sun.pdf_li(Vec3A::ZERO, ls.wi, t);
                assert!((pdf - ls.pdf).abs() <= 1e-4 * ls.pdf, "h {h}: {pdf} vs {}", ls.pdf);
                assert!((pdf as f64 * 2.0 * std::f64::consts::PI * (1.0 - (h as f64).cos()) - 1.0).abs() < 1e-3);
            }
            let away = Frame::from_normal(-sun.direction).to_world(Vec3A::new((1.02 * h).sin(), 0.0, (1.02 * h).cos()));
            assert!(sun.hit(Vec3A::ZERO, away, &mut hit).is_none() && sun.pdf_li(Vec3A::ZERO, away, 1.0) == 0.0);
        }
        let parallel = DistantLight {
            direction: -Vec3A::Z,
            irradiance: SampledSpectrum::splat(1, 2.0),
            scene_center: Vec3A::ZERO,
            scene_radius: 1.0,
            half_angle: 0.0,
        };
        let mut le = SampledSpectrum::zeros(1);
        assert!(!parallel.hittable() && parallel.hit(Vec3A::ZERO, Vec3A::Z, &mut le).is_none());
        assert!(parallel.sample_li(Vec3A::ZERO, Vec2::splat(0.5), &mut le).unwrap().delta);
    }
}
