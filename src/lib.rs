//! tacsim: the command line and pipeline glue over the simulator crate (`tacsim-sim`).
//!
//! [`embedded`] carries the built-in stimuli so the binary runs anywhere; [`commands`] holds
//! one function per subcommand, called by the thin `main.rs`; [`validation`] and [`bench`] run
//! the contact checks and benchmarks.

pub mod bench;
pub mod commands;
pub mod embedded;
pub mod validation;
