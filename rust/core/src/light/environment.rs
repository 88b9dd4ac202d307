//! A uniform environment: the same radiance from every direction (Blender's world colour).

use super::{Light, LightSample};
use crate::sampling::uniform_sphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct UniformEnvironment {
    pub radiance: SampledSpectrum,
    /// Radius of a sphere bounding the scene: the power an infinite light delivers to it.
    pub scene_radius: f32,
}

impl UniformEnvironment {
    pub const PDF: f32 = 1.0 / (4.0 * PI);
}

impl Light for UniformEnvironment {
    fn power(&self, weights: &[f32]) -> f64 {
        // Flux through a disk of the scene's radius from every direction: π r² · 4π ∫L.
        let r = self.scene_radius.max(1e-3) as f64;
        std::f64::consts::PI * r * r * 4.0 * std::f64::consts::PI * self.radiance.dot(weights) as f64
    }
    fn sample_li(&self, _p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        le.copy_from(&self.radiance);
        Some(LightSample { wi: uniform_sphere(u), distance: f32::INFINITY, pdf: Self::PDF, delta: false })
    }
    fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _distance: f32) -> f32 {
        Self::PDF
    }
}
