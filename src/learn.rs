//! `tacsim train` and `tacsim eval`: the command-line edge of the learning crate
//! (`tacsim-model`), with progress bars, Ctrl-C that saves a checkpoint, and config files.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context as _, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use serde::de::DeserializeOwned;
use tacsim_model::{
    Backend, Corpus, Mode, PoseConfig, Preprocess, Progress, StepLosses, TrainState, UnshearConfig, eval_markdown,
    run_size, train_posenet, train_unshear,
};

/// Which network `tacsim train` trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Network {
    /// The semi-supervised shear-removal model (or, with --no-labels, self-supervised only).
    Unshear,
    /// The fully supervised baseline (supervised phase on every training pair).
    Baseline,
    /// The pose network on tap images.
    Posenet,
}

/// Options of `tacsim train` (its command-line flags).
#[derive(Clone, Debug, clap::Args)]
pub struct TrainOptions {
    /// unshear, baseline or posenet.
    #[arg(value_enum)]
    pub network: Network,
    /// Dataset directory (`tacsim generate` output) or a lab recording folder (targets.csv +
    /// images/, no meta.json).
    #[arg(long)]
    pub data: PathBuf,
    /// Run directory (config, checkpoints, model.safetensors).
    #[arg(long)]
    pub out: PathBuf,
    /// TOML config (fields of the crate's UnshearConfig / PoseConfig); flags override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Image side: 256 (paper), 128, 64 or 32; the dataset is resized to it.
    #[arg(long)]
    pub size: Option<usize>,
    /// Epochs (each phase of the unshear model; the pose network's).
    #[arg(long)]
    pub epochs: Option<usize>,
    /// At most this many batches per epoch.
    #[arg(long)]
    pub max_batches: Option<usize>,
    /// Batch size (paper: 32).
    #[arg(long)]
    pub batch: Option<usize>,
    /// Fraction of training poses with labels (unshear; paper: 0.1).
    #[arg(long)]
    pub label_fraction: Option<f64>,
    /// Self-supervised phase only (unshear).
    #[arg(long)]
    pub no_labels: bool,
    /// Train without the L1 patch loss (ablation).
    #[arg(long)]
    pub no_patch: bool,
    /// Multiply the learning rates by this factor.
    #[arg(long)]
    pub lr_scale: Option<f64>,
    /// Seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Backend: flex (default); wgpu, cuda and ndarray with the crate features of those names.
    #[arg(long, default_value = "flex")]
    pub backend: Backend,
    /// Continue an interrupted run in --out.
    #[arg(long)]
    pub resume: bool,
    /// Start from these weights (for example a simulator-trained model.safetensors).
    #[arg(long)]
    pub init: Option<PathBuf>,
    /// Lab recording folders: crop and threshold.
    #[command(flatten)]
    pub lab: LabOptions,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The lab's preprocessing for recording folders (`targets.csv` + `images/` without a
/// `meta.json`); `tacsim generate` datasets only get resized.
#[derive(Clone, Copy, Debug, Default, clap::Args)]
pub struct LabOptions {
    /// Lab recording folders: crop left,top,width,height (px) before resizing.
    #[arg(long, value_parser = parse_crop)]
    pub crop: Option<[u32; 4]>,
    /// Lab recording folders: threshold (0-255) after resizing.
    #[arg(long)]
    pub threshold: Option<u8>,
}

impl LabOptions {
    /// Opens a dataset or lab folder at the network side `side` with these options.
    pub fn open(&self, dir: &Path, side: usize) -> Result<Corpus> {
        Ok(Corpus::open_any(dir, &self.preprocess(side))?)
    }

    /// The preprocessing to the network side `side`.
    pub fn preprocess(&self, side: usize) -> Preprocess {
        Preprocess { crop: self.crop, side: side as u32, threshold: self.threshold }
    }
}

/// Parses `left,top,width,height`.
pub fn parse_crop(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>().map_err(|_| format!("crop `{s}`: `{p}` is not a whole number of px")))
        .collect::<Result<_, _>>()?;
    <[u32; 4]>::try_from(v).map_err(|_| format!("crop `{s}`: give left,top,width,height"))
}

/// A training config from a TOML file (its fields; the rest default), or the defaults.
pub fn load_config<C: DeserializeOwned + Default>(path: Option<&Path>) -> Result<C> {
    match path {
        None => Ok(C::default()),
        Some(p) => {
            let text =
                std::fs::read_to_string(p).with_context(|| format!("{}: could not read the config", p.display()))?;
            toml::from_str(&text).with_context(|| format!("{}: not a valid training config", p.display()))
        }
    }
}

/// Resolves the unshear config from the file and flags.
pub fn unshear_config(o: &TrainOptions) -> Result<UnshearConfig> {
    let mut c: UnshearConfig = load_config(o.config.as_deref())?;
    c.mode = match (o.network, o.no_labels) {
        (Network::Baseline, _) => Mode::Baseline,
        (_, true) => Mode::SelfSupervised,
        _ => c.mode,
    };
    if let Some(v) = o.size {
        c.size = v;
    }
    if let Some(v) = o.epochs {
        c.self_supervised_epochs = v;
        c.supervised_epochs = v;
    }
    if let Some(v) = o.max_batches {
        c.max_batches_per_epoch = v;
    }
    if let Some(v) = o.batch {
        c.batch = v;
    }
    if let Some(v) = o.label_fraction {
        c.label_fraction = v;
    }
    if o.no_patch {
        c.patch_weight = 0.0;
    }
    if let Some(k) = o.lr_scale {
        c.lr_self_supervised *= k;
        c.lr_supervised *= k;
    }
    if let Some(v) = o.seed {
        c.seed = v;
    }
    c.validate()?;
    Ok(c)
}

/// Resolves the pose-network config from the file and flags.
pub fn pose_config(o: &TrainOptions) -> Result<PoseConfig> {
    let mut c: PoseConfig = load_config(o.config.as_deref())?;
    if let Some(v) = o.size {
        c.size = v;
    }
    if let Some(v) = o.epochs {
        c.epochs = v;
    }
    if let Some(v) = o.max_batches {
        c.max_batches_per_epoch = v;
    }
    if let Some(v) = o.batch {
        c.batch = v;
    }
    if let Some(k) = o.lr_scale {
        c.lr *= k;
    }
    if let Some(v) = o.seed {
        c.seed = v;
    }
    c.validate()?;
    Ok(c)
}

/// A progress bar with the running loss and rate; Ctrl-C asks the loop to stop.
pub struct Bar {
    bar: Option<ProgressBar>,
    stop: Arc<AtomicBool>,
    recent: Vec<f64>,
}

impl Bar {
    /// A bar (hidden when `quiet`) with Ctrl-C handling.
    pub fn new(quiet: bool) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        // A second handler cannot be installed (tests call this repeatedly): then Ctrl-C
        // simply ends the process and the last periodic checkpoint remains.
        let _ = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst));
        Self { bar: (!quiet).then(ProgressBar::hidden), stop, recent: Vec::new() }
    }
}

impl Progress for Bar {
    fn phase(&mut self, name: &str, total: u64, done: u64) {
        if let Some(bar) = &mut self.bar {
            let b = ProgressBar::new(total);
            b.set_style(
                ProgressStyle::with_template("{prefix:>16} [{bar:30}] {pos}/{len} steps, {per_sec}, eta {eta} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_prefix(name.to_string());
            b.set_position(done);
            *bar = b;
        }
        self.recent.clear();
    }

    fn step(&mut self, losses: &StepLosses) {
        self.recent.push(losses.total);
        if self.recent.len() > 20 {
            self.recent.remove(0);
        }
        if let Some(bar) = &self.bar {
            let mean = self.recent.iter().sum::<f64>() / self.recent.len() as f64;
            bar.set_message(format!("loss {mean:.4}"));
            bar.inc(1);
        }
    }

    fn message(&mut self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None => eprintln!("{text}"),
        }
    }

    fn stop(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }
}

fn summary(out: &Path, state: &TrainState) -> String {
    let mut s = format!("trained into {}\n", out.display());
    for e in &state.history {
        s.push_str(&format!(
            "  {:<16} epoch {:>3}: {} steps, lr {:.2e}, loss {:.5} (cycle {:.5}/{:.5}, rec {:.5}, sup {:.5}, patch {:.5})",
            e.phase,
            e.epoch,
            e.steps,
            e.lr,
            e.mean.total,
            e.mean.cycle_forward,
            e.mean.cycle_backward,
            e.mean.reconstruction,
            e.mean.supervised,
            e.mean.patch
        ));
        if e.mean.critic != 0.0 {
            s.push_str(&format!(" [adversarial {:.5}, critic {:.5}]", e.mean.adversarial, e.mean.critic));
        }
        s.push('\n');
    }
    s
}

/// Runs `tacsim train`.
pub fn train(o: &TrainOptions) -> Result<String> {
    let mut bar = Bar::new(o.quiet);
    match o.network {
        Network::Unshear | Network::Baseline => {
            let cfg = unshear_config(o)?;
            let corpus = o.lab.open(&o.data, cfg.size)?;
            let (_, state) = train_unshear(&corpus, &cfg, o.backend, &o.out, o.resume, o.init.as_deref(), &mut bar)?;
            Ok(summary(&o.out, &state))
        }
        Network::Posenet => {
            if o.no_labels || o.no_patch || o.label_fraction.is_some() {
                bail!("--no-labels, --no-patch and --label-fraction apply to the unshear model, not posenet");
            }
            let cfg = pose_config(o)?;
            let corpus = o.lab.open(&o.data, cfg.size)?;
            let (_, state) = train_posenet(&corpus, &cfg, o.backend, &o.out, o.resume, o.init.as_deref(), &mut bar)?;
            Ok(summary(&o.out, &state))
        }
    }
}

/// Runs `tacsim eval`: every run against the test split of `data`, report into `out`.
pub fn evaluate(
    data: &Path,
    runs: &[PathBuf],
    out: &Path,
    max_pairs: usize,
    backend: Backend,
    lab: LabOptions,
) -> Result<String> {
    let first = runs.first().context("give at least one run directory of `tacsim train`")?;
    let corpus = lab.open(data, run_size(first)?)?;
    let report = tacsim_model::evaluate(&corpus, runs, backend, max_pairs, out)?;
    Ok(format!("{}\nreport: {}\n", eval_markdown(&report), out.join("report.md").display()))
}
