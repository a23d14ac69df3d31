//! The pins against the contact grid, per body: the bench's taps (`tacsim bench`'s samples on
//! the built-in `disk`, its flat top or across its rim) on grids of 13 to 49 cells across the
//! footprint, each pin's tip against the same tap on 65 cells (every cell on every pin, as the
//! bench's grid rows take their reference): the largest and the rms difference (mm), the same
//! for the 65-cell product summed cell by cell (no blocks), and the blocks' own part; then the
//! contact's pressure along the footprint's `x` axis (`y = 0`, `x < -6` mm) for the first tap
//! on every grid, where the contact ends.
//!
//! ```text
//! cargo run --release -p tacsim-sim --example grid_pins -- [BODY] [TAPS] [flat|rim] [SUBSQUARES] [FRICTION] [EDGE_SUBCELLS]
//! ```
//! `BODY` `half-space`, `layer`, `skin-on-gel` or `dome` (default `dome`, built once into the
//! cache folder); `TAPS` (default 40); `SUBSQUARES` the pins' sub-squares per side of a near
//! cell (default the model's, 3); `FRICTION` the disk's friction coefficient (default the
//! built-in disk's; `-` for it); `EDGE_SUBCELLS` the sub-cells a side of the compared grids'
//! refined cells (`skin.edge_subcells`; the 65-cell reference keeps the default, 3). The
//! calibrated half-space sensor with that body.

#[allow(dead_code)]
// `support::model_at` and `support::tractions_hash` serve the timing examples, `support::dome_mesh` the dome's.
mod support;

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{PinPose, SensorParams, SkinModel};

/// The grids compared, the last the reference.
const GRIDS: [usize; 7] = [13, 17, 19, 25, 33, 49, 65];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let body = args.first().map_or("dome", String::as_str);
    let mut sensor = SensorParams::half_space();
    sensor.skin.model = body.parse::<SkinModel>().map_err(|e| format!("argument 1: {e}"))?;
    let n = support::whole(&args, 1, 40)?;
    let taps = match args.get(2).map_or("flat", String::as_str) {
        "flat" => tacsim_sim::bench::samples(n, tacsim_sim::bench::SAMPLES_SEED),
        "rim" => tacsim_sim::bench::rim_samples(n, tacsim_sim::bench::SAMPLES_SEED),
        other => return Err(format!("argument 3: `{other}` is neither `flat` nor `rim`").into()),
    };
    let subsquares = args.get(3).map(|_| support::whole(&args, 3, 3)).transpose()?;
    let edge_subcells = args.get(5).map(|_| support::whole(&args, 5, 3)).transpose()?;
    let scene = match args.get(4).filter(|f| *f != "-") {
        Some(f) => {
            let friction: f64 = f.parse().map_err(|_| format!("argument 5: `{f}` is not a number"))?;
            let disk = tacsim_sim::builtin_catalogue()?.get("disk")?;
            tacsim_sim::flat_scene(&disk, friction)?
        }
        None => support::disk_scene()?,
    };
    // Per grid, per tap: the pins (blocks as the model takes them, and cell by cell) and the
    // pressure profile of the first tap.
    let mut runs: Vec<Vec<(Vec<PinPose>, Vec<PinPose>)>> = Vec::new();
    let mut profiles = Vec::new();
    for cells in GRIDS {
        let mut s = sensor.clone();
        s.skin.cells_across = cells;
        if let Some(r) = edge_subcells.filter(|_| Some(&cells) != GRIDS.last()) {
            s.skin.edge_subcells = r;
        }
        let mut model = ContactModel::new(&s)?;
        if let Some(sub) = subsquares {
            model.pin_subsquares = sub;
        }
        let mut run = Vec::new();
        for (i, (pose, _)) in taps.iter().enumerate() {
            let mut sim = Simulation::new(&model, &scene, &[*pose]);
            sim.step(*pose)?;
            if i == 0 {
                profiles.push(profile(&sim));
            }
            run.push((sim.pins(), sim.pins_exact()));
        }
        runs.push(run);
    }
    let reference = runs.last().expect("grids");
    println!("{body}, {n} {} taps: pins against 65 cells (mm)", args.get(2).map_or("flat", String::as_str));
    for (cells, run) in GRIDS.iter().zip(&runs) {
        let (mut largest, mut exact, mut blocks, mut squares, mut count) = (0.0f64, 0.0f64, 0.0f64, 0.0, 0usize);
        for ((pins, cell_by_cell), (_, truth)) in run.iter().zip(reference) {
            for ((a, b), t) in pins.iter().zip(cell_by_cell).zip(truth) {
                let d = (a.tip - t.tip).norm();
                (largest, squares, count) = (largest.max(d), squares + d * d, count + 1);
                exact = exact.max((b.tip - t.tip).norm());
                blocks = blocks.max((a.tip - b.tip).norm());
            }
        }
        let rms = (squares / count.max(1) as f64).sqrt();
        println!(
            "{cells:>3} cells: largest {largest:.4}, rms {rms:.4}; cell by cell: largest {exact:.4}; the blocks' part {blocks:.4}"
        );
    }
    println!("pressure (MPa) at x (mm) along y = 0, x < -6 mm, first tap:");
    for (cells, p) in GRIDS.iter().zip(&profiles) {
        println!("{cells:>3} cells: {p}");
    }
    Ok(())
}

/// The pressure of the cells on the footprint's `x` axis left of `x = -6` mm, as `x:p` pairs.
fn profile(sim: &Simulation<'_>) -> String {
    let Some(grid) = sim.grid() else { return "no contact".into() };
    let p = sim.pressure();
    (0..p.len())
        .map(|k| (grid.centre(k), p[k]))
        .filter(|(c, _)| c[1].abs() < 0.5 * grid.cell_mm && c[0] < -6.0)
        .map(|(c, p)| format!("{:.2}:{p:.4}", c[0]))
        .collect::<Vec<_>>()
        .join(" ")
}
