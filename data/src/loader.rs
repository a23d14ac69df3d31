//! Reading a dataset directory, with the paper's splits and pairing: true tap/slide pairs of
//! one pose for the supervised subset, and the unpaired subset re-paired at random every epoch
//! from a seeded RNG (self-supervised phase).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use image::GrayImage;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::error::{DataError, Result};
use crate::meta::Meta;
use crate::row::{Kind, Row, Split, read_csv};

/// Which training poses a pairing draws from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Subset {
    /// Every pose of the split.
    All,
    /// Poses marked `paired` (the supervised subset).
    Paired,
    /// Poses not marked `paired` (the self-supervised subset).
    Unpaired,
}

/// A dataset on disk: its meta and rows, every image checked present.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// The directory.
    pub dir: PathBuf,
    /// `meta.json`.
    pub meta: Meta,
    /// `targets.csv`, in order.
    pub rows: Vec<Row>,
}

impl Dataset {
    /// Opens `dir`: reads `meta.json` and `targets.csv` and checks that every image exists.
    pub fn open(dir: &Path) -> Result<Self> {
        let meta = Meta::load(&dir.join("meta.json"))?;
        let rows = read_csv(&dir.join("targets.csv"))?;
        let fail = |reason: String| DataError::Dataset { dir: dir.to_owned(), reason };
        if meta.shard.is_none() && rows.len() != meta.samples {
            return Err(fail(format!("targets.csv has {} rows, meta.json says {}", rows.len(), meta.samples)));
        }
        for (k, r) in rows.iter().enumerate() {
            let labels = [
                ("pose_x", r.pose_x),
                ("pose_y", r.pose_y),
                ("pose_z", r.pose_z),
                ("pose_Rx", r.pose_rx),
                ("pose_Ry", r.pose_ry),
                ("pose_Rz", r.pose_rz),
                ("shear_x", r.shear_x),
                ("shear_y", r.shear_y),
                ("shear_z", r.shear_z),
                ("shear_Rx", r.shear_rx),
                ("shear_Ry", r.shear_ry),
                ("shear_Rz", r.shear_rz),
            ];
            if let Some((column, v)) = labels.iter().find(|(_, v)| !v.is_finite()) {
                return Err(DataError::format(
                    dir.join("targets.csv"),
                    format!("row {} ({}): {column} is {v}; every label must be a finite number", k + 2, r.sensor_image),
                ));
            }
        }
        for name in rows.iter().map(|r| &r.sensor_image).chain(std::iter::once(&meta.reference_image)) {
            if !dir.join("images").join(name).is_file() {
                return Err(fail(format!(
                    "images/{name} is missing: the run was interrupted; rerun the same `tacsim generate` command with --resume"
                )));
            }
        }
        Ok(Self { dir: dir.to_owned(), meta, rows })
    }

    /// Indices of the rows of `split` (and `subset`) of `kind`.
    pub fn indices(&self, split: Split, subset: Subset, kind: Kind) -> Vec<usize> {
        (0..self.rows.len())
            .filter(|&i| {
                let r = &self.rows[i];
                r.split == split
                    && r.kind == kind
                    && match subset {
                        Subset::All => true,
                        Subset::Paired => r.paired,
                        Subset::Unpaired => !r.paired,
                    }
            })
            .collect()
    }

    /// True pairs `(tap, slide)` (row indices) of the same pose: every slide with the tap of
    /// its pose whose depth (`pose_z`) is nearest the slide's (the first such tap on a tie).
    /// Taps carry the recipe's depth jitter and a slide ends at the pose's own depth, so the
    /// nearest tap is the slide's unsheared counterpart: with 10 taps and 1 mm of jitter it
    /// lies about 0.05 mm off, where the `k`-th tap (the pairing before) lay up to 0.5 mm off,
    /// a target no model could meet (regression: `true_pairs_match_the_slide_depth`). Every
    /// slide of the split and subset appears once; poses without taps are skipped.
    pub fn true_pairs(&self, split: Split, subset: Subset) -> Vec<(usize, usize)> {
        let mut by_pose: BTreeMap<usize, (Vec<usize>, Vec<usize>)> = BTreeMap::new();
        for i in self.indices(split, subset, Kind::Tap) {
            by_pose.entry(self.rows[i].pose_id).or_default().0.push(i);
        }
        for i in self.indices(split, subset, Kind::Slide) {
            by_pose.entry(self.rows[i].pose_id).or_default().1.push(i);
        }
        let rows = &self.rows;
        by_pose
            .values()
            .flat_map(|(t, s)| {
                // No tap (an empty `t`): no nearest, the pose's slides are skipped.
                s.iter().filter_map(move |&slide| {
                    let gap = |tap: usize| (rows[tap].pose_z - rows[slide].pose_z).abs();
                    t.iter().copied().min_by(|&a, &b| gap(a).total_cmp(&gap(b))).map(|tap| (tap, slide))
                })
            })
            .collect()
    }

    /// The unpaired training subset re-paired at random for `epoch`: every slide with a tap
    /// drawn without regard to pose from a permutation seeded by `(seed, epoch)`. The same
    /// arguments give the same pairs.
    pub fn epoch_pairs(&self, seed: u64, epoch: u64) -> Vec<(usize, usize)> {
        let mut taps = self.indices(Split::Train, Subset::Unpaired, Kind::Tap);
        let slides = self.indices(Split::Train, Subset::Unpaired, Kind::Slide);
        if taps.is_empty() {
            return Vec::new();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ epoch.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        taps.shuffle(&mut rng);
        slides.iter().enumerate().map(|(k, &s)| (taps[k % taps.len()], s)).collect()
    }

    /// Path of a row's image.
    pub fn image_path(&self, row: &Row) -> PathBuf {
        self.dir.join("images").join(&row.sensor_image)
    }

    /// Loads a row's image: 8-bit grey at the dataset's `image_size`, as `tacsim generate`
    /// writes them (another size or an RGB image is an error naming the file).
    pub fn image(&self, row: &Row) -> Result<GrayImage> {
        self.checked_image(&self.image_path(row))
    }

    /// Loads the undeformed reference image (checked as [`Dataset::image`]).
    pub fn reference(&self) -> Result<GrayImage> {
        self.checked_image(&self.dir.join("images").join(&self.meta.reference_image))
    }

    /// Loads the image at `path`, checked as [`Dataset::image`].
    pub fn checked_image(&self, path: &Path) -> Result<GrayImage> {
        let img = image::open(path).map_err(|e| DataError::format(path, format!("not a readable image: {e}")))?;
        let side = self.meta.image_size;
        if img.color() != image::ColorType::L8 || (img.width(), img.height()) != (side, side) {
            return Err(DataError::format(
                path,
                format!(
                    "is {}x{} {:?}; the images of this dataset are {side}x{side} 8-bit grey (meta.json image_size)",
                    img.width(),
                    img.height(),
                    img.color()
                ),
            ));
        }
        Ok(img.into_luma8())
    }
}
