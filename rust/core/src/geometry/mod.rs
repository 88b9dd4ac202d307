//! Geometry: triangle meshes, instances with transforms, rays, watertight
//! ray/triangle intersection, robust ray offsets, and curves and point clouds
//! tessellated into triangles; which rays see what (visibility).

pub mod curves;
pub mod frame;
pub mod mesh;
pub mod motion;
pub mod ray;
pub mod triangle;
pub mod visibility;

pub use frame::Frame;
pub use mesh::{Instance, Mesh};
pub use ray::{offset_ray_origin, shadow_ray, Ray};
