//! Stimuli: planar outlines, meshes, contours, and the catalogue that names them.

pub mod builtin;
pub mod catalogue;
pub mod contour;
pub mod mesh;
pub mod outline;

pub use catalogue::{Catalogue, ShapeEntry, Stimulus};
pub use contour::{Contour, EdgePoint};
pub use mesh::Mesh;
pub use outline::Outline;
