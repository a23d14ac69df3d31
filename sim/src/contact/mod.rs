//! Frictional elastic contact between the sensor skin and rigid stimuli: a boundary-element
//! solver on a grid over the contact footprint (DESIGN.md section 3).
//!
//! Data flows one way: a [`SensorPose`](crate::SensorPose) and the scene give the initial gap
//! ([`initial_gap`]) on a [`Grid`]; the [`Operator`] (built from the [`Kernel`]s, products
//! dense or by FFT) turns tractions into displacements; a [`Simulation`] solves the normal
//! (Polonsky-Keer) and tangential (Kalker) contact step by step with history and moves the pins;
//! a [`SensorPath`](crate::SensorPath) strings steps into taps and slides; [`validate`] runs
//! the analytic cases.
//!
//! # Sign conventions
//! On the contact plane `(x, y)` are the axes of the path's [`frame::ContactFrame`] (the
//! sensor's axes for an untilted path); pressure `p >= 0` presses into the skin; shear
//! traction `q` is the stimulus's force per area on the skin (MPa); the gap `g` (mm) is
//! measured along the frame's `+z` and is negative for overlap.
mod cut;
mod dome;
mod engine;
mod fft2;
mod frame;
mod grid;
mod kernel;
mod lanes;
mod layered;
mod matrix;
mod normal;
mod operator;
mod pin_motion;
pub(crate) mod pose;
mod precision;
mod refine;
mod stencil;
mod tangential;
pub(crate) mod trajectory;
pub mod validate;

pub use dome::{DomeBody, cache_dir};
pub use engine::{ContactModel, Footprint, Influence, Simulation, StepReport, contact_disk_grid, initial_gap};
pub use frame::{ContactFrame, press_direction};
pub use grid::Grid;
pub use kernel::{Elastic, Kernel, point_load_displacement};
pub use matrix::{CellMatrix, MatrixCache};
pub use operator::{Component, HalfSpace, Operator, Pairing, Product};
pub use pin_motion::PIN_SUBSQUARES;
#[cfg(feature = "wgpu")]
pub(crate) use pin_motion::{
    PinKernel, PinLoad, motion_from_stencil, moved_pin, patch_points, sensor_displacement, sensor_motion, stencil,
};
pub use pose::MAX_TILT_DEG;
pub use precision::Precision;
pub use trajectory::{MAX_PATH_STEPS, PathStep};
