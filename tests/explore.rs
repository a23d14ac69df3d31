//! Closed-loop exploration: every scenario of `scenarios/explore/` meets its criteria, runs
//! are deterministic, bad scenarios are clear errors, and the loop's contact carries sliding
//! history.

use std::path::{Path, PathBuf};
use std::process::Command;

use rayon::prelude::*;
use tacsim_explore::{PerceptionKind, RunReport, Scenario};
use tacsim_sim::contact::Grid;
use tacsim_sim::contact::{ContactModel, Simulation, contact_disk_grid};
use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::{ObjectPose, Scene, SensorParams, SensorPose};

/// A scenario run as `tacsim run` does it, with the `tacsim-model` networks for learned
/// perception.
fn run(s: &Scenario, sensor: &SensorParams, catalogue: &Catalogue) -> tacsim_explore::Result<RunReport> {
    tacsim_explore::run(s, sensor, catalogue, Some(&tacsim::explore::learned::Networks))
}

fn scenarios() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/explore");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("scenarios/explore")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

#[test]
fn every_scenario_meets_its_criteria() {
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let sensor = SensorParams::half_space();
    let files = scenarios();
    assert!(files.len() >= 7, "one scenario per shape at least");
    let reports: Vec<_> = files
        .par_iter()
        .map(|f| {
            let s = Scenario::load(f).expect("scenario");
            run(&s, &s.sensor_or(&sensor).expect("the scenario's sensor"), &catalogue).expect("run")
        })
        .collect();
    print!("{}", tacsim::explore::report::table(&reports));
    let shapes: std::collections::BTreeSet<&str> = reports.iter().map(|r| r.shape.as_str()).collect();
    assert_eq!(shapes.len(), 7, "all seven shapes: {shapes:?}");
    for r in &reports {
        assert!(r.pass, "{}: {:?}", r.name, r.failures);
        // The loop's own perception error: none for the oracle; geometric perception reads
        // the lateral offset within 0.6 mm of the truth on average (0.16-0.31 mm measured with
        // cut cells, 0.13-0.19 with whole cells; 0.14-0.81 and 0.19-0.41 with a one-tap tare).
        match (&r.perception, &r.perception_error) {
            (PerceptionKind::Oracle, e) => assert!(e.is_none(), "{}", r.name),
            (_, Some(e)) => assert!(e.steps > 0 && e.offset_mae_mm <= 0.6, "{}: {e:?}", r.name),
            (_, None) => panic!("{}: image-based perception without its error", r.name),
        }
    }
}

#[test]
fn the_geometric_scenarios_pass_on_the_edge2d_preset() {
    // Geometric perception takes its template from the sensor's own reference press, so the
    // same scenarios pass on the other lab's TacTip (128 px framing, its own camera and rings)
    // with no threshold changed.
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let sensor = SensorParams::edge2d().expect("the edge2d preset");
    let files: Vec<PathBuf> =
        scenarios().into_iter().filter(|f| f.to_string_lossy().ends_with("-geometric.toml")).collect();
    assert_eq!(files.len(), 7, "one geometric scenario per shape");
    let reports: Vec<_> = files
        .par_iter()
        .map(|f| {
            let s = Scenario::load(f).expect("scenario");
            assert!(s.sensor.is_none(), "{}: the geometric scenarios run on the sensor they are given", s.name);
            run(&s, &sensor, &catalogue).expect("run")
        })
        .collect();
    print!("{}", tacsim::explore::report::table(&reports));
    for r in &reports {
        assert!(r.pass, "{} on the edge2d preset: {:?}", r.name, r.failures);
    }
}

#[test]
fn a_run_is_deterministic_for_its_seed() {
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/explore/disk-oracle-noisy.toml");
    let mut s = Scenario::load(&file).expect("scenario");
    s.max_steps = 30;
    let sensor = SensorParams::half_space();
    let (a, b) = (run(&s, &sensor, &catalogue).expect("run"), run(&s, &sensor, &catalogue).expect("run"));
    assert_eq!(a.trajectory, b.trajectory);
    s.seed = 2;
    assert_ne!(a.trajectory, run(&s, &sensor, &catalogue).expect("run").trajectory, "the seed drives the noise");
}

#[test]
fn the_same_pose_by_another_path_gives_other_pins() {
    // Sliding history in the loop's contact: touch down at the pose, or 2 mm before it along
    // the edge and slide there.
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk").expect("disk"), ObjectPose::default()).expect("add");
    let model = ContactModel::new(&SensorParams::half_space()).expect("contact model");
    let grid = contact_disk_grid(&model, 1.5);
    let pose = SensorPose::new(50.0, 0.0, 1.5, 90.0);
    let mut direct = Simulation::with_grid(&model, &scene, Some(grid));
    direct.step(pose).expect("step");
    let mut slid = Simulation::with_grid(&model, &scene, Some(grid));
    for k in 0..=8 {
        slid.step(SensorPose { y_mm: -2.0 + 0.25 * k as f64, ..pose }).expect("step");
    }
    let shift = direct.pins().iter().zip(&slid.pins()).map(|(a, b)| (a.tip - b.tip).norm()).fold(0.0, f64::max);
    assert!(shift > 0.01, "history must show in the pins: {shift} mm");
}

#[test]
fn bad_scenarios_are_clear_errors_and_failures_exit_non_zero() {
    let dir = std::env::temp_dir().join(format!("tacsim-explore-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let tacsim = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_tacsim")).args(args).output().expect("runs");
    for (text, needle) in [
        ("shape = \"disk\"\nspeed = 3\n", "speed"),
        ("depth_mm = -1.0\n", "depth_mm"),
        ("perception = \"telepathy\"\n", "perception"),
        ("[criteria]\niou = 1.5\n", "criteria.iou"),
        // Absurd but parseable values that hung or ran away (issue 32): each is refused at once.
        ("[noise]\noffset_mm = 1000\n", "noise.offset_mm"),
        ("[control]\nkp_offset = 1e300\n", "control.kp_offset"),
        ("substep_mm = 1e-300\n", "substep_mm"),
        ("step_mm = 1e300\n", "step_mm"),
        ("max_steps = 100000000\n", "max_steps"),
    ] {
        let f = dir.join("bad.toml");
        std::fs::write(&f, text).expect("write");
        let o = tacsim(&["run", f.to_str().expect("utf-8"), "--out", dir.join("out").to_str().expect("utf-8")]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains("bad.toml") && err.contains(needle), "{text}: {err}");
    }
    let f = dir.join("unknown-shape.toml");
    std::fs::write(&f, "shape = \"cube\"\nmax_steps = 5\n").expect("write");
    let o = tacsim(&["run", f.to_str().expect("utf-8"), "--out", dir.join("out").to_str().expect("utf-8")]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("cube"));
    // A run that misses its criteria (step limit before closing) exits 1 and still reports.
    let f = dir.join("short.toml");
    std::fs::write(&f, "shape = \"disk\"\nmax_steps = 5\n").expect("write");
    let out = dir.join("short-out");
    let o = tacsim(&["run", f.to_str().expect("utf-8"), "--out", out.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("FAIL: completion"));
    assert!(out.join("report.json").is_file() && out.join("short.svg").is_file());
    // A report directory that cannot be made stops before any run (issue 32: it used to
    // simulate every scenario first and then fail without a word).
    let o = tacsim(&["run", f.to_str().expect("utf-8"), "--out", f.join("out").to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--out") && !err.contains("FAIL"), "{err}");
    assert!(o.stdout.is_empty(), "no run before the check: {}", String::from_utf8_lossy(&o.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Depth of the single-press patch tests (mm).
const DEPTH_MM: f64 = 1.5;

/// The disk alone in a scene, the sensor of the geometric scenarios (the built-in calibrated
/// TacTip), its contact model and the contact-disc grid at `depth_mm`.
fn on_the_disk(depth_mm: f64) -> (Scene, SensorParams, ContactModel, Grid) {
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk").expect("disk"), ObjectPose::default()).expect("add");
    let sensor = SensorParams::half_space();
    let model = ContactModel::new(&sensor).expect("contact model");
    let grid = contact_disk_grid(&model, depth_mm);
    (scene, sensor, model, grid)
}

#[test]
fn the_pins_voronoi_patch_matches_the_contact_engines_patch() {
    // The patch read off the image's pins (Voronoi cell dilation) against the contact
    // engine's own patch, with the sensor over the edge of the disk as the servo keeps it,
    // pressed 1.5 mm. The pins also
    // dilate, less, in a band of about 2 mm off the edge where the free skin bends over it,
    // and little at the contact's rim: those points are left undecided. A single threshold
    // agreed on only 72-88% of the disc (0.1 dilation) or 16-56% (30% of the largest one).
    let (scene, sensor, model, grid) = on_the_disk(DEPTH_MM);
    let depth = DEPTH_MM;
    let mut shares = Vec::new();
    for (x, yaw) in [(50.0, 90.0), (49.0, 90.0), (51.0, 30.0), (50.5, 0.0), (49.5, -45.0)] {
        let mut sim = Simulation::with_grid(&model, &scene, Some(grid));
        let press = tacsim_explore::reference_press(&model, depth, 0.5).expect("reference press");
        let mut g = tacsim_explore::Geometric::new(&sensor, 256, &press).expect("perception");
        sim.step(SensorPose::new(x, 0.0, depth, yaw)).expect("step");
        g.estimate(&sim.pins());
        let centres = grid.centres();
        let reach = 0.9 * (sensor.dome.outer_radius_mm * depth).sqrt();
        let pins = g.touching(&centres);
        let (mut agree, mut decided, mut n) = (0, 0, 0);
        for ((c, p), t) in centres.iter().zip(sim.pressure()).zip(&pins) {
            if c[0].hypot(c[1]) <= reach {
                n += 1;
                if let Some(t) = t {
                    decided += 1;
                    agree += usize::from((*p > 0.0) == *t);
                }
            }
        }
        let (share, coverage) = (agree as f64 / decided.max(1) as f64, decided as f64 / n as f64);
        eprintln!("x {x}, yaw {yaw}: {agree} of {decided} decided agree ({n} in the disc)");
        assert!(
            share >= 0.7 && coverage >= 0.25,
            "x {x} mm, yaw {yaw} deg: agreement {share:.2} on {coverage:.2} of the disc"
        );
        shares.push(share);
    }
    // Measured: 1.00, 0.94, 0.98, 1.00, 0.76.
    let mean = shares.iter().sum::<f64>() / shares.len() as f64;
    assert!(mean >= 0.9, "mean agreement {mean:.2}");
}

#[test]
fn edge_frame_labels_are_the_pose_relative_to_the_edge_that_the_servo_reads() {
    use tacsim_data::wrap_deg;
    use tacsim_explore::oracle;
    use tacsim_sim::dataset::Plan;
    use tacsim_sim::dataset::Recipe;
    let text = "[poses]\nper_shape = 40\nframe = \"edge\"\naround_contour = true\nx_mm = [-3.0, 3.0]\n\
                y_mm = [0.0, 0.0]\ndepth_mm = [1.0, 2.0]\nyaw_deg = [-45.0, 45.0]\n\
                [taps]\nper_pose = 1\ndepth_jitter_mm = 0.0\n[slides]\nper_pose = 1\ntwist_deg = [-10.0, 10.0]\n";
    let recipe = Recipe::from_toml_str(text, "edge.toml").expect("recipe");
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let plan = Plan::new(&recipe, &catalogue, "edge.toml").expect("plan");
    let scenes: Vec<(Scene, usize)> = plan
        .shapes
        .iter()
        .map(|(name, _)| {
            let mut scene = Scene::new();
            let object = scene.add(catalogue.get(name).expect("shape"), ObjectPose::default()).expect("add");
            (scene, object)
        })
        .collect();
    let mut arcs = vec![Vec::new(); scenes.len()];
    for i in 0..plan.len() {
        let sample = plan.sample(i);
        let shape = plan.poses[sample.pose_id].shape;
        let (scene, object) = &scenes[shape];
        let (start, target) = plan.sensor_poses(&sample);
        // The label is what the servo's oracle reads at the target: offset along the outward
        // normal and minus the edge angle (polygonal contours: 0.1 mm, 2 deg).
        let o = oracle(scene, *object, &target);
        assert!(
            (o.offset_mm - sample.pose[0]).abs() < 0.1,
            "{}: offset {} against label {}",
            i,
            o.offset_mm,
            sample.pose[0]
        );
        let d = wrap_deg(o.angle_deg + sample.pose[5]);
        assert!(d.abs() < 2.0, "{i}: edge angle {} against label yaw {}", o.angle_deg, sample.pose[5]);
        // A slide's touch-down offset is in the same frame: its yaw differs by the twist, and
        // its position by the offset turned into the scene.
        let moved = (start.x_mm - target.x_mm).hypot(start.y_mm - target.y_mm);
        assert!((moved - sample.shear[0].hypot(sample.shear[1])).abs() < 1e-9);
        assert!((start.yaw_deg - target.yaw_deg - sample.shear[5]).abs() < 1e-9);
        arcs[shape].push(scene.edge(*object, target.x_mm, target.y_mm).point);
    }
    // Contact points spread all around each contour: every quadrant about the centroid is used.
    for (shape, points) in arcs.iter().enumerate() {
        let n = points.len() as f64;
        let c = points.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
        let mut quadrants = [0; 4];
        for p in points {
            quadrants[usize::from(p[0] > c[0]) + 2 * usize::from(p[1] > c[1])] += 1;
        }
        assert!(quadrants.iter().all(|&q| q > 0), "{}: {quadrants:?}", plan.shapes[shape].0);
    }
}

#[test]
fn learned_perception_without_trained_runs_names_the_field_and_the_command() {
    let catalogue = tacsim::commands::load_catalogue(None).expect("catalogue");
    let mut s: Scenario = toml::from_str("perception = \"learned\"\nimage_size = 128\n").expect("scenario");
    s.name = "learned".into();
    s.models.posenet = std::env::temp_dir().join("tacsim-no-such-run/posenet");
    let err = format!("{:#}", run(&s, &SensorParams::half_space(), &catalogue).expect_err("no runs"));
    assert!(
        err.contains("models") && err.contains("cargo xtask explore") && err.contains("model.safetensors"),
        "{err}"
    );
}

#[test]
fn learned_scenarios_parse_and_find_their_runs_under_models_dir() {
    // Not run here (they need trained runs, `cargo xtask explore`), but they must load, and
    // `tacsim run --models DIR` must keep each scenario's choice of run.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/explore/learned");
    let mut unshear_runs = std::collections::BTreeSet::new();
    for entry in std::fs::read_dir(&dir).expect("scenarios/explore/learned") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let s = Scenario::load(&path).expect("learned scenario");
        assert!(matches!(s.perception, PerceptionKind::Learned | PerceptionKind::LearnedRaw), "{}", path.display());
        let moved = s.models.under(Path::new("/elsewhere"));
        assert_eq!(moved.posenet, Path::new("/elsewhere/posenet"), "{}", path.display());
        assert_eq!(moved.unshear.parent(), Some(Path::new("/elsewhere")));
        assert_eq!(moved.unshear.file_name(), s.models.unshear.file_name());
        if s.perception == PerceptionKind::Learned {
            unshear_runs.insert(s.models.unshear.file_name().expect("run name").to_string_lossy().into_owned());
        }
    }
    let expected: std::collections::BTreeSet<String> = ["baseline", "unshear"].map(String::from).into();
    assert_eq!(unshear_runs, expected, "learned runs use the supervised baseline and the semi-supervised model");
}

#[test]
fn a_dome_wholly_on_the_material_reads_no_free_skin() {
    // Regression: with the dome pressed wholly onto the material, the indentation fades
    // towards the rim of the contact as it does towards an edge, and the rim's pins read as
    // free skin, "no material", which punched a hole into the foil's footprint where the
    // robot wandered onto it (IoU from the pins 0.894). Free evidence now counts only on the
    // free side of the estimated edge.
    let (scene, sensor, model, grid) = on_the_disk(DEPTH_MM);
    let depth = DEPTH_MM;
    let reach = 0.9 * (sensor.dome.outer_radius_mm * depth).sqrt();
    let centres = grid.centres();
    for (x, yaw) in [(40.0, 90.0), (30.0, 0.0), (44.0, 45.0)] {
        let mut sim = Simulation::with_grid(&model, &scene, Some(grid));
        let press = tacsim_explore::reference_press(&model, depth, 0.5).expect("reference press");
        let mut g = tacsim_explore::Geometric::new(&sensor, 256, &press).expect("perception");
        sim.step(SensorPose::new(x, 0.0, depth, yaw)).expect("step");
        g.estimate(&sim.pins());
        let touching = g.touching(&centres);
        let within = centres.iter().zip(&touching).filter(|(c, _)| c[0].hypot(c[1]) <= reach);
        let (free, touch) = within.fold((0, 0), |(f, t), (_, v)| match v {
            Some(false) => (f + 1, t),
            Some(true) => (f, t + 1),
            None => (f, t),
        });
        eprintln!("x {x}, yaw {yaw}: {touch} touching, {free} free within the reach");
        assert!(free == 0 && touch > 0, "x {x} mm: {free} points read as free skin, {touch} touching");
    }
}

#[test]
fn geometric_perception_keeps_the_edge_pins_through_a_slide() {
    // Regression: perception tracked the pins frame to frame by nearest neighbours from their
    // last positions, and the calibrated sensor's pins next to the edge moved 7-9 px (most of
    // a 10.7 px spacing at 256 px) when pressed: they were lost at the first image and, tracked
    // from their undeformed places ever after, never found again; with the edge's own pins
    // missing the disk run left the contour (completion 0.285, read error 3.3 mm / 63 deg).
    // Now the tracker follows them from the undeformed image and the fitted edge stays within
    // half a millimetre and a few degrees of the truth along a slide on the disk's edge.
    use tacsim_data::wrap_deg;
    use tacsim_explore::{EdgeEstimate, Geometric, oracle};
    let (scene, sensor, model, grid) = on_the_disk(DEPTH_MM);
    let press = tacsim_explore::reference_press(&model, DEPTH_MM, 0.5).expect("reference press");
    let mut g = Geometric::new(&sensor, 256, &press).expect("perception");
    let mut sim = Simulation::with_grid(&model, &scene, Some(grid));
    // Along the disk's edge at x = 50 mm, the material on the sensor's left, sliding +y.
    let at = |y: f64| SensorPose::new((50.0f64.powi(2) - y * y).sqrt(), y, DEPTH_MM, 90.0 + y.atan2(50.0).to_degrees());
    for k in 0..=8 {
        sim.step(at(-2.0 + 0.25 * f64::from(k))).expect("step");
    }
    g.tare(&[(sim.pins(), EdgeEstimate { offset_mm: 0.0, angle_deg: 0.0 })]);
    for k in 1..=16 {
        sim.step(at(0.25 * f64::from(k))).expect("step");
        if k % 4 != 0 {
            continue;
        }
        let pose = at(0.25 * f64::from(k));
        let e = g.estimate(&sim.pins()).expect("contact");
        let truth = oracle(&scene, 0, &pose);
        let (dx, da) = (e.offset_mm - truth.offset_mm, wrap_deg(e.angle_deg - truth.angle_deg));
        eprintln!("y {:.1} mm: offset error {dx:.2} mm, angle error {da:.1} deg", pose.y_mm);
        assert!(dx.abs() <= 0.5 && da.abs() <= 6.0, "y {} mm: {dx} mm, {da} deg", pose.y_mm);
    }
}
