//! `tacsim calibrate` end to end: a tiny subset of the shared real recordings into a preset
//! and a held-out report, and malformed lab folders as clear errors.

use std::path::Path;

use tacsim_sim::sensor::SensorParams;

mod common;
use common::{err, s, tacsim, temp_dir};

const HEADER: &str =
    "sensor_image,pose_x,pose_y,pose_z,pose_Rx,pose_Ry,pose_Rz,shear_x,shear_y,shear_z,shear_Rx,shear_Ry,shear_Rz";

#[test]
fn a_tiny_lab_folder_calibrates_into_a_preset_and_a_held_out_report() {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real-tactip-surface3d");
    if !real.join("targets.csv").is_file() {
        eprintln!("skipped: ../shared/data/real-tactip-surface3d is not here");
        return;
    }
    // The reference and 30 recordings, in the lab's format.
    let dir = temp_dir("calibrate", "tiny");
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let text = std::fs::read_to_string(real.join("targets.csv")).expect("real targets.csv");
    let lines: Vec<&str> = text.lines().take(31).collect();
    std::fs::write(lab.join("targets.csv"), lines.join("\n") + "\n").expect("csv");
    for name in lines[1..].iter().map(|l| l.split(',').next().expect("image column")).chain(["image_0.png"]) {
        std::fs::copy(real.join("images").join(name), lab.join("images").join(name)).expect("copy image");
    }
    let preset = dir.join("out/preset.toml");
    let o = tacsim(&["calibrate", "--real", s(&lab), "-o", s(&preset), "--quick", "-q"]);
    assert!(o.status.success(), "calibrate failed: {}", String::from_utf8_lossy(&o.stderr));
    let sensor = SensorParams::load(&preset).expect("the preset loads as a sensor");
    assert_eq!(sensor.name, "tactip-331-calibrated");
    let report_dir = dir.join("out/preset-report");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(report_dir.join("report.json")).expect("report.json")).expect("json");
    let rows = report["rows"].as_array().expect("rows");
    assert_eq!(rows.len() as u64, report["held_out"].as_u64().expect("held_out"));
    assert_eq!(report["train"].as_u64().expect("train") + rows.len() as u64, 30);
    assert!(report["undeformed_rms_px420"].as_f64().expect("rms") < 1.0, "{report}");
    let rel = report["held_out_means"]["relative_error"].as_f64().expect("relative error");
    assert!(rel.is_finite() && rel > 0.0, "{rel}");
    for r in rows {
        assert!(r["error_px420"].as_f64().expect("error") >= 0.0 && r["pins"].as_u64().expect("pins") > 250, "{r}");
    }
    let md = std::fs::read_to_string(report_dir.join("report.md")).expect("report.md");
    assert!(md.contains("tacsim calibrate") && md.contains("mean relative error") && md.contains("grid.png"));
    let grid = image::open(report_dir.join("grid.png")).expect("grid.png");
    assert_eq!(grid.width(), 3 * 210);
    assert_eq!(grid.height(), 210 * rows.len().min(12) as u32);
}

#[test]
fn malformed_lab_folders_are_clear_errors() {
    let dir = temp_dir("calibrate", "bad");
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let preset = dir.join("p.toml");
    let run = || err(&["calibrate", "--real", s(&lab), "-o", s(&preset), "--quick", "-q"]);
    // No targets.csv.
    let e = run();
    assert!(e.contains("targets.csv"), "{e}");
    // A column missing.
    std::fs::write(lab.join("targets.csv"), "sensor_image,pose_x\nimage_1.png,0\n").expect("csv");
    let e = run();
    assert!(e.contains("targets.csv") && e.contains("pose_y"), "{e}");
    // An image listed but missing.
    let row = |name: &str| format!("{name},0,0,2,0,0,0,1,0,0,0,0,0\n");
    std::fs::write(lab.join("targets.csv"), format!("{HEADER}\n{}", row("image_1.png"))).expect("csv");
    let e = run();
    assert!(e.contains("images/image_1.png does not exist"), "{e}");
    // No reference image.
    std::fs::write(lab.join("images/image_1.png"), b"not a png").expect("image");
    let e = run();
    assert!(e.contains("image_0.png") && e.contains("reference"), "{e}");
    // An unreadable recording (the reference rendered by the simulator).
    let o = tacsim(&["render", "--size", "420", "-o", s(&lab.join("images/image_0.png"))]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = run();
    assert!(e.contains("image_1.png"), "{e}");
    assert!(!preset.exists(), "no preset is written when the folder is bad");
}
