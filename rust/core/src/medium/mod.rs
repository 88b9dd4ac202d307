//! Participating media: what light meets between surfaces. Homogeneous media inside
//! closed meshes (`homogeneous.rs`; heterogeneous ones whose density is a voxel grid in
//! `grid.rs`; the path's free flights through them are in
//! `integrator/volume.rs`), a phase function, and the subsurface random walk in a
//! homogeneous medium bounded by a mesh.

pub mod grid;
pub mod homogeneous;
pub mod phase;
pub mod random_walk;

pub use grid::GridMedium;
pub use homogeneous::{HomogeneousMedium, MediumStack};
pub use phase::HenyeyGreenstein;
pub use random_walk::{Boundary, SubsurfaceMedium, WalkExit};
