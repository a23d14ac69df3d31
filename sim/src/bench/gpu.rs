//! The GPU raster and pin product (feature `wgpu`) against the CPU's on the bench's taps.

use std::time::Instant;

use super::report::{GpuPinsBench, GpuRasterBench};
use crate::contact::{ContactModel, Simulation};
use crate::error::Result;
use crate::{PinPose, PinRenderer, Scene, SensorPose};

/// Frames per GPU batch in the bench.
const GPU_FRAMES: usize = 256;

/// [`GpuRasterBench`] on `gpu` for the pins of the contact `states`, cycled to [`GPU_FRAMES`]
/// frames.
pub(super) fn gpu_raster_bench(
    gpu: &crate::Gpu,
    renderer: &PinRenderer,
    states: &[Simulation<'_>],
    single: &rayon::ThreadPool,
) -> Result<GpuRasterBench> {
    let pins: Vec<Vec<PinPose>> = states.iter().map(Simulation::pins).collect();
    let nominal = crate::Variation::NOMINAL;
    let batch: Vec<(&[PinPose], &crate::Variation)> =
        (0..GPU_FRAMES).map(|k| (pins[k % pins.len()].as_slice(), &nominal)).collect();
    let t = Instant::now();
    let cpu: Vec<_> = single.install(|| batch.iter().map(|(p, _)| renderer.render(p)).collect());
    let cpu_ms = t.elapsed().as_secs_f64() * 1e3 / GPU_FRAMES as f64;
    renderer.render_batch(gpu, &batch)?;
    let t = Instant::now();
    let drawn = renderer.render_batch(gpu, &batch)?;
    let gpu_ms = t.elapsed().as_secs_f64() * 1e3 / GPU_FRAMES as f64;
    let differing_pixels =
        cpu.iter().zip(&drawn).map(|(a, b)| a.as_raw().iter().zip(b.as_raw()).filter(|(x, y)| x != y).count()).sum();
    Ok(GpuRasterBench {
        adapter: gpu.adapter().to_owned(),
        frames: GPU_FRAMES,
        cpu_ms_per_frame: cpu_ms,
        gpu_ms_per_frame: gpu_ms,
        differing_pixels,
    })
}

/// The contact states of `taps`, each solved from its own start (the GPU benches' input).
pub(super) fn tap_states<'a>(
    model: &'a ContactModel,
    scene: &'a Scene,
    taps: &[(SensorPose, [f64; 2])],
) -> Result<Vec<Simulation<'a>>> {
    taps.iter()
        .map(|(pose, _)| -> Result<_> {
            let mut sim = Simulation::new(model, scene, &[*pose]);
            sim.step(*pose)?;
            Ok(sim)
        })
        .collect()
}

/// [`GpuPinsBench`] on `gpu` for the contact `states`, cycled to [`GPU_FRAMES`].
pub(super) fn gpu_pins_bench(
    gpu: &crate::Gpu,
    states: &[Simulation<'_>],
    single: &rayon::ThreadPool,
) -> Result<Option<GpuPinsBench>> {
    if !gpu.has_pins() {
        return Ok(None);
    }
    let batch: Vec<&Simulation<'_>> = (0..GPU_FRAMES).map(|k| &states[k % states.len()]).collect();
    let t = Instant::now();
    let cpu: Vec<Vec<PinPose>> = single.install(|| batch.iter().map(|s| s.pins()).collect());
    let cpu_ms = t.elapsed().as_secs_f64() * 1e3 / GPU_FRAMES as f64;
    gpu.pins_batch(&batch)?;
    let t = Instant::now();
    let moved = gpu.pins_batch(&batch)?;
    let gpu_ms = t.elapsed().as_secs_f64() * 1e3 / GPU_FRAMES as f64;
    let max_tip_diff_mm = cpu
        .iter()
        .zip(&moved)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(p, q)| (p.tip - q.tip).norm()))
        .fold(0.0, f64::max);
    Ok(Some(GpuPinsBench {
        adapter: gpu.adapter().to_owned(),
        states: GPU_FRAMES,
        cpu_ms_per_state: cpu_ms,
        gpu_ms_per_state: gpu_ms,
        max_tip_diff_mm,
    }))
}
