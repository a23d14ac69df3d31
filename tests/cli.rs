//! End-to-end tests of the `tacsim` command line, as a user runs it.

use std::path::{Path, PathBuf};

use tacsim_sim::{detect_blobs, read_png};

mod common;
use common::{err, ok, s, tacsim, temp_dir};

fn render_and_count(dir: &Path, file: &str, extra: &[&str]) -> (u32, usize) {
    let out = dir.join(file);
    let mut args = vec!["render", "-o", out.to_str().expect("utf-8 path")];
    args.extend_from_slice(extra);
    let o = tacsim(&args);
    assert!(o.status.success(), "tacsim {args:?} failed: {}", String::from_utf8_lossy(&o.stderr));
    let img = read_png(&out).expect("PNG written");
    assert_eq!(img.width(), img.height());
    assert!(img.as_raw().iter().all(|&p| p == 0 || p == 255), "binary image");
    (img.width(), detect_blobs(&img).len())
}

#[test]
fn render_default_gives_331_separate_blobs_at_256() {
    let dir = temp_dir("cli", "default");
    assert_eq!(render_and_count(&dir, "x.png", &[]), (256, 331));
    assert_eq!(render_and_count(&dir, "x1.png", &["--one-bit"]), (256, 331));
    assert_eq!(render_and_count(&dir, "p127.png", &["--pins", "127"]), (256, 127));
    assert_eq!(render_and_count(&dir, "s128.png", &["--size", "128"]), (128, 331));
    assert_eq!(render_and_count(&dir, "s420.png", &["--size", "420"]), (420, 331));
    // The same command twice gives the same bytes.
    render_and_count(&dir, "again.png", &[]);
    assert_eq!(std::fs::read(dir.join("x.png")).expect("x"), std::fs::read(dir.join("again.png")).expect("again"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_realism_and_grey_modes() {
    let dir = temp_dir("cli", "realism");
    let (size, blobs) = render_and_count(&dir, "r.png", &["--realism", "--seed", "3"]);
    assert_eq!(size, 256);
    assert!(blobs >= 331, "every pin plus threshold specks at the rim: {blobs}");
    let out = dir.join("g.png");
    let o = tacsim(&["render", "--grey", "-o", out.to_str().expect("utf-8")]);
    assert!(o.status.success());
    let grey = read_png(&out).expect("grey PNG");
    assert!(grey.as_raw().iter().any(|&p| p != 0 && p != 255), "grey levels present");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_sensor_files_are_clear_errors_and_leave_no_output() {
    let dir = temp_dir("cli", "bad");
    let out = dir.join("never.png");
    let out_s = out.to_str().expect("utf-8");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[dome]\nouter_radius_mm = -20.0\n").expect("write");
    let o = tacsim(&["render", "--sensor", bad.to_str().expect("utf-8"), "-o", out_s]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("bad.toml") && err.contains("dome.outer_radius_mm"), "{err}");
    assert!(!err.contains("panicked"), "{err}");

    for (text, field) in [
        ("[skin]\nmodel = \"skin-on-gel\"\ngel_poisson = 0.7\n", "skin.gel_poisson"),
        ("[skin]\nbase_depth_mm = 1.0\n", "skin.base_depth_mm"),
        ("[skin]\ngel_youngs_modulus_mpa = nan\n", "skin.gel_youngs_modulus_mpa"),
        ("[skin]\nmodel = \"gel\"\n", "model"),
    ] {
        std::fs::write(&bad, text).expect("write");
        let o = tacsim(&["render", "--sensor", bad.to_str().expect("utf-8"), "-o", out_s]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains("bad.toml") && err.contains(field), "{text}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }

    let o = tacsim(&["render", "--sensor", dir.join("missing.toml").to_str().expect("utf-8"), "-o", out_s]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("missing.toml"), "{err}");

    let o = tacsim(&["render", "--pins", "100", "-o", out_s]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("127"), "suggests valid counts: {err}");

    let o = tacsim(&["render", "--size", "24", "-o", out_s]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("24x24"), "{err}");

    let o = tacsim(&["render", "-o", dir.join("no-dir/x.png").to_str().expect("utf-8")]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("no-dir"));
    assert!(!out.exists(), "failed runs write nothing");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn shapes_lists_the_seven_stimuli() {
    let o = tacsim(&["shapes"]);
    assert!(o.status.success());
    let table = String::from_utf8_lossy(&o.stdout);
    for name in ["disk", "clover", "teardrop", "square", "foil", "spiral-1", "spiral-2"] {
        assert!(table.lines().any(|l| l.starts_with(name)), "{name} missing from\n{table}");
    }
    assert!(table.contains("acrylic") && table.contains("ABS"));
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("shapes");
    let o = tacsim(&["shapes", "--dir", dir.to_str().expect("utf-8")]);
    assert_eq!(String::from_utf8_lossy(&o.stdout), table, "built-in equals shapes/");
}

#[test]
fn embedded_shapes_match_the_shapes_directory() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("shapes");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .expect("shapes/")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut embedded: Vec<String> = tacsim_sim::SHAPE_FILES.iter().map(|(n, _)| (*n).to_owned()).collect();
    embedded.sort();
    assert_eq!(embedded, on_disk, "update sim/src/embedded.rs after adding or removing a shape");
    assert_eq!(tacsim_sim::builtin_catalogue().expect("loads").stimuli.len(), 7);
}

#[test]
fn render_tap_and_slide_on_a_shape() {
    let dir = temp_dir("cli", "contact");
    let (_, blobs) = render_and_count(&dir, "tap.png", &["--shape", "clover", "--pose", "0,0,3,0"]);
    assert_eq!(blobs, 331);
    let (_, blobs) =
        render_and_count(&dir, "slide.png", &["--shape", "clover", "--pose", "0,0,3,0", "--slide-from", "2.5,0"]);
    assert_eq!(blobs, 331);
    render_and_count(&dir, "plain.png", &[]);
    let read = |f: &str| std::fs::read(dir.join(f)).expect("written");
    assert_ne!(read("tap.png"), read("plain.png"), "pressing moves the pins");
    assert_ne!(read("tap.png"), read("slide.png"), "sliding history shows");
    // Same command, same bytes.
    render_and_count(&dir, "slide2.png", &["--shape", "clover", "--pose", "0,0,3,0", "--slide-from", "2.5,0"]);
    assert_eq!(read("slide.png"), read("slide2.png"));
    // Off the stimulus: no contact, the undeformed image.
    let o = tacsim(&[
        "render",
        "--shape",
        "disk",
        "--pose",
        "200,0,2,0",
        "-o",
        dir.join("off.png").to_str().expect("utf-8"),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("no contact"));
    assert_eq!(read("off.png"), read("plain.png"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The `study` recipes once labelled every pose in the edge frame at one contact point, with y
/// offsets of up to 5 mm along the edge (the paper's protocol). The disk (radius 50 mm, centred
/// on the scene origin) shows why its yaw labels were not in the images: a tap turned about the
/// disk's centre by `phi` gives the same image, yet its label yaw at the fixed contact point is
/// `phi` larger (4.5 deg here); in the edge frame at the contact point under the sensor
/// (`around_contour = true`, y = 0, what the recipes use now) the two labels are equal. A tap
/// moved by the same y without turning, which has the fixed-point labels of the first, gives
/// another image.
#[test]
fn disk_taps_turned_about_its_centre_gave_one_image_but_two_yaw_labels() {
    let dir = temp_dir("cli", "disk-symmetry");
    let radius_mm = 51.0; // 1 mm off the material
    let phi = (4.0f64 / radius_mm).asin();
    let render = |file: &str, x: f64, y: f64, yaw: f64| {
        let pose = format!("{x},{y},2,{yaw}");
        render_and_count(&dir, file, &["--shape", "disk", "--size", "128", "--pose", &pose]);
        read_png(&dir.join(file)).expect("written").into_raw()
    };
    let at_contact = render("a.png", radius_mm, 0.0, 10.0);
    let turned = render("c.png", radius_mm * phi.cos(), 4.0, 10.0 + phi.to_degrees());
    let moved = render("b.png", radius_mm, 4.0, 10.0);
    assert_eq!(at_contact, turned, "a tap turned about the disk's centre is the same tap");
    let differ = at_contact.iter().zip(&moved).filter(|(a, b)| a != b).count();
    assert!(differ > 50, "the same fixed-point labels at another place: {differ} px differ");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_on_layered_skins() {
    let dir = temp_dir("cli", "layered");
    // The camera-only sensor fit (1.5 mm skin): with the calibrated half-space preset's 0.66 mm skin a
    // slide on the skin-on-gel model drags neighbouring pins into one blob (320 of 331 at 256 px).
    let camera_fit = concat!(env!("CARGO_MANIFEST_DIR"), "/sim/presets/tactip-331-camera.toml");
    let pose = ["--shape", "disk", "--pose", "0,0,1.5,0", "--slide-from", "2.5,0", "--sensor", camera_fit];
    let mut images = Vec::new();
    for skin in ["half-space", "layer", "skin-on-gel"] {
        let file = format!("{skin}.png");
        let mut args = pose.to_vec();
        args.extend(["--skin", skin]);
        let (_, blobs) = render_and_count(&dir, &file, &args);
        assert_eq!(blobs, 331, "{skin}");
        images.push(std::fs::read(dir.join(&file)).expect("written"));
    }
    assert_ne!(images[0], images[1]);
    assert_ne!(images[1], images[2]);
    let o = tacsim(&["render", "--skin", "gel", "-o", dir.join("x.png").to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("skin-on-gel"), "lists the models: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// What broke (issue 88): `validate --grid 100001` aborted on a 1.9 TB allocation, `bench
/// --samples 18446744073709551615` panicked, `validate --grid 1001` and `generate --threads
/// 100000` ran past a minute with nothing written. Each is now refused as it is parsed,
/// naming the flag and its range.
#[test]
fn absurd_command_line_numbers_are_refused_before_any_work() {
    let dir = temp_dir("cli", "absurd");
    let out = dir.join("data");
    for (args, needle) in [
        (vec!["validate", "--grid", "100001"], "[5, 257]"),
        (vec!["validate", "--grid", "1001"], "[5, 257]"),
        (vec!["bench", "--samples", "18446744073709551615"], "[4, 100000]"),
        (vec!["generate", "quick", "--threads", "100000", "--out", s(&out)], "per core"),
    ] {
        let o = tacsim(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        let flag = args.iter().find(|a| a.starts_with("--")).expect("a flag");
        assert!(!o.status.success() && err.contains(needle) && err.contains(flag), "{args:?}: {err}");
    }
    assert!(!out.exists(), "generate wrote before refusing its threads");
    // Training counts and rates, refused by the config's ranges naming the field (issue 88):
    // an 8 TB allocation aborted the first, the next two ran on with nothing written.
    for (args, needle) in [
        (
            vec!["train", "posenet", "--data", s(&dir), "--out", s(&out), "--epochs", "1000000000000"],
            "epochs: 1000000000000 must lie in [1, 100000]",
        ),
        (
            vec!["train", "posenet", "--data", s(&dir), "--out", s(&out), "--batch", "100000000"],
            "batch: 100000000 must lie in [1, 4096]",
        ),
        (
            vec!["train", "unshear", "--data", s(&dir), "--out", s(&out), "--lr-scale", "1e300"],
            "lr_self_supervised: 5.000000000000001e295 must lie in (0, 1]",
        ),
        (
            vec!["sim2real", "--real", s(&dir), "--out", s(&out), "--epochs", "1000000000000"],
            "epochs: 1000000000000 must lie in [1, 100000]",
        ),
    ] {
        let o = tacsim(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{args:?}: {err}");
    }
    assert!(!out.exists(), "a training wrote before refusing its flags");
    // An output that cannot be written is refused before the benchmark runs (it failed after
    // it, losing the figures): a plot under a file, in /proc, or naming a folder.
    let file = dir.join("a-file");
    std::fs::write(&file, b"").expect("file");
    for plot in [file.join("bench.svg"), PathBuf::from("/proc/tacsim-bench.svg"), dir.clone()] {
        let o = tacsim(&["bench", "--samples", "4", "--plot", s(&plot)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(s(&plot)) && !err.contains("taps/s"), "{plot:?}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run that fails before its work leaves no empty folder behind (issue 88): `sim2real` made
/// `--out` before refusing its `--report`, `calibrate` made `NAME-report/` before refusing its
/// `--edge-contact`, and `bench` the plot's folder before refusing its `--cells`.
#[test]
fn a_failed_run_leaves_no_empty_folder() {
    let dir = temp_dir("cli", "no-empty-folder");
    let lab = dir.join("lab");
    ok(&["generate", "quick", "--quiet", "--out", s(&lab)]);
    let file = dir.join("a-file");
    std::fs::write(&file, b"").expect("file");
    let (out, report) = (dir.join("s2r/deep"), file.join("report"));
    let _ = err(&["sim2real", "--real", s(&lab), "--out", s(&out), "--report", s(&report)]);
    let _ = err(&[
        "calibrate",
        "--real",
        s(&lab),
        "--edge",
        "square",
        "--edge-contact",
        "1e300,0",
        "-o",
        s(&dir.join("cal/c.toml")),
    ]);
    let _ = err(&["bench", "--cells", "4", "--plot", s(&dir.join("plots/b.svg"))]);
    let mut left: Vec<String> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["a-file", "lab"], "folders left by failed runs");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_poses_and_shapes_are_clear_errors() {
    let dir = temp_dir("cli", "badpose");
    let out = dir.join("x.png");
    let out = out.to_str().expect("utf-8");
    for (args, needle) in [
        (vec!["--shape", "clover", "--pose", "0,0,nan,0"], "not finite"),
        (vec!["--shape", "clover", "--pose", "0,0,3"], "x,y,depth,yaw"),
        (vec!["--shape", "clover", "--pose", "0,0,15,0"], "pose.depth_mm"),
        (vec!["--shape", "clover", "--pose", "0,0,3,0,60,0"], "pose.rx_deg"),
        (vec!["--shape", "nosuch"], "unknown"),
        (vec!["--shape", "disk", "--slide-from", "1,x"], "not a number"),
        (vec!["--shape", "disk", "--slide-from", "1,0", "--step", "0"], "step_mm"),
        // Absurd but parseable numbers (issue 88): refused, naming the field and its range; a
        // pose 1e300 mm away rendered an undeformed image, a step of 1e300 mm was taken, and a
        // slide from 1e300 mm blamed the step with a 300-digit number.
        (vec!["--shape", "disk", "--pose", "1e300,0,1,0"], "pose.x_mm` must be within +-1e4 mm"),
        (vec!["--shape", "disk", "--pose", "0,0,-1e9,0"], "pose.depth_mm` must be within +-1e4 mm"),
        (vec!["--shape", "disk", "--pose", "0,0,1,1e300"], "pose.yaw_deg` must be within +-1e6 deg"),
        (vec!["--shape", "disk", "--slide-from", "1,0", "--step", "1e300"], "[0.01, 10] mm"),
        (vec!["--shape", "disk", "--slide-from", "1e300,0"], "slide_from` must be at most 100 mm"),
        (vec!["--pins", "30301"], "K in [1, 30]"),
    ] {
        let mut a = vec!["render", "-o", out];
        a.extend(args.iter());
        let o = tacsim(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{args:?}: {err}");
        assert!(!dir.join("x.png").exists(), "{args:?} wrote a file");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn validate_json_meets_the_bounds() {
    let o = tacsim(&["validate", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let f = |path: &str| v.pointer(path).and_then(|x| x.as_f64()).unwrap_or_else(|| panic!("{path} missing"));
    assert!(f("/hertz/force_rel_err").abs() <= 0.005);
    assert!(f("/hertz/radius_rel_err").abs() <= 0.01);
    assert!(f("/hertz/pmax_rel_err").abs() <= 0.01);
    assert!(f("/cattaneo/shift_rel_err").abs() <= 0.002);
    assert!(f("/cattaneo/stick_radius_err_cells") <= 1.0);
    assert!(f("/grid") >= 5.0 && f("/cells_across_contact") > 10.0);
    assert!(f("/hertz/seconds") > 0.0 && f("/cattaneo/seconds") > 0.0);
    assert_eq!(v["pass"], serde_json::Value::Bool(true));
}

#[test]
fn bench_json_reports_rates_breakdown_skips_and_curve() {
    let dir = temp_dir("cli", "bench");
    let plot = dir.join("bench.svg");
    let o = tacsim(&["bench", "--json", "--samples", "4", "--cells", "9", "--plot", plot.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    for key in [
        "/tap_frames_per_s",
        "/slide_samples_per_s",
        "/first_pass/tap_frames_per_s",
        "/first_pass/slide_samples_per_s",
        "/tap_breakdown/solve_ms",
        "/tap_breakdown/pins_ms",
    ] {
        assert!(v.pointer(key).and_then(|x| x.as_f64()).is_some_and(|x| x > 0.0), "{key}");
    }
    assert_eq!(v["cells_across"], 9);
    assert_eq!(v["edge_subcells"], 3);
    for key in
        ["no_contact_step_ms", "tap_without_tangential_ms", "footprint_grid_ms", "no_render_ms", "far_stimuli_ms"]
    {
        assert_eq!(v["skips"][key].as_array().map(|a| a.len()), Some(2), "{key}");
    }
    let curve = v["curve"].as_array().expect("curve");
    assert!(curve.iter().filter(|p| p["knob"] == "grid").count() >= 4);
    assert!(curve.iter().filter(|p| p["knob"] == "step").count() >= 4);
    assert!(std::fs::read_to_string(&plot).expect("plot written").contains("<svg"));
    let bad = tacsim(&["bench", "--cells", "10", "--plot", plot.to_str().expect("utf-8")]);
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("skin.cells_across"));
    let bad = tacsim(&["bench", "--edge-subcells", "7", "--plot", plot.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("skin.edge_subcells") && err.contains("[0, 6]"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `render --slide-from 2,0 --step 1e-5` ran for minutes (200,000 contact solves) and
/// `--step 1e-300` aborted on "capacity overflow": the step's range (0.01 to 10 mm, as a
/// recipe's) is checked before any work (a path's step count is too, for recipes' slides).
#[test]
fn render_with_a_step_too_small_for_the_slide_was_a_hang_or_an_abort() {
    let dir = temp_dir("cli", "tiny-step");
    let out = dir.join("x.png");
    for step in ["1e-5", "1e-300"] {
        let started = std::time::Instant::now();
        let e = err(&[
            "render",
            "--shape",
            "disk",
            "--pose",
            "0,0,2,0",
            "--slide-from",
            "2,0",
            "--step",
            step,
            "-o",
            s(&out),
        ]);
        assert!(e.contains("step_mm") && e.contains("[0.01, 10] mm"), "{step}: {e}");
        assert!(!out.exists(), "{step}: nothing written");
        println!("--step {step}: refused in {:?}", started.elapsed());
    }
}
