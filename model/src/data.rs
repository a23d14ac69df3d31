//! Training and evaluation data: a `tacsim generate` dataset (through `tacsim-data`) held in
//! memory at the network size, with the paper's pairings and the pose labels.
//!
//! A pose is identified by `(shape, pose_id)`; the splits, the paired subset and the true
//! tap/slide pairs come from the dataset ([`tacsim_data::Dataset`]).

use std::collections::BTreeSet;
use std::path::Path;

use burn::tensor::{Device, Tensor};
use tacsim_data::{Dataset, Kind, Row, Split, Subset};

use crate::error::{ModelError, Result};
use crate::images::{ImageSet, Preprocess};
use crate::posenet::{Pose, PoseScale};

/// A dataset with every image loaded at one side.
#[derive(Clone, Debug)]
pub struct Corpus {
    /// The dataset (rows, meta).
    pub dataset: Dataset,
    /// One image per row, in row order.
    pub images: ImageSet,
    /// Ranges that normalise the pose labels: the recipe's pose ranges, else the labels'.
    pub scale: PoseScale,
}

impl Corpus {
    /// Opens the dataset at `dir` and loads every image at `side` px (resized and
    /// thresholded if the dataset's images have another size).
    pub fn open(dir: &Path, side: usize) -> Result<Self> {
        let dataset = Dataset::open(dir)?;
        let pre = Preprocess::resize(side as u32);
        let images = ImageSet::load(dataset.rows.len(), &pre, |k| {
            let row = &dataset.rows[k];
            Ok((dataset.image(row)?, dataset.image_path(row).display().to_string()))
        })?;
        let scale = recipe_scale(&dataset.meta.recipe)
            .unwrap_or_else(|| PoseScale::covering(&dataset.rows.iter().map(pose_of).collect::<Vec<_>>()));
        Ok(Self { dataset, images, scale })
    }

    /// Image side (px).
    pub fn side(&self) -> usize {
        self.images.side()
    }

    /// A batch of the images of `rows`, shifted by `shifts` (px).
    pub fn batch(&self, rows: &[usize], shifts: &[(i32, i32)], device: &Device) -> Tensor<4> {
        self.images.batch(rows, shifts, device)
    }

    /// The pose label of a row.
    pub fn pose(&self, row: usize) -> Pose {
        pose_of(&self.dataset.rows[row])
    }

    /// True `(tap, slide)` pairs for the supervised phase: those of the first
    /// `ceil(fraction * training poses)` paired training poses. Errors when the dataset's
    /// paired subset is smaller than that.
    pub fn labelled_pairs(&self, fraction: f64) -> Result<Vec<(usize, usize)>> {
        let train = self.poses(Split::Train, Subset::All);
        let paired = self.poses(Split::Train, Subset::Paired);
        let want = (fraction * train.len() as f64).ceil() as usize;
        if want > paired.len() {
            return Err(ModelError::Insufficient(format!(
                "label_fraction {fraction} needs {want} paired training poses but {} has {} of {} (its recipe's split.paired_fraction): lower label_fraction or generate with a larger paired_fraction",
                self.dataset.dir.display(),
                paired.len(),
                train.len()
            )));
        }
        let keep: BTreeSet<(String, usize)> = paired.into_iter().take(want).collect();
        Ok(self
            .dataset
            .true_pairs(Split::Train, Subset::Paired)
            .into_iter()
            .filter(|&(t, _)| keep.contains(&key(&self.dataset.rows[t])))
            .collect())
    }

    /// The distinct poses `(shape, pose_id)` of a split and subset, sorted.
    pub fn poses(&self, split: Split, subset: Subset) -> Vec<(String, usize)> {
        let mut set = BTreeSet::new();
        for kind in [Kind::Tap, Kind::Slide] {
            for i in self.dataset.indices(split, subset, kind) {
                set.insert(key(&self.dataset.rows[i]));
            }
        }
        set.into_iter().collect()
    }
}

fn key(r: &Row) -> (String, usize) {
    (r.shape.clone(), r.pose_id)
}

/// The pose label of a row: `pose_x`, `pose_y` (mm) and `pose_rz` (deg).
pub fn pose_of(r: &Row) -> Pose {
    Pose { x_mm: r.pose_x, y_mm: r.pose_y, yaw_deg: r.pose_rz }
}

/// The recipe's pose ranges (`poses.x_mm`, `poses.y_mm`, `poses.yaw_deg`), if the meta holds
/// a recipe.
fn recipe_scale(recipe: &serde_json::Value) -> Option<PoseScale> {
    let range = |name: &str| -> Option<[f64; 2]> {
        let v = recipe.get("poses")?.get(name)?.as_array()?;
        Some([v.first()?.as_f64()?, v.get(1)?.as_f64()?])
    };
    Some(PoseScale { x_mm: range("x_mm")?, y_mm: range("y_mm")?, yaw_deg: range("yaw_deg")? })
}
