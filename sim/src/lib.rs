//! tacsim-sim: the TacTip simulator.
//!
//! Data flows one way: [`sensor`] parameters -> [`pins`] layout -> [`camera`] projection ->
//! [`raster`] discs -> binary image ([`render`]), optionally through [`realism`] and the lab's
//! [`processing`]. Stimuli ([`stimulus`]) are placed in a [`scene`] that answers the geometric
//! queries of contact and ground truth. [`detect`] and [`calibration`] read pins back from
//! images (real or simulated). Frames of reference are defined once: the sensor frame in
//! [`sensor`], image coordinates in [`camera`], the world frame in [`scene`].

pub mod atomic;
pub mod calibrate;
pub mod calibration;
pub mod camera;
pub mod contact;
pub mod dataset;
pub mod detect;
pub mod embedded;
pub mod error;
pub mod fit;
pub mod pins;
pub mod png_io;
pub mod processing;
pub mod raster;
pub mod realism;
pub mod render;
pub mod rig;
pub mod scene;
pub mod sensor;
pub mod stimulus;
pub mod tracking;
pub mod variation;

pub use error::{Result, SimError};
pub use render::PinRenderer;
pub use sensor::SensorParams;
