//! Helpers shared by the command-line integration tests: running the `tacsim` binary, fresh
//! temporary folders and reading the JSON reports it writes. Each test binary uses a subset,
//! hence the `dead_code` allowance.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `tacsim` binary with `args`.
pub fn tacsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tacsim")).args(args).output().expect("tacsim runs")
}

/// Runs `tacsim args`, asserts it succeeds, and returns its stdout.
pub fn ok(args: &[&str]) -> String {
    let o = tacsim(args);
    assert!(o.status.success(), "tacsim {args:?} failed: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs `tacsim args`, asserts it fails, and returns its stderr.
pub fn err(args: &[&str]) -> String {
    let o = tacsim(args);
    assert!(!o.status.success(), "tacsim {args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path under the system temp folder for this test run, removed if it exists (not created).
pub fn fresh_path(prefix: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tacsim-{prefix}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// An empty temporary folder for this test run.
pub fn temp_dir(prefix: &str, name: &str) -> PathBuf {
    let dir = fresh_path(prefix, name);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// `p` as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The lab folder `data/<name>` of the shared folder (with its `targets.csv`;
/// [`tacsim_sim::shared_for_test`]), or `None` after printing why the test skips; under
/// `CI=true` a missing folder fails the test.
pub fn lab_folder(name: &str) -> Option<PathBuf> {
    tacsim_sim::shared_for_test(&format!("data/{name}/targets.csv")).and_then(|csv| csv.parent().map(Path::to_path_buf))
}

/// A JSON file the binary wrote (a report, a curve's point), parsed; panics naming the file.
pub fn json_file(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
