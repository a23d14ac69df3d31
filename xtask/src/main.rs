//! Project automation, run as `cargo xtask <command>`:
//! - `shapes [--check]`: regenerate the built-in stimuli in `shapes/` (or check the committed
//!   files are up to date);
//! - `fit-camera [--real PNG]`: fit the camera and ring layout to the lab's undeformed
//!   reference image and write `sim/presets/tactip-331-camera.toml` (the calibration's start);
//! - `real-compare [--real DIR] [--sensor FILE] [--skin MODEL] [--depth-offset MM] [--friction MU] [--pivot MM]
//!   [--pivot-offset X,Y] [--depth-compliance C] [--tilt-relaxation K] [--tilt-play DEG] [--base-depth MM] [--gel-ratio R] [--pin-length MM] [--poisson NU] [--camera-distance MM]
//!   [--cells N] [--frame DEG[m][r]|auto] [--dump FILE] [--sensor-out FILE]`: track the lab's recordings and compare the
//!   simulated pin motion of one parameter set with the real one (undeformed positions, radial
//!   profiles by depth, the label frame found from the data, used with `--frame auto`, the
//!   error left after a per-recording affine map, errors by subset); `--dump` writes every
//!   recording's real and simulated fields as JSON (`tacsim calibrate` fits the parameters);
//! - `reproduce [--quick] [--out DIR] [--jobs N]`: the paper's study end to end (dataset, every model,
//!   evaluation report); see [`reproduce`];
//! - `explore [--out DIR] [--jobs N]`: contour following with learned perception: the
//!   `explore` dataset, the pose network and shear-removal model trained on it, their
//!   evaluation and the `scenarios/explore/learned/` runs; see [`explore`];
//! - `bench-model [--quick] [--pytorch PYTHON]`: training samples/s and inference images/s of
//!   the networks on flex at 256, 128 and 64 px (and on ndarray at 64 px when built with
//!   `--features ndarray`), and with `--pytorch`
//!   the same networks in PyTorch (`model/pytorch/bench.py` under that interpreter) on one
//!   thread and on every core, with the ratio to flex; writes `docs/model-bench.json`;
//! - `image-diff A B`: how two dataset folders differ: images by decoded pixels, other files by
//!   bytes (see [`image_diff`]);
//! - `bench`: run the benchmarks (criterion: renderer, contact operator products, a tap's solve and pin product) and print
//!   their figures; `tacsim bench` times whole taps and slides.

mod explore;
mod image_diff;
mod reproduce;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use tacsim_data::write_atomic;
use tacsim_sim::RigFrame;
use tacsim_sim::calibrate::{
    Deformation, ImageMap, Observations, Reference, SampleError, Simulator, best_frame, compare_sensor, fit_camera,
    fit_realism, label_frame, ring_table, shift_samples,
};
use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::stimulus::shape_files;
use tacsim_sim::{Realism, SensorParams, read_png};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// `cargo xtask`: project automation (see the module docs).
#[derive(Debug, Parser)]
#[command(name = "xtask", bin_name = "cargo xtask", about = "tacsim's project automation")]
struct Xtask {
    #[command(subcommand)]
    command: Task,
}

#[derive(Debug, Subcommand)]
enum Task {
    /// Regenerate the built-in stimuli in shapes/ (or check the committed files).
    Shapes {
        /// Check that the committed files are up to date instead of writing them.
        #[arg(long)]
        check: bool,
    },
    /// Fit the camera and ring layout to the lab's undeformed reference image and write
    /// sim/presets/tactip-331-camera.toml.
    FitCamera {
        /// The reference image (default: the surface recordings' image_0.png).
        #[arg(long)]
        real: Option<PathBuf>,
    },
    /// Run the criterion benchmarks (renderer, contact operator products, a tap's solve and pin product).
    Bench {
        /// Arguments passed on to criterion.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        criterion: Vec<String>,
    },
    /// How two dataset folders differ: images by decoded pixels, other files by bytes; exit
    /// status 1 when they differ.
    ImageDiff {
        /// The first folder.
        a: PathBuf,
        /// The second folder.
        b: PathBuf,
    },
    /// Track the lab's recordings and compare the simulated pin motion of one parameter set
    /// with the real one.
    RealCompare(Box<RealCompareArgs>),
    /// The paper's study end to end (dataset, every model, evaluation report).
    Reproduce {
        /// The CPU-scale study's quick plan.
        #[arg(long)]
        quick: bool,
        #[command(flatten)]
        run: reproduce::RunArgs,
    },
    /// Contour following with learned perception, end to end.
    Explore(reproduce::RunArgs),
    /// Training and inference throughput of the networks.
    BenchModel {
        /// 64 px on flex only; docs/model-bench.json is not written.
        #[arg(long)]
        quick: bool,
        /// A Python interpreter that imports torch: the same networks in PyTorch beside.
        #[arg(long, value_name = "PYTHON")]
        pytorch: Option<String>,
    },
}

/// `cargo xtask real-compare`'s flags: the parameter set (the calibrated default with the
/// changes named) and what to print or dump.
#[derive(Debug, clap::Args)]
struct RealCompareArgs {
    /// The lab folder (default: the surface recordings).
    #[arg(long)]
    real: Option<PathBuf>,
    /// Sensor file (default: the calibrated TacTip).
    #[arg(long)]
    sensor: Option<PathBuf>,
    /// Skin model: half-space, layer or skin-on-gel.
    #[arg(long)]
    skin: Option<String>,
    /// The rig's depth zero (mm).
    #[arg(long, value_name = "MM")]
    depth_offset: Option<f64>,
    /// Friction coefficient.
    #[arg(long, value_name = "MU")]
    friction: Option<f64>,
    /// Tilt pivot above the apex (mm).
    #[arg(long, value_name = "MM")]
    pivot: Option<f64>,
    /// The tilt pivot's offset off the sensor's axis (mm, `X,Y`), as `tacsim calibrate` fits it.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    pivot_offset: Option<String>,
    /// The rig's yield under load (mm^-0.5).
    #[arg(long, value_name = "C")]
    depth_compliance: Option<f64>,
    /// Tilt relaxation (1/mm).
    #[arg(long, value_name = "K")]
    tilt_relaxation: Option<f64>,
    /// The rig's play in tilt (deg), taken off each labelled tilt's size.
    #[arg(long, value_name = "DEG")]
    tilt_play: Option<f64>,
    /// Rigid base below the apex (mm).
    #[arg(long, value_name = "MM")]
    base_depth: Option<f64>,
    /// Gel over skin modulus ratio.
    #[arg(long, value_name = "R")]
    gel_ratio: Option<f64>,
    /// Pin length (mm).
    #[arg(long, value_name = "MM")]
    pin_length: Option<f64>,
    /// Poisson's ratio of the skin.
    #[arg(long, value_name = "NU")]
    poisson: Option<f64>,
    /// Refit the camera at this distance (mm).
    #[arg(long, value_name = "MM")]
    camera_distance: Option<f64>,
    /// Cells across the footprint (17, as `tacsim calibrate` fits).
    #[arg(long, default_value_t = 17)]
    cells: usize,
    /// The label frame: DEG, DEGm (mirrored first), DEGmr (tilts reversed too) or auto (found
    /// from the data); default the identity.
    #[arg(long, value_name = "DEG[m][r]|auto")]
    frame: Option<String>,
    /// Write every recording's real and simulated fields as JSON.
    #[arg(long, value_name = "FILE")]
    dump: Option<PathBuf>,
    /// Write the sensor compared (its camera refitted at `--camera-distance`, the skin and
    /// pin flags applied) as a sensor file, before the comparison runs.
    #[arg(long, value_name = "FILE")]
    sensor_out: Option<PathBuf>,
}

fn main() -> Result<()> {
    match Xtask::parse().command {
        Task::Shapes { check } => shapes(check),
        Task::FitCamera { real } => {
            fit(&real.unwrap_or_else(|| root().join("../shared/data/real-tactip-surface3d/images/image_0.png")))
        }
        Task::Bench { criterion } => bench(&criterion),
        Task::ImageDiff { a, b } => image_diff::run(&a, &b),
        Task::RealCompare(a) => real_compare(&a),
        Task::Reproduce { quick, run } => reproduce::run(quick, &run),
        Task::Explore(run) => explore::run(&run),
        Task::BenchModel { quick, pytorch } => bench_model(quick, pytorch.as_deref()),
    }
}

fn shapes(check: bool) -> Result<()> {
    let dir = root().join("shapes");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut stale = Vec::new();
    for (name, text) in shape_files()? {
        let path = dir.join(&name);
        let current = std::fs::read_to_string(&path).unwrap_or_default();
        if current == text {
            continue;
        }
        if check {
            stale.push(name);
        } else {
            write_atomic(&path, text.as_bytes())?;
            println!("wrote {}", path.display());
        }
    }
    if !stale.is_empty() {
        bail!("shapes/ is out of date ({}): run `cargo xtask shapes` and commit", stale.join(", "));
    }
    let catalogue = Catalogue::load_dir(&dir)?;
    for s in &catalogue.stimuli {
        let e = s.extent_mm();
        println!(
            "{:<10} {:>6.1} x {:>6.1} x {:>4.1} mm  area {:>8.1} mm2  perimeter {:>6.1} mm  {} (mu {})",
            s.name(),
            e[0],
            e[1],
            e[2],
            s.contour.area_mm2(),
            s.contour.perimeter_mm(),
            s.entry.material,
            s.entry.friction
        );
    }
    Ok(())
}

/// The camera-only fit: the previous default sensor and `tacsim calibrate`'s starting point.
const CAMERA_PRESET: &str = "sim/presets/tactip-331-camera.toml";

fn fit(real_path: &Path) -> Result<()> {
    let real =
        read_png(real_path).with_context(|| format!("the real reference image is needed: {}", real_path.display()))?;
    let name = real_path.display().to_string();
    let out = root().join(CAMERA_PRESET);
    let start = SensorParams::load(&out)?;
    let candidate = fit_camera(&start, &real, &name)?;
    // Keep the current preset when the refit does not improve it measurably, so rerunning
    // the command on an already fitted preset leaves it byte-identical.
    let old = compare_sensor(&start, &real, &name)?;
    let new = compare_sensor(&candidate, &real, &name)?;
    let keep = old.0.ring_radius_rms_px <= new.0.ring_radius_rms_px + 0.01
        && old.0.area_rel_err.abs() <= new.0.area_rel_err.abs() + 0.01;
    let (fitted, (cmp, sim, real_p)) = if keep {
        println!("the current preset is already at the optimum (refit gains < 0.01 px, < 1% area); keeping it");
        (start.clone(), old)
    } else {
        (candidate, new)
    };
    print!("{}", ring_table(&sim, &real_p));
    println!(
        "ring radius RMS {:.3} px (max {:.3}), mean blob area error {:+.1}%, centre offset {:.2} px",
        cmp.ring_radius_rms_px,
        cmp.ring_radius_max_px,
        100.0 * cmp.area_rel_err,
        cmp.centre_offset_px
    );
    let header = format!(
        "# TacTip 331, camera and ring layout fitted to the lab's processed 420 px reference\n\
         # ({}) by `cargo xtask fit-camera`.\n\
         # Ring radius RMS {:.3} px, blob area error {:+.1}%. The default sensor until the calibration\n\
         # against the real recordings (tactip-331-calibrated.toml, now the default) and its starting point.\n\n",
        real_path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        cmp.ring_radius_rms_px,
        100.0 * cmp.area_rel_err
    );
    let (realism, realism_err) = fit_realism(&fitted, &Realism::default(), &real, &name)?;
    println!(
        "realism: pin_radius_scale {:.4} (Realism::default() has {:.4}) gives blob area error {:+.1}%",
        realism.pin_radius_scale,
        Realism::default().pin_radius_scale,
        100.0 * realism_err
    );
    if (realism.pin_radius_scale - Realism::default().pin_radius_scale).abs() > 0.005 {
        println!("copy pin_radius_scale into Realism::default() in sim/src/realism.rs");
    }
    write_atomic(&out, format!("{header}{}", fitted.to_toml()).as_bytes())?;
    println!("wrote {}", out.display());
    if fitted != start {
        println!("the camera fit changed: rerun `tacsim calibrate` from it (docs/guide/calibration.md)");
    }
    Ok(())
}

fn bench(extra: &[String]) -> Result<()> {
    let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(root())
        .args(["bench", "-p", "tacsim-sim", "--bench", "render", "--bench", "contact", "--bench", "tap", "--"])
        .args(extra)
        .status()
        .context("running cargo bench")?;
    if !status.success() {
        bail!("cargo bench failed");
    }
    Ok(())
}

fn real_compare(args: &RealCompareArgs) -> Result<()> {
    let [lo, hi] = tacsim_sim::TILT_PLAY_RANGE_DEG;
    if let Some(play) = args.tilt_play.filter(|p| !(lo..=hi).contains(p)) {
        bail!("--tilt-play {play}: expected a play in tilt of {lo} to {hi} deg, as a recipe's [rig] tilt_play_deg");
    }
    let dir = args.real.clone().unwrap_or_else(|| root().join("../shared/data/real-tactip-surface3d"));
    let lab = tacsim_data::LabFolder::open(&dir)?;
    let reference = Reference::of(&lab, None, Default::default())?;
    let obs = Observations::track(&lab, &reference)?;
    let n = obs.reference.len();
    let tracked: Vec<usize> = obs.samples.iter().map(|o| n - o.tracking.unmatched()).collect();
    println!(
        "{}: {} recordings, {n} reference pins, tracked per recording: mean {:.1}, min {}",
        dir.display(),
        obs.samples.len(),
        tracked.iter().sum::<usize>() as f64 / tracked.len().max(1) as f64,
        tracked.iter().min().copied().unwrap_or(0)
    );
    let (base, d) = compared_model(args, &reference)?;
    if let Some(path) = &args.sensor_out {
        write_atomic(path, d.sensor(&base)?.to_toml().as_bytes())
            .with_context(|| format!("--sensor-out {}", path.display()))?;
    }
    let cat = Catalogue::load_dir(&root().join("shapes"))?;
    let disk = cat.get("disk")?;
    // 17 cells across the footprint, as `tacsim calibrate` fits; `--cells` for a finer grid.
    let sim = Simulator::new(&base, &d, args.cells, &obs, &disk)?;
    let (rms, matched) = sim.undeformed_rms(&obs);
    println!("{d:?}\nundeformed: {matched} pins matched, RMS {rms:.2} px from the real reference");
    println!("radial displacement (px, outward), real / simulated untilted tap, recordings tilted < 8 deg:");
    println!("depth      r 0-25%        25-50%        50-75%        75-100%");
    for (band, row) in sim.radial_profiles(&obs, 8.0)?.iter().enumerate() {
        let cells: Vec<String> = row.iter().map(|(re, si, _)| format!("{re:5.1} / {si:5.1}")).collect();
        println!("{}-{} mm   {}", band + 1, band + 2, cells.join("   "));
    }
    let found = found_frame(&sim, &obs)?;
    let frame = chosen_frame(args.frame.as_deref(), found)?;
    // One simulation per recording serves the errors, the affine residual and the dump.
    let all: Vec<usize> = (0..obs.samples.len()).collect();
    let fields = sim.fields(&obs, &all, &frame)?;
    let errs: Vec<_> = fields.iter().enumerate().map(|(k, f)| sim.error(&obs, k, f)).collect();
    let affine: Vec<f64> = fields.iter().enumerate().filter_map(|(k, f)| sim.affine_residual(&obs, k, f)).collect();
    println!(
        "all recordings, mean relative error left after the best affine map of each simulated field onto the real one: {:.2}",
        affine.iter().sum::<f64>() / affine.len().max(1) as f64
    );
    if let Some(path) = &args.dump {
        let rows: Vec<serde_json::Value> = fields
            .iter()
            .zip(&obs.samples)
            .map(|(d, o)| {
                let simd: Vec<Option<[f64; 2]>> = sim.reference_to_sim().iter().map(|m| m.and_then(|i| d[i])).collect();
                serde_json::json!({"pose": o.sample.pose, "shear": o.sample.shear, "real": o.tracking.displacement, "sim": simd})
            })
            .collect();
        write_atomic(path, &serde_json::to_vec(&serde_json::json!({"reference": obs.reference, "samples": rows}))?)?;
    }
    print_errors(&errs, &obs);
    Ok(())
}

/// The sensor (`--sensor`, its camera refitted at `--camera-distance`) and the deformation
/// with `--skin` and every parameter flag given.
fn compared_model(args: &RealCompareArgs, reference: &Reference) -> Result<(SensorParams, Deformation)> {
    let mut base = match &args.sensor {
        Some(p) => SensorParams::load(p)?,
        // The layered skins' analytic model compares on the half-space preset's skin.
        None => SensorParams::half_space(),
    };
    if let Some(v) = args.camera_distance {
        base = tacsim_sim::calibrate::fit_camera_at(&base, &reference.image, &reference.describe(), Some(v))?;
        println!("camera refitted at {v} mm: {:?}", base.camera);
    }
    let mut d = Deformation::of(&base, 0.5);
    if let Some(m) = &args.skin {
        d.model = m.parse().map_err(|e| anyhow::anyhow!("--skin {m}: {e}"))?;
    }
    for (value, field) in [
        (args.depth_offset, &mut d.depth_offset_mm),
        (args.pivot, &mut d.pivot_mm),
        (args.depth_compliance, &mut d.depth_compliance),
        (args.tilt_relaxation, &mut d.tilt_relaxation_per_mm),
        (args.tilt_play, &mut d.tilt_play_deg),
        (args.base_depth, &mut d.base_depth_mm),
        (args.gel_ratio, &mut d.gel_ratio),
        (args.pin_length, &mut d.pin_length_mm),
        (args.poisson, &mut d.poisson),
        (args.friction, &mut d.friction),
    ] {
        if let Some(v) = value {
            *field = v;
        }
    }
    if let Some(xy) = &args.pivot_offset {
        let parsed: Option<Vec<f64>> =
            xy.split(',').map(|v| v.trim().parse::<f64>().ok().filter(|v| v.is_finite())).collect();
        let [x, y] = parsed.as_deref().unwrap_or_default()[..] else {
            bail!("--pivot-offset {xy}: expected two finite numbers in mm, `X,Y`")
        };
        d.pivot_offset_mm = [x, y];
    }
    Ok((base, d))
}

/// The label frame found from the data (the real and the simulated, identity-frame global
/// shifts regressed on the labels), printed.
fn found_frame(sim: &Simulator, obs: &Observations) -> Result<RigFrame> {
    let all: Vec<usize> = (0..obs.samples.len()).collect();
    let identity = sim.errors(obs, &all, &RigFrame::IDENTITY)?;
    let [real_samples, sim_samples] = shift_samples(obs.samples.iter().map(|o| &o.sample), &identity);
    let too_few = "too few recordings to find the label frame";
    let (real_map, sim_map) =
        (ImageMap::fit(&real_samples).context(too_few)?, ImageMap::fit(&sim_samples).context(too_few)?);
    for (name, m) in [("real", &real_map), ("simulated", &sim_map)] {
        println!(
            "{name} shift per label offset: rotation {:.1} deg{}, {:.2} px/mm, isotropy {:.2}, residual {:.2} px RMS",
            m.rotation_deg,
            if m.mirrored { " mirrored" } else { "" },
            m.gain_px_per_mm,
            m.isotropy,
            m.rms_px
        );
    }
    let fit = best_frame(&real_samples, &sim_map).context(too_few)?;
    println!(
        "label frame from the data: rotation {:.0} deg{}, real/simulated slide gain {:.2}, tilt gain {:.2}, shift residual {:.2} px RMS (the slide map alone: {:?})",
        fit.rotation_deg,
        if fit.mirrored { " mirrored" } else { "" },
        fit.slide_gain,
        fit.tilt_gain,
        fit.rms_px,
        label_frame(&real_map, &sim_map).m
    );
    Ok(fit.frame)
}

/// The label frame `--frame` asks for: `DEG`, `DEGm`, `DEGmr` (labels rotated by DEG,
/// mirrored first with `m`, tilts reversed with `r`), `auto` (the one `found` from the data);
/// by default the identity.
fn chosen_frame(flag: Option<&str>, found: RigFrame) -> Result<RigFrame> {
    Ok(match flag {
        Some("auto") => found,
        Some(f) => {
            let reversed = f.ends_with('r');
            let f = f.trim_end_matches('r');
            RigFrame::new(f.trim_end_matches('m').parse()?, f.ends_with('m')).with_tilts_reversed(reversed)
        }
        None => RigFrame::IDENTITY,
    })
}

/// Mean errors of the shallow untilted, the shallow and all recordings.
fn print_errors(errs: &[SampleError], obs: &Observations) {
    for (name, zmax, tmax) in
        [("depth <= 2.5 mm, tilt < 8 deg", 2.5, 8.0), ("depth <= 2.5 mm", 2.5, 90.0), ("all", f64::INFINITY, 90.0)]
    {
        let sel: Vec<_> = errs
            .iter()
            .zip(&obs.samples)
            .filter(|(_, o)| o.sample.pose[2] <= zmax && o.sample.pose[3].abs().max(o.sample.pose[4].abs()) < tmax)
            .map(|(e, _)| e)
            .collect();
        let mean = |f: &dyn Fn(&&SampleError) -> f64| sel.iter().map(f).sum::<f64>() / sel.len().max(1) as f64;
        println!(
            "{name}: {} recordings, mean error {:.2} px against mean real motion {:.2} px, mean relative error {:.2}",
            sel.len(),
            mean(&|e| e.error_px),
            mean(&|e| e.real_px),
            mean(&|e| e.relative())
        );
    }
}

/// `cargo xtask bench-model [--quick] [--pytorch PYTHON]`: throughput of the networks (`tacsim_model::measure_networks`).
/// `--quick` measures 64 px on flex only.
fn bench_model(quick: bool, python: Option<&str>) -> Result<()> {
    use tacsim_model::Backend;
    use tacsim_model::BenchRow;
    if let Some(python) = python {
        // Checked before the burn measurements, which take minutes.
        let ok = Command::new(python)
            .args(["-c", "import torch, numpy"])
            .status()
            .with_context(|| format!("running {python}: is it a Python interpreter?"))?;
        if !ok.success() {
            bail!("{python} cannot import torch and numpy: install them (`pip install torch numpy`)");
        }
    }
    let mut cases = vec![(Backend::Flex, 64)];
    if !quick {
        cases = vec![(Backend::Flex, 256), (Backend::Flex, 128), (Backend::Flex, 64)];
        #[cfg(feature = "ndarray")]
        cases.push((Backend::Ndarray, 64));
    }
    let sizes: Vec<usize> = cases.iter().filter(|c| c.0 == Backend::Flex).map(|c| c.1).collect();
    println!(
        "| backend | size | batch | self-supervised samples/s | supervised samples/s | posenet samples/s | inference images/s |"
    );
    println!("|---|---|---|---|---|---|---|");
    let print = |r: &BenchRow| {
        println!(
            "| {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} |",
            r.backend,
            r.size,
            r.batch,
            r.self_supervised_samples_per_s,
            r.supervised_samples_per_s,
            r.posenet_samples_per_s,
            r.inference_images_per_s
        )
    };
    let mut rows = Vec::new();
    for (backend, size) in cases {
        let r = tacsim_model::measure_networks(backend, size)?;
        print(&r);
        rows.push(r);
    }
    if let Some(python) = python {
        // The same networks and steps in PyTorch (model/pytorch/bench.py): one thread, as
        // flex runs here, then every core.
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let list = sizes.iter().map(ToString::to_string).collect::<Vec<_>>().join(",");
        let mut one_thread = Vec::new();
        for threads in if cores > 1 { vec![1, cores] } else { vec![1] } {
            let out = root().join("target").join(format!("model-bench-pytorch-{threads}.json"));
            let status = Command::new(python)
                .arg(root().join("model/pytorch/bench.py"))
                .args(["--threads", &threads.to_string(), "--sizes", &list, "--json"])
                .arg(&out)
                .stdout(std::process::Stdio::null())
                .status()
                .with_context(|| format!("running {python}: is it a Python interpreter?"))?;
            if !status.success() {
                bail!(
                    "model/pytorch/bench.py failed under {python}: install PyTorch and numpy (`pip install torch numpy`)"
                );
            }
            let text = std::fs::read(&out).with_context(|| format!("reading {}", out.display()))?;
            let torch: Vec<BenchRow> =
                serde_json::from_slice(&text).with_context(|| format!("parsing {}", out.display()))?;
            torch.iter().for_each(print);
            if threads == 1 {
                one_thread.clone_from(&torch);
            }
            rows.extend(torch);
        }
        println!("\nPyTorch (one thread) over flex, per column:\n");
        println!("| size | self-supervised | supervised | posenet | inference |\n|---|---|---|---|---|");
        for &size in &sizes {
            let flex = rows.iter().find(|r| r.size == size && r.backend == Backend::Flex.to_string());
            let torch = one_thread.iter().find(|r| r.size == size);
            if let (Some(f), Some(t)) = (flex, torch) {
                println!(
                    "| {size} | {:.1}x | {:.1}x | {:.1}x | {:.1}x |",
                    t.self_supervised_samples_per_s / f.self_supervised_samples_per_s,
                    t.supervised_samples_per_s / f.supervised_samples_per_s,
                    t.posenet_samples_per_s / f.posenet_samples_per_s,
                    t.inference_images_per_s / f.inference_images_per_s
                );
            }
        }
    }
    if !quick {
        let path = root().join("docs/model-bench.json");
        write_atomic(&path, &serde_json::to_vec_pretty(&rows)?)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
