//! tacsim-model: the learning half (`docs/design.md`). It reads datasets through
//! `tacsim-data` and never depends on the simulator.
//!
//! Modules are private; the surface is the list below, at the crate root (parry-style). In
//! the order data flows:
//! - `network.rs`: the paper's four networks (E_S, D_T, D_S, E_T) at 256, 128 and 64 px
//!   ([`Size`]); `unshear.rs`: the shear-removal model ([`Unshear`]) and its mappings M, N, K;
//!   `objective.rs`: the losses and per-module objectives ([`StepLosses`]);
//! - `posenet.rs`: the pose network and its label encoding ([`Pose`], [`decode_batch`]);
//! - `config.rs`: every hyperparameter, the paper's values as defaults ([`UnshearConfig`],
//!   [`PoseConfig`], [`Mode`]);
//! - `data.rs`, `images.rs`: datasets in memory ([`Corpus`]), batches, the lab's preprocessing
//!   ([`Preprocess`], [`to_images`]);
//! - `train.rs`: seeded, checkpointed, resumable training loops ([`train_unshear`],
//!   [`train_posenet`], [`Progress`]);
//! - `checkpoint.rs`: safetensors weights ([`load_weights`]), optimizer state, run
//!   directories, atomic writes (`tacsim_data::write_atomic`);
//! - `infer.rs`: poses read from single images by trained runs ([`PoseReader`],
//!   [`load_posenet`]);
//! - `eval.rs`: the held-out scores of trained runs ([`evaluate`], [`EvalReport`]);
//! - `transfer/`: label maps from a simulated dataset's labels to a lab's ([`LabelMap`]) and
//!   sim2real's scoring on a lab's held-out part ([`score_transfer`]), the yaw averaged over turns
//!   ([`Turns`]) and the lateral and depth read in the edge's frame ([`EdgeStage`]);
//! - `metrics.rs`: SSIM, MS-SSIM and MSE, checked against reference values ([`ssim`]);
//! - `bench.rs`: network throughput ([`measure_networks`]); `backend.rs`: which burn device
//!   runs the networks ([`Backend`]).

mod backend;
mod bench;
mod checkpoint;
mod config;
mod data;
mod error;
mod eval;
mod images;
mod infer;
mod metrics;
mod network;
mod objective;
mod posenet;
mod train;
mod transfer;
mod unshear;

pub use backend::Backend;
pub use bench::{BenchRow, measure as measure_networks};
pub use checkpoint::load_weights;
pub use config::{Mode, PoseConfig, UnshearConfig};
pub use data::Corpus;
pub use error::{ModelError, Result};
pub use eval::{Report as EvalReport, corpus_images, evaluate, markdown as eval_markdown, predict_poses, run_size};
pub use images::{ImageSet, Preprocess, to_images};
pub use infer::{PoseReader, load_posenet, load_unshear};
pub use metrics::{MetricError, ms_ssim, mse, ssim};
pub use network::Size;
pub use objective::StepLosses;
pub use posenet::{Pose, PoseNet, PoseScale, decode_batch};
pub use train::{EpochLog, Progress, Silent, TrainState, train_posenet, train_unshear};
pub use transfer::{
    Coverage, Curve as FinetuneCurve, CurvePoint, EdgeStage, LabelCurve, LabelMap, LabelScore, MATCH_FACTOR,
    MAX_SIM_SHARE as FINETUNE_MAX_SIM_SHARE, MAX_TURNS, MIN_STEPS as FINETUNE_MIN_STEPS, Matching, Moments, Scores,
    Scoring, Span, Spread, TurnImage, Turns, coverage as transfer_coverage, difference as label_difference,
    edge_frame_labels, epochs_for as finetune_epochs, in_edge_frame, lab_in_edge_frame, lab_yaw_sense,
    label as label_name, parse_ks as parse_finetune_ks, score as score_transfer, summarise as summarise_finetune,
    yaw_sense,
};
pub use unshear::Unshear;
