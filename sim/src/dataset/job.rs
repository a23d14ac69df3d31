//! A recipe's run, set up before any work: the one way `tacsim generate` and the Python
//! package's `generate` start one. [`Job::new`] plans the samples and builds the sensor, its
//! contact model, renderer and scenes; [`Job::estimate`] says what the run would write (and
//! refuses beyond the caps unless forced); [`Job::run`] writes it ([`super::generate`]).

use std::path::{Path, PathBuf};

use super::generate::{self, Context, Summary, Target};
use super::plan::Plan;
use super::recipe::Recipe;
use crate::contact::ContactModel;
use crate::error::{Result, SimError};
use crate::png_io::{PngDepth, encode_png};
use crate::scene::{ObjectPose, Scene};
use crate::stimulus::Catalogue;
use crate::{PinRenderer, SensorParams};

/// The most images a run writes unless forced (the `paper` recipe is 120,000).
pub const MAX_UNFORCED_IMAGES: usize = 1_000_000;
/// The most bytes (estimated) a run writes unless forced: 16 GiB.
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
    /// Bytes in all (images and their rows).
    pub fn bytes(&self) -> u64 {
        (self.images as u64).saturating_mul(self.bytes_per_image + CSV_ROW_BYTES)
    }

    /// An error naming `source` where the run is beyond the unforced caps and `force` is not
    /// given.
    pub fn check(&self, source: &str, force: bool) -> Result<()> {
        if force || (self.images <= MAX_UNFORCED_IMAGES && self.bytes() <= MAX_UNFORCED_BYTES) {
            return Ok(());
        }
        Err(SimError::invalid(
            source,
            "poses.per_shape",
            format!(
                "makes {} images of about {} bytes each, about {}, beyond the caps of {MAX_UNFORCED_IMAGES} images and \
                 {} without --force: shrink the recipe (poses.per_shape, taps/slides.per_pose, image_size), split it \
                 with --shard, or pass --force once the disk has room",
                self.images,
                self.bytes_per_image,
                human_bytes(self.bytes()),
                human_bytes(MAX_UNFORCED_BYTES)
            ),
        ))
    }
}

/// `bytes` in GiB or MiB.
fn human_bytes(bytes: u64) -> String {
    let gib = bytes as f64 / f64::from(1u32 << 30);
    if gib >= 1.0 { format!("{gib:.1} GiB") } else { format!("{:.1} MiB", bytes as f64 / f64::from(1u32 << 20)) }
}

/// The sensor a run of `recipe` starts from: `sensor` (a file or a preset), else the
/// recipe's `sensor` field (a preset, or a file beside the recipe file `recipe_path`), else
/// the default sensor (the calibrated TacTip with its finite-element dome).
pub fn base_sensor(recipe: &Recipe, recipe_path: Option<&Path>, sensor: Option<&str>) -> Result<SensorParams> {
    match (sensor, &recipe.sensor) {
        (Some(arg), _) => SensorParams::file_or_preset(arg, None),
        (None, Some(name)) => {
            let dir = recipe_path.filter(|p| p.is_file()).and_then(Path::parent);
            SensorParams::file_or_preset(name, dir)
        }
        (None, None) => Ok(SensorParams::default()),
    }
}

/// A dataset from a recipe: built, then run into a folder (images, `targets.csv`,
/// `meta.json`; `docs/guide/datasets.md`).
///
/// ```
/// use tacsim_sim::dataset::{Job, Recipe};
/// use tacsim_sim::{SensorParams, builtin_catalogue};
///
/// let text = "image_size = 128\ncells_across = 9\n[[shapes]]\nname = \"disk\"\n\
///             [poses]\nper_shape = 1\n[taps]\nper_pose = 2\n[slides]\nper_pose = 0\n";
/// let recipe = Recipe::from_toml_str(text, "tiny.toml")?;
/// let job = Job::new(&recipe, "tiny.toml", &SensorParams::default(), &builtin_catalogue()?, None)?;
/// let out = std::env::temp_dir().join(format!("tacsim-doc-job-{}", std::process::id()));
/// let summary = job.run(&out, false, &|_done| {})?;
/// assert_eq!(summary.written, job.images());
/// assert!(out.join("targets.csv").is_file() && out.join("meta.json").is_file());
/// # std::fs::remove_dir_all(&out).ok();
/// # Ok::<(), tacsim_sim::SimError>(())
/// ```
///
/// A recipe's run, everything built but nothing simulated or written.
pub struct Job {
    /// The plan (its recipe validated).
    pub plan: Plan,
    /// Where the recipe came from (a file, or a built-in's name), for errors.
    pub source: String,
    /// The recipe's sensor (its image size, grid and skin model applied).
    pub sensor: SensorParams,
    /// Shard `(i, n)` of the plan, or all of it.
    pub shard: Option<(usize, usize)>,
    /// The GPU that moves the pins and rasterises the images in batches (`tacsim generate
    /// --device gpu`); `None` (as [`Job::new`] leaves it): the CPU per image.
    #[cfg(feature = "wgpu")]
    pub gpu: Option<crate::gpu::Gpu>,
    model: ContactModel,
    renderer: PinRenderer,
    scenes: Vec<Scene>,
}

impl Job {
    /// Validates `recipe` (from `source`), plans it on the stimuli of `catalogue` and builds
    /// `base` as the recipe asks (see [`super::recipe_sensor`]).
    pub fn new(
        recipe: &Recipe,
        source: &str,
        base: &SensorParams,
        catalogue: &Catalogue,
        shard: Option<(usize, usize)>,
    ) -> Result<Self> {
        recipe.validate(source)?;
        let plan = Plan::new(recipe, catalogue, source)?;
        let sensor = generate::recipe_sensor(&plan, base)?;
        let model = ContactModel::new(&sensor)?;
        let renderer = PinRenderer::new(&sensor, recipe.image_size)?;
        let scenes = plan
            .shapes
            .iter()
            .zip(&plan.recipe.shapes)
            .map(|((name, _), spec)| -> Result<Scene> {
                let mut scene = Scene::new();
                let stimulus = catalogue.get(name)?.with_friction(spec.friction).with_edge_radius(spec.edge_radius_mm);
                scene.add(stimulus, ObjectPose::default())?;
                Ok(scene)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            plan,
            source: source.to_owned(),
            sensor,
            shard,
            #[cfg(feature = "wgpu")]
            gpu: None,
            model,
            renderer,
            scenes,
        })
    }

    /// What [`Job::run`] generates from, with the CPU.
    #[cfg(all(test, feature = "wgpu"))]
    pub(crate) fn context(&self) -> super::generate::Context<'_> {
        super::generate::Context {
            plan: &self.plan,
            model: &self.model,
            scenes: &self.scenes,
            renderer: &self.renderer,
            source: &self.source,
            gpu: None,
        }
    }

    /// Images this run makes (its shard's).
    pub fn images(&self) -> usize {
        match self.shard {
            Some((i, n)) => generate::shard_range(self.plan.len(), i, n).len(),
            None => self.plan.len(),
        }
    }

    /// What the run would write.
    pub fn estimate(&self) -> Result<OutputEstimate> {
        let png = encode_png(&self.renderer.render_undeformed(), PngDepth::Grey8)?;
        Ok(OutputEstimate { images: self.images(), bytes_per_image: png.len() as u64 })
    }

    /// Writes the dataset into `out` (finishing an interrupted run of it with `resume`), on
    /// the current rayon pool; `progress` gets the count of images done.
    pub fn run(&self, out: &Path, resume: bool, progress: &(dyn Fn(usize) + Sync)) -> Result<Summary> {
        let ctx = Context {
            plan: &self.plan,
            model: &self.model,
            scenes: &self.scenes,
            renderer: &self.renderer,
            source: &self.source,
            #[cfg(feature = "wgpu")]
            gpu: self.gpu.as_ref(),
        };
        let target = Target { out: PathBuf::from(out), shard: self.shard, resume };
        generate::generate(&ctx, &self.sensor, &target, progress)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_beyond_the_byte_cap_is_refused_without_force_and_says_how_much() {
        let big = OutputEstimate { images: 20_000, bytes_per_image: 1 << 20 };
        let e = big.check("r.toml", false).expect_err("20,000 images of 1 MiB is beyond 16 GiB").to_string();
        assert!(
            e.contains("r.toml") && e.contains("20000 images") && e.contains("19.5 GiB") && e.contains("--force"),
            "{e}"
        );
        assert!(big.check("r.toml", true).is_ok());
        // The paper recipe's size passes.
        assert!(OutputEstimate { images: 120_000, bytes_per_image: 7_000 }.check("paper", false).is_ok());
    }
}
