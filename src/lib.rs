//! tacsim: the command line and pipeline glue over the simulator crate (`tacsim-sim`).
//!
//! [`calibrate`] fits the simulator to a lab's recordings (`calibrate`);
//! [`commands`] holds one function per subcommand, called by the thin `main.rs`; [`dataset`]
//! runs `generate` and `merge`; [`explore`] runs the closed loop of `tacsim-explore` with learned perception and reports it (`run`); [`validation`] and [`mod@bench`] run the contact checks and
//! benchmarks; [`learn`] trains and evaluates the networks of `tacsim-model`; [`sim2real`]
//! measures how a network trained on simulated images reads a lab's real ones; [`flags`]
//! bounds the command line's numbers.

pub mod bench;
pub mod calibrate;
pub mod commands;
pub mod dataset;
pub mod device;
pub mod explore;
pub mod finetune;
pub mod flags;
pub mod learn;
pub mod sim2real;
pub mod validation;
