//! The GPU raster (feature `wgpu`; `cargo test -p tacsim-sim --features wgpu --test gpu`)
//! against the CPU renderer on the sensor's own images. Without a GPU adapter (or a software
//! Vulkan driver such as lavapipe) it skips with a message; `.ci/run` installs lavapipe and
//! sets `TACSIM_REQUIRE_GPU=1` so that there it must run.
#![cfg(feature = "wgpu")]

use std::path::PathBuf;

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::{ObjectPose, PinRenderer, Scene, SensorParams, SensorPose, Variation};

/// Taps on the square's edge and top at several yaws and depths, rendered one by one on the
/// CPU and as one batch on the GPU at 128, 256 and 420 px: the same images, with the nominal
/// sensor and with a recipe's variations (roll, pin scale, shift and specks on the GPU; a
/// blurred one, which the CPU draws, in the same batch).
#[test]
fn a_batch_of_taps_renders_on_the_gpu_as_on_the_cpu() {
    let Some(gpu) = tacsim_sim::gpu_for_tests() else { return };
    let cat = Catalogue::load_dir(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shapes")).expect("catalogue");
    let mut scene = Scene::new();
    scene.add(cat.get("square").expect("square"), ObjectPose::default()).expect("add");
    let sensor = SensorParams::default();
    let model = ContactModel::new(&sensor);
    let taps: Vec<Vec<tacsim_sim::PinPose>> = (0..12)
        .map(|k| {
            let pose = SensorPose::new(40.0 + k as f64, 0.5 * k as f64, 1.0 + 0.3 * k as f64, 30.0 * k as f64);
            let mut sim = Simulation::new(&model, &scene, &[pose]);
            sim.step(pose).expect("step");
            sim.pins()
        })
        .collect();
    let varied = |k: usize| match k % 3 {
        0 => Variation::NOMINAL,
        1 => Variation {
            shift_px: [1.3, -0.7],
            roll_deg: 7.0 * k as f64,
            pin_scale: 1.08,
            specks: 12,
            speck_seed: k as u64,
            ..Variation::NOMINAL
        },
        _ => Variation { blur_px: 0.8, threshold: 0.45, ..Variation::NOMINAL },
    };
    let variations: Vec<Variation> = (0..taps.len()).map(varied).collect();
    let batch: Vec<(&[tacsim_sim::PinPose], &Variation)> = taps.iter().map(Vec::as_slice).zip(&variations).collect();
    for size in [128, 256, 420] {
        let renderer = PinRenderer::new(&sensor, size).expect("renderer");
        let images = renderer.render_batch(&gpu, &batch).expect("GPU batch");
        let mut differ = 0;
        for ((pins, v), got) in batch.iter().zip(&images) {
            let cpu = renderer.render_varied(pins, v);
            differ += cpu.as_raw().iter().zip(got.as_raw()).filter(|(a, b)| a != b).count();
        }
        println!("{size} px: {differ} pixels differ over {} images", taps.len());
        // f32 decides alike but where a pixel's coverage lies within its rounding of 1/2
        // (`gpu_raster.rs`'s unit test bounds those); none on these images.
        assert_eq!(differ, 0, "{size} px: {differ} pixels differ");
    }
}
