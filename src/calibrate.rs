//! `tacsim calibrate`: fit the simulator to a lab's own recordings (`targets.csv` +
//! `images/`; an undeformed reference image where there is one, else the consensus of the
//! most alike shallow recordings; any image shape) and write a sensor preset and a held-out report
//! (`report.md`, `report.json`, `grid.png`). `--camera-only` fits the camera, ring layout and
//! image framing alone: the first step for a TacTip whose recordings are not of a flat surface.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use tacsim_data::LabFolder;
use tacsim_data::write_atomic;
use tacsim_sim::calibrate::edge;
use tacsim_sim::calibrate::{
    Calibration, ConsensusRule, FitOptions, Observations, Problem, RecordingSplit, Reference, ReferenceSource, Report,
    comparison_row, fit, fit_camera_only, fit_pin_offsets, held_out, markdown, ring_table,
};
use tacsim_sim::{SensorParams, SkinModel};

/// What `tacsim calibrate` was asked.
#[derive(Clone, Debug, clap::Args)]
pub struct CalibrateOptions {
    /// The lab folder.
    #[arg(long)]
    pub real: PathBuf,
    /// Sensor TOML or built-in preset to start from (default: tactip-331-calibrated, the
    /// built-in TacTip over a half-space, itself calibrated on the lab's recordings;
    /// `sim/presets/tactip-331-camera.toml` is the uncalibrated start it came from; `--dome`
    /// fits a dome from it).
    #[arg(long)]
    pub sensor: Option<PathBuf>,
    /// The preset TOML to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Report directory (default: `<preset stem>-report/` beside the preset).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// The undeformed reference image under images/ (default: image_0.png where it exists,
    /// else the consensus of the recordings by --consensus).
    #[arg(long)]
    pub reference: Option<String>,
    /// Without a reference image, whose pixel-wise majority stands in for it: `alike`, the 30
    /// most alike of the shallowest half (taps that touch nothing, where there are some), or
    /// `shallowest`, the shallowest 5% (at least 30), pressed or not.
    #[arg(long, default_value = "alike", value_name = "RULE")]
    pub consensus: ConsensusRule,
    /// Fit the camera, ring layout and image framing (rim, mask) to the reference only: a
    /// preset at the recordings' image size, for a TacTip whose recordings are not of a flat
    /// surface.
    #[arg(long, conflicts_with = "quick")]
    pub camera_only: bool,
    /// Fit each pin's offset in the image (`pins.image_offsets`) to the reference, the
    /// sensor's camera, rings and framing held as given: simulated undeformed pins on the real
    /// ones, pin by pin ([`tacsim_sim::calibrate::fit_pin_offsets`]). Written and reported as
    /// --camera-only.
    #[arg(long, conflicts_with_all = ["quick", "camera_only", "rig_only", "edge"])]
    pub pin_offsets: bool,
    /// Fit the rig alone (depth offset, friction, the tilt pivot's height and its offset off
    /// the axis, yield, tilt relaxation, play in tilt; searched from 0, 2 and 4 deg of play),
    /// the sensor held as given ([`FitOptions::rig_only`]): for a preset already calibrated.
    /// The preset written is the sensor unchanged.
    #[arg(long, conflicts_with = "camera_only")]
    pub rig_only: bool,
    /// The recordings are taps on this stimulus's edge (a catalogue shape, e.g. square) at
    /// labelled lateral offset, depth and yaw: fits the label map (signs, offsets, the rig's
    /// yield under load) and compares the edge's rounding (0, 1, 2, 4 mm), the pins' skin
    /// patch (0, 0.75, 1.5, 2.5 mm), the dome's slope (0, 1, 2) and the gap profile (the
    /// dome's own, 0.75 and 0.5 of its radius: `skin.gap_radius_mm`) on the held-out per-pin
    /// error, the rest of the sensor held as given ([`tacsim_sim::calibrate::edge::fit_edge`]).
    /// The preset written is the sensor with the best candidate's skin patch, dome slope and
    /// gap profile.
    #[arg(long, conflicts_with_all = ["camera_only", "rig_only"])]
    pub edge: Option<String>,
    /// Fit the finite-element dome (`skin.model = "dome"`, docs/guide/fem.md) to the
    /// recordings: the gel's modulus (as a ratio to the skin's), the skin's thickness (the
    /// pins' tips kept) and the base's depth, by a coordinate search over at most 16 domes (6
    /// with --quick) from the sensor's own, each a finite-element build of about 20 s; on each
    /// dome the rig is fitted (surface) or the label map (with --edge). The preset written is
    /// the sensor with the best dome.
    #[arg(long, conflicts_with_all = ["camera_only", "pin_offsets", "rig_only"])]
    pub dome: bool,
    /// With --edge: the point on the shape's edge the taps' lateral offsets are measured from
    /// (x,y mm, object frame; default: the catalogue's contact point). The square's straight
    /// side: 45,0.
    #[arg(long, requires = "edge", value_parser = crate::commands::parse_offset, allow_hyphen_values = true)]
    pub edge_contact: Option<[f64; 2]>,
    /// A short fit (one model, few evaluations) for a first look; with --edge, the label map
    /// of the sensor as given only, no candidates.
    #[arg(long)]
    pub quick: bool,
    /// No progress spinner.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Domes a `--dome` fit scores at most (each a finite-element build of its own).
const DOME_POINTS: usize = 16;
/// Domes a `--dome --quick` fit scores at most.
const QUICK_DOME_POINTS: usize = 6;

impl CalibrateOptions {
    /// Domes the fit scores: none without `--dome`.
    fn dome_points(&self) -> usize {
        match (self.dome, self.quick) {
            (false, _) => 0,
            (true, false) => DOME_POINTS,
            (true, true) => QUICK_DOME_POINTS,
        }
    }

    /// The name a fitted dome's preset takes: its file's, as `--camera-only`'s (a sensor of
    /// another body); `None` where the fit keeps the sensor's name.
    fn dome_name(&self) -> Option<String> {
        self.output.file_stem().filter(|_| self.dome).map(|stem| stem.to_string_lossy().into_owned())
    }
}

/// The report directory for a preset at `output`: `<stem>-report/` beside it.
pub fn default_report_dir(output: &Path) -> PathBuf {
    let stem = output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "preset".into());
    output.with_file_name(format!("{stem}-report"))
}

/// Runs the calibration; returns the summary to print. `command` is recorded in the report.
pub fn calibrate(o: &CalibrateOptions, command: &str) -> Result<String> {
    let folder = LabFolder::open(&o.real)
        .with_context(|| format!("{} is not a lab folder (targets.csv + images/)", o.real.display()))?;
    let base = crate::commands::SensorArgs { sensor: o.sensor.clone(), ..Default::default() }
        .load_or(tacsim_sim::SensorParams::half_space)?;
    // The outputs are checked writable before any work.
    let report_dir = o.report.clone().unwrap_or_else(|| default_report_dir(&o.output));
    let _made = crate::commands::ensure_file_writable(&o.output)?.and(crate::commands::ensure_writable(&report_dir)?);
    let reference = Reference::of(&folder, o.reference.as_deref(), o.consensus)?;
    // The edge's stimulus and contact point are checked before any tracking.
    let edge = match o.edge.as_deref() {
        Some(shape) => Some(edge::edge_stimulus(&crate::commands::load_catalogue(None)?, shape, o.edge_contact)?),
        None => None,
    };
    if o.camera_only || o.pin_offsets {
        return camera_only(o, &reference, &base, &report_dir, command);
    }
    // A sensor whose dome the search cannot start from is refused before the tracking.
    if o.dome {
        tacsim_sim::calibrate::dome_start(&base).with_context(|| format!("--dome with the sensor `{}`", base.name))?;
    }
    let started = std::time::Instant::now();
    let spinner = if o.quiet { ProgressBar::hidden() } else { ProgressBar::new_spinner() };
    spinner.set_style(ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_msg}")?);
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    // Without a terminal (CI logs, background runs) the spinner is hidden: print each step.
    let log = !o.quiet && !std::io::stderr().is_terminal();
    let progress = |m: &str| {
        if log {
            eprintln!("[{:>6.1} s] {m}", started.elapsed().as_secs_f64());
        }
        spinner.set_message(m.to_owned());
    };
    spinner.set_message(format!("tracking the pins of {} recordings", folder.samples.len()));
    let obs = Observations::track(&folder, &reference)?;
    let split = RecordingSplit::of(&obs);
    if let Some((stimulus, contact)) = edge {
        let real = o.real.display().to_string();
        let report = edge::fit_edge(&edge::EdgeFit {
            stimulus,
            contact,
            obs: &obs,
            split: &split,
            base: &base,
            quick: o.quick,
            dome_points: o.dome_points(),
            real: &real,
            command,
            progress: &progress,
        })?;
        let summary = write_edge_report(o, &report, &base, &report_dir)?;
        spinner.finish_and_clear();
        return Ok(summary);
    }
    surface_fit(
        o,
        &SurfaceFit { folder: &folder, base: &base, reference: &reference, obs: &obs, split: &split },
        &report_dir,
        command,
        &progress,
        &spinner,
    )
}

/// What a surface fit works on: the lab folder, the sensor to start from, the undeformed
/// reference, the tracked recordings and their split.
struct SurfaceFit<'a> {
    folder: &'a LabFolder,
    base: &'a SensorParams,
    reference: &'a Reference,
    obs: &'a Observations,
    split: &'a RecordingSplit,
}

/// The surface fit (`tacsim calibrate` without `--camera-only` or `--edge`): the deformation
/// fitted on the fitting part, the held-out report written to `report_dir`, the sensor to
/// `-o`; returns the summary to print.
fn surface_fit(
    o: &CalibrateOptions,
    job: &SurfaceFit<'_>,
    report_dir: &Path,
    command: &str,
    progress: &dyn Fn(&str),
    spinner: &ProgressBar,
) -> Result<String> {
    let (obs, split) = (job.obs, job.split);
    if split.train.len() < 8 || split.held_out.is_empty() {
        bail!(
            "{}: {} recordings besides the reference give {} to fit and {} to hold out; record at least 10",
            o.real.display(),
            obs.samples.len(),
            split.train.len(),
            split.held_out.len()
        );
    }
    let catalogue = crate::commands::load_catalogue(None)?;
    let surface = catalogue.get("disk")?;
    let opts = if o.quick {
        FitOptions {
            search_stride: 1,
            search_evaluations: 10,
            polish_evaluations: 0,
            models: vec![SkinModel::HalfSpace],
            rig_only: o.rig_only,
            dome_points: o.dome_points(),
            dome_evaluations: 20,
            ..FitOptions::default()
        }
    } else {
        FitOptions { rig_only: o.rig_only, dome_points: o.dome_points(), ..FitOptions::default() }
    };
    let problem = Problem {
        folder: job.folder,
        base: job.base,
        reference: job.reference,
        obs,
        surface: &surface,
        cells: opts.cells,
    };
    let calib = fit(&problem, split, &opts, progress).with_context(|| match &job.reference.source {
        ReferenceSource::Consensus(rule, names) => format!(
            "the reference is the consensus of the {}: where those presses move the pins too much for a clear \
             layout, name an undeformed image with --reference or record a few shallow presses",
            rule.describe(names.len())
        ),
        ReferenceSource::Image(name) => format!("fitting against the reference {name}"),
    })?;
    spinner.set_message("held-out report");
    let (report, grid) = held_out(&problem, &calib, split, command, &o.real.display().to_string(), "grid.png")?;
    spinner.finish_and_clear();
    let mut png = Vec::new();
    grid.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    write_atomic(&report_dir.join("grid.png"), &png)?;
    write_atomic(&report_dir.join("report.json"), &serde_json::to_vec_pretty(&report)?)?;
    write_atomic(&report_dir.join("report.md"), markdown(&report).as_bytes())?;
    write_calibrated_sensor(o, job.base, &calib, &report, report_dir, command)?;
    let m = &report.held_out_means;
    Ok(format!(
        "{} recordings: {} fitted, {} held out; model {:?}\nheld out: mean relative error {:.3} (target <= 0.25), \
         shift direction within 20 deg on {} of {}, per-pin error {:.2} px at 420 = {:.3} mm, undeformed RMS {:.2} px\n\
         wrote {} and {}\n",
        report.recordings,
        report.train,
        report.held_out,
        calib.deformation.model,
        m.relative_error,
        m.direction_within_target,
        m.direction_samples,
        m.error_px420,
        m.error_mm,
        report.undeformed_rms_px420,
        o.output.display(),
        report_dir.join("report.md").display()
    ))
}

/// Writes the calibrated sensor (`-o`) with a header naming the data, the command, the
/// held-out error and the recordings' press (not part of the sensor). The rig alone
/// (`--rig-only`) leaves the sensor as it was given; recalibrating a calibrated sensor keeps
/// its name; a dome fit (`--dome`) names the sensor after the file.
fn write_calibrated_sensor(
    o: &CalibrateOptions,
    base: &SensorParams,
    calib: &Calibration,
    report: &Report,
    report_dir: &Path,
    command: &str,
) -> Result<()> {
    // The rig alone leaves the sensor as given; the dome fit gives it the fitted dome only.
    let mut sensor = match (o.rig_only, o.dome) {
        (true, _) => base.clone(),
        (false, true) => calib.deformation.sensor(base)?,
        (false, false) => calib.sensor.clone(),
    };
    sensor.name = match o.dome_name() {
        Some(name) => name,
        None if base.name.ends_with("-calibrated") => base.name.clone(),
        None => format!("{}-calibrated", base.name),
    };
    let header = format!(
        "# {} calibrated against {} by `{command}`.\n# Held-out mean relative error {:.3}; report: {}.\n\
         # The recordings' press (not part of the sensor): depth offset {:.3} mm, friction {:.3}, tilt pivot \
         {:.2} mm above the apex and ({:.3}, {:.3}) mm off its axis,\n# depth compliance {:.4} mm^-0.5, tilt relaxation {:.4} per mm, play in tilt {:.2} deg.\n\n",
        base.name,
        o.real.display(),
        report.held_out_means.relative_error,
        report_dir.display(),
        calib.deformation.depth_offset_mm,
        calib.deformation.friction,
        calib.deformation.pivot_mm,
        calib.deformation.pivot_offset_mm[0],
        calib.deformation.pivot_offset_mm[1],
        calib.deformation.depth_compliance,
        calib.deformation.tilt_relaxation_per_mm,
        calib.deformation.tilt_play_deg,
    );
    write_atomic(&o.output, format!("{header}{}", sensor.to_toml()).as_bytes())?;
    Ok(())
}

/// Side of each tile of the camera-only grid (px).
const TILE_PX: u32 = 256;

/// `--camera-only` ([`fit_camera_only`]) or `--pin-offsets` ([`fit_pin_offsets`]): writes
/// the preset, named after its file, and a report (`report.md`, `grid.png`: real reference,
/// simulated, difference).
fn camera_only(
    o: &CalibrateOptions,
    reference: &Reference,
    base: &SensorParams,
    report_dir: &Path,
    command: &str,
) -> Result<String> {
    let name = reference.describe();
    let (fit, (title, what)) = if o.pin_offsets {
        let fit = fit_pin_offsets(base, reference)
            .with_context(|| format!("fitting the pins' image offsets to the reference ({name})"))?;
        (fit, ("Pin offsets fit", "pins' image offsets"))
    } else {
        let fit = fit_camera_only(base, reference)
            .with_context(|| format!("fitting the camera to the reference ({name})"))?;
        (fit, ("Camera fit", "camera, ring layout and framing"))
    };
    let mut sensor = fit.sensor.clone();
    sensor.name = o.output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| base.name.clone());
    let summary = fit.summary();
    let mut png = Vec::new();
    comparison_row(&reference.image, &fit.simulated, TILE_PX)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    write_atomic(&report_dir.join("grid.png"), &png)?;
    let md = format!(
        "# {title} against real TacTip recordings\n\nMade by `{command}` from `{}`.\n\nReference: {name}.\n\n\
         {summary}.\n\nThe camera distance ({:.2} mm), the dome, the skin and the pins' length are the starting \
         sensor's: an undeformed image does not tell them.\n\n```\n{}```\n\n`grid.png`: the reference, the \
         simulated undeformed image, their difference (real only red, simulated only cyan).\n",
        o.real.display(),
        sensor.camera.distance_mm,
        ring_table(&fit.sim, &fit.real),
    );
    write_atomic(&report_dir.join("report.md"), md.as_bytes())?;
    let header = format!(
        "# {} {what} fitted to {} by `{command}`.\n# Reference: {name}.\n# {summary}.\n\n",
        base.name,
        o.real.display()
    );
    write_atomic(&o.output, format!("{header}{}", sensor.to_toml()).as_bytes())?;
    Ok(format!("{summary}\nwrote {} and {}\n", o.output.display(), report_dir.join("report.md").display()))
}

/// Writes an edge fit's report (`report.json`, `report.md`) and its preset (the sensor with the
/// winner's skin patch, dome slope and gap profile); returns the summary to print.
fn write_edge_report(
    o: &CalibrateOptions,
    report: &edge::EdgeReport,
    base: &SensorParams,
    report_dir: &Path,
) -> Result<String> {
    write_atomic(&report_dir.join("report.json"), &serde_json::to_vec_pretty(report)?)?;
    write_atomic(&report_dir.join("report.md"), report.markdown().as_bytes())?;
    let b = report.winner();
    let best = match &b.dome {
        Some(d) => format!(
            "the dome of gel / skin {:.4}, skin {:.2} mm, base {:.1} mm",
            d.gel_ratio, d.skin_thickness_mm, d.base_depth_mm
        ),
        None => format!(
            "edge rounding {} mm, skin patch {} mm, dome slope {}, gap profile {} mm (0: the dome's own)",
            b.edge_radius_mm, b.patch_radius_mm, b.dome_slope, b.gap_radius_mm
        ),
    };
    let what = if b.dome.is_some() { "finite-element dome" } else { "skin patch, dome slope and gap profile" };
    let mut sensor = report.sensor(base)?;
    if let Some(name) = o.dome_name() {
        sensor.name = name;
    }
    let header = format!(
        "# {} with the {what} of edge taps of {} on `{}` fitted by `{}`.\n# Best: {best} (held-out per-pin error \
         {:.3}); report: {}.\n\n",
        base.name,
        o.real.display(),
        report.shape,
        report.command,
        b.held_out_error,
        report_dir.display()
    );
    write_atomic(&o.output, format!("{header}{}", sensor.to_toml()).as_bytes())?;
    Ok(format!(
        "{} taps fitted, {} held out; best: {best}: held-out per-pin error {:.3}\nwrote {} and {}\n",
        report.fitted,
        report.held_out,
        b.held_out_error,
        o.output.display(),
        report_dir.join("report.md").display()
    ))
}
