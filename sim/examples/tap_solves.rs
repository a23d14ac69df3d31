//! The criterion bench's two taps (`cargo bench -p tacsim-sim --bench tap -- tap-solve`) solved
//! many times in a row on one thread, for timing a change with the shell's `time` where
//! criterion's runs spread too far on a noisy machine (issue 31): the first solve's normal and
//! tangential iterations and a hash of its tractions' bits, then `REPEATS` more solves. Each
//! solve asks for its sub-cells along an edge (`Simulation::refined_cells`), which a step
//! leaves for the pins to find, so a solve is a tap's whole contact work but the pins.
//!
//! ```text
//! cargo run --release -p tacsim-sim --example tap_solves -- [CELLS] [REPEATS] [flat|rim]
//! ```
//! `CELLS` cells across the footprint (default 25); `REPEATS` solves of each tap after the
//! first (default 0); only the named tap (default both). The taps: the calibrated default
//! sensor on the built-in `disk` (100 mm across, centred at the origin), pressed 3 mm on its
//! flat top at `(5, -3)` mm, yaw 30 deg, and across its rim at `(48, 0)` mm.

#[allow(dead_code)] // `support::dome_mesh` serves the dome's examples.
mod support;

use tacsim_sim::SensorPose;
use tacsim_sim::contact::Simulation;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (cells, repeats) = (support::whole(&args, 0, 25)?, support::whole(&args, 1, 0)?);
    let only = args.get(2).map(String::as_str);
    if !matches!(only, None | Some("flat" | "rim")) {
        return Err(format!("argument 3: `{}` is neither `flat` nor `rim`", args[2]).into());
    }
    let scene = support::disk_scene()?;
    let model = support::model_at(cells)?;
    let taps = [("flat", SensorPose::new(5.0, -3.0, 3.0, 30.0)), ("rim", SensorPose::new(48.0, 0.0, 3.0, 0.0))];
    for (name, pose) in taps.into_iter().filter(|(name, _)| only.is_none_or(|o| o == *name)) {
        let mut sim = Simulation::new(&model, &scene, &[pose]);
        let report = sim.step(pose)?.clone();
        std::hint::black_box(sim.refined_cells());
        let [normal, shear] = sim.matrix_counts();
        let hash = support::tractions_hash(&sim);
        println!(
            "{name}, {cells} cells: {} in contact, iterations normal {} tangential {}, matrices built / reused \
             normal {normal:?} shear {shear:?}, tractions' hash {hash:016x}",
            report.contact_cells, report.normal_iterations, report.tangential_iterations
        );
        for _ in 0..repeats {
            sim.lift();
            sim.step(pose)?;
            // The sub-cells along an edge, which the pins would ask for.
            std::hint::black_box(sim.refined_cells());
        }
    }
    Ok(())
}
