//! Run reports: a table, one JSON object for all runs, and a plot per run (trajectory over
//! the shape with the start marked; reconstruction beside the truth).

use std::path::Path;

use anyhow::Context as _;
use anyhow::Result;
use plotters::prelude::*;
use serde::Serialize;

use tacsim_explore::{RunReport, Scenario};

/// All runs of one `tacsim run`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Whether every run passed.
    pub pass: bool,
    /// The runs, in the order given.
    pub runs: Vec<RunReport>,
}

/// The plot file of each scenario (`names[i]` from `files[i]`): `NAME.svg` with every character
/// outside `[A-Za-z0-9._-]` replaced by `_`, so a name cannot leave the report directory; a
/// name shared by several scenarios takes its file's folder as a prefix (`FOLDER-NAME.svg`),
/// and the run's position where that is shared too (`FOLDER-NAME-3.svg`).
pub fn plot_names(files: &[std::path::PathBuf], names: &[&str]) -> Vec<String> {
    let clean = |s: &str| -> String {
        s.chars().map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' }).collect()
    };
    let count = |v: &[String], x: &String| v.iter().filter(|y| *y == x).count();
    let base: Vec<String> = names.iter().map(|n| clean(n)).collect();
    let folder = |i: usize| {
        let dir = files[i].parent().and_then(|d| d.file_name()).map(|d| d.to_string_lossy().into_owned());
        clean(&dir.unwrap_or_default())
    };
    let prefixed: Vec<String> = (0..base.len())
        .map(|i| if count(&base, &base[i]) > 1 { format!("{}-{}", folder(i), base[i]) } else { base[i].clone() })
        .collect();
    (0..prefixed.len())
        .map(|i| {
            if count(&prefixed, &prefixed[i]) > 1 {
                format!("{}-{}.svg", prefixed[i], i + 1)
            } else {
                format!("{}.svg", prefixed[i])
            }
        })
        .collect()
}

/// `tacsim run`: loads every scenario first (a bad file stops before any run), runs them in
/// parallel, writes `out/report.json` and `out/NAME.svg`; returns the text to print and
/// whether every run passed. `sensor` is used by the scenarios that name none. `models`, when
/// given, is the directory the scenarios' `[models]` runs are looked up in, by their directory
/// names ([`tacsim_explore::Models::under`]).
pub fn run_files(
    files: &[std::path::PathBuf],
    out: &Path,
    json: bool,
    models: Option<&Path>,
    sensor: &tacsim_sim::SensorParams,
) -> Result<(String, bool)> {
    use rayon::prelude::*;
    let mut scenarios = files.iter().map(|f| Scenario::load(f)).collect::<Result<Vec<_>, _>>()?;
    if let Some(dir) = models {
        for s in &mut scenarios {
            s.models = s.models.under(dir);
        }
    }
    let catalogue = crate::commands::load_catalogue(None)?;
    // Each scenario's own sensor, loaded before any run (a bad file stops them all).
    let sensors = scenarios.iter().map(|s| s.sensor_or(sensor)).collect::<Result<Vec<_>, _>>()?;
    // The report directory, checked writable before any run.
    let _made = crate::commands::ensure_writable(out).context("the report directory (--out)")?;
    let plots = plot_names(files, &scenarios.iter().map(|s| s.name.as_str()).collect::<Vec<_>>());
    let mut runs = scenarios
        .par_iter()
        .zip(&sensors)
        .map(|(s, sensor)| tacsim_explore::run(s, sensor, &catalogue, Some(&super::learned::Networks)))
        .collect::<Result<Vec<_>, _>>()?;
    for (r, name) in runs.iter_mut().zip(plots) {
        plot(r, &out.join(&name))?;
        r.plot = name;
    }
    let summary = Summary { pass: runs.iter().all(|r| r.pass), runs };
    let text = serde_json::to_string_pretty(&summary)? + "\n";
    tacsim_data::write_atomic(&out.join("report.json"), text.as_bytes())?;
    let shown =
        if json { text } else { table(&summary.runs) + &format!("report: {}\n", out.join("report.json").display()) };
    Ok((shown, summary.pass))
}

/// The table printed by `tacsim run`.
pub fn table(runs: &[RunReport]) -> String {
    let mut out = format!(
        "{:<22} {:<10} {:>5} {:>6} {:>9} {:>9} {:>8} {:>7} {:>9} {:>15} {:>8}  result\n",
        "scenario",
        "shape",
        "steps",
        "done",
        "mean mm",
        "max mm",
        "yaw deg",
        "IoU eng",
        "IoU pins",
        "read err mm/deg",
        "steps/s"
    );
    for r in runs {
        out += &format!(
            "{:<22} {:<10} {:>5} {:>6.3} {:>9.3} {:>9.3} {:>8.2} {:>7.3} {:>9} {:>15} {:>8.0}  {}\n",
            r.name,
            r.shape,
            r.steps,
            r.completion,
            r.mean_deviation_mm,
            r.max_deviation_mm,
            r.mean_yaw_error_deg,
            r.iou,
            r.iou_pins.map_or("-".to_string(), |v| format!("{v:.3}")),
            r.perception_error
                .as_ref()
                .map_or("-".to_string(), |e| format!("{:.2}/{:.1}", e.offset_mae_mm, e.angle_mae_deg)),
            r.steps_per_s,
            if r.pass { "pass".to_string() } else { format!("FAIL: {}", r.failures.join("; ")) }
        );
    }
    out
}

/// Writes the plot of a run as SVG: the trajectory over the shape, the reconstruction from
/// the contact engine's patches beside the truth, and (image-based perception) the one from
/// the pins' patches.
pub fn plot(r: &RunReport, path: &Path) -> Result<()> {
    let mut svg = String::new();
    {
        let panels = 2 + usize::from(r.footprint_pins.is_some());
        let root = SVGBackend::with_string(&mut svg, (500 * panels as u32, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, panels));
        let b = r.footprint.3;
        let side = (b[2] - b[0]).max(b[3] - b[1]);
        let (x0, y0) = (0.5 * (b[0] + b[2] - side), 0.5 * (b[1] + b[3] - side));
        let outline: Vec<(f64, f64)> = r.contour.iter().chain(r.contour.first()).map(|p| (p[0], p[1])).collect();
        let (_, nx, _, bounds) = &r.footprint;
        let rasters = [None, Some((&r.footprint.0, "engine")), r.footprint_pins.as_ref().map(|f| (f, "pins"))];
        for (k, area) in areas.iter().enumerate() {
            let title = match rasters[k] {
                None => format!("{}: trajectory", r.name),
                Some((_, from)) => format!("reconstruction from the {from} (grey) vs truth"),
            };
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(40)
                .build_cartesian_2d(x0..x0 + side, y0..y0 + side)?;
            chart.configure_mesh().x_desc("x (mm)").y_desc("y (mm)").draw()?;
            if let Some((fp, _)) = rasters[k] {
                // Every fourth raster cell (2 mm) keeps the file small.
                let cell = (bounds[2] - bounds[0]) / *nx as f64;
                let rects = fp.iter().enumerate().filter(|(k, f)| **f && (k % nx) % 4 == 0 && (k / nx) % 4 == 0).map(
                    |(k, _)| {
                        let (i, j) = ((k % nx) as f64, (k / nx) as f64);
                        let (x, y) = (bounds[0] + i * cell, bounds[1] + j * cell);
                        Rectangle::new([(x, y), (x + 4.0 * cell, y + 4.0 * cell)], RGBColor(190, 190, 190).filled())
                    },
                );
                chart.draw_series(rects)?;
            }
            chart.draw_series(LineSeries::new(outline.clone(), BLACK.stroke_width(2)))?;
            if rasters[k].is_none() {
                chart.draw_series(LineSeries::new(r.trajectory.iter().map(|p| (p[0], p[1])), BLUE.stroke_width(1)))?;
                if let Some(s) = r.trajectory.first() {
                    chart.draw_series(std::iter::once(Circle::new((s[0], s[1]), 6, RED.filled())))?;
                }
            }
        }
        root.present()?;
    }
    tacsim_data::write_atomic(path, svg.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::plot_names;

    #[test]
    fn two_scenarios_with_one_name_overwrote_each_others_plot() {
        let files: Vec<PathBuf> = ["a/disk.toml", "b/disk.toml", "c/x.toml", "a/z/disk.toml", "a/q/disk.toml"]
            .iter()
            .map(PathBuf::from)
            .collect();
        let names = plot_names(&files, &["disk", "disk", "../../etc/x", "disk", "disk"]);
        assert_eq!(names, ["a-disk.svg", "b-disk.svg", ".._.._etc_x.svg", "z-disk.svg", "q-disk.svg"]);
        let same = plot_names(&[PathBuf::from("a/d.toml"), PathBuf::from("a/d.toml")], &["d", "d"]);
        assert_eq!(same, ["a-d-1.svg", "a-d-2.svg"]);
    }
}
