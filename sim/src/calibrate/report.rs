//! The held-out report of a calibration: per recording and mean, the global shift error, the
//! per-pin displacement error (px at the images' size, scaled to 420 px, and mm) and the
//! error relative to the real motion; the direction of the global shift; the undeformed
//! image's pin positions; and a grid of real, simulated and difference images.

use image::{GrayImage, Rgb, RgbImage, imageops};
use serde::Serialize;

use super::fitting::{Calibration, Candidate, Problem, RecordingSplit};
use super::model::{Deformation, SampleError};
use crate::error::Result;
use crate::sensor::SkinModel;

/// Real global shifts above this (px at 420) count for the direction criterion.
pub const DIRECTION_MIN_SHIFT_PX420: f64 = 2.0;
/// Targets of the issue: mean relative error and global shift direction (deg).
pub const TARGET_RELATIVE_ERROR: f64 = 0.25;
/// See [`TARGET_RELATIVE_ERROR`].
pub const TARGET_DIRECTION_DEG: f64 = 20.0;
/// Held-out recordings in the image grid.
pub const GRID_SAMPLES: usize = 12;
/// Side of each grid tile (px).
const TILE_PX: u32 = 210;

/// One held-out recording.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Image file name.
    pub image: String,
    /// Labelled depth (mm).
    pub depth_mm: f64,
    /// Labelled tilt `[Rx, Ry]` (deg).
    pub tilt_deg: [f64; 2],
    /// Labelled slide offset `[x, y]` (mm).
    pub offset_mm: [f64; 2],
    /// Labelled twist (deg).
    pub twist_deg: f64,
    /// Pins compared.
    pub pins: usize,
    /// Real global shift (px at 420).
    pub real_shift_px420: [f64; 2],
    /// Simulated global shift (px at 420).
    pub sim_shift_px420: [f64; 2],
    /// Length of their difference (px at 420).
    pub shift_error_px420: f64,
    /// Angle between them (deg), where the real shift exceeds
    /// [`DIRECTION_MIN_SHIFT_PX420`].
    pub shift_direction_error_deg: Option<f64>,
    /// Mean per-pin displacement error (px at 420).
    pub error_px420: f64,
    /// The same in mm at the pin tips.
    pub error_mm: f64,
    /// Mean real displacement (px at 420).
    pub real_px420: f64,
    /// Error relative to the real displacement.
    pub relative_error: f64,
}

/// Means over the held-out recordings.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Means {
    /// Global shift error (px at 420).
    pub shift_error_px420: f64,
    /// Per-pin displacement error (px at 420).
    pub error_px420: f64,
    /// Per-pin displacement error (mm).
    pub error_mm: f64,
    /// Real displacement (px at 420).
    pub real_px420: f64,
    /// Mean of the per-recording relative errors.
    pub relative_error: f64,
    /// Recordings whose real shift exceeds [`DIRECTION_MIN_SHIFT_PX420`].
    pub direction_samples: usize,
    /// Of those, how many have the simulated shift within [`TARGET_DIRECTION_DEG`].
    pub direction_within_target: usize,
    /// Their mean direction error (deg).
    pub direction_error_deg: f64,
}

/// The label frame as reported.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Rotation (deg), after mirroring `y` when `mirrored`.
    pub rotation_deg: f64,
    /// Whether the labels' axes are mirrored against the sensor's.
    pub mirrored: bool,
    /// Whether the labels' tilts turn opposite to the rotation-vector convention.
    pub tilts_reversed: bool,
    /// `sensor = m * label` for lateral vectors.
    pub m: [[f64; 2]; 2],
    /// RMS residual of the real global shifts predicted through the frame (px).
    pub shift_residual_px: f64,
}

/// A calibration's report.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The command that produced it.
    pub command: String,
    /// The recordings' folder.
    pub real_dir: String,
    /// The undeformed reference: an image, or the consensus of the most alike shallow recordings.
    pub reference: String,
    /// Recordings (the reference excluded).
    pub recordings: usize,
    /// Reference pins and the mean tracked per recording.
    pub reference_pins: usize,
    /// Mean pins tracked per recording.
    pub tracked_mean: f64,
    /// Training recordings.
    pub train: usize,
    /// Held-out recordings.
    pub held_out: usize,
    /// RMS distance of the simulated undeformed pins from the real reference's (px at 420).
    pub undeformed_rms_px420: f64,
    /// Image scale at the pin tips (mm per px at 420).
    pub mm_per_px420: f64,
    /// The label frame.
    pub frame: FrameReport,
    /// The fitted parameters.
    pub deformation: Deformation,
    /// Every candidate model's search.
    pub candidates: Vec<Candidate>,
    /// Mean relative error on the training recordings.
    pub train_relative_error: f64,
    /// Means over the held-out recordings.
    pub held_out_means: Means,
    /// Whether the mean relative error is within [`TARGET_RELATIVE_ERROR`].
    pub relative_target_met: bool,
    /// Whether the mean direction error over the recordings with a real shift over the
    /// threshold is within [`TARGET_DIRECTION_DEG`] (`held_out_means` also counts the
    /// recordings within it one by one).
    pub direction_target_met: bool,
    /// The held-out recordings.
    pub rows: Vec<Row>,
    /// File name of the image grid.
    pub grid: String,
}

/// Angle between two vectors (deg).
fn angle_deg(a: [f64; 2], b: [f64; 2]) -> f64 {
    let cross = a[0] * b[1] - a[1] * b[0];
    let dot = a[0] * b[0] + a[1] * b[1];
    cross.atan2(dot).abs().to_degrees()
}

/// One held-out row from its error (`k420` converts the images' px to px at 420).
fn row(sample: &tacsim_data::LabSample, e: &SampleError, k420: f64, mm_per_px: f64) -> Row {
    let scale = |v: [f64; 2]| v.map(|x| x * k420);
    let (real, sim) = (scale(e.real_shift), scale(e.sim_shift));
    let real_len = real[0].hypot(real[1]);
    Row {
        image: sample.image.clone(),
        depth_mm: sample.pose[2],
        tilt_deg: [sample.pose[3], sample.pose[4]],
        offset_mm: [sample.shear[0], sample.shear[1]],
        twist_deg: sample.shear[5],
        pins: e.pins,
        real_shift_px420: real,
        sim_shift_px420: sim,
        shift_error_px420: (real[0] - sim[0]).hypot(real[1] - sim[1]),
        shift_direction_error_deg: (real_len > DIRECTION_MIN_SHIFT_PX420).then(|| angle_deg(real, sim)),
        error_px420: e.error_px * k420,
        error_mm: e.error_px * mm_per_px,
        real_px420: e.real_px * k420,
        relative_error: e.relative(),
    }
}

/// Means over `rows`.
fn means(rows: &[Row]) -> Means {
    let n = rows.len().max(1) as f64;
    let avg = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).sum::<f64>() / n;
    let dirs: Vec<f64> = rows.iter().filter_map(|r| r.shift_direction_error_deg).collect();
    Means {
        shift_error_px420: avg(&|r| r.shift_error_px420),
        error_px420: avg(&|r| r.error_px420),
        error_mm: avg(&|r| r.error_mm),
        real_px420: avg(&|r| r.real_px420),
        relative_error: avg(&|r| r.relative_error),
        direction_samples: dirs.len(),
        direction_within_target: dirs.iter().filter(|d| **d <= TARGET_DIRECTION_DEG).count(),
        direction_error_deg: dirs.iter().sum::<f64>() / dirs.len().max(1) as f64,
    }
}

/// Evaluates `calib` on the held-out recordings of `split`: the report (its `grid` named
/// `grid_name`) and the image grid.
pub fn held_out(
    problem: &Problem,
    calib: &Calibration,
    split: &RecordingSplit,
    command: &str,
    real_dir: &str,
    grid_name: &str,
) -> Result<(Report, RgbImage)> {
    let obs = problem.obs;
    let sim = problem.simulator(&calib.deformation)?;
    let frame = &calib.frame.frame;
    let k420 = 420.0 / obs.size as f64;
    let mm_per_px = sim.mm_per_px();
    let errors = sim.errors(obs, &split.held_out, frame)?;
    let rows: Vec<Row> =
        split.held_out.iter().zip(&errors).map(|(&k, e)| row(&obs.samples[k].sample, e, k420, mm_per_px)).collect();
    let held_out_means = means(&rows);
    let n = obs.reference.len();
    let tracked: usize = obs.samples.iter().map(|o| n - o.tracking.unmatched()).sum();
    let (rms, _) = sim.undeformed_rms(obs);
    let f = &calib.frame;
    let report = Report {
        command: command.to_owned(),
        real_dir: real_dir.to_owned(),
        reference: problem.reference.describe(),
        recordings: obs.samples.len(),
        reference_pins: n,
        tracked_mean: tracked as f64 / obs.samples.len().max(1) as f64,
        train: split.train.len(),
        held_out: split.held_out.len(),
        undeformed_rms_px420: rms * k420,
        mm_per_px420: mm_per_px / k420,
        frame: FrameReport {
            rotation_deg: f.rotation_deg,
            mirrored: f.mirrored,
            tilts_reversed: f.frame.tilt_sign < 0.0,
            m: f.frame.m,
            shift_residual_px: f.rms_px,
        },
        deformation: calib.deformation.clone(),
        candidates: calib.candidates.clone(),
        train_relative_error: calib.train_relative_error,
        relative_target_met: held_out_means.relative_error <= TARGET_RELATIVE_ERROR,
        direction_target_met: held_out_means.direction_error_deg <= TARGET_DIRECTION_DEG,
        held_out_means,
        rows,
        grid: grid_name.to_owned(),
    };
    // The grid: held-out recordings spread over depth.
    let mut by_depth = split.held_out.clone();
    by_depth.sort_by(|a, b| obs.samples[*a].sample.pose[2].total_cmp(&obs.samples[*b].sample.pose[2]));
    let picks: Vec<usize> = (0..GRID_SAMPLES.min(by_depth.len()))
        .map(|i| by_depth[i * by_depth.len() / GRID_SAMPLES.min(by_depth.len())])
        .collect();
    let mut grid = RgbImage::new(3 * TILE_PX, TILE_PX * picks.len() as u32);
    for (r, &k) in picks.iter().enumerate() {
        let real = problem.real_image(k)?;
        let simulated = sim.render(&sim.pins(obs, k, frame)?);
        imageops::replace(&mut grid, &comparison_row(&real, &simulated, TILE_PX), 0, i64::from(r as u32 * TILE_PX));
    }
    Ok((report, grid))
}

/// One row of a comparison grid: `real`, `simulated` and their difference (real only red,
/// simulated only cyan, both white), each resized to `tile_px` square tiles.
pub fn comparison_row(real: &GrayImage, simulated: &GrayImage, tile_px: u32) -> RgbImage {
    let tile = |img: &GrayImage| imageops::resize(img, tile_px, tile_px, imageops::FilterType::Nearest);
    let (a, b) = (tile(real), tile(simulated));
    let mut row = RgbImage::new(3 * tile_px, tile_px);
    for (x, y, p) in a.enumerate_pixels() {
        let q = b.get_pixel(x, y)[0];
        row.put_pixel(x, y, Rgb([p[0]; 3]));
        row.put_pixel(tile_px + x, y, Rgb([q; 3]));
        row.put_pixel(2 * tile_px + x, y, Rgb([p[0], q, q]));
    }
    row
}

/// The report as markdown.
pub fn markdown(r: &Report) -> String {
    [held_out_section(r), fitted_model_section(r), rig_section(r), recordings_section(r)].concat()
}

/// The title, the data and the held-out result against the targets.
fn held_out_section(r: &Report) -> String {
    let m = &r.held_out_means;
    let yes = |b: bool| if b { "met" } else { "NOT met" };
    let direction_line = format!(
        "| global shift direction error, mean over real shifts > {DIRECTION_MIN_SHIFT_PX420} px | {:.1} deg ({} of {} \
         within {TARGET_DIRECTION_DEG} deg) | <= {TARGET_DIRECTION_DEG} deg ({}) |\n",
        m.direction_error_deg,
        m.direction_within_target,
        m.direction_samples,
        yes(r.direction_target_met)
    );
    format!(
        "# Calibration against real TacTip recordings\n\nMade by `{}` from `{}`. Reference: {}.\n\n\
         {} recordings ({} reference pins, {:.1} tracked per recording): {} fitted, {} held out \
         (never used in the fit). Pixels are given at 420 px; 1 px at the pin tips is {:.3} mm.\n\n\
         ## Held-out result\n\n\
         | measure | value | target |\n|---|---|---|\n\
         | mean relative error (per-pin error over real motion) | {:.3} | <= {} ({}) |\n\
         {}\
         | mean global shift error | {:.2} px | |\n\
         | mean per-pin displacement error | {:.2} px = {:.3} mm | |\n\
         | mean real displacement | {:.2} px | |\n\
         | undeformed pin positions, RMS | {:.2} px | <= 1 px ({}) |\n\
         | training recordings, mean relative error | {:.3} | |\n\n",
        r.command,
        r.real_dir,
        r.reference,
        r.recordings,
        r.reference_pins,
        r.tracked_mean,
        r.train,
        r.held_out,
        r.mm_per_px420,
        m.relative_error,
        TARGET_RELATIVE_ERROR,
        yes(r.relative_target_met),
        direction_line,
        m.shift_error_px420,
        m.error_px420,
        m.error_mm,
        m.real_px420,
        r.undeformed_rms_px420,
        yes(r.undeformed_rms_px420 <= 1.0),
        r.train_relative_error,
    )
}

/// The fitted deformation model, the label frame and the candidate models.
fn fitted_model_section(r: &Report) -> String {
    let d = &r.deformation;
    let mut s = format!(
        "## Fitted model\n\n\
         | parameter | value |\n|---|---|\n\
         | elastic model | {:?} |\n| depth offset (added to the labelled depth) | {:.3} mm |\n\
         | friction | {:.3} |\n| tilt pivot above the apex | {:.2} mm |\n\
         | tilt pivot off the axis (sensor x, y) | {:.3}, {:.3} mm |\n\
         | depth compliance of the rig (indentation lost: c d^1.5) | {:.4} mm^-0.5 |\n\
         | tilt relaxation under load (tilt kept: 1 - k d) | {:.4} per mm |\n\
         | the rig's play in tilt (taken off each tilt's size) | {:.2} deg |\n| pin length | {:.3} mm |\n\
         | camera distance behind the dome centre | {:.2} mm |\n| skin Poisson's ratio | {:.3} |\n| base depth (layered models, dome) | {:.2} mm |\n\
         | gel / skin modulus (skin-on-gel, dome) | {:.4} |\n\n\
         Label frame: rotation {:.0} deg{}{}, shift residual {:.2} px; `sensor = m label` with m = {:?}.\n\n\
         | candidate model | search relative error | evaluations |\n|---|---|---|\n",
        d.model,
        d.depth_offset_mm,
        d.friction,
        d.pivot_mm,
        d.pivot_offset_mm[0],
        d.pivot_offset_mm[1],
        d.depth_compliance,
        d.tilt_relaxation_per_mm,
        d.tilt_play_deg,
        d.pin_length_mm,
        d.camera_distance_mm,
        d.poisson,
        d.base_depth_mm,
        d.gel_ratio,
        r.frame.rotation_deg,
        if r.frame.mirrored { ", mirrored" } else { "" },
        if r.frame.tilts_reversed { ", tilts reversed" } else { "" },
        r.frame.shift_residual_px,
        r.frame.m,
    );
    for c in &r.candidates {
        let d = &c.deformation;
        // The dome search's candidates differ in their dome, not their model.
        let model = match d.model {
            SkinModel::Dome => format!(
                "Dome: gel / skin {:.4}, pins {:.2} mm, base {:.1} mm, play {:.2} deg",
                d.gel_ratio, d.pin_length_mm, d.base_depth_mm, d.tilt_play_deg
            ),
            m => format!("{m:?}, play {:.2} deg", d.tilt_play_deg),
        };
        s += &format!("| {model} | {:.3} | {} |\n", c.relative_error, c.evaluations);
    }
    s
}

/// The `[rig]` a dataset recipe needs to replay the lab's rig.
fn rig_section(r: &Report) -> String {
    let d = &r.deformation;
    format!(
        "\nA dataset recipe replays this rig (labels in the lab's frame, the sensor where the rig took it) with:\n\n```toml\n[[shapes]]\nname = \"disk\"\nfriction = {:.3}\n\n[rig]\nrotation_deg = {:.1}\nmirrored = {}\ntilts_reversed = {}\ndepth_offset_mm = {:.3}\npivot_mm = {:.2}\ndepth_compliance = {:.4}\ntilt_relaxation_per_mm = {:.4}\npivot_offset_mm = [{:.3}, {:.3}]\ntilt_play_deg = {:.2}\n```\n",
        d.friction,
        r.frame.rotation_deg,
        r.frame.mirrored,
        r.frame.tilts_reversed,
        d.depth_offset_mm,
        d.pivot_mm,
        d.depth_compliance,
        d.tilt_relaxation_per_mm,
        d.pivot_offset_mm[0],
        d.pivot_offset_mm[1],
        d.tilt_play_deg,
    )
}

/// The image grid and the table of held-out recordings.
fn recordings_section(r: &Report) -> String {
    let mut s = format!(
        "\n## Images\n\n![held-out recordings: real, simulated, difference (red: real only, cyan: \
         simulated only)]({})\n\nRows: {GRID_SAMPLES} held-out recordings from shallow to deep; columns: real, \
         simulated, difference (red: real only, cyan: simulated only).\n\n## Held-out recordings\n\n\
         | image | depth mm | tilt deg | offset mm | twist deg | pins | shift err px | direction err deg | \
         error px | error mm | real px | relative |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        r.grid
    );
    for w in &r.rows {
        s += &format!(
            "| {} | {:.2} | {:.1}, {:.1} | {:.2}, {:.2} | {:.1} | {} | {:.2} | {} | {:.2} | {:.3} | {:.2} | {:.3} |\n",
            w.image,
            w.depth_mm,
            w.tilt_deg[0],
            w.tilt_deg[1],
            w.offset_mm[0],
            w.offset_mm[1],
            w.twist_deg,
            w.pins,
            w.shift_error_px420,
            w.shift_direction_error_deg.map_or("-".to_owned(), |v| format!("{v:.1}")),
            w.error_px420,
            w.error_mm,
            w.real_px420,
            w.relative_error
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shift_directions_are_compared_only_above_the_threshold() {
        let s = tacsim_data::LabSample { image: "a.png".into(), pose: [0.0; 6], shear: [0.0; 6] };
        let e = SampleError { error_px: 1.0, real_px: 4.0, pins: 10, real_shift: [3.0, 0.0], sim_shift: [0.0, 3.0] };
        let r = row(&s, &e, 1.0, 0.1);
        assert!((r.shift_direction_error_deg.expect("above 2 px") - 90.0).abs() < 1e-9);
        assert!((r.relative_error - 0.25).abs() < 1e-12 && (r.error_mm - 0.1).abs() < 1e-12);
        let small = SampleError { real_shift: [1.0, 1.0], ..e };
        assert!(row(&s, &small, 1.0, 0.1).shift_direction_error_deg.is_none());
        let m = means(&[r]);
        assert_eq!((m.direction_samples, m.direction_within_target), (1, 0));
    }
}
