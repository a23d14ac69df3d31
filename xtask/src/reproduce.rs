//! `cargo xtask reproduce [--quick] [--out DIR] [--jobs N]`: the paper's study end to end through the
//! `tacsim` command line: generate the dataset, train the self-supervised phase once, the
//! supervised phase at each label fraction (10%, 8%, 5%) and without the patch loss, the
//! fully supervised baseline and the pose network, then evaluate them all into a report
//! (`report.md`, `report.json`, `grid.png`). Every step resumes, so an interrupted study
//! continues where it stopped when rerun.
//!
//! | | `--quick` | full (CPU scale) |
//! |---|---|---|
//! | recipe | `study-quick` (2,880 images at 128 px, 180 poses) | `study` (18,000 images at 128 px, 600 poses) |
//! | poses | contact points around each contour, edge-frame labels | the same |
//! | network size | 64 px (images averaged down, grey) | 128 px |
//! | self-supervised: epochs x batches | 3 x all | 3 x 150 |
//! | supervised at 10/8/5% and no-patch: epochs | 40 (3 batches each) | 50, the paper's (23 batches each at 10%) |
//! | baseline: epochs x batches | 5 x all (41) | 5 x all (225): 1,125 steps, the 10% run 1,150 |
//! | pose network: epochs | 15 | 15 (113 batches each) |
//! | pose network: loss | x and yaw (`y_weight = 0`), `l2 = 1e-5` | the same |
//! | learning rates, self-supervised / supervised | 2e-3 / 2e-3 | 2e-3 / 2e-3 |
//!
//! The paper trains every phase for 50 epochs at 5e-5 and 2.5e-5 on a GPU: tens of thousands
//! of steps. A CPU-scale study has hundreds, and at the paper's rates its models stay grey
//! blurs (the first quick study's). At 2e-3 (40x and 80x the paper's; the supervised one is
//! still divided by 10 after half its phase) they learn the pin lattice within an epoch: on
//! the `study` data at 64 px, two baseline epochs reached SSIM(U_rec, U_GT) 12% at 1e-4, 39%
//! at 1e-3 and 45% at 3e-3 (measured while the supervised targets were still shifted with
//! their inputs, which capped every run near the mean lattice). The semi-supervised runs see
//! 10% of the pairs, so they get more epochs than the baseline to reach a comparable number of
//! steps (in the quick study, 10 epochs gave SSIM(U_rec, U_GT) 61% against the baseline's 75%,
//! 40 epochs 74%; the same 10 epochs without the self-supervised phase 11%). After 50
//! supervised epochs the start is gone: on the `study` data at 64 px the 10% model reached
//! 88.4% after 3 x 150 self-supervised batches, 88.5% after 6 x 150 and 88.3% with none
//! (docs/guide/learning.md, "The CPU-scale study"), so a longer self-supervised phase buys nothing. In the full
//! study, 50 supervised epochs instead of 25 (and a baseline of 5 epochs instead of 3) raised
//! SSIM(U_rec, U_GT) from 80.0% to 83.4% at 10% labels and from 81.6% to 86.9% for the
//! baseline (docs/guide/learning.md, "The CPU-scale study"). Everything else keeps the paper's values.
//! Independent runs train in parallel (`--jobs`, default: one per core; a training is
//! single-threaded on flex).

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

struct Plan {
    recipe: &'static str,
    size: usize,
    ss_epochs: usize,
    /// Batches per self-supervised epoch (0: all).
    ss_batches: usize,
    sup_epochs: usize,
    baseline_epochs: usize,
    /// Batches per baseline epoch (0: all).
    baseline_batches: usize,
    pose_epochs: usize,
    max_pairs: usize,
}

const QUICK: Plan = Plan {
    recipe: "study-quick",
    size: 64,
    ss_epochs: 3,
    ss_batches: 0,
    sup_epochs: 40,
    baseline_epochs: 5,
    baseline_batches: 0,
    pose_epochs: 15,
    max_pairs: 360,
};
const FULL: Plan = Plan {
    recipe: "study",
    size: 128,
    ss_epochs: 3,
    ss_batches: 150,
    sup_epochs: 50,
    baseline_epochs: 5,
    baseline_batches: 0,
    pose_epochs: 15,
    max_pairs: 400,
};

/// Learning rates of CPU-scale studies (see the module documentation): 40x the paper's
/// self-supervised rate and 80x its supervised one, both 2e-3.
pub(crate) const LR_SELF_SUPERVISED: f64 = 5e-5 * 40.0;
pub(crate) const LR_SUPERVISED: f64 = 2.5e-5 * 80.0;

/// The pose network's loss in the studies: x and yaw only, as the paper's PoseNet (y runs along
/// the edge, which the taps do not reveal: learning it anyway memorises the training poses),
/// and a light L2 penalty. On the `study` data at 128 px (15 epochs, 400 test pairs), when its
/// labels were still measured at one contact point per shape, the tap MAE went from 0.40 mm /
/// 6.97 deg to 0.32 mm / 6.47 deg (0.32 / 6.58 without the penalty).
pub(crate) const POSE_REGRESSION: &str = "y_weight = 0.0\nl2 = 1e-5\n";

/// The `tacsim` binary beside this xtask (same target directory and profile), built first:
/// `cargo xtask` (a release alias, `.cargo/config.toml`) runs the release build. Two runs of
/// one build train to identical weights, but the quick study under the dev profile gave
/// SSIM(U_rec, U_GT) 74.0% for the semi-supervised model and 73.9% under release, on the
/// same data (the input's scores agree in every digit): figures come from the release build.
pub(crate) fn tacsim_binary() -> Result<PathBuf> {
    let mut args = vec!["build", "--quiet", "--bin", "tacsim"];
    if !cfg!(debug_assertions) {
        args.push("--release");
    }
    let status =
        Command::new(env!("CARGO")).args(&args).current_dir(crate::root()).status().context("building tacsim")?;
    if !status.success() {
        bail!("building tacsim failed");
    }
    let exe = std::env::current_exe().context("locating the xtask binary")?;
    let bin = exe.with_file_name(format!("tacsim{}", std::env::consts::EXE_SUFFIX));
    if !bin.is_file() {
        bail!("{} not found after building it", bin.display());
    }
    Ok(bin)
}

pub(crate) fn tacsim(bin: &Path, args: &[String]) -> Result<()> {
    println!("$ tacsim {}", args.join(" "));
    let status = Command::new(bin).args(args).status().with_context(|| format!("running {}", bin.display()))?;
    if !status.success() {
        bail!("`tacsim {}` failed", args.join(" "));
    }
    Ok(())
}

pub(crate) fn s(v: impl ToString) -> String {
    v.to_string()
}

/// One `tacsim` command of the study and the jobs it waits for.
pub(crate) struct Job {
    pub(crate) args: Vec<String>,
    pub(crate) after: Vec<usize>,
}

/// The `tacsim train` arguments of one run, or `None` when it has finished (an interrupted
/// run resumes).
pub(crate) fn train(net: &str, data: &Path, out: &Path, config: &str, extra: &[String]) -> Result<Option<Vec<String>>> {
    if out.join("model.safetensors").is_file() {
        println!("{} done", out.display());
        return Ok(None);
    }
    std::fs::create_dir_all(out)?;
    let cfg = out.with_extension("toml");
    std::fs::write(&cfg, config)?;
    let mut args = vec![s("train"), s(net), s("--data"), s(data.display()), s("--out"), s(out.display())];
    args.extend([s("--config"), s(cfg.display()), s("-q")]);
    if out.join("config.json").is_file() {
        args.push(s("--resume"));
    }
    args.extend_from_slice(extra);
    Ok(Some(args))
}

/// The `--jobs` count: a positive number, or one per core.
pub(crate) fn workers(jobs: Option<usize>) -> Result<usize> {
    Ok(match jobs {
        Some(0) => bail!("--jobs 0: expected a positive count"),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    })
}

/// The flags `reproduce` and `explore` share.
#[derive(Debug, clap::Args)]
pub(crate) struct RunArgs {
    /// Where the data, runs and report go (default: under target/); rerun to resume.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Trainings at a time (default: every core).
    #[arg(long)]
    pub jobs: Option<usize>,
}

/// Runs `jobs` on `workers` threads, each job once every job it waits for has finished.
/// The trainings are single-threaded on flex, so independent runs share the cores. The
/// first failure stops new jobs from starting; running ones finish.
pub(crate) fn run_jobs(bin: &Path, jobs: &[Job], workers: usize) -> Result<()> {
    use std::sync::{Condvar, Mutex};
    #[derive(Default)]
    struct State {
        started: Vec<bool>,
        done: Vec<bool>,
        error: Option<anyhow::Error>,
    }
    let state = Mutex::new(State { started: vec![false; jobs.len()], done: vec![false; jobs.len()], error: None });
    let wake = Condvar::new();
    std::thread::scope(|scope| {
        for _ in 0..workers.max(1) {
            scope.spawn(|| {
                let mut st = state.lock().unwrap_or_else(|e| e.into_inner());
                loop {
                    if st.error.is_some() || st.started.iter().all(|&b| b) {
                        return;
                    }
                    let ready = (0..jobs.len()).find(|&i| !st.started[i] && jobs[i].after.iter().all(|&d| st.done[d]));
                    let Some(i) = ready else {
                        st = wake.wait(st).unwrap_or_else(|e| e.into_inner());
                        continue;
                    };
                    st.started[i] = true;
                    drop(st);
                    let result = tacsim(bin, &jobs[i].args);
                    st = state.lock().unwrap_or_else(|e| e.into_inner());
                    match result {
                        Ok(()) => st.done[i] = true,
                        Err(e) => st.error = Some(e),
                    }
                    wake.notify_all();
                }
            });
        }
    });
    match state.into_inner().unwrap_or_else(|e| e.into_inner()).error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Runs the study into `out`.
pub fn run(quick: bool, args: &RunArgs) -> Result<()> {
    let plan = if quick { QUICK } else { FULL };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| crate::root().join("target").join(if quick { "reproduce-quick" } else { "reproduce" }));
    let workers = workers(args.jobs)?;
    let started = std::time::Instant::now();
    let bin = tacsim_binary()?;
    let data = out.join("data");
    let mut generate = vec![s("generate"), s(plan.recipe), s("--out"), s(data.display()), s("-q")];
    if data.join("meta.json").is_file() {
        generate.push(s("--resume"));
    }
    tacsim(&bin, &generate)?;
    let runs = out.join("runs");
    let common =
        format!("size = {}\nlr_self_supervised = {LR_SELF_SUPERVISED}\nlr_supervised = {LR_SUPERVISED}\n", plan.size);
    let mut jobs = Vec::new();
    // Pushes a run's job (if it has not finished) and returns its index for `after` lists.
    let add = |jobs: &mut Vec<Job>, args: Option<Vec<String>>, after: Vec<usize>| {
        args.map(|args| {
            jobs.push(Job { args, after });
            jobs.len() - 1
        })
    };
    let ss = runs.join("self-supervised");
    let ss_config = format!(
        "{common}mode = \"self-supervised\"\nself_supervised_epochs = {}\nmax_batches_per_epoch = {}\n",
        plan.ss_epochs, plan.ss_batches
    );
    let ss_job = add(&mut jobs, train("unshear", &data, &ss, &ss_config, &[])?, vec![]);
    // The pose network, the shortest run, before the baseline: its tap error is known early.
    let pose = runs.join("posenet");
    let pose_config = format!("size = {}\nepochs = {}\n{POSE_REGRESSION}", plan.size, plan.pose_epochs);
    add(&mut jobs, train("posenet", &data, &pose, &pose_config, &[])?, vec![]);
    let base = runs.join("baseline");
    let base_config = format!(
        "{common}mode = \"baseline\"\nsupervised_epochs = {}\nmax_batches_per_epoch = {}\n",
        plan.baseline_epochs, plan.baseline_batches
    );
    add(&mut jobs, train("baseline", &data, &base, &base_config, &[])?, vec![]);
    let init = [s("--init"), s(ss.join("model.safetensors").display())];
    // The report lists the models in this order: self-supervised, semi-supervised runs,
    // baseline, then the pose network. The jobs start longest first (the 10% runs before the
    // 8% and 5% ones), so the last to finish is a short one.
    let semi = [
        ("semi-supervised-10", 0.1, 0.1),
        ("semi-supervised-8", 0.08, 0.1),
        ("semi-supervised-5", 0.05, 0.1),
        ("semi-supervised-10-no-patch", 0.1, 0.0),
    ];
    for &(name, fraction, patch) in [&semi[0], &semi[3], &semi[1], &semi[2]] {
        let cfg = format!(
            "{common}mode = \"semi-supervised\"\nself_supervised_epochs = 0\nsupervised_epochs = {}\nlabel_fraction = {fraction}\npatch_weight = {patch}\n",
            plan.sup_epochs
        );
        add(&mut jobs, train("unshear", &data, &runs.join(name), &cfg, &init)?, ss_job.into_iter().collect());
    }
    let mut names = vec![ss.clone()];
    names.extend(semi.iter().map(|(name, ..)| runs.join(name)));
    names.extend([base, pose]);
    println!("{} training runs to do, {workers} at a time", jobs.len());
    run_jobs(&bin, &jobs, workers)?;
    let report = out.join("report");
    let mut eval = vec![s("eval"), s("--data"), s(data.display()), s("--out"), s(report.display())];
    eval.extend([s("--max-pairs"), s(plan.max_pairs)]);
    eval.extend(names.iter().map(|p| s(p.display())));
    tacsim(&bin, &eval)?;
    println!(
        "study finished in {:.1} min (this run, resumed steps excluded); report in {}",
        started.elapsed().as_secs_f64() / 60.0,
        report.display()
    );
    Ok(())
}
