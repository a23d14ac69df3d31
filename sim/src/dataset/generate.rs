//! Generating a plan into a dataset directory (`tacsim_data` format), in parallel, resumably
//! and in shards; and merging shards.
//!
//! Order of writes: `meta.json` and `targets.csv` (both fully determined by the plan) and the
//! reference image first, then the sample images, each written atomically and its SHA-256
//! appended to the journal (`tacsim_data::JOURNAL_FILE`), last the listing `SHA256SUMS` of
//! every file. A directory is complete when it holds the listing; `--resume` keeps an image
//! only where its bytes are the recorded ones, and `merge` and `tacsim verify` check every file
//! against the listing.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;
use tacsim_data::to_csv;
use tacsim_data::{
    CHECKSUMS_FILE, JOURNAL_FILE, Journal, Kind, Meta, Row, Shard, image_entry, read_checksums, recorded_checksums,
    sha256_hex, write_checksums,
};

use super::plan::{Plan, REFERENCE_IMAGE, Sample, image_name};
use crate::SensorPath;
use crate::atomic::{is_temp_name, write_atomic, write_atomic_unsynced};
use crate::contact::{ContactModel, Footprint, Grid, Simulation};
use crate::error::{Result, SimError};
use crate::pins::PinLayout;
use crate::png_io::{PngDepth, encode_png};
use crate::render::PinRenderer;
use crate::scene::Scene;
use crate::sensor::SensorParams;

/// Tool name and version recorded in `meta.json`.
pub const TOOL: &str = concat!("tacsim ", env!("CARGO_PKG_VERSION"));

/// What to generate where.
#[derive(Clone, Debug)]
pub struct Target {
    /// Output directory.
    pub out: PathBuf,
    /// `(i, n)`: generate shard `i` of `n` (sample indices `i N / n .. (i + 1) N / n`).
    pub shard: Option<(usize, usize)>,
    /// Finish an interrupted run of the same dataset in `out`.
    pub resume: bool,
}

/// Seconds spent per stage (summed over threads) and counts.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Summary {
    /// Images written by this run.
    pub written: usize,
    /// Images already present with their recorded bytes (resume).
    pub skipped: usize,
    /// Images present but not as recorded (swapped, edited, truncated, or written by a run
    /// killed before it recorded them), written again (resume).
    pub rewritten: usize,
    /// Samples (of the run's range) whose sensor touches nothing (`poses.allow_no_contact`).
    pub no_contact: usize,
    /// Taps and slides written.
    pub taps: usize,
    /// Slides written.
    pub slides: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Thread-seconds in taps (contact + pins + render + encode + write).
    pub tap_s: f64,
    /// Thread-seconds in slides.
    pub slide_s: f64,
    /// Thread-seconds in the contact solve and pins.
    pub solve_s: f64,
    /// Thread-seconds rendering.
    pub render_s: f64,
    /// Thread-seconds encoding PNG.
    pub encode_s: f64,
    /// Thread-seconds writing files.
    pub write_s: f64,
}

/// The sensor a recipe runs: `base` with the recipe's grid and skin overrides and image size.
pub fn recipe_sensor(plan: &Plan, base: &SensorParams) -> Result<SensorParams> {
    let mut s = base.clone();
    if let Some(n) = plan.recipe.cells_across {
        s.skin.cells_across = n;
    }
    if let Some(m) = plan.recipe.skin {
        s.skin.model = m;
    }
    s.camera.image_size = plan.recipe.image_size;
    s.validate("recipe sensor")?;
    Ok(s)
}

/// The `meta.json` of a plan (with `shard` set for a shard).
pub fn meta(plan: &Plan, sensor: &SensorParams, shard: Option<Shard>) -> Result<Meta> {
    let (taps, slides) = plan.counts();
    Ok(Meta {
        format: Meta::FORMAT,
        tool: TOOL.into(),
        seed: plan.recipe.seed,
        image_size: plan.recipe.image_size,
        samples: plan.len(),
        taps,
        slides,
        reference_image: REFERENCE_IMAGE.into(),
        recipe: to_json(&plan.recipe, "recipe")?,
        sensor: to_json(sensor, "sensor")?,
        shard,
    })
}

fn to_json<T: Serialize>(v: &T, what: &str) -> Result<serde_json::Value> {
    serde_json::to_value(v).map_err(|e| SimError::invalid("meta.json", what, format!("cannot be written as JSON: {e}")))
}

/// Sample indices of shard `i` of `n` over `len` samples.
pub fn shard_range(len: usize, i: usize, n: usize) -> std::ops::Range<usize> {
    (i * len / n)..((i + 1) * len / n)
}

/// Whether `old` (a dataset's `meta.json`) names the dataset `new` does: equal, or equal once
/// each side's recipe and sensor are read back as this build reads them, so that a field added
/// since, at its default, names no other dataset. Regression: 33ec276's `[rig] tilt_play_deg`
/// made every earlier work folder "a different dataset".
fn same_dataset(old: &Meta, new: &Meta) -> bool {
    fn read_back<T: Serialize + serde::de::DeserializeOwned>(v: &serde_json::Value) -> Option<serde_json::Value> {
        serde_json::to_value(serde_json::from_value::<T>(v.clone()).ok()?).ok()
    }
    let normal = |m: &Meta| -> Option<Meta> {
        Some(Meta {
            recipe: read_back::<super::Recipe>(&m.recipe)?,
            sensor: read_back::<SensorParams>(&m.sensor)?,
            ..m.clone()
        })
    };
    old == new || matches!((normal(old), normal(new)), (Some(a), Some(b)) if a == b)
}

/// Prepares `target.out` for `meta`: a new (or empty) directory, or the same dataset when
/// resuming. Refuses a directory holding anything else.
fn prepare(target: &Target, meta: &Meta) -> Result<()> {
    let out = &target.out;
    let images = out.join("images");
    if out.exists() {
        let meta_path = out.join("meta.json");
        if meta_path.exists() {
            let old = Meta::load(&meta_path)?;
            if !same_dataset(&old, meta) {
                return Err(SimError::Analysis {
                    source_name: out.display().to_string(),
                    reason: "holds a different dataset (recipe, seed, sensor, size or shard differ); \
                             choose another --out or delete it"
                        .into(),
                });
            }
            if !target.resume {
                return Err(SimError::Analysis {
                    source_name: out.display().to_string(),
                    reason: "already holds this dataset; pass --resume to finish an interrupted run".into(),
                });
            }
        } else if std::fs::read_dir(out).map_err(|e| SimError::io(out, "list", e))?.next().is_some() {
            return Err(SimError::Analysis {
                source_name: out.display().to_string(),
                reason: "is not empty and holds no tacsim dataset (meta.json); choose another --out".into(),
            });
        }
    }
    std::fs::create_dir_all(&images).map_err(|e| SimError::io(&images, "create directory", e))?;
    // Temporary files of an interrupted run.
    for entry in std::fs::read_dir(&images).map_err(|e| SimError::io(&images, "list", e))? {
        let entry = entry.map_err(|e| SimError::io(&images, "list", e))?;
        if is_temp_name(&entry.file_name().to_string_lossy()) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
    Ok(())
}

/// Whether `path` holds a complete PNG of `size` x `size` (a folder written before checksums
/// keeps it on resume).
fn complete_image(path: &Path, size: u32) -> bool {
    image::ImageReader::open(path)
        .ok()
        .and_then(|r| r.with_guessed_format().ok())
        .and_then(|r| r.into_dimensions().ok())
        .is_some_and(|d| d == (size, size))
        && crate::png_io::read_png(path).is_ok()
}

/// The SHA-256 of the file at `path`, `None` where it cannot be read.
fn file_sha256(path: &Path) -> Option<String> {
    std::fs::read(path).ok().map(|b| sha256_hex(&b))
}

/// Everything a sample needs that is shared by all samples.
pub struct Context<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Contact model of the recipe's sensor.
    pub model: &'a ContactModel,
    /// One scene per recipe shape, the shape at its origin.
    pub scenes: &'a [Scene],
    /// Renderer at the recipe's image size.
    pub renderer: &'a PinRenderer,
    /// Where the recipe came from (a file, or a built-in's name), for errors.
    pub source: &'a str,
    /// The GPU that moves the pins and rasterises the images in batches (`--device gpu`), else
    /// the CPU per image.
    #[cfg(feature = "wgpu")]
    pub gpu: Option<&'a crate::gpu::Gpu>,
}

/// Samples per GPU dispatch (`--device gpu`): their contact is solved on the CPU threads,
/// then their pins moved and their images rasterised together.
#[cfg(feature = "wgpu")]
const GPU_BATCH: usize = 256;

/// Samples whose footprint grids the pre-check keeps for the solve (48 bytes each, 48 MB at
/// most): a larger run's solve probes the scene for them again.
const KEPT_FOOTPRINTS: usize = 1_000_000;

/// Every sample of `range` checked before any work: its sensor poses within the sensor's
/// range and its path bounded; a sample that touches nothing is an error unless the recipe
/// allows it (`poses.allow_no_contact`). Returns each sample's footprint grid (in `range`'s
/// order, up to [`KEPT_FOOTPRINTS`] samples, else none: the solve reuses them instead of
/// probing the scene again) and how many touch nothing.
pub fn check_samples(ctx: &Context<'_>, range: std::ops::Range<usize>) -> Result<(Vec<Option<Grid>>, usize)> {
    let plan = ctx.plan;
    let source = ctx.source;
    let radius = ctx.model.sensor.dome.outer_radius_mm;
    let check = |i: usize| -> Result<Option<Grid>> {
        let s = plan.sample(i);
        let (start, target) = plan.sensor_poses(&s);
        let at =
            |e: SimError| SimError::invalid(source, format!("sample {} ({})", i + 1, image_name(i)), e.to_string());
        start.validate("its start pose", radius).map_err(at)?;
        target.validate("its pose", radius).map_err(at)?;
        Ok(sample_footprint(ctx, &s).map_err(at)?.grid)
    };
    let (grids, misses): (Vec<Option<Grid>>, Vec<usize>) = if range.len() <= KEPT_FOOTPRINTS {
        let grids: Vec<Option<Grid>> = range.clone().into_par_iter().map(check).collect::<Result<_>>()?;
        let misses = grids.iter().zip(range).filter(|(g, _)| g.is_none()).map(|(_, i)| i).collect();
        (grids, misses)
    } else {
        let misses = range
            .into_par_iter()
            .map(|i| Ok(check(i)?.is_none().then_some(i)))
            .filter_map(Result::transpose)
            .collect::<Result<_>>()?;
        (Vec::new(), misses)
    };
    if let (Some(&first), false) = (misses.first(), plan.recipe.poses.allow_no_contact) {
        let s = plan.sample(first);
        return Err(SimError::invalid(
            source,
            "poses",
            format!(
                "{} of the samples touch nothing (the first: sample {}, labels x {:.2} mm, y {:.2} mm, depth {:.2} \
                 mm, yaw {:.1} deg): their images would be undeformed under a depth label. Keep the poses on the \
                 shape (poses.x_mm, poses.y_mm, shapes[].contact_mm), or set poses.allow_no_contact = true to keep \
                 such samples",
                misses.len(),
                first + 1,
                s.pose[0],
                s.pose[1],
                s.pose[2],
                s.pose[5]
            ),
        ));
    }
    Ok((grids, misses.len()))
}

/// Where sample `s`'s contact is solved.
fn sample_footprint(ctx: &Context<'_>, s: &Sample) -> Result<Footprint> {
    let scene = &ctx.scenes[ctx.plan.poses[s.pose_id].shape];
    Ok(Footprint::of_path(ctx.model, scene, &sample_path(ctx.plan, s)?.poses()))
}

/// The path of sample `s`: a tap, or a slide in the recipe's steps.
fn sample_path(plan: &Plan, s: &Sample) -> Result<SensorPath> {
    let (start, target) = plan.sensor_poses(s);
    Ok(match s.kind {
        Kind::Tap => SensorPath::tap(target),
        Kind::Slide => {
            let sl = &plan.recipe.slides;
            SensorPath::slide_between(start, target, sl.step_mm, sl.step_deg)?
        }
    })
}

/// Simulates, renders and encodes one sample, on its footprint grid where the pre-check kept
/// it (`known`, [`check_samples`]); returns the PNG bytes and the stage times `[solve,
/// render, encode]` (s).
pub fn sample_png(ctx: &Context<'_>, s: &Sample, known: Option<Option<Grid>>) -> Result<(Vec<u8>, [f64; 3])> {
    let t0 = Instant::now();
    let pins = sample_state(ctx, s, known)?.pins();
    let t1 = Instant::now();
    let img = ctx.renderer.render_varied(&pins, &s.variation);
    let t2 = Instant::now();
    let png = encode_png(&img, PngDepth::Grey8)?;
    let t3 = Instant::now();
    Ok((png, [(t1 - t0).as_secs_f64(), (t2 - t1).as_secs_f64(), (t3 - t2).as_secs_f64()]))
}

/// One sample's contact state at the end of its path, solved on its footprint grid where it
/// is `known` (else found again).
fn sample_state<'a>(ctx: &Context<'a>, s: &Sample, known: Option<Option<Grid>>) -> Result<Simulation<'a>> {
    let path = sample_path(ctx.plan, s)?;
    let scene = &ctx.scenes[ctx.plan.poses[s.pose_id].shape];
    let poses = path.poses();
    let footprint = match known {
        Some(grid) => Footprint::on_grid(&poses, grid),
        None => Footprint::of_path(ctx.model, scene, &poses),
    };
    let mut sim = Simulation::on_footprint(ctx.model, scene, footprint);
    for step in &path.steps {
        sim.step(step.pose)?;
    }
    Ok(sim)
}

/// Generates `target` (the whole plan or a shard) into its directory. `progress` is called
/// with the number of images done so far (skipped ones included) after each image.
pub fn generate(
    ctx: &Context<'_>,
    sensor: &SensorParams,
    target: &Target,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Summary> {
    let wall = Instant::now();
    let plan = ctx.plan;
    let range = match target.shard {
        Some((i, n)) => {
            if n == 0 || i >= n {
                return Err(SimError::invalid("--shard", "shard", format!("must be i/n with i < n, got {i}/{n}")));
            }
            shard_range(plan.len(), i, n)
        }
        None => 0..plan.len(),
    };
    let shard = target.shard.map(|(index, count)| Shard { index, count, start: range.start, end: range.end });
    let meta = meta(plan, sensor, shard)?;
    let (grids, no_contact) = check_samples(ctx, range.clone())?;
    let known = |i: usize| grids.get(i - range.start).copied();
    prepare(target, &meta)?;
    let out = &target.out;
    let rows: Vec<Row> = range.clone().map(|i| plan.row(&plan.sample(i))).collect();
    let (meta_bytes, csv_bytes) = (meta.to_json()?, to_csv(&rows)?);
    write_atomic(&out.join("meta.json"), &meta_bytes)?;
    write_atomic(&out.join("targets.csv"), &csv_bytes)?;
    let images = out.join("images");
    let reference = ctx.renderer.render(&PinLayout::new(sensor).poses());
    let reference_png = encode_png(&reference, PngDepth::Grey8)?;
    write_atomic(&images.join(REFERENCE_IMAGE), &reference_png)?;

    // Resuming, an image is kept where its bytes are the ones its run recorded (regression: a
    // decodable image of the right size was kept, so one overwritten by a copy of another
    // passed); the kept lines start the journal and the listing goes until the run ends.
    let recorded = if target.resume { recorded_checksums(out) } else { HashMap::new() };
    // A folder written before datasets carried checksums (no listing, no journal) keeps each
    // image that decodes whole at the dataset's size, as resuming did then, so that its work is
    // not redone; its checksums start here.
    let legacy = target.resume && !out.join(CHECKSUMS_FILE).exists() && !out.join(JOURNAL_FILE).exists();
    let size = plan.recipe.image_size;
    let kept: Vec<Option<String>> = range
        .clone()
        .into_par_iter()
        .map(|i| {
            let path = images.join(image_name(i));
            if legacy {
                return complete_image(&path, size).then(|| file_sha256(&path)).flatten();
            }
            let hex = recorded.get(&image_entry(&image_name(i)))?;
            (file_sha256(&path).as_ref() == Some(hex)).then(|| hex.clone())
        })
        .collect();
    let journal_lines: String = (range.clone().zip(&kept))
        .filter_map(|(i, hex)| Some(format!("{}  {}\n", hex.as_ref()?, image_entry(&image_name(i)))))
        .collect();
    write_atomic(&out.join(JOURNAL_FILE), journal_lines.as_bytes())?;
    match std::fs::remove_file(out.join(CHECKSUMS_FILE)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(SimError::io(out.join(CHECKSUMS_FILE), "remove", e));
        }
        _ => {}
    }
    let journal = Journal::open(out)?;
    let todo: Vec<usize> = range.clone().zip(&kept).filter(|(_, k)| k.is_none()).map(|(i, _)| i).collect();
    let rewritten = todo.iter().filter(|&&i| images.join(image_name(i)).exists()).count();
    let written_sha: Mutex<HashMap<usize, String>> = Mutex::new(HashMap::new());
    let skipped = range.len() - todo.len();
    let done = std::sync::atomic::AtomicUsize::new(skipped);
    progress(skipped);
    let nanos: [AtomicU64; 6] = Default::default(); // solve, render, encode, write, tap, slide
    let add = |k: usize, s: f64| nanos[k].fetch_add((s * 1e9) as u64, Ordering::Relaxed);
    let taps = std::sync::atomic::AtomicUsize::new(0);
    let written = todo.len();
    // Sample `i`'s PNG written and its times counted (s: its solve, render and encode; the
    // render a GPU batch's share).
    let record = |i: usize, s: &Sample, png: &[u8], [solve, render, encode]: [f64; 3]| -> Result<()> {
        let tw = Instant::now();
        write_atomic_unsynced(&images.join(image_name(i)), png)?;
        let hex = sha256_hex(png);
        journal.record(&image_entry(&image_name(i)), &hex)?;
        written_sha.lock().unwrap_or_else(|e| e.into_inner()).insert(i, hex);
        let write = tw.elapsed().as_secs_f64();
        add(0, solve);
        add(1, render);
        add(2, encode);
        add(3, write);
        if s.kind == Kind::Tap {
            add(4, solve + render + encode + write);
            taps.fetch_add(1, Ordering::Relaxed);
        } else {
            add(5, solve + render + encode + write);
        }
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        Ok(())
    };
    #[cfg(feature = "wgpu")]
    if let Some(gpu) = ctx.gpu {
        for chunk in todo.chunks(GPU_BATCH) {
            // Solved on the CPU threads; moved on the GPU where it has f64, else on the CPU.
            let solved: Vec<(Sample, Simulation<'_>, f64)> = chunk
                .par_iter()
                .map(|&i| {
                    let t = Instant::now();
                    let s = plan.sample(i);
                    let sim = sample_state(ctx, &s, known(i))?;
                    Ok((s, sim, t.elapsed().as_secs_f64()))
                })
                .collect::<Result<_>>()?;
            let t = Instant::now();
            let states: Vec<&Simulation<'_>> = solved.iter().map(|(_, sim, _)| sim).collect();
            let pins = if gpu.has_pins() {
                gpu.pins_batch(&states)?
            } else {
                states.par_iter().map(|sim| sim.pins()).collect()
            };
            let moved = t.elapsed().as_secs_f64() / chunk.len() as f64;
            let staged: Vec<(Sample, Vec<crate::pins::PinPose>, f64)> =
                solved.into_iter().zip(pins).map(|((s, _, solve), pins)| (s, pins, solve + moved)).collect();
            let t = Instant::now();
            let batch: Vec<_> = staged.iter().map(|(s, pins, _)| (pins.as_slice(), &s.variation)).collect();
            let drawn = ctx.renderer.render_batch(gpu, &batch)?;
            let render = t.elapsed().as_secs_f64() / chunk.len() as f64;
            chunk.par_iter().zip(&staged).zip(&drawn).try_for_each(|((&i, (s, _, solve)), img)| {
                let t = Instant::now();
                let png = encode_png(img, PngDepth::Grey8)?;
                record(i, s, &png, [*solve, render, t.elapsed().as_secs_f64()])
            })?;
        }
    }
    #[cfg(feature = "wgpu")]
    let todo = if ctx.gpu.is_some() { Vec::new() } else { todo };
    todo.par_iter().try_for_each(|&i| -> Result<()> {
        let s = plan.sample(i);
        let (png, times) = sample_png(ctx, &s, known(i))?;
        record(i, &s, &png, times)
    })?;
    // Every image is in place: the listing, in sample order, then no journal.
    let mut written_sha = written_sha.into_inner().unwrap_or_else(|e| e.into_inner());
    let mut entries = vec![
        ("meta.json".to_owned(), sha256_hex(&meta_bytes)),
        ("targets.csv".to_owned(), sha256_hex(&csv_bytes)),
        (image_entry(REFERENCE_IMAGE), sha256_hex(&reference_png)),
    ];
    for (i, hex) in range.clone().zip(kept) {
        let hex = hex.or_else(|| written_sha.remove(&i)).ok_or_else(|| SimError::Analysis {
            source_name: out.display().to_string(),
            reason: format!("image {i} was neither kept nor written (a bug: please report it)"),
        })?;
        entries.push((image_entry(&image_name(i)), hex));
    }
    write_checksums(out, &entries)?;
    journal.finish()?;
    let secs = |k: usize| nanos[k].load(Ordering::Relaxed) as f64 * 1e-9;
    let taps = taps.into_inner();
    Ok(Summary {
        written,
        skipped,
        rewritten,
        no_contact,
        taps,
        slides: written - taps,
        wall_s: wall.elapsed().as_secs_f64(),
        tap_s: secs(4),
        slide_s: secs(5),
        solve_s: secs(0),
        render_s: secs(1),
        encode_s: secs(2),
        write_s: secs(3),
    })
}

/// Joins complete shards of one dataset into `out` (new or empty): images copied, rows
/// concatenated in sample order, `meta.json` without the shard. The result equals the
/// unsharded run byte for byte, its `SHA256SUMS` included. Every shard is verified first
/// ([`tacsim_data::verify`]: each file against its listing, each image decodable 8-bit grey of
/// the dataset's size), before anything is written.
pub fn merge(out: &Path, shards: &[PathBuf]) -> Result<usize> {
    merge_with(out, shards, Images::Copy)
}

/// [`merge`] for shards that are not kept (`tacsim.ray`'s): each verified image is renamed into
/// `out` instead of copied (copied where a rename cannot cross filesystems), so the shards
/// lose their images. The same bytes as [`merge`]. Interrupted, it leaves shards without some
/// images: generating them again with `--resume` makes only those, and the merge then
/// finishes. What the copy costs a large recipe: `docs/guide/cluster.md`, "Measured".
pub fn merge_moving(out: &Path, shards: &[PathBuf]) -> Result<usize> {
    merge_with(out, shards, Images::Move)
}

/// How [`merge_with`] brings the shards' images into the dataset.
#[derive(Clone, Copy, PartialEq)]
enum Images {
    /// Read, checked against the listing once more and written (the shards stay whole).
    Copy,
    /// Renamed (the shards were verified just before).
    Move,
}

fn merge_with(out: &Path, shards: &[PathBuf], how: Images) -> Result<usize> {
    let bad = |reason: String| SimError::Analysis { source_name: "tacsim merge".into(), reason };
    let mut parts = Vec::new();
    for dir in shards {
        let ds = tacsim_data::Dataset::open(dir)?;
        let Some(shard) = ds.meta.shard else {
            return Err(bad(format!("{} is not a shard (its meta.json has no shard)", dir.display())));
        };
        parts.push((shard, ds));
    }
    if parts.is_empty() {
        return Err(bad("no shard directories given".into()));
    }
    shard_set(&parts).map_err(bad)?;
    parts.sort_by_key(|(s, _)| s.index);
    // Every shard's files are checked before anything is written: each image's bytes against
    // the shard's listing (a swapped or edited image is found), decodable, 8-bit grey, the
    // dataset's size (regression: a truncated or RGB image merged with exit 0 and broke
    // train, eval and sim2real later).
    let mut sums: HashMap<String, String> = HashMap::new();
    for (_, ds) in &parts {
        let verified = tacsim_data::verify(&ds.dir)?;
        if let Some(first) = verified.problems.first() {
            let more = verified.problems.len() - 1;
            let more = if more > 0 {
                format!(" (and {more} more; `tacsim verify {}` lists them)", ds.dir.display())
            } else {
                String::new()
            };
            return Err(bad(format!("shard {}: {first}{more}", ds.dir.display())));
        }
        sums.extend(read_checksums(&ds.dir)?);
    }
    // A folder that already holds this dataset is an interrupted merge: merging again finishes it.
    let target = Target { out: out.to_owned(), shard: None, resume: true };
    let meta = Meta { shard: None, ..parts[0].1.meta.clone() };
    prepare(&target, &meta)?;
    let images = out.join("images");
    let mut rows = Vec::new();
    for (_, ds) in &parts {
        for r in &ds.rows {
            let (from, to) = (ds.image_path(r), images.join(&r.sensor_image));
            if how == Images::Move && std::fs::rename(&from, &to).is_ok() {
                continue;
            }
            let bytes = std::fs::read(&from).map_err(|e| SimError::io(&from, "read", e))?;
            if Some(&sha256_hex(&bytes)) != sums.get(&image_entry(&r.sensor_image)) {
                return Err(bad(format!("{} changed while it was merged", from.display())));
            }
            write_atomic_unsynced(&to, &bytes)?;
        }
        rows.extend(ds.rows.iter().cloned());
    }
    if rows.len() != meta.samples {
        return Err(bad(format!("the shards hold {} samples, the dataset {}", rows.len(), meta.samples)));
    }
    let reference = parts[0].1.dir.join("images").join(&meta.reference_image);
    let bytes = std::fs::read(&reference).map_err(|e| SimError::io(&reference, "read", e))?;
    write_atomic(&images.join(&meta.reference_image), &bytes)?;
    let (meta_bytes, csv_bytes) = (meta.to_json()?, to_csv(&rows)?);
    write_atomic(&out.join("targets.csv"), &csv_bytes)?;
    write_atomic(&out.join("meta.json"), &meta_bytes)?;
    let mut entries = vec![
        ("meta.json".to_owned(), sha256_hex(&meta_bytes)),
        ("targets.csv".to_owned(), sha256_hex(&csv_bytes)),
        (image_entry(&meta.reference_image), sha256_hex(&bytes)),
    ];
    for r in &rows {
        let name = image_entry(&r.sensor_image);
        let hex = sums[&name].clone();
        entries.push((name, hex));
    }
    write_checksums(out, &entries)?;
    Ok(rows.len())
}

/// Checks that `parts` (at least one) are the shards of one dataset, each once and none
/// missing; the reason names the directories. Regression: a shard given twice (and so another
/// missing) was reported as the missing one "missing or given twice".
fn shard_set(parts: &[(tacsim_data::Shard, tacsim_data::Dataset)]) -> std::result::Result<(), String> {
    let (first, first_ds) = &parts[0];
    let count = first.count;
    for (s, ds) in parts {
        if s.index >= s.count {
            return Err(format!("{}: its meta.json names shard {} of {}", ds.dir.display(), s.index, s.count));
        }
        if !ds.meta.same_dataset(&first_ds.meta) || s.count != count {
            return Err(format!(
                "{} belongs to a different dataset or shard count than {}",
                ds.dir.display(),
                first_ds.dir.display()
            ));
        }
    }
    let mut holders: Vec<Vec<&Path>> = vec![Vec::new(); count];
    for (s, ds) in parts {
        holders[s.index].push(&ds.dir);
    }
    if let Some((i, dirs)) = holders.iter().enumerate().find(|(_, d)| d.len() > 1) {
        let dirs: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
        return Err(format!("shard {i} of {count} is given {} times: {}", dirs.len(), dirs.join(", ")));
    }
    let missing: Vec<String> =
        holders.iter().enumerate().filter(|(_, d)| d.is_empty()).map(|(i, _)| i.to_string()).collect();
    if !missing.is_empty() {
        return Err(format!(
            "shard{} {} of {count} missing: generate {} with `--shard i/{count}`",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            if missing.len() > 1 { "them" } else { "it" }
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::{Job, Recipe, base_sensor};

    /// A `meta.json` written before a defaulted field existed is the same dataset; one whose
    /// recipe differs in a value is not.
    #[test]
    fn a_field_added_at_its_default_names_the_same_dataset() {
        let (recipe, source) = Recipe::file_or_builtin("quick").expect("quick");
        let base = base_sensor(&recipe, None, None).expect("sensor");
        let job = Job::new(&recipe, &source, &base, &crate::builtin_catalogue().expect("shapes"), None).expect("job");
        let sensor = recipe_sensor(&job.plan, &base).expect("sensor");
        let now = meta(&job.plan, &sensor, None).expect("meta");
        let mut before = now.clone();
        let randomise = before.recipe["randomise"].as_object_mut().expect("randomise");
        assert!(randomise.remove("pin_jitter_px").is_some(), "a field at its default");
        assert_ne!(before, now);
        assert!(same_dataset(&before, &now) && same_dataset(&now, &now));
        let mut other = now.clone();
        other.recipe["seed"] = serde_json::json!(7);
        assert!(!same_dataset(&other, &now));
        let mut unreadable = before;
        unreadable.recipe["randomise"]["colour"] = serde_json::json!(1);
        assert!(!same_dataset(&unreadable, &now), "a field this build does not know");
    }
}

/// The GPU path against the CPU's on the `quick` recipe's samples (feature `wgpu`): the pins
/// of every state alike to 1e-9 mm, and the images alike but where a pixel's exact coverage
/// lies within a bound of 1/2: 1e-9 for the f64 raster (adapters with SHADER_F64), 1e-2 for
/// the f32 one (`gpu/raster.rs`). Regression: in f32, samples 81 and 225 (`image_81.png`,
/// `image_225.png` of `tacsim generate quick`) differed from the CPU's in one pixel each,
/// coverage 2.9e-5 and 2.1e-9 from 1/2 on lavapipe; on an NVIDIA H100 201 of 300 images did.
#[cfg(all(test, feature = "wgpu"))]
mod gpu_tests {
    use super::*;
    use crate::dataset::{Job, Recipe, base_sensor};
    use crate::raster::pixel_coverage;

    #[test]
    fn quick_samples_move_and_render_on_the_gpu_as_on_the_cpu() {
        let Some(gpu) = crate::gpu::for_tests() else { return };
        let (recipe, source) = Recipe::file_or_builtin("quick").expect("quick");
        let base = base_sensor(&recipe, None, None).expect("sensor");
        let job = Job::new(&recipe, &source, &base, &crate::builtin_catalogue().expect("shapes"), None).expect("job");
        let ctx = job.context();
        let samples: Vec<Sample> = (0..16).chain([80, 224]).map(|i| job.plan.sample(i)).collect();
        let states: Vec<Simulation<'_>> = samples.iter().map(|s| sample_state(&ctx, s, None).expect("solve")).collect();
        let refs: Vec<&Simulation<'_>> = states.iter().collect();
        let moved = if gpu.has_pins() { gpu.pins_batch(&refs).expect("GPU pins") } else { Vec::new() };
        let cpu_pins: Vec<_> = states.iter().map(Simulation::pins).collect();
        for (a, b) in cpu_pins.iter().zip(&moved) {
            for (p, q) in a.iter().zip(b) {
                assert!((p.tip - q.tip).norm() < 1e-9 && (p.axis - q.axis).norm() < 1e-9, "{p:?} vs {q:?}");
            }
        }
        let batch: Vec<_> = cpu_pins.iter().zip(&samples).map(|(p, s)| (p.as_slice(), &s.variation)).collect();
        let drawn = ctx.renderer.render_batch(&gpu, &batch).expect("GPU raster");
        let bound = if gpu.has_pins() { 1e-9 } else { 1e-2 };
        let mut differ = Vec::new();
        for ((pins, s), got) in cpu_pins.iter().zip(&samples).zip(&drawn) {
            let cpu = ctx.renderer.render_varied(pins, &s.variation);
            let discs = ctx.renderer.varied_discs(pins, &s.variation);
            for (k, (a, b)) in cpu.as_raw().iter().zip(got.as_raw()).enumerate() {
                if a == b {
                    continue;
                }
                let (x, y) = ((k % cpu.width() as usize) as u32, (k / cpu.width() as usize) as u32);
                let off = discs.iter().map(|d| (pixel_coverage(d, x, y) - 0.5).abs()).fold(f64::INFINITY, f64::min);
                assert!(
                    off < bound,
                    "sample {}: pixel ({x}, {y}) {a} on the CPU, {b} on the GPU, {off:.2e} off 1/2",
                    s.index
                );
                differ.push((s.index, x, y, off));
            }
        }
        println!("{} samples: pixels apart (sample, x, y, coverage off 1/2): {differ:?}", samples.len());
    }
}
