//! Datasets with the paper's tap/slide protocol (`docs/design.md`): a [`Recipe`] (TOML)
//! becomes a deterministic [`Plan`] of samples (every random draw comes from the seed and the
//! sample's own index, so any subset can be generated alone: shards, resumes, any thread
//! count), which [`generate()`] renders into the directory format of `tacsim_data`; a [`Job`]
//! sets a run up (sensor, scenes, the size it would write) before any work.

mod generate;
mod job;
mod plan;
mod recipe;

pub use generate::{Summary, generate, merge, merge_moving, recipe_sensor};
pub use job::{Job, MAX_UNFORCED_BYTES, MAX_UNFORCED_IMAGES, OutputEstimate, base_sensor};
pub use plan::{LabelFrame, Plan, PosePlan, REFERENCE_IMAGE, Sample, image_name};
pub use recipe::{
    Axes, MAX_PER_POSE, MAX_PER_SHAPE, MAX_SAMPLES, PoseSpec, RandomiseSpec, Recipe, RecipeShape, RigSpec, SlideSpec,
    SplitSpec, TapSpec,
};
