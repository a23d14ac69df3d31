//! `cargo xtask explore [--out DIR] [--jobs N]`: contour following with learned perception,
//! end to end through the `tacsim` command line: generate the `explore` recipe (poses
//! relative to the edge, all around the disk, clover and teardrop), train the pose network on
//! its taps and the semi-supervised shear-removal model (10% labels) on its tap/slide pairs,
//! evaluate both on the test split (pose MAE in the edge frame on tap, sheared and unsheared
//! images), then run `scenarios/explore/learned/*.toml` (`learned` and `learned-raw`
//! perception) with them. Every step resumes.
//!
//! Networks at 64 px (the recipe renders 128 px images, averaged down), trained at the
//! CPU-scale study's learning rates ([`crate::reproduce`]): pose network 30 epochs; shear
//! removal 2 self-supervised epochs of 150 batches, then 15 supervised epochs.

use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::reproduce::{Job, LR_SELF_SUPERVISED, LR_SUPERVISED, run_jobs, s, tacsim, tacsim_binary, train, workers};

/// Network side (px).
const SIZE: usize = 64;

/// Runs the pipeline into `out` (default `target/explore`, where the scenarios' `[models]`
/// defaults look).
pub fn run(args: &[String]) -> Result<()> {
    let value = |flag: &str| args.iter().position(|a| a == flag).and_then(|i| args.get(i + 1));
    let root = crate::root();
    let out = value("--out").map(PathBuf::from).unwrap_or_else(|| root.join("target").join("explore"));
    let workers = workers(value("--jobs"))?;
    let started = std::time::Instant::now();
    let bin = tacsim_binary()?;
    let data = out.join("data");
    let recipe = root.join("scenarios/datasets/explore.toml");
    let mut generate = vec![s("generate"), s(recipe.display()), s("--out"), s(data.display()), s("-q")];
    if data.join("meta.json").is_file() {
        generate.push(s("--resume"));
    }
    tacsim(&bin, &generate)?;

    let runs = out.join("runs");
    let pose = runs.join("posenet");
    let unshear = runs.join("unshear");
    let mut jobs = Vec::new();
    let pose_config = format!("size = {SIZE}\nepochs = 30\n");
    if let Some(args) = train("posenet", &data, &pose, &pose_config, &[])? {
        jobs.push(Job { args, after: vec![] });
    }
    let unshear_config = format!(
        "size = {SIZE}\nlr_self_supervised = {LR_SELF_SUPERVISED}\nlr_supervised = {LR_SUPERVISED}\n\
         mode = \"semi-supervised\"\nself_supervised_epochs = 2\nsupervised_epochs = 15\n\
         max_batches_per_epoch = 150\nlabel_fraction = 0.1\npatch_weight = 0.1\n"
    );
    if let Some(args) = train("unshear", &data, &unshear, &unshear_config, &[])? {
        jobs.push(Job { args, after: vec![] });
    }
    println!("{} training runs to do, {workers} at a time", jobs.len());
    run_jobs(&bin, &jobs, workers)?;

    let eval = out.join("eval");
    tacsim(
        &bin,
        &[
            s("eval"),
            s("--data"),
            s(data.display()),
            s("--out"),
            s(eval.display()),
            s("--max-pairs"),
            s(600),
            s(unshear.display()),
            s(pose.display()),
        ],
    )?;
    let mut scenarios: Vec<PathBuf> = std::fs::read_dir(root.join("scenarios/explore/learned"))
        .context("listing scenarios/explore/learned")?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenarios.sort();
    let report = out.join("report");
    let mut run = vec![s("run"), s("--out"), s(report.display()), s("--models"), s(runs.display())];
    run.extend(scenarios.iter().map(|p| s(p.display())));
    let result = tacsim(&bin, &run);
    println!(
        "explore finished in {:.1} min (resumed steps excluded); evaluation in {}, runs in {}",
        started.elapsed().as_secs_f64() / 60.0,
        eval.display(),
        report.display()
    );
    result
}
