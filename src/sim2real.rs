//! `tacsim sim2real`: does a network trained only on simulated images read a lab's real ones?
//!
//! One pipeline, each stage a named step whose output lands under `--out`, so an interrupted
//! run resumes where it stopped:
//! 1. `generate_sim`: the recipe's dataset with the sensor (`sim/`), or `--sim`, one made before.
//!    With `--input motion`, `motion_inputs` then puts each image's pin motion from its own
//!    domain's undeformed reference in place of the pin image, in both sets
//!    (`tacsim_sim::PinMotion`; computed again on a resumed run, in about a minute);
//! 2. `train_both`: the pose network on the simulated images (`sim-posenet/`) and the same
//!    network, same settings, on the lab folder's fitting part (`real-posenet/`); with
//!    `--edge-frame`, `train_edge_frame`: a second network on the simulated images turned
//!    into the edge's frame (`sim-edge-posenet/`), and `train_real_edge_frame`: one on the
//!    lab's fitting images turned by their labelled yaws (`real-edge-posenet/`), so that the
//!    real-trained network is read as the simulator-trained one is;
//! 3. `score_transfer` (tacsim-model's `transfer::score`): the label map (component, sign and
//!    offset, `LabelMap::fit`) from the
//!    simulator-trained network's readings of the fitting part, then both networks on the
//!    held-out part (the 20% `tacsim calibrate` never fits either);
//! 4. `report.md`, `report.json`, `predictions.csv` (each held-out image's labels and both
//!    networks' readings, in the lab's frame), `fitting.csv` (each fitting image's labels and
//!    the simulator-trained reading) and `grid.png` (held-out real images beside the
//!    simulated image nearest them in label), in `--report` (default `--out`).
//!
//! Every label that varies over the lab's fitting part is scored (the edge recordings'
//! lateral `pose_2`, depth `pose_3` and yaw `pose_6`; the surface recordings' depth, tilts and
//! slide offsets). The real-trained network reads those labels; the simulator-trained one
//! reads every label that varies over the simulated training images (taps, or the slides when
//! the lab's labels include a slide offset), and the map picks which of its readings is which
//! lab label.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};
use image::GrayImage;
use serde::Serialize;
use tacsim_data::Column;
use tacsim_data::Split;
use tacsim_model::{
    Backend, Corpus, Coverage, EdgeStage, LabelScore, PoseConfig, Scores, Scoring, Span, label_name, score_transfer,
    transfer_coverage,
};

use crate::dataset::GenerateOptions;
use crate::learn::{Bar, LabOptions};

/// Options of `tacsim sim2real`.
#[derive(Clone, Debug, clap::Args)]
pub struct Sim2RealOptions {
    /// The lab folder (`targets.csv` + `images/`); its held-out 20% is the test.
    #[arg(long)]
    pub real: PathBuf,
    /// Recipe of the simulated set: a file or a built-in name.
    #[arg(long, default_value = "edge-2d")]
    pub recipe: String,
    /// Sensor file or built-in preset (default: the recipe's `sensor`, else the calibrated
    /// TacTip).
    #[arg(long)]
    pub sensor: Option<PathBuf>,
    /// A simulated dataset made beforehand (`tacsim generate`, shards merged, or several sets
    /// joined) to train on instead of generating the recipe's; the recipe is then unused.
    #[arg(long, conflicts_with_all = ["recipe", "sensor"])]
    pub sim: Option<PathBuf>,
    /// Work directory: the simulated set (sim/) and the two runs; rerun to resume.
    #[arg(long)]
    pub out: PathBuf,
    /// Where report.md, report.json, predictions.csv, fitting.csv and grid.png go (default: --out).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Pose network config (TOML, the fields of `tacsim train posenet --config`) for both
    /// trainings; the flags below override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Network image side: 32, 64, 128 or 256.
    #[arg(long, default_value_t = 64)]
    pub size: usize,
    /// Epochs of both trainings.
    #[arg(long, default_value_t = 30)]
    pub epochs: usize,
    /// Seed of both trainings.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Backend: flex (default); wgpu, cuda and ndarray with the crate features of those names.
    #[arg(long, default_value = "flex")]
    pub backend: Backend,
    /// What both networks read: `pins`, the pin images; `motion`, each image's pin motion
    /// from its own domain's undeformed reference (the simulated set's `reference_image`, the
    /// lab folder's reference as `tacsim calibrate` takes it), which does not carry where the
    /// sensor's pins sit off the simulated lattice.
    #[arg(long, value_enum, default_value_t = Input::Pins)]
    pub input: Input,
    /// With `--input motion`: the pins tracked, those within this fraction of the image's
    /// half-side from its centre, in [0.2, 1] (default 0.6875, 44 px of 64: the edge taps'
    /// outer ring spreads into the rim's clutter; 1, every pin, reads the surface presses
    /// better).
    #[arg(long, value_parser = crate::flags::motion_field)]
    pub motion_field: Option<f64>,
    /// Re-estimate the simulator-trained network's batch-norm statistics on the lab's fitting
    /// images (their labels unused) before the map is fitted and the held-out part scored:
    /// unsupervised adaptation (AdaBN); the weights stay trained on simulated images only.
    #[arg(long)]
    pub adapt_norms: bool,
    /// With `--input motion`, on a set whose labels a turn leaves alone but the yaw (pose_x,
    /// pose_y, pose_z, pose_Rz: the edge recipes): the simulator-trained network reads each
    /// lab image this many times, turned about its centre by 360/N deg steps, its readings
    /// averaged with the yaw turned back (1 to 64; 1: the images as they are). The
    /// real-trained network and the fine-tuning curve read the images as they are.
    #[arg(long, default_value_t = 1, value_parser = crate::flags::turns)]
    pub turns: usize,
    /// With `--input motion`, on the same sets as `--turns`: read in the edge's frame. A second
    /// network, trained on the simulated images each turned by minus its own yaw, reads the
    /// lateral offset and the depth from each lab image turned by minus the yaw the
    /// simulator-trained network reads of it (with `--turns`, averaged over the turns); the
    /// yaw stays the first network's. The real-trained network reads the images as they are.
    /// With `--finetune`, each arm of the curve reads in the edge's frame too: a second
    /// network trained on the K turned by their labelled yaws (the pretrained arm's from the
    /// simulator's second network) reads what the arm's first network's yaw turns.
    #[arg(long)]
    pub edge_frame: bool,
    /// With `--edge-frame`: each lab image, once turned into the edge's frame, matched pixel by
    /// pixel to the simulated images in that frame, every value's mean and spread over the
    /// lab's fitting images taken to the simulated training images' (labels unused:
    /// unsupervised adaptation of the second network's input; with `--finetune`, the
    /// pretrained arm's too).
    #[arg(long, requires = "edge_frame")]
    pub match_motion: bool,
    /// Fit the lab sensor's axis offset into the label map: each lateral label also gets `a
    /// cos(yaw) + b sin(yaw)` (mm, the yaw the simulator-trained network reads), fitted on the
    /// fitting part with the offset, as a sensor off the robot's yaw axis (or an image centred
    /// off its pin field) shifts the lateral with the yaw. For sets whose network reads the
    /// yaw (the edge recipes); the fine-tuning curve's maps are fitted without it.
    #[arg(long)]
    pub axis_offset: bool,
    /// After the zero-shot run, the fine-tuning curve: for each of these counts K of the lab's
    /// labelled fitting samples (`all`: every one), the simulator-trained network fine-tuned
    /// on K and the same network trained from scratch on them, both on the held-out part
    /// (finetune.md, finetune.json, finetune.svg). Example: 25,50,100,200,400,all
    #[arg(long, value_parser = crate::finetune::ks)]
    pub finetune: Option<crate::finetune::Ks>,
    /// Seeds per K of the fine-tuning curve (1 to 20).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=20))]
    pub finetune_seeds: u64,
    /// The fewest optimiser steps of either arm of the curve at any K (1 to 100,000): a small K
    /// trains more epochs to reach it.
    #[arg(long, default_value_t = tacsim_model::FINETUNE_MIN_STEPS, value_parser = crate::flags::finetune_min_steps)]
    pub finetune_min_steps: usize,
    /// The fine-tuned (pretrained) arm's learning rate as a factor on the real-trained
    /// network's, in (0, 1] (the same steps; the from-scratch arm keeps the rate).
    #[arg(long, default_value_t = 1.0, value_parser = crate::flags::finetune_lr_scale)]
    pub finetune_lr_scale: f64,
    /// The share of the fine-tuned (pretrained) arm's training samples drawn from the
    /// simulated set, in [0, 0.9]: K s / (1 - s) simulated images join the K real ones, in the
    /// same optimiser steps (0: the K alone).
    #[arg(long, default_value_t = 0.0, value_parser = crate::flags::finetune_sim_share)]
    pub finetune_sim_share: f64,
    /// The lab folder's preprocessing.
    #[command(flatten)]
    pub lab: LabOptions,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

/// What the networks read (`--input`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Input {
    /// The pin images, as rendered and as recorded.
    #[default]
    Pins,
    /// Each image's pin motion from its domain's undeformed reference, drawn as an image
    /// (`tacsim_sim::PinMotion`).
    Motion,
}

/// `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Sim2RealReport {
    /// The command that made the report.
    pub command: String,
    /// The lab folder.
    pub real: String,
    /// The recipe (or the `--sim` dataset).
    pub recipe: String,
    /// Simulated training images.
    pub sim_train: usize,
    /// The labels the simulator-trained network reads.
    pub sim_labels: Vec<Column>,
    /// Real recordings the real-trained network and the label map saw.
    pub real_fitting: usize,
    /// Real recordings neither saw: the test.
    pub real_held_out: usize,
    /// The pose networks' settings (both; `labels` are the lab's, the real-trained network's).
    pub posenet: PoseConfig,
    /// What both networks read.
    pub input: Input,
    /// With `--input motion`, the references the motion is tracked from (simulated, lab).
    pub motion_references: Option<[String; 2]>,
    /// With `--input motion`, the part of the pin field tracked (`--motion-field`).
    pub motion_field: Option<f64>,
    /// Whether the simulator-trained network's batch-norm statistics were re-estimated on the
    /// lab's fitting images (`--adapt-norms`).
    pub adapt_norms: bool,
    /// How many turns of each lab image the simulator-trained network's readings average
    /// (`--turns`; 1: none).
    pub turns: usize,
    /// Whether a second simulator-trained network read the labels a turn leaves alone from
    /// each image turned into the edge's frame (`--edge-frame`).
    pub edge_frame: bool,
    /// Whether the second network's input was matched to the simulated images' mean and
    /// spread, pixel by pixel (`--match-motion`).
    pub match_motion: bool,
    /// Whether the label map carries the lab sensor's axis offset (`--axis-offset`).
    pub axis_offset: bool,
    /// The fitted label map.
    pub map: Vec<String>,
    /// Errors per label on the held-out part.
    pub labels: Vec<LabelScore>,
    /// The simulated poses against the lab's, per mapped label.
    pub coverage: Vec<Coverage>,
    /// Wall time of this run (s): stages found finished in the work folder (a resumed run) are
    /// not counted.
    pub seconds: f64,
}

/// Runs `tacsim sim2real`; `command` is recorded in the report. Returns the summary to print.
pub fn sim2real(o: &Sim2RealOptions, command: &str) -> Result<String> {
    let started = std::time::Instant::now();
    let file: PoseConfig = crate::learn::load_config(o.config.as_deref())?;
    if file.labels != PoseConfig::default().labels {
        bail!(
            "{}: field `labels`: sim2real picks each network's labels itself (every label that varies in its images); remove the field",
            o.config.as_deref().map_or("--config".into(), |p| p.display().to_string())
        );
    }
    let cfg = PoseConfig { size: o.size, epochs: o.epochs, seed: o.seed, ..file };
    cfg.validate()?;
    // Bad input stops here, before any work: the recipe, its sensor, the outputs.
    if o.sim.is_none() {
        let (recipe, _) = crate::dataset::load_recipe(Some(&o.recipe))?;
        crate::dataset::recipe_base_sensor(&recipe, &generate_options(o))?;
    }
    if o.input == Input::Pins && o.motion_field.is_some() {
        bail!(
            "--motion-field sets the part of the pin field tracked with --input motion: add --input motion or drop it"
        );
    }
    if o.input == Input::Pins && o.edge_frame {
        bail!(
            "--edge-frame turns the pin motion's grids into the edge's frame: add --input motion or drop it (a turned \
             pin image puts the pins off the lattice the network learnt)"
        );
    }
    if o.input == Input::Pins && o.turns > 1 {
        bail!(
            "--turns turns the pin motion's grids: add --input motion or drop it (a turned pin image puts the pins off \
             the lattice the network learnt)"
        );
    }
    let motion_field = (o.input == Input::Motion).then(|| o.motion_field.unwrap_or(tacsim_sim::MOTION_FIELD));
    if o.input == Input::Motion && (o.lab.crop.is_some() || o.lab.threshold.is_some()) {
        bail!(
            "--input motion tracks the lab's images at their own size, cut about their pin field as `tacsim calibrate` \
             cuts them: drop --crop and --threshold"
        );
    }
    let report_dir = o.report.clone().unwrap_or_else(|| o.out.clone());
    let _made = crate::commands::ensure_writable(&o.out)?.and(crate::commands::ensure_writable(&report_dir)?);
    let mut real = Corpus::open_lab(&o.real, &o.lab.preprocess(o.size))
        .with_context(|| format!("{} is not a lab folder (targets.csv + images/)", o.real.display()))?;
    let lab_train: Vec<usize> =
        (0..real.dataset.rows.len()).filter(|&r| real.dataset.rows[r].split == Split::Train).collect();
    let real_labels = real.varying(&Column::ALL, &lab_train);
    if real_labels.is_empty() {
        bail!("no label varies over the fitting part of {}: sim2real scores the labels that vary", o.real.display());
    }
    let fitting = real.pose_rows(Split::Train, &real_labels);
    let held_out = real.pose_rows(Split::Test, &real_labels);
    if fitting.len() < 10 || held_out.is_empty() {
        bail!(
            "{} has {} fitting and {} held-out recordings: sim2real needs at least 10 and 1",
            o.real.display(),
            fitting.len(),
            held_out.len()
        );
    }
    let real_cfg = PoseConfig { labels: real_labels.clone(), ..cfg.clone() };

    let sim_dir = match &o.sim {
        Some(dir) => dir.clone(),
        None => generate_sim(o)?,
    };
    let mut sim = Corpus::open(&sim_dir, o.size).with_context(|| {
        format!("{} is not a simulated dataset (meta.json, targets.csv, images/)", sim_dir.display())
    })?;
    let motion_references = match motion_field {
        None => None,
        Some(field) => Some(motion_inputs(&mut sim, &mut real, o.size, field)?),
    };
    let sim_rows = sim.pose_rows(Split::Train, &real_labels);
    let sim_labels = sim.varying(&Column::ALL, &sim_rows);
    if sim_labels.is_empty() {
        bail!("no label varies over the simulated training images of {}: check the recipe's ranges", sim_dir.display());
    }
    let sim_cfg = PoseConfig { labels: sim_labels.clone(), ..cfg.clone() };
    let turns = (o.turns > 1).then_some(tacsim_model::Turns { count: o.turns, turn: tacsim_sim::turn_motion });
    if let Some(t) = &turns {
        t.check(&sim_labels).with_context(|| format!("the simulated set {}", sim_dir.display()))?;
    }
    if o.axis_offset && !sim_labels.contains(&Column::PoseRz) {
        bail!(
            "--axis-offset turns the lateral's map with the yaw, but the simulator-trained network does not read the \
             yaw (no pose_Rz varies over the simulated training images of {}): use a recipe whose poses draw a yaw (the \
             edge recipes) or drop the flag",
            sim_dir.display()
        );
    }
    let edge_labels = match o.edge_frame {
        false => None,
        true => Some(
            tacsim_model::edge_frame_labels(&sim_labels)
                .with_context(|| format!("the simulated set {}", sim_dir.display()))?,
        ),
    };
    // The real-trained network (and the curve's from-scratch arm) reads the lab's own labels
    // in the edge's frame.
    let real_edge_labels = match o.edge_frame {
        false => None,
        true => Some(
            tacsim_model::edge_frame_labels(&real_labels)
                .with_context(|| format!("the lab's labels in {} (--edge-frame)", o.real.display()))?,
        ),
    };
    let (sim_run, real_run) = train_both(o, [&sim_cfg, &real_cfg], &sim, &real)?;
    let edge = match edge_labels {
        None => None,
        Some(labels) => {
            let edge_cfg = PoseConfig { labels, ..cfg.clone() };
            Some(train_edge_frame(o, &edge_cfg, &sim, &sim_rows, &sim_run)?)
        }
    };
    let real_edge = match (&edge, real_edge_labels) {
        (Some((_, sense)), Some(labels)) => {
            let edge_cfg = PoseConfig { labels, ..real_cfg.clone() };
            Some(train_real_edge_frame(o, &edge_cfg, (&real, &fitting, &real_labels), &sim_run, *sense)?)
        }
        _ => None,
    };
    // The lab's images are matched to the simulated ones for the simulator's second network
    // only.
    fn stage((run, sense): &(PathBuf, f64), match_motion: bool) -> EdgeStage<'_> {
        EdgeStage { run, sense: *sense, turn: tacsim_sim::turn_motion, match_motion }
    }
    let edge_stage = edge.as_ref().map(|e| stage(e, o.match_motion));
    let real_edge_stage = real_edge.as_ref().map(|e| stage(e, false));
    let how =
        Scoring { backend: o.backend, size: o.size, adapt_norms: o.adapt_norms, turns, axis_offset: o.axis_offset };
    let Scores { labels, map, nearest, predictions, fitting: fitting_csv } = score_transfer(
        &how,
        [&sim, &real],
        &real_labels,
        [&fitting, &held_out, &sim_rows],
        [&sim_run, &real_run],
        [edge_stage, real_edge_stage],
    )?;
    tacsim_data::write_atomic(&report_dir.join("predictions.csv"), predictions.as_bytes())?;
    tacsim_data::write_atomic(&report_dir.join("fitting.csv"), fitting_csv.as_bytes())?;
    write_grid(&report_dir.join("grid.png"), &sim, &real, &held_out, &nearest)?;
    let coverage = transfer_coverage(&map, [&sim, &real], [&sim_rows, &fitting]);

    let report = Sim2RealReport {
        command: command.to_owned(),
        real: o.real.display().to_string(),
        recipe: o.sim.as_ref().map_or_else(|| o.recipe.clone(), |d| d.display().to_string()),
        sim_train: sim_rows.len(),
        sim_labels,
        real_fitting: fitting.len(),
        real_held_out: held_out.len(),
        posenet: real_cfg,
        input: o.input,
        motion_references,
        motion_field,
        adapt_norms: o.adapt_norms,
        turns: o.turns,
        edge_frame: o.edge_frame,
        match_motion: o.match_motion,
        axis_offset: o.axis_offset,
        map: map.describe(),
        labels,
        coverage,
        seconds: started.elapsed().as_secs_f64(),
    };
    let json = serde_json::to_string_pretty(&report)?;
    tacsim_data::write_atomic(&report_dir.join("report.json"), json.as_bytes())?;
    let md = markdown(&report);
    tacsim_data::write_atomic(&report_dir.join("report.md"), md.as_bytes())?;
    let mut out = format!("{md}\nreport: {}\n", report_dir.join("report.md").display());
    if let Some(ks) = &o.finetune {
        let curve = tacsim_model::FinetuneCurve {
            how,
            real: &real,
            labels: &real_labels,
            fitting: &fitting,
            held_out: &held_out,
            sim_run: &sim_run,
            cfg: &report.posenet,
            min_steps: o.finetune_min_steps,
            pretrained_lr_scale: o.finetune_lr_scale,
            sim: &sim,
            sim_rows: &sim_rows,
            sim_share: o.finetune_sim_share,
            edge: edge_stage,
            dir: o.out.join("finetune"),
        };
        let real_all: Vec<f64> = report.labels.iter().map(|l| l.real_trained).collect();
        let md = crate::finetune::run(&curve, ks, o.finetune_seeds, &real_all, o.quiet, command, &report_dir)?;
        out.push_str(&format!("\n{md}\nfine-tuning curve: {}\n", report_dir.join("finetune.md").display()));
    }
    Ok(out)
}

/// Step 1: the simulated set under `out/sim` (resumed when a previous run started it).
fn generate_sim(o: &Sim2RealOptions) -> Result<PathBuf> {
    let g = generate_options(o);
    let line = crate::dataset::generate(&g).context("generating the simulated set")?;
    if !o.quiet {
        eprint!("{line}");
    }
    Ok(g.out)
}

/// `tacsim generate`'s options for the simulated set (`out/sim`, resumed where it exists).
fn generate_options(o: &Sim2RealOptions) -> GenerateOptions {
    let dir = o.out.join("sim");
    GenerateOptions {
        recipe: Some(o.recipe.clone()),
        resume: dir.join("meta.json").is_file(),
        out: dir,
        sensor: o.sensor.clone(),
        quiet: o.quiet,
        ..GenerateOptions::default()
    }
}

/// Step 1b (`--input motion`): every image of both sets replaced by its pin motion
/// (`tacsim_sim::PinMotion`, at the network side `side`, the pins within `field` of the
/// half-side from the image's centre) from its own domain's undeformed
/// reference: the simulated set's `reference_image`; the lab folder's `image_0.png` where it
/// has one, else the consensus of its taps that touch nothing (`tacsim calibrate`'s
/// reference; each recording cut about the reference's pin field as calibrate cuts it).
/// Returns the two references, described.
fn motion_inputs(sim: &mut Corpus, real: &mut Corpus, side: usize, field: f64) -> Result<[String; 2]> {
    use rayon::prelude::*;
    use tacsim_sim::PinMotion;
    use tacsim_sim::calibrate::{ConsensusRule, Reference};
    let side_px = side as u32;
    let data = &sim.dataset;
    let sim_reference = data.reference().with_context(|| format!("the undeformed image of {}", data.dir.display()))?;
    let sim_source =
        format!("{} (the set's undeformed image)", data.dir.join("images").join(&data.meta.reference_image).display());
    let motion = PinMotion::new(&sim_reference, &sim_source)?.within(field);
    let images = data
        .rows
        .par_iter()
        .map(|row| -> Result<Vec<u8>> {
            let name = data.image_path(row).display().to_string();
            Ok(motion.image(&data.image(row)?, side_px, &name)?.into_raw())
        })
        .collect::<Result<Vec<_>>>()?;
    sim.images = tacsim_model::ImageSet::from_raw(side, &images)?;

    let folder = tacsim_data::LabFolder::open(&real.dataset.dir)?;
    let reference = Reference::of(&folder, None, ConsensusRule::Alike)?;
    let real_source = reference.describe();
    let motion = PinMotion::new(&reference.image, &real_source)?.within(field);
    let images = folder
        .samples
        .par_iter()
        .map(|s| -> Result<Vec<u8>> {
            let path = folder.image_path(s);
            Ok(motion.image(&reference.read(&path)?, side_px, &path.display().to_string())?.into_raw())
        })
        .collect::<Result<Vec<_>>>()?;
    real.images = tacsim_model::ImageSet::from_raw(side, &images)?;
    Ok([sim_source, real_source])
}

/// Step 2: the pose network on each domain (each resumed when a previous run started it).
fn train_both(o: &Sim2RealOptions, cfg: [&PoseConfig; 2], sim: &Corpus, real: &Corpus) -> Result<(PathBuf, PathBuf)> {
    let runs =
        [("simulated", sim, o.out.join("sim-posenet"), cfg[0]), ("real", real, o.out.join("real-posenet"), cfg[1])];
    for (name, corpus, dir, cfg) in &runs {
        let resume = dir.join("config.json").is_file();
        tacsim_model::train_posenet(corpus, cfg, o.backend, dir, resume, None, &mut Bar::new(o.quiet)).with_context(
            || format!("training the pose network on the {name} images into {} (rerun to resume)", dir.display()),
        )?;
    }
    let [(_, _, s, _), (_, _, r, _)] = runs;
    Ok((s, r))
}

/// Step 2b (`--edge-frame`): the yaw's sense under a turn of the image (from the
/// simulator-trained network on its own images), then the second network on the simulated
/// images each turned by minus its own yaw (`sim-edge-posenet/`, resumed when a previous run
/// started it). Returns its run and the sense.
fn train_edge_frame(
    o: &Sim2RealOptions,
    cfg: &PoseConfig,
    sim: &Corpus,
    sim_rows: &[usize],
    sim_run: &Path,
) -> Result<(PathBuf, f64)> {
    let turn = tacsim_sim::turn_motion;
    let sense = tacsim_model::yaw_sense(o.backend, o.size, sim_run, sim, sim_rows, turn)?;
    let turned = tacsim_model::in_edge_frame(sim, None, (sense, turn), None)?;
    Ok((train_turned(o, cfg, &turned, "sim-edge-posenet", "the simulated images")?, sense))
}

/// Step 2c (`--edge-frame`): the lab's yaw sense under a turn (the simulator's `sense` through
/// the label map fitted on the simulator-trained network's readings of the fitting part), then a
/// second network on the lab's labels (`cfg`), trained on the fitting images each turned by
/// minus its labelled yaw (`real-edge-posenet/`, resumed when a previous run started it): the
/// fine-tuning curve's from-scratch arm at every fitting sample, seed 0. `lab`: the lab's
/// corpus, its fitting rows and its labels. Returns its run and the lab's sense.
fn train_real_edge_frame(
    o: &Sim2RealOptions,
    cfg: &PoseConfig,
    (real, fitting, labels): (&Corpus, &[usize], &[Column]),
    sim_run: &Path,
    sense: f64,
) -> Result<(PathBuf, f64)> {
    let lab_sense = tacsim_model::lab_yaw_sense((o.backend, o.size), sim_run, real, fitting, labels, sense)?;
    let turned = tacsim_model::lab_in_edge_frame(real, fitting, labels, (lab_sense, tacsim_sim::turn_motion))?;
    Ok((train_turned(o, cfg, &turned, "real-edge-posenet", "the lab's fitting images")?, lab_sense))
}

/// A second network (`cfg`) on `turned` (`whose` images, turned into the edge's frame) into
/// `--out`'s `name/`, resumed when a previous run started it. Returns its run.
fn train_turned(o: &Sim2RealOptions, cfg: &PoseConfig, turned: &Corpus, name: &str, whose: &str) -> Result<PathBuf> {
    let dir = o.out.join(name);
    let resume = dir.join("config.json").is_file();
    tacsim_model::train_posenet(turned, cfg, o.backend, &dir, resume, None, &mut Bar::new(o.quiet)).with_context(
        || {
            format!(
                "training the pose network on {whose} turned into the edge's frame into {} (rerun to resume)",
                dir.display()
            )
        },
    )?;
    Ok(dir)
}

/// `grid.png`: up to 8 held-out real images (top) over the simulated taps nearest their labels
/// (bottom), at the network side.
fn write_grid(path: &Path, sim: &Corpus, real: &Corpus, held_out: &[usize], nearest: &[usize]) -> Result<()> {
    let side = real.side() as u32;
    let n = held_out.len().min(8);
    let step = (held_out.len() / n.max(1)).max(1);
    let mut grid = GrayImage::new(side * n as u32, side * 2);
    for k in 0..n {
        let i = k * step;
        for (row, img) in [(0, real.images.image(held_out[i])), (1, sim.images.image(nearest[i]))] {
            let tile = GrayImage::from_raw(side, side, img.to_vec()).context("an image of the wrong size")?;
            image::imageops::replace(&mut grid, &tile, i64::from(k as u32 * side), i64::from(row * side));
        }
    }
    let mut bytes = Vec::new();
    grid.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)?;
    tacsim_data::write_atomic(path, &bytes)?;
    Ok(())
}

fn markdown(r: &Sim2RealReport) -> String {
    let mut s = format!(
        "# Sim-to-real: {} against {}\n\n`{}`\n\n{} simulated training images (labels read: {}); the real folder's fitting part ({} recordings) trains the real-trained network and fits the label map, its held-out part ({}) is the test. Pose network at {} px, {} epochs, seed {}; {:.0} s in this run (stages found finished in the work folder not counted).{}{}{}{}{}\n\nLabel map{}: {}.\n\n| label (held-out real) | trained on tacsim | trained on real | ratio | chance | tacsim reading's gain |{}\n|---|---|---|---|---|---|{}\n",
        r.recipe,
        r.real,
        r.command,
        r.sim_train,
        r.sim_labels.iter().map(|c| c.name()).collect::<Vec<_>>().join(", "),
        r.real_fitting,
        r.real_held_out,
        r.posenet.size,
        r.posenet.epochs,
        r.posenet.seed,
        r.seconds,
        if r.adapt_norms {
            " The simulator-trained network's batch-norm statistics were re-estimated on the fitting part's images (`--adapt-norms`, labels unused); its weights are trained on simulated images only."
        } else {
            ""
        },
        match (&r.motion_references, r.motion_field) {
            (Some([sim, real]), Some(field)) => format!(
                " Both networks read pin motion (`--input motion`): each image's pins within {field} of the half-side from its centre tracked from its domain's undeformed reference, {sim} and {real}, and drawn as the motion along x above the motion along y."
            ),
            _ => String::new(),
        },
        if r.turns > 1 {
            format!(
                " The simulator-trained network read each lab image at {} turns about its centre, {} deg apart, its readings averaged with the yaw turned back (`--turns`); the real-trained network read each image once, unturned.",
                r.turns,
                360.0 / r.turns as f64
            )
        } else {
            String::new()
        },
        if r.edge_frame {
            " The lateral offset and the depth were read in the edge's frame (`--edge-frame`): a second network, trained on the simulated images each turned by minus its own yaw, read each lab image turned by minus the yaw the simulator-trained network read of it; the yaw is that network's. The real-trained network is read the same way (the ratio's reference): a second network, trained on the fitting part's images each turned by minus its labelled yaw, read each held-out image turned by minus the yaw the real-trained network read; the last column: the real-trained network alone, the images as they are."
        } else {
            ""
        },
        if r.match_motion {
            " Before the second network read them, the turned lab images were matched pixel by pixel to the simulated images turned into the same frame (`--match-motion`): each value's mean and spread over the fitting part's images taken to the simulated training images' (labels unused)."
        } else {
            ""
        },
        if r.axis_offset {
            " (with the lab sensor's axis offset, `--axis-offset`: the lateral's `a cos + b sin` of the yaw read, fitted on the fitting part with its offset)"
        } else {
            ""
        },
        r.map.join("; "),
        if r.edge_frame { " trained on real, as is |" } else { "" },
        if r.edge_frame { "---|" } else { "" },
    );
    for l in &r.labels {
        s.push_str(&format!(
            "| {} | {:.2} | {:.2} | {:.1}x | {:.2} | {} |{}\n",
            l.label,
            l.sim_trained,
            l.real_trained,
            l.ratio,
            l.chance,
            l.sim_trained_gain.map_or("-".to_owned(), |g| format!("{g:.2}")),
            l.real_trained_as_is.map_or(String::new(), |e| format!(" {e:.2} |"))
        ));
    }
    s.push_str("\ngrid.png: held-out real images (top) above the simulated training images nearest their labels through the map (bottom).\n");
    if !r.coverage.is_empty() {
        s.push_str("\nCoverage: the lab's fitting poses in the recipe's frame (through the map) against the simulated training poses. A simulated span much wider than the lab's spends samples on poses the lab never takes; lab poses outside it make the network extrapolate.\n\n| simulated label | lab's span | simulated span | lab's outside |\n|---|---|---|---|\n");
        for c in &r.coverage {
            let span = |x: &Span| format!("{:.2} .. {:.2} ({:.2} wide)", x.lo, x.hi(c.label), x.width);
            s.push_str(&format!(
                "| {} | {} | {} | {:.0}% |\n",
                label_name(c.label),
                span(&c.lab),
                span(&c.sim),
                100.0 * c.lab_outside
            ));
        }
    }
    s
}
