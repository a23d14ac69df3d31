//! Training and evaluation data: a `tacsim generate` dataset (through `tacsim-data`) held in
//! memory at the network size, with the paper's pairings and the pose labels.
//!
//! A pose is identified by `(shape, pose_id)`; the splits, the paired subset and the true
//! tap/slide pairs come from the dataset ([`tacsim_data::Dataset`]).

use std::collections::BTreeSet;
use std::path::Path;

use burn::tensor::{Device, Tensor};
use tacsim_data::{Dataset, Kind, LabFolder, Meta, Row, Split, Subset};

use crate::error::{ModelError, Result};
use crate::images::{ImageSet, Preprocess};
use crate::posenet::{Column, LabelRange, Pose, PoseScale};

/// A dataset with every image loaded at one side.
#[derive(Clone, Debug)]
pub struct Corpus {
    /// The dataset (rows, meta).
    pub dataset: Dataset,
    /// One image per row, in row order.
    pub images: ImageSet,
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
        Ok(Self { dataset, images })
    }

    /// Opens a lab recording folder (`targets.csv` + `images/`, as in
    /// `../shared/data/real-tactip-surface3d/`) with the lab's preprocessing `pre` (crop,
    /// resize, threshold), so that a simulator-trained model can be fine-tuned or evaluated on
    /// real recordings. Recordings with zero shear count as taps, the others as slides; each
    /// recording is its own pose; the held-out 20% ([`tacsim_data::LabSample::is_held_out`],
    /// the part `tacsim calibrate` never fits) is the test split, the rest the training split;
    /// none is paired.
    pub fn open_lab(dir: &Path, pre: &Preprocess) -> Result<Self> {
        let folder = LabFolder::open(dir)?;
        let rows: Vec<Row> = folder
            .samples
            .iter()
            .enumerate()
            .map(|(i, s)| Row {
                sensor_image: s.image.clone(),
                pose_x: s.pose[0],
                pose_y: s.pose[1],
                pose_z: s.pose[2],
                pose_rx: s.pose[3],
                pose_ry: s.pose[4],
                pose_rz: s.pose[5],
                shear_x: s.shear[0],
                shear_y: s.shear[1],
                shear_z: s.shear[2],
                shear_rx: s.shear[3],
                shear_ry: s.shear[4],
                shear_rz: s.shear[5],
                kind: if s.shear.iter().all(|v| *v == 0.0) { Kind::Tap } else { Kind::Slide },
                shape: "lab".into(),
                pose_id: i,
                split: if s.is_held_out() { Split::Test } else { Split::Train },
                paired: false,
                ..Default::default()
            })
            .collect();
        // Every image the first one's size (one lab-folder rule with calibrate's).
        let first = folder.samples.first().map(|s| folder.image_path(s));
        let first_size = match &first {
            Some(p) => {
                let (w, h) = image::image_dimensions(p)
                    .map_err(|e| ModelError::checkpoint(p, format!("not a readable image: {e}")))?;
                tacsim_data::check_lab_image_size(p, w, h)?;
                Some((w, h))
            }
            None => None,
        };
        let images = ImageSet::load(rows.len(), pre, |k| {
            let path = folder.image_path(&folder.samples[k]);
            let img = image::open(&path)
                .map_err(|e| ModelError::checkpoint(&path, format!("not a readable image: {e}")))?
                .into_luma8();
            tacsim_data::check_lab_image_size(&path, img.width(), img.height())?;
            if let (Some(first), Some(size)) = (&first, first_size) {
                tacsim_data::check_lab_image_alike(&path, img.dimensions(), size, &first.display().to_string())?;
            }
            Ok((img, path.display().to_string()))
        })?;
        let taps = rows.iter().filter(|r| r.kind == Kind::Tap).count();
        let meta = Meta {
            format: Meta::FORMAT,
            tool: "lab folder".into(),
            seed: 0,
            image_size: pre.side,
            samples: rows.len(),
            taps,
            slides: rows.len() - taps,
            reference_image: "image_0.png".into(),
            recipe: serde_json::Value::Null,
            sensor: serde_json::Value::Null,
            shard: None,
        };
        Ok(Self { dataset: Dataset { dir: dir.to_owned(), meta, rows }, images })
    }

    /// Opens `dir` as a `tacsim generate` dataset when it holds tacsim's `meta.json` (one with
    /// a `format` field), else as a lab folder with the preprocessing `pre` (a lab's own
    /// `meta.json`, as the edge recordings' rig frames, is not tacsim's).
    pub fn open_any(dir: &Path, pre: &Preprocess) -> Result<Self> {
        let tacsim_meta = std::fs::read_to_string(dir.join("meta.json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .is_some_and(|v| v.get("format").is_some());
        if tacsim_meta { Self::open(dir, pre.side as usize) } else { Self::open_lab(dir, pre) }
    }

    /// Image side (px).
    pub fn side(&self) -> usize {
        self.images.side()
    }

    /// A 64-bit FNV-1a hash of the rows (labels, splits, pairs, image names) and every
    /// image's pixels as loaded: a training run records it, and a resume with other data
    /// is refused.
    pub fn fingerprint(&self) -> u64 {
        let mut h = tacsim_data::Fnv1a::default();
        for (k, row) in self.dataset.rows.iter().enumerate() {
            h.write(serde_json::to_string(row).unwrap_or_default().as_bytes());
            h.write(self.images.image(k));
        }
        h.finish()
    }

    /// A batch of the images of `rows`, shifted by `shifts` (px).
    pub fn batch(&self, rows: &[usize], shifts: &[(i32, i32)], device: &Device) -> Tensor<4> {
        self.images.batch(rows, shifts, device)
    }

    /// The `(taps, slides)` batches of `(tap, slide)` row pairs: every slide shifted by its
    /// entry of `shifts` (px), every tap by the same shift when `shift_taps`, else not at all
    /// (supervised targets, see [`UnshearConfig::shift_targets`](crate::config::UnshearConfig::shift_targets)).
    pub fn pair_batch(
        &self,
        pairs: &[(usize, usize)],
        shifts: &[(i32, i32)],
        shift_taps: bool,
        device: &Device,
    ) -> (Tensor<4>, Tensor<4>) {
        let taps: Vec<usize> = pairs.iter().map(|p| p.0).collect();
        let slides: Vec<usize> = pairs.iter().map(|p| p.1).collect();
        let tap_shifts = if shift_taps { shifts } else { &[] };
        (self.batch(&taps, tap_shifts, device), self.batch(&slides, shifts, device))
    }

    /// The rows of `split` a pose network reading `labels` learns from: the slides when it
    /// reads a slide's offset (`shear_*`, zero on taps), else the taps, or the slides where
    /// there are no taps (a lab folder where every recording slid, as the surface recordings).
    pub fn pose_rows(&self, split: Split, labels: &[Column]) -> Vec<usize> {
        let slides = || self.dataset.indices(split, Subset::All, Kind::Slide);
        if labels.iter().any(|c| c.is_shear()) {
            return slides();
        }
        let taps = self.dataset.indices(split, Subset::All, Kind::Tap);
        if taps.is_empty() { slides() } else { taps }
    }

    /// This corpus with `rows` its only training rows, each labelled `relabel(pose)` in the
    /// columns `labels`, every other row held out of training (the images as they are).
    pub fn training_only(&self, rows: &[usize], relabel: impl Fn(&Pose) -> Pose, labels: &[Column]) -> Corpus {
        let mut dataset = self.dataset.clone();
        for r in &mut dataset.rows {
            r.split = Split::Test;
        }
        for &i in rows {
            let pose = relabel(&self.pose(i));
            let row = &mut dataset.rows[i];
            row.split = Split::Train;
            for &c in labels {
                c.set(row, pose.get(c));
            }
        }
        Corpus { dataset, images: self.images.clone() }
    }

    /// The labels of a row.
    pub fn pose(&self, row: usize) -> Pose {
        Pose::of_row(&self.dataset.rows[row])
    }

    /// The ranges that normalise `labels` for a network trained on `rows`: the recipe's pose
    /// ranges (`poses.x_mm`, `poses.y_mm`, `poses.yaw_deg`) where the dataset's meta holds a
    /// recipe, else the smallest ranges holding the labels of `rows`.
    pub fn pose_scale(&self, labels: &[Column], rows: &[usize]) -> PoseScale {
        let poses: Vec<Pose> = rows.iter().map(|&r| self.pose(r)).collect();
        let mut scale = PoseScale::covering(labels, &poses);
        for l in &mut scale.labels {
            if let Some(range) = recipe_range(&self.dataset.meta.recipe, l.column) {
                *l = LabelRange { column: l.column, range };
            }
        }
        scale
    }

    /// The labels among `candidates` that vary over `rows` (by more than 1e-6 mm or deg).
    pub fn varying(&self, candidates: &[Column], rows: &[usize]) -> Vec<Column> {
        candidates
            .iter()
            .copied()
            .filter(|&c| {
                let v = rows.iter().map(|&r| c.of(&self.dataset.rows[r]));
                let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
                hi - lo > 1e-6
            })
            .collect()
    }

    /// True `(tap, slide)` pairs for the supervised phase at a label `fraction` of the
    /// training poses. The dataset's paired subset holds its recipe's `split.paired_fraction`
    /// of them (the paper's 10%); a smaller fraction keeps the first
    /// `floor(paired * fraction / paired_fraction)` (at least one) of those poses, so that
    /// 10%, 8% and 5% of a 10% subset of 3 poses use 3, 2 and 1. A fraction above the
    /// dataset's is an error.
    pub fn labelled_pairs(&self, fraction: f64) -> Result<Vec<(usize, usize)>> {
        let train = self.poses(Split::Train, Subset::All);
        let paired = self.poses(Split::Train, Subset::Paired);
        let have = recipe_paired_fraction(&self.dataset.meta.recipe)
            .unwrap_or(paired.len() as f64 / train.len().max(1) as f64);
        if paired.is_empty() || fraction > have + 1e-9 {
            return Err(ModelError::Insufficient(format!(
                "label_fraction {fraction} is more than {} holds ({} of {} training poses paired, split.paired_fraction {have}): lower label_fraction or generate with a larger paired_fraction",
                self.dataset.dir.display(),
                paired.len(),
                train.len()
            )));
        }
        let want = ((paired.len() as f64 * fraction / have + 1e-9).floor() as usize).clamp(1, paired.len());
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

/// The recipe's `split.paired_fraction`, if the meta holds a recipe.
fn recipe_paired_fraction(recipe: &serde_json::Value) -> Option<f64> {
    recipe.get("split")?.get("paired_fraction")?.as_f64()
}

/// The recipe's range of a pose label (`poses.x_mm`, `poses.y_mm`, `poses.yaw_deg` for
/// `pose_x`, `pose_y`, `pose_Rz`), if the meta holds a recipe.
fn recipe_range(recipe: &serde_json::Value, column: Column) -> Option<[f64; 2]> {
    let name = match column {
        Column::PoseX => "x_mm",
        Column::PoseY => "y_mm",
        Column::PoseRz => "yaw_deg",
        _ => return None,
    };
    let v = recipe.get("poses")?.get(name)?.as_array()?;
    Some([v.first()?.as_f64()?, v.get(1)?.as_f64()?])
}
