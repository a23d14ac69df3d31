//! `tacsim sim2real --finetune`: the fine-tuning curve after the zero-shot run
//! (`tacsim_model::FinetuneCurve` trains and scores each point), its report
//! (`finetune.md`, `finetune.json`) and its plot (`finetune.svg`, error against K per label).

use std::path::Path;

use anyhow::Result;
use plotters::prelude::*;
use serde::Serialize;
use tacsim_model::{CurvePoint, FinetuneCurve, LabelCurve, MATCH_FACTOR, summarise_finetune};

use crate::learn::Bar;

/// The sample counts of `--finetune` (`None`: every fitting sample).
#[derive(Clone, Debug, PartialEq)]
pub struct Ks(pub Vec<Option<usize>>);

/// Parses `--finetune 25,50,100,all` (clap's value parser).
pub fn ks(text: &str) -> std::result::Result<Ks, String> {
    tacsim_model::parse_finetune_ks(text).map(Ks)
}

/// `finetune.json`.
#[derive(Clone, Debug, Serialize)]
pub struct FinetuneReport {
    /// The command that made it.
    pub command: String,
    /// Seeds per K.
    pub seeds: u64,
    /// The rule both arms train by.
    pub rule: String,
    /// Every point (K, seed).
    pub points: Vec<CurvePoint>,
    /// Per label: both arms against K, the K where the pretrained network matches the
    /// real-trained one on all fitting samples, and the labels saved.
    pub labels: Vec<LabelCurve>,
}

/// Runs every point of the curve (a finished one is read back) and writes the report into
/// `report_dir`; returns the markdown.
pub fn run(
    curve: &FinetuneCurve<'_>,
    ks: &Ks,
    seeds: u64,
    real_all: &[f64],
    quiet: bool,
    command: &str,
    report_dir: &Path,
) -> Result<String> {
    let n = curve.fitting.len();
    let mut points = Vec::new();
    for k in ks.0.iter().map(|k| k.unwrap_or(n).min(n)) {
        for seed in 0..seeds {
            if !quiet {
                eprintln!("fine-tuning curve: K = {k}, seed {seed}");
            }
            points.push(curve.point(k, seed, &mut Bar::new(quiet))?);
        }
    }
    points.sort_by_key(|p| (p.k, p.seed));
    points.dedup_by_key(|p| (p.k, p.seed));
    let report = FinetuneReport {
        command: command.to_owned(),
        seeds,
        rule: format!(
            "both arms: the real-trained network's settings (lr {} for the first half of the epochs, then times {}), \
             the same epochs at each K: {} or more, so that each arm takes at least {} optimiser steps{}{}{}{}",
            curve.cfg.lr,
            curve.cfg.lr_step_factor,
            curve.cfg.epochs,
            curve.min_steps,
            match curve.pretrained_lr_scale {
                1.0 => String::new(),
                s => format!("; the pretrained arm at {s} times that rate"),
            },
            match curve.sim_share {
                0.0 => String::new(),
                s => format!(
                    "; the pretrained arm trains on K s / (1 - s) simulated images beside the K (s = {s}), \
                     in the epochs that give it the same steps"
                ),
            },
            if curve.how.axis_offset {
                "; the pretrained arm's map fitted on the K takes the lab sensor's axis offset (--axis-offset)"
            } else {
                ""
            },
            match &curve.edge {
                None => String::new(),
                Some(e) => format!(
                    "; in the edge's frame (--edge-frame): each arm also trains a second network, in the same epochs on \
                     the K alone, on the K images each turned by minus its labelled yaw (the pretrained arm's from the \
                     simulator's second network{}, the from-scratch arm's from fresh weights), and reads the labels a \
                     turn leaves alone from each held-out image turned by minus the yaw its first network reads",
                    if e.match_motion { ", its input matched to the simulated images' moments" } else { "" }
                ),
            }
        ),
        labels: summarise_finetune(&points, curve.labels, real_all),
        points,
    };
    tacsim_data::write_atomic(&report_dir.join("finetune.json"), serde_json::to_string_pretty(&report)?.as_bytes())?;
    let mut svg = String::new();
    plot(&report.labels, &mut svg)?;
    tacsim_data::write_atomic(&report_dir.join("finetune.svg"), svg.as_bytes())?;
    let md = markdown(&report);
    tacsim_data::write_atomic(&report_dir.join("finetune.md"), md.as_bytes())?;
    Ok(md)
}

fn markdown(r: &FinetuneReport) -> String {
    let mut s = format!(
        "# Fine-tuning curve\n\n`{}`\n\nFor each K labelled real fitting samples (a seeded choice stratified over the first label; {} seeds): \
         (a) the simulator-trained network fine-tuned on them (labels into its frame through a map fitted on the K), \
         (b) the same network trained from scratch on them; both on the held-out part. Training: {}. \
         Mean over the seeds (least..greatest). finetune.svg plots it.\n",
        r.command, r.seeds, r.rule
    );
    for l in &r.labels {
        let (first_head, first_rule) = match l.first {
            Some(_) => (" first alone (a / b) |", "---|"),
            None => ("", ""),
        };
        s.push_str(&format!(
            "\n## {}\n\nReal-trained on every fitting sample: {:.3}. Pretrained within {MATCH_FACTOR}x of it from K = {}.{}\n\n\
             | K | pretrained (a) | from scratch (b) | (a)/(b) | labels saved |{first_head}\n|---|---|---|---|---|{first_rule}\n",
            l.label,
            l.real_all,
            l.pretrained_matches_at.map_or("never (within the Ks run)".to_owned(), |k| k.to_string()),
            if l.first.is_some() {
                " Read in the edge's frame, the real-trained network on every fitting sample too; the last column: each arm's first network alone, the images as they are."
            } else {
                ""
            }
        ));
        for (i, k) in l.k.iter().enumerate() {
            let (a, b) = (l.pretrained[i], l.scratch[i]);
            s.push_str(&format!(
                "| {k} | {:.3} ({:.3}..{:.3}) | {:.3} ({:.3}..{:.3}) | {:.2} | {} |",
                a.mean,
                a.min,
                a.max,
                b.mean,
                b.min,
                b.max,
                a.mean / b.mean,
                l.labels_saved[i].map_or("-".to_owned(), |x| format!("{x:.1}x"))
            ));
            if let Some([fa, fb]) = &l.first {
                s.push_str(&format!(" {:.3} / {:.3} |", fa[i].mean, fb[i].mean));
            }
            s.push('\n');
        }
    }
    s
}

/// One panel per label: error against K (log), both arms' means with their spread, and the
/// real-trained network on all fitting samples.
fn plot(labels: &[LabelCurve], svg: &mut String) -> Result<()> {
    let width = 420 * labels.len().max(1) as u32;
    let root = SVGBackend::with_string(svg, (width, 380)).into_drawing_area();
    root.fill(&WHITE)?;
    for (area, l) in root.split_evenly((1, labels.len().max(1))).iter().zip(labels) {
        let ys = l.pretrained.iter().chain(&l.scratch).flat_map(|s| [s.min, s.max]).chain([l.real_all]);
        let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        let (k0, k1) = (*l.k.first().unwrap_or(&1) as f64, *l.k.last().unwrap_or(&2) as f64);
        let mut chart = ChartBuilder::on(area)
            .caption(&l.label, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(34)
            .y_label_area_size(50)
            .build_cartesian_2d((k0 * 0.8..k1 * 1.25).log_scale(), 0.0..(y1.max(y0) * 1.1).max(1e-9))?;
        chart.configure_mesh().x_desc("labelled real samples K").y_desc("held-out error").draw()?;
        let all = vec![(k0 * 0.8, l.real_all), (k1 * 1.25, l.real_all)];
        chart
            .draw_series(LineSeries::new(all, BLACK.stroke_width(1)))?
            .label("real-trained, all")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK));
        for (name, arm, color) in [("pretrained (a)", &l.pretrained, BLUE), ("from scratch (b)", &l.scratch, RED)] {
            let pts: Vec<(f64, f64)> = l.k.iter().zip(arm).map(|(&k, s)| (k as f64, s.mean)).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            chart.draw_series(
                l.k.iter().zip(arm).map(|(&k, s)| PathElement::new(vec![(k as f64, s.min), (k as f64, s.max)], color)),
            )?;
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(())
}
