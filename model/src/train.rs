//! Training loops: the shear-removal model's two phases (or one, for the baseline and the
//! no-label model) and the pose network, seeded, checkpointed and resumable.
//!
//! Every random draw comes from a ChaCha8 stream keyed by the config's seed and the position
//! in training: the batch order of an epoch by `(seed, phase, epoch)`, the image shifts and
//! patch crops of a step by `(seed, phase, epoch, batch)`. A run resumed from any checkpoint
//! therefore sees the same batches as an uninterrupted one. (Floating-point results can still
//! differ with the backend and its thread count.)

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Tensor, TensorData};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use tacsim_data::{Kind, Split, Subset};

use crate::backend::Backend;
use crate::checkpoint::{RunDir, canonical_ids, load_weights, read_json, save_weights, write_json};
use crate::config::{Mode, PoseConfig, UnshearConfig};
use crate::data::Corpus;
use crate::error::{ModelError, Result};
use crate::objective::{self, StepLosses, Weights};
use crate::posenet::{Column, PoseNet};
use crate::unshear::Unshear;

/// Name of the self-supervised phase in logs.
pub const SELF_SUPERVISED: &str = "self-supervised";
/// Name of the supervised phase in logs.
pub const SUPERVISED: &str = "supervised";

/// Receives training progress (the command line shows it as a progress bar).
pub trait Progress {
    /// A phase starts: `total` steps, of which `done` are already done (resume).
    fn phase(&mut self, _name: &str, _total: u64, _done: u64) {}
    /// One step finished with these losses.
    fn step(&mut self, _losses: &StepLosses) {}
    /// A line of information.
    fn message(&mut self, _text: &str) {}
    /// Asked after every step: `true` saves a checkpoint and stops the run with
    /// [`ModelError::Interrupted`] (Ctrl-C on the command line).
    fn stop(&self) -> bool {
        false
    }
}

/// Progress that goes nowhere.
pub struct Silent;

impl Progress for Silent {}

/// The mean losses of one epoch.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EpochLog {
    /// Phase name.
    pub phase: String,
    /// Epoch within the phase (from 0).
    pub epoch: usize,
    /// Steps taken.
    pub steps: usize,
    /// Learning rate.
    pub lr: f64,
    /// Mean of each loss over the epoch's steps.
    pub mean: StepLosses,
}

/// Where a run stands; saved in every checkpoint.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainState {
    /// Index of the current phase.
    pub phase: usize,
    /// Epoch within the phase.
    pub epoch: usize,
    /// Next batch of the epoch.
    pub batch: usize,
    /// Sum of the losses of the current epoch's finished steps.
    pub partial: StepLosses,
    /// Finished epochs.
    pub history: Vec<EpochLog>,
    /// The run has finished.
    pub done: bool,
}

/// A ChaCha8 stream for a position in training.
pub fn stream(seed: u64, keys: &[u64]) -> ChaCha8Rng {
    let mut s = seed ^ 0x5DEE_CE66_D1CE_4E5B;
    for &k in keys {
        s = s.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29) ^ k.wrapping_add(0x632B_E59B_D9B4_E019);
    }
    ChaCha8Rng::seed_from_u64(s)
}

/// One phase of a training loop.
struct PhasePlan<'a, T> {
    name: &'static str,
    epochs: usize,
    /// The epoch's items (unshuffled).
    items: Box<dyn Fn(usize) -> Vec<T> + 'a>,
    /// The epoch's learning rate.
    lr: Box<dyn Fn(usize) -> f64 + 'a>,
}

struct LoopSettings {
    batch: usize,
    max_batches: usize,
    seed: u64,
    checkpoint_steps: usize,
    adam: AdamConfig,
}

/// A module with its optimizer and where training stands.
struct Session<M> {
    model: M,
    optim: ModuleOptimizer,
    state: TrainState,
}

/// Runs the phases from the session's state, checkpointing into `run`, and returns the
/// trained module.
fn run_loop<M: Module, T: Copy>(
    run: &RunDir,
    session: Session<M>,
    phases: &[PhasePlan<'_, T>],
    s: &LoopSettings,
    progress: &mut dyn Progress,
    mut step: impl FnMut(&M, &str, &[T], &mut ChaCha8Rng) -> (GradientsParams, StepLosses),
) -> Result<(M, TrainState)> {
    let Session { mut model, mut optim, mut state } = session;
    let batches_of = |n: usize| {
        let full = n / s.batch + usize::from(n % s.batch >= 2);
        if s.max_batches > 0 { full.min(s.max_batches) } else { full }
    };
    while state.phase < phases.len() {
        let plan = &phases[state.phase];
        if plan.epochs == 0 {
            state.phase += 1;
            continue;
        }
        let per_epoch: Vec<usize> = (0..plan.epochs).map(|e| batches_of((plan.items)(e).len())).collect();
        if per_epoch.iter().all(|&b| b == 0) {
            return Err(ModelError::Insufficient(format!(
                "phase `{}` has no batch of at least 2 samples: the dataset is too small for it",
                plan.name
            )));
        }
        let done: usize = per_epoch[..state.epoch.min(plan.epochs)].iter().sum::<usize>() + state.batch;
        progress.phase(plan.name, per_epoch.iter().sum::<usize>() as u64, done as u64);
        if state.epoch == 0 && state.batch == 0 {
            optim = s.adam.init();
        }
        let mut since_save = 0;
        while state.epoch < plan.epochs {
            let epoch = state.epoch;
            let mut items = (plan.items)(epoch);
            items.shuffle(&mut stream(s.seed, &[state.phase as u64, epoch as u64]));
            let lr = (plan.lr)(epoch);
            let nb = per_epoch[epoch];
            while state.batch < nb {
                let b = state.batch;
                let chunk = &items[b * s.batch..((b + 1) * s.batch).min(items.len())];
                let mut rng = stream(s.seed, &[state.phase as u64, epoch as u64, b as u64, 1]);
                let (grads, losses) = step(&model, plan.name, chunk, &mut rng);
                if !losses.total.is_finite() {
                    return Err(ModelError::Insufficient(format!(
                        "phase `{}` epoch {epoch} batch {b}: the loss is {} (diverged): lower the learning rate",
                        plan.name, losses.total
                    )));
                }
                model = optim.step(lr, model, grads);
                state.partial = state.partial.combine(&losses, |a, b| a + b);
                progress.step(&losses);
                state.batch += 1;
                since_save += 1;
                if progress.stop() && state.batch < nb {
                    run.save_checkpoint(&model, &optim, &state)?;
                    return Err(ModelError::Interrupted { dir: run.dir.clone() });
                }
                if s.checkpoint_steps > 0 && since_save >= s.checkpoint_steps && state.batch < nb {
                    run.save_checkpoint(&model, &optim, &state)?;
                    since_save = 0;
                }
            }
            state.history.push(EpochLog {
                phase: plan.name.to_string(),
                epoch,
                steps: nb,
                lr,
                mean: state.partial.combine(&state.partial, |a, _| a / nb.max(1) as f64),
            });
            state.partial = StepLosses::default();
            state.epoch += 1;
            state.batch = 0;
            if state.epoch == plan.epochs {
                state.phase += 1;
                state.epoch = 0;
            }
            run.save_checkpoint(&model, &optim, &state)?;
            since_save = 0;
            if progress.stop() && state.phase < phases.len() {
                return Err(ModelError::Interrupted { dir: run.dir.clone() });
            }
            if state.epoch == 0 {
                break;
            }
        }
    }
    state.done = true;
    run.save_checkpoint(&model, &optim, &state)?;
    save_weights(&model, &run.weights())?;
    Ok((model, state))
}

/// The data a run trains on (`data.json` in its directory).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct DataRecord {
    /// The dataset's directory, for the message.
    dir: String,
    /// [`Corpus::fingerprint`], in hex.
    fingerprint: String,
}

/// Prepares a run directory: writes the config and the data's fingerprint, or (on resume)
/// checks both are the same and loads the newest checkpoint.
fn open_run<M: Module, C: Serialize + for<'de> Deserialize<'de> + PartialEq>(
    out: &std::path::Path,
    config: &C,
    corpus: &Corpus,
    resume: bool,
    model: M,
    optim: ModuleOptimizer,
) -> Result<(RunDir, M, ModuleOptimizer, TrainState)> {
    let run = RunDir::create(out)?;
    let path = run.config();
    let data = DataRecord {
        dir: corpus.dataset.dir.display().to_string(),
        fingerprint: format!("{:016x}", corpus.fingerprint()),
    };
    let data_path = out.join("data.json");
    if path.is_file() && resume && data_path.is_file() {
        let saved: DataRecord = read_json(&data_path)?;
        if saved.fingerprint != data.fingerprint {
            return Err(ModelError::checkpoint(
                &data_path,
                format!(
                    "the run was trained on other data ({}, fingerprint {}; --data {} gives {}): resume with the \
                     same --data, or choose another --out",
                    saved.dir, saved.fingerprint, data.dir, data.fingerprint
                ),
            ));
        }
    }
    if path.is_file() {
        if !resume {
            return Err(ModelError::checkpoint(
                out,
                "already holds a training run: add --resume to continue it, or choose another --out",
            ));
        }
        let saved: C = read_json(&path)?;
        if saved != *config {
            return Err(ModelError::checkpoint(
                &path,
                "the run was started with another config: resume with the same options, or choose another --out",
            ));
        }
        if !data_path.is_file() {
            write_json(&data_path, &data)?;
        }
        if let Some(dir) = run.latest_checkpoint() {
            let (model, optim, state) = RunDir::load_checkpoint(&dir, model, optim)?;
            return Ok((run, model, optim, state));
        }
    } else {
        write_json(&path, config)?;
    }
    if !data_path.is_file() {
        write_json(&data_path, &data)?;
    }
    Ok((run, model, optim, TrainState::default()))
}

fn adam(beta1: f64, beta2: f64, epsilon: f64) -> AdamConfig {
    AdamConfig::new().with_beta_1(beta1 as f32).with_beta_2(beta2 as f32).with_epsilon(epsilon as f32)
}

/// Random shifts for `n` samples, each component uniform in `[-max, max]` px.
fn shifts(n: usize, max: i32, rng: &mut ChaCha8Rng) -> Vec<(i32, i32)> {
    (0..n)
        .map(|_| if max > 0 { (rng.random_range(-max..=max), rng.random_range(-max..=max)) } else { (0, 0) })
        .collect()
}

/// Checks the data was loaded at the config's side `size` (px).
fn check_side(corpus: &Corpus, size: usize) -> Result<()> {
    if corpus.side() != size {
        return Err(ModelError::config(
            "size",
            format!("the data was loaded at {} px, the config says {size}", corpus.side()),
        ));
    }
    Ok(())
}

/// The training device and a network `build` makes on it from `seed`.
///
/// A device's random stream is one per process (`Device::seed` sets it for every user of the
/// device), so seeding and drawing the initial weights happen under one lock: two trainings
/// started at once in one process (tests on parallel threads, a library user's threads) would
/// otherwise interleave their draws and each start from weights no seed gives. burn's
/// parameters are lazy (drawn at their first use), so every one is drawn before the lock is
/// let go: otherwise the draws happened at the first forward pass, after another training's
/// `seed` (regression test `trainings_started_at_once_start_from_their_own_seeds`, which
/// failed one run in several under a loaded machine).
fn seeded<M: Module>(
    backend: Backend,
    seed: u64,
    build: impl FnOnce(&burn::tensor::Device) -> Result<M>,
) -> Result<(burn::tensor::Device, M)> {
    static DRAWS: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let device = backend.training_device();
    // A thread that panicked while holding the lock left no state behind it: carry on.
    let _draws = DRAWS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    device.seed(seed);
    let model = build(&device)?;
    model.visit(&mut DrawEvery);
    Ok((device, model))
}

/// Draws every lazy float parameter of a module ([`seeded`]).
struct DrawEvery;

impl burn::module::ModuleVisitor for DrawEvery {
    fn visit_float<const D: usize>(&mut self, param: &burn::module::Param<Tensor<D>>) {
        // `val` draws an uninitialised parameter once; the clone it returns is dropped.
        let _ = param.val();
    }
}

/// Trains the shear-removal model on `corpus` into the run directory `out`.
///
/// `init` starts from saved weights (fine-tuning a simulator-trained model on real data).
/// With `resume` an interrupted run continues from its newest checkpoint.
pub fn train_unshear(
    corpus: &Corpus,
    cfg: &UnshearConfig,
    backend: Backend,
    out: &std::path::Path,
    resume: bool,
    init: Option<&std::path::Path>,
    progress: &mut dyn Progress,
) -> Result<(Unshear, TrainState)> {
    cfg.validate()?;
    check_side(corpus, cfg.size)?;
    let (device, model) = seeded(backend, cfg.seed, |device| {
        let mut model = Unshear::new(cfg.net_size()?, device);
        if let Some(path) = init {
            model = load_weights(model, path)?;
        }
        // The critic only where a self-supervised phase uses it, added after `--init`: those
        // weights need not hold one.
        if cfg.uses_critic() {
            model = model.with_critic(cfg.net_size()?, device);
        }
        Ok(model)
    })?;
    let settings = LoopSettings {
        batch: cfg.batch,
        max_batches: cfg.max_batches_per_epoch,
        seed: cfg.seed,
        checkpoint_steps: cfg.checkpoint_steps,
        adam: adam(cfg.beta1, cfg.beta2, cfg.epsilon),
    };
    // Checked before the run directory is written: a config the data cannot serve leaves
    // nothing behind that would block the corrected command.
    let labelled = match cfg.mode {
        Mode::SemiSupervised => corpus.labelled_pairs(cfg.label_fraction)?,
        Mode::Baseline => corpus.dataset.true_pairs(Split::Train, Subset::All),
        Mode::SelfSupervised => Vec::new(),
    };
    let (run, model, optim, state) = open_run(out, cfg, corpus, resume, model, settings.adam.init())?;
    if state.done {
        progress.message("the run had already finished");
        return Ok((model, state));
    }
    let ss = PhasePlan {
        name: SELF_SUPERVISED,
        epochs: cfg.self_supervised_epochs,
        items: Box::new(|e| corpus.dataset.epoch_pairs(cfg.seed, e as u64)),
        lr: Box::new(|_| cfg.lr_self_supervised),
    };
    let half = cfg.supervised_epochs / 2;
    let sup = PhasePlan {
        name: SUPERVISED,
        epochs: cfg.supervised_epochs,
        items: Box::new(|_| labelled.clone()),
        lr: Box::new(
            move |e| if e >= half && half > 0 { cfg.lr_supervised * cfg.lr_step_factor } else { cfg.lr_supervised },
        ),
    };
    let phases: Vec<PhasePlan<'_, (usize, usize)>> = match cfg.mode {
        Mode::SemiSupervised => vec![ss, sup],
        Mode::SelfSupervised => vec![ss],
        Mode::Baseline => vec![sup],
    };
    let w = Weights { patch: cfg.patch_weight, l1: cfg.l1, l2: cfg.l2, adversarial: cfg.adversarial_weight };
    let (max_shift, side, crop) = (cfg.max_shift_px(), cfg.size, cfg.patch_px());
    let (model, state) =
        run_loop(&run, Session { model, optim, state }, &phases, &settings, progress, |m, phase, chunk, rng| {
            let sh = shifts(chunk.len(), max_shift, rng);
            let shift_taps = phase != SUPERVISED || cfg.shift_targets;
            let (t, s) = corpus.pair_batch(chunk, &sh, shift_taps, &device);
            if phase == SUPERVISED {
                let mask = (w.patch > 0.0)
                    .then(|| objective::patch_mask(chunk.len(), side, cfg.patch_count, crop, rng, &device));
                objective::supervised(m, s, t, mask, w)
            } else {
                objective::self_supervised(m, s, t, w)
            }
        })?;
    Ok((model, state))
}

/// The label scale of the pose network run whose weights are at `weights` (its folder's
/// `scale.json`), if it is one.
fn init_scale(weights: &std::path::Path) -> Option<crate::posenet::PoseScale> {
    let dir = if weights.is_dir() { weights } else { weights.parent()? };
    read_json(&dir.join("scale.json")).ok()
}

/// Trains the pose network to read `cfg.labels` from the training rows of `corpus`
/// ([`Corpus::pose_rows`]: the taps, or the slides for slide offsets or where there are no
/// taps) into `out`.
///
/// `init` starts from saved weights of the same network (fine-tuning a simulator-trained
/// network on a lab's images; the same start on two backends), with that run's label scale
/// where it reads the same labels. With `resume` an interrupted
/// run continues from its newest checkpoint.
///
/// ```no_run
/// use tacsim_model::{Backend, Corpus, PoseConfig, Silent, train_posenet};
///
/// // A dataset from `tacsim generate` (its images read at the network's side).
/// let cfg = PoseConfig::default();
/// let corpus = Corpus::open(std::path::Path::new("data/quick"), cfg.size)?;
/// let (net, state) =
///     train_posenet(&corpus, &cfg, Backend::default(), std::path::Path::new("runs/pose"), false, None, &mut Silent)?;
/// # let _ = (net, state);
/// # Ok::<(), tacsim_model::ModelError>(())
/// ```
pub fn train_posenet(
    corpus: &Corpus,
    cfg: &PoseConfig,
    backend: Backend,
    out: &std::path::Path,
    resume: bool,
    init: Option<&std::path::Path>,
    progress: &mut dyn Progress,
) -> Result<(PoseNet, TrainState)> {
    cfg.validate()?;
    check_side(corpus, cfg.size)?;
    let rows = corpus.pose_rows(Split::Train, &cfg.labels);
    if rows.is_empty() {
        return Err(ModelError::Insufficient(format!(
            "{} has no training images for the labels {}",
            corpus.dataset.dir.display(),
            cfg.labels.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ")
        )));
    }
    // Initialised from a pose network of the same labels, the run keeps that network's label
    // scale, so that its head reads as it was trained to (fine-tuning on a few samples, whose
    // own ranges differ from the run's).
    let scale = match init.and_then(init_scale) {
        Some(scale) if scale.columns() == cfg.labels => scale,
        _ => corpus.pose_scale(&cfg.labels, &rows),
    };
    let (device, model) = seeded(backend, cfg.seed, |device| {
        let model = canonical_ids(PoseNet::new(cfg.net_size()?, cfg.hidden, scale.width(), device));
        match init {
            Some(path) => load_weights(model, path),
            None => Ok(model),
        }
    })?;
    let settings = LoopSettings {
        batch: cfg.batch,
        max_batches: cfg.max_batches_per_epoch,
        seed: cfg.seed,
        checkpoint_steps: cfg.checkpoint_steps,
        adam: AdamConfig::new(),
    };
    let (run, model, optim, state) = open_run(out, cfg, corpus, resume, model, settings.adam.init())?;
    write_json(&out.join("scale.json"), &scale)?;
    if state.done {
        progress.message("the run had already finished");
        return Ok((model, state));
    }
    if corpus.dataset.rows[rows[0]].kind == Kind::Slide {
        progress.message("training the pose network on the slides (slide offsets read, or no tap images)");
    }
    let half = cfg.epochs / 2;
    let phases = vec![PhasePlan {
        name: "posenet",
        epochs: cfg.epochs,
        items: Box::new(|_| rows.clone()),
        lr: Box::new(move |e| if e >= half && half > 0 { cfg.lr * cfg.lr_step_factor } else { cfg.lr }),
    }];
    let max_shift = cfg.max_shift_px();
    // Per output, averaging 1: with `y_weight` 1 the loss is the plain mean squared error.
    let w = scale.output_weights(|c| if c == Column::PoseY { cfg.y_weight } else { 1.0 });
    let output_weights: Tensor<2> = Tensor::from_data(TensorData::new(w.clone(), [1, w.len()]), &device);
    run_loop(&run, Session { model, optim, state }, &phases, &settings, progress, |m, _, chunk, rng| {
        let sh = shifts(chunk.len(), max_shift, rng);
        let x = corpus.batch(chunk, &sh, &device);
        let poses: Vec<_> = chunk.iter().map(|&r| corpus.pose(r)).collect();
        let y = scale.targets(&poses, &device);
        let loss = ((m.forward(x) - y).square() * output_weights.clone()).mean();
        let v = loss.clone().into_scalar::<f32>() as f64;
        let (loss, reg) =
            objective::with_regularisation(loss, m, Weights { patch: 0.0, l1: 0.0, l2: cfg.l2, adversarial: 0.0 });
        (
            GradientsParams::from_grads(loss.backward(), m),
            StepLosses { supervised: v, regularisation: reg, total: v + reg, ..StepLosses::default() },
        )
    })
}
