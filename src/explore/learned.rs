//! Learned perception: the pose relative to the edge read from the rendered image by trained
//! networks (`tacsim-model`), as the paper's robot does: the shear-removal model turns the
//! sliding (sheared) image into a tap-like one, then the pose network, trained on taps in the
//! edge frame (`scenarios/datasets/explore.toml`), regresses the lateral offset and the edge
//! angle. `learned-raw` skips the shear removal (the paper's Table I "sheared" row).

use tacsim_data::wrap_deg;
use tacsim_explore::{EdgeEstimate, EdgeReader, ExploreError, LearnedPerception, Models, Scenario};
use tacsim_model::{Backend, PoseReader};
use tacsim_sim::SensorParams;

/// The undeformed image and the trained networks.
pub struct Learned {
    reference: image::GrayImage,
    reader: PoseReader,
}

/// Share of the image's pixels that must differ from the undeformed image for the sensor to
/// count as touching. The networks were trained on contacts only and read some pose from any
/// image, so a robot that slid off the edge must be told apart first (as `geometric`
/// perception does when no pin shows contact).
const CONTACT_PIXELS: f64 = 1e-3;

impl Learned {
    /// Perception for `sensor` reading images of `size` px with the runs of `models`; with `raw`
    /// the shear-removal model is left out.
    pub fn new(sensor: &SensorParams, size: u32, models: &Models, raw: bool) -> tacsim_explore::Result<Self> {
        let renderer = tacsim_sim::PinRenderer::new(sensor, size)?;
        let unshear = (!raw).then_some(models.unshear.as_path());
        let failed = |reason: String| ExploreError::Perception { what: "field `models`".into(), reason };
        let reader = PoseReader::load(&models.posenet, unshear, Backend::Flex).map_err(|e| {
            failed(format!(
                "loading {}{} (train them with `cargo xtask explore`): {e}",
                models.posenet.display(),
                unshear.map(|u| format!(" and {}", u.display())).unwrap_or_default()
            ))
        })?;
        reader
            .require(&[tacsim_data::Column::PoseX, tacsim_data::Column::PoseRz], "edge perception")
            .map_err(|e| failed(e.to_string()))?;
        let reference = renderer.render_undeformed();
        Ok(Self { reference, reader })
    }
}

impl EdgeReader for Learned {
    /// The estimate from the current pins' image (`size` px, rendered for `sensor`). The pose network's labels are edge-frame poses:
    /// `x` is the offset along the outward normal and the yaw is the sensor's `x` axis from
    /// the tangent, so the edge angle from the sensor's `x` axis is minus the yaw. `None`
    /// when the image shows no contact (fewer than `CONTACT_PIXELS` of its pixels changed).
    fn estimate(&self, img: &image::GrayImage) -> tacsim_explore::Result<Option<EdgeEstimate>> {
        let changed = img.as_raw().iter().zip(self.reference.as_raw()).filter(|(a, b)| a != b).count();
        if (changed as f64) < CONTACT_PIXELS * img.as_raw().len() as f64 {
            return Ok(None);
        }
        let pose = self
            .reader
            .read(img)
            .map_err(|e| ExploreError::Perception { what: "learned perception".into(), reason: e.to_string() })?;
        Ok(Some(EdgeEstimate { offset_mm: pose.x_mm(), angle_deg: wrap_deg(-pose.yaw_deg()) }))
    }
}

/// The loop's learned perception with the `tacsim-model` networks of each scenario's
/// `[models]` (`learned-raw`: the pose network alone).
pub struct Networks;

impl LearnedPerception for Networks {
    fn reader(&self, scenario: &Scenario, sensor: &SensorParams) -> tacsim_explore::Result<Box<dyn EdgeReader>> {
        let raw = scenario.perception == tacsim_explore::PerceptionKind::LearnedRaw;
        Learned::new(sensor, scenario.image_size, &scenario.models, raw)
            .map(|l| Box::new(l) as Box<dyn EdgeReader>)
            .map_err(|e| e.within(&format!("scenario {}", scenario.name)))
    }
}
