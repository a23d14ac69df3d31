//! `cargo xtask reproduce [--quick] [--out DIR]`: the paper's study end to end through the
//! `tacsim` command line: generate the dataset, train the self-supervised phase once, the
//! supervised phase at each label fraction (10%, 8%, 5%) and without the patch loss, the
//! fully supervised baseline and the pose network, then evaluate them all into a report
//! (`report.md`, `report.json`, `grid.png`). Every step resumes, so an interrupted study
//! continues where it stopped when rerun.
//!
//! | | `--quick` | full (CPU scale) |
//! |---|---|---|
//! | recipe | `study-quick` (2,880 images at 128 px, 180 poses) | `study` (7,200 images at 128 px, 360 poses) |
//! | network size | 64 px (images averaged down, grey) | 128 px |
//! | self-supervised / supervised / baseline / pose epochs | 3 / 10 / 5 / 15 | 4 / 20 / 6 / 20 |
//! | learning rates | 4x the paper's | 4x the paper's |
//!
//! The learning rates are raised because a CPU-scale study takes hundreds of steps where the
//! paper took tens of thousands; everything else keeps the paper's values.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

struct Plan {
    recipe: &'static str,
    size: usize,
    ss_epochs: usize,
    sup_epochs: usize,
    baseline_epochs: usize,
    pose_epochs: usize,
    max_pairs: usize,
}

const QUICK: Plan = Plan {
    recipe: "study-quick",
    size: 64,
    ss_epochs: 3,
    sup_epochs: 10,
    baseline_epochs: 5,
    pose_epochs: 15,
    max_pairs: 360,
};
const FULL: Plan = Plan {
    recipe: "study",
    size: 128,
    ss_epochs: 4,
    sup_epochs: 20,
    baseline_epochs: 6,
    pose_epochs: 20,
    max_pairs: 400,
};

/// Learning-rate factor of CPU-scale studies.
const LR_SCALE: f64 = 4.0;

fn tacsim(args: &[String]) -> Result<()> {
    println!("$ tacsim {}", args.join(" "));
    let status = Command::new(env!("CARGO"))
        .args(["run", "--quiet", "--bin", "tacsim", "--"])
        .args(args)
        .status()
        .context("running tacsim through cargo")?;
    if !status.success() {
        bail!("`tacsim {}` failed", args.join(" "));
    }
    Ok(())
}

fn s(v: impl ToString) -> String {
    v.to_string()
}

/// Trains one run unless it has finished (resuming it if it was interrupted).
fn train(net: &str, data: &Path, out: &Path, config: &str, extra: &[String]) -> Result<()> {
    if out.join("model.safetensors").is_file() {
        println!("{} done", out.display());
        return Ok(());
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
    tacsim(&args)
}

/// Runs the study into `out`.
pub fn run(args: &[String]) -> Result<()> {
    let quick = args.iter().any(|a| a == "--quick");
    let plan = if quick { QUICK } else { FULL };
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map(PathBuf::from)
        .unwrap_or_else(|| crate::root().join("target").join(if quick { "reproduce-quick" } else { "reproduce" }));
    let started = std::time::Instant::now();
    let data = out.join("data");
    let mut generate = vec![s("generate"), s(plan.recipe), s("--out"), s(data.display()), s("-q")];
    if data.join("meta.json").is_file() {
        generate.push(s("--resume"));
    }
    tacsim(&generate)?;
    let runs = out.join("runs");
    let lr_ss = 5e-5 * LR_SCALE;
    let lr_s = 2.5e-5 * LR_SCALE;
    let common = format!("size = {}\nlr_self_supervised = {lr_ss}\nlr_supervised = {lr_s}\n", plan.size);
    let ss = runs.join("self-supervised");
    train(
        "unshear",
        &data,
        &ss,
        &format!("{common}mode = \"self-supervised\"\nself_supervised_epochs = {}\n", plan.ss_epochs),
        &[],
    )?;
    let init = [s("--init"), s(ss.join("model.safetensors").display())];
    let mut names = vec![ss.clone()];
    for (name, fraction, patch) in [
        ("semi-supervised-10", 0.1, 0.1),
        ("semi-supervised-8", 0.08, 0.1),
        ("semi-supervised-5", 0.05, 0.1),
        ("semi-supervised-10-no-patch", 0.1, 0.0),
    ] {
        let dir = runs.join(name);
        let cfg = format!(
            "{common}mode = \"semi-supervised\"\nself_supervised_epochs = 0\nsupervised_epochs = {}\nlabel_fraction = {fraction}\npatch_weight = {patch}\n",
            plan.sup_epochs
        );
        train("unshear", &data, &dir, &cfg, &init)?;
        names.push(dir);
    }
    let base = runs.join("baseline");
    train(
        "baseline",
        &data,
        &base,
        &format!("{common}mode = \"baseline\"\nsupervised_epochs = {}\n", plan.baseline_epochs),
        &[],
    )?;
    names.push(base);
    let pose = runs.join("posenet");
    train("posenet", &data, &pose, &format!("size = {}\nepochs = {}\n", plan.size, plan.pose_epochs), &[])?;
    names.push(pose);
    let report = out.join("report");
    let mut eval = vec![s("eval"), s("--data"), s(data.display()), s("--out"), s(report.display())];
    eval.extend([s("--max-pairs"), s(plan.max_pairs)]);
    eval.extend(names.iter().map(|p| s(p.display())));
    tacsim(&eval)?;
    println!(
        "study finished in {:.1} min (this run, resumed steps excluded); report in {}",
        started.elapsed().as_secs_f64() / 60.0,
        report.display()
    );
    Ok(())
}
