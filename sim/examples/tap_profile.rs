//! Where a tap's time goes on one thread, per elastic body, with the solvers' iterations: the
//! bench's 200 taps on the disk (`tacsim_sim::bench::samples`) run `REPEATS` times, each a new
//! path's grid and operator (`Simulation::new`), its step (gap, normal and tangential solves,
//! the sub-cells along edges) and its pins; then the bench's slides, whole.
//!
//! ```text
//! RAYON_NUM_THREADS=1 cargo run --release -p tacsim-sim --example tap_profile -- [SKIN] [REPEATS]
//! ```
//! `SKIN`: half-space, layer, skin-on-gel or dome (default dome); `REPEATS` default 3. Run it
//! under `perf record --call-graph dwarf` for the functions. On the dome (2026-12-05, commit
//! 1141115, 2-core AMD EPYC, `-- dome 3`): 0.60 ms new, 2.05 ms step, 2.42 ms pins a tap, 32
//! normal and 93 tangential iterations, 14.4 ms a slide; the half-space 0.06 / 0.51 / 0.28 ms,
//! 11.5 and 20 iterations, 5.9 ms (`docs/experiments/fem-dome.md`, 2026-12-05).

#[allow(dead_code)] // `support::model_at` and `support::tractions_hash` serve the timing examples.
mod support;

use std::time::Instant;

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{SensorParams, SensorPath, SkinModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let skin: SkinModel = match args.first() {
        Some(name) => name.parse().map_err(|e| format!("argument 1: {e}"))?,
        None => SkinModel::Dome,
    };
    let repeats = support::whole(&args, 1, 3)?.max(1);
    let mut sensor = SensorParams::default();
    sensor.skin.model = skin;
    let model = ContactModel::new(&sensor)?;
    let scene = support::disk_scene()?;
    let poses = tacsim_sim::bench::samples(200, tacsim_sim::bench::SAMPLES_SEED);
    let (mut new, mut step, mut pins) = (0.0, 0.0, 0.0);
    let mut iterations = [0usize; 2];
    for _ in 0..repeats {
        for (pose, _) in &poses {
            let t = Instant::now();
            let mut sim = Simulation::new(&model, &scene, &[*pose]);
            new += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let report = sim.step(*pose)?.clone();
            std::hint::black_box(sim.refined_cells());
            step += t.elapsed().as_secs_f64();
            iterations[0] += report.normal_iterations;
            iterations[1] += report.tangential_iterations;
            let t = Instant::now();
            std::hint::black_box(sim.pins());
            pins += t.elapsed().as_secs_f64();
        }
    }
    let taps = (repeats * poses.len()) as f64;
    let ms = |s: f64| s * 1e3 / taps;
    println!(
        "{skin:?}, a tap: new {:.3} ms, step {:.3} ms, pins {:.3} ms; iterations normal {:.1}, tangential {:.1}",
        ms(new),
        ms(step),
        ms(pins),
        iterations[0] as f64 / taps,
        iterations[1] as f64 / taps
    );
    let t = Instant::now();
    for (pose, from) in &poses {
        let frames = SensorPath::slide(*pose, *from, tacsim_sim::bench::STEP_MM)?.run(&model, &scene)?;
        std::hint::black_box(frames);
    }
    println!("{skin:?}, a slide: {:.3} ms", t.elapsed().as_secs_f64() * 1e3 / poses.len() as f64);
    Ok(())
}
