//! The built-in stimuli and dataset recipes, compiled in ([`tacsim_sim::embedded`]), so
//! `tacsim` runs from any directory without the repository.

pub use tacsim_sim::embedded::{RECIPES, SHAPE_FILES, catalogue};
