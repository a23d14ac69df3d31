//! `tacsim calibrate`: fit the simulator to a lab's own recordings (`targets.csv` +
//! `images/`, with an undeformed reference image) and write a sensor preset and a held-out
//! report (`report.md`, `report.json`, `grid.png`).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use tacsim_data::LabFolder;
use tacsim_sim::atomic::write_atomic;
use tacsim_sim::calibrate::fitting::{FitOptions, Problem, Split, calibrate as fit};
use tacsim_sim::calibrate::observe::Observations;
use tacsim_sim::calibrate::report::{held_out, markdown};
use tacsim_sim::png_io::read_png;
use tacsim_sim::sensor::{SensorParams, SkinModel};

/// What `tacsim calibrate` was asked.
#[derive(Clone, Debug)]
pub struct CalibrateOptions {
    /// The lab folder.
    pub real: PathBuf,
    /// The sensor to start from (default: the built-in TacTip, itself calibrated on the lab's
    /// recordings; `sim/presets/tactip-331-camera.toml` is the uncalibrated start it came from).
    pub sensor: Option<PathBuf>,
    /// Where the preset goes.
    pub output: PathBuf,
    /// Where the report goes (default: beside the preset, `<stem>-report/`).
    pub report: Option<PathBuf>,
    /// The undeformed reference image under `images/`.
    pub reference: String,
    /// A short fit (one model, few evaluations): for tests and a first look.
    pub quick: bool,
    /// No progress spinner.
    pub quiet: bool,
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
    let ref_path = folder.dir.join("images").join(&o.reference);
    if !ref_path.is_file() {
        bail!(
            "{}: the undeformed reference image is missing; record one with the sensor touching nothing, or name \
             another with --reference",
            ref_path.display()
        );
    }
    let reference = read_png(&ref_path)?;
    let base = match &o.sensor {
        Some(p) => SensorParams::load(p)?,
        None => SensorParams::default(),
    };
    let started = std::time::Instant::now();
    let spinner = if o.quiet { ProgressBar::hidden() } else { ProgressBar::new_spinner() };
    spinner.set_style(ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_msg}")?);
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    spinner.set_message(format!("tracking the pins of {} recordings", folder.samples.len()));
    let obs = Observations::track(&folder, &o.reference)?;
    let split = Split::of(&obs);
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
            ..FitOptions::default()
        }
    } else {
        FitOptions::default()
    };
    let problem = Problem {
        folder: &folder,
        base: &base,
        reference: &reference,
        reference_name: &o.reference,
        obs: &obs,
        surface: &surface,
        cells: opts.cells,
    };
    // Without a terminal (CI logs, background runs) the spinner is hidden: print each step.
    let log = !o.quiet && !std::io::stderr().is_terminal();
    let progress = |m: &str| {
        if log {
            eprintln!("[{:>6.1} s] {m}", started.elapsed().as_secs_f64());
        }
        spinner.set_message(m.to_owned());
    };
    let calib = fit(&problem, &split, &opts, &progress)?;
    spinner.set_message("held-out report");
    let report_dir = o.report.clone().unwrap_or_else(|| default_report_dir(&o.output));
    let (report, grid) = held_out(&problem, &calib, &split, command, &o.real.display().to_string(), "grid.png")?;
    spinner.finish_and_clear();
    std::fs::create_dir_all(&report_dir).with_context(|| format!("creating {}", report_dir.display()))?;
    let mut png = Vec::new();
    grid.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    write_atomic(&report_dir.join("grid.png"), &png)?;
    write_atomic(&report_dir.join("report.json"), &serde_json::to_vec_pretty(&report)?)?;
    write_atomic(&report_dir.join("report.md"), markdown(&report).as_bytes())?;
    let mut sensor = calib.sensor.clone();
    // Recalibrating a calibrated sensor (the default) keeps its name.
    sensor.name =
        if base.name.ends_with("-calibrated") { base.name.clone() } else { format!("{}-calibrated", base.name) };
    let header = format!(
        "# {} calibrated against {} by `{command}`.\n# Held-out mean relative error {:.3}; report: {}.\n\
         # The recordings' press (not part of the sensor): depth offset {:.3} mm, friction {:.3}, tilt pivot \
         {:.2} mm above the apex,\n# depth compliance {:.4} mm^-0.5, tilt relaxation {:.4} per mm.\n\n",
        base.name,
        o.real.display(),
        report.held_out_means.relative_error,
        report_dir.display(),
        calib.deformation.depth_offset_mm,
        calib.deformation.friction,
        calib.deformation.pivot_mm,
        calib.deformation.depth_compliance,
        calib.deformation.tilt_relaxation_per_mm,
    );
    if let Some(dir) = o.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    write_atomic(&o.output, format!("{header}{}", sensor.to_toml()).as_bytes())?;
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
