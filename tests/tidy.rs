//! Tidy checks over the source tree: every Rust file starts with a `//!` doc comment saying
//! what it is for (module docs are the map of the house), and no file carries leftover
//! debugging macros.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n != "target") {
                rust_files(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn every_rust_file_has_module_docs() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in
        ["src", "tests", "sim/src", "sim/tests", "sim/benches", "data/src", "model/src", "model/tests", "xtask/src"]
    {
        rust_files(&root.join(dir), &mut files);
    }
    assert!(files.len() > 20, "found only {} files", files.len());
    let mut missing = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).expect("readable");
        if !text.trim_start().starts_with("//!") {
            missing.push(f.strip_prefix(&root).unwrap_or(f).display().to_string());
        }
        if text.contains(&["dbg", "!("].concat()) {
            missing.push(format!("{} (leftover debug macro)", f.display()));
        }
    }
    assert!(missing.is_empty(), "files without a leading //! doc comment: {missing:?}");
}
