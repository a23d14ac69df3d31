//! The bench's pin error per grid, tap by tap (issue 31: which grid keeps the pins within
//! 0.03 mm of a fine reference, and where the error comes from): `tacsim bench`'s 40 taps on
//! the disk's top (`flat`) or across its rim (`rim`), solved on each grid and on a reference
//! grid whose pins sum every cell (`pins_exact`); prints the largest pin-tip difference, the
//! five largest taps' and the median tap's.
//!
//! ```text
//! cargo run --release --example pin_errors -- flat|rim REFERENCE GRIDS [--exact] [--subcells N]
//! ```
//! `REFERENCE` cells across the footprint of the reference (the bench's: 65); `GRIDS` a
//! comma-separated list (`17,25,33`); `--exact`: the grids' pins sum every cell too (the
//! bench's and the datasets' pins group far cells); `--subcells N`: the grids' sub-cells
//! along an edge (the sensor's `skin.edge_subcells`; the reference keeps the default).
//! The taps are the bench's own (`tacsim::bench::samples` and `rim_samples`, its seeds).

use rayon::prelude::*;
use tacsim::bench::{RIM_SEED, SAMPLES_SEED, disk_scene, rim_samples, samples};
use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{PinPose, SensorParams, SensorPose};

/// The calibrated default sensor's contact model at `cells` cells across the footprint.
fn model_at(cells: usize) -> Result<ContactModel, Box<dyn std::error::Error>> {
    let mut sensor = SensorParams::default();
    sensor.skin.cells_across = cells;
    sensor.validate("GRIDS")?;
    Ok(ContactModel::new(&sensor))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: pin_errors flat|rim REFERENCE GRIDS [--exact] [--subcells N]";
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
    let subcells: Option<usize> = match args.iter().position(|a| a == "--subcells") {
        Some(i) => Some(args.get(i + 1).and_then(|s| s.parse().ok()).ok_or(usage)?),
        None => None,
    };
    let scene = disk_scene()?;
    let poses: Vec<SensorPose> =
        if flat { samples(40, SAMPLES_SEED) } else { rim_samples(40, RIM_SEED) }.into_iter().map(|(p, _)| p).collect();
    let pins = |m: &ContactModel, pose: SensorPose, exact: bool| -> tacsim_sim::Result<Vec<PinPose>> {
        let mut sim = Simulation::new(m, &scene, &[pose]);
        sim.step(pose)?;
        Ok(if exact { sim.pins_exact() } else { sim.pins() })
    };
    let fine = model_at(reference)?;
    let refs: Vec<Vec<PinPose>> = poses.par_iter().map(|p| pins(&fine, *p, true)).collect::<Result<_, _>>()?;
    for &cells in &grids {
        let mut model = model_at(cells)?;
        if let Some(s) = subcells {
            model.edge_subcells = s;
        }
        let errors: Vec<f64> = poses
            .par_iter()
            .zip(&refs)
            .map(|(p, r)| {
                let got = pins(&model, *p, exact)?;
                Ok(got.iter().zip(r).map(|(a, b)| (a.tip - b.tip).norm()).fold(0.0, f64::max))
            })
            .collect::<tacsim_sim::Result<_>>()?;
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
