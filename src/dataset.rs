//! `tacsim generate` and `tacsim merge`: dataset recipes to image folders, with a progress bar.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use indicatif::{ProgressBar, ProgressStyle};
use tacsim_sim::SensorParams;
use tacsim_sim::dataset::Recipe;
use tacsim_sim::dataset::{self, Job, Summary};

use crate::commands::load_catalogue;

/// Options of `tacsim generate`.
#[derive(Clone, Debug, Default)]
pub struct GenerateOptions {
    /// Recipe file, or the name of a built-in recipe (`paper`, `quick`, ...); `None`: `quick`.
    pub recipe: Option<String>,
    /// Output directory.
    pub out: PathBuf,
    /// Sensor TOML (default: the built-in calibrated TacTip).
    pub sensor: Option<PathBuf>,
    /// Image size override (px).
    pub size: Option<u32>,
    /// Seed override.
    pub seed: Option<u64>,
    /// Contact grid override (cells across the footprint).
    pub cells: Option<usize>,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// `(i, n)`: shard `i` of `n`.
    pub shard: Option<(usize, usize)>,
    /// Finish an interrupted run.
    pub resume: bool,
    /// No progress bar.
    pub quiet: bool,
    /// Write beyond [`tacsim_sim::dataset::MAX_UNFORCED_IMAGES`] images or
    /// [`tacsim_sim::dataset::MAX_UNFORCED_BYTES`] bytes.
    pub force: bool,
    /// Where the pins are moved and the images rasterised.
    pub device: crate::device::DeviceChoice,
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
    dataset::base_sensor(recipe, opts.recipe.as_deref().map(Path::new), sensor.as_deref()).with_context(
        || match &sensor {
            Some(s) => format!("loading the sensor `{s}` (see sim/presets/tactip-331-calibrated.toml for the format)"),
            None => format!("the sensor of recipe {} (its `sensor` field)", recipe.name),
        },
    )
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
    }
}

/// `tacsim merge`: joins shards into `out`.
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<String> {
    let n = dataset::merge(out, shards)?;
    Ok(format!("merged {} shards: {n} images in {}\n", shards.len(), out.display()))
}
