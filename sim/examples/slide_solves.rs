//! The bench's slide (`tacsim bench`: 2.5 mm in 0.25 mm steps, pins at the end) run many
//! times in a row on one thread, for timing a change with the shell's `time` where the bench's
//! runs spread too far on a noisy machine (issue 31): each step's contact cells, normal and
//! tangential iterations and a hash of its tractions' bits, then `REPEATS` more runs of the
//! whole slide.
//!
//! ```text
//! cargo run --release -p tacsim-sim --example slide_solves -- [CELLS] [REPEATS]
//! ```
//! `CELLS` cells across the footprint (default 25); `REPEATS` runs after the first (default
//! 0). The slide: the calibrated half-space sensor on the built-in `disk`, 3 mm deep, yaw 30 deg,
//! from `(6.5, -1)` to `(5, -3)` mm on its flat top (the companion of `tap_solves`' tap there).

#[allow(dead_code)] // `support::dome_mesh` serves the dome's examples.
mod support;

use tacsim_sim::contact::Simulation;
use tacsim_sim::{SensorPath, SensorPose};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (cells, repeats) = (support::whole(&args, 0, 25)?, support::whole(&args, 1, 0)?);
    let scene = support::disk_scene()?;
    let model = support::model_at(cells)?;
    let poses = SensorPath::slide(SensorPose::new(5.0, -3.0, 3.0, 30.0), [1.5, 2.0], 0.25)?.poses();
    let run = |report: bool| -> tacsim_sim::Result<()> {
        let mut sim = Simulation::new(&model, &scene, &poses);
        for (i, pose) in poses.iter().enumerate() {
            let r = sim.step(*pose)?;
            if report {
                let (contact, normal, tangential) = (r.contact_cells, r.normal_iterations, r.tangential_iterations);
                let hash = support::tractions_hash(&sim);
                println!(
                    "step {i}, {cells} cells: {contact} in contact, iterations normal {normal} tangential {tangential}, \
                     tractions' hash {hash:016x}"
                );
            }
        }
        std::hint::black_box(sim.pins());
        Ok(())
    };
    run(true)?;
    for _ in 0..repeats {
        run(false)?;
    }
    Ok(())
}
