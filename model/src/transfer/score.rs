//! Scoring a simulator-trained pose network on a lab's recordings (`tacsim sim2real`): the
//! label map fitted on the lab's fitting part ([`LabelMap::fit`]), then the simulator-trained
//! network through the map and a network trained on the lab's fitting part, both on the
//! held-out part, per label against chance; and how the simulated training poses cover the
//! lab's ([`coverage`]).

use std::path::Path;

use serde::Serialize;

use super::edge_frame::{EdgeReader, EdgeStage, Fitting};
use super::turns::sense_on;
use super::{LabelMap, Span, Turns};
use crate::backend::Backend;
use crate::data::Corpus;
use crate::error::Result;
use crate::eval::{corpus_images, predict_poses};
use crate::infer::load_posenet;
use crate::posenet::{Column, Pose};

/// One label's errors on the held-out real images.
#[derive(Clone, Debug, Serialize)]
pub struct LabelScore {
    /// The lab's label, with unit.
    pub label: String,
    /// Mean absolute error of the simulator-trained network through the label map.
    pub sim_trained: f64,
    /// Mean absolute error of the network trained on the lab's fitting part, read as the
    /// simulator-trained one is: in the edge's frame where that is (a second real-trained
    /// network, [`score`]'s `edge`), else the images as they are.
    pub real_trained: f64,
    /// In the edge's frame: the network trained on the lab's fitting part alone, reading the
    /// images as they are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub real_trained_as_is: Option<f64>,
    /// `sim_trained / real_trained`.
    pub ratio: f64,
    /// Mean absolute error of always answering the fitting part's median (chance).
    pub chance: f64,
    /// Slope of the simulator-trained readings (through the map) against the labels, least
    /// squares, for a length (1: the simulated images change with it as the real ones do;
    /// below 1: the network reads real images as if they changed less). None for the yaw.
    pub sim_trained_gain: Option<f64>,
}

/// How the simulated training poses cover the lab's, one simulated label: the lab's fitting
/// part taken into the recipe's frame through the label map, against the simulated set.
/// A recipe wider than the lab's span spends its samples on poses the lab never takes; lab
/// poses outside the simulated span ask the network to extrapolate.
#[derive(Clone, Debug, Serialize)]
pub struct Coverage {
    /// The simulated label.
    pub label: Column,
    /// The lab's fitting part, in the recipe's frame.
    pub lab: Span,
    /// The simulated training set.
    pub sim: Span,
    /// Share of the lab's fitting recordings outside the simulated span (0..1).
    pub lab_outside: f64,
}

/// How [`score`] reads the images: the backend, the networks' side (px), whether the
/// simulator-trained network's batch-norm statistics are re-estimated on the lab's fitting
/// images first, and whether it reads each image at several turns.
#[derive(Clone, Copy, Debug)]
pub struct Scoring {
    /// The backend the networks run on.
    pub backend: Backend,
    /// The networks' image side (px).
    pub size: usize,
    /// Re-estimate the simulator-trained network's batch norms on the lab's fitting images.
    pub adapt_norms: bool,
    /// The simulator-trained network's readings (of the fitting part, for the map, and of the
    /// held-out part) averaged over turns of each image ([`Turns`]); the real-trained network
    /// reads the images as they are.
    pub turns: Option<Turns>,
    /// Fit the lab sensor's axis offset into the label map ([`LabelMap::with_axis_offset`]).
    pub axis_offset: bool,
}

/// What [`score`] finds.
#[derive(Clone, Debug)]
pub struct Scores {
    /// Errors per label on the held-out part.
    pub labels: Vec<LabelScore>,
    /// The fitted label map.
    pub map: LabelMap,
    /// For each held-out image, the simulated training row nearest its label.
    pub nearest: Vec<usize>,
    /// `predictions.csv`: each held-out image's labels and both networks' readings, in the
    /// lab's frame (in the edge's frame, the real-trained network's first alone too:
    /// `_real_trained_as_is`).
    pub predictions: String,
    /// `fitting.csv`: each fitting image's labels and the simulator-trained network's reading
    /// through the map, in the lab's frame (where a lab diagnoses its gap, by depth or by
    /// side, without looking at the held-out part; the real-trained network is left out: it
    /// was trained on these images).
    pub fitting: String,
}

/// The label map on the lab's fitting part, both networks on its held-out part; with, for
/// each held-out image, the simulated training image nearest its label (for a grid).
/// `rows`: the lab's fitting and held-out rows and the simulated training rows; `runs`: the
/// simulator-trained and the real-trained networks' run folders; `edge`, for each of the two,
/// a second network that reads the labels a turn leaves alone in the edge's frame, its first
/// network's yaw turned out of each image ([`EdgeStage`]; the real-trained one's trained on
/// the lab's fitting images turned by their labelled yaws, [`lab_in_edge_frame`], and never
/// matched).
///
/// [`lab_in_edge_frame`]: super::lab_in_edge_frame
pub fn score(
    how: &Scoring,
    [sim, real]: [&Corpus; 2],
    real_labels: &[Column],
    [fitting, held_out, sim_rows]: [&[usize]; 3],
    [sim_run, real_run]: [&Path; 2],
    [edge, real_edge]: [Option<EdgeStage<'_>>; 2],
) -> Result<Scores> {
    let device = how.backend.device();
    let images = |rows: &[usize]| corpus_images(real, rows);
    let poses = |rows: &[usize]| -> Vec<Pose> { rows.iter().map(|&r| real.pose(r)).collect() };
    let fit_images = images(fitting);
    let (sim_net, _, sim_scale) = load_posenet(sim_run, &device)?;
    let sim_net = if how.adapt_norms { sim_net.adapt_norms(&fit_images, how.size, &device) } else { sim_net };
    let (real_net, _, real_scale) = load_posenet(real_run, &device)?;
    let read_sim = match how.turns.filter(|t| t.count > 1) {
        None => None,
        Some(turns) => {
            turns.check(&sim_scale.columns())?;
            let sense = sense_on(&sim_net, &sim_scale, sim, sim_rows, how.size, &device, turns.turn, "--turns")?;
            Some((turns, sense))
        }
    };
    let read_first = |images: &[Vec<f32>]| match read_sim {
        None => predict_poses(&sim_net, &sim_scale, images, how.size, &device),
        Some((turns, sense)) => turns.read(&sim_net, &sim_scale, images, how.size, &device, sense),
    };
    let fit_truth = poses(fitting);
    let fit_read = read_first(&fit_images);
    let edge = match &edge {
        None => None,
        Some(stage) => {
            let fit = Fitting { images: &fit_images, first: &fit_read, adapt_norms: how.adapt_norms };
            Some(EdgeReader::load(stage, (sim, sim_rows), &fit, how.size, &device)?)
        }
    };
    let read = |images: &[Vec<f32>], first: Vec<Pose>| match &edge {
        None => first,
        Some(e) => e.read(images, &first, how.size, &device),
    };
    let fit_read = read(&fit_images, fit_read);
    let map = LabelMap::fit(&fit_read, &sim_scale.columns(), &fit_truth, real_labels)?;
    let map = if how.axis_offset { map.with_axis_offset(&fit_read, &fit_truth) } else { map };
    let truth = poses(held_out);
    let test_images = images(held_out);
    let sim_read = read(&test_images, read_first(&test_images));
    let sim_err = map.errors(&sim_read, &truth);
    let identity = LabelMap::identity(real_labels);
    let real_first = predict_poses(&real_net, &real_scale, &test_images, how.size, &device);
    // In the edge's frame, the real-trained network's second network reads what a turn leaves
    // alone; else its first reads everything.
    let real_framed = match &real_edge {
        None => None,
        Some(stage) => Some(EdgeReader::new(stage.run, (stage.sense, stage.turn), None, &device)?.read(
            &test_images,
            &real_first,
            how.size,
            &device,
        )),
    };
    let real_read = real_framed.as_deref().unwrap_or(&real_first);
    let real_err = identity.errors(real_read, &truth);
    let as_is = real_edge.map(|_| identity.errors(&real_first, &truth));
    let mut readers = vec![("sim_trained", through(&map, &sim_read)), ("real_trained", through(&identity, real_read))];
    if as_is.is_some() {
        readers.push(("real_trained_as_is", through(&identity, &real_first)));
    }
    let predictions = readings_csv(real, real_labels, held_out, &truth, &readers);
    let fitting_csv =
        readings_csv(real, real_labels, fitting, &fit_truth, &[("sim_trained", through(&map, &fit_read))]);
    // Chance: one constant for every image, the best on the fitting part.
    let chance = LabelMap::constant(real_labels, &fit_truth).errors(&vec![Pose::default(); truth.len()], &truth);
    let labels = map
        .links
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let gain = (!l.real.is_angle()).then(|| {
                let pairs: Vec<(f64, f64)> =
                    truth.iter().zip(&sim_read).map(|(t, p)| (t.get(l.real), l.apply(p))).collect();
                slope(&pairs)
            });
            LabelScore {
                label: super::label(l.real),
                sim_trained: sim_err[k],
                real_trained: real_err[k],
                real_trained_as_is: as_is.as_ref().map(|e| e[k]),
                ratio: sim_err[k] / real_err[k],
                chance: chance[k],
                sim_trained_gain: gain,
            }
        })
        .collect();
    let nearest = truth
        .iter()
        .map(|t| {
            let want = map.sim_pose(t);
            // Label distance with 10 deg as far as 1 mm.
            let d = |r: usize| {
                let p = sim.pose(r);
                map.links
                    .iter()
                    .map(|l| {
                        let unit = if l.sim.is_angle() { 10.0 } else { 1.0 };
                        (super::difference(l.sim, p.get(l.sim), want.get(l.sim)) / unit).powi(2)
                    })
                    .sum::<f64>()
            };
            sim_rows.iter().copied().min_by(|a, b| d(*a).total_cmp(&d(*b))).unwrap_or(0)
        })
        .collect();
    Ok(Scores { labels, map, nearest, predictions, fitting: fitting_csv })
}

/// Each reading in the lab's frame through `map`, one value per link.
fn through(map: &LabelMap, read: &[Pose]) -> Vec<Vec<f64>> {
    read.iter().map(|p| map.links.iter().map(|l| l.apply(p)).collect()).collect()
}

/// One line per image of `rows` (`truth` its labels): the image, then per label its value and
/// each reader's value (`readers`: a column suffix and, per image, one value per label).
fn readings_csv(
    real: &Corpus,
    labels: &[Column],
    rows: &[usize],
    truth: &[Pose],
    readers: &[(&str, Vec<Vec<f64>>)],
) -> String {
    let mut csv = String::from("image");
    for c in labels {
        csv.push_str(&format!(",{c}"));
        for (name, _) in readers {
            csv.push_str(&format!(",{c}_{name}"));
        }
    }
    csv.push('\n');
    for (k, &r) in rows.iter().enumerate() {
        csv.push_str(&real.dataset.rows[r].sensor_image);
        for (j, &c) in labels.iter().enumerate() {
            csv.push_str(&format!(",{:.4}", truth[k].get(c)));
            for (_, values) in readers {
                csv.push_str(&format!(",{:.4}", values[k][j]));
            }
        }
        csv.push('\n');
    }
    csv
}

/// Per link of `map`: the lab's fitting poses (`real` at `rows[1]`) in the recipe's frame
/// against the simulated training poses (`sim` at `rows[0]`).
pub fn coverage(map: &LabelMap, [sim, real]: [&Corpus; 2], [sim_rows, fitting]: [&[usize]; 2]) -> Vec<Coverage> {
    let lab_poses: Vec<Pose> = fitting.iter().map(|&r| map.sim_pose(&real.pose(r))).collect();
    map.links
        .iter()
        .filter_map(|l| {
            let lab: Vec<f64> = lab_poses.iter().map(|p| p.get(l.sim)).collect();
            let simulated: Vec<f64> = sim_rows.iter().map(|&r| sim.pose(r).get(l.sim)).collect();
            let (lab_span, sim_span) = (Span::of(l.sim, &lab)?, Span::of(l.sim, &simulated)?);
            let outside = lab.iter().filter(|&&v| !sim_span.contains(l.sim, v)).count();
            Some(Coverage {
                label: l.sim,
                lab: lab_span,
                sim: sim_span,
                lab_outside: outside as f64 / lab.len() as f64,
            })
        })
        .collect()
}

/// Least-squares slope of `y` on `x` over `(x, y)` pairs (0 when `x` does not vary).
fn slope(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len().max(1) as f64;
    let (mx, my) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = pairs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pairs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx > 0.0 { sxy / sxx } else { 0.0 }
}
