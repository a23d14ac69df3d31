//! The dome body's pins against its resolution: the largest pin tip difference (mm) between
//! `skin.dome_cells` A and B on three paths (a centred tap, a tap across the disk's rim, a
//! slide), the grid fixed.
//!
//! `cargo run --release -p tacsim-sim --example dome_convergence -- [A] [B] [SKIN_LAYERS]`
//! (default 8 10 2). Each dome is built once into the cache folder (`TACSIM_CACHE_DIR`).

#[allow(dead_code)] // `support::model_at` and `support::tractions_hash` serve the timing examples.
mod support;

use tacsim_sim::contact::ContactModel;
use tacsim_sim::{PinLayout, PinPose, SensorParams, SensorPath, SensorPose, SkinModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let cells = [support::whole(&args, 0, 8)?, support::whole(&args, 1, 10)?];
    let layers = support::whole(&args, 2, 2)?;
    let scene = support::disk_scene()?;
    let paths = [
        ("centred tap 1.5 mm", SensorPath::tap(SensorPose::new(0.0, 0.0, 1.5, 0.0))),
        ("tap across the rim 1.5 mm", SensorPath::tap(SensorPose::new(48.0, 0.0, 1.5, 0.0))),
        ("slide 2.5 mm at 1.5 mm", SensorPath::slide(SensorPose::new(0.0, 0.0, 1.5, 0.0), [2.5, 0.0], 0.25)?),
    ];
    let mut pins: Vec<Vec<Vec<PinPose>>> = Vec::new();
    for &n in &cells {
        let mut sensor = SensorParams::default();
        sensor.skin.model = SkinModel::Dome;
        sensor.skin.dome_cells = n;
        sensor.skin.dome_skin_layers = layers;
        sensor.validate("dome_convergence")?;
        let t = std::time::Instant::now();
        let model = ContactModel::new(&sensor)?;
        println!("{n} cells, {layers} skin layers: model in {:.1} s", t.elapsed().as_secs_f64());
        let mut per_path = Vec::new();
        for (_, path) in &paths {
            let frames = path.run(&model, &scene)?;
            per_path.push(frames.last().ok_or("no frame")?.pins.clone());
        }
        pins.push(per_path);
    }
    let layout = PinLayout::new(&SensorParams::default());
    for (k, (name, _)) in paths.iter().enumerate() {
        let (a, b) = (&pins[0][k], &pins[1][k]);
        let (mut worst, mut moved) = (0.0f64, 0.0f64);
        for ((p, q), rest) in a.iter().zip(b).zip(&layout.pins) {
            worst = worst.max((p.tip - q.tip).norm());
            moved = moved.max((q.tip - rest.tip).norm());
        }
        println!(
            "{name}: largest pin difference {worst:.4} mm ({} vs {} cells; largest motion {moved:.3} mm)",
            cells[0], cells[1]
        );
    }
    Ok(())
}
