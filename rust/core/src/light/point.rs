//! A point light, or with a radius a sphere light (Blender's point light
//! `shadow_soft_size`, UsdLux SphereLight `radius`): soft shadows.
//!
//! A sphere of radius r emits the uniform radiance L = I / (π r²), I the radiant
//! intensity, as Cycles' sphere lights do (scene/light.cpp: `invarea` = 1/(π r²) for
//! point lights): far away it is the point light of intensity I, and a point facing it
//! at distance d receives E = π L (r/d)² = I/d². Next-event estimation samples the
//! cone the sphere subtends uniformly ([`super::sample_sphere_cone`]). The sphere is
//! not scene geometry, but camera and BSDF rays reach it ([`Light::hit`], as Cycles'
//! `point_light_intersect`, kernel/light/point.h): its highlight shows in a mirror, its
//! caustic through glass, and light sampling is MIS-weighted against BSDF sampling. It
//! blocks nothing (a ray goes on behind it, as Cycles' lights are transparent bounces).
//! Radius 0 stays a delta light, reached by light sampling only.

use super::{EmissionSample, Light, LightBounds, LightSample, Profile};
use crate::geometry::Frame;
use crate::sampling::{cosine_hemisphere, uniform_sphere};
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct PointLight {
    pub position: Vec3A,
    /// Radiant intensity per wavelength (W·sr⁻¹·nm⁻¹ in scene units).
    pub intensity: SampledSpectrum,
    /// Radius of the emitting sphere (0: a point).
    pub radius: f32,
    /// Scales the intensity per direction (an IES profile).
    pub profile: Option<Profile>,
}

impl PointLight {
    /// The profile's factor towards `p` from the centre (1 without a profile).
    fn toward(&self, p: Vec3A) -> f32 {
        match (&self.profile, super::direction_to(self.position, p)) {
            (Some(prof), Some((w, _, _))) => prof.eval(w),
            (Some(_), None) => 0.0,
            (None, _) => 1.0,
        }
    }
}

/// Light sampling of a point (radius 0) or sphere light at `center`, whose radiant
/// intensity towards `p` is `intensity × scale`: `le` receives the incident radiance
/// (intensity/d² for a point). Shared with spot lights.
pub(crate) fn sample_point_or_sphere(
    center: Vec3A,
    radius: f32,
    intensity: &SampledSpectrum,
    scale: f32,
    p: Vec3A,
    u: Vec2,
    le: &mut SampledSpectrum,
) -> Option<LightSample> {
    if radius > 0.0 {
        let (wi, distance, pdf) = super::sample_sphere_cone(center, radius, p, u)?;
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        le.copy_from(intensity);
        le.scale(scale / (PI * radius * radius));
        // BSDF rays hit the sphere too (`sphere_hit`): MIS.
        return Some(LightSample { wi, distance, pdf, delta: false, part: 0 });
    }
    let (wi, distance, d2) = super::direction_to(p, center)?;
    le.copy_from(intensity);
    le.scale(scale / d2);
    Some(LightSample { wi, distance, pdf: 1.0, delta: true, part: 0 })
}

/// A ray from `p` along `wi` reaching the sphere light at `center` whose radiant
/// intensity towards `p` is `intensity × scale`: the distance, `le` its radiance.
pub(crate) fn sphere_hit(
    center: Vec3A,
    radius: f32,
    intensity: &SampledSpectrum,
    scale: f32,
    p: Vec3A,
    wi: Vec3A,
    le: &mut SampledSpectrum,
) -> Option<f32> {
    if !(radius > 0.0 && scale > 0.0) {
        return None;
    }
    let t = super::hit_sphere(center, radius, p, wi)?;
    le.copy_from(intensity);
    le.scale(scale / (PI * radius * radius));
    Some(t)
}

/// A ray leaving a sphere light: a uniform point of the sphere and a cosine-weighted
/// direction about its outward normal; `le` receives the radiance I / (π r²).
pub(crate) fn sphere_le(
    center: Vec3A,
    radius: f32,
    intensity: &SampledSpectrum,
    u_pos: Vec2,
    u_dir: Vec2,
    le: &mut SampledSpectrum,
) -> Option<EmissionSample> {
    let n = uniform_sphere(u_pos);
    let local = cosine_hemisphere(Vec2::new(u_dir.x.min(0.999_999_9), u_dir.y));
    let pdf_dir = local.z / PI;
    if !(pdf_dir > 0.0) {
        return None;
    }
    le.copy_from(intensity);
    le.scale(1.0 / (PI * radius * radius));
    Some(EmissionSample {
        origin: center + n * radius,
        direction: Frame::from_normal(n).to_world(local),
        normal: Some(n),
        pdf_pos: 1.0 / (4.0 * PI * radius * radius),
        pdf_dir,
        // Camera and BSDF rays reach the sphere (`Light::hit`): no delta.
        delta_position: false,
        part: 0,
    })
}

/// The densities with which [`sphere_le`] starts the ray from `origin` (a point of the
/// sphere) along `dir`: uniform on the sphere, cosine about the outward normal. None
/// behind the surface (no such ray).
pub(crate) fn sphere_le_density(center: Vec3A, radius: f32, origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
    let n = (origin - center).normalize_or_zero();
    let cos = n.dot(dir);
    (cos > 0.0 && radius > 0.0).then(|| super::LeDensity {
        pos: 1.0 / (4.0 * PI * radius * radius),
        dir: cos / PI,
        cos,
        directional: false,
    })
}

impl Light for PointLight {
    /// The sphere's box, emitting every way (a profile too: it may light any direction).
    fn bounds(&self) -> Option<LightBounds> {
        let r = Vec3A::splat(self.radius.max(0.0));
        Some(LightBounds::omni(self.position - r, self.position + r))
    }
    fn power(&self, weights: &[f32]) -> f64 {
        let mean = self.profile.as_ref().map_or(1.0, |p| p.mean()) as f64;
        4.0 * PI as f64 * self.intensity.dot(weights) as f64 * mean
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        sample_point_or_sphere(self.position, self.radius, &self.intensity, self.toward(p), p, u, le)
    }
    fn pdf_li(&self, p: Vec3A, wi: Vec3A, _distance: f32) -> f32 {
        if self.radius > 0.0 {
            super::sphere_cone_pdf(self.position, self.radius, p, wi)
        } else {
            0.0
        }
    }
    fn hittable(&self) -> bool {
        self.radius > 0.0
    }
    fn hit(&self, p: Vec3A, wi: Vec3A, le: &mut SampledSpectrum) -> Option<f32> {
        sphere_hit(self.position, self.radius, &self.intensity, self.toward(p), p, wi, le)
    }
    fn receiver_dependent(&self) -> bool {
        self.radius > 0.0 && self.profile.is_some()
    }
    /// A profiled sphere: the profile towards `receiver` seen from the centre.
    fn receiver_factor_at(&self, receiver: Vec3A, _time: f32) -> f32 {
        if self.receiver_dependent() {
            self.toward(receiver)
        } else {
            1.0
        }
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let along = |w: Vec3A| self.profile.as_ref().map_or(1.0, |p| p.eval(w));
        if self.radius > 0.0 {
            // Uniform: a profile is the receiver's (`receiver_factor_at`).
            return sphere_le(self.position, self.radius, &self.intensity, u_pos, u_dir, le);
        }
        let direction = uniform_sphere(u_dir);
        le.copy_from(&self.intensity);
        le.scale(along(direction));
        Some(EmissionSample {
            origin: self.position,
            direction,
            normal: None,
            pdf_pos: 1.0,
            pdf_dir: 1.0 / (4.0 * PI),
            delta_position: true,
            part: 0,
        })
    }
    /// A point: its uniform direction. A sphere: [`sphere_le_density`] (its light
    /// paths are a strategy of the bidirectional MIS like an area light's) — unless it
    /// has a profile: camera paths take the profile towards the shading point seen from
    /// the centre (`hit`, `sample_li`), light paths along their own direction from a
    /// point of the sphere, two slightly different lights that must not be mixed (None).
    fn pdf_le(&self, origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
        if self.radius > 0.0 {
            return if self.profile.is_some() {
                None
            } else {
                sphere_le_density(self.position, self.radius, origin, dir)
            };
        }
        Some(super::LeDensity { pos: 1.0, dir: 1.0 / (4.0 * PI), cos: 1.0, directional: false })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Irradiance at a point facing a sphere light, estimated with its own light samples
    /// (E ≈ mean of L·cos/pdf), against the closed form π L (r/d)² for radiance L.
    #[test]
    fn sphere_irradiance_is_pi_l_r2_over_d2() {
        for &(r, d) in &[(0.25f32, 2.0f32), (1.0, 1.5), (0.01, 3.0), (2.0, 2.2)] {
            let light = PointLight {
                position: Vec3A::new(0.0, 0.0, d),
                intensity: SampledSpectrum::splat(1, 3.0),
                radius: r,
                profile: None,
            };
            let radiance = 3.0 / (PI * r * r);
            let mut rng = Rng::new(7, 1);
            let mut le = SampledSpectrum::zeros(1);
            let n = 200_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let ls = light.sample_li(Vec3A::ZERO, rng.uniform2(), &mut le).unwrap();
                assert!((le.get(0) - radiance).abs() <= 1e-4 * radiance);
                // The shadow ray ends on the sphere.
                let q = ls.wi * ls.distance - light.position;
                assert!((q.length() - r).abs() < 1e-3 * d.max(1.0), "{} vs {r}", q.length());
                sum += (le.get(0) * ls.wi.z.max(0.0) / ls.pdf) as f64;
            }
            let e = sum / n as f64;
            let closed = (PI * radiance * (r / d).powi(2)) as f64;
            assert!((e / closed - 1.0).abs() < 3e-3, "r {r} d {d}: {e} vs {closed}");
            // ... which is the point light's I/d² (Cycles' normalisation).
            assert!((closed - 3.0 / (d * d) as f64).abs() < 1e-4 * closed);
        }
    }

    #[test]
    fn inside_the_sphere_no_sample_and_power_is_the_points() {
        let light =
            PointLight { position: Vec3A::ZERO, intensity: SampledSpectrum::splat(1, 1.0), radius: 1.0, profile: None };
        let mut le = SampledSpectrum::zeros(1);
        assert!(light.sample_li(Vec3A::new(0.5, 0.0, 0.0), Vec2::splat(0.5), &mut le).is_none());
        // Emitted rays carry the point light's power: Le·cos/(pdf_pos·pdf_dir) = 4π I.
        let es = light.sample_le(Vec2::new(0.3, 0.6), Vec2::new(0.2, 0.7), &mut le).unwrap();
        let cos = es.normal.unwrap().dot(es.direction);
        let flux = le.get(0) * cos / (es.pdf_pos * es.pdf_dir);
        assert!((flux - 4.0 * PI).abs() < 1e-3, "{flux}");
        // Its light paths are a bidirectional strategy, with the densities it drew.
        let d = light.pdf_le(es.origin, es.direction).unwrap();
        assert!((d.pos - es.pdf_pos).abs() < 1e-6 && (d.dir - es.pdf_dir).abs() < 1e-5);
    }

    /// A sphere light's cone samples are the directions a ray from the point reaches
    /// the sphere along ([`Light::hit`]: the same near-surface distance and radiance,
    /// `pdf_li` = the sample's pdf); rays past it reach nothing; radius 0 stays a delta.
    #[test]
    fn sampled_directions_hit_the_sphere_with_their_pdf() {
        let light = PointLight {
            position: Vec3A::new(0.5, 1.0, 2.0),
            intensity: SampledSpectrum::splat(1, 3.0),
            radius: 0.7,
            profile: None,
        };
        assert!(light.hittable());
        let p = Vec3A::new(0.1, -0.3, 0.0);
        let mut rng = Rng::new(11, 2);
        let (mut le, mut hit) = (SampledSpectrum::zeros(1), SampledSpectrum::zeros(1));
        for _ in 0..2000 {
            let ls = light.sample_li(p, rng.uniform2(), &mut le).unwrap();
            assert!(!ls.delta);
            let t = light.hit(p, ls.wi, &mut hit).expect("a sampled direction reaches the sphere");
            assert!((t - ls.distance).abs() < 1e-3, "{t} vs {}", ls.distance);
            assert!((hit.get(0) - le.get(0)).abs() <= 1e-6 * le.get(0));
            let pdf = light.pdf_li(p, ls.wi, t);
            assert!((pdf - ls.pdf).abs() <= 1e-4 * ls.pdf, "{pdf} vs {}", ls.pdf);
        }
        let axis = (light.position - p).normalize();
        let past = Frame::from_normal(axis).to_world(Vec3A::new(0.5, 0.0, 0.75f32.sqrt()));
        assert!(light.hit(p, past, &mut hit).is_none() && light.pdf_li(p, past, 1.0) == 0.0);
        assert!(light.hit(p, -axis, &mut hit).is_none());
        let point = PointLight { radius: 0.0, ..light };
        assert!(!point.hittable() && point.hit(p, axis, &mut hit).is_none());
        assert!(point.sample_li(p, Vec2::splat(0.5), &mut le).unwrap().delta);
    }

    /// A sphere light's `pdf_le` is the density `sample_le` reports for its own rays
    /// (uniform on the sphere: 1/(4π r²); cosine about the normal: cos/π), None for a
    /// ray into the sphere; its light paths carry the power: the mean of le·cos/(pdf_pos
    /// ·pdf_dir) is 4π I, the closed form. A profiled sphere starts no MIS strategy.
    #[test]
    fn sphere_light_path_densities_match_and_carry_the_power() {
        let light = PointLight {
            position: Vec3A::new(1.0, -2.0, 0.5),
            intensity: SampledSpectrum::splat(1, 3.0),
            radius: 0.4,
            profile: None,
        };
        let mut rng = Rng::new(3, 5);
        let mut le = SampledSpectrum::zeros(1);
        let n = 20_000;
        let mut flux = 0.0f64;
        for _ in 0..n {
            let es = light.sample_le(rng.uniform2(), rng.uniform2(), &mut le).unwrap();
            let d = light.pdf_le(es.origin, es.direction).expect("its own ray");
            assert!((d.pos - es.pdf_pos).abs() <= 1e-6 * es.pdf_pos && (d.dir - es.pdf_dir).abs() <= 1e-4 * es.pdf_dir);
            let nl = es.normal.unwrap();
            assert!((d.cos - nl.dot(es.direction)).abs() < 1e-5 && !d.directional);
            assert!(light.pdf_le(es.origin, -es.direction).is_none());
            flux += (le.get(0) * d.cos / (es.pdf_pos * es.pdf_dir)) as f64;
        }
        let power = 4.0 * std::f64::consts::PI * 3.0;
        assert!((flux / n as f64 / power - 1.0).abs() < 1e-4, "{} vs {power}", flux / n as f64);
        let profiled = PointLight {
            profile: Some(
                crate::light::profile::Profile::new(
                    vec![0.0, 6.0],
                    vec![0.0, 3.0],
                    vec![1.0; 4],
                    glam::Mat3A::IDENTITY,
                )
                .unwrap(),
            ),
            ..light
        };
        let es = profiled.sample_le(Vec2::splat(0.3), Vec2::splat(0.6), &mut le).unwrap();
        assert!(profiled.pdf_le(es.origin, es.direction).is_none());
    }
}
