//! Numerical stability of the contact engine: Poisson's ratios up to 0.5, indentations from
//! 0.01 to 8 mm, a 10,000-step back-and-forth slide, and the solver invariants on random
//! shapes, poses and paths (proptest).

use std::path::PathBuf;

use proptest::prelude::*;
use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::{ObjectPose, Scene, SensorParams, SensorPose, SkinModel};

fn catalogue() -> Catalogue {
    Catalogue::load_dir(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shapes")).expect("catalogue")
}

fn scene_with(shape: &str) -> Scene {
    let mut scene = Scene::new();
    scene.add(catalogue().get(shape).expect("shape"), ObjectPose::default()).expect("add");
    scene
}

fn model(cells: usize, poisson: f64) -> ContactModel {
    model_of(cells, poisson, SkinModel::HalfSpace)
}

fn model_of(cells: usize, poisson: f64, skin: SkinModel) -> ContactModel {
    let mut s = SensorParams::half_space();
    s.skin.cells_across = cells;
    s.skin.poisson = poisson;
    s.skin.model = skin;
    ContactModel::new(&s).expect("contact model")
}

/// A path from `start` by `moves` (mm, mm, mm, deg: x, y, depth, yaw), the depth kept within
/// 0.05..5 mm.
fn path(start: SensorPose, moves: &[(f64, f64, f64, f64)]) -> Vec<SensorPose> {
    let mut poses = vec![start];
    for &(dx, dy, dd, dyaw) in moves {
        let last = *poses.last().expect("non-empty");
        poses.push(SensorPose {
            x_mm: last.x_mm + dx,
            y_mm: last.y_mm + dy,
            depth_mm: (last.depth_mm + dd).clamp(0.05, 5.0),
            yaw_deg: last.yaw_deg + dyaw,
            ..last
        });
    }
    poses
}

/// Checks every invariant of the current state, with gaps to within 1e-4 of the step's
/// indentation (the engine stops the normal solve at a relative pressure change of 1e-5). The
/// indentation is the report's, how far the stimulus reaches into the skin: a tilted pose's
/// `depth_mm` only places the apex, and the dome's flank can reach 20 times deeper.
fn check_invariants(sim: &Simulation<'_>, what: &str) {
    let p = sim.pressure();
    let (qx, qy) = sim.shear();
    let g = sim.gap();
    let mu = sim.friction();
    let pmax = p.iter().fold(0.0f64, |m, v| m.max(*v));
    let r = sim.report();
    let gap_tol = 1e-4 * r.indentation_mm + 1e-6;
    for k in 0..p.len() {
        assert!(p[k].is_finite() && qx[k].is_finite() && qy[k].is_finite(), "{what}: NaN at cell {k}");
        assert!(p[k] >= 0.0, "{what}: p < 0 at {k}");
        assert!(g[k] >= -gap_tol, "{what}: g = {} < 0 at {k}", g[k]);
        if p[k] > 1e-6 * pmax {
            assert!(g[k].abs() <= gap_tol, "{what}: p g != 0 at {k}: p {} g {}", p[k], g[k]);
        }
        let q = qx[k].hypot(qy[k]);
        assert!(q <= mu[k] * p[k] * (1.0 + 1e-9) + 1e-15, "{what}: |q| {q} > mu p {} at {k}", mu[k] * p[k]);
    }
    assert!(r.dissipation_nmm >= 0.0, "{what}: dissipation {}", r.dissipation_nmm);
    // Coulomb bounds the tangential force in the contact frame (the sensor frame's "shear" of a
    // tilted press also carries part of the normal force).
    let f = r.contact_force_n;
    let shear = f[0].hypot(f[1]);
    let mu_max = mu.iter().fold(0.0f64, |m, v| m.max(*v));
    assert!(shear <= mu_max * f[2] * (1.0 + 1e-9) + 1e-12, "{what}: shear {shear} > mu N {}", f[2]);
    let total = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!((total(f) - total(r.force_n)).abs() <= 1e-9 * total(f) + 1e-12, "{what}: frames disagree on the force");
}

#[test]
fn poisson_ratios_up_to_incompressible() {
    let scene = scene_with("disk");
    for nu in [0.0, 0.3, 0.45, 0.49, 0.499, 0.5] {
        let m = model(13, nu);
        let path: Vec<SensorPose> = (0..=5).map(|i| SensorPose::new(1.0 - 0.2 * i as f64, 0.0, 2.0, 0.0)).collect();
        let mut sim = Simulation::new(&m, &scene, &path);
        for pose in &path {
            sim.step(*pose).unwrap_or_else(|e| panic!("nu {nu}: {e}"));
            check_invariants(&sim, &format!("nu {nu}"));
        }
        assert!(sim.report().force_n[2] > 0.0);
    }
}

#[test]
fn indentations_from_a_hundredth_to_eight_mm() {
    let scene = scene_with("disk");
    for (skin, _) in SkinModel::ALL {
        let m = model_of(17, 0.5, skin);
        let mut last = 0.0;
        for depth in [0.01, 0.03, 0.1, 0.3, 1.0, 2.0, 4.0, 6.0, 8.0] {
            let pose = SensorPose::new(0.0, 0.0, depth, 0.0);
            let mut sim = Simulation::new(&m, &scene, &[pose]);
            let r = sim.step(pose).expect("step").clone();
            let what = format!("{skin:?} depth {depth}");
            check_invariants(&sim, &what);
            assert!(r.in_contact && r.force_n[2] > last, "{what}: force {} after {last}", r.force_n[2]);
            last = r.force_n[2];
            // Pins stay finite.
            for p in sim.pins() {
                assert!(p.tip.coords.iter().all(|v| v.is_finite()), "{what}");
            }
        }
    }
}

#[test]
fn ten_thousand_step_back_and_forth_slide_keeps_invariants_and_returns_on_lift_off() {
    let scene = scene_with("disk");
    let m = model(9, 0.5);
    let steps = 10_000;
    let pose_at = |i: usize| {
        // Triangle wave of amplitude 2 mm, 0.05 mm per step.
        let phase = (i % 160) as f64;
        let x = if phase < 80.0 { phase * 0.05 - 2.0 } else { 2.0 - (phase - 80.0) * 0.05 };
        SensorPose::new(x, 0.5 * x, 1.5, 0.0)
    };
    let poses: Vec<SensorPose> = (0..steps).map(pose_at).step_by(40).collect();
    let mut sim = Simulation::new(&m, &scene, &poses);
    let mut max_ratio = 0.0f64;
    for i in 0..steps {
        let r = sim.step(pose_at(i)).expect("step").clone();
        let ratio = r.force_n[0].hypot(r.force_n[1]) / (0.5 * r.force_n[2]);
        assert!(ratio <= 1.0 + 1e-9, "step {i}: shear / (mu N) = {ratio}");
        assert!(r.dissipation_nmm >= 0.0 && r.force_n.iter().all(|f| f.is_finite()), "step {i}: {r:?}");
        max_ratio = max_ratio.max(ratio);
        if i % 500 == 0 {
            check_invariants(&sim, &format!("step {i}"));
        }
    }
    assert!(max_ratio > 0.99, "gross sliding must be reached: {max_ratio}");
    sim.step(SensorPose::new(0.0, 0.0, -1.0, 0.0)).expect("lift");
    for (p, pin) in sim.pins().iter().zip(&m.layout.pins) {
        assert!((p.tip - pin.tip).norm() < 1e-6);
    }
}

/// Regression: on a tilted lift-off (layer skin) a cell that was a candidate of an earlier
/// coupling round, with that round's overlap, left the candidates of the last round and kept
/// the earlier gap, -0.011 mm (found by the proptest below once a step's first round saw the
/// shear it starts with; its shrunk case).
#[test]
fn a_cell_that_leaves_the_candidates_keeps_no_stale_overlap() {
    let names = catalogue().names();
    let scene = scene_with(&names[0]);
    let m = model_of(11, 0.5, SkinModel::ALL[1].0);
    let start = SensorPose {
        depth_mm: 2.3889101147427367,
        rx_deg: 5.856413122873717,
        ry_deg: -8.49115049253562,
        ..Default::default()
    };
    let poses = path(
        start,
        &[
            (0.0, 0.0, 0.21324950026444536, 0.0),
            (-0.515910239656014, -0.27339391020707443, -0.23523555541110727, 0.0),
            (0.0, 0.0, -0.21631979507517474, 0.0),
        ],
    );
    let mut sim = Simulation::new(&m, &scene, &poses);
    for (i, pose) in poses.iter().enumerate() {
        sim.step(*pose).unwrap_or_else(|e| panic!("step {i}: {e}"));
        check_invariants(&sim, &format!("step {i}"));
    }
}

/// Regression: a press at 0.05 mm tilted 12.6 and -11.1 deg, deepened and lifted back (the
/// proptest's shrunk case), failed the invariants with a gap of -6.4e-6 mm against a bound of
/// 1e-4 of the pose's depth. The solve was right: the tilted dome's flank reaches 0.90 mm into
/// the stimulus, not 0.05, and the gap is 7e-6 of that. The bound now scales with the report's
/// `indentation_mm`, which this checks too.
#[test]
fn a_tilted_press_is_held_to_its_indentation_not_its_depth() {
    let names = catalogue().names();
    let scene = scene_with(&names[0]);
    let m = model_of(11, 0.5, SkinModel::ALL[0].0);
    let start =
        SensorPose { depth_mm: 0.05, rx_deg: 12.580644942393397, ry_deg: -11.148117666348002, ..Default::default() };
    let poses = [start, SensorPose { depth_mm: 0.05 + 0.2752649276059783, ..start }, start];
    let mut sim = Simulation::new(&m, &scene, &poses);
    for (i, pose) in poses.iter().enumerate() {
        let r = sim.step(*pose).unwrap_or_else(|e| panic!("step {i}: {e}"));
        // A sphere of radius R tilted by t about its apex drops by R (1 - cos t) below it.
        let tilt = (pose.rx_deg.to_radians().cos() * pose.ry_deg.to_radians().cos()).acos();
        let drop = m.sensor.dome.outer_radius_mm * (1.0 - tilt.cos());
        let expected = pose.depth_mm + drop;
        assert!(
            (r.indentation_mm - expected).abs() < 0.02 * expected,
            "step {i}: indentation {} mm, expected {expected} mm",
            r.indentation_mm
        );
        check_invariants(&sim, &format!("step {i}"));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn invariants_hold_on_random_shapes_poses_and_paths(
        shape in 0usize..7,
        skin in 0usize..3,
        x in -30.0f64..30.0,
        y in -30.0f64..30.0,
        depth in 0.05f64..5.0,
        yaw in -180.0f64..180.0,
        rx in -15.0f64..15.0,
        ry in -15.0f64..15.0,
        moves in proptest::collection::vec((-0.6f64..0.6, -0.6f64..0.6, -0.3f64..0.3, -5.0f64..5.0), 1..6),
    ) {
        let names = catalogue().names();
        let scene = scene_with(&names[shape % names.len()]);
        let m = model_of(11, 0.5, SkinModel::ALL[skin].0);
        let start = SensorPose { x_mm: x, y_mm: y, depth_mm: depth, yaw_deg: yaw, rx_deg: rx, ry_deg: ry };
        let poses = path(start, &moves);
        let mut sim = Simulation::new(&m, &scene, &poses);
        for (i, pose) in poses.iter().enumerate() {
            sim.step(*pose).map_err(|e| TestCaseError::fail(format!("step {i}: {e}")))?;
            check_invariants(&sim, &format!("step {i} {pose:?}"));
        }
    }
}

/// Regression (issue 31's CI, the proptest's shrunk case): a one-cell touch, lifted off and
/// set down deeper on 14 other cells (skin-on-gel). The shear's eigenvalue bound started from
/// the touch's vector, zero on the new cells, and came out 0 against 2.03 mm/MPa; the solve
/// cycled at residual 2.0 for 20,000 iterations.
#[test]
fn a_press_set_down_on_other_cells_after_a_lift_off_converges() {
    let names = catalogue().names();
    let scene = scene_with(&names[1]);
    let m = model_of(11, 0.5, SkinModel::ALL[2].0);
    let start = SensorPose {
        x_mm: -29.379201625211692,
        y_mm: -27.45884357028779,
        depth_mm: 0.2711016682404069,
        yaw_deg: 178.03134946900795,
        rx_deg: -5.609705749333901,
        ry_deg: -9.560093525825907,
    };
    let poses = path(
        start,
        &[
            (0.5197513128312378, 0.4074933853839348, -0.275928325802332, 1.6231785635968072),
            (0.0, 0.0, 0.2911033596217112, 0.0),
        ],
    );
    let mut sim = Simulation::new(&m, &scene, &poses);
    for (i, pose) in poses.iter().enumerate() {
        sim.step(*pose).unwrap_or_else(|e| panic!("step {i}: {e}"));
        check_invariants(&sim, &format!("step {i}"));
    }
}
