//! Comparing (and, to come, calibrating) the deformation model against real recordings: track
//! the real pins ([`observe`]), simulate the same recordings with a label frame and
//! deformation parameters ([`model`]), and measure the difference ([`evaluate`];
//! `cargo xtask real-compare` prints it).

pub mod evaluate;
pub mod model;
pub mod observe;
