//! Stimuli: planar outlines, meshes, contours, and the catalogue that names them.

mod builtin;
mod catalogue;
mod contour;
mod mesh;
mod outline;

pub use builtin::{BuiltinShape, SEGMENT_MM, builtin_shapes, shape_files};
pub use catalogue::{
    CONTACT_TOLERANCE_MM, Catalogue, MAX_EDGE_RADIUS_MM, MAX_FRICTION, ShapeEntry, Stimulus, check_edge_radius,
    off_the_edge,
};
pub use contour::{Contour, EdgePoint};
pub use mesh::{Mesh, winding_number};
pub use outline::{Outline, perimeter, signed_area};
