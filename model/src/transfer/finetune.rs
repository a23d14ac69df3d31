//! How many real labels pretraining on tacsim saves (`tacsim sim2real --finetune`): for each
//! number `K` of the lab's labelled fitting samples and each seed, (a) the simulator-trained
//! network fine-tuned on those `K` and (b) the same network trained from scratch on them, both
//! scored on the held-out part as the zero-shot run scores its two networks.
//!
//! - The `K` samples: a seeded choice stratified over the lab's first scored label (the
//!   fitting rows sorted by it, cut into `K` equal runs, one drawn from each), so that a small
//!   `K` still spans the lab's range ([`stratified`]).
//! - (a) reads the simulator's labels: the `K` labels go into the simulated frame through a
//!   label map fitted on those `K` alone (as a lab with `K` labels would fit it), the network
//!   starts from the simulator-trained weights and its label scale, and its readings go back
//!   through the same map.
//! - (b) reads the lab's labels directly, from freshly initialised weights.
//! - Equal budget: both arms train the same epochs, so the same optimiser steps, at the same
//!   learning rate and rule as the real-trained network (`lr`, times `lr_step_factor` after
//!   half the epochs); a small `K` trains more epochs so that each arm takes at least
//!   [`Curve::min_steps`] steps (default [`MIN_STEPS`]; [`epochs_for`]). The pretrained arm's
//!   rate may be scaled down ([`Curve::pretrained_lr_scale`]), its steps kept.
//! - The pretrained arm may keep training on simulated images beside the `K`
//!   ([`Curve::sim_share`]): `m = K s / (1 - s)` of the simulated training images (a seeded
//!   choice per point) join the `K`, and the arm trains the epochs that give it the
//!   from-scratch arm's steps ([`mixed_epochs`]).
//! - With [`Scoring::axis_offset`] (`--axis-offset`) the map fitted on the `K` takes the lab
//!   sensor's axis offset too ([`LabelMap::with_axis_offset`]), as the zero-shot map does.
//! - The from-scratch arm does not depend on the pretrained arm's rate, simulated share or
//!   map: it is trained once per `K` and seed, in the plain point's folder, and shared.
//!
//! - In the edge's frame ([`Curve::edge`], `--edge-frame`): each arm also trains a second
//!   network, in the same steps as its first, on the `K` images each turned by minus its
//!   labelled yaw (the pretrained arm's from the simulator's second network, its labels and yaw
//!   taken through the map; the from-scratch arm's from fresh weights on the lab's labels,
//!   turned with the lab's yaw sense, the simulator's sense times the map's sign), and reads the
//!   held-out images as the zero-shot run does ([`EdgeStage`]): the yaw the arm's first network
//!   reads, each image turned by minus it, the labels a turn leaves alone read by the second.
//!   With [`EdgeStage::match_motion`] the pretrained arm's turned images, the `K` and the
//!   held-out ones, are matched to the simulated images' moments over the lab's fitting images
//!   turned by the fine-tuned network's yaws (labels unused).
//!
//! Each point's runs and its scores live in `k{K}-s{seed}/` under the curve's folder (with a
//! suffix per option above; the from-scratch runs in the plain point's): a finished point is
//! read back, not recomputed; an interrupted one resumes its runs.

use std::path::{Path, PathBuf};

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use tacsim_data::Split;

use super::edge_frame::{
    EdgeReader, EdgeStage, Matching, edge_frame_labels, in_edge_frame, lab_matching, lab_sense, turned_by,
};
use super::turns::TurnImage;
use super::{LabelMap, Scoring};
use crate::checkpoint::{read_json, write_json};
use crate::config::PoseConfig;
use crate::data::Corpus;
use crate::error::{ModelError, Result};
use crate::eval::{corpus_images, predict_poses};
use crate::infer::load_posenet;
use crate::posenet::{Column, Pose};
use crate::train::{Progress, train_posenet};

/// The fewest optimiser steps either arm takes by default, whatever `K` ([`epochs_for`],
/// [`Curve::min_steps`]).
pub const MIN_STEPS: usize = 300;

/// "Matches the real-trained network": within this factor of its error on all fitting
/// samples (issue 87's bound).
pub const MATCH_FACTOR: f64 = 1.2;

/// The largest [`Curve::sim_share`].
pub const MAX_SIM_SHARE: f64 = 0.9;

/// The epochs both arms train at `k` samples: `epochs` (the real-trained network's), raised
/// where `k` gives too few batches for `min_steps` steps.
pub fn epochs_for(k: usize, batch: usize, epochs: usize, min_steps: usize) -> usize {
    let per_epoch = k.div_ceil(batch.max(1)).max(1);
    epochs.max(min_steps.div_ceil(per_epoch))
}

/// The epochs of the pretrained arm on `k` real and `m` simulated samples that give it the
/// steps of `epochs` over the `k` alone (rounded; at least 2, so that the rate's step after half
/// the epochs falls inside the run).
pub fn mixed_epochs(k: usize, m: usize, batch: usize, epochs: usize) -> usize {
    let batch = batch.max(1);
    let steps = epochs * k.div_ceil(batch).max(1);
    let per_epoch = (k + m).div_ceil(batch).max(1);
    ((steps as f64 / per_epoch as f64).round() as usize).max(2)
}

/// The `m` simulated samples that join `k` real ones at the simulated share `share` (0: none).
pub fn sim_samples(k: usize, share: f64) -> usize {
    (k as f64 * share / (1.0 - share)).round() as usize
}

/// Parses `25,50,100,all` into sample counts (`None`: every fitting sample), each at least
/// 2, in increasing order.
pub fn parse_ks(text: &str) -> std::result::Result<Vec<Option<usize>>, String> {
    let mut ks = Vec::new();
    for part in text.split(',').map(str::trim) {
        let k = if part == "all" {
            None
        } else {
            let k: usize = part.parse().map_err(|_| format!("`{part}` is not a sample count or `all`"))?;
            if !(2..=1_000_000).contains(&k) {
                return Err(format!("{k} samples: each K must be in [2, 1000000] or `all`"));
            }
            Some(k)
        };
        if ks.last().is_some_and(|last: &Option<usize>| last.is_none() || k.is_some_and(|k| Some(k) <= *last)) {
            return Err(format!("`{text}`: give the counts in increasing order, `all` last"));
        }
        ks.push(k);
    }
    if ks.is_empty() {
        return Err("no sample counts given".into());
    }
    Ok(ks)
}

/// A seeded choice of `k` of `rows`, stratified over `label`: `rows` sorted by it (ties by
/// row), cut into `k` runs of (nearly) equal length, one row drawn from each. All of `rows`
/// (sorted) where `k` is at least their number.
pub fn stratified(corpus: &Corpus, rows: &[usize], label: Column, k: usize, seed: u64) -> Vec<usize> {
    let mut sorted = rows.to_vec();
    sorted.sort_by(|&a, &b| corpus.pose(a).get(label).total_cmp(&corpus.pose(b).get(label)).then(a.cmp(&b)));
    if k >= sorted.len() {
        return sorted;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(tacsim_data::splitmix64(seed ^ (k as u64).rotate_left(32)));
    (0..k)
        .map(|i| {
            let (lo, hi) = (i * sorted.len() / k, (i + 1) * sorted.len() / k);
            sorted[rng.random_range(lo..hi)]
        })
        .collect()
}

/// One point of the curve: `k` samples, one seed, the held-out error per lab label (in the
/// order of the curve's labels) of both arms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Labelled real samples the arms trained on.
    pub k: usize,
    /// The seed of the choice and of both trainings (added to the config's).
    pub seed: u64,
    /// Epochs of both arms ([`epochs_for`]).
    pub epochs: usize,
    /// (a) the simulator-trained network fine-tuned: mean absolute error per label (mm or deg).
    pub pretrained: Vec<f64>,
    /// (b) the network trained from scratch on the same samples.
    pub scratch: Vec<f64>,
    /// The label map fitted on the `k` samples, as `LabelMap::describe` writes it.
    pub map: Vec<String>,
    /// Simulated samples the pretrained arm trained on beside the `k` ([`Curve::sim_share`]).
    #[serde(default)]
    pub sim_samples: usize,
    /// The pretrained arm's epochs where simulated samples joined the `k` (`mixed_epochs`);
    /// without them it trains `epochs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pretrained_epochs: Option<usize>,
    /// In the edge's frame ([`Curve::edge`]): the pretrained arm's first network alone, every
    /// label read from the image as it is (the figures `pretrained` has without the frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pretrained_first: Option<Vec<f64>>,
    /// In the edge's frame: the from-scratch arm's first network alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scratch_first: Option<Vec<f64>>,
}

/// Everything a curve's points share.
pub struct Curve<'a> {
    /// How the networks read images.
    pub how: Scoring,
    /// The lab's corpus.
    pub real: &'a Corpus,
    /// The lab labels scored.
    pub labels: &'a [Column],
    /// The lab's fitting rows (the samples are drawn from them) and held-out rows (the test).
    pub fitting: &'a [usize],
    /// The held-out rows.
    pub held_out: &'a [usize],
    /// The simulator-trained network's run.
    pub sim_run: &'a Path,
    /// The pose network's settings (the real-trained network's; labels are set per arm).
    pub cfg: &'a PoseConfig,
    /// The fewest optimiser steps of either arm at any `K` (default [`MIN_STEPS`]).
    pub min_steps: usize,
    /// The pretrained arm's learning rate over the real-trained network's, in (0, 1]: a
    /// fine-tuning that starts from trained weights may step more gently than training from
    /// scratch, in the same steps (1: the same rate).
    pub pretrained_lr_scale: f64,
    /// The simulator-trained network's training set (its images and labels, in its frame).
    pub sim: &'a Corpus,
    /// The simulated training rows the pretrained arm may draw from.
    pub sim_rows: &'a [usize],
    /// The share of the pretrained arm's training samples drawn from the simulated set, in
    /// [0, [`MAX_SIM_SHARE`]] (0: the `K` alone): training on with the simulator's images keeps
    /// what they taught while the `K` teach the lab's.
    pub sim_share: f64,
    /// Read in the edge's frame (`--edge-frame`): the simulator's second network, the yaw's
    /// sense, the turn and whether the pretrained arm's input is matched (see the module
    /// documentation). None: each arm's one network reads the images as they are.
    pub edge: Option<EdgeStage<'a>>,
    /// The curve's folder (`k{K}-s{seed}/` per point).
    pub dir: PathBuf,
}

impl Curve<'_> {
    /// The point of `k` samples (capped at the fitting part) and `seed`: read back where it
    /// is finished, else trained (resuming its runs) and scored.
    pub fn point(&self, k: usize, seed: u64, progress: &mut dyn Progress) -> Result<CurvePoint> {
        let k = k.min(self.fitting.len());
        // A gentler fine-tuning, one with simulated images or one whose map fits the axis
        // offset is a point of its own; its from-scratch arm, which none of them touch, is
        // the plain point's (trained once per K and seed).
        let mut name = format!("k{k}-s{seed}");
        if self.pretrained_lr_scale != 1.0 {
            name.push_str(&format!("-lr{}", self.pretrained_lr_scale));
        }
        if self.sim_share > 0.0 {
            name.push_str(&format!("-sim{}", self.sim_share));
        }
        let mut plain = format!("k{k}-s{seed}");
        if let Some(edge) = &self.edge {
            let frame = if edge.match_motion { "-edge-matched" } else { "-edge" };
            name.push_str(frame);
            plain.push_str(frame);
        }
        if self.how.axis_offset {
            name.push_str("-axis");
        }
        let dir = self.dir.join(name);
        let scratch_dir = self.dir.join(plain);
        let done = dir.join("point.json");
        if done.is_file() {
            return read_json(&done);
        }
        if k < 2 {
            return Err(ModelError::Insufficient(format!("{k} fitting samples: a curve point needs at least 2")));
        }
        let rows = stratified(self.real, self.fitting, self.labels[0], k, seed);
        let epochs = epochs_for(k, self.cfg.batch, self.cfg.epochs, self.min_steps);
        let device = self.how.backend.device();
        let truth = |rows: &[usize]| -> Vec<Pose> { rows.iter().map(|&r| self.real.pose(r)).collect() };
        let held_images = corpus_images(self.real, self.held_out);
        let held_truth = truth(self.held_out);
        let seed_cfg = self.cfg.seed.wrapping_add(seed);

        // (a) Pretrained: the map from the simulator-trained network's readings of the k.
        let (sim_net, _, sim_scale) = load_posenet(self.sim_run, &device)?;
        let read = predict_poses(&sim_net, &sim_scale, &corpus_images(self.real, &rows), self.how.size, &device);
        let map = LabelMap::fit(&read, &sim_scale.columns(), &truth(&rows), self.labels)?;
        let map = if self.how.axis_offset { map.with_axis_offset(&read, &truth(&rows)) } else { map };
        let sim_labels = sim_scale.columns();
        // In the edge's frame, what each arm's second network reads and the lab's yaw sense,
        // checked before any training.
        let edge_plan = match &self.edge {
            None => None,
            Some(stage) => {
                Some((edge_frame_labels(&sim_labels)?, edge_frame_labels(self.labels)?, lab_sense(&map, stage.sense)?))
            }
        };
        let mut as_sim = self.real.training_only(&rows, |pose| map.sim_pose(pose), &sim_labels);
        let sim_samples = sim_samples(k, self.sim_share).min(self.sim_rows.len());
        let mut pretrained_epochs = None;
        if sim_samples > 0 {
            self.add_sim(&mut as_sim, &sim_labels, sim_samples, seed ^ (k as u64).rotate_left(32))?;
            pretrained_epochs = Some(mixed_epochs(k, sim_samples, self.cfg.batch, epochs));
        }
        let lr = self.cfg.lr * self.pretrained_lr_scale;
        let cfg = PoseConfig {
            labels: sim_labels.clone(),
            epochs: pretrained_epochs.unwrap_or(epochs),
            seed: seed_cfg,
            lr,
            ..self.cfg.clone()
        };
        let run = dir.join("pretrained");
        let weights = self.sim_run.join("model.safetensors");
        train_posenet(
            &as_sim,
            &cfg,
            self.how.backend,
            &run,
            run.join("config.json").is_file(),
            Some(&weights),
            progress,
        )?;
        let (net, _, scale) = load_posenet(&run, &device)?;
        let pretrained_read = predict_poses(&net, &scale, &held_images, self.how.size, &device);
        let fitting_read = self
            .edge
            .filter(|e| e.match_motion)
            .map(|_| predict_poses(&net, &scale, &corpus_images(self.real, self.fitting), self.how.size, &device));
        let pretrained_first = map.errors(&pretrained_read, &held_truth);

        // (b) From scratch, on the lab's own labels.
        let own = self.real.training_only(&rows, |pose| *pose, self.labels);
        let scratch_cfg = PoseConfig { labels: self.labels.to_vec(), epochs, seed: seed_cfg, ..self.cfg.clone() };
        let run = scratch_dir.join("scratch");
        train_posenet(&own, &scratch_cfg, self.how.backend, &run, run.join("config.json").is_file(), None, progress)?;
        let (net, _, scale) = load_posenet(&run, &device)?;
        let scratch_read = predict_poses(&net, &scale, &held_images, self.how.size, &device);
        let identity = LabelMap::identity(self.labels);
        let scratch_first = identity.errors(&scratch_read, &held_truth);

        let (pretrained, scratch, pretrained_first, scratch_first) = match (&self.edge, edge_plan) {
            (Some(stage), Some((sim_edge_labels, lab_edge_labels, lab_sense))) => {
                // (a) in the edge's frame: the simulator's second network fine-tuned on the K
                // turned by their labelled yaws (in its frame), matched where asked.
                let turn = (stage.sense, stage.turn);
                let matching = fitting_read.map(|read| {
                    let fitting = turned_by(&corpus_images(self.real, self.fitting), &read, turn, self.how.size);
                    lab_matching(turn, (self.sim, self.sim_rows), &fitting)
                });
                let second = EdgeArm {
                    set: self.real.training_only(&rows, |pose| map.sim_pose(pose), &sim_labels),
                    labels: sim_edge_labels,
                    cfg: PoseConfig { epochs, lr, seed: seed_cfg, ..self.cfg.clone() },
                    run: dir.join("pretrained-edge"),
                    weights: Some(stage.run.join("model.safetensors")),
                    turn,
                    matching,
                };
                let read = self.edge_arm(second, &rows, (&held_images, &pretrained_read), progress)?;
                let pretrained = map.errors(&read, &held_truth);
                // (b) in the edge's frame: a second network from scratch on the K turned by
                // their labelled yaws in the lab's frame.
                let second = EdgeArm {
                    set: own,
                    labels: lab_edge_labels,
                    cfg: scratch_cfg,
                    run: scratch_dir.join("scratch-edge"),
                    weights: None,
                    turn: (lab_sense, stage.turn),
                    matching: None,
                };
                let read = self.edge_arm(second, &rows, (&held_images, &scratch_read), progress)?;
                (pretrained, identity.errors(&read, &held_truth), Some(pretrained_first), Some(scratch_first))
            }
            _ => (pretrained_first, scratch_first, None, None),
        };

        let point = CurvePoint {
            k,
            seed,
            epochs,
            pretrained,
            scratch,
            map: map.describe(),
            sim_samples,
            pretrained_epochs,
            pretrained_first,
            scratch_first,
        };
        write_json(&done, &point)?;
        Ok(point)
    }

    /// An arm's second network in the edge's frame: trained on `rows` of `arm.set`, each image
    /// turned by minus the sense times its yaw label (matched where `arm.matching` is given),
    /// resumed where its run was started; then the held-out images read with the yaw of the
    /// arm's first network (`first`, its readings of `images`) and the rest the second's.
    fn edge_arm(
        &self,
        arm: EdgeArm,
        rows: &[usize],
        (images, first): (&[Vec<f32>], &[Pose]),
        progress: &mut dyn Progress,
    ) -> Result<Vec<Pose>> {
        let set = in_edge_frame(&arm.set, Some(rows), arm.turn, arm.matching.as_ref())?;
        let cfg = PoseConfig { labels: arm.labels, ..arm.cfg };
        let resume = arm.run.join("config.json").is_file();
        train_posenet(&set, &cfg, self.how.backend, &arm.run, resume, arm.weights.as_deref(), progress)?;
        let device = self.how.backend.device();
        let reader = EdgeReader::new(&arm.run, arm.turn, arm.matching, &device)?;
        Ok(reader.read(images, first, self.how.size, &device))
    }

    /// Appends `m` of the simulated training rows (a seeded choice), with their images, to
    /// `set` as training rows.
    fn add_sim(&self, set: &mut Corpus, labels: &[Column], m: usize, seed: u64) -> Result<()> {
        let mut rng = ChaCha8Rng::seed_from_u64(tacsim_data::splitmix64(seed ^ 0x5349_4d53));
        let mut chosen = self.sim_rows.to_vec();
        chosen.shuffle(&mut rng);
        chosen.truncate(m);
        chosen.sort_unstable();
        // The simulated rows join as the kind of the lab's (taps or slides), so that the
        // network's choice of rows (`Corpus::pose_rows`) takes both.
        let kind = set.dataset.rows.iter().find(|r| r.split == Split::Train).map(|r| r.kind);
        let before = set.pose_rows(Split::Train, labels).len();
        set.images.append(&self.sim.images, &chosen)?;
        set.dataset.rows.extend(chosen.iter().map(|&r| {
            let mut row = self.sim.dataset.rows[r].clone();
            row.split = Split::Train;
            row.kind = kind.unwrap_or(row.kind);
            row
        }));
        let after = set.pose_rows(Split::Train, labels).len();
        if after != before + m {
            return Err(ModelError::Insufficient(format!(
                "{} of {m} simulated samples joined the {before} real ones: the labels {} select other rows",
                after.saturating_sub(before),
                labels.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ")
            )));
        }
        Ok(())
    }
}

/// What an arm's second network trains on in the edge's frame ([`Curve::edge_arm`]).
struct EdgeArm {
    /// The lab's corpus with the `K` as its training rows, labelled in the arm's frame.
    set: Corpus,
    /// The labels the second network reads (those a turn leaves alone).
    labels: Vec<Column>,
    /// Its settings (epochs, rate, seed; the labels are `labels`).
    cfg: PoseConfig,
    /// Its run folder.
    run: PathBuf,
    /// The weights it starts from (None: fresh).
    weights: Option<PathBuf>,
    /// The yaw's sense in the arm's frame and the turn.
    turn: (f64, TurnImage),
    /// The pretrained arm's matching of its turned input.
    matching: Option<Matching>,
}

/// Mean, least and greatest of a label's error over the seeds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Mean over the seeds (mm or deg).
    pub mean: f64,
    /// Least.
    pub min: f64,
    /// Greatest.
    pub max: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Self {
        let mean = values.iter().sum::<f64>() / values.len().max(1) as f64;
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Self { mean, min, max }
    }
}

/// One label's curve: both arms at every `K`, against the real-trained network on all
/// fitting samples.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelCurve {
    /// The lab label with its unit.
    pub label: String,
    /// The real-trained network's held-out error with every fitting sample (the zero-shot
    /// run's, read as the arms are: in the edge's frame where they are).
    pub real_all: f64,
    /// `K` in increasing order.
    pub k: Vec<usize>,
    /// (a) over the seeds, per `K`.
    pub pretrained: Vec<Spread>,
    /// (b) over the seeds, per `K`.
    pub scratch: Vec<Spread>,
    /// The least `K` at which (a)'s mean is within [`MATCH_FACTOR`] of `real_all`.
    pub pretrained_matches_at: Option<usize>,
    /// Per `K`: labels saved, the `K` from-scratch training needs to reach (a)'s mean error at
    /// this `K` (linear in log K between measured points) over this `K`; `None` where no
    /// measured `K` of (b) reaches it.
    pub labels_saved: Vec<Option<f64>>,
    /// In the edge's frame: each arm's first network alone (the images as they are), (a) and
    /// (b) over the seeds per `K` ([`CurvePoint::pretrained_first`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first: Option<[Vec<Spread>; 2]>,
}

/// The curves per label from the points of every `K` and seed (`labels` in the points'
/// order, `real_all` the real-trained network's errors).
pub fn summarise(points: &[CurvePoint], labels: &[Column], real_all: &[f64]) -> Vec<LabelCurve> {
    let mut ks: Vec<usize> = points.iter().map(|p| p.k).collect();
    ks.sort_unstable();
    ks.dedup();
    labels
        .iter()
        .enumerate()
        .map(|(j, &c)| {
            let at = |k: usize, arm: fn(&CurvePoint) -> Option<&Vec<f64>>| {
                Spread::of(&points.iter().filter(|p| p.k == k).filter_map(|p| arm(p).map(|v| v[j])).collect::<Vec<_>>())
            };
            let curve = |arm: fn(&CurvePoint) -> Option<&Vec<f64>>| ks.iter().map(|&k| at(k, arm)).collect();
            let pretrained: Vec<Spread> = curve(|p| Some(&p.pretrained));
            let scratch: Vec<Spread> = curve(|p| Some(&p.scratch));
            let first = points
                .iter()
                .all(|p| p.pretrained_first.is_some() && p.scratch_first.is_some())
                .then(|| [curve(|p| p.pretrained_first.as_ref()), curve(|p| p.scratch_first.as_ref())]);
            let matches =
                ks.iter().zip(&pretrained).find(|(_, s)| s.mean <= MATCH_FACTOR * real_all[j]).map(|(&k, _)| k);
            let saved = ks
                .iter()
                .zip(&pretrained)
                .map(|(&k, a)| k_reaching(&ks, &scratch, a.mean).map(|kb| kb / k as f64))
                .collect();
            LabelCurve {
                label: super::label(c),
                real_all: real_all[j],
                k: ks.clone(),
                pretrained,
                scratch,
                pretrained_matches_at: matches,
                labels_saved: saved,
                first,
            }
        })
        .collect()
}

/// The (fractional) `K` at which the curve `scratch` over `ks` first comes down to `error`:
/// linear in log K between the measured points; `None` where it never does.
fn k_reaching(ks: &[usize], scratch: &[Spread], error: f64) -> Option<f64> {
    let first = scratch.iter().position(|s| s.mean <= error)?;
    if first == 0 {
        return Some(ks[0] as f64);
    }
    let (k0, k1) = ((ks[first - 1] as f64).ln(), (ks[first] as f64).ln());
    let (e0, e1) = (scratch[first - 1].mean, scratch[first].mean);
    let t = if e0 > e1 { (e0 - error) / (e0 - e1) } else { 1.0 };
    Some((k0 + t.clamp(0.0, 1.0) * (k1 - k0)).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_counts_parse_in_order_with_all_last() {
        assert_eq!(parse_ks("25,50, 100,all"), Ok(vec![Some(25), Some(50), Some(100), None]));
        for bad in ["", "50,25", "all,25", "1", "x", "25,25"] {
            assert!(parse_ks(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn small_k_trains_at_least_min_steps_and_all_keeps_the_epochs() {
        assert_eq!(epochs_for(25, 32, 30, MIN_STEPS), 300);
        assert_eq!(epochs_for(100, 32, 30, MIN_STEPS), 75);
        assert_eq!(epochs_for(2000, 32, 30, MIN_STEPS), 30);
        assert!(epochs_for(400, 32, 30, MIN_STEPS) * 400usize.div_ceil(32) >= MIN_STEPS);
        assert_eq!(epochs_for(10, 32, 2, 1), 2);
    }

    /// With simulated samples beside the K the pretrained arm keeps the from-scratch arm's
    /// steps: 75 epochs of 4 batches over 100 real samples are 43 of 7 over 200, 19 of 16 over
    /// 500; never fewer than 2 epochs.
    #[test]
    fn simulated_samples_keep_the_steps() {
        assert_eq!((sim_samples(100, 0.5), sim_samples(100, 0.8), sim_samples(8, 0.0)), (100, 400, 0));
        assert_eq!(mixed_epochs(100, 100, 32, 75), 43);
        assert_eq!(mixed_epochs(100, 400, 32, 75), 19);
        assert_eq!(mixed_epochs(8, 8, 32, 4), 4);
        assert_eq!(mixed_epochs(2, 2000, 32, 1), 2);
    }

    /// The lab's yaw turns with its images as the simulator's does where the map keeps the
    /// yaw's sign, the other way where it flips it; a map without a yaw link is refused.
    #[test]
    fn the_labs_yaw_sense_is_the_simulators_times_the_maps_sign() {
        let link = |sign| LabelMap {
            links: vec![
                super::super::Link::new(Column::PoseY, Column::PoseX, -1.0, 0.5),
                super::super::Link::new(Column::PoseRz, Column::PoseRz, sign, 90.0),
            ],
        };
        assert_eq!(lab_sense(&link(1.0), -1.0).expect("kept"), -1.0);
        assert_eq!(lab_sense(&link(-1.0), -1.0).expect("flipped"), 1.0);
        let e = lab_sense(&LabelMap::identity(&[Column::PoseY, Column::PoseZ]), 1.0).expect_err("no yaw");
        assert!(e.to_string().contains("--edge-frame") && e.to_string().contains("pose_Rz"), "{e}");
    }

    /// Labels saved: the K from scratch needs for the pretrained error, log-linear between
    /// measured points; none where scratch never gets there.
    #[test]
    fn labels_saved_interpolate_in_log_k() {
        let s = |mean| Spread { mean, min: mean, max: mean };
        let ks = [25, 100, 400];
        let scratch = [s(4.0), s(2.0), s(1.0)];
        assert_eq!(k_reaching(&ks, &scratch, 5.0), Some(25.0));
        let k = k_reaching(&ks, &scratch, 3.0).expect("reached");
        assert!((k - 50.0).abs() < 1e-9, "{k}");
        assert_eq!(k_reaching(&ks, &scratch, 0.5), None);
    }
}
