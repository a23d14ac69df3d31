//! The layout every cache file of this crate shares, and its atomic write: a magic line, a
//! little-endian `u64` header length, the JSON header, then the tables as little-endian
//! numbers. Errors name the file and, when reading, say what to do (delete it: it is rebuilt
//! on the next use).

use std::fs;
use std::io::{Read, Write};
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

/// Opens a file written by [`write`]: its header, and a [`Reader`] of the tables after it.
/// The tables are read straight into the numbers they hold ([`Reader::values`]), not through
/// a copy of the file's bytes: a dome's 228 MB table once, not three times (each a fresh
/// allocation the kernel zeroes page by page).
pub(crate) fn read<H: DeserializeOwned>(path: &Path, magic: &[u8]) -> Result<(H, Reader)> {
    let cannot = |e: std::io::Error| unusable(path, format!("cannot read: {e}"));
    let mut file = fs::File::open(path).map_err(cannot)?;
    let size = file.metadata().map_err(cannot)?.len();
    let truncated = || unusable(path, "truncated header".into());
    let mut start = vec![0; magic.len() + 8];
    file.read_exact(&mut start).map_err(|_| truncated())?;
    let len = start.strip_prefix(magic).ok_or_else(|| unusable(path, "not a tacsim dome cache".into()))?;
    let len = u64::from_le_bytes(len.try_into().map_err(|_| truncated())?);
    let left = (size - start.len() as u64).checked_sub(len).ok_or_else(truncated)?;
    let mut header = vec![0; usize::try_from(len).map_err(|_| truncated())?];
    file.read_exact(&mut header).map_err(|_| truncated())?;
    let header: H = serde_json::from_slice(&header).map_err(|e| unusable(path, format!("bad header: {e}")))?;
    Ok((header, Reader { file, path: path.to_path_buf(), left }))
}

/// The tables of a cache file after its header ([`read`]), read in order.
pub(crate) struct Reader {
    file: fs::File,
    path: std::path::PathBuf,
    left: u64,
}

impl Reader {
    /// Bytes not read yet.
    pub(crate) fn left(&self) -> u64 {
        self.left
    }

    /// The next `n` little-endian numbers.
    pub(crate) fn values<T: Number>(&mut self, n: usize) -> Result<Vec<T>> {
        let mut out = vec![T::zeroed(); n];
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut out);
        self.file.read_exact(bytes).map_err(|e| unusable(&self.path, format!("cannot read the tables: {e}")))?;
        self.left = self.left.saturating_sub(bytes.len() as u64);
        if cfg!(target_endian = "big") {
            out.iter_mut().for_each(|v| *v = T::read_le(*v));
        }
        Ok(out)
    }
}

/// A number a cache file stores, little-endian.
pub(crate) trait Number: bytemuck::Pod {
    /// The number whose little-endian bytes `stored` holds.
    fn read_le(stored: Self) -> Self;
}

impl Number for f64 {
    fn read_le(stored: Self) -> Self {
        f64::from_bits(u64::from_le(stored.to_bits()))
    }
}

impl Number for f32 {
    fn read_le(stored: Self) -> Self {
        f32::from_bits(u32::from_le(stored.to_bits()))
    }
}

impl Number for u32 {
    fn read_le(stored: Self) -> Self {
        u32::from_le(stored)
    }
}

/// Little-endian bytes of numbers.
pub(crate) fn bytes_of<const N: usize, T: Copy>(values: &[T], le: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|&v| le(v)).collect()
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
