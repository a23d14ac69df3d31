//! The one way the tests find the lab's recordings ([`tacsim_sim::shared_for_test`]): a
//! missing folder skips the test, saying so, and fails it under `CI=true`. Each case runs this
//! test binary again, on the ignored probe below, with the environment it needs.

use std::process::Command;

/// Set in the probe's child process.
const PROBE_ENV: &str = "TACSIM_SHARED_PROBE";

/// Looks for a folder that is not there; run only by the tests below, in a child process.
#[test]
#[ignore = "a probe: run by the other tests of this file with their environment"]
fn probe_a_missing_shared_folder() {
    // Only in the child the tests below start (`--include-ignored` runs it too).
    if std::env::var_os(PROBE_ENV).is_none() {
        return;
    }
    assert!(tacsim_sim::shared_for_test("data/no-such-recording").is_none());
    println!("the probe went on after the skip");
}

/// Runs the probe with `CI` set to `ci` (or unset) and the shared folder somewhere empty.
fn probe(ci: Option<&str>) -> (bool, String) {
    let empty = std::env::temp_dir().join(format!("tacsim-no-shared-{}", std::process::id()));
    let mut cmd = Command::new(std::env::current_exe().expect("the test binary"));
    cmd.args(["--exact", "probe_a_missing_shared_folder", "--ignored", "--nocapture", "--test-threads=1"])
        .env(tacsim_sim::SHARED_ENV, &empty)
        .env(PROBE_ENV, "1");
    match ci {
        Some(v) => cmd.env("CI", v),
        None => cmd.env_remove("CI"),
    };
    let out = cmd.output().expect("the test binary runs");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out.status.success(), text)
}

#[test]
fn a_missing_shared_folder_skips_the_test_and_says_so() {
    let (passed, out) = probe(None);
    assert!(passed, "{out}");
    assert!(
        out.contains("SKIPPED:") && out.contains("data/no-such-recording") && out.contains("TACSIM_SHARED"),
        "{out}"
    );
    assert!(out.contains("the probe went on after the skip"), "{out}");
}

#[test]
fn a_missing_shared_folder_fails_the_test_under_ci() {
    let (passed, out) = probe(Some("true"));
    assert!(!passed, "CI=true passed without the recordings:\n{out}");
    assert!(out.contains("CI=true and the lab's recordings are missing"), "{out}");
    assert!(out.contains("data/no-such-recording"), "{out}");
}
