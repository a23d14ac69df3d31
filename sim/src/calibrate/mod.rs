//! Calibrating the deformation model against real recordings: track the real pins
//! ([`observe`]), find the labels' frame from the data ([`frame`]), simulate the same
//! recordings with that label frame and deformation parameters ([`model`]), measure the
//! difference ([`evaluate`]; `cargo xtask real-compare` prints it), fit the parameters on 80%
//! of the recordings ([`fitting`]) and report on the held-out 20% ([`report`];
//! `tacsim calibrate` runs both). [`reference`] finds the undeformed layout (an undeformed
//! image, or the consensus of the most alike shallow recordings) and cuts non-square images square;
//! [`camera`] fits a sensor's camera, ring layout and framing to that reference alone.

pub mod camera;
pub mod edge;
pub mod evaluate;
pub mod fitting;
pub mod frame;
pub mod model;
pub mod observe;
pub mod reference;
pub mod report;
