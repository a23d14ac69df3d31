//! `tacsim calibrate` end to end: a tiny subset of the shared real recordings into a preset
//! and a held-out report, and malformed lab folders as clear errors.

use std::path::Path;

use tacsim_sim::{FramingParams, PinRenderer, SensorParams};

mod common;
use common::{err, json_file, lab_folder, s, tacsim, temp_dir};

const HEADER: &str =
    "sensor_image,pose_x,pose_y,pose_z,pose_Rx,pose_Ry,pose_Rz,shear_x,shear_y,shear_z,shear_Rx,shear_Ry,shear_Rz";

#[test]
fn a_tiny_lab_folder_calibrates_into_a_preset_and_a_held_out_report() {
    let Some(real) = lab_folder("real-tactip-surface3d") else { return };
    let dir = temp_dir("calibrate", "tiny");
    let lab = tiny_surface_folder(&real, &dir);
    let preset = dir.join("out/preset.toml");
    let o = tacsim(&["calibrate", "--real", s(&lab), "-o", s(&preset), "--quick", "-q"]);
    assert!(o.status.success(), "calibrate failed: {}", String::from_utf8_lossy(&o.stderr));
    let sensor = SensorParams::load(&preset).expect("the preset loads as a sensor");
    assert_eq!(sensor.name, "tactip-331-calibrated");
    let report_dir = dir.join("out/preset-report");
    let report = json_file(&report_dir.join("report.json"));
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

    // The rig alone on the same folder, the preset just written held: the preset it writes is
    // that sensor unchanged, and its report carries the pivot's offset off the axis.
    let rig = dir.join("rig/preset.toml");
    let o =
        tacsim(&["calibrate", "--real", s(&lab), "--sensor", s(&preset), "--rig-only", "-o", s(&rig), "--quick", "-q"]);
    assert!(o.status.success(), "calibrate --rig-only failed: {}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(SensorParams::load(&rig).expect("the rig run's preset"), sensor, "--rig-only keeps the sensor");
    let report = json_file(&dir.join("rig/preset-report/report.json"));
    let d = &report["deformation"];
    assert_eq!(d["pin_length_mm"].as_f64(), Some(sensor.pins.length_mm), "{d}");
    assert!(d["pivot_offset_mm"].as_array().is_some_and(|a| a.len() == 2), "{d}");
    let md = std::fs::read_to_string(dir.join("rig/preset-report/report.md")).expect("report.md");
    assert!(md.contains("pivot_offset_mm = ["), "the [rig] block carries the offset");
    let e = err(&["calibrate", "--real", s(&lab), "-o", s(&rig), "--rig-only", "--camera-only"]);
    assert!(e.contains("--rig-only") && e.contains("--camera-only"), "{e}");
}

/// The reference and the first 30 recordings of the surface folder `real`, in the lab's
/// format, in `dir/lab`.
fn tiny_surface_folder(real: &Path, dir: &Path) -> std::path::PathBuf {
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let text = std::fs::read_to_string(real.join("targets.csv")).expect("real targets.csv");
    let lines: Vec<&str> = text.lines().take(31).collect();
    std::fs::write(lab.join("targets.csv"), lines.join("\n") + "\n").expect("csv");
    for name in lines[1..].iter().map(|l| l.split(',').next().expect("image column")).chain(["image_0.png"]) {
        std::fs::copy(real.join("images").join(name), lab.join("images").join(name)).expect("copy image");
    }
    lab
}

/// `--dome` on the surface presses (a tiny folder, a coarse 4-cell dome, `--quick`): each dome
/// the search scores has its own rig fitted, the report lists them, and the preset written is
/// the sensor with the best dome (its tips kept), nothing else changed.
#[test]
fn a_dome_fit_of_the_surface_presses_writes_the_best_dome() {
    use tacsim_sim::SkinModel;
    let Some(real) = lab_folder("real-tactip-surface3d") else { return };
    let dir = temp_dir("calibrate", "tiny-dome");
    let lab = tiny_surface_folder(&real, &dir);
    let mut sensor = SensorParams::half_space();
    sensor.skin.model = SkinModel::Dome;
    sensor.skin.dome_cells = 4;
    sensor.skin.dome_skin_refinement = 1;
    sensor.skin.gel_youngs_modulus_mpa = 0.02;
    sensor.validate("the test's dome").expect("a valid dome sensor");
    let start = dir.join("start.toml");
    std::fs::write(&start, sensor.to_toml()).expect("sensor file");
    let preset = dir.join("out/dome.toml");
    let o =
        tacsim(&["calibrate", "--real", s(&lab), "--sensor", s(&start), "--dome", "--quick", "-o", s(&preset), "-q"]);
    assert!(o.status.success(), "calibrate --dome failed: {}", String::from_utf8_lossy(&o.stderr));
    let report = json_file(&dir.join("out/dome-report/report.json"));
    let candidates = report["candidates"].as_array().expect("candidates");
    assert_eq!(candidates.len(), 6, "--quick scores six domes: {report}");
    let f = |v: &serde_json::Value| v.as_f64().expect("number");
    let errors: Vec<f64> = candidates.iter().map(|c| f(&c["relative_error"])).collect();
    assert!(errors.iter().all(|e| e.is_finite() && *e > 0.0), "{errors:?}");
    let d = &report["deformation"];
    assert_eq!(d["model"].as_str(), Some("dome"), "{d}");
    let written = SensorParams::load(&preset).expect("preset");
    assert_eq!(written.skin.model, SkinModel::Dome);
    assert_eq!(written.name, "dome", "a dome fit names the sensor after its file");
    assert!((written.skin.gel_youngs_modulus_mpa - f(&d["gel_ratio"]) * sensor.skin.youngs_modulus_mpa).abs() < 1e-12);
    assert_eq!(written.pins.length_mm, f(&d["pin_length_mm"]));
    let tips = |s: &SensorParams| s.pins.length_mm + s.dome.skin_thickness_mm;
    assert!((tips(&written) - tips(&sensor)).abs() < 1e-9, "the tips are kept");
    assert_eq!(written.camera, sensor.camera, "the camera is held");
    let md = std::fs::read_to_string(dir.join("out/dome-report/report.md")).expect("report.md");
    assert!(md.contains("| Dome: gel / skin 0.0200, pins"), "{md}");
    // A dome the search cannot start from (pins of 0.2 mm under a 3 mm skin) is refused by
    // name and range before the recordings are tracked (the folder's bad image is never read).
    let mut bad = sensor.clone();
    (bad.pins.length_mm, bad.dome.skin_thickness_mm) = (0.2, 3.0);
    let bad_file = dir.join("bad.toml");
    std::fs::write(&bad_file, bad.to_toml()).expect("sensor file");
    std::fs::write(lab.join("images/image_1.png"), b"not a png").expect("damage");
    let e = err(&["calibrate", "--real", s(&lab), "--sensor", s(&bad_file), "--dome", "-o", s(&preset), "-q"]);
    assert!(e.contains("--dome") && e.contains("pins of at least 0.5 mm") && !e.contains("image_1"), "{e}");
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
    // A named reference image that is not there.
    std::fs::write(lab.join("images/image_1.png"), b"not a png").expect("image");
    let e = err(&["calibrate", "--real", s(&lab), "-o", s(&preset), "--reference", "ref.png", "--quick", "-q"]);
    assert!(e.contains("ref.png") && e.contains("reference"), "{e}");
    // No reference image: the consensus of the recordings reads them, and names the bad one.
    let e = run();
    assert!(e.contains("image_1.png"), "{e}");
    // An unreadable recording (the reference rendered by the simulator).
    let o = tacsim(&["render", "--size", "420", "-o", s(&lab.join("images/image_0.png"))]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = run();
    assert!(e.contains("image_1.png"), "{e}");
    assert!(!preset.exists(), "no preset is written when the folder is bad");
    // An output that names a folder is refused before any work (issue 88: it failed after
    // the fit), so the bad recording is never read.
    let e = err(&["calibrate", "--real", s(&lab), "-o", s(&dir), "--quick", "-q"]);
    assert!(e.contains("is a folder") && !e.contains("image_1.png"), "{e}");
}

/// Copies `n` recordings of a lab folder (rows and images) into `dest`, each image passed
/// through `cut`.
fn derived_folder(
    real: &Path,
    dest: &Path,
    n: usize,
    cut: impl Fn(image::GrayImage) -> image::GrayImage,
) -> Vec<String> {
    std::fs::create_dir_all(dest.join("images")).expect("lab dir");
    let text = std::fs::read_to_string(real.join("targets.csv")).expect("real targets.csv");
    // The header and the `n` shallowest recordings (a folder of that many shallow presses).
    let mut rows: Vec<&str> = text.lines().skip(1).filter(|l| !l.starts_with("image_0.png,")).collect();
    let depth = |l: &str| l.split(',').nth(3).and_then(|v| v.parse::<f64>().ok()).expect("pose_z");
    rows.sort_by(|a, b| depth(a).total_cmp(&depth(b)));
    let lines: Vec<&str> = text.lines().take(1).chain(rows.into_iter().take(n)).collect();
    std::fs::write(dest.join("targets.csv"), lines.join("\n") + "\n").expect("csv");
    let names: Vec<String> = lines[1..].iter().map(|l| l.split(',').next().expect("image column").to_owned()).collect();
    for name in &names {
        let img = image::open(real.join("images").join(name)).expect("real image").to_luma8();
        cut(img).save(dest.join("images").join(name)).expect("save");
    }
    names
}

#[test]
fn a_lab_folder_with_non_square_images_calibrates() {
    let Some(real) = lab_folder("real-tactip-surface3d") else { return };
    // The 40 shallowest recordings and the undeformed image, each 420 px image put into a
    // 452 x 430 frame at (20, 4).
    let dir = temp_dir("calibrate", "derived");
    let lab = dir.join("lab");
    let pad = |img: image::GrayImage| {
        let mut wide = image::GrayImage::new(452, 430);
        image::imageops::replace(&mut wide, &img, 20, 4);
        wide
    };
    derived_folder(&real, &lab, 40, pad);
    let reference = image::open(real.join("images/image_0.png")).expect("image_0").to_luma8();
    pad(reference).save(lab.join("images/image_0.png")).expect("save");
    let preset = dir.join("out/preset.toml");
    let o = tacsim(&["calibrate", "--real", s(&lab), "-o", s(&preset), "--quick", "-q"]);
    assert!(o.status.success(), "calibrate failed: {}", String::from_utf8_lossy(&o.stderr));
    SensorParams::load(&preset).expect("the preset loads as a sensor");
    let report = json_file(&dir.join("out/preset-report/report.json"));
    let reference = report["reference"].as_str().expect("reference");
    assert!(reference.contains("image_0.png") && reference.contains("452x430"), "{reference}");
    assert!(report["undeformed_rms_px420"].as_f64().expect("rms") < 1.0, "{report}");
    assert!(report["tracked_mean"].as_f64().expect("tracked") > 300.0, "{report}");
}

#[test]
fn the_consensus_of_the_shallowest_presses_stands_in_for_the_undeformed_image() {
    use tacsim_sim::calibrate::Reference;
    use tacsim_sim::pin_centres;
    let Some(real) = lab_folder("real-tactip-surface3d") else { return };
    let lab = tacsim_data::LabFolder::open(&real).expect("lab folder");
    let truth = pin_centres(&Reference::image(&lab, "image_0.png").expect("image_0").image);
    let consensus = Reference::consensus(&lab, Default::default()).expect("consensus");
    let found = pin_centres(&consensus.image);
    // Each true pin's nearest consensus pin, within half a spacing (17.5 px at 420).
    let near: Vec<f64> = truth
        .iter()
        .filter_map(|t| {
            let d = found.iter().map(|f| (f[0] - t[0]).hypot(f[1] - t[1])).fold(f64::INFINITY, f64::min);
            (d < 8.75).then_some(d)
        })
        .collect();
    let rms = (near.iter().map(|d| d * d).sum::<f64>() / near.len() as f64).sqrt();
    eprintln!("consensus: {} of {} pins, RMS {rms:.2} px at 420", near.len(), truth.len());
    assert!(near.len() + 10 >= truth.len() && rms < 3.0, "{} of {} pins, RMS {rms:.2} px", near.len(), truth.len());
    // But flat presses all push the central pins, so the consensus's centre is smeared and the
    // ring fit cannot read it (ring 1 shows 3 of its 6 pins): calibrate says what to do.
    let dir = temp_dir("calibrate", "consensus");
    derived_folder(&real, &dir.join("lab"), 40, |img| img);
    let e = err(&["calibrate", "--real", s(&dir.join("lab")), "-o", s(&dir.join("p.toml")), "--quick", "-q"]);
    assert!(e.contains("consensus of the 30 most alike") && e.contains("--reference"), "{e}");
}

#[test]
fn camera_only_recovers_a_simulated_sensor_from_framed_non_square_images_without_a_reference() {
    // The truth: the calibrated half-space sensor at 128 px with a rim, drawn into 150 x 136 frames (no
    // reference image; the lab's older column names).
    let mut truth = SensorParams::half_space();
    truth.camera.fov_deg *= 1.1;
    truth.framing = FramingParams { rim_radius: Some(0.455), rim_width: Some(0.02), mask_radius: Some(0.47) };
    let img = PinRenderer::new(&truth, 128).expect("renderable").render_undeformed();
    let dir = temp_dir("calibrate", "camera-only");
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let mut csv = String::from(
        "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6\n",
    );
    for i in 1..=24 {
        let mut wide = image::GrayImage::new(150, 136);
        image::imageops::replace(&mut wide, &img, 11, 4);
        wide.save(lab.join(format!("images/image_{i}.png"))).expect("save");
        csv.push_str(&format!("image_{i}.png,0,{},{},0,0,{},0,0,0,0,0,0\n", i % 5, 3.0 + 0.05 * i as f64, 15 * i));
    }
    std::fs::write(lab.join("targets.csv"), csv).expect("csv");
    let preset = dir.join("fitted.toml");
    let o = tacsim(&["calibrate", "--real", s(&lab), "-o", s(&preset), "--camera-only", "-q"]);
    assert!(o.status.success(), "calibrate failed: {}", String::from_utf8_lossy(&o.stderr));
    let fitted = SensorParams::load(&preset).expect("preset");
    assert_eq!(fitted.camera.image_size, 136);
    // 128 px of truth in a 136 px square: the rim at 0.455 * 128 px.
    let px = |f: Option<f64>| f.expect("rim fitted") * 136.0;
    assert!((px(fitted.framing.rim_radius) - 0.455 * 128.0).abs() < 1.0, "{:?}", fitted.framing);
    assert!((px(fitted.framing.rim_width) - 0.02 * 128.0).abs() < 0.75, "{:?}", fitted.framing);
    // Rendered, the fitted sensor draws the same image (but for boundary pixels).
    let again = PinRenderer::new(&fitted, 136).expect("renderable").render_undeformed();
    let folder = tacsim_data::LabFolder::open(&lab).expect("lab folder");
    let framed = tacsim_sim::calibrate::Reference::of(&folder, None, Default::default()).expect("reference").image;
    let differ = again.as_raw().iter().zip(framed.as_raw()).filter(|(a, b)| a != b).count();
    assert!(differ < 400, "{differ} of {} pixels differ", 136 * 136);
    let md = std::fs::read_to_string(dir.join("fitted-report/report.md")).expect("report.md");
    assert!(md.contains("consensus") && md.contains("150x136"), "{md}");
}

#[test]
fn pin_offsets_recover_a_simulated_sensors_irregular_pins() {
    // The truth: the calibrated half-space sensor at 128 px, each pin off its ring place by up to 0.4 px
    // (a fixed pseudo-random pattern), with an undeformed reference image.
    let mut truth = SensorParams::half_space();
    truth.camera.image_size = 128;
    let wobble = |i: usize, k: f64| ((i as f64 * 12.9898 + k * 78.233).sin() * 43758.5453).fract() * 0.4 / 128.0;
    truth.pins.image_offsets = (0..truth.pin_count()).map(|i| [wobble(i, 1.0), wobble(i, 2.0)]).collect();
    truth.validate("truth").expect("valid offsets");
    let img = PinRenderer::new(&truth, 128).expect("renderable").render_undeformed();
    let dir = temp_dir("calibrate", "pin-offsets");
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let mut csv = String::from(
        "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6\n",
    );
    for i in 0..4 {
        img.save(lab.join(format!("images/image_{i}.png"))).expect("save");
        csv.push_str(&format!("image_{i}.png,0,0,{},0,0,0,0,0,0,0,0,0\n", 1.0 + i as f64));
    }
    std::fs::write(lab.join("targets.csv"), csv).expect("csv");
    let mut base = truth.clone();
    base.pins.image_offsets.clear();
    let base_file = dir.join("base.toml");
    std::fs::write(&base_file, base.to_toml()).expect("base");
    let preset = dir.join("fitted.toml");
    let o =
        tacsim(&["calibrate", "--real", s(&lab), "--sensor", s(&base_file), "--pin-offsets", "-o", s(&preset), "-q"]);
    assert!(o.status.success(), "calibrate failed: {}", String::from_utf8_lossy(&o.stderr));
    let fitted = SensorParams::load(&preset).expect("preset");
    assert_eq!((fitted.camera.clone(), fitted.pins.rings), (base.camera.clone(), base.pins.rings), "the rest is held");
    // Each pin's offset recovered to within half its size on average (a binary image does not
    // tell a disc's place closer than its boundary pixels do).
    let error = |o: &[[f64; 2]]| {
        let n = truth.pins.image_offsets.len() as f64;
        truth.pins.image_offsets.iter().zip(o).map(|(t, f)| (t[0] - f[0]).hypot(t[1] - f[1]) * 128.0).sum::<f64>() / n
    };
    let before = error(&vec![[0.0; 2]; truth.pin_count()]);
    let after = error(&fitted.pins.image_offsets);
    assert!(before > 0.2 && after < 0.5 * before, "mean offset error {before:.3} px before, {after:.3} px after");
    // Rendered, the fitted sensor draws the reference again (but for a few boundary pixels).
    let again = PinRenderer::new(&fitted, 128).expect("renderable").render_undeformed();
    let differ = again.as_raw().iter().zip(img.as_raw()).filter(|(a, b)| a != b).count();
    let plain = PinRenderer::new(&base, 128).expect("renderable").render_undeformed();
    let differ_before = plain.as_raw().iter().zip(img.as_raw()).filter(|(a, b)| a != b).count();
    eprintln!("pin offsets: mean error {before:.3} -> {after:.3} px, {differ_before} -> {differ} pixels differ");
    assert!(differ < differ_before / 4, "{differ} pixels differ ({differ_before} without offsets)");
    let md = std::fs::read_to_string(dir.join("fitted-report/report.md")).expect("report.md");
    assert!(md.starts_with("# Pin offsets fit"), "{md}");
}

#[test]
fn the_edge2d_preset_is_what_camera_only_makes_of_the_edge_recordings() {
    let Some(real) = lab_folder("real-tactip-edge2d") else { return };
    // The command in the preset's header (no reference image, the older column names).
    let dir = temp_dir("calibrate", "edge2d");
    let preset = dir.join("tactip-331-edge2d.toml");
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/calibration-edge2d/base.toml");
    let o = tacsim(&[
        "calibrate",
        "--real",
        s(&real),
        "--camera-only",
        "--consensus",
        "shallowest",
        "--sensor",
        s(&base),
        "-o",
        s(&preset),
        "-q",
    ]);
    assert!(o.status.success(), "calibrate failed: {}", String::from_utf8_lossy(&o.stderr));
    let fitted = SensorParams::load(&preset).expect("preset");
    assert_eq!(
        fitted,
        SensorParams::edge2d().expect("committed preset"),
        "rerun the command in sim/presets/tactip-331-edge2d.toml"
    );
    // Every real pin within 0.5 px RMS of the simulated one (1.6 px at 420).
    let summary = String::from_utf8_lossy(&o.stdout);
    let rms: f64 = summary
        .split("RMS ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|v| v.parse().ok())
        .expect("RMS in the summary");
    assert!(rms < 0.5, "{summary}");
}

#[test]
fn the_alike_consensus_of_the_edge_taps_is_of_taps_that_touch_nothing() {
    // Regression: the shallowest 75 of the edge taps press the material, so their majority
    // is a pressed layout; the most alike shallow taps are those beside the edge that touch
    // nothing (lab lateral `pose_2` below -4 mm: the material lies on the positive side).
    use tacsim_sim::calibrate::{ConsensusRule, Reference, ReferenceSource};
    let Some(real) = lab_folder("real-tactip-edge2d") else { return };
    let lab = tacsim_data::LabFolder::open(&real).expect("lab folder");
    let lateral: std::collections::HashMap<&str, f64> =
        lab.samples.iter().map(|s| (s.image.as_str(), s.pose[1])).collect();
    for (rule, off) in [(ConsensusRule::Alike, true), (ConsensusRule::Shallowest, false)] {
        let r = Reference::consensus(&lab, rule).expect("consensus");
        let ReferenceSource::Consensus(_, names) = &r.source else { panic!("{:?}", r.source) };
        let beside = names.iter().filter(|n| lateral[n.as_str()] < -4.0).count();
        eprintln!("{rule:?}: {beside} of {} taps more than 4 mm off the material", names.len());
        assert_eq!(beside == names.len(), off, "{rule:?}: {beside} of {}", names.len());
    }
}

/// A lab folder of 40 taps simulated with `sensor` on the square's edge rounded to
/// `radius_mm`, at 320 px, labelled by a known map (lateral reversed and measured from 1 mm
/// off the edge, yaw reversed and turned, depth zero 2.9 mm above first touch, no yield; the
/// lab's older column names, an undeformed `image_0.png`).
fn simulated_edge_taps(sensor: &SensorParams, radius_mm: f64, dir: &Path) -> std::path::PathBuf {
    use tacsim_sim::calibrate::{edge_scene, edge_sensor_pose};
    use tacsim_sim::contact::{ContactModel, Simulation};
    use tacsim_sim::stimulus::Catalogue;

    let shapes = Path::new(env!("CARGO_MANIFEST_DIR")).join("shapes");
    let square = Catalogue::load_dir(&shapes).expect("catalogue").get("square").expect("square");
    let (scene, frame) = edge_scene(square.with_edge_radius(Some(radius_mm)), [45.0, 0.0]).expect("edge");
    let model = ContactModel::new(sensor).expect("contact model");
    let renderer = PinRenderer::new(sensor, 320).expect("renderable");
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    renderer.render_undeformed().save(lab.join("images/image_0.png")).expect("save");
    let mut csv = String::from(
        "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6\n",
    );
    for i in 1..=40 {
        // Edge frame: x across the edge (mm), indentation (mm), yaw (deg), spread by coprime steps.
        let x = -3.0 + 0.25 * ((i * 7) % 24) as f64;
        let depth = 0.6 + 0.1 * ((i * 3) % 15) as f64;
        let yaw = -40.0 + 10.0 * ((i * 5) % 9) as f64;
        let pose = edge_sensor_pose(&frame, (x, depth, yaw));
        let mut sim = Simulation::new(&model, &scene, &[pose]);
        sim.step(pose).expect("tap");
        renderer.render(&sim.pins()).save(lab.join(format!("images/image_{i}.png"))).expect("save");
        csv.push_str(&format!("image_{i}.png,0,{},{},0,0,{},0,0,0,0,0,0\n", 1.0 - x, depth + 2.9, -(yaw + 178.8)));
    }
    std::fs::write(lab.join("targets.csv"), csv).expect("csv");
    lab
}

/// `--edge`: taps simulated with the contact's gap on a 20 mm profile (half the 40 mm dome's
/// radius, `skin.gap_radius_mm`) on the sharp edge give that profile back, before the edge's
/// roundings (which also delay the contact off the material) and the dome's own, and the
/// preset written carries it.
#[test]
fn edge_taps_give_back_the_gap_profile_they_were_simulated_with() {
    let mut sensor = SensorParams::preset("tactip-331-edge2d").expect("preset");
    sensor.skin.cells_across = tacsim_sim::calibrate::edge::grid_cells().expect("the edge fit's grid");
    let mut profiled = sensor.clone();
    profiled.skin.gap_radius_mm = 0.5 * sensor.dome.outer_radius_mm;
    profiled.validate("the test's sensor").expect("valid");
    let dir = temp_dir("calibrate", "edge-gap");
    let lab = simulated_edge_taps(&profiled, 0.0, &dir);
    let preset = dir.join("out/edge.toml");
    let args = ["calibrate", "--real", s(&lab), "--sensor", "tactip-331-edge2d", "--edge", "square"];
    let o = tacsim(&[&args[..], &["--edge-contact", "45,0", "-o", s(&preset), "-q"]].concat());
    assert!(o.status.success(), "calibrate --edge failed: {}", String::from_utf8_lossy(&o.stderr));
    let report = json_file(&dir.join("out/edge-report/report.json"));
    let f = |v: &serde_json::Value| v.as_f64().expect("number");
    let best = &report["candidates"][report["best"].as_u64().expect("best") as usize];
    assert_eq!((f(&best["edge_radius_mm"]), f(&best["gap_radius_mm"])), (0.0, 20.0), "{report}");
    assert!((f(&best["labels"]["depth_offset_mm"]) + 2.9).abs() < 0.15, "{best}");
    assert_eq!(SensorParams::load(&preset).expect("preset").skin.gap_radius_mm, 20.0, "{report}");
}

/// `--edge`: taps simulated on the square's rounded edge with a known label map
/// ([`simulated_edge_taps`]) give that map back, and the rounding they were made with fits the
/// held-out taps best.
#[test]
fn edge_taps_give_back_the_label_map_and_the_rounding_they_were_simulated_with() {
    let mut sensor = SensorParams::preset("tactip-331-edge2d").expect("preset");
    sensor.skin.cells_across = tacsim_sim::calibrate::edge::grid_cells().expect("the edge fit's grid");
    let dir = temp_dir("calibrate", "edge");
    let lab = simulated_edge_taps(&sensor, 2.0, &dir);
    let preset = dir.join("out/edge.toml");
    let o = tacsim(&[
        "calibrate",
        "--real",
        s(&lab),
        "--sensor",
        "tactip-331-edge2d",
        "--edge",
        "square",
        "--edge-contact",
        "45,0",
        "-o",
        s(&preset),
        "-q",
    ]);
    assert!(o.status.success(), "calibrate --edge failed: {}", String::from_utf8_lossy(&o.stderr));
    let report = json_file(&dir.join("out/edge-report/report.json"));
    let best = &report["candidates"][report["best"].as_u64().expect("best") as usize];
    let l = &best["labels"];
    let f = |v: &serde_json::Value| v.as_f64().expect("number");
    assert_eq!((f(&l["lateral_sign"]), f(&l["yaw_sign"]), l["lateral"].as_u64()), (-1.0, -1.0, Some(1)), "{best}");
    assert!((f(&l["lateral_offset_mm"]) - 1.0).abs() < 0.3, "{best}");
    assert!((f(&l["yaw_offset_deg"]) + 178.8).abs() < 6.0, "{best}");
    assert!((f(&l["depth_offset_mm"]) + 2.9).abs() < 0.15, "{best}");
    // The taps were pressed as labelled: no yield under load.
    assert!(f(&l["depth_compliance"]) < 0.03, "{best}");
    assert_eq!(f(&best["edge_radius_mm"]), 2.0, "{report}");
    // What is left is the 320 px images' quantisation (pins tracked as pixel blobs).
    assert!(f(&best["held_out_error"]) < 0.12, "{best}");
    assert_eq!(SensorParams::load(&preset).expect("preset").name, "tactip-331-edge2d", "the sensor is held");
    let md = std::fs::read_to_string(dir.join("out/edge-report/report.md")).expect("report.md");
    assert!(md.contains(&format!("| 2 | {} | 0 | 0 (dome's) (best) |", sensor.pins.patch_radius_mm)), "{md}");
    // The gap profiles ran (0.75 and 0.5 of the 40 mm dome), and lost to the dome's own that
    // the taps were simulated with.
    let profiles: Vec<f64> = report["candidates"]
        .as_array()
        .expect("candidates")
        .iter()
        .map(|c| f(&c["gap_radius_mm"]))
        .filter(|&p| p > 0.0)
        .collect();
    assert_eq!(profiles, [30.0, 20.0], "{report}");
    // The dome-slope candidates ran, and lost to the rounding the taps were simulated with.
    assert!(md.contains(&format!("| 0 | {} | 1 |", sensor.pins.patch_radius_mm)), "{md}");
    let e = err(&["calibrate", "--real", s(&lab), "--edge", "square", "--edge-contact", "30,0", "-o", s(&preset)]);
    assert!(e.contains("--edge-contact 30.0,0.0") && e.contains("from the edge"), "{e}");
}

/// `--edge --dome`: taps simulated on the square's sharp edge with a finite-element dome whose
/// gel is a fiftieth of the skin's modulus (4 cells, a coarse dome for speed), fitted from the
/// same sensor with a gel four times stiffer: the dome search walks the gel back to the one
/// the taps were made with, gives the label map back and writes a preset with that dome.
#[test]
fn the_dome_fit_finds_the_gel_the_edge_taps_were_simulated_with() {
    use tacsim_sim::SkinModel;
    let mut sensor = SensorParams::preset("tactip-331-edge2d").expect("preset");
    sensor.skin.cells_across = tacsim_sim::calibrate::edge::grid_cells().expect("the edge fit's grid");
    sensor.skin.model = SkinModel::Dome;
    sensor.skin.dome_cells = 4;
    sensor.skin.dome_skin_refinement = 1;
    sensor.skin.gel_youngs_modulus_mpa = 0.02 * sensor.skin.youngs_modulus_mpa;
    // The base at the 40 mm dome's equator.
    sensor.skin.base_depth_mm = sensor.dome.outer_radius_mm;
    sensor.validate("the test's dome").expect("a valid dome sensor");
    let dir = temp_dir("calibrate", "edge-dome");
    let lab = simulated_edge_taps(&sensor, 0.0, &dir);
    let mut start = sensor.clone();
    start.skin.gel_youngs_modulus_mpa *= 4.0;
    let start_file = dir.join("start.toml");
    std::fs::write(&start_file, start.to_toml()).expect("sensor file");
    let preset = dir.join("out/dome.toml");
    let args =
        ["calibrate", "--real", s(&lab), "--sensor", s(&start_file), "--edge", "square", "--edge-contact", "45,0"];
    let o = tacsim(&[&args[..], &["--dome", "--quick", "-o", s(&preset), "-q"]].concat());
    assert!(o.status.success(), "calibrate --edge --dome failed: {}", String::from_utf8_lossy(&o.stderr));
    let report = json_file(&dir.join("out/dome-report/report.json"));
    let f = |v: &serde_json::Value| v.as_f64().expect("number");
    let candidates = report["candidates"].as_array().expect("candidates");
    assert_eq!(candidates.len(), 6, "--quick scores six domes: {report}");
    let best = &candidates[report["best"].as_u64().expect("best") as usize];
    let gel = f(&best["dome"]["gel_ratio"]);
    assert!((gel / 0.02).ln().abs() < 0.5 * std::f64::consts::LN_2 + 1e-9, "gel ratio {gel}: {report}");
    // Chosen by the fitting taps' error, the lowest of the search.
    assert!(candidates.iter().all(|c| f(&c["fit_error"]) >= f(&best["fit_error"])), "{report}");
    let l = &best["labels"];
    assert_eq!((f(&l["lateral_sign"]), f(&l["yaw_sign"])), (-1.0, -1.0), "{best}");
    assert!((f(&l["lateral_offset_mm"]) - 1.0).abs() < 0.3 && (f(&l["depth_offset_mm"]) + 2.9).abs() < 0.15, "{best}");
    let written = SensorParams::load(&preset).expect("preset");
    assert_eq!((written.skin.model, written.name.as_str()), (SkinModel::Dome, "dome"), "named after its file");
    assert!((written.skin.gel_youngs_modulus_mpa / written.skin.youngs_modulus_mpa - gel).abs() < 1e-12);
    assert!(
        (written.pins.length_mm + written.dome.skin_thickness_mm
            - sensor.pins.length_mm
            - sensor.dome.skin_thickness_mm)
            .abs()
            < 1e-9,
        "the tips are kept"
    );
    let md = std::fs::read_to_string(dir.join("out/dome-report/report.md")).expect("report.md");
    assert!(md.contains("dome: gel / skin") && md.contains("A dome search"), "{md}");
    // The dome search fits the rig or the label map itself: not with --rig-only.
    let e = err(&[&args[..], &["--dome", "--rig-only", "-o", s(&preset)]].concat());
    assert!(e.contains("--dome") && e.contains("--rig-only"), "{e}");
}
