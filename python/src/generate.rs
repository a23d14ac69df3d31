//! `generate`: a dataset from a recipe, as `tacsim generate` writes it.

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use tacsim_sim::dataset::Recipe;
use tacsim_sim::dataset::{self, Job};

use crate::sim_err;

/// Generates the dataset of `recipe` (a file or a built-in name: paper, quick, edge-2d, ...)
/// into `out`, as `tacsim generate` does (same bytes for the same seed, whatever `threads`).
/// `progress(done, total)` is called as images are written (from worker threads, at most
/// about 100 times; an exception it raises is re-raised at the end). Returns the summary:
/// images, written, skipped (already there with `resume`), rewritten (there but not as recorded,
/// written again), no_contact, wall_s. `shard = (i, n)` generates shard `i` of `n` (from 0) as
/// `tacsim generate --shard i/n` does; [`merge`] joins the shards.
#[pyfunction]
#[pyo3(signature = (
    recipe, out, sensor = None, seed = None, size = None, cells = None, threads = None, resume = false,
    force = false, progress = None, shard = None
))]
#[allow(clippy::too_many_arguments)]
pub fn generate<'py>(
    py: Python<'py>,
    recipe: &str,
    out: &str,
    sensor: Option<&str>,
    seed: Option<u64>,
    size: Option<u32>,
    cells: Option<usize>,
    threads: Option<usize>,
    resume: bool,
    force: bool,
    progress: Option<Py<PyAny>>,
    shard: Option<(usize, usize)>,
) -> PyResult<Bound<'py, PyDict>> {
    if threads.is_some_and(|n| !(1..=1024).contains(&n)) {
        return Err(PyValueError::new_err(format!("threads must be in [1, 1024], got {threads:?}")));
    }
    let job = job_of(recipe, sensor, (seed, size, cells), force, shard)?;
    let total = job.images();
    let step = total.div_ceil(100).max(1);
    let reported = AtomicUsize::new(0);
    let failed: Mutex<Option<PyErr>> = Mutex::new(None);
    let report = |done: usize| {
        let Some(cb) = &progress else { return };
        let last = reported.load(Ordering::Relaxed);
        if (done < last + step && done < total)
            || reported.compare_exchange(last, done, Ordering::Relaxed, Ordering::Relaxed).is_err()
        {
            return;
        }
        Python::attach(|py| {
            if let Err(e) = cb.call1(py, (done, total))
                && let Ok(mut slot) = failed.lock()
            {
                slot.get_or_insert(e);
            }
        });
    };
    let summary = py
        .detach(|| {
            let run = || job.run(Path::new(out), resume, &report);
            match threads {
                Some(n) => rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| tacsim_sim::SimError::invalid("generate", "threads", e.to_string()))
                    .and_then(|pool| pool.install(run)),
                None => run(),
            }
        })
        .map_err(sim_err)?;
    if let Some(e) = failed.into_inner().ok().flatten() {
        return Err(e);
    }
    let d = PyDict::new(py);
    d.set_item("images", total)?;
    d.set_item("written", summary.written)?;
    d.set_item("skipped", summary.skipped)?;
    d.set_item("rewritten", summary.rewritten)?;
    d.set_item("no_contact", summary.no_contact)?;
    d.set_item("wall_s", summary.wall_s)?;
    Ok(d)
}

/// Joins the shards of one recipe (folders written by `generate(..., shard=(i, n))`, every
/// `i` of `n` once) into `out`, as `tacsim merge` does: each shard is checked against its
/// SHA256SUMS first, and the result has the bytes of the unsharded run. With `move`, each
/// checked image is renamed into `out` instead of copied: the shards lose their images (for
/// shards that are removed next). Returns the images merged.
#[pyfunction]
#[pyo3(signature = (out, shards, r#move = false))]
pub fn merge(py: Python<'_>, out: &str, shards: Vec<String>, r#move: bool) -> PyResult<usize> {
    let shards: Vec<std::path::PathBuf> = shards.iter().map(std::path::PathBuf::from).collect();
    let out = Path::new(out);
    py.detach(|| if r#move { dataset::merge_moving(out, &shards) } else { dataset::merge(out, &shards) })
        .map_err(sim_err)
}

/// The images `generate` would make for these arguments (a shard's with `shard`), with every
/// check it makes before writing (the recipe, the sensor, the size limits without `force`),
/// nothing simulated or written: what a driver checks before it hands shards out.
#[pyfunction]
#[pyo3(signature = (recipe, sensor = None, seed = None, size = None, cells = None, force = false, shard = None))]
pub fn plan(
    recipe: &str,
    sensor: Option<&str>,
    seed: Option<u64>,
    size: Option<u32>,
    cells: Option<usize>,
    force: bool,
    shard: Option<(usize, usize)>,
) -> PyResult<usize> {
    Ok(job_of(recipe, sensor, (seed, size, cells), force, shard)?.images())
}

/// The job of `recipe` with the overrides `(seed, size, cells)`, checked as `tacsim generate`
/// checks it before writing (the size limits unless `force`).
fn job_of(
    recipe: &str,
    sensor: Option<&str>,
    (seed, size, cells): (Option<u64>, Option<u32>, Option<usize>),
    force: bool,
    shard: Option<(usize, usize)>,
) -> PyResult<Job> {
    if let Some((i, n)) = shard
        && i >= n
    {
        return Err(PyValueError::new_err(format!("shard ({i}, {n}): need 0 <= i < n")));
    }
    let (r, source) = Recipe::file_or_builtin(recipe).map_err(sim_err)?;
    let r = r.with_overrides(seed, size, cells);
    let base = dataset::base_sensor(&r, Some(Path::new(recipe)), sensor).map_err(sim_err)?;
    let catalogue = tacsim_sim::builtin_catalogue().map_err(sim_err)?;
    let job = Job::new(&r, &source, &base, &catalogue, shard).map_err(sim_err)?;
    job.estimate().map_err(sim_err)?.check(&source, force).map_err(sim_err)?;
    Ok(job)
}
