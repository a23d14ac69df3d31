//! The neo-Hookean element and the flat press: the element's force and tangent are its
//! energy's derivatives, its tangent at rest is the linear element's stiffness, and a shallow
//! press gives what the linear model gives.

use tacsim_fem::{
    Dome, FemError, FlatPress, Kinematics, Material, PressState, large_displacement, matrices, neo_hookean,
};

mod support;

/// A curved skin element of a coarse dome, and its material.
fn element() -> ([[f64; 3]; 10], Material) {
    let dome = Dome::build(&support::spec(3)).expect("dome");
    let e = (0..dome.mesh.elements.len())
        .find(|&e| dome.mesh.regions[e] == tacsim_fem::Region::Skin)
        .expect("a skin element");
    (dome.mesh.element_nodes(e), dome.spec.skin)
}

/// A fixed displacement of an element's nodes, of the order of 5% of its size: a large strain.
fn displacement(scale: f64) -> [[f64; 3]; 10] {
    let mut u = [[0.0; 3]; 10];
    for (a, ua) in u.iter_mut().enumerate() {
        for (i, v) in ua.iter_mut().enumerate() {
            *v = scale * (1.7 * a as f64 + 2.3 * i as f64 + 0.4).sin();
        }
    }
    u
}

#[test]
fn neo_hookean_tangent_at_rest_is_the_linear_stiffness() {
    let (x, m) = element();
    let rest = neo_hookean(&x, &[[0.0; 3]; 10], &m);
    let linear = matrices(&x, &m);
    let scale = linear.stiffness.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    for r in 0..30 {
        assert!(rest.force[r].abs() < 1e-12 * scale, "force at rest {}", rest.force[r]);
        for c in 0..30 {
            let d = (rest.matrices.stiffness[r][c] - linear.stiffness[r][c]).abs();
            assert!(
                d < 1e-9 * scale,
                "tangent ({r}, {c}) {} against {}",
                rest.matrices.stiffness[r][c],
                linear.stiffness[r][c]
            );
        }
    }
}

#[test]
fn neo_hookean_force_and_tangent_are_the_energy_derivatives() {
    let (x, m) = element();
    let size = (0..3).map(|k| (x[1][k] - x[0][k]).powi(2)).sum::<f64>().sqrt();
    let u = displacement(0.05 * size);
    let at = neo_hookean(&x, &u, &m);
    let h = 1e-6 * size;
    let (force_scale, tangent_scale) = (
        at.force.iter().fold(0.0f64, |s, v| s.max(v.abs())),
        at.matrices.stiffness.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs())),
    );
    for d in 0..30 {
        let (mut plus, mut minus) = (u, u);
        plus[d / 3][d % 3] += h;
        minus[d / 3][d % 3] -= h;
        let (p, q) = (neo_hookean(&x, &plus, &m), neo_hookean(&x, &minus, &m));
        let force = (p.energy - q.energy) / (2.0 * h);
        assert!((force - at.force[d]).abs() < 1e-6 * force_scale, "force {d}: {} against {force}", at.force[d]);
        for r in 0..30 {
            let k = (p.force[r] - q.force[r]) / (2.0 * h);
            let analytic = at.matrices.stiffness[r][d];
            assert!((k - analytic).abs() < 1e-6 * tangent_scale, "tangent ({r}, {d}): {analytic} against {k}");
        }
    }
}

fn press(depths_mm: Vec<f64>) -> FlatPress {
    FlatPress { depths_mm, step_mm: 0.25, penalty_n_per_mm: 1000.0 }
}

/// The largest pin tip difference between the two states, as a fraction of the largest tip
/// motion.
fn pin_difference(dome: &Dome, a: &PressState, b: &PressState) -> f64 {
    let probes = dome.pin_probes(&support::pins(0.0)).expect("probes");
    let (mut worst, mut moved) = (0.0f64, 0.0f64);
    for probe in &probes {
        let lin = probe.displacement(&a.displacement);
        let big = large_displacement(probe, &dome.mesh, &b.displacement);
        worst = worst.max((0..3).map(|k| (lin[k] - big[k]).powi(2)).sum::<f64>().sqrt());
        moved = moved.max(big.iter().map(|v| v * v).sum::<f64>().sqrt());
    }
    worst / moved
}

#[test]
fn a_shallow_press_is_the_same_in_both_models_and_a_deep_one_is_not() {
    // Measured at 4 cells (these five pins): 0.1 mm: pins 0.45% of their motion apart, forces
    // 0.31%; 1 mm: 2.7% and 4.5% (331 pins and deeper presses: the example
    // `cargo run --release -p tacsim-fem --example dome_nonlinear -- 4 0.25 1`).
    let dome = Dome::build(&support::spec(4)).expect("dome");
    let depths = vec![0.1, 1.0];
    let linear = press(depths.clone()).run(&dome, Kinematics::Linear, |_, _| {}).expect("linear press");
    let large = press(depths).run(&dome, Kinematics::NeoHookean, |_, _| {}).expect("neo-Hookean press");
    for (a, b) in linear.iter().zip(&large) {
        assert!(
            a.penetration_mm < 1e-3 && b.penetration_mm < 1e-3,
            "penalty too soft: {} {}",
            a.penetration_mm,
            b.penetration_mm
        );
    }
    let shallow = pin_difference(&dome, &linear[0], &large[0]);
    let deep = pin_difference(&dome, &linear[1], &large[1]);
    let force = |k: usize| (large[k].force_n / linear[k].force_n - 1.0).abs();
    eprintln!("pins: {shallow:.4} at 0.1 mm, {deep:.4} at 1 mm; force: {:.4}, {:.4}", force(0), force(1));
    assert!(shallow < 0.02 && force(0) < 0.01, "a 0.1 mm press differs by {shallow} (pins), {} (force)", force(0));
    assert!(deep > 2.0 * shallow, "the models' difference does not grow with depth: {shallow} then {deep}");
}

#[test]
fn a_press_does_not_depend_on_the_thread_count() {
    let dome = Dome::build(&support::spec(3)).expect("dome");
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| press(vec![0.5]).run(&dome, Kinematics::NeoHookean, |_, _| {}).expect("press"))
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one[0].force_n.to_bits(), two[0].force_n.to_bits());
    assert!(one[0].displacement == two[0].displacement);
}

#[test]
fn an_absurd_press_is_refused_with_the_field_named() {
    let dome = Dome::build(&support::spec(3)).expect("dome");
    for (p, field) in [
        (press(vec![1.0, 0.5]), "depths_mm"),
        (press(vec![-1.0]), "depths_mm"),
        (FlatPress { step_mm: 0.0, ..press(vec![1.0]) }, "step_mm"),
        (FlatPress { penalty_n_per_mm: f64::NAN, ..press(vec![1.0]) }, "penalty_n_per_mm"),
    ] {
        match p.run(&dome, Kinematics::Linear, |_, _| {}) {
            Err(FemError::Parameter { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {:?}", other.map(|s| s.len())),
        }
    }
}
