//! A distant (sun) light: parallel rays travelling along `direction` with spectral
//! irradiance E(λ) on a surface facing them (Blender's sun strength, W/m²).

use super::{EmissionSample, Light, LightSample};
use crate::geometry::Frame;
use crate::sampling::concentric_disk;
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
}

impl Light for DistantLight {
    fn power(&self, weights: &[f32]) -> f64 {
        // Flux through the disk the scene presents to the rays: π r² ∫E dλ.
        let r = self.scene_radius.max(1e-3) as f64;
        std::f64::consts::PI * r * r * self.irradiance.dot(weights) as f64
    }
    fn sample_li(&self, _p: Vec3A, _u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        le.copy_from(&self.irradiance);
        Some(LightSample { wi: -self.direction, distance: f32::INFINITY, pdf: 1.0, delta: true })
    }
    /// Light paths start on the disk of the bounding sphere facing the light; the
    /// direction is a delta (pdf_dir = 1), `le` is the irradiance, so `le/pdf_pos` is
    /// the flux through the disk. No normal (the start disk is not a surface a camera
    /// could see) and `delta_position: true`: like a point light, no camera or BSDF ray
    /// can ever reach a distant light, so caustics from it belong to forward tracing.
    fn sample_le(&self, u_pos: Vec2, _u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let r = self.scene_radius.max(1e-3);
        let d = concentric_disk(u_pos) * r;
        let f = Frame::from_normal(self.direction);
        let origin = self.scene_center - self.direction * r + f.s * d.x + f.t * d.y;
        le.copy_from(&self.irradiance);
        Some(EmissionSample {
            origin,
            direction: self.direction,
            normal: None,
            pdf_pos: 1.0 / (PI * r * r),
            pdf_dir: 1.0,
            delta_position: true,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, _dir: Vec3A) -> Option<super::LeDensity> {
        let r = self.scene_radius.max(1e-3);
        Some(super::LeDensity { pos: 1.0 / (PI * r * r), dir: 1.0, cos: 1.0, directional: true })
    }
}
