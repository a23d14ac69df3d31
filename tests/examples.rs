//! The runnable start runs: `examples/tap.rs` (sensor -> scene -> tap -> image) writes a
//! binarised image of the pins. `cargo test` builds the examples beside the test binaries
//! (`target/<profile>/examples/`); where this one is not built (a run of this test file alone)
//! the test skips, saying so, and fails under `CI=true`.

use std::path::PathBuf;

mod common;

/// The built `tap` example, next to this test's own binary (`target/<profile>/deps/`).
fn tap_example() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?.parent()?.join("examples");
    Some(dir.join(format!("tap{}", std::env::consts::EXE_SUFFIX))).filter(|p| p.is_file())
}

#[test]
fn the_tap_example_writes_a_binarised_image_of_the_pins() {
    let Some(example) = tap_example() else {
        let why = "the `tap` example is not built: run `cargo test` on every target, or `cargo build --example tap`";
        assert!(std::env::var("CI").as_deref() != Ok("true"), "CI=true: {why}");
        println!("SKIPPED: {why}");
        return;
    };
    let dir = common::temp_dir("tacsim-example", "tap");
    let out = dir.join("tap.png");
    let run = std::process::Command::new(&example).arg(&out).output().expect("the example runs");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.contains("cells in contact") && stdout.contains("wrote"), "{stdout}");
    let image = tacsim_sim::read_png(&out).expect("a PNG");
    assert_eq!(image.dimensions(), (256, 256));
    // Binarised: black and white only, both present.
    assert!(image.pixels().all(|p| p.0[0] == 0 || p.0[0] == 255));
    assert!(image.pixels().any(|p| p.0[0] == 255) && image.pixels().any(|p| p.0[0] == 0));
}
