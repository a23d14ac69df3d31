//! Real observations: the reference pins of a lab folder's undeformed image and, per sample,
//! each reference pin's tracked displacement (px of the real images).

use rayon::prelude::*;
use tacsim_data::{LabFolder, LabSample};

use super::reference::Reference;
use crate::error::Result;
use crate::motion::PinMotion;
use crate::tracking::Tracking;

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
        let motion = PinMotion::new(&reference.image, &reference.describe())?;
        let skip = reference.image_name();
        let samples = folder
            .samples
            .par_iter()
            .filter(|s| Some(s.image.as_str()) != skip)
            .map(|s| -> Result<Observation> {
                let img = reference.read(&folder.image_path(s))?;
                // The lab's recordings move pins by under half a spacing as a whole (the largest
                // shift of a tracked sample is about 0.3 spacing), but a deep press spreads the
                // outer rings by most of a spacing: `PinMotion::track` starts from the best
                // spread and shift.
                Ok(Observation { sample: s.clone(), tracking: motion.track(&img) })
            })
            .collect::<Result<Vec<_>>>()?;
        let reference_pins = motion.reference().to_vec();
        Ok(Self { size: reference.image.width(), reference: reference_pins, samples })
    }
}
