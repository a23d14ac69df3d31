//! The lab's recording folders (`targets.csv` + `images/`, as in
//! `../shared/data/real-tactip-surface3d/`): the labels each sample carries, read by column
//! name, with errors naming the file, the column and the line.
//!
//! Two column namings are read (a folder uses one of them whole):
//! - [`COLUMNS`]: `pose_x, pose_y, pose_z, pose_Rx, pose_Ry, pose_Rz` and the touch-down offset
//!   `shear_x .. shear_Rz` (the lab's current collection code);
//! - [`OLDER_COLUMNS`]: `pose_1 .. pose_6` and `move_1 .. move_6`, the same six components in
//!   the same order (x, y, z mm; Rx, Ry, Rz deg), as the lab's older collection code wrote them
//!   (`../shared/data/real-tactip-edge2d/`: `pose_2` lateral, `pose_3` depth, `pose_6` yaw).

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

/// The lab's older naming of [`COLUMNS`], in the same order: `pose_1..pose_6` are `pose_x ..
/// pose_Rz` and `move_1..move_6` are `shear_x .. shear_Rz`.
pub const OLDER_COLUMNS: [&str; 13] = [
    "sensor_image",
    "pose_1",
    "pose_2",
    "pose_3",
    "pose_4",
    "pose_5",
    "pose_6",
    "move_1",
    "move_2",
    "move_3",
    "move_4",
    "move_5",
    "move_6",
];

/// Largest label magnitude a lab folder may carry (mm or deg): a robot's positions and a
/// turn's angles sit far below; a larger one is a unit or export error (regression, issue 88:
/// labels of 1e300 passed and gave a report with a 9e298 mm error).
pub const MAX_LABEL: f64 = 1e6;

/// The sides a lab image may have (px), checked by every command that reads the images:
/// below 16 px no pin pattern shows, above 8192 px the image is not a TacTip frame (regression,
/// issue 88: 1x1 images were refused by `calibrate` but trained on by `train` and `sim2real`).
pub const LAB_IMAGE_SIDE_PX: std::ops::RangeInclusive<u32> = 16..=8192;

/// Checks a lab image's size ([`LAB_IMAGE_SIDE_PX`]), naming the file.
pub fn check_lab_image_size(path: &Path, width: u32, height: u32) -> Result<()> {
    if LAB_IMAGE_SIDE_PX.contains(&width) && LAB_IMAGE_SIDE_PX.contains(&height) {
        return Ok(());
    }
    Err(DataError::format(
        path,
        format!(
            "is {width}x{height} px: a lab image's sides must be in [{}, {}] px",
            LAB_IMAGE_SIDE_PX.start(),
            LAB_IMAGE_SIDE_PX.end()
        ),
    ))
}

/// Checks that a lab image has its folder's size `expected` (px, that of `first`: the
/// reference, or the first sample's file), naming both: `train` and `sim2real` resized a
/// folder of mixed sizes image by image without a word (issue 88); `calibrate` refused it.
pub fn check_lab_image_alike(path: &Path, size: (u32, u32), expected: (u32, u32), first: &str) -> Result<()> {
    if size == expected {
        return Ok(());
    }
    Err(DataError::format(
        path,
        format!(
            "is {}x{} px but {first} is {}x{} px: a lab folder's images must all have one size",
            size.0, size.1, expected.0, expected.1
        ),
    ))
}

impl LabFolder {
    /// Reads `dir/targets.csv` (either naming of the columns) and checks that every image
    /// exists.
    pub fn open(dir: &Path) -> Result<Self> {
        let csv_path = dir.join("targets.csv");
        let text = std::fs::read(&csv_path).map_err(|e| DataError::io(&csv_path, "read", e))?;
        let mut r = csv::Reader::from_reader(text.as_slice());
        let headers = r.headers().map_err(|e| DataError::format(&csv_path, e.to_string()))?.clone();
        let col: HashMap<&str, usize> = headers.iter().enumerate().map(|(i, h)| (h, i)).collect();
        let missing_of = |names: &[&'static str]| -> Vec<&'static str> {
            names.iter().copied().filter(|c| !col.contains_key(c)).collect()
        };
        let (missing, older) = (missing_of(&COLUMNS), missing_of(&OLDER_COLUMNS));
        let names = match (missing.is_empty(), older.is_empty()) {
            (true, _) => COLUMNS,
            (false, true) => OLDER_COLUMNS,
            (false, false) => {
                return Err(DataError::format(
                    &csv_path,
                    format!(
                        "missing column(s) {}; a lab folder needs {} (or the older naming {})",
                        missing.join(", "),
                        COLUMNS.join(", "),
                        OLDER_COLUMNS.join(", ")
                    ),
                ));
            }
        };
        let mut samples = Vec::new();
        for (line, rec) in r.records().enumerate() {
            let rec = rec.map_err(|e| DataError::format(&csv_path, e.to_string()))?;
            let field = |name: &str| -> Result<f64> {
                let s = rec.get(col[name]).unwrap_or("");
                s.trim().parse::<f64>().ok().filter(|v| v.is_finite() && v.abs() <= MAX_LABEL).ok_or_else(|| {
                    DataError::format(
                        &csv_path,
                        format!("line {}: column {name}: `{s}` is not a number in [-{MAX_LABEL:e}, {MAX_LABEL:e}] (mm or deg)", line + 2),
                    )
                })
            };
            let image = rec.get(col["sensor_image"]).unwrap_or("").to_owned();
            // A plain path inside images/ (regression, issue 88: `../../../etc/passwd` was read).
            let inside = Path::new(&image).components().all(|c| matches!(c, std::path::Component::Normal(_)));
            if image.is_empty() || !inside {
                return Err(DataError::format(
                    &csv_path,
                    format!("line {}: column sensor_image: `{image}` is not a file inside images/", line + 2),
                ));
            }
            if !dir.join("images").join(&image).is_file() {
                return Err(DataError::format(&csv_path, format!("line {}: images/{image} does not exist", line + 2)));
            }
            let g = |cols: [&str; 6]| -> Result<[f64; 6]> {
                let mut v = [0.0; 6];
                for (o, n) in v.iter_mut().zip(cols) {
                    *o = field(n)?;
                }
                Ok(v)
            };
            let pose = [names[1], names[2], names[3], names[4], names[5], names[6]];
            let shear = [names[7], names[8], names[9], names[10], names[11], names[12]];
            samples.push(LabSample { image, pose: g(pose)?, shear: g(shear)? });
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

/// One hash bucket in this many is held out (20%).
const HELD_OUT_EVERY: u64 = 5;

impl LabSample {
    /// Whether the recording belongs to the held-out 20% that no fit may see (`tacsim
    /// calibrate`'s report, `tacsim sim2real`'s test): its image name hashes into one bucket of
    /// five, so a recording lands on the same side however the folder is ordered or grown.
    pub fn is_held_out(&self) -> bool {
        crate::hash::fnv1a(self.image.as_bytes()).is_multiple_of(HELD_OUT_EVERY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_held_out_part_is_about_a_fifth_by_name() {
        let sample = |i: usize| LabSample { image: format!("image_{i}.png"), pose: [0.0; 6], shear: [0.0; 6] };
        let held = (0..1000).filter(|&i| sample(i).is_held_out()).count();
        assert!((170..=230).contains(&held), "{held}");
        assert_eq!(sample(1).is_held_out(), sample(1).is_held_out());
    }

    fn folder(name: &str, csv: &str, images: &[&str]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("tacsim-lab-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("images")).expect("dir");
        std::fs::write(dir.join("targets.csv"), csv).expect("csv");
        for i in images {
            std::fs::write(dir.join("images").join(i), b"").expect("image");
        }
        dir
    }

    #[test]
    fn the_older_column_names_read_as_the_same_six_components() {
        let csv = "sensor_video,sensor_image,obj_id,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,\
                   move_1,move_2,move_3,move_4,move_5,move_6\n\
                   v.mp4,a.png,1,0.0,1.5,4.0,0.0,0.0,-170.0,0.5,0,0,0,0,2.0\n";
        let dir = folder("older", csv, &["a.png"]);
        let f = LabFolder::open(&dir).expect("older naming");
        assert_eq!(f.samples[0].pose, [0.0, 1.5, 4.0, 0.0, 0.0, -170.0]);
        assert_eq!(f.samples[0].shear, [0.5, 0.0, 0.0, 0.0, 0.0, 2.0]);
    }

    #[test]
    fn a_folder_with_neither_naming_names_what_is_missing() {
        let dir = folder("neither", "sensor_image,pose_x,pose_1\na.png,1,2\n", &["a.png"]);
        let e = LabFolder::open(&dir).expect_err("incomplete").to_string();
        assert!(e.contains("targets.csv") && e.contains("pose_y") && e.contains("move_1"), "{e}");
    }

    /// Regressions (issue 88): labels of 1e300 passed (only non-finite ones were refused), and
    /// `sensor_image = ../../../etc/passwd` was read from outside `images/`.
    #[test]
    fn absurd_labels_and_images_outside_the_folder_are_refused() {
        let head = "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6\n";
        let dir = folder("huge", &format!("{head}a.png,0,1e300,4,0,0,0,0,0,0,0,0,0\n"), &["a.png"]);
        let e = LabFolder::open(&dir).expect_err("1e300").to_string();
        assert!(
            e.contains("targets.csv") && e.contains("line 2") && e.contains("pose_2") && e.contains("1e300"),
            "{e}"
        );
        assert!(e.contains("1e6"), "names the range: {e}");
        let dir = folder("edge", &format!("{head}a.png,0,1e6,4,0,0,-1e6,0,0,0,0,0,0\n"), &["a.png"]);
        assert!(LabFolder::open(&dir).is_ok(), "the bounds themselves are labels");
        for image in ["../targets.csv", "/etc/passwd", "images/../../x.png", ""] {
            let dir = folder("outside", &format!("{head}{image},0,1,4,0,0,0,0,0,0,0,0,0\n"), &[]);
            let e = LabFolder::open(&dir).expect_err(image).to_string();
            assert!(e.contains("sensor_image") && e.contains("inside images/"), "{image}: {e}");
        }
        let e = check_lab_image_size(Path::new("x/a.png"), 1, 1).expect_err("1x1").to_string();
        assert!(e.contains("x/a.png") && e.contains("1x1") && e.contains("[16, 8192]"), "{e}");
        assert!(check_lab_image_size(Path::new("a.png"), 420, 420).is_ok());
    }
}
