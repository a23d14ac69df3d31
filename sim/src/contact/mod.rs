//! Frictional elastic contact between the sensor skin and rigid stimuli: a boundary-element
//! solver on a grid over the contact footprint (DESIGN.md section 3).
pub mod fft2;
pub mod grid;
pub mod kernel;
pub mod normal;
pub mod operator;
pub mod tangential;
pub mod validate;
