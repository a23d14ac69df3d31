//! The Python package (`python/`): builds it into a virtual environment with maturin and runs
//! its pytest suite (`python/tests`), so that `cargo test --workspace` covers it.
//!
//! The venv lives in `$HOME/.cache/tacsim/venv` under `CI=true` (as the cargo cache), else in
//! `target/python-venv`; the extension builds into its own target folder beside cargo's (a
//! second cargo may not share the folder of the `cargo test` that runs it). Needs `python3`
//! with `venv` and pip's registry; where either is missing the test says what to install and
//! passes, except under `CI=true`, where it fails. The venv holds the package's extras too
//! (gymnasium for the environments, ray for `tacsim.ray`, stable-baselines3 and torch for a
//! policy trained on them), so no test of the suite skips.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The folder cargo builds into (`target/`, or `CARGO_TARGET_DIR`).
fn cargo_target() -> PathBuf {
    // CARGO_TARGET_TMPDIR is `<target>/tmp`.
    Path::new(env!("CARGO_TARGET_TMPDIR")).parent().map(Path::to_path_buf).unwrap_or_else(|| "target".into())
}

fn venv_dir() -> PathBuf {
    match (std::env::var("CI").as_deref(), std::env::var_os("HOME")) {
        (Ok("true"), Some(home)) => PathBuf::from(home).join(".cache/tacsim/venv"),
        _ => cargo_target().join("python-venv"),
    }
}

/// Runs `cmd`; `Err` with its output where it fails or cannot start.
fn run(cmd: &mut Command) -> Result<String, String> {
    let shown = format!("{cmd:?}");
    let o = cmd.output().map_err(|e| format!("{shown}: cannot start: {e}"))?;
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    if o.status.success() { Ok(text) } else { Err(format!("{shown} failed ({}):\n{text}", o.status)) }
}

/// Missing tools: a failure under CI, else a message and a pass.
fn unavailable(what: &str) {
    let msg = format!(
        "skipping the Python package's tests: {what}\n(install python3 with venv and pip, e.g. Debian's python3-venv, and \
         reach PyPI for maturin, numpy, pytest, gymnasium)"
    );
    assert!(std::env::var("CI").as_deref() != Ok("true"), "{msg}");
    eprintln!("{msg}");
}

#[test]
fn the_python_package_passes_its_pytest_suite() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let venv = venv_dir();
    let python = venv.join("bin/python");
    if !python.is_file()
        && let Err(e) = run(Command::new("python3").args(["-m", "venv"]).arg(&venv))
    {
        return unavailable(&e);
    }
    let pip = run(Command::new(&python).args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
        "maturin>=1.9,<2",
        "numpy",
        "pytest",
        "gymnasium>=1,<2",
        "ray>=2.9",
        // A policy trained on the environments (python/tests/test_sb3.py). PyPI's torch is
        // its CUDA build: about 5 GB with its libraries, 1 minute to install here, once.
        "stable-baselines3>=2.3,<3",
        "torch>=2.3",
    ]));
    if let Err(e) = pip {
        return unavailable(&e);
    }
    // With the package's extras, as `pip install './python[ray,rl]'` installs them (their
    // packages are there from the line above: this checks the extras' names and pins).
    run(Command::new(venv.join("bin/maturin"))
        .args(["develop", "--quiet", "--extras", "ray,rl", "-m"])
        .arg(root.join("python/Cargo.toml"))
        .env("VIRTUAL_ENV", &venv)
        .env("CARGO_TARGET_DIR", cargo_target().join("python")))
    .unwrap_or_else(|e| panic!("building the Python package: {e}"));
    let out = run(Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(root.join("python/tests"))
        .env("TACSIM_BIN", env!("CARGO_BIN_EXE_tacsim")))
    .unwrap_or_else(|e| panic!("pytest: {e}"));
    // The suite's summary, for the test log.
    eprintln!("{}", out.lines().last().unwrap_or_default());
    assert!(!out.contains(" skipped"), "no test may skip here (TACSIM_BIN is set):\n{out}");
}
