//! `tacsim`: physics-simulated TacTip data generator and test harness.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};
use tacsim::commands::{self, RenderOptions};
use tacsim::{bench, validation};

#[derive(Parser)]
#[command(name = "tacsim", version, about = "Physics-simulated TacTip data generator and test harness")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render the sensor to a PNG: undeformed, or tapped / slid onto a stimulus.
    Render(RenderOptions),
    /// Run the analytic contact cases (Hertz, Cattaneo-Mindlin) and print errors.
    Validate {
        /// Cells across the validation grid (odd, 5 to 257).
        #[arg(long, default_value_t = tacsim_sim::contact::validate::DEFAULT_CELLS, value_parser = tacsim::flags::validate_grid)]
        grid: usize,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
        /// Also run the grid-refinement study (17, 33, 65, 129 cells) with measured orders.
        #[arg(long)]
        convergence: bool,
    },
    /// Benchmark taps and slides on all cores, and run time against error.
    Bench(tacsim::bench::BenchOptions),
    /// Generate a dataset from a recipe (default: the built-in `quick`): images, targets.csv,
    /// meta.json. Deterministic for a seed, whatever the threads or shards.
    Generate(tacsim::dataset::GenerateOptions),
    /// Join the shards of one dataset into a directory equal to the unsharded run.
    Merge {
        /// Output directory (new or empty).
        #[arg(long)]
        out: PathBuf,
        /// The shard directories.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
    },
    /// Check a dataset on its own: every file against its SHA256SUMS (a swapped, edited or
    /// truncated image, an edited targets.csv), every image readable at the dataset's size.
    /// Exits non-zero, listing each problem, where one is found.
    Verify {
        /// The dataset directory (`tacsim generate --out` or `tacsim merge --out`).
        dir: PathBuf,
    },
    /// Run closed-loop exploration scenarios (in parallel): a table, a JSON report and a plot
    /// per run; exits non-zero when any criterion fails.
    Run {
        /// Scenario TOML files (`scenarios/explore/*.toml`).
        #[arg(required = true)]
        scenarios: Vec<PathBuf>,
        /// Directory for `report.json` and one SVG plot per run.
        #[arg(long, default_value = "explore-report")]
        out: PathBuf,
        /// Print the JSON report instead of the table.
        #[arg(long)]
        json: bool,
        /// Directory holding the runs of learned perception (for example `target/explore/runs`
        /// of `cargo xtask explore`): each scenario's `[models]` runs are looked up there by
        /// their directory names (`posenet`, `unshear`, `baseline`).
        #[arg(long)]
        models: Option<PathBuf>,
        /// The sensor (default: tactip-331-calibrated, the built-in calibrated TacTip over a
        /// half-space: the scenarios slide along sharp edges, where the dome's pins need 49
        /// contact cells, and the learned runs' networks are trained on the `explore` recipe's
        /// half-space images). The learned runs' networks must have been trained on images of
        /// the same sensor.
        #[command(flatten)]
        sensor: commands::SensorArgs,
    },
    /// Train a network of the paper on a dataset (`tacsim generate` output): the shear-removal
    /// model, the supervised baseline or the pose network. Resumable; Ctrl-C saves a
    /// checkpoint.
    Train(tacsim::learn::TrainOptions),
    /// Evaluate trained runs on a dataset's test split: the paper's tables beside its numbers,
    /// as report.md, report.json and grid.png.
    Eval {
        /// Dataset directory or lab recording folder.
        #[arg(long)]
        data: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// At most this many test pairs (0: all).
        #[arg(long, default_value_t = 0)]
        max_pairs: usize,
        /// Backend.
        #[arg(long, default_value = "flex")]
        backend: tacsim_model::Backend,
        #[command(flatten)]
        lab: tacsim::learn::LabOptions,
        /// Run directories of `tacsim train` (shear-removal models and one pose network).
        #[arg(required = true)]
        runs: Vec<PathBuf>,
    },
    /// Fit the simulator to a lab's recordings (`targets.csv` + `images/`): of a flat surface
    /// (as in the lab's `surface_3d` folders) the label frame, the elastic model and its
    /// parameters on 80% of the recordings; of taps on an edge (--edge) the label map and the
    /// edge's and skin's candidates. Writes a sensor preset and a report on the held-out 20%
    /// (report.md, report.json, grid.png).
    Calibrate(tacsim::calibrate::CalibrateOptions),
    /// Sim-to-real benchmark on a lab's recordings: generates the recipe's simulated set,
    /// trains the pose network on it only and, beside it, on the lab folder's fitting part
    /// (80%); fits the label map on the fitting part; reports both on the held-out 20%
    /// (report.md, report.json, grid.png). Resumable: rerun the same command.
    Sim2real(tacsim::sim2real::Sim2RealOptions),
    /// List the stimuli with size, material and friction.
    Shapes {
        /// Catalogue directory (default: the built-in shapes).
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

/// The command line as typed, for reports.
fn command_line() -> String {
    std::iter::once("tacsim".to_owned())
        .chain(std::env::args().skip(1))
        .map(|a| if a.contains(' ') { format!("'{a}'") } else { a })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs the command; a failed check (`validate`, `run`) exits with status 1 after its report.
fn main() -> Result<ExitCode> {
    match Cli::parse().command {
        Command::Render(o) => {
            println!("{}", commands::render(&o)?);
        }
        Command::Validate { grid, json, convergence } => {
            let (text, pass) = validation::run(grid, json, convergence)?;
            print!("{text}");
            return Ok(exit_code(pass));
        }
        Command::Bench(o) => {
            print!("{}", bench::run(&o)?);
        }
        Command::Generate(opts) => {
            print!("{}", tacsim::dataset::generate(&opts)?);
        }
        Command::Merge { out, shards } => {
            print!("{}", tacsim::dataset::merge(&out, &shards)?);
        }
        Command::Verify { dir } => {
            print!("{}", tacsim::dataset::verify(&dir)?);
        }
        Command::Run { scenarios, out, json, models, sensor } => {
            let sensor = sensor.load_or(tacsim_sim::SensorParams::half_space)?;
            let (text, pass) = tacsim::explore::report::run_files(&scenarios, &out, json, models.as_deref(), &sensor)?;
            print!("{text}");
            return Ok(exit_code(pass));
        }
        Command::Train(opts) => {
            print!("{}", tacsim::learn::train(&opts)?);
        }
        Command::Eval { data, out, max_pairs, backend, lab, runs } => {
            print!("{}", tacsim::learn::evaluate(&data, &runs, &out, max_pairs, backend, lab)?);
        }
        Command::Calibrate(o) => {
            print!("{}", tacsim::calibrate::calibrate(&o, &command_line())?);
        }
        Command::Sim2real(o) => {
            print!("{}", tacsim::sim2real::sim2real(&o, &command_line())?);
        }
        Command::Shapes { dir } => {
            print!("{}", commands::shapes_table(&commands::load_catalogue(dir.as_deref())?));
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Status 0 when every check passed, else 1.
fn exit_code(pass: bool) -> ExitCode {
    if pass { ExitCode::SUCCESS } else { ExitCode::FAILURE }
}
