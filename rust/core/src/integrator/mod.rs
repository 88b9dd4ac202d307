//! Integrators: how a camera sample's radiance is estimated. One file per method.

pub mod bidir;
pub mod forward;
pub mod monochromatic;
pub mod path;

use crate::film::PixelSample;
use crate::sampling::Rng;
use crate::scene::Scene;

/// Estimates the radiance arriving through film position (x, y) in pixels.
pub trait Integrator: Sync {
    fn sample(&self, scene: &Scene, x: f32, y: f32, rng: &mut Rng, out: &mut PixelSample);
}
