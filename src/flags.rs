//! Bounds of the command line's numbers, checked by clap as it parses (before any work), so
//! that an absurd value gets an error naming the flag, the value and the accepted range.
//! Regressions (issue 88): `validate --grid 100001` aborted on a 1.9 TB allocation, `bench
//! --samples 18446744073709551615` panicked, and `validate --grid 1001` and `generate
//! --threads 100000` ran past a minute with nothing written.

/// Largest `validate --grid` (cells across): the grid-refinement study's finest is 129.
pub const MAX_VALIDATE_GRID: usize = 257;
/// Largest `bench --samples`.
pub const MAX_BENCH_SAMPLES: usize = 100_000;
/// Worker threads allowed per core of this machine (`generate --threads`).
pub const THREADS_PER_CORE: usize = 4;

fn whole(text: &str) -> Result<usize, String> {
    text.trim().parse::<usize>().map_err(|_| format!("expected a whole number, got `{text}`"))
}

/// `text` as a whole number in `[lo, hi]`; either error names the range.
fn whole_in(text: &str, lo: usize, hi: usize) -> Result<usize, String> {
    match whole(text) {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        Ok(n) => Err(format!("must be in [{lo}, {hi}], got {n}")),
        Err(e) => Err(format!("{e} (accepted: [{lo}, {hi}])")),
    }
}

/// `text` as a number; where it is not one, the error names `accepted`, the flag's range.
fn number(text: &str, accepted: &str) -> Result<f64, String> {
    text.trim().parse::<f64>().map_err(|_| format!("not a number: {text:?} (accepted: {accepted})"))
}

/// `validate --grid`: odd, in [5, [`MAX_VALIDATE_GRID`]].
pub fn validate_grid(text: &str) -> Result<usize, String> {
    let n = whole(text)?;
    if !(5..=MAX_VALIDATE_GRID).contains(&n) || n % 2 == 0 {
        return Err(format!("must be odd and in [5, {MAX_VALIDATE_GRID}] cells, got {n}"));
    }
    Ok(n)
}

/// `bench --samples`: in [[`tacsim_sim::bench::MIN_SAMPLES`], [`MAX_BENCH_SAMPLES`]].
pub fn bench_samples(text: &str) -> Result<usize, String> {
    whole_in(text, tacsim_sim::bench::MIN_SAMPLES, MAX_BENCH_SAMPLES)
}

/// `sim2real --finetune-min-steps`: in [1, 100,000].
pub fn finetune_min_steps(text: &str) -> Result<usize, String> {
    whole_in(text, 1, 100_000)
}

/// `--finetune-lr-scale`: a factor in (0, 1].
pub fn finetune_lr_scale(text: &str) -> Result<f64, String> {
    let v = number(text, "(0, 1]")?;
    if !(v > 0.0 && v <= 1.0) {
        return Err(format!("must be in (0, 1], got {v}"));
    }
    Ok(v)
}

/// `text` as a number in the closed range `[lo, hi]`; the error names the range.
fn closed(text: &str, lo: f64, hi: f64) -> Result<f64, String> {
    let v = number(text, &format!("[{lo}, {hi}]"))?;
    if !(lo..=hi).contains(&v) {
        return Err(format!("must be in [{lo}, {hi}], got {v}"));
    }
    Ok(v)
}

/// `--finetune-sim-share`: a share in [0, `tacsim_model::FINETUNE_MAX_SIM_SHARE`].
pub fn finetune_sim_share(text: &str) -> Result<f64, String> {
    closed(text, 0.0, tacsim_model::FINETUNE_MAX_SIM_SHARE)
}

/// `sim2real --motion-field`: a fraction of the image's half-side in
/// [[`tacsim_sim::MIN_MOTION_FIELD`], 1].
pub fn motion_field(text: &str) -> Result<f64, String> {
    closed(text, tacsim_sim::MIN_MOTION_FIELD, 1.0)
}

/// `--turns`: a whole number in [1, `tacsim_model::MAX_TURNS`].
pub fn turns(text: &str) -> Result<usize, String> {
    whole_in(text, 1, tacsim_model::MAX_TURNS)
}

/// The most worker threads: [`THREADS_PER_CORE`] per core of this machine.
pub fn max_threads() -> usize {
    THREADS_PER_CORE * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `--threads`: in [1, [`max_threads`]].
pub fn threads(text: &str) -> Result<usize, String> {
    let n = whole(text)?;
    let max = max_threads();
    if !(1..=max).contains(&n) {
        return Err(format!("must be in [1, {max}] ({THREADS_PER_CORE} per core of this machine), got {n}"));
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_numbers_are_refused_with_their_range() {
        for (parse, text, range) in [
            (validate_grid as fn(&str) -> Result<usize, String>, "100001", "[5, 257]"),
            (validate_grid, "1001", "[5, 257]"),
            (validate_grid, "16", "odd"),
            (validate_grid, "-3", "whole number"),
            (bench_samples, "18446744073709551615", "[4, 100000]"),
            (bench_samples, "18446744073709551616", "whole number"),
            (bench_samples, "0", "[4, 100000]"),
            (threads, "100000", "per core"),
            (threads, "0", "per core"),
        ] {
            let e = parse(text).expect_err(text);
            assert!(e.contains(text) && e.contains(range), "{text}: {e}");
        }
        assert_eq!(validate_grid("33"), Ok(33));
        assert_eq!(bench_samples("200"), Ok(200));
        assert_eq!(threads("1"), Ok(1));
    }
}
