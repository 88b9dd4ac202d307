//! Polychrome's rendering core.
//!
//! Implements the polychromatic ray tracing of Zhdanov et al. 2011 ("Spectral Ray
//! Tracing in Problems of Photorealistic Imagery Construction"): rays carry the whole
//! sampled spectrum of a [`spectrum::WavelengthGrid`]. Scenes arrive as a plain
//! [`scene::SceneDesc`] (from Python, Blender or USD), are compiled against a grid into
//! a [`scene::Scene`], and rendered by [`render::render`].

pub mod accel;
pub mod camera;
pub mod color;
pub mod error;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod material;
pub mod medium;
pub mod numeric;
pub mod procedural;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod spectrum;

pub use error::{Error, Result};
