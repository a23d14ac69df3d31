//! tacsim-model: the learning half (DESIGN.md section 5). It reads datasets through
//! `tacsim-data` and never depends on the simulator.
//!
//! - [`network`]: the paper's four networks (E_S, D_T, D_S, E_T) at 256, 128 and 64 px;
//! - [`unshear`]: the shear-removal model and its mappings M, N, K;
//! - [`objective`]: the losses and per-module objectives;
//! - [`posenet`]: the pose network and its label encoding;
//! - [`config`]: every hyperparameter, the paper's values as defaults;
//! - [`data`], [`images`]: datasets in memory, batches, the lab's preprocessing;
//! - [`infer`]: poses read from single images by trained runs (robot perception);
//! - [`transfer`]: label maps from a simulated dataset's labels to a lab's (sim-to-real);
//! - [`train`]: seeded, checkpointed, resumable training loops;
//! - [`checkpoint`]: safetensors weights, optimizer state, run directories;
//! - [`metrics`]: SSIM, MS-SSIM and MSE, checked against reference values;
//! - [`backend`]: which burn device runs the networks.

pub mod backend;
pub mod bench;
pub mod checkpoint;
pub mod config;
pub mod data;
pub mod error;
pub mod eval;
pub mod images;
pub mod infer;
pub mod metrics;
pub mod network;
pub mod objective;
pub mod posenet;
pub mod train;
pub mod transfer;
pub mod unshear;

pub use backend::Backend;
pub use error::{ModelError, Result};
