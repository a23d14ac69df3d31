//! Learned perception as the loop sees it: a reader of the pose relative to the edge from the
//! rendered image, supplied by the caller. The networks live in `tacsim-model` (burn), which
//! this crate does not depend on, so the loop builds and runs its oracle and geometric
//! perception without them; `tacsim run` supplies readers built on the trained runs.

use image::GrayImage;
use tacsim_sim::SensorParams;

use crate::error::Result;
use crate::perception::EdgeEstimate;
use crate::scenario::Scenario;

/// Reads the pose relative to the edge from one rendered image (the scenario's size, the
/// run's sensor): `None` where the image shows no contact.
pub trait EdgeReader {
    /// The estimate from `image`.
    fn estimate(&self, image: &GrayImage) -> Result<Option<EdgeEstimate>>;
}

/// Builds the reader a scenario's `learned` or `learned-raw` perception asks for (its
/// `[models]`, its image size) for the run's sensor.
pub trait LearnedPerception {
    /// The reader for `scenario` with `sensor`.
    fn reader(&self, scenario: &Scenario, sensor: &SensorParams) -> Result<Box<dyn EdgeReader>>;
}
