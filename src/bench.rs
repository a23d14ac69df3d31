//! `tacsim bench`: tap and slide throughput on all cores, where the time goes, and run time
//! against error (grid size against the Hertz and Cattaneo errors, slide step size against the
//! pin error of a fine-step reference), with an SVG plot.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::Serialize;
use tacsim_sim::contact::validate;
use tacsim_sim::contact::{ContactModel, PIN_SUBSQUARES, Simulation};
use tacsim_sim::{ObjectPose, PinPose, PinRenderer, Scene, SensorParams, SensorPath, SensorPose, SkinModel};

/// Slide length of the paper's protocol (mm).
pub const SLIDE_MM: f64 = 2.5;
/// Default slide step (mm).
pub const STEP_MM: f64 = 0.25;

/// Deterministic generator (SplitMix64) for the sample poses.
struct Rng(tacsim_data::SplitMix64);

impl Rng {
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.next_f64()
    }
}

/// The seed of the bench's taps and slides on the disk's top ([`samples`]).
pub const SAMPLES_SEED: u64 = 1;
/// The seed of the bench's taps across the disk's rim ([`rim_samples`]).
pub const RIM_SEED: u64 = 2;

/// Sample poses over the disk: the paper's tap ranges (depth 1-5 mm, any yaw), centre within
/// 20 mm of the disk's centre, and a slide direction. The bench's: `n` from [`SAMPLES_SEED`]
/// (its grid curve takes the first 40).
pub fn samples(n: usize, seed: u64) -> Vec<(SensorPose, [f64; 2])> {
    let mut rng = Rng(tacsim_data::SplitMix64(seed));
    (0..n)
        .map(|_| {
            let pose = SensorPose::new(
                rng.range(-20.0, 20.0),
                rng.range(-20.0, 20.0),
                rng.range(1.0, 5.0),
                rng.range(-180.0, 180.0),
            );
            let a = rng.range(0.0, std::f64::consts::TAU);
            (pose, [SLIDE_MM * a.cos(), SLIDE_MM * a.sin()])
        })
        .collect()
}

/// Taps across the disk's rim (its edge at x = 50 mm): centre 44-54 mm from the disk's centre
/// (the edge 6 mm inside to 4 mm outside the apex), depth 1-5 mm, any yaw. The bench's: 40
/// from [`RIM_SEED`].
pub fn rim_samples(n: usize, seed: u64) -> Vec<(SensorPose, [f64; 2])> {
    let mut rng = Rng(tacsim_data::SplitMix64(seed));
    (0..n)
        .map(|_| {
            let pose = SensorPose::new(
                rng.range(44.0, 54.0),
                rng.range(-5.0, 5.0),
                rng.range(1.0, 5.0),
                rng.range(-180.0, 180.0),
            );
            (pose, [0.0, 0.0])
        })
        .collect()
}

/// The rates of one pass over the bench's samples ([`BenchReport::first_pass`]).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PassRates {
    /// Taps per second on all threads.
    pub tap_frames_per_s: f64,
    /// Slides per second on all threads.
    pub slide_samples_per_s: f64,
}

/// Time per stage of a tap, single thread (ms per frame).
#[derive(Debug, Serialize)]
pub struct Breakdown {
    /// Footprint probe and grid (ray casts).
    pub footprint_ms: f64,
    /// Gap ray casts and the normal and tangential solves.
    pub solve_ms: f64,
    /// Pin displacements.
    pub pins_ms: f64,
    /// 256x256 render.
    pub render_ms: f64,
}

/// What each skip saves: the time with the skip (as the engine runs) against the time without it
/// (ms, one thread, mean over the sample poses).
#[derive(Debug, Serialize)]
pub struct Skips {
    /// A step out of contact (gap ray casts only, cached undeformed pins) against a tap's step.
    pub no_contact_step_ms: [f64; 2],
    /// A tap's step (normal solve only, tangential skipped) against a slide step on the same
    /// contact (normal and tangential solves).
    pub tap_without_tangential_ms: [f64; 2],
    /// Footprint probe and gap on a scene of one stimulus against the same with 48 more
    /// stimuli 300 mm away (the query BVH skips them).
    pub far_stimuli_ms: [f64; 2],
    /// A tap on the footprint grid (25 cells) against a grid of the same cell size over the
    /// whole dome (43 cells).
    pub footprint_grid_ms: [f64; 2],
    /// Pins only against pins and a 256x256 render.
    pub no_render_ms: [f64; 2],
}

/// One point of the run-time-vs-error curve.
#[derive(Debug, Serialize)]
pub struct CurvePoint {
    /// `grid` (cells across the footprint) or `step` (slide step, mm).
    pub knob: &'static str,
    /// The knob's value.
    pub value: f64,
    /// Run time per sample, single thread (ms): a tap for `grid`, a slide for `step`.
    pub ms_per_sample: f64,
    /// Hertz force relative error on this grid (grid points).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hertz_force_rel_err: Option<f64>,
    /// Cattaneo shift relative error at `nu = 0` on this grid (grid points).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cattaneo_shift_rel_err: Option<f64>,
    /// Largest pin-tip difference (mm): step points from a 0.025 mm-step reference slide; grid
    /// points from taps on a 65-cell grid summing every cell on every pin.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pin_err_mm: Option<f64>,
    /// Grid points: the same for taps across the disk's rim (an edge through the contact).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_pin_err_mm: Option<f64>,
    /// Grid points: both pin errors (top, rim) with one point force per cell in the pin
    /// product, reference included (`ContactModel::pin_subsquares` = 1: the product before
    /// the sub-squares).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point_force_pin_err_mm: Option<[f64; 2]>,
}

/// The answer of `tacsim bench --json`.
#[derive(Debug, Serialize)]
pub struct BenchReport {
    /// Threads used for the throughput figures.
    pub threads: usize,
    /// Cells across the footprint (sensor default).
    pub cells_across: usize,
    /// Whether cells a sharp edge cuts carry their load on the covered part (the sensor's
    /// `skin.cut_edges`, on unless `--no-edge-cuts`), every grid's and the reference's.
    pub cut_edges: bool,
    /// Sub-cells per side of the cells along a sharp edge (the sensor's `skin.edge_subcells`,
    /// `--edge-subcells`), every grid's; the reference's stay at the default, 3.
    pub edge_subcells: usize,
    /// Taps per second on all threads (contact solve + pins + 256x256 render), on a warm
    /// model: the median of three passes over the samples after a first ([`Rates`]).
    pub tap_frames_per_s: f64,
    /// Slides per second on all threads (touch down 2.5 mm away, slide in 0.25 mm steps, capture
    /// pins and a 256x256 image), on a warm model as the taps.
    pub slide_samples_per_s: f64,
    /// The same rates in the first pass over the samples, on a new model: with its first-use
    /// costs, as a run's first samples have them ([`Rates`]).
    pub first_pass: PassRates,
    /// Mean contact cells of the taps.
    pub mean_contact_cells: f64,
    /// Hertz force error of the default grid.
    pub hertz_force_rel_err: f64,
    /// Where a tap's time goes.
    pub tap_breakdown: Breakdown,
    /// What the skips save.
    pub skips: Skips,
    /// Run time against error.
    pub curve: Vec<CurvePoint>,
    /// The GPU raster against the CPU's (`--device gpu` or `auto` with a GPU adapter).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_raster: Option<GpuRasterBench>,
    /// The GPU pin product against the CPU's (`--device gpu` or `auto`, where the adapter has
    /// f64 in shaders).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_pins: Option<GpuPinsBench>,
}

/// The GPU pin product (`--device gpu`, feature `wgpu`) against the CPU's on the same contact
/// states: the bench's taps, cycled to a batch.
#[derive(Debug, Serialize)]
pub struct GpuPinsBench {
    /// The adapter (as [`GpuRasterBench::adapter`]).
    pub adapter: String,
    /// Contact states in the batch.
    pub states: usize,
    /// The CPU's pin product, one thread (ms per state): the work per state the GPU path
    /// takes off the CPU threads.
    pub cpu_ms_per_state: f64,
    /// The GPU batch's wall time per state, packing, upload, dispatch, readback and the pins'
    /// move included (ms per state; after one warm-up batch).
    pub gpu_ms_per_state: f64,
    /// Largest distance between a GPU pin tip and the CPU's (mm).
    pub max_tip_diff_mm: f64,
}

/// The batched GPU raster (`--device gpu`, feature `wgpu`) against the CPU's on the same
/// frames: 256 px images of the bench's taps.
#[derive(Debug, Serialize)]
pub struct GpuRasterBench {
    /// The adapter: name, type and backend. A `Cpu` type is a software driver (lavapipe), whose
    /// figures say nothing of a GPU's speed.
    pub adapter: String,
    /// Frames in the batch.
    pub frames: usize,
    /// The CPU's render (discs, raster, framing), one thread (ms per frame): the work per frame
    /// the GPU path takes off the CPU threads.
    pub cpu_ms_per_frame: f64,
    /// The GPU batch's wall time per frame, upload, dispatch, readback and framing included
    /// (ms per frame; after one warm-up batch).
    pub gpu_ms_per_frame: f64,
    /// Pixels where the GPU's images differ from the CPU's (only where a pixel's coverage is
    /// within f32 rounding of 1/2, `sim/src/gpu/raster.rs`).
    pub differing_pixels: usize,
}

/// Frames per GPU batch in the bench.
#[cfg(feature = "wgpu")]
const GPU_FRAMES: usize = 256;

/// [`GpuRasterBench`] on `gpu` for the pins of the contact `states`, cycled to [`GPU_FRAMES`]
/// frames.
#[cfg(feature = "wgpu")]
fn gpu_raster_bench(
    gpu: &tacsim_sim::Gpu,
    renderer: &PinRenderer,
    states: &[Simulation<'_>],
    single: &rayon::ThreadPool,
) -> Result<GpuRasterBench> {
    let pins: Vec<Vec<PinPose>> = states.iter().map(Simulation::pins).collect();
    let nominal = tacsim_sim::Variation::NOMINAL;
    let batch: Vec<(&[PinPose], &tacsim_sim::Variation)> =
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
#[cfg(feature = "wgpu")]
fn tap_states<'a>(
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
#[cfg(feature = "wgpu")]
fn gpu_pins_bench(
    gpu: &tacsim_sim::Gpu,
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

/// The bench's scene: the built-in `disk` (100 mm across) at the origin.
pub fn disk_scene() -> Result<Scene> {
    disk_scene_with_friction(None)
}

/// [`disk_scene`] with the skin-stimulus friction `friction` where one is given (`Some(0.0)`:
/// no shear but the coupling's), else the disk's own.
pub fn disk_scene_with_friction(friction: Option<f64>) -> Result<Scene> {
    let catalogue = tacsim_sim::builtin_catalogue()?;
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk")?.with_friction(friction), ObjectPose::default())?;
    Ok(scene)
}

/// Taps/s and slides/s on all threads, over the same samples several times.
///
/// A pass of 200 taps takes about 0.15 s on 2 threads, and a new model's first samples pay
/// what a dataset's thousands share: the tables a model keeps (the fine grid of the sub-cells
/// along an edge, once per grid shape: about 40 ms on one core at 25 cells), the first touches
/// of the workers' memory. One pass read 1,085-1,131 taps/s where 1,000 samples read
/// 1,320-1,436 (issue 31). The rates reported are the median of [`WARM_PASSES`] passes after
/// the first, the rate a run holds (this machine's speed also swings by 15% within seconds);
/// the first pass is kept beside them.
struct Rates {
    /// Each rate's median over the warm passes.
    warm: PassRates,
    /// The first pass (taps first, on a new model).
    first: PassRates,
    mean_contact_cells: f64,
}

/// Timed passes after the first ([`Rates`]).
const WARM_PASSES: usize = 3;

impl Rates {
    fn measure(
        model: &ContactModel,
        scene: &Scene,
        renderer: &PinRenderer,
        poses: &[(SensorPose, [f64; 2])],
    ) -> Result<Self> {
        let pass = || -> Result<(PassRates, f64)> {
            let (tap_frames_per_s, cells) = tap_rate(model, scene, renderer, poses)?;
            let slide_samples_per_s = slide_rate(model, scene, renderer, poses, STEP_MM)?;
            Ok((PassRates { tap_frames_per_s, slide_samples_per_s }, cells))
        };
        let (first, mean_contact_cells) = pass()?;
        let warm: Vec<PassRates> = (0..WARM_PASSES).map(|_| Ok(pass()?.0)).collect::<Result<_>>()?;
        let median = |rate: fn(&PassRates) -> f64| {
            let mut v: Vec<f64> = warm.iter().map(rate).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let warm = PassRates {
            tap_frames_per_s: median(|r| r.tap_frames_per_s),
            slide_samples_per_s: median(|r| r.slide_samples_per_s),
        };
        Ok(Self { warm, first, mean_contact_cells })
    }
}

fn tap_rate(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    poses: &[(SensorPose, [f64; 2])],
) -> Result<(f64, f64)> {
    let start = Instant::now();
    let cells: Vec<usize> = poses
        .par_iter()
        .map(|(pose, _)| {
            let frames = captured(model, scene, &SensorPath::tap(*pose), renderer)?;
            Ok(frames.first().map_or(0, |f| f.report.contact_cells))
        })
        .collect::<Result<_>>()?;
    let rate = poses.len() as f64 / start.elapsed().as_secs_f64();
    Ok((rate, cells.iter().sum::<usize>() as f64 / cells.len().max(1) as f64))
}

/// A path run and each captured frame rendered, as a dataset sample is (the images are
/// timed, not kept).
fn captured(
    model: &ContactModel,
    scene: &Scene,
    path: &SensorPath,
    renderer: &PinRenderer,
) -> tacsim_sim::Result<Vec<tacsim_sim::Capture>> {
    let frames = path.run(model, scene)?;
    for f in &frames {
        std::hint::black_box(renderer.render(&f.pins));
    }
    Ok(frames)
}

fn slide_rate(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    poses: &[(SensorPose, [f64; 2])],
    step: f64,
) -> Result<f64> {
    let start = Instant::now();
    poses.par_iter().try_for_each(|(pose, from)| -> Result<()> {
        captured(model, scene, &SensorPath::slide(*pose, *from, step)?, renderer)?;
        Ok(())
    })?;
    Ok(poses.len() as f64 / start.elapsed().as_secs_f64())
}

fn ms_single<T>(n: usize, mut f: impl FnMut(usize) -> Result<T>) -> Result<f64> {
    let start = Instant::now();
    for i in 0..n {
        f(i)?;
    }
    Ok(start.elapsed().as_secs_f64() * 1e3 / n as f64)
}

/// Cells across the footprint of the reference taps for the grid rows' pin error.
const PIN_REFERENCE_CELLS: usize = 65;

/// `tacsim bench`'s flags.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchOptions {
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Taps and slides to time (4 to 100,000).
    #[arg(long, default_value_t = 200, value_parser = crate::flags::bench_samples)]
    pub samples: usize,
    /// Write the run-time-vs-error plot (SVG) here.
    #[arg(long, default_value = "bench.svg")]
    pub plot: PathBuf,
    /// Cells across the contact footprint for the throughput figures (odd; default: the
    /// sensor's, 25).
    #[arg(long)]
    pub cells: Option<usize>,
    /// Elastic body behind the skin for the throughput figures: half-space, layer,
    /// skin-on-gel or dome (default: the sensor's).
    #[arg(long)]
    pub skin: Option<SkinModel>,
    /// Sub-cells per side of the cells along a sharp edge (the sensor's `skin.edge_subcells`,
    /// 0 to 6; default 3), for the throughput figures and every grid's row; the 65-cell
    /// reference keeps the default.
    #[arg(long)]
    pub edge_subcells: Option<usize>,
    /// Also time the batched GPU raster and pin product against the CPU's: gpu (a build
    /// with `--features wgpu` and a GPU adapter; a software one's figures say nothing of a
    /// GPU's speed) or auto.
    #[arg(long, value_enum, default_value = "cpu")]
    pub device: crate::device::DeviceChoice,
    /// Every cell wholly in or out of contact by the gap at its centre, the reference
    /// grid's included (the sensor's `skin.cut_edges = false`; by default cells a sharp
    /// edge cuts carry their load on the covered part, `docs/experiments/contact.md`, "Cut cells").
    #[arg(long)]
    pub no_edge_cuts: bool,
}

/// Runs the benchmark; returns the text to print.
pub fn run(o: &BenchOptions) -> Result<String> {
    let (samples_n, json, plot) = (o.samples, o.json, o.plot.as_path());
    anyhow::ensure!(samples_n >= 4, "--samples must be at least 4, got {samples_n}");
    crate::commands::ensure_file_writable(plot)?;
    #[cfg(feature = "wgpu")]
    let gpu = crate::device::gpu(o.device)?;
    #[cfg(not(feature = "wgpu"))]
    crate::device::check(o.device)?;
    let sensor = bench_sensor(o)?;
    let scene = disk_scene()?;
    let model = ContactModel::new(&sensor)?;
    let renderer = PinRenderer::new(&sensor, 256)?;
    let poses = samples(samples_n, SAMPLES_SEED);
    let rates = Rates::measure(&model, &scene, &renderer, &poses)?;
    let few = &poses[..samples_n.min(40)];
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let tap_breakdown = single.install(|| tap_breakdown(&model, &scene, &renderer, few))?;
    let skips = single.install(|| measure_skips(&sensor, &scene, few))?;
    let rim = rim_samples(few.len(), RIM_SEED);
    let mut curve = grid_curve(&sensor, &scene, &renderer, few, &rim, &single)?;
    curve.extend(step_curve(&model, &scene, &renderer, &poses[..samples_n.min(8)], &single)?);
    #[cfg(feature = "wgpu")]
    let (gpu_raster, gpu_pins) = match &gpu {
        Some(gpu) => {
            let states = tap_states(&model, &scene, few)?;
            (Some(gpu_raster_bench(gpu, &renderer, &states, &single)?), gpu_pins_bench(gpu, &states, &single)?)
        }
        None => (None, None),
    };
    #[cfg(not(feature = "wgpu"))]
    let (gpu_raster, gpu_pins) = (None, None);
    let report = BenchReport {
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
    };
    draw(&report, plot).with_context(|| format!("writing the plot {}", plot.display()))?;
    Ok(if json { serde_json::to_string_pretty(&report)? + "\n" } else { report.table(plot) })
}

/// The calibrated sensor with the bench's `--cells`, `--skin`, `--edge-subcells` and cut cells
/// at edges unless `--no-edge-cuts`.
fn bench_sensor(o: &BenchOptions) -> Result<SensorParams> {
    let mut sensor = SensorParams::default();
    sensor.skin.cut_edges = !o.no_edge_cuts;
    if let Some(n) = o.cells {
        sensor.skin.cells_across = n;
        sensor.validate("--cells")?;
    }
    if let Some(r) = o.edge_subcells {
        sensor.skin.edge_subcells = r;
        sensor.validate("--edge-subcells")?;
    }
    if let Some(m) = o.skin {
        sensor.skin.model = m;
    }
    Ok(sensor)
}

/// Where a tap's time goes (ms per tap, in the calling thread's pool): footprint grid, gap
/// and solve, pins, render.
fn tap_breakdown(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    taps: &[(SensorPose, [f64; 2])],
) -> Result<Breakdown> {
    let (mut footprint, mut solve, mut pins_t, mut render_t) = (0.0, 0.0, 0.0, 0.0);
    for (pose, _) in taps {
        let t = Instant::now();
        let mut sim = Simulation::new(model, scene, &[*pose]);
        footprint += t.elapsed().as_secs_f64();
        let t = Instant::now();
        sim.step(*pose)?;
        // The sub-cells along an edge, found when first asked for, are the solve's.
        std::hint::black_box(sim.refined_cells());
        solve += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pins = sim.pins();
        pins_t += t.elapsed().as_secs_f64();
        let t = Instant::now();
        std::hint::black_box(renderer.render(&pins));
        render_t += t.elapsed().as_secs_f64();
    }
    let per = |s: f64| s * 1e3 / taps.len() as f64;
    Ok(Breakdown { footprint_ms: per(footprint), solve_ms: per(solve), pins_ms: per(pins_t), render_ms: per(render_t) })
}

/// Run time against error over the grid: per grid size, one thread's ms per tap (solve, pins,
/// render), the Hertz and Cattaneo errors of `tacsim validate` at that grid, and the largest
/// pin error of the taps (`taps` on the disk's top, `rim` across its edge) against the same
/// taps on the fine reference grid.
fn grid_curve(
    sensor: &SensorParams,
    scene: &Scene,
    renderer: &PinRenderer,
    taps: &[(SensorPose, [f64; 2])],
    rim: &[(SensorPose, [f64; 2])],
    single: &rayon::ThreadPool,
) -> Result<Vec<CurvePoint>> {
    let at_grid = |cells: usize, subsquares: usize| -> Result<ContactModel> {
        let mut s = sensor.clone();
        s.skin.cells_across = cells;
        let mut model = ContactModel::new(&s)?;
        model.pin_subsquares = subsquares;
        Ok(model)
    };
    let tap_pins = |m: &ContactModel, pose: SensorPose, exact: bool| -> Result<Vec<_>> {
        let mut sim = Simulation::new(m, scene, &[pose]);
        sim.step(pose)?;
        Ok(if exact { sim.pins_exact() } else { sim.pins() })
    };
    // Pin reference: the same taps on a fine grid, every cell on every pin, with the same
    // pin product (sub-squares near the pins, or one point force per cell).
    let reference = |subsquares: usize, poses: &[(SensorPose, [f64; 2])]| -> Result<Vec<Vec<PinPose>>> {
        let mut fine = at_grid(PIN_REFERENCE_CELLS, subsquares)?;
        fine.edge_subcells = tacsim_sim::DEFAULT_EDGE_SUBCELLS;
        poses.par_iter().map(|(p, _)| tap_pins(&fine, *p, true)).collect()
    };
    let largest_error =
        |m: &ContactModel, poses: &[(SensorPose, [f64; 2])], reference: &[Vec<PinPose>]| -> Result<f64> {
            let mut err = 0.0f64;
            for ((p, _), r) in poses.iter().zip(reference) {
                for (a, b) in tap_pins(m, *p, false)?.iter().zip(r) {
                    err = err.max((a.tip - b.tip).norm());
                }
            }
            Ok(err)
        };
    let products = [PIN_SUBSQUARES, 1];
    let references: Vec<_> =
        products.iter().map(|&s| Ok((reference(s, taps)?, reference(s, rim)?))).collect::<Result<_>>()?;
    let mut curve = Vec::new();
    for cells in [9usize, 13, 17, 25, 33] {
        // One model per pin product; the first (the default) is also timed.
        let [a, b] = products.map(|s| at_grid(cells, s));
        let models = [a?, b?];
        let m = &models[0];
        // The errors first: their taps, flat and across the rim, build the model's kept
        // tables, so the time is a warm model's, as the rates' ([`Rates`]).
        let mut errors = [[0.0; 2]; 2];
        for ((e, m), (flat, edge)) in errors.iter_mut().zip(&models).zip(&references) {
            *e = [largest_error(m, taps, flat)?, largest_error(m, rim, edge)?];
        }
        let ms = single
            .install(|| ms_single(taps.len(), |i| Ok(captured(m, scene, &SensorPath::tap(taps[i].0), renderer)?)))?;
        curve.push(CurvePoint {
            knob: "grid",
            value: cells as f64,
            ms_per_sample: ms,
            hertz_force_rel_err: Some(validate::hertz(cells)?.force_rel_err.abs()),
            cattaneo_shift_rel_err: Some(validate::cattaneo_with(cells, 0.0)?.shift_rel_err.abs()),
            pin_err_mm: Some(errors[0][0]),
            edge_pin_err_mm: Some(errors[0][1]),
            point_force_pin_err_mm: Some(errors[1]),
        });
    }
    Ok(curve)
}

/// Run time against error over the slide step: per step (mm), one thread's ms per slide and
/// the largest pin error at the slide's end against 0.025 mm steps.
fn step_curve(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    slides: &[(SensorPose, [f64; 2])],
    single: &rayon::ThreadPool,
) -> Result<Vec<CurvePoint>> {
    let reference: Vec<_> =
        slides.iter().map(|(p, f)| SensorPath::slide(*p, *f, 0.025)?.run(model, scene)).collect::<Result<_, _>>()?;
    let mut curve = Vec::new();
    for step in [2.5, 1.0, 0.5, 0.25, 0.1] {
        let mut err = 0.0f64;
        let ms = single.install(|| {
            ms_single(slides.len(), |i| {
                let (p, f) = slides[i];
                let frames = captured(model, scene, &SensorPath::slide(p, f, step)?, renderer)?;
                for (a, b) in frames[0].pins.iter().zip(&reference[i][0].pins) {
                    err = err.max((a.tip - b.tip).norm());
                }
                Ok(())
            })
        })?;
        curve.push(CurvePoint {
            knob: "step",
            value: step,
            ms_per_sample: ms,
            hertz_force_rel_err: None,
            cattaneo_shift_rel_err: None,
            pin_err_mm: Some(err),
            edge_pin_err_mm: None,
            point_force_pin_err_mm: None,
        });
    }
    Ok(curve)
}

impl BenchReport {
    /// The report as the text table `tacsim bench` prints, naming the plot written.
    fn table(&self, plot: &Path) -> String {
        let b = &self.tap_breakdown;
        let mut out = format!(
            "{} threads, {} cells across the footprint (mean {:.0} in contact), {} x {} sub-cells along edges{}\n\
             taps:   {:>9.1} frames/s  (solve + pins + 256x256 render; first pass {:.1})\n\
             slides: {:>9.1} samples/s (touch down {SLIDE_MM} mm away, {STEP_MM} mm steps, capture; first pass {:.1})\n\
             a tap, one thread: footprint {:.3} ms, gap + solve {:.3} ms, pins {:.3} ms, render {:.3} ms\n",
            self.threads,
            self.cells_across,
            self.mean_contact_cells,
            self.edge_subcells,
            self.edge_subcells,
            if self.cut_edges { "" } else { ", whole cells at edges (--no-edge-cuts)" },
            self.tap_frames_per_s,
            self.first_pass.tap_frames_per_s,
            self.slide_samples_per_s,
            self.first_pass.slide_samples_per_s,
            b.footprint_ms,
            b.solve_ms,
            b.pins_ms,
            b.render_ms,
        );
        let k = &self.skips;
        out.push_str(&format!(
            "skips (with / without, ms, one thread): no contact {:.3} / {:.3}; tap without tangential {:.3} / {:.3}; \
             48 far stimuli {:.3} / {:.3} (probe + gap, without = with them); footprint grid {:.3} / {:.3}; \
             no render {:.3} / {:.3}\n\n",
            k.no_contact_step_ms[0],
            k.no_contact_step_ms[1],
            k.tap_without_tangential_ms[0],
            k.tap_without_tangential_ms[1],
            k.far_stimuli_ms[0],
            k.far_stimuli_ms[1],
            k.footprint_grid_ms[0],
            k.footprint_grid_ms[1],
            k.no_render_ms[0],
            k.no_render_ms[1],
        ));
        out.push_str(&format!(
            "{:<6} {:>7} {:>12} {:>12} {:>12} {:>12} {:>12} {:>18}\n",
            "knob", "value", "ms/sample", "hertz force", "cattaneo", "pin err mm", "on edge mm", "point forces mm"
        ));
        let opt = |v: Option<f64>| v.map_or("-".to_owned(), |x| format!("{x:.2e}"));
        for p in &self.curve {
            out.push_str(&format!(
                "{:<6} {:>7} {:>12.3} {:>12} {:>12} {:>12} {:>12} {:>18}\n",
                p.knob,
                p.value,
                p.ms_per_sample,
                opt(p.hertz_force_rel_err),
                opt(p.cattaneo_shift_rel_err),
                opt(p.pin_err_mm),
                opt(p.edge_pin_err_mm),
                p.point_force_pin_err_mm.map_or("-".to_owned(), |[a, b]| format!("{a:.2e} / {b:.2e}"))
            ));
        }
        if let Some(g) = &self.gpu_raster {
            out.push_str(&format!(
                "GPU raster on {}: {} frames of 256 px, {:.3} ms a frame (CPU, one thread: {:.3} ms); {} pixels differ\n",
                g.adapter, g.frames, g.gpu_ms_per_frame, g.cpu_ms_per_frame, g.differing_pixels
            ));
        }
        if let Some(g) = &self.gpu_pins {
            out.push_str(&format!(
                "GPU pins on {}: {} states, {:.3} ms a state (CPU, one thread: {:.3} ms); tips up to {:.1e} mm apart\n",
                g.adapter, g.states, g.gpu_ms_per_state, g.cpu_ms_per_state, g.max_tip_diff_mm
            ));
        }
        out.push_str(&format!("plot: {}\n", plot.display()));
        out
    }
}

fn measure_skips(sensor: &SensorParams, scene: &Scene, poses: &[(SensorPose, [f64; 2])]) -> Result<Skips> {
    let model = ContactModel::new(sensor)?;
    let n = poses.len();
    let mean = |total: f64| total * 1e3 / n as f64;
    let (mut off, mut tap, mut slide) = (0.0, 0.0, 0.0);
    for (pose, from) in poses {
        let target = *pose;
        let start = SensorPose { x_mm: pose.x_mm + 0.1 * from[0], y_mm: pose.y_mm + 0.1 * from[1], ..*pose };
        let mut sim = Simulation::new(&model, scene, &[start, target]);
        let t = Instant::now();
        sim.step(SensorPose { depth_mm: -1.0, ..target })?;
        off += t.elapsed().as_secs_f64();
        let t = Instant::now();
        sim.step(start)?;
        tap += t.elapsed().as_secs_f64();
        let t = Instant::now();
        sim.step(target)?;
        slide += t.elapsed().as_secs_f64();
    }
    // Far stimuli: the same scene plus 48 disks on a 300 mm lattice.
    let catalogue = tacsim_sim::builtin_catalogue()?;
    let mut crowded = disk_scene()?;
    for i in 0..7i32 {
        for j in 0..7i32 {
            if (i, j) != (3, 3) {
                let position_mm = [300.0 * (i - 3) as f64, 300.0 * (j - 3) as f64, 0.0];
                crowded.add(catalogue.get("disk")?, ObjectPose { position_mm, yaw_deg: 0.0 })?;
            }
        }
    }
    let probe = |s: &Scene| -> f64 {
        let t = Instant::now();
        for (pose, _) in poses {
            let mut sim = Simulation::new(&model, s, &[*pose]);
            std::hint::black_box(sim.step(SensorPose { depth_mm: -1.0, ..*pose }).map(|r| r.in_contact).ok());
        }
        mean(t.elapsed().as_secs_f64())
    };
    let far = [probe(scene), probe(&crowded)];
    // Footprint grid against a whole-dome grid of the same cell size.
    let tap_ms = |cells: usize| -> Result<f64> {
        let mut s = sensor.clone();
        s.skin.cells_across = cells;
        let m = ContactModel::new(&s)?;
        let t = Instant::now();
        for (pose, _) in poses {
            let mut sim = Simulation::new(&m, scene, &[*pose]);
            sim.step(*pose)?;
        }
        Ok(mean(t.elapsed().as_secs_f64()))
    };
    // Mean footprint over these taps is about 22 mm across against 38 mm of dome: 25 -> 43 cells.
    let footprint = [tap_ms(sensor.skin.cells_across)?, tap_ms(43)?];
    // Rendering only when asked.
    let renderer = PinRenderer::new(sensor, 256)?;
    let (mut pins_only, mut with_render) = (0.0, 0.0);
    for (pose, _) in poses {
        let mut sim = Simulation::new(&model, scene, &[*pose]);
        sim.step(*pose)?;
        let t = Instant::now();
        let pins = sim.pins();
        pins_only += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pins2 = sim.pins();
        std::hint::black_box(renderer.render(&pins2));
        with_render += t.elapsed().as_secs_f64();
        std::hint::black_box(pins);
    }
    Ok(Skips {
        no_contact_step_ms: [mean(off), mean(tap)],
        tap_without_tangential_ms: [mean(tap), mean(slide)],
        far_stimuli_ms: far,
        footprint_grid_ms: footprint,
        no_render_ms: [mean(pins_only), mean(with_render)],
    })
}

/// Draws the plot into a string, then writes it atomically.
fn draw(report: &BenchReport, path: &Path) -> Result<()> {
    let mut svg = String::new();
    draw_into(report, &mut svg)?;
    tacsim_data::write_atomic(path, svg.as_bytes())?;
    Ok(())
}

fn draw_into(report: &BenchReport, svg: &mut String) -> Result<()> {
    let root = SVGBackend::with_string(svg, (1000, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(500);
    let series = |knob: &str, pick: fn(&CurvePoint) -> Option<f64>| -> Vec<(f64, f64)> {
        report
            .curve
            .iter()
            .filter(|p| p.knob == knob)
            .filter_map(|p| pick(p).map(|e| (p.ms_per_sample, e.max(1e-9))))
            .collect()
    };
    for (area, title, lines) in [
        (
            &left,
            "grid: tap time vs error",
            vec![
                ("Hertz force", series("grid", |p| p.hertz_force_rel_err), BLUE),
                ("Cattaneo shift (nu=0)", series("grid", |p| p.cattaneo_shift_rel_err), RED),
                ("pin error (mm)", series("grid", |p| p.pin_err_mm), GREEN),
                ("pin error on an edge (mm)", series("grid", |p| p.edge_pin_err_mm), MAGENTA),
            ],
        ),
        (
            &right,
            "slide step: slide time vs pin error (mm)",
            vec![("pin error", series("step", |p| p.pin_err_mm), GREEN)],
        ),
    ] {
        let all: Vec<(f64, f64)> = lines.iter().flat_map(|l| l.1.iter().copied()).collect();
        if all.is_empty() {
            continue;
        }
        let (x0, x1) = all.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
        let (y0, y1) = all.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), (y0 * 0.5..y1 * 2.0).log_scale())?;
        chart.configure_mesh().x_desc("ms per sample (one thread)").y_desc("error").draw()?;
        for (name, pts, color) in lines {
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}
