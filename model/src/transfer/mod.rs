//! Sim-to-real label maps: how the labels of a simulated dataset relate to a lab's.
//!
//! A lab's labels are given in its rig's frame (which side of an edge is positive, where yaw 0
//! points, which column is the lateral offset, where depth 0 is), a simulated dataset's in the
//! recipe's frame. The two agree up to a choice of label, a sign and an offset, which the
//! lab's data fixes: a pose network trained on simulated images reads the lab's fitting part,
//! and every lab label that varies takes the simulated label and sign whose readings, after
//! the best offset, are nearest the lab's labels (least mean absolute error; for a rotation,
//! on the circle), positions from positions and rotations from rotations, no two lab labels
//! from one simulated label. No scale is fitted: a network that reads magnitudes wrong must
//! show it in the error.
//!
//! `real = sign * sim + offset` (mm, or deg modulo 360 for a rotation).
//!
//! A lab's sensor whose axis lies off the robot's yaw axis (or whose image is centred off its
//! pin field) reads a lateral offset that turns with the yaw: with the axis offset fitted
//! ([`LabelMap::with_axis_offset`]), a lateral label (`pose_x`, `pose_y` simulated) is
//! `real = sign * sim + offset + a cos(yaw) + b sin(yaw)` (mm), `yaw` the simulated reading's
//! `pose_Rz` (deg): two more numbers fitted on the fitting part, as the surface rig's pivot
//! offset is (`tacsim calibrate`).

mod edge_frame;
mod finetune;
mod score;
mod turns;

pub use edge_frame::{
    EdgeStage, Matching, Moments, edge_frame_labels, in_edge_frame, lab_in_edge_frame, lab_yaw_sense, yaw_sense,
};
pub use finetune::{
    Curve, CurvePoint, LabelCurve, MATCH_FACTOR, MAX_SIM_SHARE, MIN_STEPS, Spread, epochs_for, parse_ks, summarise,
};
pub use score::{Coverage, LabelScore, Scores, Scoring, coverage, score};
pub use turns::{MAX_TURNS, TurnImage, Turns};

use serde::{Deserialize, Serialize};
use tacsim_data::wrap_deg;

use crate::error::{ModelError, Result};
use crate::eval::yaw_difference_deg;
use crate::posenet::{Column, Pose};

/// Absolute difference of two values of `c` (mm or deg): plain, or on the circle for a
/// rotation.
pub fn difference(c: Column, a: f64, b: f64) -> f64 {
    if c.is_angle() { yaw_difference_deg(a, b) } else { (a - b).abs() }
}

/// The label `c` with its unit, as in reports: `pose_y (mm)`.
pub fn label(c: Column) -> String {
    format!("{} ({})", c.name(), c.unit())
}

/// One lab label and the simulated label it is read from: `real = sign * sim + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Link {
    /// The lab's label.
    pub real: Column,
    /// The simulated label.
    pub sim: Column,
    /// +1 or -1.
    pub sign: f64,
    /// Offset (mm or deg).
    pub offset: f64,
    /// The axis offset's terms `[a, b]` (mm): `a cos(yaw) + b sin(yaw)` added, `yaw` the
    /// simulated pose's `pose_Rz` (deg); zero unless fitted ([`LabelMap::with_axis_offset`]).
    #[serde(default, skip_serializing_if = "no_turning")]
    pub turning_mm: [f64; 2],
}

fn no_turning(t: &[f64; 2]) -> bool {
    *t == [0.0, 0.0]
}

/// `a cos(yaw) + b sin(yaw)` for `[a, b]` and `yaw` in deg.
fn turning(t: [f64; 2], yaw_deg: f64) -> f64 {
    if no_turning(&t) {
        return 0.0;
    }
    let (s, c) = yaw_deg.to_radians().sin_cos();
    t[0] * c + t[1] * s
}

impl Link {
    /// A link without the axis offset's terms.
    pub fn new(real: Column, sim: Column, sign: f64, offset: f64) -> Self {
        Self { real, sim, sign, offset, turning_mm: [0.0; 2] }
    }

    /// The lab's value of the simulated pose `p`.
    pub fn apply(&self, p: &Pose) -> f64 {
        let v = self.sign * p.get(self.sim) + self.offset + turning(self.turning_mm, p.get(Column::PoseRz));
        if self.real.is_angle() { wrap_deg(v) } else { v }
    }

    /// The simulated value of the lab's value `v` (inverse of [`Self::apply`]), `sim_yaw_deg`
    /// the simulated pose's `pose_Rz` (read only where the link has the axis offset's terms).
    pub fn invert(&self, v: f64, sim_yaw_deg: f64) -> f64 {
        let s = self.sign * (v - self.offset - turning(self.turning_mm, sim_yaw_deg));
        if self.sim.is_angle() { wrap_deg(s) } else { s }
    }
}

/// The map from a simulated dataset's labels to a lab's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelMap {
    /// One link per lab label.
    pub links: Vec<Link>,
}

impl LabelMap {
    /// The identity on `labels` (a network trained on the lab's own labels).
    pub fn identity(labels: &[Column]) -> Self {
        Self { links: labels.iter().map(|&c| Link::new(c, c, 1.0, 0.0)).collect() }
    }

    /// Chance: each of `labels` answered by the one constant that fits `real` best (the
    /// median; for a rotation, on the circle).
    pub fn constant(labels: &[Column], real: &[Pose]) -> Self {
        let zero = vec![Pose::default(); real.len()];
        Self { links: labels.iter().map(|&c| Link::new(c, c, 1.0, best_offset(c, c, 1.0, &zero, real))).collect() }
    }

    /// Fits the map from `predicted` (a simulator-trained network's readings, of the
    /// labels `sim`, of the lab's fitting images) to their lab labels `real` (same order) for
    /// the lab's labels `labels`; see the module documentation. Positions link to positions
    /// and rotations to rotations, one lab label to one simulated label where there are as
    /// many: of every such assignment, the one of least summed error, each label's error
    /// relative to its chance error (so that millimetres and degrees weigh alike).
    pub fn fit(predicted: &[Pose], sim: &[Column], real: &[Pose], labels: &[Column]) -> Result<Self> {
        if predicted.len() != real.len() || real.is_empty() {
            return Err(ModelError::Insufficient(format!(
                "a label map needs predictions for every fitting image: {} predictions, {} labels",
                predicted.len(),
                real.len()
            )));
        }
        let chance = Self::constant(labels, real).errors(&vec![Pose::default(); real.len()], real);
        let mut links: Vec<Option<Link>> = vec![None; labels.len()];
        for angle in [false, true] {
            let lab: Vec<usize> = (0..labels.len()).filter(|&k| labels[k].is_angle() == angle).collect();
            let cands: Vec<Column> = sim.iter().copied().filter(|c| c.is_angle() == angle).collect();
            if lab.is_empty() {
                continue;
            }
            if cands.is_empty() {
                return Err(ModelError::Insufficient(format!(
                    "the simulator-trained network reads no {} label to map the lab's {} onto",
                    if angle { "rotation" } else { "position" },
                    lab.iter().map(|&k| labels[k].name()).collect::<Vec<_>>().join(", ")
                )));
            }
            // The best link of every (lab, simulated) pair and its relative error.
            let best: Vec<Vec<(f64, Link)>> = lab
                .iter()
                .map(|&k| {
                    cands
                        .iter()
                        .map(|&s| {
                            [1.0, -1.0]
                                .into_iter()
                                .map(|sign| {
                                    let r = labels[k];
                                    let link = Link::new(r, s, sign, best_offset(r, s, sign, predicted, real));
                                    (mean_error(&link, predicted, real) / chance[k].max(1e-12), link)
                                })
                                .min_by(|a, b| a.0.total_cmp(&b.0))
                                .expect("two signs")
                        })
                        .collect()
                })
                .collect();
            let choice = assign(&best, cands.len() >= lab.len());
            for (i, &k) in lab.iter().enumerate() {
                links[k] = Some(best[i][choice[i]].1);
            }
        }
        Ok(Self { links: links.into_iter().map(|l| l.expect("every label assigned")).collect() })
    }

    /// Mean absolute error per link (mm or deg) of `predicted` through the map against the
    /// lab's labels `real` (same order).
    pub fn errors(&self, predicted: &[Pose], real: &[Pose]) -> Vec<f64> {
        self.links.iter().map(|l| mean_error(l, predicted, real)).collect()
    }

    /// The lab sensor's axis offset fitted into this map (see the module docs): each lateral
    /// link (simulated `pose_x` or `pose_y`) refitted as `offset + a cos(yaw) + b sin(yaw)` on
    /// `predicted` (the simulator-trained readings of the fitting images, with their yaw)
    /// against their lab labels `real`, of least mean absolute error (iteratively reweighted
    /// least squares from the link's offset). Unchanged where the readings carry no yaw, and
    /// where their yaws do not determine the terms: fewer than [`AXIS_OFFSET_MIN_SAMPLES`]
    /// samples, or `[1, cos, sin]` over them nearly dependent (the least eigenvalue of their
    /// mean outer product under [`AXIS_OFFSET_MIN_SPREAD`]: yaws bunched at one angle).
    pub fn with_axis_offset(mut self, predicted: &[Pose], real: &[Pose]) -> Self {
        let yawed = self.links.iter().any(|l| l.sim == Column::PoseRz);
        let terms: Vec<[f64; 3]> = predicted
            .iter()
            .map(|p| {
                let (s, c) = p.get(Column::PoseRz).to_radians().sin_cos();
                [1.0, c, s]
            })
            .collect();
        let spread = terms.iter().fold(nalgebra::Matrix3::<f64>::zeros(), |m, r| {
            let r = nalgebra::Vector3::from(*r);
            m + r * r.transpose()
        }) / terms.len().max(1) as f64;
        let determined = terms.len() >= AXIS_OFFSET_MIN_SAMPLES
            && spread.symmetric_eigenvalues().iter().copied().fold(f64::INFINITY, f64::min) >= AXIS_OFFSET_MIN_SPREAD;
        for l in self.links.iter_mut().filter(|l| determined && yawed && matches!(l.sim, Column::PoseX | Column::PoseY))
        {
            let rows: Vec<([f64; 3], f64)> = terms
                .iter()
                .zip(predicted.iter().zip(real))
                .map(|(r, (p, t))| (*r, t.get(l.real) - l.sign * p.get(l.sim)))
                .collect();
            let [offset, a, b] = least_absolute(&rows, [l.offset, 0.0, 0.0]);
            (l.offset, l.turning_mm) = (offset, [a, b]);
        }
        self
    }

    /// The simulated pose of a lab pose (labels the map does not name are 0): the rotations
    /// first, so that the lateral links' axis offset turns with the simulated yaw.
    pub fn sim_pose(&self, real: &Pose) -> Pose {
        let mut p = Pose::default();
        for angle in [true, false] {
            for l in self.links.iter().filter(|l| l.sim.is_angle() == angle) {
                p.set(l.sim, l.invert(real.get(l.real), p.get(Column::PoseRz)));
            }
        }
        p
    }

    /// One line per link, such as `lab pose_y (mm) = -sim pose_x (mm) + 0.12`.
    pub fn describe(&self) -> Vec<String> {
        self.links
            .iter()
            .map(|l| {
                let sign = |v: f64| if v < 0.0 { "-" } else { "+" };
                let turning = if no_turning(&l.turning_mm) {
                    String::new()
                } else {
                    let [a, b] = l.turning_mm;
                    format!(
                        " {} {:.2} cos(sim pose_Rz) {} {:.2} sin(sim pose_Rz) (the axis offset, {:.2} mm)",
                        sign(a),
                        a.abs(),
                        sign(b),
                        b.abs(),
                        a.hypot(b)
                    )
                };
                format!(
                    "lab {} = {}sim {} {} {:.2}{turning}",
                    label(l.real),
                    if l.sign < 0.0 { "-" } else { "" },
                    label(l.sim),
                    sign(l.offset),
                    l.offset.abs()
                )
            })
            .collect()
    }
}

/// The range a label's values cover: `lo..lo + width` (mm or deg); for a rotation the
/// shortest arc holding every value (its complement is the widest gap between neighbours on
/// the circle), so that -175 and 175 deg span 10 deg, not 350.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// Start (mm, or deg in -180..180).
    pub lo: f64,
    /// Width (mm or deg, 0..=360).
    pub width: f64,
}

impl Span {
    /// The span of `values` of label `c`; `None` when there are none.
    pub fn of(c: Column, values: &[f64]) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        let mut v: Vec<f64> = values.iter().map(|&x| if c.is_angle() { wrap_deg(x) } else { x }).collect();
        v.sort_by(f64::total_cmp);
        let (first, last) = (v[0], v[v.len() - 1]);
        if !c.is_angle() {
            return Some(Self { lo: first, width: last - first });
        }
        // The widest gap, the one across +-180 included; the span starts after it.
        let (mut gap, mut lo) = (first + 360.0 - last, first);
        for w in v.windows(2) {
            if w[1] - w[0] > gap {
                (gap, lo) = (w[1] - w[0], w[1]);
            }
        }
        Some(Self { lo, width: 360.0 - gap })
    }

    /// End (mm; deg in -180..180).
    pub fn hi(&self, c: Column) -> f64 {
        if c.is_angle() { wrap_deg(self.lo + self.width) } else { self.lo + self.width }
    }

    /// Whether `v` lies in the span (on the circle for a rotation).
    pub fn contains(&self, c: Column, v: f64) -> bool {
        if c.is_angle() {
            (v - self.lo).rem_euclid(360.0) <= self.width
        } else {
            v >= self.lo && v <= self.lo + self.width
        }
    }
}

/// The choice of column per row of `cost` (`cost[i][j].0`) of least sum, distinct columns
/// when `distinct` (exhaustive: a handful of labels).
fn assign<T>(cost: &[Vec<(f64, T)>], distinct: bool) -> Vec<usize> {
    fn go<T>(cost: &[Vec<(f64, T)>], distinct: bool, at: &mut Vec<usize>, best: &mut (f64, Vec<usize>), sum: f64) {
        if sum >= best.0 {
            return;
        }
        let i = at.len();
        if i == cost.len() {
            *best = (sum, at.clone());
            return;
        }
        for j in 0..cost[i].len() {
            if distinct && at.contains(&j) {
                continue;
            }
            at.push(j);
            go(cost, distinct, at, best, sum + cost[i][j].0);
            at.pop();
        }
    }
    let mut best = (f64::INFINITY, vec![0; cost.len()]);
    go(cost, distinct, &mut Vec::new(), &mut best, 0.0);
    best.1
}

/// The fewest samples [`LabelMap::with_axis_offset`] fits its three terms on.
pub const AXIS_OFFSET_MIN_SAMPLES: usize = 8;

/// The least eigenvalue of the mean of `[1, cos, sin]` of the yaws' outer products that
/// [`LabelMap::with_axis_offset`] fits on: yaws spread evenly over the whole turn give 0.5,
/// over 120 deg 0.0135, over 90 deg 0.0043, all at one angle 0.
pub const AXIS_OFFSET_MIN_SPREAD: f64 = 0.01;

/// The coefficients `x` of least `sum |y - r . x|` over `rows` `(r, y)`, by iteratively
/// reweighted least squares from `start` (weights `1 / max(|residual|, 1e-4)`, 50 rounds;
/// a round whose normal equations are singular keeps the last coefficients).
fn least_absolute(rows: &[([f64; 3], f64)], start: [f64; 3]) -> [f64; 3] {
    let mut x = start;
    for _ in 0..50 {
        let (mut m, mut v) = (nalgebra::Matrix3::<f64>::zeros(), nalgebra::Vector3::<f64>::zeros());
        for (r, y) in rows {
            let r = nalgebra::Vector3::from(*r);
            let w = 1.0 / (y - r.dot(&nalgebra::Vector3::from(x))).abs().max(1e-4);
            m += w * r * r.transpose();
            v += w * *y * r;
        }
        match m.lu().solve(&v) {
            Some(next) if next.iter().all(|c| c.is_finite()) => x = next.into(),
            _ => break,
        }
    }
    x
}

fn mean_error(link: &Link, predicted: &[Pose], real: &[Pose]) -> f64 {
    let sum: f64 =
        predicted.iter().zip(real).map(|(p, t)| difference(link.real, link.apply(p), t.get(link.real))).sum();
    sum / real.len().max(1) as f64
}

/// The offset of least mean absolute error: the median of the differences for a length; for an
/// angle, the best of a 0.5 deg grid over the circle, refined to the circular median of the
/// differences within 90 deg of it.
fn best_offset(real: Column, sim: Column, sign: f64, predicted: &[Pose], labels: &[Pose]) -> f64 {
    let mut d: Vec<f64> = predicted.iter().zip(labels).map(|(p, t)| t.get(real) - sign * p.get(sim)).collect();
    if !real.is_angle() {
        d.sort_by(f64::total_cmp);
        let n = d.len();
        return if n % 2 == 1 { d[n / 2] } else { 0.5 * (d[n / 2 - 1] + d[n / 2]) };
    }
    let cost = |o: f64| d.iter().map(|v| yaw_difference_deg(*v, o)).sum::<f64>();
    let coarse = (0..720).map(|k| -180.0 + 0.5 * k as f64).min_by(|a, b| cost(*a).total_cmp(&cost(*b))).unwrap_or(0.0);
    let mut near: Vec<f64> =
        d.iter().map(|v| coarse + wrap_deg(v - coarse)).filter(|v| (v - coarse).abs() <= 90.0).collect();
    if near.is_empty() {
        return coarse;
    }
    near.sort_by(f64::total_cmp);
    let m = near[near.len() / 2];
    wrap_deg(if cost(m) < cost(coarse) { m } else { coarse })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x_mm: f64, y_mm: f64, yaw_deg: f64) -> Pose {
        Pose::planar(x_mm, y_mm, yaw_deg)
    }

    const SIM: [Column; 3] = [Column::PoseX, Column::PoseY, Column::PoseRz];

    #[test]
    fn a_span_of_angles_takes_the_short_way_round() {
        let s = Span::of(Column::PoseRz, &[175.0, -175.0, 179.0]).expect("values");
        assert_eq!((s.lo, s.width), (175.0, 10.0));
        assert!((s.hi(Column::PoseRz) + 175.0).abs() < 1e-9);
        assert!(s.contains(Column::PoseRz, 180.0) && !s.contains(Column::PoseRz, 0.0));
        // The lab's edge yaws (-180..-62): one arc, not the whole turn.
        let lab = Span::of(Column::PoseRz, &[-180.0, -120.0, -62.0, 179.5]).expect("values");
        assert_eq!((lab.lo, lab.width), (179.5, 118.5));
        // A whole turn sampled every 30 deg spans 330.
        let turn: Vec<f64> = (0..12).map(|k| -180.0 + 30.0 * k as f64).collect();
        assert_eq!(Span::of(Column::PoseRz, &turn).expect("values").width, 330.0);
        let x = Span::of(Column::PoseX, &[2.0, -1.0, 0.5]).expect("values");
        assert_eq!((x.lo, x.width, x.hi(Column::PoseX)), (-1.0, 3.0, 2.0));
        assert!(x.contains(Column::PoseX, 2.0) && !x.contains(Column::PoseX, 2.1));
        assert_eq!(Span::of(Column::PoseX, &[]), None);
    }

    #[test]
    fn an_off_axis_sensors_turning_lateral_is_fitted_and_inverted() {
        // Lab: lateral = -sim x + 0.4 + 0.42 cos(yaw) + 0.05 sin(yaw) (mm, yaw the simulated
        // one), yaw reversed and 90 deg off; the readings carry a little noise and a few
        // wild lateral readings (a least-absolute fit is not pulled by them).
        let turning = |yaw: f64| 0.42 * yaw.to_radians().cos() + 0.05 * yaw.to_radians().sin();
        let sim: Vec<Pose> = (0..300)
            .map(|i| {
                let t = i as f64;
                pose(-6.0 + 12.0 * ((t * 0.618) % 1.0), 0.0, -180.0 + 360.0 * ((t * 0.377) % 1.0))
            })
            .collect();
        let real: Vec<Pose> = sim
            .iter()
            .map(|p| pose(0.0, -p.x_mm() + 0.4 + turning(p.yaw_deg()), wrap_deg(-p.yaw_deg() + 90.0)))
            .collect();
        let read: Vec<Pose> = sim
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let wild = if i % 50 == 0 { 3.0 } else { 0.0 };
                pose(p.x_mm() + 0.03 * ((i % 3) as f64 - 1.0) + wild, 0.0, p.yaw_deg())
            })
            .collect();
        let labels = [Column::PoseY, Column::PoseRz];
        let plain = LabelMap::fit(&read, &SIM, &real, &labels).expect("fit");
        assert_eq!(plain.links[0].turning_mm, [0.0, 0.0]);
        // Without the terms the map's JSON is the one written before they existed.
        let json = serde_json::to_string(&plain).expect("json");
        assert!(!json.contains("turning"), "{json}");
        let fitted = plain.clone().with_axis_offset(&read, &real);
        let lat = fitted.links[0];
        assert!((lat.offset - 0.4).abs() < 0.02, "{lat:?}");
        assert!((lat.turning_mm[0] - 0.42).abs() < 0.02 && (lat.turning_mm[1] - 0.05).abs() < 0.02, "{lat:?}");
        assert_eq!(fitted.links[1], plain.links[1], "the yaw's link is left alone");
        let (before, after) = (plain.errors(&read, &real)[0], fitted.errors(&read, &real)[0]);
        // After: the six wild readings' 3 mm (0.06 of the mean) and the noise (0.02).
        assert!(before > 0.25 && after < 0.085, "{before} -> {after}");
        assert!(fitted.describe()[0].contains("cos(sim pose_Rz)"), "{:?}", fitted.describe());
        // The inverse takes a lab pose back to the simulated one, the yaw first.
        let back = fitted.sim_pose(&real[11]);
        assert!((back.x_mm() - sim[11].x_mm()).abs() < 0.03, "{back:?} against {:?}", sim[11]);
        // Readings without a yaw leave the map as it is.
        let flat = [Column::PoseX];
        let lateral_only = LabelMap::fit(&read, &flat, &real, &[Column::PoseY]).expect("fit");
        assert_eq!(lateral_only.clone().with_axis_offset(&read, &real), lateral_only);
        // Too few samples, or yaws that do not spread over the turn, leave the map as it is
        // rather than fit three terms the yaws cannot tell apart.
        let few = AXIS_OFFSET_MIN_SAMPLES - 1;
        assert_eq!(plain.clone().with_axis_offset(&read[..few], &real[..few]), plain);
        let bunched: Vec<Pose> = read.iter().map(|p| pose(p.x_mm(), 0.0, 30.0 + (p.yaw_deg() / 180.0))).collect();
        assert_eq!(plain.clone().with_axis_offset(&bunched, &real), plain);
    }

    #[test]
    fn a_flipped_swapped_shifted_frame_is_recovered() {
        // Lab frame: lateral in y with the opposite sign, 0.4 mm off; yaw reversed and 90 deg
        // off. The predictions are the simulated labels with a little noise; the simulated y
        // is read too, but noise only.
        let sim: Vec<Pose> = (0..200)
            .map(|i| {
                let t = i as f64;
                pose(-6.0 + 12.0 * ((t * 0.618) % 1.0), 0.0, -180.0 + 360.0 * ((t * 0.377) % 1.0))
            })
            .collect();
        let real: Vec<Pose> = sim.iter().map(|p| pose(0.0, -p.x_mm() + 0.4, wrap_deg(-p.yaw_deg() + 90.0))).collect();
        let noisy: Vec<Pose> = sim
            .iter()
            .enumerate()
            .map(|(i, p)| {
                pose(
                    p.x_mm() + 0.05 * ((i % 3) as f64 - 1.0),
                    0.3 * ((i % 7) as f64 - 3.0),
                    p.yaw_deg() + ((i % 5) as f64 - 2.0),
                )
            })
            .collect();
        let labels = [Column::PoseY, Column::PoseRz];
        let map = LabelMap::fit(&noisy, &SIM, &real, &labels).expect("fit");
        assert_eq!(map.links.len(), 2, "{map:?}");
        let (lat, yaw) = (map.links[0], map.links[1]);
        assert_eq!((lat.real, lat.sim, lat.sign), (Column::PoseY, Column::PoseX, -1.0));
        assert!((lat.offset - 0.4).abs() < 0.06, "{lat:?}");
        assert_eq!((yaw.real, yaw.sim, yaw.sign), (Column::PoseRz, Column::PoseRz, -1.0));
        assert!(yaw_difference_deg(yaw.offset, 90.0) < 1.5, "{yaw:?}");
        let e = map.errors(&noisy, &real);
        assert!(e[0] < 0.05 && e[1] < 1.5, "{e:?}");
        // The inverse takes a lab pose back to the simulated one.
        let back = map.sim_pose(&real[7]);
        assert!(
            (back.x_mm() - sim[7].x_mm()).abs() < 0.06 && yaw_difference_deg(back.yaw_deg(), sim[7].yaw_deg()) < 1.5
        );
    }

    /// Two lab labels that the simulated readings fit alike (both near one simulated label)
    /// must not both take it: the assignment is one to one, of least summed relative error.
    #[test]
    fn two_lab_labels_never_share_one_simulated_label() {
        let n = 120;
        let sim: Vec<Pose> = (0..n)
            .map(|i| {
                let mut p = Pose::default();
                p.set(Column::PoseZ, 1.0 + 4.0 * ((i as f64 * 0.618) % 1.0));
                p.set(Column::ShearX, -5.0 + 10.0 * ((i as f64 * 0.377) % 1.0));
                p
            })
            .collect();
        // The lab's depth is the simulated depth + 2 mm; its slide x follows the simulated
        // depth more than the simulated slide x, so each lab label alone would take depth.
        let real: Vec<Pose> = sim
            .iter()
            .map(|p| {
                let mut q = Pose::default();
                q.set(Column::PoseZ, p.get(Column::PoseZ) + 2.0);
                q.set(Column::ShearX, p.get(Column::PoseZ) - 0.3 * p.get(Column::ShearX));
                q
            })
            .collect();
        let labels = [Column::PoseZ, Column::ShearX];
        let alone = LabelMap::fit(&sim, &[Column::PoseZ], &real, &labels[1..]).expect("fit");
        let both = LabelMap::fit(&sim, &labels, &real, &labels[1..]).expect("fit");
        assert_eq!((alone.links[0].sim, both.links[0].sim), (Column::PoseZ, Column::PoseZ), "{both:?}");
        let map = LabelMap::fit(&sim, &labels, &real, &labels).expect("fit");
        let sims: Vec<Column> = map.links.iter().map(|l| l.sim).collect();
        assert_eq!(sims, vec![Column::PoseZ, Column::ShearX], "{map:?}");
        assert_eq!(map.links[1].sign, -1.0);
        assert!((map.links[0].offset - 2.0).abs() < 1e-9);
    }

    #[test]
    fn predictions_at_chance_give_chance_errors() {
        // A network that says the same for every image: the best offset cannot make it right.
        let real: Vec<Pose> = (0..100).map(|i| pose(0.0, -6.0 + 0.12 * i as f64, -180.0 + 3.6 * i as f64)).collect();
        let flat = vec![pose(0.0, 0.0, 0.0); 100];
        let labels = [Column::PoseY, Column::PoseRz];
        let map = LabelMap::fit(&flat, &SIM, &real, &labels).expect("fit");
        let e = map.errors(&flat, &real);
        assert!(
            (e[0] - 3.0).abs() < 0.1 && (e[1] - 90.0).abs() < 2.0,
            "uniform labels: 3 mm and 90 deg at chance, {e:?}"
        );
        let chance = LabelMap::constant(&labels, &real).errors(&flat, &real);
        assert!((chance[0] - e[0]).abs() < 1e-9 && (chance[1] - e[1]).abs() < 1.0, "{chance:?} {e:?}");
    }

    #[test]
    fn an_empty_or_uneven_fit_is_an_error() {
        assert!(LabelMap::fit(&[], &SIM, &[], &[Column::PoseX]).is_err());
        assert!(LabelMap::fit(&[pose(0.0, 0.0, 0.0)], &SIM, &[], &[Column::PoseX]).is_err());
        let e = LabelMap::fit(&[pose(0.0, 0.0, 0.0)], &[Column::PoseX], &[pose(0.0, 0.0, 5.0)], &[Column::PoseRz]);
        assert!(e.is_err_and(|e| e.to_string().contains("no rotation label")));
    }
}
