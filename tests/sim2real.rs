//! `tacsim sim2real` end to end on a lab folder derived from simulated taps (labels in the
//! lab's older columns, in another frame), the recipe's `sensor` field, and bad input.

mod common;

use common::{err, json_file, ok, s, temp_dir};
use std::path::Path;

/// A small edge-tap recipe (128 px, as the edge preset needs) with the edge preset, `taps` poses.
fn recipe(dir: &Path, name: &str, seed: u64, taps: usize) -> std::path::PathBuf {
    recipe_at(dir, name, seed, taps, [0.3, 1.0])
}

/// [`recipe`] with the taps' depths drawn from `depth_mm`.
fn recipe_at(dir: &Path, name: &str, seed: u64, taps: usize, depth_mm: [f64; 2]) -> std::path::PathBuf {
    let path = dir.join(format!("{name}.toml"));
    let text = format!(
        "name = \"{name}\"\nseed = {seed}\nimage_size = 128\ncells_across = 9\nsensor = \"tactip-331-edge2d\"\n\
         [[shapes]]\nname = \"square\"\ncontact_mm = [45.0, 0.0]\n\
         [poses]\nper_shape = {taps}\nframe = \"edge\"\nx_mm = [-6.0, 6.0]\ny_mm = [0.0, 0.0]\ndepth_mm = [{}, {}]\nyaw_deg = [-180.0, 180.0]\nallow_no_contact = true\n\
         [taps]\nper_pose = 1\ndepth_jitter_mm = 0.0\n[slides]\nper_pose = 0\n\
         [split]\ntrain = 0.8\nval = 0.2\ntest = 0.0\npaired_fraction = 0.0\n",
        depth_mm[0], depth_mm[1]
    );
    std::fs::write(&path, text).expect("recipe");
    path
}

/// A "lab" folder of the simulated taps in `sim`, relabelled as the edge recordings are:
/// lateral in pose_2 with the opposite sign and 0.5 mm off, depth 3 mm deeper, yaw in pose_6
/// turned by 90 deg.
fn lab_folder(sim: &Path, lab: &Path) {
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    std::fs::write(lab.join("meta.json"), "{\"tap_depth\": -5.0}").expect("the lab's own meta.json");
    let text = std::fs::read_to_string(sim.join("targets.csv")).expect("targets");
    let mut rows = vec![
        "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6".to_owned(),
    ];
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (x, z, yaw): (f64, f64, f64) =
            (f[1].parse().expect("x"), f[3].parse().expect("z"), f[6].parse().expect("yaw"));
        rows.push(format!(
            "{},0,{},{},0,0,{},0,0,0,0,0,0",
            f[0],
            -x + 0.5,
            z + 3.0,
            (yaw + 90.0 + 180.0).rem_euclid(360.0) - 180.0
        ));
        std::fs::copy(sim.join("images").join(f[0]), lab.join("images").join(f[0])).expect("image");
    }
    std::fs::write(lab.join("targets.csv"), rows.join("\n") + "\n").expect("csv");
}

#[test]
fn sim2real_reads_a_lab_folder_in_its_own_frame_and_resumes() {
    let dir = temp_dir("sim2real", "e2e");
    // The "lab": other simulated taps, relabelled as the edge recordings are.
    let sim = dir.join("lab-sim");
    ok(&["generate", s(&recipe(&dir, "lab", 11, 60)), "--out", s(&sim), "-q"]);
    let lab = dir.join("lab");
    lab_folder(&sim, &lab);

    let out = dir.join("out");
    let train = recipe(&dir, "train", 5, 60);
    let args = ["sim2real", "--real", s(&lab), "--recipe", s(&train), "--out", s(&out)];
    let text = ok(&[&args[..], &["--epochs", "2", "-q"]].concat());
    assert!(text.contains("trained on tacsim") && text.contains("pose_Rz (deg)"), "{text}");
    let report: serde_json::Value = json_file(&out.join("report.json"));
    // x (pose_1) is constant in the lab's labels: the lateral y, the depth and the yaw are
    // scored; the simulator-trained network reads what varies in the simulated taps.
    let labels: Vec<&str> =
        report["labels"].as_array().expect("labels").iter().map(|l| l["label"].as_str().expect("label")).collect();
    assert_eq!(labels, ["pose_y (mm)", "pose_z (mm)", "pose_Rz (deg)"]);
    assert_eq!(report["sim_labels"], serde_json::json!(["pose_x", "pose_z", "pose_Rz"]));
    let (fitting, held_out) =
        (report["real_fitting"].as_u64().expect("n"), report["real_held_out"].as_u64().expect("n"));
    assert_eq!(fitting + held_out, 60);
    assert!((5..=20).contains(&held_out), "about a fifth held out: {held_out}");
    for l in report["labels"].as_array().expect("labels") {
        for k in ["sim_trained", "real_trained", "chance"] {
            assert!(l[k].as_f64().is_some_and(|v| v.is_finite() && v >= 0.0), "{k}: {l}");
        }
    }
    // Coverage: per mapped label, the lab's fitting poses in the recipe's frame beside the
    // simulated ones (the recipe's -6..6 mm and whole turn, sampled by 48 taps).
    assert!(text.contains("| simulated label | lab's span | simulated span | lab's outside |"), "{text}");
    let coverage = report["coverage"].as_array().expect("coverage");
    assert_eq!(coverage.len(), 3, "{coverage:?}");
    for c in coverage {
        let outside = c["lab_outside"].as_f64().expect("share");
        assert!((0.0..=1.0).contains(&outside), "{c}");
        let (lab_width, sim_width) = (c["lab"]["width"].as_f64().expect("w"), c["sim"]["width"].as_f64().expect("w"));
        assert!(lab_width.is_finite() && lab_width >= 0.0 && sim_width >= 0.0, "{c}");
        match c["label"].as_str().expect("label") {
            "pose_x" => {
                let lo = c["sim"]["lo"].as_f64().expect("lo");
                assert!(lo >= -6.0 && lo + sim_width <= 6.0 && sim_width > 8.0, "{c}");
            }
            "pose_Rz" => assert!(sim_width > 270.0 && sim_width <= 360.0, "{c}"),
            other => assert_eq!(other, "pose_z", "{c}"),
        }
    }
    // predictions.csv: one line per held-out image, the labels and both readings.
    let csv = std::fs::read_to_string(out.join("predictions.csv")).expect("predictions.csv");
    assert!(
        csv.starts_with("image,pose_y,pose_y_sim_trained,pose_y_real_trained,pose_z,pose_z_sim_trained,pose_z_real_trained,pose_Rz,pose_Rz_sim_trained,pose_Rz_real_trained\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count() as u64, held_out + 1);
    // fitting.csv: one line per fitting image, its labels and the simulator-trained reading.
    let fit = std::fs::read_to_string(out.join("fitting.csv")).expect("fitting.csv");
    assert!(
        fit.starts_with("image,pose_y,pose_y_sim_trained,pose_z,pose_z_sim_trained,pose_Rz,pose_Rz_sim_trained\n"),
        "{fit}"
    );
    assert_eq!(fit.lines().count() as u64, fitting + 1);
    let grid = image::open(out.join("grid.png")).expect("grid.png");
    assert_eq!((grid.width(), grid.height()), (8 * 64, 2 * 64));
    // A rerun finds both runs finished and the set generated: the same errors.
    let again = ok(&[&args[..], &["--epochs", "2", "-q"]].concat());
    let table = |t: &str| t.lines().filter(|l| l.starts_with("| pose_")).map(str::to_owned).collect::<Vec<_>>();
    assert_eq!(table(&again), table(&text));
    // The fine-tuning curve (issue 87) on the finished zero-shot run: two K, one seed, a few
    // steps; its report's fields, the same bytes from a second work folder, and a resumed
    // point not trained again.
    let curve = ["--epochs", "2", "--finetune", "8,all", "--finetune-seeds", "1", "--finetune-min-steps", "4", "-q"];
    let with_curve = ok(&[&args[..], &curve[..]].concat());
    assert!(with_curve.contains("# Fine-tuning curve") && with_curve.contains("labels saved"), "{with_curve}");
    let json: serde_json::Value = json_file(&out.join("finetune.json"));
    let points = json["points"].as_array().expect("points");
    assert_eq!(points.iter().map(|p| p["k"].as_u64().expect("k")).collect::<Vec<_>>(), [8, fitting]);
    for p in points {
        assert_eq!(p["epochs"].as_u64(), Some(if p["k"] == 8 { 4 } else { 2 }), "{p}");
        for arm in ["pretrained", "scratch"] {
            let errs = p[arm].as_array().expect(arm);
            assert!(
                errs.len() == 3 && errs.iter().all(|e| e.as_f64().is_some_and(|v| v.is_finite() && v >= 0.0)),
                "{p}"
            );
        }
    }
    let curves = json["labels"].as_array().expect("labels");
    assert_eq!(curves.len(), 3);
    for c in curves {
        assert!(c["real_all"].as_f64().is_some() && c["labels_saved"].as_array().expect("saved").len() == 2, "{c}");
    }
    assert!(std::fs::read_to_string(out.join("finetune.svg")).expect("svg").contains("<svg"));
    let point = out.join("finetune/k8-s0/point.json");
    let stamp = std::fs::metadata(&point).expect("point.json").modified().expect("mtime");
    let md = std::fs::read_to_string(out.join("finetune.md")).expect("finetune.md");
    ok(&[&args[..], &curve[..]].concat());
    assert_eq!(std::fs::read_to_string(out.join("finetune.md")).expect("md"), md, "a rerun reads the points back");
    assert_eq!(std::fs::metadata(&point).expect("point.json").modified().expect("mtime"), stamp, "not recomputed");
    let other = dir.join("out-again");
    let args2 = ["sim2real", "--real", s(&lab), "--recipe", s(&train), "--out", s(&other)];
    ok(&[&args2[..], &curve[..]].concat());
    assert_eq!(
        std::fs::read_to_string(other.join("finetune/k8-s0/point.json")).expect("point"),
        std::fs::read_to_string(&point).expect("point"),
        "same seed, same curve"
    );
    // A gentler fine-tuning (`--finetune-lr-scale`) is a point of its own: the same scratch
    // arm, the pretrained arm at a tenth of the rate, the rule saying so.
    let gentle = ["--epochs", "2", "--finetune", "8", "--finetune-seeds", "1", "--finetune-min-steps", "4"];
    ok(&[&args[..], &gentle[..], &["--finetune-lr-scale", "0.1", "-q"]].concat());
    let (fast, slow) = (json_file(&point), json_file(&out.join("finetune/k8-s0-lr0.1/point.json")));
    assert_eq!(fast["scratch"], slow["scratch"], "the from-scratch arm keeps its rate");
    assert!(!out.join("finetune/k8-s0-lr0.1/scratch").exists(), "the plain point's from-scratch run, shared");
    assert_ne!(fast["pretrained"], slow["pretrained"], "{fast} {slow}");
    let rule = std::fs::read_to_string(out.join("finetune.json")).expect("finetune.json");
    assert!(rule.contains("the pretrained arm at 0.1 times that rate"), "{rule}");
    let e = err(&[&args[..], &gentle[..], &["--finetune-lr-scale", "0", "-q"]].concat());
    assert!(e.contains("--finetune-lr-scale") && e.contains("(0, 1]"), "{e}");
    // Simulated images beside the K (`--finetune-sim-share 0.5`): a point of its own, 8 of
    // the simulated training images join the 8 real ones, the pretrained arm trains the epochs
    // that keep its steps (the 16 still one batch: the same 4 epochs), the from-scratch arm as
    // before; the same bytes again from the other work folder.
    let mixed = ["--finetune-sim-share", "0.5", "-q"];
    ok(&[&args[..], &gentle[..], &mixed[..]].concat());
    let mix_point = out.join("finetune/k8-s0-sim0.5/point.json");
    let with_sim = json_file(&mix_point);
    assert_eq!((with_sim["sim_samples"].as_u64(), with_sim["pretrained_epochs"].as_u64()), (Some(8), Some(4)));
    assert_eq!(fast["scratch"], with_sim["scratch"], "the from-scratch arm is unchanged");
    assert_ne!(fast["pretrained"], with_sim["pretrained"], "{fast} {with_sim}");
    assert!(fast.get("pretrained_epochs").is_none() && fast["sim_samples"] == 0, "{fast}");
    let rule = std::fs::read_to_string(out.join("finetune.json")).expect("finetune.json");
    assert!(rule.contains("simulated images beside the K (s = 0.5)"), "{rule}");
    ok(&[&args2[..], &gentle[..], &mixed[..]].concat());
    assert_eq!(
        std::fs::read_to_string(other.join("finetune/k8-s0-sim0.5/point.json")).expect("point"),
        std::fs::read_to_string(&mix_point).expect("point"),
        "same seed, same mixed point"
    );
    for bad in ["0.95", "-0.1", "x"] {
        let flag = format!("--finetune-sim-share={bad}");
        let e = err(&[&args[..], &gentle[..], &[flag.as_str(), "-q"]].concat());
        assert!(e.contains("--finetune-sim-share") && e.contains("[0, 0.9]"), "{bad}: {e}");
    }
    // `--sim`: the set made before (here the one the recipe generated) trains the same
    // networks to the same errors; a folder that holds no dataset is a clear error.
    let (set, given_out) = (out.join("sim"), dir.join("given"));
    let given = ["sim2real", "--real", s(&lab), "--sim", s(&set), "--out", s(&given_out)];
    let from_set = ok(&[&given[..], &["--epochs", "2", "-q"]].concat());
    assert_eq!(table(&from_set), table(&text));
    let e = err(&["sim2real", "--real", s(&lab), "--sim", s(&lab), "--out", s(&dir.join("bad-set")), "-q"]);
    assert!(e.contains("is not a simulated dataset") && e.contains("meta.json"), "{e}");

    // `--input motion`: both networks read pin motion from their own domain's reference (the
    // lab folder has no undeformed image: the consensus of its taps); the report says so, and
    // a resumed run reads the same motion to the same errors.
    let motion_out = dir.join("motion");
    let motion = ["sim2real", "--real", s(&lab), "--sim", s(&set), "--out", s(&motion_out), "--input", "motion"];
    let first = ok(&[&motion[..], &["--epochs", "2", "-q"]].concat());
    assert!(first.contains("Both networks read pin motion") && first.contains("consensus"), "{first}");
    let report: serde_json::Value = json_file(&motion_out.join("report.json"));
    assert_eq!(report["input"], "motion");
    assert!(report["motion_references"][0].as_str().expect("sim reference").contains("image_0.png"), "{report}");
    assert_eq!(report["motion_field"], 0.6875, "the default part of the pin field");
    assert!(first.contains("within 0.6875 of the half-side"), "{first}");
    assert_eq!(table(&ok(&[&motion[..], &["--epochs", "2", "-q"]].concat())), table(&first));
    // `--turns` on these networks (resumed, two epochs on 48 shallow taps): the
    // simulator-trained network does not read the yaw, so no turn can be turned back: a clear
    // error saying so.
    let e = err(&[&motion[..], &["--turns", "4", "--epochs", "2", "-q"]].concat());
    assert!(e.contains("--turns") && e.contains("does not read the yaw"), "{e}");
    // `--edge-frame` needs that yaw too: the same error, naming its own flag.
    let e = err(&[&motion[..], &["--edge-frame", "--epochs", "2", "-q"]].concat());
    assert!(e.contains("--edge-frame") && e.contains("does not read the yaw"), "{e}");
    // `--motion-field 1`: every pin tracked, said in both reports; a fraction outside [0.2, 1]
    // and the flag without motion are refused before any work.
    let every_out = dir.join("motion-every-pin");
    let every = ["sim2real", "--real", s(&lab), "--sim", s(&set), "--out", s(&every_out), "--input", "motion"];
    let text = ok(&[&every[..], &["--motion-field", "1", "--epochs", "2", "-q"]].concat());
    assert!(text.contains("within 1 of the half-side"), "{text}");
    let report: serde_json::Value = json_file(&every_out.join("report.json"));
    assert_eq!(report["motion_field"], 1.0);
    // A refused run's error, nothing written before the check.
    let refuse = |name: &str, flags: &[&str]| {
        let out = dir.join(name);
        let e =
            err(&[&["sim2real", "--real", s(&lab), "--sim", s(&set), "--out", s(&out)][..], flags, &["-q"]].concat());
        assert!(!out.exists(), "nothing written before the check: {e}");
        e
    };
    for bad in ["0.1", "1.5", "nan", "x"] {
        let e = refuse("motion-field-bad", &["--input", "motion", &format!("--motion-field={bad}")]);
        assert!(e.contains("--motion-field") && e.contains("[0.2, 1]"), "{bad}: {e}");
    }
    let e = refuse("motion-field-pins", &["--motion-field", "1"]);
    assert!(e.contains("--motion-field") && e.contains("--input motion"), "{e}");
    // `--turns` turns the motion's grids: refused on pin images and outside [1, 64].
    let e = refuse("turns-pins", &["--turns", "4"]);
    assert!(e.contains("--turns") && e.contains("--input motion"), "{e}");
    let e = refuse("edge-frame-pins", &["--edge-frame"]);
    assert!(e.contains("--edge-frame") && e.contains("--input motion"), "{e}");
    let e = refuse("match-alone", &["--input", "motion", "--match-motion"]);
    assert!(e.contains("--edge-frame"), "{e}");
    for bad in ["0", "65", "x"] {
        let e = refuse("turns-bad", &["--input", "motion", &format!("--turns={bad}")]);
        assert!(e.contains("--turns") && e.contains("[1, 64]"), "{bad}: {e}");
    }
    // The lab's crop or threshold does not apply to tracked motion.
    let e = refuse("motion-threshold", &["--input", "motion", "--threshold", "128"]);
    assert!(e.contains("--input motion") && e.contains("--threshold"), "{e}");
}

/// `--turns`: a simulator-trained network that reads the yaw (200 deeper taps, 30 epochs) reads
/// each lab image at four turns, its yaw turned back; both reports say so, the real-trained
/// network reads the images as they are, and a rerun gives the same readings. Then
/// `--edge-frame` on the same networks: a second one reads the lateral and the depth, and the
/// real-trained network is read the same way (its own second network), its first alone kept
/// beside; the fine-tuning curve's K = all from-scratch arm, seed 0, is that reading to the bit.
#[test]
fn turned_readings_average_the_simulator_trained_networks_yaw_turned_back() {
    let dir = temp_dir("sim2real", "turns");
    let set = dir.join("set");
    ok(&["generate", s(&recipe_at(&dir, "deep", 5, 200, [1.5, 2.5])), "--out", s(&set), "-q"]);
    let lab_sim = dir.join("lab-sim");
    ok(&["generate", s(&recipe_at(&dir, "lab", 11, 60, [1.5, 2.5])), "--out", s(&lab_sim), "-q"]);
    let lab = dir.join("lab");
    lab_folder(&lab_sim, &lab);
    let out = dir.join("out");
    let args = ["sim2real", "--real", s(&lab), "--sim", s(&set), "--out", s(&out), "--input", "motion"];
    // predictions.csv's columns of one network's readings (`_sim_trained` or `_real_trained`).
    let readings = |who: &str| -> Vec<String> {
        let text = std::fs::read_to_string(out.join("predictions.csv")).expect("predictions.csv");
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().expect("header").split(',').collect();
        let keep: Vec<usize> = (0..header.len()).filter(|&k| header[k].ends_with(who)).collect();
        assert!(!keep.is_empty(), "{who} in {header:?}");
        lines
            .map(|l| keep.iter().map(|&k| l.split(',').nth(k).unwrap_or("").to_owned()).collect::<Vec<_>>().join(","))
            .collect()
    };
    let plain = ok(&[&args[..], &["--epochs", "30", "-q"]].concat());
    let (plain_sim, plain_real) = (readings("_sim_trained"), readings("_real_trained"));
    let plain_real_yaw = readings("Rz_real_trained");
    let turned = ok(&[&args[..], &["--turns", "4", "--epochs", "30", "-q"]].concat());
    assert!(turned.contains("at 4 turns about its centre, 90 deg apart") && !plain.contains("turns about"), "{turned}");
    let report: serde_json::Value = json_file(&out.join("report.json"));
    assert_eq!(report["turns"], 4);
    let turned_sim = readings("_sim_trained");
    assert_eq!(readings("_real_trained"), plain_real, "the real-trained network reads the images as they are");
    assert_ne!(turned_sim, plain_sim, "the simulator-trained network reads them turned");
    ok(&[&args[..], &["--turns", "4", "--epochs", "30", "-q"]].concat());
    assert_eq!(readings("_sim_trained"), turned_sim, "same networks, same turned readings to the last digit");

    // `--edge-frame`: a second network, trained on the simulated images turned into the edge's
    // frame, reads the lateral and the depth of each lab image turned by the yaw read; the yaw
    // stays the first network's to the last digit, the real-trained readings are unchanged,
    // both reports say so and a rerun reads the same.
    let yaw = || readings("Rz_sim_trained");
    let turned_yaw = yaw();
    let framed_args = [&args[..], &["--turns", "4", "--edge-frame", "--epochs", "30", "-q"]].concat();
    let framed = ok(&framed_args);
    assert!(
        framed.contains("read in the edge's frame (`--edge-frame`)") && !turned.contains("edge's frame"),
        "{framed}"
    );
    let report: serde_json::Value = json_file(&out.join("report.json"));
    assert_eq!((report["edge_frame"].as_bool(), report["turns"].as_u64()), (Some(true), Some(4)));
    assert!(out.join("sim-edge-posenet").join("config.json").is_file(), "the second network's run");
    let framed_sim = readings("_sim_trained");
    assert_eq!(yaw(), turned_yaw, "the yaw is the first network's");
    assert_ne!(framed_sim, turned_sim, "the lateral and the depth are the second network's");
    // The real-trained network in the edge's frame: its yaw its own, the lateral and the depth
    // its second network's (trained on the fitting images turned by their labelled yaws); the
    // images as they are in the `_as_is` columns and the report's last column.
    assert!(out.join("real-edge-posenet").join("config.json").is_file(), "the real second network's run");
    let framed_real = readings("_real_trained");
    assert_eq!(readings("_real_trained_as_is"), plain_real, "the real-trained network alone, as before");
    assert_eq!(readings("Rz_real_trained"), plain_real_yaw, "the real-trained yaw is its first network's");
    assert_ne!(framed_real, plain_real, "the real-trained lateral and depth are its second network's");
    assert!(framed.contains("The real-trained network is read the same way") && framed.contains("as is |"), "{framed}");
    for l in report["labels"].as_array().expect("labels") {
        let (sim, real, as_is) =
            (l["sim_trained"].as_f64(), l["real_trained"].as_f64(), l["real_trained_as_is"].as_f64());
        let (Some(sim), Some(real), Some(_)) = (sim, real, as_is) else { panic!("{l}") };
        assert_eq!(l["ratio"].as_f64(), Some(sim / real), "the ratio is against the same reader: {l}");
    }
    ok(&framed_args);
    assert_eq!(readings("_sim_trained"), framed_sim, "same networks, same readings to the last digit");
    assert_eq!(readings("_real_trained"), framed_real, "the real second network read back, the same readings");

    // `--match-motion`: the second network's input matched to the simulated images' moments;
    // the same networks, other lateral and depth readings, the yaw still the first's; said in
    // both reports and reproduced by a rerun.
    let matched_args = [&framed_args[..], &["--match-motion"]].concat();
    let matched = ok(&matched_args);
    assert!(matched.contains("matched pixel by pixel") && !framed.contains("matched pixel"), "{matched}");
    let report: serde_json::Value = json_file(&out.join("report.json"));
    assert_eq!(report["match_motion"].as_bool(), Some(true));
    let matched_sim = readings("_sim_trained");
    assert_eq!(yaw(), turned_yaw, "the yaw is the first network's");
    assert_ne!(matched_sim, framed_sim, "the second network reads matched images");
    ok(&matched_args);
    assert_eq!(readings("_sim_trained"), matched_sim, "same statistics, same readings to the last digit");

    // `--axis-offset`: the lateral's map gains a cos + b sin of the yaw read, fitted on the
    // fitting part; the same networks, the yaw and the depth through the map as before, the
    // lateral not; said in both reports, and a run without it gives back the plain map.
    let offset_args = [&matched_args[..], &["--axis-offset"]].concat();
    let offset = ok(&offset_args);
    assert!(offset.contains("`--axis-offset`") && offset.contains("cos(sim pose_Rz)"), "{offset}");
    let report: serde_json::Value = json_file(&out.join("report.json"));
    assert_eq!(report["axis_offset"].as_bool(), Some(true));
    assert_eq!(yaw(), turned_yaw, "the yaw's link is left alone");
    assert_ne!(readings("_sim_trained"), matched_sim, "the lateral turns with the yaw read");
    assert!(!matched.contains("cos(sim pose_Rz)"), "{matched}");
    ok(&matched_args);
    assert_eq!(readings("_sim_trained"), matched_sim, "without the flag, the plain map's readings");

    // The fine-tuning curve in the edge's frame: each arm trains a second network on the K
    // turned by their labelled yaws and reads the lateral and the depth from the held-out
    // images turned by its first network's yaw; the point has its own folder, keeps the first
    // networks' own figures (the yaw the same, the rest read otherwise), the reports say it,
    // and a rerun reads the point back.
    let curve = ["--finetune", "8,all", "--finetune-seeds", "1", "--finetune-min-steps", "4"];
    let curve_args = [&matched_args[..], &curve[..]].concat();
    ok(&curve_args);
    let point_dir = out.join("finetune/k8-s0-edge-matched");
    for run in ["pretrained", "pretrained-edge", "scratch", "scratch-edge"] {
        assert!(point_dir.join(run).join("config.json").is_file(), "{run}");
    }
    let point: serde_json::Value = json_file(&point_dir.join("point.json"));
    let values = |key: &str| -> Vec<f64> {
        point[key].as_array().unwrap_or_else(|| panic!("{key}: {point}")).iter().filter_map(|v| v.as_f64()).collect()
    };
    // The lab's labels: pose_y (lateral), pose_z (depth), pose_Rz (yaw), in that order.
    for (arm, first) in [("pretrained", "pretrained_first"), ("scratch", "scratch_first")] {
        let (framed, alone) = (values(arm), values(first));
        assert_eq!((framed.len(), alone.len()), (3, 3), "{point}");
        assert_eq!(framed[2], alone[2], "{arm}: the yaw is the first network's");
        assert!(framed[..2] != alone[..2], "{arm}: the lateral and the depth are the second network's: {point}");
    }
    // K = all, seed 0: the from-scratch arm is the zero-shot report's real-trained network, read
    // in the edge's frame and alone, to the last bit (the curve's reference line).
    let report: serde_json::Value = json_file(&out.join("report.json"));
    let fitting = report["real_fitting"].as_u64().expect("real_fitting");
    let all: serde_json::Value = json_file(&out.join(format!("finetune/k{fitting}-s0-edge-matched/point.json")));
    let lab = |key: &str| -> Vec<f64> {
        report["labels"].as_array().expect("labels").iter().filter_map(|l| l[key].as_f64()).collect()
    };
    let at_all =
        |key: &str| -> Vec<f64> { all[key].as_array().expect(key).iter().filter_map(|v| v.as_f64()).collect() };
    assert_eq!(at_all("scratch"), lab("real_trained"), "K = all from scratch is the report's real-trained: {all}");
    assert_eq!(at_all("scratch_first"), lab("real_trained_as_is"), "and its first network alone: {all}");
    let md = std::fs::read_to_string(out.join("finetune.md")).expect("finetune.md");
    assert!(md.contains("Read in the edge's frame, the real-trained network on every fitting sample too"), "{md}");
    assert!(md.contains("first alone (a / b)"), "{md}");
    let rule = std::fs::read_to_string(out.join("finetune.json")).expect("finetune.json");
    assert!(rule.contains("in the edge's frame (--edge-frame)") && rule.contains("matched"), "{rule}");
    ok(&curve_args);
    assert_eq!(std::fs::read_to_string(out.join("finetune.md")).expect("md"), md, "a rerun reads the point back");
    // With `--axis-offset` the map fitted on the K turns the lateral with the yaw read: a point
    // of its own, its pretrained runs its own, the from-scratch arm the plain point's (not
    // trained again), the rule saying so.
    let axis_curve = ["--finetune", "8", "--finetune-seeds", "1", "--finetune-min-steps", "4", "--axis-offset"];
    ok(&[&matched_args[..], &axis_curve[..]].concat());
    let axis_dir = out.join("finetune/k8-s0-edge-matched-axis");
    let axis: serde_json::Value = json_file(&axis_dir.join("point.json"));
    assert!(
        axis["map"].to_string().contains("cos(sim pose_Rz)") && !point["map"].to_string().contains("cos("),
        "{axis}"
    );
    assert_eq!((&axis["scratch"], &axis["scratch_first"]), (&point["scratch"], &point["scratch_first"]), "{axis}");
    assert!(axis_dir.join("pretrained-edge").join("config.json").is_file(), "the pretrained arm's own runs");
    assert!(!axis_dir.join("scratch").exists() && !axis_dir.join("scratch-edge").exists(), "shared from-scratch runs");
    let rule = std::fs::read_to_string(out.join("finetune.json")).expect("finetune.json");
    assert!(rule.contains("axis offset (--axis-offset)"), "{rule}");
}

#[test]
fn a_recipes_sensor_names_a_preset_or_a_file_and_bad_ones_are_clear_errors() {
    let dir = temp_dir("sim2real", "sensor");
    let out = dir.join("set");
    ok(&["generate", s(&recipe(&dir, "edge", 1, 4)), "--out", s(&out), "-q"]);
    let meta = std::fs::read_to_string(out.join("meta.json")).expect("meta");
    assert!(meta.contains("tactip-331-edge2d"), "the recipe's sensor is the edge preset: {meta}");
    // The built-in edge-2d recipe runs the edge preset too.
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/datasets/edge-2d.toml"))
        .expect("edge-2d");
    assert!(text.contains("sensor = \"tactip-331-edge2d\""));
    // An unknown sensor names the recipe, the field and the presets.
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(recipe(&dir, "x", 1, 4))
            .expect("recipe")
            .replace("tactip-331-edge2d", "no-such-sensor"),
    )
    .expect("bad");
    let e = err(&["generate", s(&bad), "--out", s(&dir.join("bad-out")), "-q"]);
    assert!(e.contains("no-such-sensor") && e.contains("`sensor` field") && e.contains("tactip-331-edge2d"), "{e}");
    // sim2real: a bad recipe's sensor and a missing lab folder, before any work.
    let e = err(&["sim2real", "--real", s(&dir.join("none")), "--recipe", s(&bad), "--out", s(&dir.join("s2r")), "-q"]);
    assert!(e.contains("no-such-sensor"), "{e}");
    assert!(!dir.join("s2r/sim").exists(), "nothing generated");
    let e = err(&["sim2real", "--real", s(&dir.join("none")), "--out", s(&dir.join("s2r")), "-q"]);
    assert!(e.contains("not a lab folder") && e.contains("targets.csv"), "{e}");
    // A pose network config naming labels: sim2real picks them itself, so it is refused.
    let config = dir.join("pose.toml");
    std::fs::write(&config, "labels = [\"pose_z\"]\n").expect("config");
    let e =
        err(&["sim2real", "--real", s(&dir.join("none")), "--config", s(&config), "--out", s(&dir.join("s2r")), "-q"]);
    assert!(e.contains("pose.toml") && e.contains("`labels`"), "{e}");
    assert!(!dir.join("s2r/sim").exists(), "nothing generated");
    // A lab folder where no label varies: refused with the reason, before any work.
    let lab = dir.join("constant");
    std::fs::create_dir_all(lab.join("images")).expect("lab");
    let mut rows = vec![
        "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6".to_owned(),
    ];
    for k in 1..=20 {
        std::fs::copy(out.join("images/image_1.png"), lab.join(format!("images/image_{k}.png"))).expect("image");
        rows.push(format!("image_{k}.png,0,0,3.5,0,0,0,0,0,0,0,0,0"));
    }
    std::fs::write(lab.join("targets.csv"), rows.join("\n") + "\n").expect("csv");
    let e = err(&["sim2real", "--real", s(&lab), "--out", s(&dir.join("s2r-constant")), "-q"]);
    assert!(e.contains("no label varies"), "{e}");
    assert!(!dir.join("s2r-constant/sim").exists(), "nothing generated");
}

/// Slid recordings labelled with depth and slide offsets (as the surface recordings): the
/// networks learn from slides and read the slide offsets; the simulator-trained one's readings
/// are mapped onto the lab's by label, sign and offset.
#[test]
fn sim2real_scores_slide_offsets_on_slid_recordings() {
    let dir = temp_dir("sim2real", "slides");
    let recipe = |name: &str, seed: u64| {
        let path = dir.join(format!("{name}.toml"));
        let text = format!(
            "name = \"{name}\"\nseed = {seed}\nimage_size = 128\ncells_across = 9\n\
             [[shapes]]\nname = \"disk\"\ncontact_mm = [0.0, 0.0]\n\
             [poses]\nper_shape = 30\nx_mm = [0.0, 0.0]\ny_mm = [0.0, 0.0]\ndepth_mm = [1.0, 3.0]\nyaw_deg = [0.0, 0.0]\n\
             [taps]\nper_pose = 1\ndepth_jitter_mm = 0.0\n\
             [slides]\nper_pose = 2\noffset_mm = [-3.0, 3.0]\naxes = [\"both\"]\nstep_mm = 1.0\n"
        );
        std::fs::write(&path, text).expect("recipe");
        path
    };
    // The "lab": other simulated slides in the surface folder's columns, slide x and y swapped
    // and y negated, depth 2 mm deeper.
    let sim = dir.join("lab-sim");
    ok(&["generate", s(&recipe("lab", 3)), "--out", s(&sim), "-q"]);
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let mut rows = vec![
        "sensor_image,pose_x,pose_y,pose_z,pose_Rx,pose_Ry,pose_Rz,shear_x,shear_y,shear_z,shear_Rx,shear_Ry,shear_Rz"
            .to_owned(),
    ];
    let text = std::fs::read_to_string(sim.join("targets.csv")).expect("targets");
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect("column");
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f[col("kind")] != "slide" {
            continue;
        }
        let v = |name: &str| f[col(name)].parse::<f64>().expect("number");
        rows.push(format!("{},0,0,{},0,0,0,{},{},0,0,0,0", f[0], v("pose_z") + 2.0, v("shear_y"), -v("shear_x")));
        std::fs::copy(sim.join("images").join(f[0]), lab.join("images").join(f[0])).expect("image");
    }
    assert_eq!(rows.len(), 61, "60 slides");
    std::fs::write(lab.join("targets.csv"), rows.join("\n") + "\n").expect("csv");
    let out = dir.join("out");
    let text = ok(&[
        "sim2real",
        "--real",
        s(&lab),
        "--recipe",
        s(&recipe("train", 8)),
        "--out",
        s(&out),
        "--epochs",
        "2",
        "-q",
    ]);
    let report: serde_json::Value = json_file(&out.join("report.json"));
    let labels: Vec<&str> =
        report["labels"].as_array().expect("labels").iter().map(|l| l["label"].as_str().expect("label")).collect();
    assert_eq!(labels, ["pose_z (mm)", "shear_x (mm)", "shear_y (mm)"], "{text}");
    assert_eq!(report["sim_labels"], serde_json::json!(["pose_z", "shear_x", "shear_y"]));
    // The simulated training images are the slides of the training poses (2 per pose).
    let sim_train = report["sim_train"].as_u64().expect("n");
    assert!(sim_train.is_multiple_of(2) && (30..=60).contains(&sim_train), "{sim_train}");
    // Each lab label is read from a distinct simulated label.
    let map: Vec<&str> = report["map"].as_array().expect("map").iter().map(|l| l.as_str().expect("line")).collect();
    let sims: std::collections::BTreeSet<&str> = map
        .iter()
        .map(|l| l.split(" = ").nth(1).expect("rhs").trim_start_matches('-').split(' ').nth(1).expect("sim"))
        .collect();
    assert_eq!(sims.len(), 3, "{map:?}");
    // `--axis-offset` turns the lateral's map with the yaw: these slides draw none, so it is
    // refused with what to do, not run as a plain map.
    let train = recipe("train", 8);
    let e = err(&[
        "sim2real",
        "--real",
        s(&lab),
        "--recipe",
        s(&train),
        "--out",
        s(&out),
        "--epochs",
        "2",
        "--axis-offset",
        "-q",
    ]);
    assert!(e.contains("--axis-offset") && e.contains("does not read the yaw"), "{e}");
}

/// The built-in `surface-3d` recipe replays the rig `tacsim calibrate` fitted to the surface
/// recordings (`docs/calibration/report.json`): label frame, press and friction, to the
/// precision the recipe writes them. A recalibration must update the recipe too.
#[test]
fn the_surface_3d_recipe_carries_the_calibrated_rig() {
    use tacsim_sim::dataset::Recipe;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let recipe = Recipe::from_toml_str(
        &std::fs::read_to_string(root.join("scenarios/datasets/surface-3d.toml")).expect("recipe"),
        "surface-3d.toml",
    )
    .expect("valid recipe");
    let report: serde_json::Value = json_file(&root.join("docs/calibration-rig/report.json"));
    let (d, f) = (&report["deformation"], &report["frame"]);
    let num = |v: &serde_json::Value| v.as_f64().expect("number");
    let r = &recipe.rig;
    assert_eq!(r.rotation_deg, num(&f["rotation_deg"]));
    assert_eq!((r.mirrored, r.tilts_reversed), (f["mirrored"] == true, f["tilts_reversed"] == true));
    for (got, want, tol) in [
        (r.depth_offset_mm, num(&d["depth_offset_mm"]), 1e-3),
        (r.pivot_mm, num(&d["pivot_mm"]), 1e-2),
        (r.depth_compliance, num(&d["depth_compliance"]), 1e-4),
        (r.tilt_relaxation_per_mm, num(&d["tilt_relaxation_per_mm"]), 1e-4),
        (r.pivot_offset_mm[0], num(&d["pivot_offset_mm"][0]), 1e-3),
        (r.pivot_offset_mm[1], num(&d["pivot_offset_mm"][1]), 1e-3),
        (recipe.shapes[0].friction.expect("friction"), num(&d["friction"]), 1e-3),
    ] {
        assert!((got - want).abs() <= tol, "recipe {got}, calibration {want}");
    }
    assert_eq!(recipe.sensor.as_deref(), Some("tactip-331-calibrated"));
    // The report's `[rig]` block is a recipe fragment giving the same rig and friction.
    let md = std::fs::read_to_string(root.join("docs/calibration-rig/report.md")).expect("report.md");
    let block = md.split("```toml\n").nth(1).and_then(|b| b.split("```").next()).expect("a toml block in the report");
    let from_report = Recipe::from_toml_str(block, "report.md").expect("the block is a valid recipe fragment");
    assert_eq!(from_report.rig, recipe.rig);
    assert_eq!(from_report.shapes[0].friction, recipe.shapes[0].friction);
}
