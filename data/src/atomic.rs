//! Atomic file writes, shared by the simulator (images, datasets, reports) and the learning
//! crate (checkpoints, reports): data goes to a temporary file in the target's directory, is flushed to
//! disk, then renamed over the target. A reader never sees a half-written file, and a failed
//! write (disk full, permission denied) leaves the previous file untouched.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{DataError, Result};

/// Writes `bytes` to `path` atomically (temp file + fsync + rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, bytes, true)
}

/// [`write_atomic`] without the fsync, for bulk files that a rerun regenerates (dataset
/// images): a killed process never leaves a partial file, but after a power loss a file may be
/// empty, which `tacsim generate --resume` detects and rewrites.
pub fn write_atomic_unsynced(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, bytes, false)
}

fn write_atomic_with(path: &Path, bytes: &[u8], sync: bool) -> Result<()> {
    let tmp = temp_path(path);
    let result = (|| {
        let mut file = std::fs::File::create(&tmp).map_err(|e| DataError::io(&tmp, "create", e))?;
        file.write_all(bytes).map_err(|e| DataError::io(&tmp, "write", e))?;
        if sync {
            file.sync_all().map_err(|e| DataError::io(&tmp, "flush", e))?;
        }
        std::fs::rename(&tmp, path).map_err(|e| DataError::io(path, "rename into place", e))
    })();
    if result.is_err() {
        // Best effort: nothing half-written may stay behind.
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Whether `name` is a temporary file left by an interrupted [`write_atomic`].
pub fn is_temp_name(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(".tmp")
}

/// The temporary sibling used by [`write_atomic`] (and by writers that must hand a path to a
/// library, then rename): `.NAME.PID.tmp` in the same directory, so
/// the final rename never crosses file systems.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_keeps_old_file_and_leaves_no_temp() {
        let dir = std::env::temp_dir().join(format!("tacsim-data-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let target = dir.join("a.txt");
        write_atomic(&target, b"old").expect("first write");
        // Writing into a directory that does not exist fails and must not touch `target`.
        let bad = dir.join("missing").join("a.txt");
        assert!(write_atomic(&bad, b"new").is_err());
        assert_eq!(std::fs::read(&target).expect("read"), b"old");
        write_atomic(&target, b"new").expect("second write");
        assert_eq!(std::fs::read(&target).expect("read"), b"new");
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .expect("list")
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
