//! `tacsim bench`: its flags, the sensor they make, and the output (a table or JSON, and the
//! run-time-vs-error plot as SVG); the measuring is `tacsim_sim::bench`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use plotters::prelude::*;
use tacsim_sim::SensorParams;
use tacsim_sim::bench::{BenchReport, CurvePoint};

/// `tacsim bench`'s flags.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchOptions {
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Taps and slides to time (4 to 100,000).
    #[arg(long, default_value_t = 200, value_parser = crate::flags::bench_samples)]
    pub samples: usize,
    /// Write the run-time-vs-error plot (SVG) here.
    #[arg(long, default_value = "bench.svg")]
    pub plot: PathBuf,
    /// Cells across the contact footprint for the throughput figures (odd; default: the
    /// sensor's, 25).
    #[arg(long)]
    pub cells: Option<usize>,
    /// The sensor timed (default: the half-space preset tactip-331-calibrated, the built-in
    /// recipes' body; `--skin dome` alone: the default sensor's fitted dome).
    #[command(flatten)]
    pub sensor: crate::commands::SensorArgs,
    /// Sub-cells per side of the cells along a sharp edge (the sensor's `skin.edge_subcells`,
    /// 0 to 6; default 3), for the throughput figures and every grid's row; the 65-cell
    /// reference keeps the default.
    #[arg(long)]
    pub edge_subcells: Option<usize>,
    /// Also time the batched GPU raster and pin product against the CPU's: gpu (a build
    /// with `--features wgpu` and a GPU adapter; a software one's figures say nothing of a
    /// GPU's speed) or auto.
    #[arg(long, value_enum, default_value = "cpu")]
    pub device: crate::device::DeviceChoice,
    /// Every cell wholly in or out of contact by the gap at its centre, the reference
    /// grid's included (the sensor's `skin.cut_edges = false`; by default cells a sharp
    /// edge cuts carry their load on the covered part, `docs/experiments/contact.md`, "Cut cells").
    #[arg(long)]
    pub no_edge_cuts: bool,
}

/// Runs the benchmark; returns the text to print.
pub fn run(o: &BenchOptions) -> Result<String> {
    let (samples_n, json, plot) = (o.samples, o.json, o.plot.as_path());
    let _made = crate::commands::ensure_file_writable(plot)?;
    #[cfg(feature = "wgpu")]
    let gpu = crate::device::gpu(o.device)?;
    #[cfg(not(feature = "wgpu"))]
    crate::device::check(o.device)?;
    let sensor = bench_sensor(o)?;
    #[cfg(feature = "wgpu")]
    let report = tacsim_sim::bench::measure(&sensor, samples_n, gpu.as_ref())?;
    #[cfg(not(feature = "wgpu"))]
    let report = tacsim_sim::bench::measure(&sensor, samples_n)?;
    draw(&report, plot).with_context(|| format!("writing the plot {}", plot.display()))?;
    Ok(if json { serde_json::to_string_pretty(&report)? + "\n" } else { report.table(plot) })
}

/// The sensor of `--sensor`, `--pins` and `--skin` (the half-space preset where none is
/// named, as the built-in recipes run it) with the bench's `--cells`, `--edge-subcells` and
/// cut cells at edges unless `--no-edge-cuts`.
fn bench_sensor(o: &BenchOptions) -> Result<SensorParams> {
    let mut sensor = o.sensor.load_or(SensorParams::half_space)?;
    sensor.skin.cut_edges = !o.no_edge_cuts;
    if let Some(n) = o.cells {
        sensor.skin.cells_across = n;
        sensor.validate("--cells")?;
    }
    if let Some(r) = o.edge_subcells {
        sensor.skin.edge_subcells = r;
        sensor.validate("--edge-subcells")?;
    }
    Ok(sensor)
}

/// Draws the plot into a string, then writes it atomically.
fn draw(report: &BenchReport, path: &Path) -> Result<()> {
    let mut svg = String::new();
    draw_into(report, &mut svg)?;
    tacsim_data::write_atomic(path, svg.as_bytes())?;
    Ok(())
}

fn draw_into(report: &BenchReport, svg: &mut String) -> Result<()> {
    let root = SVGBackend::with_string(svg, (1000, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(500);
    let series = |knob: &str, pick: fn(&CurvePoint) -> Option<f64>| -> Vec<(f64, f64)> {
        report
            .curve
            .iter()
            .filter(|p| p.knob == knob)
            .filter_map(|p| pick(p).map(|e| (p.ms_per_sample, e.max(1e-9))))
            .collect()
    };
    for (area, title, lines) in [
        (
            &left,
            "grid: tap time vs error",
            vec![
                ("Hertz force", series("grid", |p| p.hertz_force_rel_err), BLUE),
                ("Cattaneo shift (nu=0)", series("grid", |p| p.cattaneo_shift_rel_err), RED),
                ("pin error (mm)", series("grid", |p| p.pin_err_mm), GREEN),
                ("pin error on an edge (mm)", series("grid", |p| p.edge_pin_err_mm), MAGENTA),
            ],
        ),
        (
            &right,
            "slide step: slide time vs pin error (mm)",
            vec![("pin error", series("step", |p| p.pin_err_mm), GREEN)],
        ),
    ] {
        let all: Vec<(f64, f64)> = lines.iter().flat_map(|l| l.1.iter().copied()).collect();
        if all.is_empty() {
            continue;
        }
        let (x0, x1) = all.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
        let (y0, y1) = all.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), (y0 * 0.5..y1 * 2.0).log_scale())?;
        chart.configure_mesh().x_desc("ms per sample (one thread)").y_desc("error").draw()?;
        for (name, pts, color) in lines {
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}
