//! How the pins of one tap across a sharp edge converge with the grid (issue 31, cut cells):
//! the largest pin-tip difference from the finest grid given, per grid.
//!
//! ```text
//! cargo run --release -p tacsim-sim --example edge_convergence -- X DEPTH YAW [CELLS[/SUB],...] [cuts]
//! ```
//! With `cuts`, cells the edge cuts carry their load on the covered part
//! (the sensor's `skin.cut_edges`). A grid written `CELLS/SUB` solves the cells along the edge
//! again at `SUB x SUB` sub-cells for the pins (`ContactModel::edge_subcells`; 0: none);
//! without it, the model's default.
//! The tap: the calibrated half-space sensor over the built-in `disk` (its sharp rim at
//! `x = 50` mm), apex at `(X, 0.3)` mm, `DEPTH` mm deep, yaw `YAW` deg; grids of `CELLS`
//! cells across the footprint (default `13,17,25,33,65,97`; the last is the reference), every
//! cell acting on every pin (`Simulation::pins_exact`).

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{ObjectPose, Scene, SensorParams, SensorPose};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let number = |i: usize, default: f64| -> Result<f64, String> {
        args.get(i).map_or(Ok(default), |s| s.parse().map_err(|_| format!("argument {}: `{s}` is not a number", i + 1)))
    };
    let (x, depth, yaw) = (number(0, 50.0)?, number(1, 2.0)?, number(2, 0.0)?);
    let whole = |v: &str| v.trim().parse::<usize>().map_err(|_| format!("CELLS: `{v}` is not a whole number"));
    let grids: Vec<(usize, Option<usize>)> = match args.get(3) {
        Some(s) => s
            .split(',')
            .map(|v| match v.split_once('/') {
                Some((n, sub)) => Ok((whole(n)?, Some(whole(sub)?))),
                None => Ok((whole(v)?, None)),
            })
            .collect::<Result<_, String>>()?,
        None => [13, 17, 25, 33, 65, 97].map(|n| (n, None)).to_vec(),
    };
    let cut_edges = args.get(4).is_some_and(|a| a == "cuts");
    let catalogue = tacsim_sim::builtin_catalogue()?;
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk")?, ObjectPose::default())?;
    let pose = SensorPose::new(x, 0.3, depth, yaw);
    let mut runs = Vec::new();
    for &(n, sub) in &grids {
        let mut sensor = SensorParams::half_space();
        sensor.skin.cells_across = n;
        sensor.validate("CELLS")?;
        sensor.skin.cut_edges = cut_edges;
        let mut model = ContactModel::new(&sensor).expect("contact model");
        if let Some(sub) = sub {
            model.edge_subcells = sub;
        }
        let mut sim = Simulation::new(&model, &scene, &[pose]);
        let force = sim.step(pose)?.force_n[2];
        let cell = sim.grid().map_or(0.0, |g| g.cell_mm);
        runs.push((n, sub.unwrap_or(model.edge_subcells), cell, force, sim.pins_exact()));
    }
    let Some((_, _, _, _, reference)) = runs.last() else { return Ok(()) };
    println!("cells  sub-cells  cell (mm)  force (N)  largest pin error vs the last (mm)");
    for (n, sub, cell, force, pins) in &runs {
        let err = pins.iter().zip(reference).map(|(a, b)| (a.tip - b.tip).norm()).fold(0.0, f64::max);
        println!("{n:>5}  {sub:>9}  {cell:>9.3}  {force:>9.3}  {err:.4}");
    }
    Ok(())
}
