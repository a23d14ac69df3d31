//! The bench's dome taps (`tacsim bench --skin dome`'s samples on the built-in `disk`: contact
//! and pins, no image) run on the calling thread, `REPEATS` times over, for a profiler
//! (`perf record --call-graph dwarf`) or the shell's `time`: prints each pass's time a tap
//! and a sum of the pins' tips (the same bits, the same sum).
//!
//! `cargo run --release -p tacsim-sim --example dome_taps -- [SAMPLES] [REPEATS] [CELLS]
//! [EDGE_SUBCELLS] [flat|rim] [MESH] [SENSOR]` (default 200 3, the sensor's 25 cells across the footprint
//! and 3 sub-cells; 0: the contact's edge not solved again, as the taps on the disk's top cut
//! no cell; `rim`: the bench's taps across the disk's rim, whose sharp edge cuts cells; `MESH`
//! the dome's, `CELLS[xREFINEMENT[+GEL_SHELLS]]` as `dome_convergence`'s, default the sensor's
//! `8x2+1`; `8` the one lattice of before; `-` the sensor's); `SENSOR` a preset or sensor file
//! (default the calibrated half-space preset with the dome behind it). The dome
//! is built once into the cache folder (`TACSIM_CACHE_DIR`). The pins' product runs on rayon's
//! pool (`RAYON_NUM_THREADS=1` for one thread).

#[allow(dead_code)] // `support::model_at` and `support::tractions_hash` serve the timing examples.
mod support;

use std::time::Instant;

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{SensorParams, SkinModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (samples, repeats) = (support::whole(&args, 0, 200)?, support::whole(&args, 1, 3)?);
    let mut sensor = match args.get(6) {
        None => SensorParams::half_space(),
        Some(name) => SensorParams::file_or_preset(name, None)?,
    };
    sensor.skin.model = SkinModel::Dome;
    sensor.skin.cells_across = support::whole(&args, 2, sensor.skin.cells_across)?;
    sensor.skin.edge_subcells = support::whole(&args, 3, sensor.skin.edge_subcells)?;
    let k = &sensor.skin;
    let (cells, refinement, gel_shells) =
        support::dome_mesh(&args, 5, (k.dome_cells, k.dome_skin_refinement, k.dome_gel_shells()))?;
    sensor.skin.dome_cells = cells;
    sensor.skin.dome_skin_refinement = refinement;
    sensor.skin.dome_refined_gel_shells = Some(gel_shells);
    sensor.validate("CELLS")?;
    let t = Instant::now();
    let model = ContactModel::new(&sensor)?;
    println!("model in {:.2} s", t.elapsed().as_secs_f64());
    let scene = support::disk_scene()?;
    let taps = match args.get(4).map_or("flat", String::as_str) {
        "flat" => tacsim_sim::bench::samples(samples, tacsim_sim::bench::SAMPLES_SEED),
        "rim" => tacsim_sim::bench::rim_samples(samples, tacsim_sim::bench::RIM_SEED),
        other => return Err(format!("argument 5: `{other}` is neither `flat` nor `rim`").into()),
    };
    let mut sum = 0.0;
    for pass in 0..repeats {
        let t = Instant::now();
        for (pose, _) in &taps {
            let mut sim = Simulation::new(&model, &scene, &[*pose]);
            sim.step(*pose)?;
            sum += sim.pins().iter().map(|p| p.tip.x + p.tip.y + p.tip.z).sum::<f64>();
        }
        println!("pass {pass}: {:.3} ms a tap", t.elapsed().as_secs_f64() * 1e3 / taps.len().max(1) as f64);
    }
    println!("sum of the pins' tips: {sum:e} mm");
    Ok(())
}
