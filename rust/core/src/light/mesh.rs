//! The emissive triangles of one mesh instance as one light, for an emission that
//! varies over the surface (a node graph, docs/shading.md): a triangle is chosen by a
//! cdf ∝ area × an estimate of its emitted power, a point on it uniformly, and the
//! radiance is evaluated exactly at that point (`SurfaceEmission`). Only the selection
//! (the cdf and the light's power) uses the estimate, so the estimator stays unbiased
//! whatever the estimate is; the build costs O(triangles) evaluations with a small
//! constant (`MeshLight::ESTIMATE_BUDGET`).

use super::{EmissionSample, LeDensity, Light, LightBounds, LightSample};
use crate::geometry::Frame;
use crate::sampling::{cosine_hemisphere, uniform_triangle_point, Distribution1D};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;
use std::sync::Arc;

/// The emission of a mesh's surface, evaluated where a light sample lands.
pub trait SurfaceEmission: Send + Sync {
    /// Radiance at barycentrics (b1, b2) of mesh triangle `triangle`, seen along
    /// `incoming` (unit, from the point towards the viewer).
    fn radiance(&self, triangle: u32, b1: f32, b2: f32, incoming: Vec3A, out: &mut SampledSpectrum);
    /// The light-selection estimate of the triangle's mean radiance (front face): the
    /// mean over `strata × strata` stratified points (1: the centroid).
    fn estimate(&self, triangle: u32, strata: usize, out: &mut SampledSpectrum);
}

pub struct MeshLight {
    /// Mesh triangle ids (ascending) and their world-space corners.
    triangles: Vec<u32>,
    p: Vec<[Vec3A; 3]>,
    /// Over `triangles`: ∝ area × estimated power (plus a small floor, so that no
    /// triangle that might emit is left out of light paths).
    distribution: Distribution1D,
    /// Σ area × estimated radiance: the light's power is 2π times its integral.
    area_radiance: SampledSpectrum,
    surface: Arc<dyn SurfaceEmission>,
}

/// Normal (unit) and area of a triangle; None when degenerate.
fn normal_area(p: &[Vec3A; 3]) -> Option<(Vec3A, f32)> {
    let c = (p[1] - p[0]).cross(p[2] - p[0]);
    let len = c.length();
    let area = 0.5 * len;
    (area > 0.0 && area.is_finite()).then(|| (c / len, area))
}

impl MeshLight {
    /// Estimate evaluations over the whole mesh at build: a mesh of n triangles gets
    /// s × s stratified points per triangle with s = ⌊√(budget / n)⌋ clamped to 1..8,
    /// so at most max(n, budget) evaluations.
    pub const ESTIMATE_BUDGET: usize = 4096;
    /// The cdf's floor, relative to the mean estimated radiance.
    pub const FLOOR: f64 = 1e-3;

    /// None when no triangle has an area. `weights`: the grid's quadrature weights.
    pub fn new(triangles: Vec<(u32, [Vec3A; 3])>, surface: Arc<dyn SurfaceEmission>, weights: &[f32]) -> Option<Self> {
        let triangles: Vec<(u32, [Vec3A; 3], f32)> =
            triangles.into_iter().filter_map(|(t, p)| normal_area(&p).map(|(_, a)| (t, p, a))).collect();
        if triangles.is_empty() {
            return None;
        }
        debug_assert!(triangles.windows(2).all(|w| w[0].0 < w[1].0), "triangle ids must ascend");
        let strata = ((Self::ESTIMATE_BUDGET / triangles.len()) as f64).sqrt().clamp(1.0, 8.0) as usize;
        let n = weights.len();
        let mut area_radiance = SampledSpectrum::zeros(n);
        let mut est = SampledSpectrum::zeros(n);
        let mut power = Vec::with_capacity(triangles.len());
        let mut total_area = 0.0f64;
        for &(t, _, a) in &triangles {
            surface.estimate(t, strata, &mut est);
            power.push(a as f64 * est.dot(weights) as f64);
            for (o, &e) in area_radiance.values_mut().iter_mut().zip(est.values()) {
                *o += a * e;
            }
            total_area += a as f64;
        }
        let total: f64 = power.iter().sum();
        let floor = Self::FLOOR * total / total_area;
        let cdf_weights: Vec<f64> = if total > 0.0 {
            power.iter().zip(&triangles).map(|(&w, &(_, _, a))| w + floor * a as f64).collect()
        } else {
            triangles.iter().map(|&(_, _, a)| a as f64).collect()
        };
        Some(Self {
            distribution: Distribution1D::new(&cdf_weights),
            p: triangles.iter().map(|t| t.1).collect(),
            triangles: triangles.into_iter().map(|t| t.0).collect(),
            area_radiance,
            surface,
        })
    }

    /// Number of triangles the light samples.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    fn local(&self, triangle: u32) -> Option<usize> {
        self.triangles.binary_search(&triangle).ok()
    }

    /// Area density of a point on local triangle `i`.
    fn pdf_area(&self, i: usize) -> Option<(Vec3A, f32)> {
        let (n, area) = normal_area(&self.p[i])?;
        Some((n, self.distribution.pmf(i) / area))
    }
}

impl Light for MeshLight {
    /// The mesh's box, emitting every way (its triangles face anywhere).
    fn bounds(&self) -> Option<LightBounds> {
        let mut lo = Vec3A::splat(f32::INFINITY);
        let mut hi = Vec3A::splat(f32::NEG_INFINITY);
        for t in &self.p {
            for &q in t {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        Some(LightBounds::omni(lo, hi))
    }
    fn power(&self, weights: &[f32]) -> f64 {
        // Both faces, Lambertian: Φ = 2 π Σ A ∫ L dλ (with the estimated L).
        2.0 * PI as f64 * self.area_radiance.dot(weights) as f64
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let (i, ux) = self.distribution.sample_remapped(u.x)?;
        let (b1, b2, q) = uniform_triangle_point(&self.p[i], Vec2::new(ux, u.y));
        let (wi, distance, d2) = super::direction_to(p, q)?;
        let (n, pdf_area) = self.pdf_area(i)?;
        let cos = n.dot(wi).abs();
        let pdf = pdf_area * d2 / cos;
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        self.surface.radiance(self.triangles[i], b1, b2, -wi, le);
        Some(LightSample { wi, distance, pdf, delta: false, part: self.triangles[i] })
    }
    /// A mesh light needs the triangle: see [`Light::pdf_li_part`].
    fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _distance: f32) -> f32 {
        0.0
    }
    fn pdf_li_part(&self, part: u32, _p: Vec3A, wi: Vec3A, distance: f32) -> f32 {
        let Some((n, pdf_area)) = self.local(part).and_then(|i| self.pdf_area(i)) else { return 0.0 };
        let cos = n.dot(wi).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        pdf_area * distance * distance / cos
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let (i, ux) = self.distribution.sample_remapped(u_pos.x)?;
        let (b1, b2, origin) = uniform_triangle_point(&self.p[i], Vec2::new(ux, u_pos.y));
        let (normal, pdf_pos) = self.pdf_area(i)?;
        // Both faces: pick one with probability 1/2 (reusing u_dir.x), cosine about it.
        let (side, ux) = if u_dir.x < 0.5 { (1.0, u_dir.x * 2.0) } else { (-1.0, (u_dir.x - 0.5) * 2.0) };
        let n = normal * side;
        let local = cosine_hemisphere(Vec2::new(ux.min(0.999_999_9), u_dir.y));
        let pdf_dir = 0.5 * local.z / PI;
        if !(pdf_dir > 0.0 && pdf_pos > 0.0) {
            return None;
        }
        let direction = Frame::from_normal(n).to_world(local);
        self.surface.radiance(self.triangles[i], b1, b2, direction, le);
        Some(EmissionSample {
            origin,
            direction,
            normal: Some(n),
            pdf_pos,
            pdf_dir,
            delta_position: false,
            part: self.triangles[i],
        })
    }
    /// A mesh light needs the triangle: see [`Light::pdf_le_part`].
    fn pdf_le(&self, _origin: Vec3A, _dir: Vec3A) -> Option<LeDensity> {
        None
    }
    fn pdf_le_part(&self, part: u32, _origin: Vec3A, dir: Vec3A) -> Option<LeDensity> {
        let (n, pos) = self.local(part).and_then(|i| self.pdf_area(i))?;
        let cos = n.dot(dir).abs();
        Some(LeDensity { pos, dir: 0.5 * cos / PI, cos, directional: false })
    }
}
