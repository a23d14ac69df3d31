//! Perception: the sensor's pose relative to the edge under it, as the servo needs it.

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tacsim_data::wrap_deg;
use tacsim_sim::{ObjectId, Scene, SensorPose};

use crate::scenario::Noise;

/// The pose relative to the edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeEstimate {
    /// Distance of the sensor centre from the edge along its normal (mm), positive off the
    /// material.
    pub offset_mm: f64,
    /// Angle of the edge tangent (material on its left) from the sensor's `x` axis (deg, in
    /// `(-180, 180]`).
    pub angle_deg: f64,
}

/// The true pose relative to the edge of `object`, from the shape's geometry.
pub fn oracle(scene: &Scene, object: ObjectId, pose: &SensorPose) -> EdgeEstimate {
    let e = scene.edge(object, pose.x_mm, pose.y_mm);
    let tangent_deg = e.tangent[1].atan2(e.tangent[0]).to_degrees();
    EdgeEstimate { offset_mm: e.signed_distance_mm, angle_deg: wrap_deg(tangent_deg - pose.yaw_deg) }
}

/// Seeded Gaussian noise and latency on estimates.
#[derive(Clone, Debug)]
pub struct Corruption {
    noise: Noise,
    rng: ChaCha8Rng,
    queue: VecDeque<EdgeEstimate>,
}

impl Corruption {
    /// Noise and latency of `noise`, seeded.
    pub fn new(noise: &Noise, seed: u64) -> Self {
        Self { noise: noise.clone(), rng: ChaCha8Rng::seed_from_u64(seed), queue: VecDeque::new() }
    }

    fn gauss(&mut self) -> f64 {
        // Box-Muller.
        let u1: f64 = self.rng.random::<f64>().max(f64::MIN_POSITIVE);
        let u2: f64 = self.rng.random();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// The estimate the servo sees this step: `fresh` plus noise, `latency_steps` late (the
    /// first estimates are repeated until the queue fills).
    pub fn apply(&mut self, fresh: EdgeEstimate) -> EdgeEstimate {
        let noisy = EdgeEstimate {
            offset_mm: fresh.offset_mm + self.noise.offset_mm * self.gauss(),
            angle_deg: wrap_deg(fresh.angle_deg + self.noise.angle_deg * self.gauss()),
        };
        self.queue.push_back(noisy);
        while self.queue.len() > self.noise.latency_steps + 1 {
            self.queue.pop_front();
        }
        self.queue.front().copied().unwrap_or(noisy)
    }
}

/// Model-free edge estimate from the sensor's image, against the sensor's own flat press.
///
/// At start-up the contact engine presses the sensor onto a flat face at the scenario's depth
/// (the reference press, [`crate::run::reference_press`]); its image gives each pin's
/// full-contact spread `D_i` (the template). Each image is then read in three stages:
/// `Geometric::track` finds the pins (detection, then the tracker of `tacsim_sim::tracking`
/// from the undeformed image, which follows presses and slides that move pins by most of a
/// spacing); `Geometric::spread` takes each pin's local spread `m_i` (`det F - 1`, `F` the
/// least-squares linear map of its six undeformed neighbours' offsets onto their tracked ones:
/// pins pressed towards the camera spread apart, while a shear, as along the side of a dragged
/// contact, keeps the area); `fit_edge` finds the straight edge, inward normal `n` and offset
/// `h` (mm) with the material where `n . r > h` (`r` a pin's rest position), whose template
/// best explains the spreads:
///
/// `min over (n, h) of sum_i (m_i - D_i s((n . r_i - h) / w))^2`, `s` the logistic step and
/// `w` = `EDGE_WIDTH_MM`.
///
/// The template carries what hand-chosen thresholds could not: how far this sensor's contact
/// reaches at this depth and how much each pin spreads in it (a compressible skin with long
/// pins spreads its contact pins far more, over a smaller patch, than the camera-only fit).
#[derive(Clone, Debug)]
pub struct Geometric {
    renderer: tacsim_sim::PinRenderer,
    reference_px: Vec<[f64; 2]>,
    /// Rest position (contact-plane mm, sensor frame) of each reference pin.
    rest_mm: Vec<Option<[f64; 2]>>,
    spacing_px: f64,
    /// The six nearest reference pins of each reference pin.
    neighbours: Vec<Vec<usize>>,
    /// Where each reference pin was last seen (px); `None` where the tracker lost it.
    last: Vec<Option<[f64; 2]>>,
    /// The tracker's global shift of the last image (px), its start for the next one.
    shift: [f64; 2],
    /// The reference press: (reference pin, rest position in mm, full-contact spread) of the
    /// pins that spread by more than `NO_CONTACT` in it.
    template: Vec<(usize, [f64; 2], f64)>,
    /// Largest rest distance of a template pin from the apex (mm): the contact's reach.
    reach_mm: f64,
    /// The reference pins perception tracks: those near the contact (all while empty).
    watched: Vec<usize>,
    /// The undeformed Voronoi tessellation, for the contact patch.
    geometry: crate::contact_geometry::ContactGeometry,
    /// The edge of the latest estimate: inward normal (contact-plane, sensor frame) and the
    /// edge's distance from the apex along it (mm), tared.
    edge: Option<([f64; 2], f64)>,
    /// The tare ([`Geometric::tare`]): subtracted from every offset (mm) and angle (deg) read.
    zero: (f64, f64),
}

/// Width of the edge's soft step in the template fit (mm): about a third of the pin pitch.
/// The skin bends over an edge, so the pins next to it spread part way; on the disk and the
/// clover with the calibrated sensor, 0.3-0.8 mm read the offset within 0.24-0.38 mm.
pub const EDGE_WIDTH_MM: f64 = 0.5;

/// The contact patch read off the pins' Voronoi cells: the skin touches where the cells grew
/// (`A / A0 - 1`) by more than this share of the largest growth in the image...
const TOUCH_SHARE: f64 = 0.65;
/// ...and is free where they grew by less than this share; between, undecided. Chosen on the
/// 7 geometric scenarios (IoU of the pins' footprint): single thresholds either took the free
/// skin bent over the edge for contact (a band about 1-2 mm wide, IoU 0.83-0.96) or the
/// faint rim of the contact for free skin, which emptied the interior (IoU below 0.2).
const FREE_SHARE: f64 = 0.12;

/// The straight edge whose template best explains the spreads (the sum of squares of
/// [`Geometric`]): `template` holds (rest position mm, full-contact spread, this image's
/// spread) per pin. Returns the inward normal and the offset `h` (mm): a coarse search over
/// normals every 6 deg and offsets every 0.2 mm within `reach_mm + 1`, refined twice, to 0.1
/// deg and 0.005 mm.
pub fn fit_edge(template: &[([f64; 2], f64, f64)], reach_mm: f64) -> ([f64; 2], f64) {
    let cost = |deg: f64, h: f64| {
        let (s, c) = deg.to_radians().sin_cos();
        template
            .iter()
            .map(|(r, d, m)| {
                let u = (c * r[0] + s * r[1] - h) / EDGE_WIDTH_MM;
                (m - d / (1.0 + (-u).exp())).powi(2)
            })
            .sum::<f64>()
    };
    // (cost, deg, h) of the best of a grid of `na` x `nh` steps of `da` deg and `dh` mm
    // about `(deg, h)`.
    let search = |best: (f64, f64, f64), na: i32, da: f64, nh: i32, dh: f64| {
        let (_, deg0, h0) = best;
        let mut best = best;
        for a in -na..=na {
            for k in -nh..=nh {
                let (deg, h) = (deg0 + da * f64::from(a), h0 + dh * f64::from(k));
                let c = cost(deg, h);
                if c < best.0 {
                    best = (c, deg, h);
                }
            }
        }
        best
    };
    let span = reach_mm + 1.0;
    let nh = (span / 0.2).ceil() as i32;
    let coarse = search((f64::INFINITY, 180.0, 0.0), 30, 6.0, nh, 0.2);
    let (_, deg, h) = search(search(coarse, 12, 0.5, 10, 0.02), 5, 0.1, 5, 0.005);
    ([deg.to_radians().cos(), deg.to_radians().sin()], h)
}

impl Geometric {
    /// Perception for `sensor` rendering at `size` px, with the pins of its reference press
    /// `press` (a flat face at the scenario's depth, [`crate::run::reference_press`]).
    pub fn new(sensor: &tacsim_sim::SensorParams, size: u32, press: &[tacsim_sim::PinPose]) -> crate::Result<Self> {
        use tacsim_sim::PinLayout;
        let renderer = tacsim_sim::PinRenderer::new(sensor, size)?;
        let layout = PinLayout::new(sensor);
        let reference_px = tacsim_sim::pin_centres(&renderer.render(&layout.poses()));
        let spacing_px = 17.5 * size as f64 / 420.0;
        // Rest positions: the layout pin whose projected tip is nearest each detected pin.
        let rest_mm: Vec<Option<[f64; 2]>> =
            tacsim_sim::match_reference(&renderer, &layout.poses(), &reference_px, spacing_px)
                .into_iter()
                .map(|m| m.map(|i| [layout.pins[i].base.x, layout.pins[i].base.y]))
                .collect();
        let neighbours = tacsim_sim::nearest_neighbours(&reference_px, 6);
        let last = reference_px.iter().map(|p| Some(*p)).collect();
        let geometry = crate::contact_geometry::ContactGeometry::new(&reference_px, spacing_px);
        let mut g = Self {
            renderer,
            reference_px,
            rest_mm,
            spacing_px,
            neighbours,
            last,
            shift: [0.0; 2],
            template: Vec::new(),
            reach_mm: 0.0,
            watched: Vec::new(),
            geometry,
            edge: None,
            zero: (0.0, 0.0),
        };
        let img = g.render(press);
        let tracked = g.track(&img, [0.0; 2]).0;
        g.template = g
            .spread(&tracked)
            .iter()
            .zip(&g.rest_mm)
            .enumerate()
            .filter_map(|(i, (m, r))| Some((i, (*r)?, (*m)?)).filter(|t| t.2 > crate::contact_geometry::NO_CONTACT))
            .collect();
        g.reach_mm = g.template.iter().fold(0.0f64, |m, (_, r, _)| m.max(r[0].hypot(r[1])));
        // From here on only the pins within two pitches of the contact's reach are tracked:
        // the assignment's cost grows with the cube of the pins (about 8x faster).
        // The pitch: the first ring's distance from the centre pin.
        let pitch_mm =
            g.rest_mm.iter().flatten().map(|r| r[0].hypot(r[1])).filter(|d| *d > 1e-6).fold(f64::INFINITY, f64::min);
        g.watched = (0..g.reference_px.len())
            .filter(|&i| g.rest_mm[i].is_some_and(|r| r[0].hypot(r[1]) <= g.reach_mm + 2.0 * pitch_mm))
            .collect();
        if g.template.len() < 3 {
            return Err(crate::ExploreError::scenario(
                "field `depth_mm`",
                format!("the reference press spread {} pins (at least 3 needed): press deeper", g.template.len()),
            ));
        }
        Ok(g)
    }

    /// The contact patch of the image of the latest estimate: whether the skin touches at
    /// each of `points` (contact-plane mm, sensor frame), from the tracked pins' Voronoi
    /// cells (`contact_geometry.rs`, thresholds `TOUCH_SHARE` and `FREE_SHARE`);
    /// `None` where undecided. Free skin on the material's side of the estimated edge is
    /// undecided too: with the dome wholly on the material the indentation fades towards the
    /// rim of the contact as it does towards an edge, and reading that rim as "no material"
    /// punched holes into the footprint (the foil's IoU was 0.894 with it, 0.912 without).
    /// Points on the free side of the estimated (tared) edge, beyond its soft width and within
    /// the reference press's reach, are free skin whatever their cells say: the skin bent over
    /// the edge grows cells there.
    pub fn touching(&self, points: &[[f64; 2]]) -> Vec<Option<bool>> {
        let mut t = crate::contact_geometry::touching(
            &self.geometry.indentation(&self.last, &self.rest_mm),
            FREE_SHARE,
            TOUCH_SHARE,
            points,
        );
        if let Some((n, h)) = self.edge {
            for (t, q) in t.iter_mut().zip(points) {
                let s = n[0] * q[0] + n[1] * q[1] - h;
                if *t == Some(false) && s > 0.0 {
                    *t = None;
                } else if s < -EDGE_WIDTH_MM && q[0].hypot(q[1]) <= self.reach_mm {
                    *t = Some(false);
                }
            }
        }
        t
    }

    /// The image of `pins` as this perception sees it.
    pub fn render(&self, pins: &[tacsim_sim::PinPose]) -> image::GrayImage {
        self.renderer.render(pins)
    }

    /// The estimate from the current pins; `None` when no pin shows contact.
    pub fn estimate(&mut self, pins: &[tacsim_sim::PinPose]) -> Option<EdgeEstimate> {
        let img = self.render(pins);
        self.estimate_image(&img)
    }

    /// Where each reference pin is in `img` (px; `None` where lost) and the tracker's global
    /// shift, tracking from the undeformed pins with the shift `start` as the first guess.
    /// Only the pins of `self.watched` are tracked (all of them while it is empty); the others
    /// are `None`.
    fn track(&self, img: &image::GrayImage, start: [f64; 2]) -> (Vec<Option<[f64; 2]>>, [f64; 2]) {
        use tacsim_sim::{Warp, track};
        let detected = tacsim_sim::pin_centres(img);
        let all: Vec<usize> = (0..self.reference_px.len()).collect();
        let which = if self.watched.is_empty() { &all } else { &self.watched };
        let reference: Vec<[f64; 2]> = which.iter().map(|&i| self.reference_px[i]).collect();
        let t = track(&reference, &detected, self.spacing_px, &Warp::shift(start));
        let mut at = vec![None; self.reference_px.len()];
        for ((&i, d), r) in which.iter().zip(&t.displacement).zip(&reference) {
            at[i] = d.map(|d| [r[0] + d[0], r[1] + d[1]]);
        }
        (at, t.global_shift)
    }

    /// Each reference pin's local spread in the tracked positions `at`: `det F - 1` (at least
    /// 0), `F` the least-squares linear map of the offsets to its tracked undeformed
    /// neighbours (at least 3) from their undeformed ones (px). A drag moves a neighbourhood
    /// without spreading it, and a shear keeps its area.
    fn spread(&self, at: &[Option<[f64; 2]>]) -> Vec<Option<f64>> {
        self.neighbours
            .iter()
            .enumerate()
            .map(|(i, nb)| {
                let pi = at[i]?;
                let r = self.reference_px[i];
                // Least-squares local map F: current offsets = F reference offsets.
                let (mut xx, mut yx, mut n) = ([[0.0f64; 2]; 2], [[0.0f64; 2]; 2], 0);
                for &j in nb {
                    if let Some(pj) = at[j] {
                        let x = [self.reference_px[j][0] - r[0], self.reference_px[j][1] - r[1]];
                        let y = [pj[0] - pi[0], pj[1] - pi[1]];
                        for a in 0..2 {
                            for b in 0..2 {
                                xx[a][b] += x[a] * x[b];
                                yx[a][b] += y[a] * x[b];
                            }
                        }
                        n += 1;
                    }
                }
                if n < 3 {
                    return None;
                }
                let det_xx = xx[0][0] * xx[1][1] - xx[0][1] * xx[1][0];
                let det_yx = yx[0][0] * yx[1][1] - yx[0][1] * yx[1][0];
                (det_xx > 0.0).then(|| (det_yx / det_xx - 1.0).max(0.0))
            })
            .collect()
    }

    /// [`Geometric::estimate`] from the current pins' image ([`Geometric::render`]).
    pub fn estimate_image(&mut self, img: &image::GrayImage) -> Option<EdgeEstimate> {
        let (at, shift) = self.track(img, self.shift);
        (self.last, self.shift) = (at, shift);
        self.edge = None;
        let m = self.spread(&self.last);
        // Template pins the tracker lost say nothing (they are skipped, not guessed).
        let pins: Vec<([f64; 2], f64, f64)> =
            self.template.iter().filter_map(|(i, r, d)| m[*i].map(|m| (*r, *d, m))).collect();
        if !pins.iter().any(|p| p.2 > crate::contact_geometry::NO_CONTACT) {
            return None;
        }
        let (n, h) = fit_edge(&pins, self.reach_mm);
        // With every template pin on the material the normal is undetermined: no turn.
        let raw_deg = if h <= -self.reach_mm {
            self.zero.1
        } else {
            // Inward normal (towards the material), sensor frame; the sensor frame's y is
            // world -y at zero yaw, so angles in the contact plane are measured with y flipped.
            (-n[1]).atan2(n[0]).to_degrees() - 90.0
        };
        let e = EdgeEstimate { offset_mm: h - self.zero.0, angle_deg: wrap_deg(raw_deg - self.zero.1) };
        let normal = (e.angle_deg + 90.0).to_radians();
        self.edge = Some(([normal.cos(), -normal.sin()], e.offset_mm));
        Some(e)
    }

    /// Takes the mean error of the estimates from `taps`, each the pins of a press whose true
    /// pose relative to the edge is known, as the zero of every later estimate, as a robot
    /// would tare at a known start: the straight edge of the fit sits off where the contact
    /// ends (the skin bends over it), by an amount that swings by up to a millimetre with
    /// where the edge falls among the contact's cells and the pins (on the default sensor at
    /// 1.5 mm, a sawtooth of 0.6-0.7 mm period across the edge), so one tap's error is a
    /// poor zero; several across the edge are averaged ([`crate::run`]'s taps span three
    /// periods). Returns the tare (offset mm, angle deg); none where no tap shows contact.
    pub fn tare(&mut self, taps: &[(Vec<tacsim_sim::PinPose>, EdgeEstimate)]) -> (f64, f64) {
        self.zero = (0.0, 0.0);
        let errors: Vec<(f64, f64)> = taps
            .iter()
            .filter_map(|(pins, known)| {
                let e = self.estimate(pins)?;
                Some((e.offset_mm - known.offset_mm, wrap_deg(e.angle_deg - known.angle_deg)))
            })
            .collect();
        if !errors.is_empty() {
            let n = errors.len() as f64;
            self.zero = (errors.iter().map(|e| e.0).sum::<f64>() / n, errors.iter().map(|e| e.1).sum::<f64>() / n);
        }
        self.zero
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pins of a hexagonal lattice (pitch 1.5 mm) within `r` mm, with a Hertz-like full-contact
    /// spread `1 - (r / a)^2` inside `a` = 4.5 mm.
    fn template() -> Vec<([f64; 2], f64)> {
        let mut out = Vec::new();
        for j in -4..=4 {
            for i in -4..=4 {
                let p = [1.5 * (f64::from(i) + 0.5 * f64::from(j)), 1.5 * f64::from(j) * 3f64.sqrt() / 2.0];
                let d = 1.0 - (p[0] * p[0] + p[1] * p[1]) / 4.5f64.powi(2);
                if d > 0.02 {
                    out.push((p, 0.3 * d));
                }
            }
        }
        out
    }

    #[test]
    fn fit_edge_finds_a_straight_edge_cut_through_the_template() {
        // The image of a press cut by an edge with inward normal at `deg` and offset `h`, made
        // by the fit's own model (each pin its template share times the soft step): the
        // search must find the global minimum, the edge itself, wherever it lies (a coarse
        // grid alone would leave up to 3 deg and 0.1 mm).
        let t = template();
        let reach = t.iter().fold(0.0f64, |m, (p, _)| m.max(p[0].hypot(p[1])));
        for (deg, h) in [(90.0f64, 0.0f64), (31.3, -1.07), (200.4, 0.72), (-60.0, 1.53)] {
            let n = [deg.to_radians().cos(), deg.to_radians().sin()];
            let step = |p: &[f64; 2]| 1.0 / (1.0 + (-(n[0] * p[0] + n[1] * p[1] - h) / EDGE_WIDTH_MM).exp());
            let pins: Vec<([f64; 2], f64, f64)> = t.iter().map(|(p, d)| (*p, *d, d * step(p))).collect();
            let (m, hm) = fit_edge(&pins, reach);
            let angle = wrap_deg(m[1].atan2(m[0]).to_degrees() - deg).abs();
            assert!(angle <= 0.2 && (hm - h).abs() <= 0.01, "{deg} deg, {h} mm: found {angle} deg off, {hm} mm");
        }
        // A press wholly on the material reads as the edge beyond the contact's reach.
        let full: Vec<([f64; 2], f64, f64)> = t.iter().map(|(p, d)| (*p, *d, *d)).collect();
        assert!(fit_edge(&full, reach).1 <= -reach, "{:?}", fit_edge(&full, reach));
    }
}
