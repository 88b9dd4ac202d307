//! Lights. Integrators see them through the [`Light`] trait; the scene picks one with
//! probability proportional to its total spectral power over the grid (eq. 7).

pub mod area;
pub mod distant;
pub mod environment;
pub mod point;
pub mod spot;

use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

pub use area::AreaTriangle;
pub use distant::DistantLight;
pub use environment::{ImageEnvironment, UniformEnvironment};
pub use point::PointLight;
pub use spot::SpotLight;

/// Incident radiance sampled from a light towards a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3A,
    /// Distance to the sampled point (shadow ray length).
    pub distance: f32,
    /// Solid-angle pdf at the shading point (1 for delta lights).
    pub pdf: f32,
    /// A point or directional light that BSDF sampling can never hit.
    pub delta: bool,
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
    /// The position is a delta (point, spot): no camera or BSDF ray can hit it.
    pub delta_position: bool,
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
    /// Total emitted power integrated over the grid with its quadrature weights (eq. 7):
    /// the light-selection weight.
    fn power(&self, weights: &[f32]) -> f64;
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
}
