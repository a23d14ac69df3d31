//! Per-file SHA-256 checksums of a dataset, so that a changed file is found: `SHA256SUMS` in
//! the dataset folder, in the format of coreutils' `sha256sum` (`HEX  PATH` per line), so
//! `sha256sum -c SHA256SUMS` run in the folder checks it too.
//!
//! The listing holds `meta.json`, `targets.csv`, the reference image, then every sample's
//! image in sample order (paths relative to the folder, `/`-separated). `tacsim generate`
//! writes it when the last image is written; until then each image's line is appended to
//! [`JOURNAL_FILE`] as the image lands, so that `--resume` keeps an image only where its bytes
//! are the ones recorded (a swapped, edited or truncated image is written again) and `merge`
//! and `tacsim verify` check every file against it.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use rayon::prelude::*;
use sha2::{Digest, Sha256};

use crate::atomic::write_atomic;
use crate::error::{DataError, Result};
use crate::loader::Dataset;

/// The checksum listing of a finished dataset.
pub const CHECKSUMS_FILE: &str = "SHA256SUMS";

/// The lines of the images written so far by an unfinished run, in the order they landed.
pub const JOURNAL_FILE: &str = "SHA256SUMS.partial";

/// The SHA-256 of `bytes`, 64 lower-case hex digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    let digest = Sha256::digest(bytes);
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// `sha256sum`'s line for `path` (relative to the dataset folder).
fn line(hex: &str, path: &str) -> String {
    format!("{hex}  {path}\n")
}

/// One line of a listing: `(hex, path)`, `None` where it is not `HEX  PATH`.
fn parse_line(text: &str) -> Option<(String, String)> {
    let (hex, path) = text.split_once("  ")?;
    let hex_ok = hex.len() == 64 && hex.bytes().all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase());
    (hex_ok && !path.is_empty()).then(|| (hex.to_owned(), path.to_owned()))
}

/// Writes the listing `entries` (`(path, hex)`, in the order given) to `dir/SHA256SUMS`
/// atomically.
pub fn write_checksums(dir: &Path, entries: &[(String, String)]) -> Result<()> {
    let text: String = entries.iter().map(|(path, hex)| line(hex, path)).collect();
    write_atomic(&dir.join(CHECKSUMS_FILE), text.as_bytes())
}

/// Reads `dir/SHA256SUMS` strictly: `(path, hex)` in its order; a malformed line or a path
/// listed twice is an error naming the line.
pub fn read_checksums(dir: &Path) -> Result<Vec<(String, String)>> {
    let path = dir.join(CHECKSUMS_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(DataError::Dataset {
                dir: dir.to_owned(),
                reason: format!(
                    "has no {CHECKSUMS_FILE}: the run is unfinished (or was written by a tacsim without checksums); \
                     finish it with the same `tacsim generate` command and --resume"
                ),
            });
        }
        Err(e) => return Err(DataError::io(&path, "read", e)),
    };
    let mut seen = HashMap::new();
    let mut entries = Vec::new();
    for (k, text) in text.lines().enumerate() {
        let Some((hex, name)) = parse_line(text) else {
            return Err(DataError::format(
                &path,
                format!("line {}: {text:?} is not `HEX  PATH` (64 lower-case hex digits, two spaces, a path)", k + 1),
            ));
        };
        if let Some(first) = seen.insert(name.clone(), k + 1) {
            return Err(DataError::format(&path, format!("line {}: {name} is listed already on line {first}", k + 1)));
        }
        entries.push((name, hex));
    }
    Ok(entries)
}

/// The images' checksums an unfinished (or finished) run recorded in `dir`: the listing's and
/// the journal's lines, by path. Lenient: a run killed mid-line leaves a malformed last line,
/// which records nothing (its image is written again).
pub fn recorded_checksums(dir: &Path) -> HashMap<String, String> {
    let mut map = HashMap::new();
    for name in [CHECKSUMS_FILE, JOURNAL_FILE] {
        if let Ok(text) = std::fs::read_to_string(dir.join(name)) {
            map.extend(text.lines().filter_map(parse_line).map(|(hex, path)| (path, hex)));
        }
    }
    map
}

/// The journal an unfinished run appends each image's line to as the image lands
/// ([`JOURNAL_FILE`]).
pub struct Journal {
    path: PathBuf,
    file: Mutex<std::fs::File>,
}

impl Journal {
    /// Opens `dir`'s journal for appending (created where absent).
    pub fn open(dir: &Path) -> Result<Self> {
        let path = dir.join(JOURNAL_FILE);
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(|e| DataError::io(&path, "open for appending", e))?;
        Ok(Self { path, file: Mutex::new(file) })
    }

    /// Records that `path` (relative to the dataset folder) now holds bytes of SHA-256 `hex`:
    /// one whole line in one write.
    pub fn record(&self, path: &str, hex: &str) -> Result<()> {
        let mut file = self.file.lock().unwrap_or_else(|e| e.into_inner());
        file.write_all(line(hex, path).as_bytes()).map_err(|e| DataError::io(&self.path, "append", e))
    }

    /// Removes the journal once the listing holds every line.
    pub fn finish(self) -> Result<()> {
        drop(self.file);
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(DataError::io(&self.path, "remove", e)),
            _ => Ok(()),
        }
    }
}

/// The path of an image in a listing: `images/NAME`.
pub fn image_entry(name: &str) -> String {
    format!("images/{name}")
}

/// The files a dataset's listing must hold, in its order: `meta.json`, `targets.csv`, the
/// reference image, every row's image.
pub fn expected_entries(ds: &Dataset) -> Vec<String> {
    let mut names = vec!["meta.json".to_owned(), "targets.csv".to_owned(), image_entry(&ds.meta.reference_image)];
    names.extend(ds.rows.iter().map(|r| image_entry(&r.sensor_image)));
    names
}

/// What [`verify`] found.
#[derive(Clone, Debug)]
pub struct Verification {
    /// Files checked against the listing.
    pub files: usize,
    /// Every problem, one sentence each naming the file (empty where all is well).
    pub problems: Vec<String>,
}

/// Checks the dataset in `dir` on its own: `meta.json` and `targets.csv` readable, every image
/// present, the listing holding exactly the dataset's files, each file's SHA-256 the listed
/// one, each image decodable 8-bit grey of the dataset's size. A file whose bytes are another
/// file's (a copy over it) is named as such.
pub fn verify(dir: &Path) -> Result<Verification> {
    let ds = Dataset::open(dir)?;
    let listed = read_checksums(dir)?;
    let expected = expected_entries(&ds);
    let mut problems = Vec::new();
    let listed_names: Vec<&str> = listed.iter().map(|(p, _)| p.as_str()).collect();
    if listed_names != expected.iter().map(String::as_str).collect::<Vec<_>>() {
        let missing: Vec<&str> =
            expected.iter().map(String::as_str).filter(|e| !listed_names.contains(e)).take(5).collect();
        let extra: Vec<&str> =
            listed_names.iter().copied().filter(|p| !expected.iter().any(|e| e == p)).take(5).collect();
        problems.push(format!(
            "{CHECKSUMS_FILE} does not list this dataset's files in order (meta.json, targets.csv, the reference, \
             the rows' images){}{}",
            if missing.is_empty() { String::new() } else { format!("; missing: {}", missing.join(", ")) },
            if extra.is_empty() { String::new() } else { format!("; not in the dataset: {}", extra.join(", ")) },
        ));
    }
    let by_hex: HashMap<&str, &str> = listed.iter().map(|(p, h)| (h.as_str(), p.as_str())).collect();
    let found: Vec<Option<String>> = listed
        .par_iter()
        .map(|(name, hex)| {
            let path = dir.join(name);
            let shown = path.display();
            let bytes = match std::fs::read(&path) {
                Ok(b) => b,
                Err(e) => return Some(format!("{shown}: cannot be read: {e}")),
            };
            let png = name.ends_with(".png");
            let got = sha256_hex(&bytes);
            if got != *hex {
                let what = match (by_hex.get(got.as_str()), png.then(|| ds.checked_image(&path)).transpose()) {
                    (Some(other), _) => format!("holds the same bytes as {other} (copied over it)"),
                    (None, Err(DataError::Format { reason, .. })) => format!("is damaged ({reason})"),
                    (None, Err(e)) => format!("is damaged ({e})"),
                    (None, Ok(_)) => "was changed after it was written".to_owned(),
                };
                let fix = if png {
                    "delete it and rerun the same `tacsim generate` command with --resume"
                } else {
                    "rerun the same `tacsim generate` command with --resume (it rewrites meta.json and targets.csv \
                     from the recipe)"
                };
                return Some(format!("{shown}: {what}; its SHA-256 is {got}, {CHECKSUMS_FILE} says {hex}; {fix}"));
            }
            match png.then(|| ds.checked_image(&path)) {
                Some(Err(e)) => Some(e.to_string()),
                _ => None,
            }
        })
        .collect();
    problems.extend(found.into_iter().flatten());
    Ok(Verification { files: listed.len(), problems })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SHA-256 test vectors of FIPS 180-2 (empty and "abc").
    #[test]
    fn sha256_matches_the_standards_vectors() {
        assert_eq!(sha256_hex(b""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
        assert_eq!(sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    }

    #[test]
    fn listing_lines_round_trip_and_malformed_ones_are_named() {
        let dir = std::env::temp_dir().join(format!("tacsim-sums-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("test io");
        let entries =
            vec![("meta.json".to_owned(), sha256_hex(b"m")), ("images/image_1.png".to_owned(), sha256_hex(b"i"))];
        write_checksums(&dir, &entries).expect("test io");
        assert_eq!(read_checksums(&dir).expect("test io"), entries);
        // A journal's torn last line records nothing; whole lines do.
        let journal = Journal::open(&dir).expect("test io");
        journal.record("images/image_2.png", &sha256_hex(b"j")).expect("test io");
        drop(journal);
        let mut f = std::fs::OpenOptions::new().append(true).open(dir.join(JOURNAL_FILE)).expect("test io");
        f.write_all(b"abc123  images/ima").expect("test io");
        let map = recorded_checksums(&dir);
        assert_eq!(map.len(), 3, "{map:?}");
        assert_eq!(map["images/image_2.png"], sha256_hex(b"j"));
        std::fs::write(dir.join(CHECKSUMS_FILE), "zz  meta.json\n").expect("test io");
        let err = read_checksums(&dir).expect_err("an error").to_string();
        assert!(err.contains("line 1") && err.contains("HEX  PATH"), "{err}");
        let twice = format!("{h}  a\n{h}  a\n", h = sha256_hex(b""));
        std::fs::write(dir.join(CHECKSUMS_FILE), twice).expect("test io");
        let err = read_checksums(&dir).expect_err("an error").to_string();
        assert!(err.contains("line 2") && err.contains("line 1"), "{err}");
        std::fs::remove_dir_all(&dir).expect("test io");
    }
}
