//! One emissive triangle of a mesh (in world space), emitting from both faces or, for
//! a one-sided emitter (Cycles' and UsdLux's area lights), from its front face only.

use super::{EmissionSample, Light, LightBounds, LightSample};
use crate::geometry::Frame;
use crate::sampling::cosine_hemisphere;
use crate::sampling::uniform_triangle_point;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct AreaTriangle {
    pub p: [Vec3A; 3],
    pub normal: Vec3A,
    pub area: f32,
    /// Emitted radiance per wavelength (constant over the triangle; an emission that
    /// varies over a mesh is a [`super::MeshLight`]).
    pub radiance: SampledSpectrum,
    /// Emits along `normal` only (the back face is dark).
    pub one_sided: bool,
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
        Some(Self { p, normal: c / len, area, radiance, one_sided: false })
    }

    /// Emits from one face only: the one `normal` points to, or the other one (`flip`).
    pub fn make_one_sided(&mut self, flip: bool) {
        if flip {
            self.normal = -self.normal;
        }
        self.one_sided = true;
    }

    /// Whether direction `wi` from a point towards the light arrives at an emitting face.
    #[inline]
    fn lit_from(&self, wi: Vec3A) -> bool {
        !self.one_sided || self.normal.dot(wi) < 0.0
    }

    /// Solid-angle pdf of choosing the point at `distance` along `wi` from the shading
    /// point, given this triangle is chosen (uniform area sampling).
    pub fn pdf_solid_angle(&self, wi: Vec3A, distance: f32) -> f32 {
        let cos = self.normal.dot(wi).abs();
        if cos <= 0.0 || !self.lit_from(wi) {
            return 0.0;
        }
        distance * distance / (cos * self.area)
    }
}

impl Light for AreaTriangle {
    /// The triangle's box and its normal; emission spreads over the hemisphere about
    /// it (both hemispheres for a two-sided emitter).
    fn bounds(&self) -> Option<LightBounds> {
        let lo = self.p[0].min(self.p[1]).min(self.p[2]);
        let hi = self.p[0].max(self.p[1]).max(self.p[2]);
        Some(LightBounds { w: self.normal, cos_theta_o: 1.0, two_sided: !self.one_sided, ..LightBounds::omni(lo, hi) })
    }
    fn power(&self, weights: &[f32]) -> f64 {
        // Lambertian from each emitting face: Φ = π A ∫ L dλ per face.
        let faces = if self.one_sided { 1.0 } else { 2.0 };
        faces * PI as f64 * self.area as f64 * self.radiance.dot(weights) as f64
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let (_, _, q) = uniform_triangle_point(&self.p, u);
        let (wi, distance, _) = super::direction_to(p, q)?;
        if !self.lit_from(wi) {
            return None; // behind a one-sided emitter
        }
        let pdf = self.pdf_solid_angle(wi, distance);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        le.copy_from(&self.radiance);
        Some(LightSample { wi, distance, pdf, delta: false, part: 0 })
    }
    fn pdf_li(&self, _p: Vec3A, wi: Vec3A, distance: f32) -> f32 {
        self.pdf_solid_angle(wi, distance)
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let (_, _, origin) = uniform_triangle_point(&self.p, u_pos);
        // Both faces: pick one with probability 1/2 (reusing u_dir.x), cosine about it;
        // one-sided: the front, cosine about it.
        let (side, ux, faces) = if self.one_sided {
            (1.0, u_dir.x, 1.0)
        } else if u_dir.x < 0.5 {
            (1.0, u_dir.x * 2.0, 2.0)
        } else {
            (-1.0, (u_dir.x - 0.5) * 2.0, 2.0)
        };
        let n = self.normal * side;
        let local = cosine_hemisphere(Vec2::new(ux.min(0.999_999_9), u_dir.y));
        let pdf_dir = local.z / (faces * PI);
        if !(pdf_dir > 0.0) {
            return None;
        }
        let direction = Frame::from_normal(n).to_world(local);
        le.copy_from(&self.radiance);
        Some(EmissionSample {
            origin,
            direction,
            normal: Some(n),
            pdf_pos: 1.0 / self.area,
            pdf_dir,
            delta_position: false,
            part: 0,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
        // Either face with probability 1/2, cosine-distributed about it (one-sided: the
        // front, none behind it).
        if self.one_sided {
            let cos = self.normal.dot(dir);
            return (cos > 0.0).then(|| super::LeDensity {
                pos: 1.0 / self.area,
                dir: cos / PI,
                cos,
                directional: false,
            });
        }
        let cos = self.normal.dot(dir).abs();
        Some(super::LeDensity { pos: 1.0 / self.area, dir: 0.5 * cos / PI, cos, directional: false })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_half() -> AreaTriangle {
        // In the z = 1 plane, wound so its normal is +z.
        let p = [Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(1.0, 0.0, 1.0), Vec3A::new(0.0, 1.0, 1.0)];
        AreaTriangle::new(p, SampledSpectrum::splat(2, 2.0)).expect("triangle")
    }

    #[test]
    fn one_sided_emits_half_the_power_and_only_in_front() {
        let w = [1.0, 1.0];
        let two = square_half();
        let mut one = square_half();
        one.make_one_sided(true); // front face down (−z)
        assert_eq!(one.normal, Vec3A::new(0.0, 0.0, -1.0));
        assert!((one.power(&w) * 2.0 - two.power(&w)).abs() < 1e-9);
        assert!((one.power(&w) - PI as f64 * 0.5 * 4.0).abs() < 1e-5, "π A ∫L = π · 0.5 · (2 + 2)");
        let mut le = SampledSpectrum::zeros(2);
        let below = Vec3A::new(0.2, 0.2, 0.0);
        let above = Vec3A::new(0.2, 0.2, 2.0);
        let u = Vec2::new(0.3, 0.3);
        let s = one.sample_li(below, u, &mut le).expect("lit from below");
        assert!(s.pdf > 0.0 && (one.pdf_li(below, s.wi, s.distance) - s.pdf).abs() < 1e-4 * s.pdf);
        assert!(one.sample_li(above, u, &mut le).is_none());
        assert_eq!(one.pdf_li(above, Vec3A::new(0.0, 0.0, -1.0), 1.0), 0.0);
        assert!(two.sample_li(above, u, &mut le).is_some());
        // Light paths leave the front only, with a cosine density about it.
        for k in 0..16 {
            let ud = Vec2::new((k as f32 + 0.5) / 16.0, 0.37);
            let e = one.sample_le(Vec2::new(0.25, 0.5), ud, &mut le).expect("emission sample");
            assert!(e.direction.z < 0.0);
            let d = one.pdf_le(e.origin, e.direction).expect("density");
            assert!((d.dir - e.pdf_dir).abs() < 1e-4 * e.pdf_dir && (d.dir - d.cos / PI).abs() < 1e-6);
        }
        assert!(one.pdf_le(Vec3A::new(0.2, 0.2, 1.0), Vec3A::Z).is_none());
    }
}
