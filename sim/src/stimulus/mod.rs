//! Stimuli: planar outlines, meshes, contours, and the catalogue that names them.

mod builtin;
mod catalogue;
mod contour;
mod mesh;
mod outline;

pub use builtin::{BuiltinShape, builtin_shapes, shape_files};
pub use catalogue::{
    CONTACT_TOLERANCE_MM, Catalogue, MAX_EDGE_RADIUS_MM, MAX_FRICTION, ShapeEntry, Stimulus, check_edge_radius,
    off_the_edge,
};
pub use contour::{Contour, EdgePoint, NearContour, SegmentPoint, project_on_segment};
pub use mesh::Mesh;
pub use outline::Outline;
pub(crate) use outline::{perimeter, signed_area};
