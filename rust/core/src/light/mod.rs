//! Lights. Integrators see them through the [`Light`] trait; the scene picks one with
//! probability proportional to its total spectral power over the grid (eq. 7).

pub mod area;
pub mod distant;
pub mod environment;
pub mod mesh;
pub mod moving;
pub mod point;
pub mod profile;
pub mod spot;
pub mod tree;

use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

pub use area::AreaTriangle;
pub use distant::DistantLight;
pub use environment::{ImageEnvironment, UniformEnvironment};
pub use mesh::{MeshLight, SurfaceEmission};
pub use moving::MovingLight;
pub use point::PointLight;
pub use profile::Profile;
pub use spot::SpotLight;
pub use tree::{LightBounds, LightChoice, LightTree};

/// Incident radiance sampled from a light towards a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3A,
    /// Distance to the sampled point (shadow ray length).
    pub distance: f32,
    /// Solid-angle pdf at the shading point (1 for delta lights).
    pub pdf: f32,
    /// A point or parallel light that BSDF sampling can never hit: weight 1, no MIS. A
    /// sun's disk or a sphere light is no delta: BSDF rays reach it ([`Light::hit`]).
    pub delta: bool,
    /// Which part of the light the point lies on (a [`MeshLight`]'s mesh triangle; 0
    /// for lights of one part), for [`Light::pdf_li_part`] / [`Light::pdf_le_part`].
    pub part: u32,
}

/// A ray leaving a light, for forward (light) tracing.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    pub origin: Vec3A,
    pub direction: Vec3A,
    /// Surface normal at the origin (None for point-like lights).
    pub normal: Option<Vec3A>,
    /// Area pdf of the origin (1 for delta positions).
    pub pdf_pos: f32,
    /// Solid-angle pdf of the direction.
    pub pdf_dir: f32,
    /// The position is a delta (point, spot, parallel sun): no camera or BSDF ray can
    /// hit it. False for lights rays do reach, a sphere or a sun's disk ([`Light::hit`]).
    pub delta_position: bool,
    /// Which part of the light the origin lies on (see [`LightSample::part`]).
    pub part: u32,
}

/// The densities with which [`Light::sample_le`] starts a given ray, for bidirectional
/// MIS weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeDensity {
    /// Area pdf of the origin (1 for a delta position; for a distant light, per unit
    /// area of its start disk, perpendicular to the direction).
    pub pos: f32,
    /// Solid-angle pdf of the direction (1 for a delta direction).
    pub dir: f32,
    /// |cos| between the light's surface normal and the direction (1 without a normal).
    pub cos: f32,
    /// Parallel light (distant): the direction is a delta and the position density is
    /// per unit area perpendicular to it.
    pub directional: bool,
}

pub trait Light: Send + Sync {
    /// Called once the scene is built, with a sphere (`center`, `radius` > 0) bounding
    /// all its geometry over the shutter (pbrt-v4's `Light::Preprocess(sceneBounds)`):
    /// lights at infinity (environments, suns) start their light paths on a disk of
    /// that radius and count their power through it. Other lights ignore it.
    fn preprocess(&mut self, _center: Vec3A, _radius: f32) {}
    /// Total emitted power integrated over the grid with its quadrature weights (eq. 7):
    /// the light-selection weight.
    fn power(&self, weights: &[f32]) -> f64;
    /// Where the light is and where it emits, for the light tree (its `phi` is set by
    /// the tree from [`Light::power`]). None: chosen by power alone, beside the tree
    /// (lights at infinity, moving lights). Bounds must hold every point and direction
    /// the light emits from and along: a light the bounds give no importance at a
    /// point is never sampled there.
    fn bounds(&self) -> Option<LightBounds> {
        None
    }
    /// Samples a direction from `p` towards the light; `le` receives the radiance
    /// (intensity / distance² for point lights) arriving at `p`.
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample>;
    /// Solid-angle pdf that `sample_li` from `p` returns the point reached along `wi`
    /// after `distance` (0 for delta lights, which BSDF sampling never hits).
    fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _distance: f32) -> f32 {
        0.0
    }
    /// Samples an emitted ray (forward tracing); `le` receives the radiance along it
    /// (intensity for point-like lights). None: this light cannot start light paths.
    fn sample_le(&self, _u_pos: Vec2, _u_dir: Vec2, _le: &mut SampledSpectrum) -> Option<EmissionSample> {
        None
    }
    /// Densities of `sample_le` starting at `origin` (a point of the light) in direction
    /// `dir` (unit). None: this light cannot start light paths, or not this ray.
    fn pdf_le(&self, _origin: Vec3A, _dir: Vec3A) -> Option<LeDensity> {
        None
    }
    /// `pdf_li` for a point on part `part` of the light (the mesh triangle a BSDF ray
    /// hit, or [`LightSample::part`]). Lights of one part ignore it; integrators call
    /// this form wherever they know the part.
    fn pdf_li_part(&self, _part: u32, p: Vec3A, wi: Vec3A, distance: f32) -> f32 {
        self.pdf_li(p, wi, distance)
    }
    /// `pdf_le` for an origin on part `part` of the light (see [`Light::pdf_li_part`]).
    fn pdf_le_part(&self, _part: u32, origin: Vec3A, dir: Vec3A) -> Option<LeDensity> {
        self.pdf_le(origin, dir)
    }
    /// A light with an extent that is no scene geometry (a sun's disk of directions, a
    /// sphere light): camera and BSDF rays reach it through [`Light::hit`], as Cycles'
    /// `distant_light_intersect` / `point_light_intersect` (kernel/light/distant.h,
    /// point.h), and its light samples are MIS-weighted against BSDF sampling.
    fn hittable(&self) -> bool {
        false
    }
    /// Where the ray from `p` along unit `wi` meets the light's emitting shape: the
    /// distance (infinite for a sun) and, in `le`, the radiance arriving along the ray.
    /// None when it misses (and for lights that are not [`Light::hittable`]). The
    /// shape blocks nothing: the ray goes on to the surface behind it.
    fn hit(&self, _p: Vec3A, _wi: Vec3A, _le: &mut SampledSpectrum) -> Option<f32> {
        None
    }

    // The same at shutter time `time` (motion blur): where a [`MovingLight`] is then.
    // Lights that stand still answer as above; integrators call these forms.
    fn sample_li_at(&self, p: Vec3A, _time: f32, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        self.sample_li(p, u, le)
    }
    fn pdf_li_at(&self, p: Vec3A, wi: Vec3A, distance: f32, _time: f32) -> f32 {
        self.pdf_li(p, wi, distance)
    }
    fn pdf_li_part_at(&self, part: u32, p: Vec3A, wi: Vec3A, distance: f32, _time: f32) -> f32 {
        self.pdf_li_part(part, p, wi, distance)
    }
    fn hit_at(&self, p: Vec3A, wi: Vec3A, _time: f32, le: &mut SampledSpectrum) -> Option<f32> {
        self.hit(p, wi, le)
    }
    fn sample_le_at(&self, _time: f32, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        self.sample_le(u_pos, u_dir, le)
    }
    fn pdf_le_at(&self, origin: Vec3A, dir: Vec3A, _time: f32) -> Option<LeDensity> {
        self.pdf_le(origin, dir)
    }
    fn pdf_le_part_at(&self, part: u32, origin: Vec3A, dir: Vec3A, _time: f32) -> Option<LeDensity> {
        self.pdf_le_part(part, origin, dir)
    }

    /// A light whose radiance depends on where it lands, as Cycles' spot falloff and
    /// IES profile of a sphere light, taken along the direction from the light's centre
    /// to the shading point (kernel/light/spot.h, point.h) rather than along the ray
    /// that leaves the sphere: `sample_le`'s radiance leaves that factor out and a light
    /// path scales by [`Light::receiver_factor_at`] of the point its first segment
    /// reaches.
    fn receiver_dependent(&self) -> bool {
        false
    }
    /// For a [`Light::receiver_dependent`] light: the factor on `sample_le`'s radiance
    /// for light landing at `receiver` (at shutter time `time`); 1 for other lights.
    fn receiver_factor_at(&self, _receiver: Vec3A, _time: f32) -> f32 {
        1.0
    }
}

/// The start of a light path from a light at infinity arriving along unit `direction`
/// (the way the light travels), as pbrt-v4's infinite lights (`UniformInfiniteLight::
/// SampleLe`): a point uniform on the disk of radius `radius` perpendicular to it,
/// tangent to the bounding sphere (`center`, `radius`) on the side the light comes
/// from. Its rays cover the whole sphere; the position density is 1/(π r²) per unit
/// area perpendicular to the direction ([`LeDensity::directional`]).
pub fn infinite_light_origin(center: Vec3A, radius: f32, direction: Vec3A, u: Vec2) -> Vec3A {
    let d = crate::sampling::concentric_disk(u) * radius;
    let f = crate::geometry::Frame::from_normal(direction);
    center - direction * radius + f.s * d.x + f.t * d.y
}

/// The radius a light at infinity uses for the scene's bounding sphere (a degenerate
/// scene, a single point, still gets a disk).
#[inline]
pub fn infinite_light_radius(radius: f32) -> f32 {
    if radius.is_finite() {
        radius.max(1e-3)
    } else {
        1e-3
    }
}

/// 1 − cos θ from sin²θ (θ ≤ π/2) without cancellation: s² / (1 + √(1 − s²)).
#[inline]
pub fn one_minus_cos_from_sin2(sin2: f32) -> f32 {
    let s2 = sin2.clamp(0.0, 1.0);
    s2 / (1.0 + (1.0 - s2).sqrt())
}

/// A direction uniform in the cone of half-angle θmax about +z, given 1 − cos θmax,
/// and its solid-angle pdf 1 / (2π (1 − cos θmax)) (pbrt-v4 `SampleUniformCone`).
/// Through the concentric disk, as Cycles' `sample_uniform_cone_concentric`: the
/// area-preserving map keeps stratified `u` stratified over the cone (the polar map's
/// √ edge left a 10° sun's 16-spp pixel spread at 0.28 % with Sobol points).
#[inline]
pub fn sample_uniform_cone(u: Vec2, one_minus_cos_max: f32) -> (Vec3A, f32) {
    let d = crate::sampling::concentric_disk(u);
    // |d|² is uniform on [0, 1) and its angle uniform: 1 − cos θ = |d|² (1 − cos θmax).
    let r2 = d.length_squared();
    let omc = r2 * one_minus_cos_max;
    let cos = 1.0 - omc;
    let sin_over_r = if r2 > 0.0 { (omc * (2.0 - omc) / r2).max(0.0).sqrt() } else { 0.0 };
    (Vec3A::new(d.x * sin_over_r, d.y * sin_over_r, cos), 1.0 / (2.0 * std::f32::consts::PI * one_minus_cos_max))
}

/// The distance along unit `wi` from `p` to the near surface of the sphere (`center`,
/// `radius` > 0); None when the ray misses it or `p` is inside (where
/// [`sample_sphere_cone`] samples nothing either).
pub fn hit_sphere(center: Vec3A, radius: f32, p: Vec3A, wi: Vec3A) -> Option<f32> {
    let d = center - p;
    let d2 = d.length_squared();
    let r2 = radius * radius;
    if !(d2 > r2 && d2.is_finite()) {
        return None;
    }
    let b = d.dot(wi);
    // Squared distance of the centre from the ray's line, without cancellation.
    let h2 = (d - wi * b).length_squared();
    if b <= 0.0 || h2 > r2 {
        return None;
    }
    Some((b - (r2 - h2).sqrt()).max(0.0))
}

/// The solid-angle pdf with which [`sample_sphere_cone`] from `p` returns `wi`: uniform
/// over the cone the sphere subtends, 0 outside it.
pub fn sphere_cone_pdf(center: Vec3A, radius: f32, p: Vec3A, wi: Vec3A) -> f32 {
    if hit_sphere(center, radius, p, wi).is_none() {
        return 0.0;
    }
    let omc_max = one_minus_cos_from_sin2(radius * radius / (center - p).length_squared());
    if omc_max > 0.0 {
        1.0 / (2.0 * std::f32::consts::PI * omc_max)
    } else {
        0.0
    }
}

/// The unit direction from `p` to `q`, the distance and its square; None when the
/// points coincide or are not finite (no light sample then).
pub(crate) fn direction_to(p: Vec3A, q: Vec3A) -> Option<(Vec3A, f32, f32)> {
    let d = q - p;
    let d2 = d.length_squared();
    if d2 <= 0.0 || !d2.is_finite() {
        return None;
    }
    let distance = d2.sqrt();
    Some((d / distance, distance, d2))
}

/// Samples the cone a sphere (`center`, `radius` > 0) subtends at `p`, uniformly in
/// solid angle, as pbrt-v4's `Sphere::Sample(ctx, u)` and Cycles' sphere lights
/// (intern/cycles/kernel/light/point.h, `point_light_sample`, Blender 4.x) do: the unit
/// direction, the distance to the sphere's near surface along it and the pdf. None
/// when `p` is inside the sphere.
pub fn sample_sphere_cone(center: Vec3A, radius: f32, p: Vec3A, u: Vec2) -> Option<(Vec3A, f32, f32)> {
    let d = center - p;
    let d2 = d.length_squared();
    let r2 = radius * radius;
    if !(d2 > r2 && d2.is_finite()) {
        return None;
    }
    let dist = d2.sqrt();
    let omc_max = one_minus_cos_from_sin2(r2 / d2);
    if !(omc_max > 0.0) {
        return None;
    }
    let (local, pdf) = sample_uniform_cone(u, omc_max);
    let wi = crate::geometry::Frame::from_normal(d / dist).to_world(local);
    // Nearest intersection of the ray p + t·wi with the sphere.
    let cos = local.z;
    let sin2 = (local.x * local.x + local.y * local.y).min(1.0);
    let t = dist * cos - (r2 - d2 * sin2).max(0.0).sqrt();
    Some((wi, t.max(0.0), pdf))
}
