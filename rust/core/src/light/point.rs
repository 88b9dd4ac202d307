//! An isotropic point light.

use super::{EmissionSample, Light, LightSample};
use crate::sampling::uniform_sphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct PointLight {
    pub position: Vec3A,
    /// Radiant intensity per wavelength (W·sr⁻¹·nm⁻¹ in scene units).
    pub intensity: SampledSpectrum,
}

impl Light for PointLight {
    fn power(&self, weights: &[f32]) -> f64 {
        4.0 * PI as f64 * self.intensity.dot(weights) as f64
    }
    fn sample_li(&self, p: Vec3A, _u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let d = self.position - p;
        let d2 = d.length_squared();
        if d2 <= 0.0 || !d2.is_finite() {
            return None;
        }
        let distance = d2.sqrt();
        le.copy_from(&self.intensity);
        le.scale(1.0 / d2);
        Some(LightSample { wi: d / distance, distance, pdf: 1.0, delta: true })
    }
    fn sample_le(&self, _u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        le.copy_from(&self.intensity);
        Some(EmissionSample {
            origin: self.position,
            direction: uniform_sphere(u_dir),
            normal: None,
            pdf_pos: 1.0,
            pdf_dir: 1.0 / (4.0 * PI),
            delta_position: true,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, _dir: Vec3A) -> Option<super::LeDensity> {
        Some(super::LeDensity { pos: 1.0, dir: 1.0 / (4.0 * PI), cos: 1.0, directional: false })
    }
}
