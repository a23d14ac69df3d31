//! Saving and loading weights and training state.
//!
//! Weights are safetensors files (burn's `SafetensorsStore`), readable from Python. A run
//! directory holds:
//!
//! - `config.json`: the resolved config; a resumed run must have the same one;
//! - `checkpoint/`: `model.safetensors`, `optimizer.bpk` (Adam's moments, burn's pack
//!   format) and `state.json` (phase, epoch, next batch, loss history), replaced as a whole;
//! - `model.safetensors`: the final weights, written when training ends.
//!
//! Every file is written to a temporary name and renamed; a new checkpoint directory is
//! renamed into place only when complete, so an interrupted save leaves the previous one.
//! Parameter ids are made canonical (numbered in module order) so that optimizer state, keyed
//! by id, finds its parameters again after a reload.

use std::fs;
use std::path::{Path, PathBuf};

use burn::module::{Module, ModuleMapper, Param, ParamId};
use burn::optim::ModuleOptimizer;
use burn::store::{ModuleSnapshot, SafetensorsStore};
use burn::tensor::Tensor;
use serde::Serialize;
use serde::de::DeserializeOwned;

use tacsim_data::temp_path;

use crate::error::{ModelError, Result};

/// Renumbers the module's parameter ids 0, 1, 2, ... in visiting order.
pub fn canonical_ids<M: Module>(module: M) -> M {
    struct Renumber(u64);
    impl ModuleMapper for Renumber {
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let (_, value, mapper) = param.consume();
            let id = ParamId::from(self.0);
            self.0 += 1;
            Param::from_mapped_value(id, value, mapper)
        }
    }
    module.map(&mut Renumber(0))
}

/// Writes `bytes` to `path` atomically (`tacsim_data::write_atomic`: temporary file, fsync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(tacsim_data::write_atomic(path, bytes)?)
}

/// Writes a value as pretty JSON, atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let bytes = serde_json::to_vec_pretty(value).map_err(|e| ModelError::checkpoint(path, e.to_string()))?;
    write_atomic(path, &bytes)
}

/// Reads a JSON value, naming the file on error.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let bytes = fs::read(path).map_err(|e| ModelError::io(path, "read", e))?;
    serde_json::from_slice(&bytes)
        .map_err(|e| ModelError::checkpoint(path, format!("not a valid file of this kind: {e}")))
}

/// Saves a module's weights as safetensors, atomically.
///
/// Batch-norm running statistics are synchronised first: burn keeps their newest update in a
/// per-thread buffer that `valid()` folds in but saving does not, so without this the file
/// would hold statistics one step old (the regression test
/// `unshear_model_losses_fall_in_both_phases_and_checkpoints_reload_to_identical_outputs`).
/// The header's keys are then sorted ([`canonical_safetensors`]), so equal weights give
/// equal bytes.
pub fn save_weights<M: Module>(module: &M, path: &Path) -> Result<()> {
    let _ = module.valid();
    let tmp = temp_path(path);
    let mut store = SafetensorsStore::from_file(&tmp).overwrite(true);
    module.save_into(&mut store).map_err(|e| ModelError::checkpoint(&tmp, format!("could not save weights: {e}")))?;
    let bytes = fs::read(&tmp).map_err(|e| ModelError::io(&tmp, "read", e))?;
    let _ = fs::remove_file(&tmp);
    write_atomic(path, &canonical_safetensors(&bytes).map_err(|e| ModelError::checkpoint(path, e))?)
}

/// A safetensors file with its JSON header's keys sorted and the header padded with spaces
/// to a multiple of 8 bytes. burn writes the `__metadata__` entries in hash-map order, which
/// changes from process to process, so two runs with equal weights wrote different bytes.
/// Tensor offsets count from the end of the header, so the data is copied unchanged.
pub fn canonical_safetensors(bytes: &[u8]) -> std::result::Result<Vec<u8>, String> {
    let len_bytes: [u8; 8] =
        bytes.get(..8).and_then(|b| b.try_into().ok()).ok_or("not safetensors: shorter than its header length")?;
    let len = usize::try_from(u64::from_le_bytes(len_bytes)).map_err(|_| "header length out of range")?;
    let end = 8usize.checked_add(len).filter(|&e| e <= bytes.len()).ok_or("not safetensors: header past the end")?;
    // serde_json's map is ordered by key (no `preserve_order`), so re-serialising sorts.
    let header: serde_json::Value =
        serde_json::from_slice(&bytes[8..end]).map_err(|e| format!("not safetensors: header is not JSON: {e}"))?;
    let mut text = serde_json::to_vec(&header).map_err(|e| e.to_string())?;
    text.resize(text.len().div_ceil(8) * 8, b' ');
    let mut out = Vec::with_capacity(8 + text.len() + bytes.len() - end);
    out.extend_from_slice(&(text.len() as u64).to_le_bytes());
    out.extend_from_slice(&text);
    out.extend_from_slice(&bytes[end..]);
    Ok(out)
}

/// Loads safetensors weights into `module`; every tensor must be present and of the right
/// shape.
pub fn load_weights<M: Module>(mut module: M, path: &Path) -> Result<M> {
    if !path.is_file() {
        return Err(ModelError::checkpoint(
            path,
            "no such weights file: train first, or give the run directory that holds it",
        ));
    }
    let mut store = SafetensorsStore::from_file(path);
    let result = module.load_from(&mut store).map_err(|e| {
        let text = e.to_string();
        let reason = if text.contains("ShapeMismatch") || text.contains("Missing") {
            "weights do not fit this network: was it trained at another image size or for another network?".to_string()
        } else {
            format!("not a readable safetensors file: {text}")
        };
        ModelError::checkpoint(path, reason)
    })?;
    if !result.missing.is_empty() || !result.errors.is_empty() {
        let missing: Vec<&str> = result.missing.iter().map(|(p, _)| p.as_str()).collect();
        return Err(ModelError::checkpoint(
            path,
            format!(
                "weights do not fit this network (missing {:?}, errors {:?}): was it trained at another image size or for another network?",
                missing,
                result.errors.iter().map(|e| e.to_string()).collect::<Vec<_>>()
            ),
        ));
    }
    Ok(canonical_ids(module))
}

/// The files of a run directory.
#[derive(Clone, Debug)]
pub struct RunDir {
    /// The directory.
    pub dir: PathBuf,
}

impl RunDir {
    /// A run directory at `dir` (created if missing).
    pub fn create(dir: &Path) -> Result<Self> {
        fs::create_dir_all(dir).map_err(|e| ModelError::io(dir, "create", e))?;
        Ok(Self { dir: dir.to_owned() })
    }

    /// `config.json`.
    pub fn config(&self) -> PathBuf {
        self.dir.join("config.json")
    }

    /// The final weights.
    pub fn weights(&self) -> PathBuf {
        self.dir.join("model.safetensors")
    }

    /// The current checkpoint directory.
    pub fn checkpoint(&self) -> PathBuf {
        self.dir.join("checkpoint")
    }

    /// Saves a checkpoint: weights, optimizer and state, replacing the previous one only once
    /// the new one is complete.
    pub fn save_checkpoint<M: Module, S: Serialize>(
        &self,
        module: &M,
        optim: &ModuleOptimizer,
        state: &S,
    ) -> Result<()> {
        let new = self.dir.join("checkpoint.new");
        let old = self.dir.join("checkpoint.old");
        let _ = fs::remove_dir_all(&new);
        fs::create_dir_all(&new).map_err(|e| ModelError::io(&new, "create", e))?;
        save_weights(module, &new.join("model.safetensors"))?;
        let opt = new.join("optimizer.bpk");
        optim.save(&opt).map_err(|e| ModelError::checkpoint(&opt, format!("could not save optimizer state: {e}")))?;
        write_json(&new.join("state.json"), state)?;
        let current = self.checkpoint();
        let _ = fs::remove_dir_all(&old);
        if current.exists() {
            fs::rename(&current, &old).map_err(|e| ModelError::io(&current, "move aside", e))?;
        }
        fs::rename(&new, &current).map_err(|e| ModelError::io(&current, "rename into place", e))?;
        let _ = fs::remove_dir_all(&old);
        Ok(())
    }

    /// The newest complete checkpoint directory, if any (the current one, or the previous one
    /// when a save was interrupted between its renames).
    pub fn latest_checkpoint(&self) -> Option<PathBuf> {
        [self.checkpoint(), self.dir.join("checkpoint.old")].into_iter().find(|d| d.join("state.json").is_file())
    }

    /// Loads a checkpoint into `module` and `optim`, returning the state.
    pub fn load_checkpoint<M: Module, S: DeserializeOwned>(
        dir: &Path,
        module: M,
        optim: ModuleOptimizer,
    ) -> Result<(M, ModuleOptimizer, S)> {
        let module = load_weights(module, &dir.join("model.safetensors"))?;
        let opt = dir.join("optimizer.bpk");
        let optim = optim
            .load(&opt)
            .map_err(|e| ModelError::checkpoint(&opt, format!("not a readable optimizer state: {e}")))?;
        let state = read_json(&dir.join("state.json"))?;
        Ok((module, optim, state))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(header: &str, data: &[u8]) -> Vec<u8> {
        let mut v = (header.len() as u64).to_le_bytes().to_vec();
        v.extend_from_slice(header.as_bytes());
        v.extend_from_slice(data);
        v
    }

    /// burn wrote `__metadata__` in hash-map order, so equal weights saved by two processes
    /// differed in their bytes.
    #[test]
    fn weights_with_metadata_in_another_order_gave_other_bytes() {
        let t = r#""w":{"dtype":"F32","shape":[2],"data_offsets":[0,8]}"#;
        let a = file(&format!(r#"{{"__metadata__":{{"version":"1","format":"pt"}},{t}}}"#), &[1, 2, 3, 4, 5, 6, 7, 8]);
        let b =
            file(&format!(r#"{{{t},"__metadata__":{{"format":"pt","version":"1"}}}}  "#), &[1, 2, 3, 4, 5, 6, 7, 8]);
        let (ca, cb) = (canonical_safetensors(&a).expect("a"), canonical_safetensors(&b).expect("b"));
        assert_eq!(ca, cb);
        let len = u64::from_le_bytes(ca[..8].try_into().expect("8 bytes")) as usize;
        assert_eq!(len % 8, 0);
        assert_eq!(&ca[8 + len..], &[1, 2, 3, 4, 5, 6, 7, 8]);
        let header: serde_json::Value = serde_json::from_slice(&ca[8..8 + len]).expect("header");
        assert_eq!(header["w"]["data_offsets"], serde_json::json!([0, 8]));
        assert!(canonical_safetensors(&[1, 2]).is_err());
        assert!(canonical_safetensors(&file("{not json", &[])).is_err());
        let mut long = file("{}", &[]);
        long[..8].copy_from_slice(&1000u64.to_le_bytes());
        assert!(canonical_safetensors(&long).expect_err("too long").contains("past the end"));
    }
}
