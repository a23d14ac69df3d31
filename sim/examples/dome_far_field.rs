//! How the dome body's contact plane answers a smooth load, against the flat skin-on-gel layers
//! of the same skin and gel: the displacement (mm per N) under a force spread as the far
//! field's Gaussian patch at the apex, pressing and shearing, at 0-8 mm from it, for
//! `skin.model = "dome"` and `"skin-on-gel"`. The dome's gel is closed in by the skin and the
//! base, so it cannot flow away sideways as the layers' does.
//!
//! `cargo run --release -p tacsim-sim --example dome_far_field -- [SENSOR.toml]` (default:
//! the calibrated preset at its gel). The dome is built once into the cache folder
//! (`TACSIM_CACHE_DIR`).

use tacsim_sim::contact::{Component, ContactModel, Grid, Product};
use tacsim_sim::{SensorParams, SkinModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let sensor = match std::env::args().nth(1) {
        Some(path) => SensorParams::load(std::path::Path::new(&path))?,
        None => SensorParams::half_space(),
    };
    let grid = Grid { nx: 81, ny: 81, cell_mm: 0.25, centre_mm: [0.0, 0.0] };
    let mut rows: Vec<(&str, Vec<[f64; 2]>)> = Vec::new();
    let mut spread = 0.0;
    for (name, model) in [("dome", SkinModel::Dome), ("skin-on-gel", SkinModel::SkinOnGel)] {
        let mut sensor = sensor.clone();
        sensor.skin.model = model;
        let model = ContactModel::new(&sensor)?;
        if let Some(dome) = model.body.far_field() {
            spread = dome.spread_mm();
        }
        let s = spread;
        let g: Vec<f64> = (0..grid.len())
            .map(|k| {
                let c = grid.centre(k);
                (-(c[0] * c[0] + c[1] * c[1]) / (s * s)).exp()
            })
            .collect();
        let total = g.iter().sum::<f64>() * grid.cell_mm * grid.cell_mm;
        let t: Vec<f64> = g.iter().map(|v| v / total).collect();
        let op = model.body.operator(grid);
        let product = |c: Component| {
            let mut out = vec![0.0; grid.len()];
            op.apply(&[(c, &t)], &mut out, Product::Fft);
            out
        };
        let (zz, xx) = (product(Component::Zz), product(Component::Xx));
        rows.push((name, (0..=4).map(|i| 40 * 81 + 40 + 8 * i).map(|k| [zz[k], xx[k]]).collect()));
    }
    println!("a 1 N force spread as a Gaussian patch of s = {spread:.3} mm at the apex (mm/N)");
    println!("{:>6}  {:>22}  {:>22}", "r mm", "pressing: dome / layers", "shear: dome / layers");
    for i in 0..=4 {
        let (d, l) = (rows[0].1[i], rows[1].1[i]);
        println!("{:>6.1}  {:>10.4} / {:<10.4}  {:>10.4} / {:<10.4}", 2.0 * i as f64, d[0], l[0], d[1], l[1]);
    }
    Ok(())
}
