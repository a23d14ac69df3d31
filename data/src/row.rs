//! One sample of a dataset: a row of `targets.csv`.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{DataError, Result};

/// How a sample was taken.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Pressed straight down onto the pose (canonical, unsheared).
    #[default]
    Tap,
    /// Touched down at `pose + shear` and slid to the pose (sheared).
    Slide,
}

/// Which part of the data a pose belongs to (split by pose, never by image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    /// Training.
    #[default]
    Train,
    /// Validation.
    Val,
    /// Test.
    Test,
}

/// A row of `targets.csv` (mm and degrees).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct Row {
    /// Image file name under `images/`.
    pub sensor_image: String,
    pub pose_x: f64,
    pub pose_y: f64,
    pub pose_z: f64,
    #[serde(rename = "pose_Rx")]
    pub pose_rx: f64,
    #[serde(rename = "pose_Ry")]
    pub pose_ry: f64,
    #[serde(rename = "pose_Rz")]
    pub pose_rz: f64,
    pub shear_x: f64,
    pub shear_y: f64,
    pub shear_z: f64,
    #[serde(rename = "shear_Rx")]
    pub shear_rx: f64,
    #[serde(rename = "shear_Ry")]
    pub shear_ry: f64,
    #[serde(rename = "shear_Rz")]
    pub shear_rz: f64,
    /// Tap or slide.
    pub kind: Kind,
    /// Stimulus name.
    pub shape: String,
    /// The pose this sample belongs to (unique over the dataset).
    pub pose_id: usize,
    /// The pose's split.
    pub split: Split,
    /// Whether the pose is in the paired (supervised) training subset.
    pub paired: bool,
    // The sample's domain randomisation draw (a recipe's `[randomise]`; see
    // `tacsim_sim::Variation`): columns present only when the recipe randomises.
    /// Pin field shifted right (px); with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_shift_x_px: Option<f64>,
    /// Pin field shifted down (px); with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_shift_y_px: Option<f64>,
    /// Pins rolled about the camera axis (deg); with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_roll_deg: Option<f64>,
    /// Factor on the pin tips' radius; with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_pin_scale: Option<f64>,
    /// Standard deviation of the pins' image offsets (px); with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_pin_jitter_px: Option<f64>,
    /// Added to the pressed depth, label unchanged (mm); with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_depth_offset_mm: Option<f64>,
    /// Blur of the pin coverage (px); with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_blur_px: Option<f64>,
    /// Coverage threshold; with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_threshold: Option<f64>,
    /// Bright specks drawn; with `[randomise]` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dr_specks: Option<u32>,
}

impl Row {
    /// The pose `[x, y, z, Rx, Ry, Rz]`.
    pub fn pose(&self) -> [f64; 6] {
        [self.pose_x, self.pose_y, self.pose_z, self.pose_rx, self.pose_ry, self.pose_rz]
    }

    /// The shear `[x, y, z, Rx, Ry, Rz]`.
    pub fn shear(&self) -> [f64; 6] {
        [self.shear_x, self.shear_y, self.shear_z, self.shear_rx, self.shear_ry, self.shear_rz]
    }
}

/// The CSV text of `rows` (header first).
pub fn to_csv(rows: &[Row]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| DataError::format("targets.csv", e.to_string()))?;
    }
    w.into_inner().map_err(|e| DataError::format("targets.csv", e.to_string()))
}

/// Reads the rows of a `targets.csv`; errors name the file and the line.
pub fn read_csv(path: &Path) -> Result<Vec<Row>> {
    let text = std::fs::read(path).map_err(|e| DataError::io(path, "read", e))?;
    let mut r = csv::Reader::from_reader(text.as_slice());
    r.deserialize().map(|row| row.map_err(|e| DataError::format(path, format!("bad row: {e}")))).collect()
}
