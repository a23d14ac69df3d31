//! The pins against the contact grid, per body: the bench's taps (`tacsim bench`'s samples on
//! the built-in `disk`, its flat top or across its rim) on grids of 13 to 49 cells across the
//! footprint, each pin's tip against the same tap on 65 cells (every cell on every pin, as the
//! bench's grid rows take their reference): the largest and the rms difference (mm), the same
//! for the 65-cell product summed cell by cell (no blocks), and the blocks' own part; then the
//! contact's pressure along the footprint's `x` axis (`y = 0`, `x < -6` mm) for the first tap
//! on every grid, where the contact ends.
//!
//! ```text
//! cargo run --release -p tacsim-sim --example grid_pins -- [BODY] [TAPS] [flat|rim] [SUBSQUARES] [FRICTION] [EDGE_SUBCELLS] [SEED] [SENSOR]
//! ```
//! `BODY` `half-space`, `layer`, `skin-on-gel` or `dome` (default `dome`, built once into the
//! cache folder); `TAPS` (default 40); `SUBSQUARES` the pins' sub-squares per side of a near
//! cell (default the model's, 3); `FRICTION` the disk's friction coefficient (default the
//! built-in disk's; `-` for it); `EDGE_SUBCELLS` the sub-cells a side of the compared grids'
//! refined cells (`skin.edge_subcells`; the 65-cell reference keeps the default, 3; `-` for
//! it); `SEED` the taps' seed (default the bench's); `SENSOR` a preset or sensor file whose
//! skin, dome and pins are taken (default the calibrated half-space preset), with `BODY` as its
//! skin's model. For each grid the three worst pins are printed too: the tap, its depth, the
//! pin's tip at rest (mm, sensor frame) and its distance from the disk's rim (mm, positive
//! over the disk).

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
    let mut sensor = match args.get(7) {
        None => SensorParams::half_space(),
        Some(name) => SensorParams::file_or_preset(name, None)?,
    };
    sensor.skin.model = body.parse::<SkinModel>().map_err(|e| format!("argument 1: {e}"))?;
    let n = support::whole(&args, 1, 40)?;
    let seed = match args.get(6) {
        Some(s) => s.parse().map_err(|_| format!("argument 7: `{s}` is not a seed (a whole number)"))?,
        None => tacsim_sim::bench::SAMPLES_SEED,
    };
    let taps = match args.get(2).map_or("flat", String::as_str) {
        "flat" => tacsim_sim::bench::samples(n, seed),
        "rim" => tacsim_sim::bench::rim_samples(n, seed),
        other => return Err(format!("argument 3: `{other}` is neither `flat` nor `rim`").into()),
    };
    let subsquares = args.get(3).map(|_| support::whole(&args, 3, 3)).transpose()?;
    let edge_subcells = args.get(5).filter(|a| *a != "-").map(|_| support::whole(&args, 5, 3)).transpose()?;
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
    let rest = Simulation::new(&ContactModel::new(&sensor)?, &scene, &[taps[0].0]).pins();
    for (cells, run) in GRIDS.iter().zip(&runs) {
        worst_pins(*cells, run, reference, &taps, &rest);
    }
    println!("pressure (MPa) at x (mm) along y = 0, x < -6 mm, first tap:");
    for (cells, p) in GRIDS.iter().zip(&profiles) {
        println!("{cells:>3} cells: {p}");
    }
    Ok(())
}

/// The three worst pins of a grid's `run` against the `reference`: the error (mm), the tap and
/// its depth, the pin and its tip at `rest` (sensor frame, mm), its distance from the disk's
/// rim (mm, the disk 50 mm in radius at the origin; positive past it), the error and the
/// reference's motion (mm).
fn worst_pins(
    cells: usize,
    run: &[(Vec<PinPose>, Vec<PinPose>)],
    reference: &[(Vec<PinPose>, Vec<PinPose>)],
    taps: &[(tacsim_sim::SensorPose, [f64; 2])],
    rest: &[PinPose],
) {
    let mut all = Vec::new();
    for (t, ((pins, _), (_, truth))) in run.iter().zip(reference).enumerate() {
        for (i, (a, b)) in pins.iter().zip(truth).enumerate() {
            all.push(((a.tip - b.tip).norm(), t, i, a.tip - b.tip, b.tip - rest[i].tip));
        }
    }
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (e, t, i, d, m) in all.iter().take(3) {
        let (pose, _) = taps[*t];
        let r = rest[*i].tip;
        let yaw = pose.yaw_deg.to_radians();
        let (x, y) = (pose.x_mm + r.x * yaw.cos() - r.y * yaw.sin(), pose.y_mm + r.x * yaw.sin() + r.y * yaw.cos());
        println!(
            "{cells} cells: error {e:.3} tap {t} depth {:.2} pin {i} at ({:.2}, {:.2}) rim {:+.3}; error ({:+.3}, {:+.3}, {:+.3}), motion ({:+.3}, {:+.3}, {:+.3})",
            pose.depth_mm,
            r.x,
            r.y,
            x.hypot(y) - 50.0,
            d.x,
            d.y,
            d.z,
            m.x,
            m.y,
            m.z
        );
    }
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
