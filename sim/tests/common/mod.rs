//! Helpers shared by the integration tests.

use std::path::PathBuf;

/// `rel` under the shared data folder (`TACSIM_SHARED`, default `../shared` next to the
/// repository), or `None` after printing why the test skips.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let root = std::env::var_os("TACSIM_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared"));
    let path = root.join(rel);
    if path.exists() {
        Some(path)
    } else {
        println!("SKIPPED: {} not found (set TACSIM_SHARED to the shared/ folder)", path.display());
        None
    }
}
