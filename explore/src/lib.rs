//! tacsim's closed loop: contour following (`docs/design.md`). A kinematic robot slides
//! the sensor along a stimulus's edge, staying in contact so that every step carries sliding
//! history from the contact engine; perception estimates the pose relative to the edge
//! ([`oracle`], [`Geometric`] from the rendered image's pins, or a [`LearnedPerception`] the
//! caller supplies: the networks live in `tacsim-model`, so this crate builds without burn);
//! a PI servo corrects it as the lab's does; [`run`] strings them into a loop with metrics
//! ([`RunReport`]), reading the contact patch off the pins' Voronoi cells and fusing the
//! patches into the object's footprint. Scenarios are TOML
//! files ([`Scenario`], `scenarios/explore/`). Data flows one way: scene -> contact -> pins ->
//! image -> perception -> control.
//!
//! Frames: world `x, y` (mm) with the object at its pose; the sensor's yaw turns its `x` axis
//! from world `x`. The servo keeps the edge under the sensor with the material on the sensor's
//! left of its direction of travel (`+x`), the contour traced counter-clockwise.

mod contact_geometry;
mod control;
mod error;
mod learned;
mod perception;
mod reconstruct;
mod robot;
mod run;
mod scenario;

pub use error::{ExploreError, Result};
pub use learned::{EdgeReader, LearnedPerception};
pub use perception::{EdgeEstimate, Geometric, oracle};
pub use run::{PerceptionError, RunReport, reference_press, run};
pub use scenario::{Control, Criteria, MAX_SUBSTEPS, Models, Noise, PerceptionKind, Scenario};
