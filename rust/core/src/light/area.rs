//! One emissive triangle of a mesh (in world space), emitting from both faces.

use super::{EmissionSample, Light, LightSample};
use crate::geometry::Frame;
use crate::sampling::cosine_hemisphere;
use crate::sampling::uniform_triangle;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct AreaTriangle {
    pub p: [Vec3A; 3],
    pub normal: Vec3A,
    pub area: f32,
    /// Emitted radiance per wavelength.
    pub radiance: SampledSpectrum,
}

impl AreaTriangle {
    /// None for a degenerate (zero-area) triangle, which cannot emit.
    pub fn new(p: [Vec3A; 3], radiance: SampledSpectrum) -> Option<Self> {
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = c.length();
        let area = 0.5 * len;
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        Some(Self { p, normal: c / len, area, radiance })
    }

    /// Solid-angle pdf of choosing the point at `distance` along `wi` from the shading
    /// point, given this triangle is chosen (uniform area sampling).
    pub fn pdf_solid_angle(&self, wi: Vec3A, distance: f32) -> f32 {
        let cos = self.normal.dot(wi).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        distance * distance / (cos * self.area)
    }
}

impl Light for AreaTriangle {
    fn power(&self, weights: &[f32]) -> f64 {
        // Both faces, Lambertian: Φ = 2 π A ∫ L dλ.
        2.0 * PI as f64 * self.area as f64 * self.radiance.dot(weights) as f64
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let (b1, b2) = uniform_triangle(u);
        let q = self.p[0] * (1.0 - b1 - b2) + self.p[1] * b1 + self.p[2] * b2;
        let d = q - p;
        let d2 = d.length_squared();
        if d2 <= 0.0 || !d2.is_finite() {
            return None;
        }
        let distance = d2.sqrt();
        let wi = d / distance;
        let pdf = self.pdf_solid_angle(wi, distance);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        le.copy_from(&self.radiance);
        Some(LightSample { wi, distance, pdf, delta: false })
    }
    fn pdf_li(&self, _p: Vec3A, wi: Vec3A, distance: f32) -> f32 {
        self.pdf_solid_angle(wi, distance)
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let (b1, b2) = uniform_triangle(u_pos);
        let origin = self.p[0] * (1.0 - b1 - b2) + self.p[1] * b1 + self.p[2] * b2;
        // Both faces: pick one with probability 1/2 (reusing u_dir.x), cosine about it.
        let (side, ux) = if u_dir.x < 0.5 { (1.0, u_dir.x * 2.0) } else { (-1.0, (u_dir.x - 0.5) * 2.0) };
        let n = self.normal * side;
        let local = cosine_hemisphere(Vec2::new(ux.min(0.999_999_9), u_dir.y));
        let pdf_dir = 0.5 * local.z / PI;
        if !(pdf_dir > 0.0) {
            return None;
        }
        le.copy_from(&self.radiance);
        Some(EmissionSample {
            origin,
            direction: Frame::from_normal(n).to_world(local),
            normal: Some(n),
            pdf_pos: 1.0 / self.area,
            pdf_dir,
            delta_position: false,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
        // Either face with probability 1/2, cosine-distributed about it.
        let cos = self.normal.dot(dir).abs();
        Some(super::LeDensity { pos: 1.0 / self.area, dir: 0.5 * cos / PI, cos, directional: false })
    }
}
