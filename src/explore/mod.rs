//! Closed-loop contour following (DESIGN.md section 6): a kinematic [`robot`] slides the
//! sensor along a stimulus's edge, staying in contact so that every step carries sliding
//! history from the contact engine; [`perception`] estimates the pose relative to the edge
//! (the [`learned`] modes with trained networks);
//! [`control`] corrects it with the lab's PI servo; [`run`] strings them into a loop with
//! metrics; [`contact_geometry`] reads the contact patch off the pins' Voronoi cells;
//! [`reconstruct`] fuses the contact patches into the object's footprint;
//! [`report`] writes the JSON report and the plot. Scenarios are TOML files
//! ([`scenario`], `scenarios/explore/`).
//!
//! Frames: world `x, y` (mm) with the object at its pose; the sensor's yaw turns its `x` axis
//! from world `x`. The servo keeps the edge under the sensor with the material on the sensor's
//! left of its direction of travel (`+x`), the contour traced counter-clockwise.

pub mod contact_geometry;
pub mod control;
pub mod learned;
pub mod perception;
pub mod reconstruct;
pub mod report;
pub mod robot;
pub mod run;
pub mod scenario;
