//! Where the lab's recordings are found, one way for every test that reads them: the folder
//! `$TACSIM_SHARED`, else `shared/` beside the repository (`../shared` from its root), which
//! holds `data/real-tactip-surface3d/`, `data/real-tactip-edge2d-full/` and the rest. The
//! recordings are never committed; a test that needs them skips, saying so, where they are
//! absent, and fails instead under `CI=true`, where they must be there.

use std::path::PathBuf;

/// The environment variable that points at another `shared/` folder.
pub const SHARED_ENV: &str = "TACSIM_SHARED";

/// The shared folder: `$TACSIM_SHARED`, else `shared/` beside the repository.
pub fn shared_folder() -> PathBuf {
    std::env::var_os(SHARED_ENV)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared"))
}

/// `rel` under the shared folder for a test: `Some(path)` where it exists; where it does not,
/// `None` after printing why the test skips, or, under `CI=true`, a panic naming the path and
/// what to set (a CI run that skipped its real-data tests would pass without checking them).
pub fn shared_for_test(rel: &str) -> Option<PathBuf> {
    let path = shared_folder().join(rel);
    if path.exists() {
        return Some(path);
    }
    let why = format!("{} not found (set {SHARED_ENV} to the shared/ folder)", path.display());
    assert!(std::env::var("CI").as_deref() != Ok("true"), "CI=true and the lab's recordings are missing: {why}");
    println!("SKIPPED: {why}");
    None
}
