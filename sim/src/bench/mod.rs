//! The bench behind `tacsim bench`: tap and slide throughput on all threads, where a tap's
//! time goes, what the engine's skips save, and run time against error (grid size against the
//! Hertz and Cattaneo errors and the pins' error against a fine grid, slide step against the
//! pins' error against fine steps), measured on the built-in disk with a given sensor. The
//! command line sets the sensor from its flags, draws the plot and prints the table or JSON.

mod curve;
#[cfg(feature = "wgpu")]
mod gpu;
mod rates;
mod report;
mod samples;

pub use report::{BenchReport, Breakdown, CurvePoint, GpuPinsBench, GpuRasterBench, PassRates, Skips};
pub use samples::{
    RIM_SEED, SAMPLES_SEED, SLIDE_MM, STEP_MM, disk_scene, disk_scene_with_friction, rim_samples, samples,
};

use crate::contact::{ContactModel, validate};
use crate::error::{Result, SimError};
use crate::{PinRenderer, SensorParams};

/// Fewest taps and slides a bench times.
pub const MIN_SAMPLES: usize = 4;

/// Measures `sensor` over `samples` taps and slides (at least [`MIN_SAMPLES`]) on the
/// current rayon pool, the single-thread figures on a pool of one; with `gpu` (feature
/// `wgpu`) the GPU raster and pin product against the CPU's too.
pub fn measure(
    sensor: &SensorParams,
    samples_n: usize,
    #[cfg(feature = "wgpu")] gpu: Option<&crate::Gpu>,
) -> Result<BenchReport> {
    if samples_n < MIN_SAMPLES {
        return Err(SimError::invalid(
            "--samples",
            "samples",
            format!("must be at least {MIN_SAMPLES}, got {samples_n}"),
        ));
    }
    let scene = disk_scene()?;
    let model = ContactModel::new(sensor)?;
    let renderer = PinRenderer::new(sensor, 256)?;
    let poses = samples(samples_n, SAMPLES_SEED);
    let rates = rates::Rates::measure(&model, &scene, &renderer, &poses)?;
    let few = &poses[..samples_n.min(40)];
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(|e| SimError::Analysis {
        source_name: "the bench".into(),
        reason: format!("a one-thread pool for the single-thread figures: {e}"),
    })?;
    let tap_breakdown = single.install(|| rates::tap_breakdown(&model, &scene, &renderer, few))?;
    let skips = single.install(|| rates::measure_skips(sensor, &scene, few))?;
    let rim = rim_samples(few.len(), RIM_SEED);
    let mut curve = curve::grid_curve(sensor, &scene, &renderer, few, &rim, &single)?;
    curve.extend(curve::step_curve(&model, &scene, &renderer, &poses[..samples_n.min(8)], &single)?);
    #[cfg(feature = "wgpu")]
    let (gpu_raster, gpu_pins) = match gpu {
        Some(gpu) => {
            let states = gpu::tap_states(&model, &scene, few)?;
            (
                Some(gpu::gpu_raster_bench(gpu, &renderer, &states, &single)?),
                gpu::gpu_pins_bench(gpu, &states, &single)?,
            )
        }
        None => (None, None),
    };
    #[cfg(not(feature = "wgpu"))]
    let (gpu_raster, gpu_pins) = (None, None);
    Ok(BenchReport {
        threads: rayon::current_num_threads(),
        cut_edges: sensor.skin.cut_edges,
        edge_subcells: sensor.skin.edge_subcells,
        cells_across: sensor.skin.cells_across,
        tap_frames_per_s: rates.warm.tap_frames_per_s,
        slide_samples_per_s: rates.warm.slide_samples_per_s,
        first_pass: rates.first,
        mean_contact_cells: rates.mean_contact_cells,
        hertz_force_rel_err: validate::hertz(sensor.skin.cells_across)?.force_rel_err,
        tap_breakdown,
        skips,
        curve,
        gpu_raster,
        gpu_pins,
    })
}
