//! Sim-to-real label maps: how the labels of a simulated dataset relate to a lab's.
//!
//! A lab's labels are given in its rig's frame (which side of an edge is positive, where yaw 0
//! points, which column is the lateral offset), a simulated dataset's in the recipe's frame.
//! The two agree up to a choice of component, a sign and an offset, which the lab's data
//! fixes: a pose network trained on simulated images reads the lab's fitting part, and for
//! every lab label that varies the map takes the simulated component and sign whose
//! predictions, after the best offset, are nearest the lab's labels (least mean absolute
//! error; for a yaw, on the circle). No scale is fitted: a network that reads magnitudes wrong
//! must show it in the error.
//!
//! `real = sign * sim + offset` (mm, or deg modulo 360 for the yaw).

use serde::{Deserialize, Serialize};

use crate::error::{ModelError, Result};
use crate::eval::yaw_difference_deg;
use crate::posenet::Pose;

/// A component of a [`Pose`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Component {
    /// x (mm).
    X,
    /// y (mm).
    Y,
    /// Yaw (deg).
    Yaw,
}

impl Component {
    /// Every component.
    pub const ALL: [Component; 3] = [Component::X, Component::Y, Component::Yaw];

    /// The component's value in `p`.
    pub fn of(self, p: &Pose) -> f64 {
        match self {
            Component::X => p.x_mm,
            Component::Y => p.y_mm,
            Component::Yaw => p.yaw_deg,
        }
    }

    /// `p` with the component set to `v`.
    pub fn set(self, p: &mut Pose, v: f64) {
        match self {
            Component::X => p.x_mm = v,
            Component::Y => p.y_mm = v,
            Component::Yaw => p.yaw_deg = v,
        }
    }

    /// Name with unit, as in reports.
    pub fn label(self) -> &'static str {
        match self {
            Component::X => "x (mm)",
            Component::Y => "y (mm)",
            Component::Yaw => "yaw (deg)",
        }
    }

    fn is_angle(self) -> bool {
        self == Component::Yaw
    }

    /// Absolute difference (mm or deg): plain, or on the circle for the yaw.
    pub fn difference(self, a: f64, b: f64) -> f64 {
        if self.is_angle() { yaw_difference_deg(a, b) } else { (a - b).abs() }
    }
}

/// One lab label and the simulated component it is read from: `real = sign * sim + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Link {
    /// The lab's component.
    pub real: Component,
    /// The simulated component.
    pub sim: Component,
    /// +1 or -1.
    pub sign: f64,
    /// Offset (mm or deg).
    pub offset: f64,
}

impl Link {
    /// The lab's value of the simulated pose `p`.
    pub fn apply(&self, p: &Pose) -> f64 {
        let v = self.sign * self.sim.of(p) + self.offset;
        if self.real.is_angle() { wrap_deg(v) } else { v }
    }

    /// The simulated value of the lab's value `v` (inverse of [`Self::apply`]).
    pub fn invert(&self, v: f64) -> f64 {
        let s = self.sign * (v - self.offset);
        if self.sim.is_angle() { wrap_deg(s) } else { s }
    }
}

/// The map from a simulated dataset's labels to a lab's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelMap {
    /// One link per lab label that varies.
    pub links: Vec<Link>,
}

/// Labels whose spread is below this (mm or deg) are constant: not mapped, not scored.
const CONSTANT_SPREAD: f64 = 1e-6;

/// The lab's components that vary over `real`.
pub fn varying(real: &[Pose]) -> Vec<Component> {
    Component::ALL
        .into_iter()
        .filter(|c| {
            let lo = real.iter().map(|p| c.of(p)).fold(f64::INFINITY, f64::min);
            let hi = real.iter().map(|p| c.of(p)).fold(f64::NEG_INFINITY, f64::max);
            hi - lo > CONSTANT_SPREAD
        })
        .collect()
}

impl LabelMap {
    /// The identity on the varying components of `real` (a network trained on the lab's own
    /// labels).
    pub fn identity(real: &[Pose]) -> Self {
        Self { links: varying(real).into_iter().map(|c| Link { real: c, sim: c, sign: 1.0, offset: 0.0 }).collect() }
    }

    /// Fits the map from `predicted` (a simulator-trained network's poses of the lab's fitting
    /// images) to their lab labels `real` (same order); see the module documentation. The
    /// yaw links to the yaw, x and y to either of x and y.
    pub fn fit(predicted: &[Pose], real: &[Pose]) -> Result<Self> {
        if predicted.len() != real.len() || real.is_empty() {
            return Err(ModelError::Insufficient(format!(
                "a label map needs predictions for every fitting image: {} predictions, {} labels",
                predicted.len(),
                real.len()
            )));
        }
        let links = varying(real)
            .into_iter()
            .map(|r| {
                let sims: &[Component] = if r.is_angle() { &[Component::Yaw] } else { &[Component::X, Component::Y] };
                let mut best: Option<(f64, Link)> = None;
                for &sim in sims {
                    for sign in [1.0, -1.0] {
                        let link = Link { real: r, sim, sign, offset: best_offset(r, sim, sign, predicted, real) };
                        let e = mean_error(&link, predicted, real);
                        if best.as_ref().is_none_or(|(b, _)| e < *b) {
                            best = Some((e, link));
                        }
                    }
                }
                best.map(|(_, l)| l).expect("at least one candidate")
            })
            .collect();
        Ok(Self { links })
    }

    /// Mean absolute error per link (mm or deg) of `predicted` through the map against the
    /// lab's labels `real` (same order).
    pub fn errors(&self, predicted: &[Pose], real: &[Pose]) -> Vec<f64> {
        self.links.iter().map(|l| mean_error(l, predicted, real)).collect()
    }

    /// The simulated pose of a lab pose (components the map does not name are 0).
    pub fn sim_pose(&self, real: &Pose) -> Pose {
        let mut p = Pose { x_mm: 0.0, y_mm: 0.0, yaw_deg: 0.0 };
        for l in &self.links {
            l.sim.set(&mut p, l.invert(l.real.of(real)));
        }
        p
    }

    /// One line per link, such as `lab y (mm) = -1 x sim x (mm) + 0.12`.
    pub fn describe(&self) -> Vec<String> {
        self.links
            .iter()
            .map(|l| {
                format!(
                    "lab {} = {}sim {} {} {:.2}",
                    l.real.label(),
                    if l.sign < 0.0 { "-" } else { "" },
                    l.sim.label(),
                    if l.offset < 0.0 { "-" } else { "+" },
                    l.offset.abs()
                )
            })
            .collect()
    }
}

fn mean_error(link: &Link, predicted: &[Pose], real: &[Pose]) -> f64 {
    let sum: f64 = predicted.iter().zip(real).map(|(p, t)| link.real.difference(link.apply(p), link.real.of(t))).sum();
    sum / real.len().max(1) as f64
}

/// Angle in `(-180, 180]` (deg).
fn wrap_deg(v: f64) -> f64 {
    let w = v.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// The offset of least mean absolute error: the median of the differences for a length; for an
/// angle, the best of a 0.5 deg grid over the circle, refined to the circular median of the
/// differences within 90 deg of it.
fn best_offset(real: Component, sim: Component, sign: f64, predicted: &[Pose], labels: &[Pose]) -> f64 {
    let mut d: Vec<f64> = predicted.iter().zip(labels).map(|(p, t)| real.of(t) - sign * sim.of(p)).collect();
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
        Pose { x_mm, y_mm, yaw_deg }
    }

    #[test]
    fn a_flipped_swapped_shifted_frame_is_recovered() {
        // Lab frame: lateral in y with the opposite sign, 0.4 mm off; yaw reversed and 90 deg
        // off. The predictions are the simulated labels with a little noise.
        let sim: Vec<Pose> = (0..200)
            .map(|i| {
                let t = i as f64;
                pose(-6.0 + 12.0 * ((t * 0.618) % 1.0), 0.0, -180.0 + 360.0 * ((t * 0.377) % 1.0))
            })
            .collect();
        let real: Vec<Pose> = sim.iter().map(|p| pose(0.0, -p.x_mm + 0.4, wrap_deg(-p.yaw_deg + 90.0))).collect();
        let noisy: Vec<Pose> = sim
            .iter()
            .enumerate()
            .map(|(i, p)| pose(p.x_mm + 0.05 * ((i % 3) as f64 - 1.0), 0.0, p.yaw_deg + ((i % 5) as f64 - 2.0)))
            .collect();
        let map = LabelMap::fit(&noisy, &real).expect("fit");
        assert_eq!(map.links.len(), 2, "x is constant in the lab's labels: {map:?}");
        let (lat, yaw) = (map.links[0], map.links[1]);
        assert_eq!((lat.real, lat.sim, lat.sign), (Component::Y, Component::X, -1.0));
        assert!((lat.offset - 0.4).abs() < 0.06, "{lat:?}");
        assert_eq!((yaw.real, yaw.sim, yaw.sign), (Component::Yaw, Component::Yaw, -1.0));
        assert!(yaw_difference_deg(yaw.offset, 90.0) < 1.5, "{yaw:?}");
        let e = map.errors(&noisy, &real);
        assert!(e[0] < 0.05 && e[1] < 1.5, "{e:?}");
        // The inverse takes a lab pose back to the simulated one.
        let back = map.sim_pose(&real[7]);
        assert!((back.x_mm - sim[7].x_mm).abs() < 0.06 && yaw_difference_deg(back.yaw_deg, sim[7].yaw_deg) < 1.5);
    }

    #[test]
    fn predictions_at_chance_give_chance_errors() {
        // A network that says the same for every image: the best offset cannot make it right.
        let real: Vec<Pose> = (0..100).map(|i| pose(0.0, -6.0 + 0.12 * i as f64, -180.0 + 3.6 * i as f64)).collect();
        let flat = vec![pose(0.0, 0.0, 0.0); 100];
        let map = LabelMap::fit(&flat, &real).expect("fit");
        let e = map.errors(&flat, &real);
        assert!(
            (e[0] - 3.0).abs() < 0.1 && (e[1] - 90.0).abs() < 2.0,
            "uniform labels: 3 mm and 90 deg at chance, {e:?}"
        );
    }

    #[test]
    fn an_empty_or_uneven_fit_is_an_error() {
        assert!(LabelMap::fit(&[], &[]).is_err());
        assert!(LabelMap::fit(&[pose(0.0, 0.0, 0.0)], &[]).is_err());
    }
}
