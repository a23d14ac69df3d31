//! `meta.json`: everything needed to regenerate a dataset bit for bit.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{DataError, Result};

/// The samples a shard holds: indices `start..end` of the full plan (image `N` is sample
/// `N - 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Shard number, from 0.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
    /// First sample index.
    pub start: usize,
    /// One past the last sample index.
    pub end: usize,
}

/// The frame a dataset's pose labels (and its slides' touch-down offsets) are given in: the
/// recipe's `poses.frame`, written by the generator and read by the evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PoseFrame {
    /// Offsets along the scene's axes from the contact location; yaw from the scene's `x`.
    #[default]
    Scene,
    /// The edge frame at the contact point (the pose's own point on the contour): `x` along
    /// the edge's outward normal (positive off the material), `y` along its tangent (material
    /// on the left), yaw of the sensor's `x` axis from the tangent. This is the pose relative
    /// to the edge that contour following servoes on: lateral offset `x` and edge angle
    /// `-yaw` (`tacsim run`'s `EdgeEstimate`).
    Edge,
}

/// The description of a dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Meta {
    /// Format version of the directory layout (1).
    pub format: u32,
    /// Tool and version that wrote it, e.g. `tacsim 0.1.0`.
    pub tool: String,
    /// The seed.
    pub seed: u64,
    /// Image side (px).
    pub image_size: u32,
    /// Samples of the full dataset (taps + slides).
    pub samples: usize,
    /// Taps of the full dataset.
    pub taps: usize,
    /// Slides of the full dataset.
    pub slides: usize,
    /// The undeformed reference image under `images/`.
    pub reference_image: String,
    /// The recipe, every field resolved.
    pub recipe: serde_json::Value,
    /// The sensor, every field resolved.
    pub sensor: serde_json::Value,
    /// Set on a shard; absent on a complete or merged dataset.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<Shard>,
}

impl Meta {
    /// Current format version.
    pub const FORMAT: u32 = 1;

    /// Pretty JSON text (newline-terminated).
    pub fn to_json(&self) -> Result<Vec<u8>> {
        let mut v = serde_json::to_vec_pretty(self).map_err(|e| DataError::format("meta.json", e.to_string()))?;
        v.push(b'\n');
        Ok(v)
    }

    /// Reads `meta.json`.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read(path).map_err(|e| DataError::io(path, "read", e))?;
        let meta: Meta = serde_json::from_slice(&text).map_err(|e| DataError::format(path, e.to_string()))?;
        if meta.format != Self::FORMAT {
            return Err(DataError::format(
                path,
                format!("format {} is not supported (this tool reads {})", meta.format, Self::FORMAT),
            ));
        }
        Ok(meta)
    }

    /// The frame of the pose labels (the recipe's `poses.frame`; `scene` where it says none).
    /// An unknown frame is an error naming the field.
    pub fn pose_frame(&self) -> Result<PoseFrame> {
        match self.recipe.pointer("/poses/frame") {
            None => Ok(PoseFrame::Scene),
            Some(v) => PoseFrame::deserialize(v).map_err(|e| {
                DataError::format("meta.json", format!("recipe.poses.frame = {v}: {e} (accepted: \"scene\", \"edge\")"))
            }),
        }
    }

    /// Whether each pose's contact point was drawn around the shape's whole contour (the
    /// recipe's `poses.around_contour`; `false` where it says none).
    pub fn around_contour(&self) -> bool {
        self.recipe.pointer("/poses/around_contour").and_then(serde_json::Value::as_bool).unwrap_or(false)
    }

    /// The same dataset, whatever the shard: equal but for `shard`.
    pub fn same_dataset(&self, other: &Meta) -> bool {
        Meta { shard: None, ..self.clone() } == Meta { shard: None, ..other.clone() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(recipe: serde_json::Value) -> Meta {
        Meta {
            format: Meta::FORMAT,
            tool: "tacsim test".into(),
            seed: 0,
            image_size: 64,
            samples: 0,
            taps: 0,
            slides: 0,
            reference_image: "image_0.png".into(),
            recipe,
            sensor: serde_json::Value::Null,
            shard: None,
        }
    }

    #[test]
    fn the_pose_frame_is_read_typed_from_the_recipe_and_an_unknown_one_is_named() {
        let edge = meta(serde_json::json!({"poses": {"frame": "edge", "around_contour": true}}));
        assert_eq!(edge.pose_frame().expect("frame"), PoseFrame::Edge);
        assert!(edge.around_contour());
        let bare = meta(serde_json::json!({"poses": {}}));
        assert_eq!(bare.pose_frame().expect("frame"), PoseFrame::Scene);
        assert!(!bare.around_contour());
        let e = meta(serde_json::json!({"poses": {"frame": "robot"}})).pose_frame().expect_err("unknown");
        assert!(e.to_string().contains("poses.frame") && e.to_string().contains("robot"), "{e}");
    }
}
