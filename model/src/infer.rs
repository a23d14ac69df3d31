//! Inference from trained run directories: load a pose network (and optionally a
//! shear-removal model in front of it) and read poses from single camera images, as a robot's
//! perception does (`tacsim run` with `learned` and `learned-raw` perception).

use std::path::Path;

use burn::module::Module;
use burn::tensor::Device;
use image::GrayImage;

use crate::Backend;
use crate::checkpoint::{load_weights, read_json};
use crate::config::{PoseConfig, UnshearConfig};
use crate::error::{ModelError, Result};
use crate::images::{ImageSet, Preprocess};
use crate::posenet::{Pose, PoseNet, PoseScale, decode_batch};
use crate::unshear::Unshear;

/// Whether `dir` holds a pose network run (it has the label scale `scale.json`).
pub fn is_posenet_run(dir: &Path) -> bool {
    dir.join("scale.json").is_file()
}

/// The weights file of run `dir`; an error when the run has not finished.
pub(crate) fn weights_of(dir: &Path) -> Result<std::path::PathBuf> {
    let weights = dir.join("model.safetensors");
    if !weights.is_file() {
        return Err(ModelError::checkpoint(
            dir,
            "no model.safetensors: the run has not finished (resume it with `tacsim train ... --resume`) or this is not a run directory",
        ));
    }
    Ok(weights)
}

/// A trained pose network in inference mode, its config and its label scale.
pub fn load_posenet(dir: &Path, device: &Device) -> Result<(PoseNet, PoseConfig, PoseScale)> {
    let weights = weights_of(dir)?;
    if !is_posenet_run(dir) {
        return Err(ModelError::checkpoint(dir, "no scale.json: not a pose network run (`tacsim train posenet`)"));
    }
    let cfg: PoseConfig = read_json(&dir.join("config.json"))?;
    let scale: PoseScale = read_json(&dir.join("scale.json"))?;
    let net = load_weights(PoseNet::new(cfg.net_size()?, cfg.hidden, scale.width(), device), &weights)?.valid();
    Ok((net, cfg, scale))
}

/// A trained shear-removal model in inference mode and its config.
pub fn load_unshear(dir: &Path, device: &Device) -> Result<(Unshear, UnshearConfig)> {
    let weights = weights_of(dir)?;
    if is_posenet_run(dir) {
        return Err(ModelError::checkpoint(dir, "a pose network run, not a shear-removal model"));
    }
    let cfg: UnshearConfig = read_json(&dir.join("config.json"))?;
    let model = load_weights(Unshear::new(cfg.net_size()?, device), &weights)?.valid();
    Ok((model, cfg))
}

/// Reads the pose from camera images: resize to the networks' side, optionally remove the
/// shear ([`Unshear::unshear`]), then the pose network. Deterministic.
pub struct PoseReader {
    posenet: PoseNet,
    scale: PoseScale,
    /// The pose network's run directory (for messages).
    posenet_dir: std::path::PathBuf,
    unshear: Option<Unshear>,
    side: usize,
    device: Device,
}

impl PoseReader {
    /// The pose network of run `posenet` behind, when given, the shear-removal model of run
    /// `unshear`; both must be trained at the same side.
    pub fn load(posenet: &Path, unshear: Option<&Path>, backend: Backend) -> Result<Self> {
        let device = backend.device();
        let (net, cfg, scale) = load_posenet(posenet, &device)?;
        let unshear = match unshear {
            Some(dir) => {
                let (model, ucfg) = load_unshear(dir, &device)?;
                if ucfg.size != cfg.size {
                    return Err(ModelError::config(
                        "size",
                        format!(
                            "{} was trained at {} px and {} at {} px: train both at one size",
                            dir.display(),
                            ucfg.size,
                            posenet.display(),
                            cfg.size
                        ),
                    ));
                }
                Some(model)
            }
            None => None,
        };
        Ok(Self { posenet: net, scale, posenet_dir: posenet.to_owned(), unshear, side: cfg.size, device })
    }

    /// The networks' image side (px).
    pub fn side(&self) -> usize {
        self.side
    }

    /// An error unless the pose network reads every label of `needed` (what `use` needs
    /// them for); see [`PoseScale::require`].
    pub fn require(&self, needed: &[crate::posenet::Column], r#use: &str) -> Result<()> {
        self.scale.require(needed, &self.posenet_dir, r#use)
    }

    /// The pose in the frame of the pose network's training labels.
    pub fn read(&self, image: &GrayImage) -> Result<Pose> {
        let img = Preprocess::resize(self.side as u32).apply(image, "camera image")?;
        let set = ImageSet::from_raw(self.side, &[img.into_raw()])?;
        let mut x = set.batch(&[0], &[], &self.device);
        if let Some(u) = &self.unshear {
            x = u.unshear(x);
        }
        decode_batch(&self.scale, self.posenet.forward(x))
            .into_iter()
            .next()
            .ok_or_else(|| ModelError::Insufficient("the pose network returned no output".into()))
    }
}
