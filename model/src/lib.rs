//! tacsim-model: the learning half (DESIGN.md section 5). It will read datasets through
//! `tacsim-data` and never depends on the simulator.
//!
//! So far: [`metrics`], the image-similarity measures of the paper's evaluation (SSIM,
//! MS-SSIM, MSE), checked against reference values; and [`network`], the paper's four
//! networks in burn at 256, 128 and 64 px. Losses, training and evaluation are the rest of
//! issue 6.

pub mod metrics;
pub mod network;
