//! `tacsim`: physics-simulated TacTip data generator and test harness.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Parser, Subcommand};
use tacsim::commands::{self, RenderMode, RenderOptions};

#[derive(Parser)]
#[command(name = "tacsim", version, about = "Physics-simulated TacTip data generator and test harness")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render the undeformed sensor to a PNG.
    Render {
        /// Sensor TOML (default: the built-in TacTip calibrated to the lab's images).
        #[arg(long)]
        sensor: Option<PathBuf>,
        /// Image size in px (default: the sensor's camera.image_size, 256).
        #[arg(long)]
        size: Option<u32>,
        /// Pin count, centred hexagonal (331 default, 127, ...).
        #[arg(long)]
        pins: Option<usize>,
        /// Grey rendering with blur and noise, then the lab's adaptive threshold and mask.
        #[arg(long, conflicts_with = "grey")]
        realism: bool,
        /// Write the raw grey frame (blur and noise, no threshold).
        #[arg(long)]
        grey: bool,
        /// Noise seed for --realism / --grey.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Write a 1-bit PNG (binary images only).
        #[arg(long)]
        one_bit: bool,
        /// Output PNG.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// List the stimuli with size, material and friction.
    Shapes {
        /// Catalogue directory (default: the built-in shapes).
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Render { sensor, size, pins, realism, grey, seed, one_bit, output } => {
            let mode = if realism {
                RenderMode::Realistic
            } else if grey {
                RenderMode::Grey
            } else {
                RenderMode::Binary
            };
            let line = commands::render(&RenderOptions { sensor, size, pins, mode, seed, one_bit, output })?;
            println!("{line}");
        }
        Command::Shapes { dir } => {
            print!("{}", commands::shapes_table(&commands::load_catalogue(dir.as_deref())?));
        }
    }
    Ok(())
}
