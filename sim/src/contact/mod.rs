//! Frictional elastic contact between the sensor skin and rigid stimuli: a boundary-element
//! solver on a grid over the contact footprint (DESIGN.md section 3).
//!
//! Data flows one way: [`pose`] and the scene give the initial gap on a [`grid`] ([`engine`]),
//! the [`operator`] (built from the [`kernel`]s, products dense or by [`fft2`]) turns tractions
//! into displacements, [`normal`] and [`tangential`] solve the contact with history, and
//! [`pin_motion`] moves the pins. [`trajectory`] strings steps into taps and slides;
//! [`validate`] runs the analytic cases.
//!
//! # Sign conventions
//! On the contact plane `(x, y)` are the axes of the path's [`frame::ContactFrame`] (the
//! sensor's axes for an untilted path); pressure `p >= 0` presses into the skin; shear
//! traction `q` is the stimulus's force per area on the skin (MPa); the gap `g` (mm) is
//! measured along the frame's `+z` and is negative for overlap.
pub mod engine;
pub mod fft2;
pub mod frame;
pub mod grid;
pub mod kernel;
pub mod layered;
pub mod normal;
pub mod operator;
pub mod pin_motion;
pub mod pose;
pub mod tangential;
pub mod trajectory;
pub mod validate;
