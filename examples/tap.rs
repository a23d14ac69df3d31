//! A runnable start: the calibrated TacTip over a half-space (`SensorParams::half_space()`;
//! `SensorParams::default()` is its finite-element dome, whose first use builds its table in
//! a minute or two) tapped 1.5 mm onto the built-in disk's flat top, the contact solved, the
//! pins moved and the camera's binarised image written.
//!
//! ```text
//! cargo run --release --example tap -- [OUT.png]   (default: tap.png)
//! ```

use std::path::PathBuf;

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{ObjectPose, PinRenderer, PngDepth, Scene, SensorParams, SensorPose, builtin_catalogue, write_png};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "tap.png".into()));
    // The sensor: the calibrated TacTip (331 pins, half-space skin); `SensorParams::load` reads a file.
    let sensor = SensorParams::half_space();
    // The scene: the built-in disk (100 mm across) at the world's origin.
    let mut scene = Scene::new();
    scene.add(builtin_catalogue()?.get("disk")?, ObjectPose::default())?;
    // The tap: the apex 20 mm from the disk's centre, 1.5 mm into it, yaw 0.
    let pose = SensorPose::new(20.0, 0.0, 1.5, 0.0);
    let model = ContactModel::new(&sensor)?;
    let mut sim = Simulation::new(&model, &scene, &[pose]);
    let report = sim.step(pose)?;
    println!(
        "{} cells in contact, force {:.3} N along the sensor's axis, {} slipping",
        report.contact_cells, report.force_n[2], report.slip_cells
    );
    // The pins and the camera's image of them (256 px).
    let image = PinRenderer::new(&sensor, 256)?.render(&sim.pins());
    write_png(&out, &image, PngDepth::OneBit)?;
    println!("wrote {}", out.display());
    Ok(())
}
