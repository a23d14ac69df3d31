//! Datasets with the paper's tap/slide protocol (DESIGN.md section 4): a [`recipe`] (TOML)
//! becomes a deterministic [`plan`] of samples (every random draw comes from the seed and the
//! sample's own index, so any subset can be generated alone: shards, resumes, any thread
//! count), which [`generate`] renders into the directory format of `tacsim_data`; a [`job`] sets
//! a run up (sensor, scenes, the size it would write) before any work.

pub mod generate;
pub mod job;
pub mod plan;
pub mod recipe;
