//! The hot kernels of a tap on the calibrated half-space sensor, one thread: the footprint probe (rays down
//! the scene: by the column index straight down, by parry's BVH when tilted), the coupled
//! contact solve (initial gap, then normal and tangential solves alternated until the
//! tractions settle) and the pin product (every pin's tip from the solved tractions), on the
//! sensor's grid and on finer ones, for a press on the disk's flat top and a tap across its rim
//! (the pins also with the edge preset's skin patch). Run with
//! `cargo bench -p tacsim-sim --bench tap`; `tacsim bench` gives the same stages' means over
//! many poses.

use criterion::{Criterion, criterion_group, criterion_main};
use tacsim_sim::contact::{ContactModel, Footprint, Simulation};
use tacsim_sim::{ObjectPose, Scene, SensorParams, SensorPose};

fn bench_tap(c: &mut Criterion) {
    let catalogue = tacsim_sim::builtin_catalogue().expect("built-in shapes");
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk").expect("the disk"), ObjectPose::default()).expect("one shape");
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    // The disk (100 mm across) centred at the origin: a press on its top, a tap across its rim.
    let taps = [("flat", SensorPose::new(5.0, -3.0, 3.0, 30.0)), ("rim", SensorPose::new(48.0, 0.0, 3.0, 0.0))];
    let default_cells = SensorParams::half_space().skin.cells_across;
    // 13 cells: pins within 0.03 mm of the 65-cell reference on flat contacts (`tacsim bench`).
    let mut grids = vec![13, default_cells, 33];
    grids.sort_unstable();
    grids.dedup();
    let models: Vec<(usize, ContactModel)> = grids
        .iter()
        .map(|&cells| {
            let mut sensor = SensorParams::half_space();
            sensor.skin.cells_across = cells;
            (cells, ContactModel::new(&sensor).expect("contact model"))
        })
        .collect();
    let mut probe = c.benchmark_group("tap-footprint");
    let model = &models[0].1;
    let tilted = SensorPose { rx_deg: 10.0, ..taps[1].1 };
    for (name, pose) in taps.into_iter().chain([("rim-tilted", tilted)]) {
        probe.bench_function(name, |b| b.iter(|| Footprint::of_path(model, &scene, &[pose]).grid.expect("a touch")));
    }
    probe.finish();
    let mut solve = c.benchmark_group("tap-solve");
    for (cells, model) in &models {
        for (name, pose) in taps {
            let mut sim = Simulation::new(model, &scene, &[pose]);
            solve.bench_function(format!("{name}/{cells}-cells"), |b| {
                b.iter(|| {
                    sim.lift();
                    // With the sub-cells along an edge, found when first asked for.
                    single.install(|| {
                        let iterations = sim.step(pose).map(|r| r.normal_iterations).expect("a tap solves");
                        iterations + sim.refined_cells()
                    })
                })
            });
        }
    }
    solve.finish();
    let mut pins = c.benchmark_group("tap-pins");
    for (cells, model) in &models {
        for (name, pose) in taps {
            let mut sim = Simulation::new(model, &scene, &[pose]);
            sim.step(pose).expect("a tap solves");
            pins.bench_function(format!("{name}/{cells}-cells"), |b| b.iter(|| single.install(|| sim.pins())));
        }
    }
    // The edge preset's pins: each moves with a skin patch of seven points (1.5 mm radius).
    let edge = SensorParams::preset("tactip-331-edge2d").expect("the edge preset");
    let edge_model = ContactModel::new(&edge).expect("contact model");
    for (name, pose) in taps {
        let mut sim = Simulation::new(&edge_model, &scene, &[pose]);
        sim.step(pose).expect("a tap solves");
        let id = format!("{name}/{}-cells-patch", edge.skin.cells_across);
        pins.bench_function(id, |b| b.iter(|| single.install(|| sim.pins())));
    }
    pins.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(2));
    targets = bench_tap
}
criterion_main!(benches);
