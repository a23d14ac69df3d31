//! What `tacsim bench` measures ([`BenchReport`]) and its text table.

use std::path::Path;

use serde::Serialize;

use super::samples::{SLIDE_MM, STEP_MM};

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
    /// The normal solver's iterations a tap (summed over the coupling's alternations).
    pub normal_iterations: f64,
    /// The tangential solver's iterations a tap.
    pub tangential_iterations: f64,
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
    /// model: the median of three passes over the samples after a first (`Rates`).
    pub tap_frames_per_s: f64,
    /// Slides per second on all threads (touch down 2.5 mm away, slide in 0.25 mm steps, capture
    /// pins and a 256x256 image), on a warm model as the taps.
    pub slide_samples_per_s: f64,
    /// The same rates in the first pass over the samples, on a new model: with its first-use
    /// costs, as a run's first samples have them (`Rates`).
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

impl BenchReport {
    /// The report as the text table `tacsim bench` prints, naming the plot written.
    pub fn table(&self, plot: &Path) -> String {
        let b = &self.tap_breakdown;
        let mut out = format!(
            "{} threads, {} cells across the footprint (mean {:.0} in contact), {} x {} sub-cells along edges{}\n\
             taps:   {:>9.1} frames/s  (solve + pins + 256x256 render; first pass {:.1})\n\
             slides: {:>9.1} samples/s (touch down {SLIDE_MM} mm away, {STEP_MM} mm steps, capture; first pass {:.1})\n\
             a tap, one thread: footprint {:.3} ms, gap + solve {:.3} ms ({:.1} normal + {:.1} tangential iterations), pins {:.3} ms, render {:.3} ms\n",
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
            b.normal_iterations,
            b.tangential_iterations,
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
