//! Geometry: triangle meshes, instances with transforms, rays, watertight
//! ray/triangle intersection and robust ray offsets.

pub mod frame;
pub mod mesh;
pub mod ray;
pub mod triangle;

pub use frame::Frame;
pub use mesh::{Instance, Mesh};
pub use ray::{offset_ray_origin, shadow_ray, Ray};
