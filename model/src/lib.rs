//! tacsim-model: the learning half (DESIGN.md section 5). It will read datasets through
//! `tacsim-data` and never depends on the simulator.
//!
//! So far: [`metrics`], the image-similarity measures of the paper's evaluation (SSIM,
//! MS-SSIM, MSE), checked against reference values. The networks (burn), training and
//! evaluation are the rest of issue 6.

pub mod metrics;
