//! Calibrating the deformation model against real recordings (`tacsim calibrate`): track the
//! real pins ([`observe`]), find how the labels' axes map to the sensor's ([`frame`]), and fit
//! the skin model and its parameters to the real pin displacements.

pub mod frame;
pub mod observe;
