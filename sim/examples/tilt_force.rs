//! The contact's force when the dome presses the built-in `disk`'s flat top with its lowest
//! point at the same indentation, upright and tilted (about the sensor's `x`): whether a rig
//! that yields under the simulated force would press a tilted recording differently from one
//! that yields with the indentation (`tacsim_sim::rig::Press::depth_compliance`). Prints, per
//! tilt (deg) and indentation of the lowest point (mm), the force (N, sensor frame), its size
//! and the size's ratio to the upright press's at the same indentation.
//!
//! `cargo run --release -p tacsim-sim --example tilt_force -- [SENSOR]` (a preset or sensor
//! file; default `tactip-331-dome`). The dome is built once into the cache folder
//! (`TACSIM_CACHE_DIR`).

#[allow(dead_code)] // The support module serves the timing examples too.
mod support;

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{SensorParams, SensorPose};

const TILTS_DEG: [f64; 6] = [0.0, 5.0, 10.0, 15.0, 20.0, 25.0];
const INDENTATIONS_MM: [f64; 6] = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sensor = SensorParams::file_or_preset(args.first().map_or("tactip-331-dome", String::as_str), None)?;
    let model = ContactModel::new(&sensor)?;
    let scene = support::disk_scene()?;
    let radius_mm = sensor.dome.outer_radius_mm;
    let mut upright = [0.0; INDENTATIONS_MM.len()];
    println!("tilt_deg indentation_mm force_x_n force_y_n force_z_n size_n ratio_to_upright");
    for tilt in TILTS_DEG {
        for (i, d) in INDENTATIONS_MM.into_iter().enumerate() {
            // The apex's depth that puts the tilted dome's lowest point `d` below the top.
            let depth_mm = d - radius_mm * (1.0 - tilt.to_radians().cos());
            let pose = SensorPose { x_mm: 0.0, y_mm: 0.0, depth_mm, yaw_deg: 0.0, rx_deg: tilt, ry_deg: 0.0 };
            let mut sim = Simulation::new(&model, &scene, &[pose]);
            let f = sim.step(pose)?.force_n;
            let size = f.iter().map(|v| v * v).sum::<f64>().sqrt();
            if tilt == 0.0 {
                upright[i] = size;
            }
            println!("{tilt} {d} {:.4} {:.4} {:.4} {size:.4} {:.4}", f[0], f[1], f[2], size / upright[i]);
        }
    }
    Ok(())
}
