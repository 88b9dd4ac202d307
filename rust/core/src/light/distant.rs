//! A distant (sun) light: parallel rays travelling along `direction` with spectral
//! irradiance E(λ) on a surface facing them (Blender's sun strength, W/m²).
//!
//! With an angular diameter (Blender's sun `angle`, UsdLux DistantLight `angle`) the
//! sun is a disk of directions of half-angle h about `−direction` with the uniform
//! radiance L = E / (π sin² h), so that a surface facing it still receives E (Cycles:
//! scene/light.cpp, the distant light's area π sin² h; kernel/light/distant.h samples
//! the cone). Next-event estimation samples the cone uniformly: soft shadows. As for a
//! sphere light, camera and BSDF rays do not reach the disk (no sun in a mirror).

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
}

impl Light for DistantLight {
    fn power(&self, weights: &[f32]) -> f64 {
        // Flux through the disk the scene presents to the rays: π r² ∫E dλ.
        let r = self.scene_radius.max(1e-3) as f64;
        std::f64::consts::PI * r * r * self.irradiance.dot(weights) as f64
    }
    fn sample_li(&self, _p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        if let Some(omc) = self.cone() {
            let (local, pdf) = super::sample_uniform_cone(u, omc);
            le.copy_from(&self.irradiance);
            le.scale(self.radiance_scale());
            let wi = Frame::from_normal(-self.direction).to_world(local);
            // Not hittable by BSDF rays: weight 1 (delta), the pdf still divides.
            return Some(LightSample { wi, distance: f32::INFINITY, pdf, delta: true, part: 0 });
        }
        le.copy_from(&self.irradiance);
        Some(LightSample { wi: -self.direction, distance: f32::INFINITY, pdf: 1.0, delta: true, part: 0 })
    }
    /// Light paths start on the disk of the bounding sphere facing the light; the
    /// direction is a delta (pdf_dir = 1), `le` is the irradiance, so `le/pdf_pos` is
    /// the flux through the disk. No normal (the start disk is not a surface a camera
    /// could see) and `delta_position: true`: like a point light, no camera or BSDF ray
    /// can ever reach a distant light, so caustics from it belong to forward tracing.
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let r = self.scene_radius.max(1e-3);
        let d = concentric_disk(u_pos) * r;
        let f = Frame::from_normal(self.direction);
        let origin = self.scene_center - self.direction * r + f.s * d.x + f.t * d.y;
        le.copy_from(&self.irradiance);
        let (direction, pdf_dir) = match self.cone() {
            // A direction in the cone through the disk: the flux per area and solid
            // angle crossing it is L·cos θ (θ from the axis).
            Some(omc) => {
                let (local, pdf) = super::sample_uniform_cone(u_dir, omc);
                le.scale(self.radiance_scale() * local.z);
                (f.to_world(local), pdf)
            }
            None => (self.direction, 1.0),
        };
        Some(EmissionSample {
            origin,
            direction,
            normal: None,
            pdf_pos: 1.0 / (PI * r * r),
            pdf_dir,
            delta_position: true,
            part: 0,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, _dir: Vec3A) -> Option<super::LeDensity> {
        // With an angle its light paths are no strategy of the bidirectional MIS: it
        // reaches camera paths only through light sampling, weighted 1.
        if self.cone().is_some() {
            return None;
        }
        let r = self.scene_radius.max(1e-3);
        Some(super::LeDensity { pos: 1.0 / (PI * r * r), dir: 1.0, cos: 1.0, directional: true })
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
}
