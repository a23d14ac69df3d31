//! Where a sharp edge falls in its cell, and how far the pins of taps across it are from
//! finer grids (issue 31: which reference the goal's 0.03 mm is measured against, and
//! whether a grid laid with the edge at a chosen place converges faster).
//!
//! ```text
//! cargo run --release -p tacsim-sim --example edge_place -- sweep DEPTH X[,X...] CELLS[,CELLS...] [REFERENCE[@F]]
//! cargo run --release -p tacsim-sim --example edge_place -- taps REFERENCE[@F] CELLS[,CELLS...] F[,F...] [TAPS] [--exact]
//! ```
//! The taps: the calibrated half-space sensor over the built-in `disk` (its sharp rim at
//! `x = 50` mm), yaw 0, so the rim runs along the grid's `y` (the sensor's `x` is the world's
//! at yaw 0: the rim at sensor `x = 50 - X`). A grid "at `F`" is the footprint's own grid
//! ([`Footprint::of_path`]) shifted along `x` by under half a cell so that the rim lies at
//! the fraction `F` of its cell's side, counted from the cell's side over the disk (`F` of the
//! cell covered); a grid without `@F` is the footprint's own.
//!
//! - `sweep`: one tap at apex `(X, 0.3)` mm, `DEPTH` mm deep, per `X` and grid: for `F` = 0,
//!   0.1, ..., 0.9 the largest pin-tip difference (mm) from the reference (default 65 cells)
//!   and the force's difference (%); every cell on every pin (`Simulation::pins_exact`).
//! - `taps`: `TAPS` (default 40) taps with the bench's rim ranges (apex x 44-54 mm, y -5-5 mm,
//!   depth 1-5 mm; SplitMix64 seed 7) on each grid, its own and at each `F`, against the
//!   reference (default at 0.5): the largest, fifth largest and median pin error over the taps;
//!   the grids' pins grouped as the bench's and the datasets' are, or every cell on every pin
//!   with `--exact` (the reference always).

#[allow(dead_code)]
// `support::whole` and `support::tractions_hash` serve the timing examples, `support::dome_mesh` the dome's.
mod support;

use rayon::prelude::*;
use support::{disk_scene, model_at};
use tacsim_sim::contact::{ContactModel, Footprint, Simulation};
use tacsim_sim::{PinPose, Scene, SensorPose};

/// The disk's rim (world `x`, mm).
const RIM_X_MM: f64 = 50.0;

/// A grid: cells across the footprint, and the fraction of its cell the rim is placed at.
#[derive(Clone, Copy)]
struct Layout {
    cells: usize,
    at: Option<f64>,
}

impl Layout {
    /// `CELLS` or `CELLS@F`.
    fn parse(s: &str) -> Result<Self, String> {
        let (n, at) = match s.split_once('@') {
            Some((n, f)) => (n, Some(fraction(f)?)),
            None => (s, None),
        };
        Ok(Self { cells: cells(n)?, at })
    }
}

/// Cells across the footprint.
fn cells(s: &str) -> Result<usize, String> {
    s.trim().parse().map_err(|_| format!("`{s}` is not a whole number of cells"))
}

/// A fraction of a cell's side, in `[0, 1)`.
fn fraction(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(f) if (0.0..1.0).contains(&f) => Ok(f),
        _ => Err(format!("fraction `{s}`: a number in [0, 1)")),
    }
}

/// A comma-separated list of `item`s.
fn list<T>(s: &str, item: impl Fn(&str) -> Result<T, String>) -> Result<Vec<T>, String> {
    s.split(',').map(item).collect()
}

/// A number.
fn number(s: &str) -> Result<f64, String> {
    s.trim().parse().map_err(|_| format!("`{s}` is not a number"))
}

/// The footprint of a tap at `pose`, its grid shifted to put the rim at `at` of its cell.
fn footprint(model: &ContactModel, scene: &Scene, pose: SensorPose, at: Option<f64>) -> Footprint {
    let mut fp = Footprint::of_path(model, scene, &[pose]);
    if let (Some(f), Some(g)) = (at, fp.grid.as_mut()) {
        let rim = RIM_X_MM - pose.x_mm;
        let left = g.centre_mm[0] - 0.5 * g.nx as f64 * g.cell_mm;
        let t = (rim - left) / g.cell_mm;
        let shift = ((t - t.floor() - f + 0.5).rem_euclid(1.0) - 0.5) * g.cell_mm;
        g.centre_mm[0] += shift;
    }
    fp
}

/// A tap's force (N) and pins (every cell on every pin with `exact`), the rim at `at` of its
/// cell (the footprint's own grid with `None`).
fn tap(
    model: &ContactModel,
    scene: &Scene,
    pose: SensorPose,
    at: Option<f64>,
    exact: bool,
) -> tacsim_sim::Result<(f64, Vec<PinPose>)> {
    let mut sim = Simulation::on_footprint(model, scene, footprint(model, scene, pose, at));
    let force = sim.step(pose)?.force_n[2];
    Ok((force, if exact { sim.pins_exact() } else { sim.pins() }))
}

/// The largest distance between corresponding pin tips (mm).
fn largest(a: &[PinPose], b: &[PinPose]) -> f64 {
    a.iter().zip(b).map(|(a, b)| (a.tip - b.tip).norm()).fold(0.0, f64::max)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: edge_place sweep DEPTH X[,X...] CELLS[,...] [REFERENCE[@F]] | \
                 edge_place taps REFERENCE[@F] CELLS[,...] F[,...] [TAPS] [--exact]";
    let arg = |i: usize| args.get(i).map(String::as_str).ok_or(usage);
    let scene = disk_scene()?;
    match arg(0)? {
        "sweep" => {
            let depth = number(arg(1)?)?;
            let xs = list(arg(2)?, number)?;
            let grids = list(arg(3)?, cells)?;
            let reference = args.get(4).map_or(Ok(Layout { cells: 65, at: None }), |s| Layout::parse(s))?;
            let fine = model_at(reference.cells)?;
            for &x in &xs {
                let pose = SensorPose::new(x, 0.3, depth, 0.0);
                let (f_ref, pins_ref) = tap(&fine, &scene, pose, reference.at, true)?;
                for &n in &grids {
                    let model = model_at(n)?;
                    let mut line = format!("x {x:.2} mm, {n} cells:");
                    for i in 0..10 {
                        let f = i as f64 / 10.0;
                        let (force, pins) = tap(&model, &scene, pose, Some(f), true)?;
                        let error = largest(&pins, &pins_ref);
                        line += &format!(" {f:.1}: {error:.4} / {:+.2}%", 100.0 * (force / f_ref - 1.0));
                    }
                    println!("{line}");
                }
            }
        }
        "taps" => {
            let mut reference = Layout::parse(arg(1)?)?;
            reference.at = reference.at.or(Some(0.5));
            let grids = list(arg(2)?, cells)?;
            let fractions = list(arg(3)?, fraction)?;
            let count: usize = match args.get(4).filter(|a| !a.starts_with("--")) {
                Some(s) => s.parse().ok().filter(|n| *n > 0).ok_or(format!("TAPS `{s}`: a whole number above 0"))?,
                None => 40,
            };
            let exact = args.iter().any(|a| a == "--exact");
            let mut rng = tacsim_data::SplitMix64(7);
            let poses: Vec<SensorPose> = (0..count)
                .map(|_| {
                    let (x, y, depth) = (rng.next_f64(), rng.next_f64(), rng.next_f64());
                    SensorPose::new(44.0 + 10.0 * x, -5.0 + 10.0 * y, 1.0 + 4.0 * depth, 0.0)
                })
                .collect();
            let fine = model_at(reference.cells)?;
            let refs: Vec<Vec<PinPose>> = poses
                .par_iter()
                .map(|p| tap(&fine, &scene, *p, reference.at, true).map(|(_, pins)| pins))
                .collect::<Result<_, _>>()?;
            let places: Vec<Option<f64>> = std::iter::once(None).chain(fractions.iter().copied().map(Some)).collect();
            for &n in &grids {
                let model = model_at(n)?;
                for at in &places {
                    let errors: Vec<f64> = poses
                        .par_iter()
                        .zip(&refs)
                        .map(|(p, r)| tap(&model, &scene, *p, *at, exact).map(|(_, pins)| largest(&pins, r)))
                        .collect::<Result<_, _>>()?;
                    let mut sorted = errors.clone();
                    sorted.sort_by(|a, b| b.total_cmp(a));
                    let worst = errors.iter().position(|e| *e == sorted[0]).unwrap_or(0);
                    let place = at.map_or("its own grid".to_string(), |f| format!("rim at {f}"));
                    println!(
                        "{n} cells, {place}: largest {:.4} mm (x {:.2}, depth {:.2} mm); fifth {:.4}; median {:.4}",
                        sorted[0],
                        poses[worst].x_mm,
                        poses[worst].depth_mm,
                        sorted[4.min(sorted.len() - 1)],
                        sorted[sorted.len() / 2]
                    );
                }
            }
        }
        _ => return Err(usage.into()),
    }
    Ok(())
}
