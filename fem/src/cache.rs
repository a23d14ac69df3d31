//! The layout every cache file of this crate shares, and its atomic write: a magic line, a
//! little-endian `u64` header length, the JSON header, then the tables as little-endian
//! numbers. Errors name the file and, when reading, say what to do (delete it: it is rebuilt
//! on the next use).

use std::fs;
use std::io::Write;
use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::{FemError, Result};

/// The version of the mesh and the element, part of every cache key: bump it when either
/// changes what a spec builds (2: Kuhn's split reflected into each octant; 3: a pin's rotation
/// the mean over the elements that hold its point).
pub(crate) const MODEL_VERSION: u32 = 3;

/// An error about the cache file `path`.
pub(crate) fn error(path: &Path, message: String) -> FemError {
    FemError::Cache { path: path.display().to_string(), message }
}

/// An error about a cache file that cannot be used, saying how to get a good one.
pub(crate) fn unusable(path: &Path, message: String) -> FemError {
    error(path, format!("{message}; delete the file and it will be rebuilt"))
}

/// Writes `magic`, the header and `body` to `path` atomically (a temporary file beside it,
/// then a rename), creating the folder.
pub(crate) fn write(path: &Path, magic: &[u8], header: &impl Serialize, body: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(|e| error(path, format!("cannot create the cache folder: {e}")))?;
    }
    let header = serde_json::to_vec(header).map_err(|e| error(path, e.to_string()))?;
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    let write = || -> std::io::Result<()> {
        let mut f = fs::File::create(&tmp)?;
        f.write_all(magic)?;
        f.write_all(&(header.len() as u64).to_le_bytes())?;
        f.write_all(&header)?;
        f.write_all(body)?;
        f.sync_all()?;
        fs::rename(&tmp, path)
    };
    write().map_err(|e| {
        let _ = fs::remove_file(&tmp);
        error(path, format!("cannot write the cache: {e}"))
    })
}

/// Reads a file written by [`write`]: its header and the bytes after it.
pub(crate) fn read<H: DeserializeOwned>(path: &Path, magic: &[u8]) -> Result<(H, Vec<u8>)> {
    let bytes = fs::read(path).map_err(|e| unusable(path, format!("cannot read: {e}")))?;
    let truncated = || unusable(path, "truncated header".into());
    let rest = bytes.strip_prefix(magic).ok_or_else(|| unusable(path, "not a tacsim dome cache".into()))?;
    let (len, rest) = rest.split_at_checked(8).ok_or_else(truncated)?;
    let len = u64::from_le_bytes(len.try_into().map_err(|_| truncated())?);
    let (header, data) = rest.split_at_checked(usize::try_from(len).map_err(|_| truncated())?).ok_or_else(truncated)?;
    let header: H = serde_json::from_slice(header).map_err(|e| unusable(path, format!("bad header: {e}")))?;
    Ok((header, data.to_vec()))
}

/// Little-endian bytes of numbers.
pub(crate) fn bytes_of<const N: usize, T: Copy>(values: &[T], le: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|&v| le(v)).collect()
}

/// Numbers from little-endian bytes (the length a multiple of `N`, checked by the caller).
pub(crate) fn values_of<const N: usize, T>(bytes: &[u8], from: impl Fn([u8; N]) -> T) -> Vec<T> {
    bytes.chunks_exact(N).map(|c| from(c.try_into().unwrap_or([0; N]))).collect()
}

/// Refuses a file of another format or made for other inputs.
pub(crate) fn check(path: &Path, format: (u32, u32), key: (&str, u64)) -> Result<()> {
    if format.0 != format.1 {
        return Err(unusable(path, format!("format {} where this build reads {}", format.0, format.1)));
    }
    if key.0 != format!("{:016x}", key.1) {
        return Err(unusable(path, format!("made for inputs {} where {:016x} were asked for", key.0, key.1)));
    }
    Ok(())
}

/// The 64-bit FNV-1a hash of a description of a file's inputs and [`MODEL_VERSION`]: its key.
pub(crate) fn key_of(words: &str) -> u64 {
    format!("model {MODEL_VERSION} {words}")
        .bytes()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

/// Checks that `dir` takes a new file (creating it), so that a long build does not end in a
/// failed write.
pub(crate) fn check_writable(dir: &Path) -> Result<()> {
    let probe = dir.join(format!(".tacsim-write-check-{}", std::process::id()));
    fs::create_dir_all(dir)
        .and_then(|()| fs::write(&probe, b""))
        .and_then(|()| fs::remove_file(&probe))
        .map_err(|e| error(dir, format!("the cache folder is not writable ({e}); set TACSIM_CACHE_DIR to one that is")))
}
