//! `tacsim generate` and `tacsim merge`: dataset recipes to image folders, with a progress bar.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use indicatif::{ProgressBar, ProgressStyle};
use tacsim_sim::contact::engine::ContactModel;
use tacsim_sim::dataset::generate::{self, Context, Summary, Target};
use tacsim_sim::dataset::plan::Plan;
use tacsim_sim::dataset::recipe::Recipe;
use tacsim_sim::scene::{ObjectPose, Scene};
use tacsim_sim::{PinRenderer, SensorParams};

use crate::commands::load_catalogue;
use crate::embedded::RECIPES;

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
    /// Write beyond [`MAX_UNFORCED_IMAGES`] images or [`MAX_UNFORCED_BYTES`] bytes.
    pub force: bool,
}

/// The most images `tacsim generate` writes without `--force` (the `paper` recipe is
/// 120,000).
pub const MAX_UNFORCED_IMAGES: usize = 1_000_000;
/// The most bytes (estimated) `tacsim generate` writes without `--force`: 16 GiB.
pub const MAX_UNFORCED_BYTES: u64 = 16 << 30;
/// Bytes of `targets.csv` per image, a generous bound (one row of labels).
const CSV_ROW_BYTES: u64 = 256;

/// What a run would write: `images` PNGs of about `bytes_per_image` each (the sensor's
/// undeformed image, encoded as the run encodes; deformed ones are of the same order) and
/// their `targets.csv` rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputEstimate {
    /// Images to write.
    pub images: usize,
    /// Bytes of one image (PNG).
    pub bytes_per_image: u64,
}

impl OutputEstimate {
    /// The estimate for `images` images drawn by `renderer`.
    pub fn of(renderer: &PinRenderer, images: usize) -> Result<Self> {
        let png = tacsim_sim::png_io::encode_png(&renderer.render_undeformed(), tacsim_sim::png_io::PngDepth::Grey8)?;
        Ok(Self { images, bytes_per_image: png.len() as u64 })
    }

    /// Bytes in all (images and their rows).
    pub fn bytes(&self) -> u64 {
        (self.images as u64).saturating_mul(self.bytes_per_image + CSV_ROW_BYTES)
    }

    /// An error where the run is beyond the unforced caps and `force` is not given.
    pub fn check(&self, what: &str, force: bool) -> Result<()> {
        if force || (self.images <= MAX_UNFORCED_IMAGES && self.bytes() <= MAX_UNFORCED_BYTES) {
            return Ok(());
        }
        anyhow::bail!(
            "{what} would write {} images of about {} bytes each, about {}, beyond the caps of {MAX_UNFORCED_IMAGES} \
             images and {} without --force: shrink the recipe (poses.per_shape, taps/slides.per_pose, image_size), \
             split it with --shard, or pass --force once the disk has room",
            self.images,
            self.bytes_per_image,
            human_bytes(self.bytes()),
            human_bytes(MAX_UNFORCED_BYTES)
        )
    }
}

/// `bytes` in GiB or MiB.
fn human_bytes(bytes: u64) -> String {
    let gib = bytes as f64 / f64::from(1u32 << 30);
    if gib >= 1.0 { format!("{gib:.1} GiB") } else { format!("{:.1} MiB", bytes as f64 / f64::from(1u32 << 20)) }
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

/// Loads a recipe: a file, else a built-in name. Returns it with its source name.
pub fn load_recipe(arg: Option<&str>) -> Result<(Recipe, String)> {
    let arg = arg.unwrap_or("quick");
    let path = Path::new(arg);
    if path.exists() {
        return Ok((Recipe::load(path)?, path.display().to_string()));
    }
    match RECIPES.iter().find(|(n, _)| *n == arg) {
        Some((name, text)) => {
            let source = format!("built-in recipe {name} (scenarios/datasets/{name}.toml)");
            Ok((Recipe::from_toml_str(text, &source)?, source))
        }
        None => anyhow::bail!(
            "recipe `{arg}` is neither a file nor a built-in recipe ({})",
            RECIPES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// `tacsim generate`: returns the summary lines to print.
pub fn generate(opts: &GenerateOptions) -> Result<String> {
    let (mut recipe, source) = load_recipe(opts.recipe.as_deref())?;
    if let Some(s) = opts.size {
        recipe.image_size = s;
    }
    if let Some(s) = opts.seed {
        recipe.seed = s;
    }
    if let Some(c) = opts.cells {
        recipe.cells_across = Some(c);
    }
    recipe.validate(&source)?;
    let catalogue = load_catalogue(None)?;
    let plan = Plan::new(&recipe, &catalogue, &source)?;
    let base = recipe_base_sensor(&recipe, opts)?;
    let sensor = generate::recipe_sensor(&plan, &base)?;
    let model = ContactModel::new(&sensor);
    let renderer = PinRenderer::new(&sensor, recipe.image_size)?;
    let total = match opts.shard {
        Some((i, n)) => generate::shard_range(plan.len(), i, n).len(),
        None => plan.len(),
    };
    OutputEstimate::of(&renderer, total)?.check(&format!("{source} into {}", opts.out.display()), opts.force)?;
    let scenes = plan
        .shapes
        .iter()
        .zip(&plan.recipe.shapes)
        .map(|((name, _), spec)| -> Result<Scene> {
            let mut scene = Scene::new();
            scene.add(
                catalogue.get(name)?.with_friction(spec.friction).with_edge_radius(spec.edge_radius_mm),
                ObjectPose::default(),
            )?;
            Ok(scene)
        })
        .collect::<Result<Vec<_>>>()?;
    let ctx = Context { plan: &plan, model: &model, scenes: &scenes, renderer: &renderer, source: &source };
    let target = Target { out: opts.out.clone(), shard: opts.shard, resume: opts.resume };
    let bar = if opts.quiet { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} images, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(recipe.name.clone());
    let run = || generate::generate(&ctx, &sensor, &target, &|done| bar.set_position(done as u64));
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
    match (&opts.sensor, &recipe.sensor) {
        (Some(_), _) | (None, None) => crate::commands::load_sensor(opts.sensor.as_deref(), None),
        (None, Some(name)) => {
            let dir = opts.recipe.as_deref().map(Path::new).filter(|p| p.is_file()).and_then(Path::parent);
            crate::commands::sensor_file_or_preset(name, dir)
                .with_context(|| format!("the sensor of recipe {} (its `sensor` field)", recipe.name))
        }
    }
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
    let n = generate::merge(out, shards)?;
    Ok(format!("merged {} shards: {n} images in {}\n", shards.len(), out.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_beyond_the_byte_cap_is_refused_without_force_and_says_how_much() {
        let big = OutputEstimate { images: 20_000, bytes_per_image: 1 << 20 };
        let e = big.check("r.toml into out", false).expect_err("20,000 images of 1 MiB is beyond 16 GiB").to_string();
        assert!(
            e.contains("r.toml") && e.contains("20000 images") && e.contains("19.5 GiB") && e.contains("--force"),
            "{e}"
        );
        assert!(big.check("r.toml into out", true).is_ok());
        // The paper recipe's size passes.
        assert!(OutputEstimate { images: 120_000, bytes_per_image: 7_000 }.check("paper", false).is_ok());
    }
}
