//! Comparing (and, to come, calibrating) the deformation model against real recordings: track
//! the real pins ([`observe`]), find the labels' frame from the data ([`frame`]), simulate
//! the same recordings with that label frame and
//! deformation parameters ([`model`]), and measure the difference ([`evaluate`];
//! `cargo xtask real-compare` prints it).

pub mod evaluate;
pub mod frame;
pub mod model;
pub mod observe;
