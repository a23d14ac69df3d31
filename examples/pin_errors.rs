//! The bench's pin error per grid, tap by tap (issue 31: which grid keeps the pins within
//! 0.03 mm of a fine reference, and where the error comes from): `tacsim bench`'s 40 taps on
//! the disk's top (`flat`) or across its rim (`rim`), solved on each grid and on a reference
//! grid whose pins sum every cell (`pins_exact`); prints the largest pin-tip difference, the
//! five largest taps' and the median tap's.
//!
//! ```text
//! cargo run --release --example pin_errors -- flat|rim REFERENCE GRIDS [--exact] [--subcells N]
//!     [--frictionless] [--by-tap]
//! ```
//! `REFERENCE` cells across the footprint of the reference (the bench's: 65); `GRIDS` a
//! comma-separated list (`17,25,33`); `--exact`: the grids' pins sum every cell too (the
//! bench's and the datasets' pins group far cells); `--subcells N`: the grids' sub-cells
//! along an edge (the sensor's `skin.edge_subcells`; the reference keeps the default);
//! `--frictionless`: the disk without friction (no shear but the coupling's: which error is
//! the normal problem's); `--by-tap`: a line per tap, its error split into the pins' mean
//! shift and what is left about it, and its normal and `x` force against the reference's.
//! The taps are the bench's own (`tacsim_sim::bench::samples` and `rim_samples`, its seeds).

use rayon::prelude::*;
use tacsim_sim::bench::{RIM_SEED, SAMPLES_SEED, disk_scene_with_friction, rim_samples, samples};
use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{PinPose, SensorParams, SensorPose};

/// One tap's pins against the reference's (mm): the largest tip difference, the mean
/// difference's length (a shift of every pin alike) and the largest difference about that
/// mean; and the two forces (N).
struct TapError {
    largest: f64,
    mean_shift: f64,
    about_mean: f64,
    force: [f64; 3],
    reference_force: [f64; 3],
}

impl TapError {
    fn of(got: &[PinPose], reference: &[PinPose], force: [f64; 3], reference_force: [f64; 3]) -> Self {
        let diffs: Vec<_> = got.iter().zip(reference).map(|(a, b)| a.tip - b.tip).collect();
        let Some(first) = diffs.first() else {
            return Self { largest: 0.0, mean_shift: 0.0, about_mean: 0.0, force, reference_force };
        };
        let mean = diffs[1..].iter().fold(*first, |sum, d| sum + d) / diffs.len() as f64;
        let largest = diffs.iter().map(|d| d.norm()).fold(0.0, f64::max);
        let about_mean = diffs.iter().map(|d| (d - mean).norm()).fold(0.0, f64::max);
        Self { largest, mean_shift: mean.norm(), about_mean, force, reference_force }
    }
}

/// The calibrated half-space sensor's contact model at `cells` cells across the footprint.
fn model_at(cells: usize) -> Result<ContactModel, Box<dyn std::error::Error>> {
    let mut sensor = SensorParams::half_space();
    sensor.skin.cells_across = cells;
    sensor.validate("GRIDS")?;
    Ok(ContactModel::new(&sensor)?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: pin_errors flat|rim REFERENCE GRIDS [--exact] [--subcells N] [--frictionless] [--by-tap]";
    let flat = match args.first().map(String::as_str) {
        Some("flat") => true,
        Some("rim") => false,
        _ => return Err(usage.into()),
    };
    let reference: usize = args.get(1).ok_or(usage)?.parse().map_err(|_| format!("REFERENCE: {usage}"))?;
    let grids: Vec<usize> = args
        .get(2)
        .ok_or(usage)?
        .split(',')
        .map(|s| s.parse().map_err(|_| format!("GRIDS `{s}`: {usage}")))
        .collect::<Result<_, _>>()?;
    let exact = args.iter().any(|a| a == "--exact");
    let frictionless = args.iter().any(|a| a == "--frictionless");
    let by_tap = args.iter().any(|a| a == "--by-tap");
    let subcells: Option<usize> = match args.iter().position(|a| a == "--subcells") {
        Some(i) => Some(args.get(i + 1).and_then(|s| s.parse().ok()).ok_or(usage)?),
        None => None,
    };
    let scene = disk_scene_with_friction(frictionless.then_some(0.0))?;
    let poses: Vec<SensorPose> =
        if flat { samples(40, SAMPLES_SEED) } else { rim_samples(40, RIM_SEED) }.into_iter().map(|(p, _)| p).collect();
    // A tap's pins and its force on the skin (N, sensor frame).
    let pins = |m: &ContactModel, pose: SensorPose, exact: bool| -> tacsim_sim::Result<(Vec<PinPose>, [f64; 3])> {
        let mut sim = Simulation::new(m, &scene, &[pose]);
        let force = sim.step(pose)?.force_n;
        Ok((if exact { sim.pins_exact() } else { sim.pins() }, force))
    };
    let fine = model_at(reference)?;
    let refs: Vec<(Vec<PinPose>, [f64; 3])> =
        poses.par_iter().map(|p| pins(&fine, *p, true)).collect::<Result<_, _>>()?;
    for &cells in &grids {
        let mut model = model_at(cells)?;
        if let Some(s) = subcells {
            model.edge_subcells = s;
        }
        let taps: Vec<TapError> = poses
            .par_iter()
            .zip(&refs)
            .map(|(p, (r, r_force))| {
                let (got, force) = pins(&model, *p, exact)?;
                Ok(TapError::of(&got, r, force, *r_force))
            })
            .collect::<tacsim_sim::Result<_>>()?;
        if by_tap {
            for (i, (t, p)) in taps.iter().zip(&poses).enumerate() {
                println!(
                    "{cells} cells, tap {i}: x {:.2} y {:.2} depth {:.2} mm yaw {:.2} deg; largest {:.4} mm, mean shift {:.4}, \
                     largest about it {:.4}; normal force {:.3} N against {:.3} ({:+.2}%), x {:+.4} N against {:+.4}",
                    p.x_mm,
                    p.y_mm,
                    p.depth_mm,
                    p.yaw_deg,
                    t.largest,
                    t.mean_shift,
                    t.about_mean,
                    t.force[2],
                    t.reference_force[2],
                    100.0 * (t.force[2] / t.reference_force[2] - 1.0),
                    t.force[0],
                    t.reference_force[0]
                );
            }
        }
        let errors: Vec<f64> = taps.iter().map(|t| t.largest).collect();
        let mut sorted = errors.clone();
        sorted.sort_by(|a, b| b.total_cmp(a));
        let worst = errors.iter().position(|e| *e == sorted[0]).unwrap_or(0);
        let p = poses[worst];
        let top: Vec<String> = sorted[..5].iter().map(|e| format!("{e:.4}")).collect();
        println!(
            "{} {cells} cells{}: largest {:.4} mm (tap {worst}: x {:.2} y {:.2} depth {:.2} mm); five largest {}; median {:.4}",
            if flat { "flat" } else { "rim" },
            if exact { ", every cell on every pin" } else { "" },
            sorted[0],
            p.x_mm,
            p.y_mm,
            p.depth_mm,
            top.join(" "),
            sorted[sorted.len() / 2]
        );
    }
    Ok(())
}
