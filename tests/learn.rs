//! `tacsim train` and `tacsim eval` end to end: a generated dataset through every network to
//! the report, a lab recording folder with the lab's preprocessing, and bad input.

mod common;
use common::{err, lab_folder, ok, s, temp_dir};

#[test]
fn generated_dataset_trains_every_network_and_evaluates() {
    let dir = temp_dir("learn", "e2e");
    let data = dir.join("data");
    ok(&["generate", "quick", "--out", s(&data), "--size", "128", "-q"]);
    let small = ["--size", "64", "--epochs", "1", "--batch", "8", "--max-batches", "2", "-q"];
    let semi = dir.join("semi");
    let mut args = vec!["train", "unshear", "--data", s(&data), "--out", s(&semi)];
    args.extend_from_slice(&small);
    let text = ok(&args);
    assert!(text.contains("self-supervised") && text.contains("supervised"), "{text}");
    // A finished run is not overwritten without --resume.
    assert!(err(&args).contains("--resume"));
    let base = dir.join("base");
    let mut args = vec!["train", "baseline", "--data", s(&data), "--out", s(&base)];
    args.extend_from_slice(&small);
    ok(&args);
    let pose = dir.join("pose");
    let mut args = vec!["train", "posenet", "--data", s(&data), "--out", s(&pose)];
    args.extend_from_slice(&small);
    ok(&args);
    let report = dir.join("report");
    let text = ok(&["eval", "--data", s(&data), "--out", s(&report), s(&semi), s(&base), s(&pose)]);
    assert!(text.contains("Pose MAE"), "{text}");
    for f in ["report.md", "report.json", "grid.png"] {
        assert!(report.join(f).is_file(), "{f}");
    }
}

#[test]
fn bad_training_input_is_a_clear_error() {
    let dir = temp_dir("learn", "bad");
    let out = dir.join("run");
    let e = err(&["train", "unshear", "--data", s(&dir.join("missing")), "--out", s(&out), "-q"]);
    assert!(e.contains("targets.csv"), "{e}");
    let e = err(&["train", "unshear", "--data", s(&dir), "--out", s(&out), "--size", "100", "-q"]);
    assert!(e.contains("256, 128, 64 or 32"), "{e}");
    let cfg = dir.join("bad.toml");
    std::fs::write(&cfg, "bach = 3\n").expect("config");
    let e = err(&["train", "unshear", "--data", s(&dir), "--out", s(&out), "--config", s(&cfg), "-q"]);
    assert!(e.contains("bad.toml") && e.contains("bach"), "{e}");
    let e = err(&["train", "posenet", "--data", s(&dir), "--out", s(&out), "--crop", "1,2,3", "-q"]);
    assert!(e.contains("left,top,width,height"), "{e}");
    // A lab folder with a column missing names the file and the column.
    std::fs::create_dir_all(dir.join("lab/images")).expect("lab");
    std::fs::write(dir.join("lab/targets.csv"), "sensor_image,pose_x\nimage_1.png,0\n").expect("csv");
    let e = err(&["train", "posenet", "--data", s(&dir.join("lab")), "--out", s(&out), "--size", "64", "-q"]);
    assert!(e.contains("targets.csv") && e.contains("pose_y"), "{e}");
}

#[test]
fn a_lab_folder_trains_the_pose_network_with_the_labs_preprocessing() {
    let Some(real) = lab_folder("real-tactip-surface3d") else { return };
    // A 40-recording subset of the real folder, in the lab's own format.
    let dir = temp_dir("learn", "lab");
    let lab = dir.join("lab");
    std::fs::create_dir_all(lab.join("images")).expect("lab dir");
    let text = std::fs::read_to_string(real.join("targets.csv")).expect("real targets.csv");
    let lines: Vec<&str> = text.lines().take(41).collect();
    std::fs::write(lab.join("targets.csv"), lines.join("\n") + "\n").expect("csv");
    for line in &lines[1..] {
        let name = line.split(',').next().expect("image column");
        std::fs::copy(real.join("images").join(name), lab.join("images").join(name)).expect("copy image");
    }
    let out = dir.join("pose");
    let args =
        ["train", "posenet", "--data", s(&lab), "--out", s(&out), "--size", "64", "--epochs", "2", "--batch", "8"];
    let text = ok(&[&args[..], &["--crop", "10,10,400,400", "--threshold", "128", "-q"]].concat());
    assert!(text.contains("posenet"), "{text}");
    assert!(out.join("model.safetensors").is_file());
    // An unreadable image names the file.
    std::fs::write(lab.join("images").join(lines[1].split(',').next().expect("name")), b"not a png").expect("corrupt");
    let e = err(&["train", "posenet", "--data", s(&lab), "--out", s(&dir.join("again")), "--size", "64", "-q"]);
    assert!(e.contains("image_") && e.contains("not a readable image"), "{e}");
    // A 1x1 image is refused as `calibrate` refuses it, naming the file and the sides allowed
    // (regression, issue 88: train and sim2real ran on 1x1 images and wrote a report).
    let first = lines[1].split(',').next().expect("name");
    image::GrayImage::new(1, 1).save(lab.join("images").join(first)).expect("a 1x1 image");
    let e = err(&["train", "posenet", "--data", s(&lab), "--out", s(&dir.join("tiny")), "--size", "64", "-q"]);
    assert!(e.contains(first) && e.contains("1x1") && e.contains("[16, 8192]"), "{e}");
    assert!(!dir.join("tiny").join("model.safetensors").exists());
    // One image of another size among the lab's is refused as `calibrate` refuses it, naming
    // both files (regression, issue 88: train and sim2real resized each image alone).
    image::GrayImage::new(64, 64).save(lab.join("images").join(first)).expect("a 64x64 image");
    let e = err(&["train", "posenet", "--data", s(&lab), "--out", s(&dir.join("mixed")), "--size", "64", "-q"]);
    assert!(e.contains(first) && e.contains("64x64 px") && e.contains("one size"), "{e}");
}
