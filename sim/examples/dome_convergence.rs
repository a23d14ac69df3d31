//! The dome body's pins against its resolution: the largest pin tip difference (mm) between
//! meshes A and B on three paths (a centred tap, a tap across the disk's rim, a slide), the
//! grid fixed.
//!
//! `cargo run --release -p tacsim-sim --example dome_convergence -- [A] [B] [SKIN_LAYERS]`
//! (default 8 10 2). A mesh is `skin.dome_cells` (one lattice for skin and gel), or `CELLSxREFINEMENT` with the skin's
//! elements that many times finer along the surface (`skin.dome_skin_refinement`): `6x2`,
//! or `CELLSxREFINEMENT+GEL_SHELLS` with the gel's outer shells refined too
//! (`skin.dome_refined_gel_shells`): `8x2+1`.
//! Each dome is built once into the cache folder (`TACSIM_CACHE_DIR`).

#[allow(dead_code)] // `support::model_at` and `support::tractions_hash` serve the timing examples.
mod support;

use tacsim_sim::contact::ContactModel;
use tacsim_sim::{PinLayout, PinPose, SensorParams, SensorPath, SensorPose, SkinModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let meshes = [support::dome_mesh(&args, 0, (8, 1, 0))?, support::dome_mesh(&args, 1, (10, 1, 0))?];
    let layers = support::whole(&args, 2, 2)?;
    let scene = support::disk_scene()?;
    let paths = [
        ("centred tap 1.5 mm", SensorPath::tap(SensorPose::new(0.0, 0.0, 1.5, 0.0))),
        ("tap across the rim 1.5 mm", SensorPath::tap(SensorPose::new(48.0, 0.0, 1.5, 0.0))),
        ("slide 2.5 mm at 1.5 mm", SensorPath::slide(SensorPose::new(0.0, 0.0, 1.5, 0.0), [2.5, 0.0], 0.25)?),
    ];
    let mut pins: Vec<Vec<Vec<PinPose>>> = Vec::new();
    for &(n, refinement, gel_shells) in &meshes {
        let mut sensor = SensorParams::half_space();
        sensor.skin.model = SkinModel::Dome;
        sensor.skin.dome_cells = n;
        sensor.skin.dome_skin_layers = layers;
        sensor.skin.dome_skin_refinement = refinement;
        sensor.skin.dome_refined_gel_shells = Some(gel_shells);
        sensor.validate("dome_convergence")?;
        let t = std::time::Instant::now();
        let model = ContactModel::new(&sensor)?;
        println!(
            "{n}x{refinement}+{gel_shells} cells, {layers} skin layers: model in {:.1} s",
            t.elapsed().as_secs_f64()
        );
        let mut per_path = Vec::new();
        for (_, path) in &paths {
            let frames = path.run(&model, &scene)?;
            per_path.push(frames.last().ok_or("no frame")?.pins.clone());
        }
        pins.push(per_path);
    }
    let layout = PinLayout::new(&SensorParams::half_space());
    for (k, (name, _)) in paths.iter().enumerate() {
        let (a, b) = (&pins[0][k], &pins[1][k]);
        let (mut worst, mut at, mut moved, mut squares) = (0.0f64, 0, 0.0f64, 0.0f64);
        for (i, ((p, q), rest)) in a.iter().zip(b).zip(&layout.pins).enumerate() {
            let d = (p.tip - q.tip).norm();
            if d > worst {
                (worst, at) = (d, i);
            }
            squares += d * d;
            moved = moved.max((q.tip - rest.tip).norm());
        }
        let rms = (squares / a.len().max(1) as f64).sqrt();
        let tip = layout.pins[at].tip;
        println!(
            "{name}: largest pin difference {worst:.4} mm at pin {at} ({:.2}, {:.2}) mm, rms {rms:.4} mm ({}x{}+{} vs \
             {}x{}+{} cells; largest motion {moved:.3} mm)",
            tip.x, tip.y, meshes[0].0, meshes[0].1, meshes[0].2, meshes[1].0, meshes[1].1, meshes[1].2
        );
    }
    Ok(())
}
