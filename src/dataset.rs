//! `tacsim generate`, `tacsim merge` and `tacsim verify`: dataset recipes to image folders, with
//! a progress bar, and a dataset checked against its checksums.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use indicatif::{ProgressBar, ProgressStyle};
use tacsim_sim::SensorParams;
use tacsim_sim::dataset::Recipe;
use tacsim_sim::dataset::{self, Job, Summary};

use crate::commands::load_catalogue;

/// Options of `tacsim generate`.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct GenerateOptions {
    /// Recipe TOML, or a built-in recipe: paper, quick, twist, tilted-surface.
    pub recipe: Option<String>,
    /// Output directory (new or empty; the same dataset with --resume).
    #[arg(long)]
    pub out: PathBuf,
    /// Sensor TOML or built-in preset name (default: the recipe's `sensor`, else the built-in
    /// calibrated TacTip).
    #[arg(long)]
    pub sensor: Option<PathBuf>,
    /// Image size (px), overriding the recipe's.
    #[arg(long)]
    pub size: Option<u32>,
    /// Seed, overriding the recipe's.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Cells across the contact footprint, overriding the recipe's.
    #[arg(long)]
    pub cells: Option<usize>,
    /// Elastic body behind the skin: half-space, layer, skin-on-gel or dome (default: the
    /// sensor's skin.model).
    #[arg(long)]
    pub skin: Option<tacsim_sim::SkinModel>,
    /// Worker threads (default: all cores; at most 4 per core).
    #[arg(long, value_parser = crate::flags::threads)]
    pub threads: Option<usize>,
    /// Generate shard i of n (i/n, from 0): for job arrays; join with `tacsim merge`.
    #[arg(long, value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,
    /// Finish an interrupted run into the same directory.
    #[arg(long)]
    pub resume: bool,
    /// Write more than 1,000,000 images or about 16 GiB (refused without it).
    #[arg(long)]
    pub force: bool,
    /// Where the pins are moved and the images rasterised: cpu, gpu (batched; a build with
    /// `--features wgpu` and a GPU adapter) or auto (the GPU where there is one).
    #[arg(long, value_enum, default_value = "cpu")]
    pub device: crate::device::DeviceChoice,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Parses `i/n`.
pub fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let (i, n) = s.split_once('/').ok_or_else(|| format!("expected i/n (for example 0/4), got `{s}`"))?;
    let i: usize = i.trim().parse().map_err(|_| format!("shard index `{i}` is not a number"))?;
    let n: usize = n.trim().parse().map_err(|_| format!("shard count `{n}` is not a number"))?;
    if n == 0 || i >= n {
        return Err(format!("shard {i}/{n}: need 0 <= i < n"));
    }
    Ok((i, n))
}

/// Loads a recipe: a file, else a built-in name (default `quick`). Returns it with its source
/// name.
pub fn load_recipe(arg: Option<&str>) -> Result<(Recipe, String)> {
    Ok(Recipe::file_or_builtin(arg.unwrap_or("quick"))?)
}

/// `tacsim generate`: returns the summary lines to print.
pub fn generate(opts: &GenerateOptions) -> Result<String> {
    let (recipe, source) = load_recipe(opts.recipe.as_deref())?;
    let recipe = recipe.with_overrides(opts.seed, opts.size, opts.cells);
    let base = recipe_base_sensor(&recipe, opts)?;
    #[cfg_attr(not(feature = "wgpu"), allow(unused_mut))]
    let mut job = Job::new(&recipe, &source, &base, &load_catalogue(None)?, opts.shard)?;
    job.estimate()?.check(&source, opts.force)?;
    #[cfg(feature = "wgpu")]
    {
        job.gpu = crate::device::gpu(opts.device)?;
    }
    #[cfg(not(feature = "wgpu"))]
    crate::device::check(opts.device)?;
    let total = job.images();
    let bar = if opts.quiet { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} images, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(recipe.name.clone());
    let run = || job.run(&opts.out, opts.resume, &|done| bar.set_position(done as u64));
    let summary = match opts.threads {
        Some(n) => rayon::ThreadPoolBuilder::new().num_threads(n).build()?.install(run),
        None => run(),
    }
    .with_context(|| format!("generating {} into {}", recipe.name, opts.out.display()))?;
    bar.finish_and_clear();
    Ok(report(&recipe, &opts.out, total, &summary))
}

/// The sensor a generate run starts from: `--sensor`, else the recipe's `sensor` (a preset
/// name, or a file beside the recipe), else the calibrated TacTip.
pub fn recipe_base_sensor(recipe: &Recipe, opts: &GenerateOptions) -> Result<SensorParams> {
    let sensor = opts.sensor.as_deref().map(|p| p.to_string_lossy().into_owned());
    let mut base = dataset::base_sensor(recipe, opts.recipe.as_deref().map(Path::new), sensor.as_deref())
        .with_context(|| match &sensor {
            Some(s) => format!("loading the sensor `{s}` (see sim/presets/tactip-331-calibrated.toml for the format)"),
            None => format!("the sensor of recipe {} (its `sensor` field)", recipe.name),
        })?;
    if let Some(m) = opts.skin {
        base.skin.model = m;
        base.validate("--skin").context("the sensor with the --skin given")?;
    }
    Ok(base)
}

fn report(recipe: &Recipe, out: &Path, total: usize, s: &Summary) -> String {
    let per = |n: usize, secs: f64| if secs > 0.0 { n as f64 / secs } else { 0.0 };
    let busy = s.solve_s + s.render_s + s.encode_s + s.write_s;
    let pct = |v: f64| if busy > 0.0 { 100.0 * v / busy } else { 0.0 };
    format!(
        "{}: {total} images in {} ({} written, {} already there) in {:.1} s, {:.0} images/s\n\
         per thread: taps {:.0}/s, slides {:.0}/s; time in contact + pins {:.0}%, render {:.0}%, \
         PNG encode {:.0}%, write {:.0}%\n",
        recipe.name,
        out.display(),
        s.written,
        s.skipped,
        s.wall_s,
        per(s.written, s.wall_s),
        per(s.taps, s.tap_s),
        per(s.slides, s.slide_s),
        pct(s.solve_s),
        pct(s.render_s),
        pct(s.encode_s),
        pct(s.write_s),
    ) + &if s.no_contact > 0 {
        format!("{} samples touch nothing (poses.allow_no_contact): undeformed images\n", s.no_contact)
    } else {
        String::new()
    } + &if s.rewritten > 0 {
        format!(
            "{} images on disk were not the ones recorded in the journal (swapped, edited, truncated, or never \
             recorded) and were written again\n",
            s.rewritten
        )
    } else {
        String::new()
    }
}

/// `tacsim verify`: checks a dataset against its `SHA256SUMS`; an error listing every problem
/// where one is found.
pub fn verify(dir: &Path) -> Result<String> {
    let v = tacsim_data::verify(dir)?;
    if v.problems.is_empty() {
        return Ok(format!("{}: {} files match SHA256SUMS; every image is readable\n", dir.display(), v.files));
    }
    anyhow::bail!(
        "dataset {}: {} of {} files fail:\n  {}",
        dir.display(),
        v.problems.len(),
        v.files,
        v.problems.join("\n  ")
    )
}

/// `tacsim merge`: joins shards into `out`.
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<String> {
    let n = dataset::merge(out, shards)?;
    Ok(format!("merged {} shards: {n} images in {}\n", shards.len(), out.display()))
}
