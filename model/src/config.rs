//! Every training hyperparameter, with the paper's values as defaults (Methods, "Training
//! Details"). Where the paper gives no value the default is ours and says so.
//!
//! Configs are plain serde structs: a run directory keeps its resolved config as
//! `config.json`, and the command line overrides single fields.

use serde::{Deserialize, Serialize};

use crate::error::{ModelError, Result};
use crate::network::Size;
use tacsim_data::Column;

/// Which training the unshear model gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// The paper's semi-supervised model: the self-supervised phase on the unpaired subset,
    /// then the supervised phase on `label_fraction` of the training poses.
    SemiSupervised,
    /// The self-supervised phase alone (the paper's "no supervision" figure).
    SelfSupervised,
    /// The fully supervised baseline: the supervised phase alone on every training pair.
    Baseline,
}

/// Hyperparameters of the shear-removal model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UnshearConfig {
    /// Which training (default semi-supervised).
    pub mode: Mode,
    /// Image side (px): 256 (paper), 128, 64 or 32.
    pub size: usize,
    /// Batch size (paper: 32).
    pub batch: usize,
    /// Epochs of the self-supervised phase (paper: 50). 0 with `--init` from a
    /// self-supervised run continues that run with the supervised phase (how a study shares
    /// one self-supervised phase among its label fractions).
    pub self_supervised_epochs: usize,
    /// Epochs of the supervised phase (paper: 50).
    pub supervised_epochs: usize,
    /// At most this many batches per epoch (0: all). For CPU-scale runs on a subset; the
    /// epoch's batches are still drawn from the whole subset.
    pub max_batches_per_epoch: usize,
    /// Learning rate of the self-supervised phase (paper: 5e-5).
    pub lr_self_supervised: f64,
    /// Learning rate of the supervised phase (paper: 2.5e-5).
    pub lr_supervised: f64,
    /// Factor applied to the supervised learning rate after half its epochs (paper: 0.1).
    pub lr_step_factor: f64,
    /// Adam beta1 (paper: 0.5).
    pub beta1: f64,
    /// Adam beta2 (paper: 0.999).
    pub beta2: f64,
    /// Adam epsilon (TensorFlow's default 1e-7, the paper's framework).
    pub epsilon: f64,
    /// Weight of the L1 patch loss (paper: lambda = 0.1); 0 disables it (ablation).
    pub patch_weight: f64,
    /// Random crops per image for the patch loss (paper: 100).
    pub patch_count: usize,
    /// Crop side at 256 px (paper: 20); scaled with the image side (10 px at 128).
    pub patch_px_at_256: usize,
    /// Largest random image shift, as a fraction of the side (paper: shifts of 1-2%).
    pub shift_fraction: f64,
    /// Whether the supervised phase shifts the target `U_GT` with its input `S_inp` (the
    /// paper does not say; default no). Sliding moves every pin by 1-2.5 px at 128 px (the
    /// global shear), so a target shifted with its input puts the target's pin lattice
    /// where the network cannot tell the shift from the shear, and `U_rec` blurs: in the
    /// quick study the baseline's SSIM(U_rec, U_GT) was 44% with shifted targets, 75% with
    /// the targets in place (78% without any shift). The self-supervised phase compares each image with its own reconstruction,
    /// so it always shifts both.
    pub shift_targets: bool,
    /// L1 weight penalty per unit |w| on every conv and linear weight (the paper uses L1/L2
    /// regularisation without values; ours).
    pub l1: f64,
    /// L2 weight penalty per unit w^2 (ours, as `l1`).
    pub l2: f64,
    /// Weight of the adversarial term in the self-supervised phase (not in the paper, which
    /// has no such term: default 0, off). Above 0 the model gets a critic that tells tap
    /// images from `M`'s output (`objective.rs`).
    pub adversarial_weight: f64,
    /// Fraction of the training poses whose true pairs the supervised phase uses (paper:
    /// 0.1). The dataset's paired subset must hold at least that many poses; a smaller
    /// fraction takes the first poses of that subset (the label-fraction sweep).
    pub label_fraction: f64,
    /// Seed of batch order, shifts and crops (weights are initialised from it too).
    pub seed: u64,
    /// Save a checkpoint every this many steps (and at every epoch's end).
    pub checkpoint_steps: usize,
}

impl Default for UnshearConfig {
    fn default() -> Self {
        Self {
            mode: Mode::SemiSupervised,
            size: 256,
            batch: 32,
            self_supervised_epochs: 50,
            supervised_epochs: 50,
            max_batches_per_epoch: 0,
            lr_self_supervised: 5e-5,
            lr_supervised: 2.5e-5,
            lr_step_factor: 0.1,
            beta1: 0.5,
            beta2: 0.999,
            epsilon: 1e-7,
            patch_weight: 0.1,
            patch_count: 100,
            patch_px_at_256: 20,
            shift_fraction: 0.02,
            shift_targets: false,
            l1: 1e-7,
            l2: 1e-6,
            adversarial_weight: 0.0,
            label_fraction: 0.1,
            seed: 0,
            checkpoint_steps: 200,
        }
    }
}

impl UnshearConfig {
    /// The network size.
    pub fn net_size(&self) -> Result<Size> {
        size_of(self.size)
    }

    /// Crop side of the patch loss at this image size (px, at least 4).
    pub fn patch_px(&self) -> usize {
        (self.patch_px_at_256 * self.size / 256).max(4)
    }

    /// Whether training adds the adversarial term's critic: a self-supervised phase with
    /// `adversarial_weight` above 0.
    pub fn uses_critic(&self) -> bool {
        self.adversarial_weight > 0.0 && self.self_supervised_epochs > 0 && self.mode != Mode::Baseline
    }

    /// Largest shift (px).
    pub fn max_shift_px(&self) -> i32 {
        (self.shift_fraction * self.size as f64).round() as i32
    }

    /// Checks every field, naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.net_size()?;
        counts(&[
            ("batch", self.batch, 1, MAX_BATCH),
            ("self_supervised_epochs", self.self_supervised_epochs, 0, MAX_EPOCHS),
            ("supervised_epochs", self.supervised_epochs, 0, MAX_EPOCHS),
            ("max_batches_per_epoch", self.max_batches_per_epoch, 0, MAX_BATCHES_PER_EPOCH),
            ("patch_count", self.patch_count, 0, 10_000),
            ("patch_px_at_256", self.patch_px_at_256, 1, 256),
            ("checkpoint_steps", self.checkpoint_steps, 1, 1_000_000),
        ])?;
        for (field, v) in [("lr_self_supervised", self.lr_self_supervised), ("lr_supervised", self.lr_supervised)] {
            learning_rate(field, v)?;
        }
        for (field, v) in [("lr_step_factor", self.lr_step_factor), ("epsilon", self.epsilon)] {
            positive(field, v)?;
        }
        for (field, v) in [("beta1", self.beta1), ("beta2", self.beta2), ("label_fraction", self.label_fraction)] {
            in_range(field, v, 0.0, 1.0)?;
        }
        for (field, v) in [
            ("patch_weight", self.patch_weight),
            ("l1", self.l1),
            ("l2", self.l2),
            ("adversarial_weight", self.adversarial_weight),
        ] {
            in_range(field, v, 0.0, f64::MAX)?;
        }
        in_range("shift_fraction", self.shift_fraction, 0.0, 0.25)?;
        if self.patch_px() > self.size {
            return Err(ModelError::config("patch_px_at_256", "the crop is larger than the image"));
        }
        if self.mode != Mode::SemiSupervised && self.mode != Mode::Baseline && self.self_supervised_epochs == 0 {
            return Err(ModelError::config(
                "self_supervised_epochs",
                "the self-supervised mode needs at least one epoch",
            ));
        }
        Ok(())
    }
}

/// Hyperparameters of the pose network (the paper's PoseNet is from its earlier supervised
/// work, which gives no training details here; the values are ours).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseConfig {
    /// Image side (px): 256, 128, 64 or 32.
    pub size: usize,
    /// Batch size.
    pub batch: usize,
    /// Epochs over the training taps.
    pub epochs: usize,
    /// At most this many batches per epoch (0: all).
    pub max_batches_per_epoch: usize,
    /// Adam learning rate.
    pub lr: f64,
    /// Factor applied to the learning rate after half the epochs.
    pub lr_step_factor: f64,
    /// Largest random image shift, as a fraction of the side.
    pub shift_fraction: f64,
    /// Hidden units of the regression head.
    pub hidden: usize,
    /// The `targets.csv` columns the network reads (default `pose_x`, `pose_y`, `pose_Rz`,
    /// the paper's PoseNet); with a slide offset (`shear_*`) it learns from the slides.
    pub labels: Vec<Column>,
    /// Weight of y (`pose_y`) in the loss, relative to x and yaw (1). The paper's PoseNet regresses the
    /// lateral position across the edge and yaw only; with edge-frame labels y runs along
    /// the edge, which a locally straight edge does not reveal, and 0 stops the network
    /// from memorising it per training pose (y is then still output, but untrained).
    pub y_weight: f64,
    /// L2 weight penalty per unit w^2 on every conv and linear weight (ours; 0: none).
    pub l2: f64,
    /// Seed.
    pub seed: u64,
    /// Save a checkpoint every this many steps (and at every epoch's end).
    pub checkpoint_steps: usize,
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            size: 256,
            batch: 32,
            epochs: 50,
            max_batches_per_epoch: 0,
            lr: 1e-3,
            lr_step_factor: 0.1,
            shift_fraction: 0.0,
            hidden: 128,
            labels: vec![Column::PoseX, Column::PoseY, Column::PoseRz],
            y_weight: 1.0,
            l2: 0.0,
            seed: 0,
            checkpoint_steps: 200,
        }
    }
}

impl PoseConfig {
    /// The network size.
    pub fn net_size(&self) -> Result<Size> {
        size_of(self.size)
    }

    /// Largest shift (px).
    pub fn max_shift_px(&self) -> i32 {
        (self.shift_fraction * self.size as f64).round() as i32
    }

    /// Checks every field, naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.net_size()?;
        counts(&[
            ("batch", self.batch, 1, MAX_BATCH),
            ("epochs", self.epochs, 1, MAX_EPOCHS),
            ("max_batches_per_epoch", self.max_batches_per_epoch, 0, MAX_BATCHES_PER_EPOCH),
            ("hidden", self.hidden, 1, 65_536),
        ])?;
        if self.labels.is_empty() {
            return Err(ModelError::config("labels", "is empty: name at least one targets.csv column, such as pose_x"));
        }
        if let Some(c) = self.labels.iter().enumerate().find(|(i, c)| self.labels[..*i].contains(c)).map(|(_, c)| c) {
            return Err(ModelError::config("labels", format!("names {c} twice")));
        }
        learning_rate("lr", self.lr)?;
        positive("lr_step_factor", self.lr_step_factor)?;
        in_range("shift_fraction", self.shift_fraction, 0.0, 0.25)?;
        in_range("y_weight", self.y_weight, 0.0, 1e3)?;
        in_range("l2", self.l2, 0.0, 1.0)
    }
}

/// The network size for a side in px.
pub fn size_of(px: usize) -> Result<Size> {
    match px {
        256 => Ok(Size::S256),
        128 => Ok(Size::S128),
        64 => Ok(Size::S64),
        32 => Ok(Size::S32),
        _ => Err(ModelError::config("size", format!("{px} px is not a network size: use 256, 128, 64 or 32"))),
    }
}

fn positive(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ModelError::config(field, format!("{v} must be a positive number")))
    }
}

/// The largest batch, epochs (each phase) and batches per epoch a training takes: far beyond
/// any run that ends, small enough that nothing sized by them fails to allocate (regression,
/// issue 88: `--epochs 1000000000000` aborted on an 8 TB allocation; `--batch 100000000` ran
/// on with nothing written).
pub const MAX_BATCH: usize = 4096;
/// See [`MAX_BATCH`].
pub const MAX_EPOCHS: usize = 100_000;
/// See [`MAX_BATCH`].
pub const MAX_BATCHES_PER_EPOCH: usize = 10_000_000;

/// The largest learning rate (a larger one diverges at once; `--lr-scale 1e300` ran on).
pub const MAX_LEARNING_RATE: f64 = 1.0;

/// Each `(field, value, least, most)`: an integer count in `[least, most]`.
fn counts(fields: &[(&str, usize, usize, usize)]) -> Result<()> {
    for &(field, v, least, most) in fields {
        if !(least..=most).contains(&v) {
            return Err(ModelError::config(field, format!("{v} must lie in [{least}, {most}]")));
        }
    }
    Ok(())
}

/// A learning rate in `(0, MAX_LEARNING_RATE]`.
fn learning_rate(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 && v <= MAX_LEARNING_RATE {
        Ok(())
    } else {
        Err(ModelError::config(field, format!("{v:e} must lie in (0, {MAX_LEARNING_RATE}] (after --lr-scale)")))
    }
}

fn in_range(field: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ModelError::config(field, format!("{v} must lie in [{lo}, {hi}]")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_and_bad_values_name_their_field() {
        let c = UnshearConfig::default();
        assert_eq!((c.batch, c.self_supervised_epochs, c.supervised_epochs), (32, 50, 50));
        assert_eq!((c.lr_self_supervised, c.lr_supervised, c.beta1), (5e-5, 2.5e-5, 0.5));
        assert_eq!((c.patch_count, c.patch_px(), c.patch_weight), (100, 20, 0.1));
        assert_eq!(UnshearConfig { size: 128, ..c.clone() }.patch_px(), 10);
        c.validate().expect("defaults valid");
        let err = UnshearConfig { beta1: f64::NAN, ..c.clone() }.validate().expect_err("nan");
        assert!(err.to_string().starts_with("beta1"), "{err}");
        let err = UnshearConfig { size: 100, ..c }.validate().expect_err("size");
        assert!(err.to_string().contains("256, 128, 64 or 32"), "{err}");
        let err = serde_json::from_str::<UnshearConfig>(r#"{"bach": 3}"#).expect_err("unknown");
        assert!(err.to_string().contains("bach"), "{err}");
        let p = PoseConfig::default();
        p.validate().expect("pose defaults valid");
        for (bad, field) in
            [(PoseConfig { y_weight: -1.0, ..p.clone() }, "y_weight"), (PoseConfig { l2: f64::NAN, ..p }, "l2")]
        {
            let err = bad.validate().expect_err(field);
            assert!(err.to_string().starts_with(field), "{err}");
        }
    }
}
