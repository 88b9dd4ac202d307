//! Participating media: what light meets between surfaces. For now the pieces the
//! subsurface random walk needs (a phase function, the walk in a homogeneous medium
//! bounded by a mesh); volumes would reuse them.

pub mod phase;
pub mod random_walk;

pub use phase::HenyeyGreenstein;
pub use random_walk::{Boundary, SubsurfaceMedium, WalkExit};
