//! The lab's recording folders (`targets.csv` + `images/`, as in
//! `../shared/data/real-tactip-surface3d/`): the labels each sample carries, read by column
//! name, with errors naming the file, the column and the line.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{DataError, Result};

/// One recording: image file and labels (mm, deg).
#[derive(Clone, Debug, PartialEq)]
pub struct LabSample {
    /// Image file name under `images/`.
    pub image: String,
    /// `[x, y, z, Rx, Ry, Rz]`.
    pub pose: [f64; 6],
    /// `[x, y, z, Rx, Ry, Rz]`: the touch-down offset (the sensor went to pose + shear, pressed
    /// in, slid to pose).
    pub shear: [f64; 6],
}

/// A lab folder.
#[derive(Clone, Debug)]
pub struct LabFolder {
    /// The folder.
    pub dir: PathBuf,
    /// Its samples, in `targets.csv` order.
    pub samples: Vec<LabSample>,
}

/// The label columns every folder must have.
pub const COLUMNS: [&str; 13] = [
    "sensor_image",
    "pose_x",
    "pose_y",
    "pose_z",
    "pose_Rx",
    "pose_Ry",
    "pose_Rz",
    "shear_x",
    "shear_y",
    "shear_z",
    "shear_Rx",
    "shear_Ry",
    "shear_Rz",
];

impl LabFolder {
    /// Reads `dir/targets.csv` and checks that every image exists.
    pub fn open(dir: &Path) -> Result<Self> {
        let csv_path = dir.join("targets.csv");
        let text = std::fs::read(&csv_path).map_err(|e| DataError::io(&csv_path, "read", e))?;
        let mut r = csv::Reader::from_reader(text.as_slice());
        let headers = r.headers().map_err(|e| DataError::format(&csv_path, e.to_string()))?.clone();
        let col: HashMap<&str, usize> = headers.iter().enumerate().map(|(i, h)| (h, i)).collect();
        let missing: Vec<&str> = COLUMNS.iter().copied().filter(|c| !col.contains_key(c)).collect();
        if !missing.is_empty() {
            return Err(DataError::format(
                &csv_path,
                format!("missing column(s) {}; a lab folder needs {}", missing.join(", "), COLUMNS.join(", ")),
            ));
        }
        let mut samples = Vec::new();
        for (line, rec) in r.records().enumerate() {
            let rec = rec.map_err(|e| DataError::format(&csv_path, e.to_string()))?;
            let field = |name: &str| -> Result<f64> {
                let s = rec.get(col[name]).unwrap_or("");
                s.trim().parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                    DataError::format(
                        &csv_path,
                        format!("line {}: column {name}: `{s}` is not a finite number", line + 2),
                    )
                })
            };
            let image = rec.get(col["sensor_image"]).unwrap_or("").to_owned();
            if !dir.join("images").join(&image).is_file() {
                return Err(DataError::format(&csv_path, format!("line {}: images/{image} does not exist", line + 2)));
            }
            let g = |names: [&str; 6]| -> Result<[f64; 6]> {
                let mut v = [0.0; 6];
                for (o, n) in v.iter_mut().zip(names) {
                    *o = field(n)?;
                }
                Ok(v)
            };
            samples.push(LabSample {
                image,
                pose: g(["pose_x", "pose_y", "pose_z", "pose_Rx", "pose_Ry", "pose_Rz"])?,
                shear: g(["shear_x", "shear_y", "shear_z", "shear_Rx", "shear_Ry", "shear_Rz"])?,
            });
        }
        if samples.is_empty() {
            return Err(DataError::format(&csv_path, "has no samples"));
        }
        Ok(Self { dir: dir.to_owned(), samples })
    }

    /// Path of a sample's image.
    pub fn image_path(&self, s: &LabSample) -> PathBuf {
        self.dir.join("images").join(&s.image)
    }
}
