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
    let sensor = SensorParams::half_space();
    let model = ContactModel::new(&sensor).expect("contact model");
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
            pin_jitter_px: 0.4,
            jitter_seed: k as u64,
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
        // The f64 raster decides as the CPU does (f32 only where the adapter lacks f64:
        // `gpu/raster.rs`'s unit test bounds that one).
        assert_eq!(differ, 0, "{size} px: {differ} pixels differ");
    }
}

/// The pin product on the GPU against [`Simulation::pins`], state by state, for a batch of
/// taps and slide steps (shear and its history in the tractions) on the square's edge, top
/// and corner: the calibrated sensor (half-space), the edge2d preset (skin patch: seven
/// points a pin) and the calibrated sensor on a skin-on-gel body (layered kernels, pins
/// between table depths). Bound 1e-9 mm on tips and 1e-9 on axes: the GPU runs the CPU's sums
/// in f64 in the CPU's order (`gpu/pins.rs`), so only the kernels' last bits (a fused
/// multiply-add, a division) may differ; the target is 1e-5 mm.
#[test]
fn the_gpu_moves_the_pins_as_the_cpu_does() {
    let Some(gpu) = tacsim_sim::gpu_for_tests() else { return };
    if !gpu.has_pins() {
        assert!(
            !std::env::var("TACSIM_REQUIRE_GPU").is_ok_and(|v| v == "1"),
            "TACSIM_REQUIRE_GPU=1 but {} has no f64 in shaders",
            gpu.adapter()
        );
        eprintln!("skipped: {} has no f64 in shaders", gpu.adapter());
        return;
    }
    let cat = Catalogue::load_dir(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shapes")).expect("catalogue");
    let mut scene = Scene::new();
    scene.add(cat.get("square").expect("square"), ObjectPose::default()).expect("add");
    let calibrated = SensorParams::half_space();
    let mut gel = calibrated.clone();
    gel.skin.model = tacsim_sim::SkinModel::SkinOnGel;
    let sensors = [
        ("calibrated", calibrated),
        ("edge2d", SensorParams::preset("tactip-331-edge2d").expect("preset")),
        ("skin-on-gel", gel),
    ];
    for (name, sensor) in &sensors {
        let model = ContactModel::new(sensor).expect("contact model");
        // Taps on the edge, the top and a corner, at yaws and depths.
        let taps: Vec<SensorPose> = (0..6)
            .map(|k| SensorPose::new(40.0 + 2.0 * k as f64, 0.5 * k as f64, 1.0 + 0.5 * k as f64, 35.0 * k as f64))
            .chain([SensorPose::new(40.0, 40.0, 2.0, 10.0)])
            .collect();
        let mut sims: Vec<Simulation<'_>> = taps
            .iter()
            .map(|&pose| {
                let mut sim = Simulation::new(&model, &scene, &[pose]);
                sim.step(pose).expect("tap");
                sim
            })
            .collect();
        // A slide across the edge: pressed, then 2 mm in 0.5 mm steps (stick and slip).
        let path: Vec<SensorPose> = (0..5).map(|k| SensorPose::new(44.0 + 0.5 * k as f64, 3.0, 2.5, 20.0)).collect();
        let mut slide = Simulation::new(&model, &scene, &path);
        for &pose in &path {
            slide.step(pose).expect("slide");
        }
        sims.push(slide);
        // And a state off the stimulus: the undeformed pins.
        let off = SensorPose::new(-80.0, 0.0, 1.0, 0.0);
        let mut lifted = Simulation::new(&model, &scene, &[off]);
        lifted.step(off).expect("off");
        sims.push(lifted);
        // The taps on the edge refine the cells along it (their sub-cells' own point forces).
        assert!(sims.iter().any(|s| s.refined_cells() > 0), "{name}: no state refines the cells along the edge");
        let refs: Vec<&Simulation<'_>> = sims.iter().collect();
        let got = gpu.pins_batch(&refs).expect("GPU pins");
        assert_eq!(got.len(), sims.len());
        let (mut tip, mut axis, mut moved) = (0.0f64, 0.0f64, 0.0f64);
        for (sim, gpu_pins) in sims.iter().zip(&got) {
            let cpu = sim.pins();
            assert_eq!(cpu.len(), gpu_pins.len());
            for ((a, b), rest) in cpu.iter().zip(gpu_pins).zip(model.layout.poses()) {
                tip = tip.max((a.tip - b.tip).norm());
                axis = axis.max((a.axis - b.axis).norm());
                moved = moved.max((a.tip - rest.tip).norm());
            }
        }
        println!("{name}: pins up to {moved:.3} mm from rest; GPU against CPU: tips {tip:.2e} mm, axes {axis:.2e}");
        assert!(moved > 0.1, "{name}: the states hardly move the pins ({moved} mm)");
        assert!(tip < 1e-9 && axis < 1e-9, "{name}: tips {tip:e} mm, axes {axis:e} apart (bound 1e-9)");
    }
}
