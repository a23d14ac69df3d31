//! Taps on a straight edge (a lab's edge recordings): the lab's labels mapped into the edge
//! frame of a catalogue stimulus, the taps simulated there, and their per-pin error against
//! the tracked real taps ([`super::evaluate::Simulator::on_scene`]).
//!
//! The edge frame ([`LabelFrame::edge`]) has `x` across the edge (positive off the
//! material), yaw from the edge tangent. A lab labels lateral offset, depth and yaw in its
//! own frame: [`EdgeLabels`] maps them, `x = s_l (lateral - l_0)`, `yaw = s_y yaw_lab + y_0`,
//! indentation `= c - k c^1.5` with `c = depth_lab + d_0` (mm, deg; `k` the rig's yield under
//! load, [`crate::rig::Press::depth_compliance`], so that a recipe's `[rig]` replays the map).

mod search;

pub use search::{CANDIDATES, Candidate, EdgeCandidate, EdgeFit, EdgeReport, edge_stimulus, fit_edge, grid_cells};

use std::sync::Arc;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tacsim_data::LabSample;

use super::evaluate::Simulator;
use super::model::SampleError;
use super::observe::Observations;
use crate::SensorPose;
use crate::dataset::LabelFrame;
use crate::error::{Result, SimError};
use crate::rig::yielded_depth_mm;
use crate::scene::{ObjectPose, Scene};
use crate::stimulus::Stimulus;

/// How a lab's edge-tap labels map into the edge frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeLabels {
    /// Which pose label (0: `pose_x`, 1: `pose_y`) is the lateral offset.
    pub lateral: usize,
    /// `+1` or `-1`: the lateral label's direction against the edge frame's `x`.
    pub lateral_sign: f64,
    /// The lateral label at the edge (mm).
    pub lateral_offset_mm: f64,
    /// `+1` or `-1`: the yaw label's sense against the edge frame's.
    pub yaw_sign: f64,
    /// The edge frame's yaw at yaw label 0 (deg).
    pub yaw_offset_deg: f64,
    /// Added to the depth label (`pose_z`) to give the commanded indentation `c` (mm).
    pub depth_offset_mm: f64,
    /// The rig's yield (mm^-0.5): the indentation reached is `c - k c^1.5`
    /// (`yielded_depth_mm`, rig.rs); 0 where the rig is stiff.
    #[serde(default)]
    pub depth_compliance: f64,
}

impl EdgeLabels {
    /// The edge-frame pose `(x, depth, yaw)` (mm, mm, deg) of a sample's labels.
    pub fn edge_pose(&self, sample: &LabSample) -> (f64, f64, f64) {
        let p = &sample.pose;
        (
            self.lateral_sign * (p[self.lateral] - self.lateral_offset_mm),
            yielded_depth_mm(p[2] + self.depth_offset_mm, self.depth_compliance),
            self.yaw_sign * p[5] + self.yaw_offset_deg,
        )
    }
}

/// `stimulus` alone at the origin of a scene, and the edge frame at its contour point
/// nearest `contact_mm` (object frame).
pub fn edge_scene(stimulus: Arc<Stimulus>, contact_mm: [f64; 2]) -> Result<(Scene, LabelFrame)> {
    if stimulus.contour.loops.is_empty() {
        return Err(SimError::invalid(stimulus.name(), "contour", "has no top-face contour, so no edge"));
    }
    let mut scene = Scene::new();
    let id = scene.add(stimulus, ObjectPose::default())?;
    let e = scene.edge(id, contact_mm[0], contact_mm[1]);
    Ok((scene, LabelFrame::edge(e.point, e.tangent)))
}

/// The scene-frame sensor pose of edge-frame pose `(x, depth, yaw)` in `frame`.
pub fn edge_sensor_pose(frame: &LabelFrame, (x, depth, yaw): (f64, f64, f64)) -> SensorPose {
    let [px, py] = frame.point(x, 0.0);
    SensorPose::new(px, py, depth, frame.yaw_zero_deg + yaw)
}

/// Per-pin errors of the taps `which` of `obs` simulated by `sim` (on the scene of
/// [`edge_scene`]) at the poses `labels` gives in `frame`.
pub fn tap_errors(
    sim: &Simulator,
    frame: &LabelFrame,
    labels: &EdgeLabels,
    obs: &Observations,
    which: &[usize],
) -> Result<Vec<SampleError>> {
    which
        .par_iter()
        .map(|&k| {
            let pose = edge_sensor_pose(frame, labels.edge_pose(&obs.samples[k].sample));
            let pins = sim.tap(pose)?;
            Ok(sim.error(obs, k, &sim.displacements_of(&pins)))
        })
        .collect()
}

/// Mean per-pin error over mean real displacement (pooled) of the taps `which`.
pub fn pooled_error(errors: &[SampleError]) -> f64 {
    let real: f64 = errors.iter().map(|e| e.real_px).sum();
    if real > 0.0 { errors.iter().map(|e| e.error_px).sum::<f64>() / real } else { f64::NAN }
}

/// The label map's starting point for a folder: the lateral label is the lateral column
/// (`pose_x` or `pose_y`) that varies most over `which`, the edge at its middle, the yaw
/// as labelled, contact at the shallowest depth label.
pub fn start_labels(obs: &Observations, which: &[usize]) -> EdgeLabels {
    let range = |i: usize| {
        let v = which.iter().map(|&k| obs.samples[k].sample.pose[i]);
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        (lo, hi)
    };
    let (x, y) = (range(0), range(1));
    let lateral = if (y.1 - y.0) > (x.1 - x.0) { 1 } else { 0 };
    let (lo, hi) = if lateral == 1 { y } else { x };
    EdgeLabels {
        lateral,
        lateral_sign: 1.0,
        lateral_offset_mm: 0.5 * (lo + hi),
        yaw_sign: 1.0,
        yaw_offset_deg: 0.0,
        depth_offset_mm: -range(2).0,
        depth_compliance: 0.0,
    }
}

/// Which sign choices [`fit_labels`] tries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signs {
    /// All four (which side of the edge is positive, which way yaw turns), each from the yaw
    /// offset searched every 30 deg: a first fit.
    Every,
    /// The start's own, the coordinate search from the start alone: where a fit on a nearby
    /// sensor gave the start.
    Kept,
}

/// Fits the label map on the taps `which` (signs and offsets): for each of the sign choices
/// `signs` allows, the yaw offset searched every 30 deg (with [`Signs::Every`]) and then a
/// coordinate search (lateral offset from 1 mm, yaw from 10 deg, depth from 0.4 mm and the
/// yield from 0.08 mm^-0.5 steps, halved three times; the yield within [0,
/// [`MAX_DEPTH_COMPLIANCE`]]); the best of them. Returns the map and its pooled error.
pub fn fit_labels(
    sim: &Simulator,
    frame: &LabelFrame,
    obs: &Observations,
    which: &[usize],
    start: EdgeLabels,
    signs: Signs,
) -> Result<(EdgeLabels, f64)> {
    let score = |l: &EdgeLabels| -> Result<f64> { Ok(pooled_error(&tap_errors(sim, frame, l, obs, which)?)) };
    if signs == Signs::Kept {
        let s = score(&start)?;
        return refine((start, s), &score);
    }
    let mut best = (start, f64::INFINITY);
    for lateral_sign in [1.0, -1.0] {
        for yaw_sign in [1.0, -1.0] {
            let mut signed = (start, f64::INFINITY);
            for k in 0..12 {
                let l = EdgeLabels { lateral_sign, yaw_sign, yaw_offset_deg: -180.0 + 30.0 * k as f64, ..start };
                let s = score(&l)?;
                if s < signed.1 {
                    signed = (l, s);
                }
            }
            let refined = refine(signed, &score)?;
            if refined.1 < best.1 {
                best = refined;
            }
        }
    }
    Ok(best)
}

/// The largest rig yield the label map may take (mm^-0.5): the surface rig fit's bound.
pub const MAX_DEPTH_COMPLIANCE: f64 = 0.3;

/// Coordinate search from `start` over the lateral offset, yaw offset, depth offset and the
/// rig's yield.
fn refine(mut best: (EdgeLabels, f64), score: &dyn Fn(&EdgeLabels) -> Result<f64>) -> Result<(EdgeLabels, f64)> {
    let mut steps = [1.0, 10.0, 0.4, 0.08];
    for _ in 0..4 {
        for p in 0..4 {
            for dir in [-1.0, 1.0] {
                loop {
                    let mut t = best.0;
                    match p {
                        0 => t.lateral_offset_mm += dir * steps[0],
                        1 => t.yaw_offset_deg += dir * steps[1],
                        2 => t.depth_offset_mm += dir * steps[2],
                        _ => t.depth_compliance += dir * steps[3],
                    }
                    if !(0.0..=MAX_DEPTH_COMPLIANCE).contains(&t.depth_compliance) {
                        break;
                    }
                    let s = score(&t)?;
                    if s < best.1 {
                        best = (t, s);
                    } else {
                        break;
                    }
                }
            }
        }
        steps = steps.map(|s| 0.5 * s);
    }
    Ok(best)
}
