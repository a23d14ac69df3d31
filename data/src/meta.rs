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

    /// The same dataset, whatever the shard: equal but for `shard`.
    pub fn same_dataset(&self, other: &Meta) -> bool {
        Meta { shard: None, ..self.clone() } == Meta { shard: None, ..other.clone() }
    }
}
