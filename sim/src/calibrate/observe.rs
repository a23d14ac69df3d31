//! Real observations: the reference pins of a lab folder's undeformed image and, per sample,
//! each reference pin's tracked displacement (px of the real images).

use rayon::prelude::*;
use tacsim_data::{LabFolder, LabSample};

use super::reference::Reference;
use crate::detect::pin_centres;
use crate::error::{Result, SimError};
use crate::tracking::{Tracking, global_warp, track};

/// Pin spacing of the lab's 420 px images (px), scaled with the image size.
pub const SPACING_PX420: f64 = 17.5;

/// Largest spread of the pins about the image centre a press is searched for (12%: the
/// outermost ring moves out by up to about 16 px of 185 in the lab's deepest recordings).
const MAX_SPREAD: f64 = 1.12;

/// One tracked real sample.
#[derive(Clone, Debug)]
pub struct Observation {
    /// The sample's labels.
    pub sample: LabSample,
    /// Tracking of the reference pins.
    pub tracking: Tracking,
}

/// The reference and the tracked samples of a lab folder.
#[derive(Clone, Debug)]
pub struct Observations {
    /// Image side (px).
    pub size: u32,
    /// Reference pin centres (px).
    pub reference: Vec<[f64; 2]>,
    /// The samples other than the reference.
    pub samples: Vec<Observation>,
}

impl Observations {
    /// Tracks every sample of `folder` against `reference` (every image cut as it is); a
    /// sample naming the reference image is skipped.
    pub fn track(folder: &LabFolder, reference: &Reference) -> Result<Self> {
        let (w, h) = reference.image.dimensions();
        let reference_pins = pin_centres(&reference.image);
        if reference_pins.len() < 7 {
            return Err(SimError::Analysis {
                source_name: reference.describe(),
                reason: format!("{} pins found in the reference: too few to track", reference_pins.len()),
            });
        }
        let spacing = SPACING_PX420 * w as f64 / 420.0;
        let skip = reference.image_name();
        let samples = folder
            .samples
            .par_iter()
            .filter(|s| Some(s.image.as_str()) != skip)
            .map(|s| -> Result<Observation> {
                let img = reference.read(&folder.image_path(s))?;
                let detected = pin_centres(&img);
                // The lab's recordings move pins by under half a spacing as a whole (the largest
                // shift of a tracked sample is about 0.3 spacing), but a deep press spreads the
                // outer rings by most of a spacing: start from the best spread and shift.
                let centre = [0.5 * w as f64, 0.5 * h as f64];
                let start = global_warp(&reference_pins, &detected, spacing, centre, MAX_SPREAD);
                let tracking = track(&reference_pins, &detected, spacing, &start);
                Ok(Observation { sample: s.clone(), tracking })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self { size: w, reference: reference_pins, samples })
    }
}
