//! How long a dome's cached response takes to load: reads the file `PATH` (a
//! `tacsim-pins-KEY.bin` in the cache folder, `TACSIM_CACHE_DIR`, default
//! `~/.cache/tacsim`) `REPEATS` times and prints each read's time.
//!
//! `cargo run --release -p tacsim-fem --example dome_load -- PATH [REPEATS]` (default 3).

use std::time::Instant;

use tacsim_fem::PinResponse;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = std::path::PathBuf::from(args.first().ok_or("argument 1: the cache file to read")?);
    let repeats: usize = args.get(1).map_or(Ok(3), |s| s.parse())?;
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    let key = stem
        .strip_prefix("tacsim-pins-")
        .and_then(|k| u64::from_str_radix(k, 16).ok())
        .ok_or_else(|| format!("`{}` is not named tacsim-pins-KEY.bin", path.display()))?;
    for _ in 0..repeats {
        let clock = Instant::now();
        let response = PinResponse::load(&path, key)?;
        println!(
            "{:.3} s: {} nodes, {} pins, {} MB of table",
            clock.elapsed().as_secs_f64(),
            response.nodes.len(),
            response.pins,
            response.table.len() * 4 / 1_000_000
        );
    }
    Ok(())
}
