//! Frictional elastic contact between the sensor skin and rigid stimuli: a boundary-element
//! solver on a grid over the contact footprint (`docs/design.md`).
//!
//! Data flows one way: a [`SensorPose`](crate::SensorPose) and the scene give the initial gap
//! ([`initial_gap`]) on a [`Grid`]; the [`Operator`] (built from the [`Kernel`]s, products
//! dense or by FFT) turns tractions into displacements; a [`Simulation`] solves the normal
//! (Polonsky-Keer) and tangential (Kalker) contact step by step with history and moves the pins;
//! a [`SensorPath`](crate::SensorPath) strings steps into taps and slides; [`validate`] runs
//! the analytic cases.
//!
//! # Sign conventions
//! On the contact plane `(x, y)` are the axes of the path's `frame::ContactFrame` (the
//! sensor's axes for an untilted path); pressure `p >= 0` presses into the skin; shear
//! traction `q` is the stimulus's force per area on the skin (MPa); the gap `g` (mm) is
//! measured along the frame's `+z` and is negative for overlap.
mod algebra;
mod body;
mod engine;
mod geometry;
mod model;
mod pins;
pub(crate) mod pose;
mod solve;
pub(crate) mod trajectory;
pub mod validate;

pub use algebra::matrix::{CellMatrix, MatrixCache};
pub use algebra::precision::Precision;
pub use body::dome::{DomeBody, cache_dir};
pub use body::kernel::{Elastic, Kernel, point_load_displacement};
pub use body::operator::{Component, HalfSpace, Operator, Pairing, Product};
pub use body::{DomeContact, ElasticBody, PinKernel};
pub use engine::Simulation;
pub use geometry::footprint::{Footprint, contact_disk_grid};
pub use geometry::frame::{ContactFrame, press_direction};
pub use geometry::gap::initial_gap;
pub use geometry::grid::Grid;
pub use model::ContactModel;
pub use pins::motion::PIN_SUBSQUARES;
#[cfg(feature = "wgpu")]
pub(crate) use pins::motion::{
    PinLoad, motion_from_stencil, moved_pin, patch_points, sensor_displacement, sensor_motion, stencil,
};
pub use pose::{MAX_POSITION_MM, MAX_TILT_DEG, MAX_YAW_DEG};
pub use solve::coupled::StepReport;
pub use trajectory::{MAX_PATH_STEPS, MAX_SLIDE_MM, MAX_STEP_MM, MIN_STEP_MM, PathStep};
