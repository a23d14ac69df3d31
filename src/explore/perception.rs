//! Perception: the sensor's pose relative to the edge under it, as the servo needs it.

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tacsim_sim::contact::pose::SensorPose;
use tacsim_sim::scene::{ObjectId, Scene};

use super::scenario::Noise;

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

/// Wraps an angle into `(-180, 180]` degrees.
pub fn wrap_deg(a: f64) -> f64 {
    let w = (a + 180.0).rem_euclid(360.0) - 180.0;
    if w == -180.0 { 180.0 } else { w }
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
/// (the reference press, [`super::run::reference_press`]); its image gives each pin's
/// full-contact stretch `D_i` (the template). Each image is then read in three stages:
/// [`Geometric::track`] finds the pins (detection, then the tracker of `tacsim_sim::tracking`
/// from the undeformed image, which follows presses and slides that move pins by most of a
/// spacing); [`Geometric::stretch`] takes each pin's local stretch `m_i` (mean distance to its
/// six undeformed neighbours over the undeformed distance, minus one: pins pressed towards the
/// camera spread apart); [`fit_edge`] finds the straight edge, inward normal `n` and offset
/// `h` (mm) with the material where `n . r > h` (`r` a pin's rest position), whose template
/// best explains the stretches:
///
/// `min over (n, h) of sum_i (m_i - D_i s((n . r_i - h) / w))^2`, `s` the logistic step and
/// `w` = [`EDGE_WIDTH_MM`].
///
/// The template carries what hand-chosen thresholds could not: how far this sensor's contact
/// reaches at this depth and how much each pin stretches in it (a compressible skin with long
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
    /// The reference press: (reference pin, rest position in mm, full-contact stretch) of the
    /// pins that stretched by more than `NO_CONTACT` in it.
    template: Vec<(usize, [f64; 2], f64)>,
    /// Largest rest distance of a template pin from the apex (mm): the contact's reach.
    reach_mm: f64,
    /// The undeformed Voronoi tessellation, for the contact patch.
    geometry: super::contact_geometry::ContactGeometry,
    /// The edge of the latest estimate: inward normal (contact-plane, sensor frame) and the
    /// edge's distance from the apex along it (mm).
    edge: Option<([f64; 2], f64)>,
}

/// Width of the edge's soft step in the template fit (mm): about a third of the pin pitch.
/// The skin bends over an edge, so the pins next to it stretch part way; on the disk and the
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

/// The straight edge whose template best explains the stretches (the sum of squares of
/// [`Geometric`]): `template` holds (rest position mm, full-contact stretch, this image's
/// stretch) per pin. Returns the inward normal and the offset `h` (mm): a coarse search over
/// normals every 3 deg and offsets every 0.1 mm within `reach_mm + 1`, refined to 0.25 deg and
/// 0.01 mm.
pub fn fit_edge(template: &[([f64; 2], f64, f64)], reach_mm: f64) -> ([f64; 2], f64) {
    let cost = |deg: f64, h: f64| {
        let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
        template
            .iter()
            .map(|(r, d, m)| {
                let u = (c * r[0] + s * r[1] - h) / EDGE_WIDTH_MM;
                (m - d / (1.0 + (-u).exp())).powi(2)
            })
            .sum::<f64>()
    };
    let span = reach_mm + 1.0;
    let mut best = (f64::INFINITY, 0.0, span);
    let steps = (2.0 * span / 0.1).ceil() as usize;
    for a in 0..120 {
        for k in 0..=steps {
            let (deg, h) = (3.0 * a as f64, -span + 0.1 * k as f64);
            let c = cost(deg, h);
            if c < best.0 {
                best = (c, deg, h);
            }
        }
    }
    let (_, deg0, h0) = best;
    for a in -12..=12 {
        for k in -10..=10 {
            let (deg, h) = (deg0 + 0.25 * f64::from(a), h0 + 0.01 * f64::from(k));
            let c = cost(deg, h);
            if c < best.0 {
                best = (c, deg, h);
            }
        }
    }
    let (_, deg, h) = best;
    ([deg.to_radians().cos(), deg.to_radians().sin()], h)
}

impl Geometric {
    /// Perception for `sensor` rendering at `size` px, with the pins of its reference press
    /// `press` (a flat face at the scenario's depth, [`super::run::reference_press`]).
    pub fn new(
        sensor: &tacsim_sim::SensorParams,
        size: u32,
        press: &[tacsim_sim::pins::PinPose],
    ) -> anyhow::Result<Self> {
        use tacsim_sim::pins::PinLayout;
        let renderer = tacsim_sim::PinRenderer::new(sensor, size)?;
        let layout = PinLayout::new(sensor);
        let reference_px = tacsim_sim::calibrate::observe::pin_centres(&renderer.render(&layout.poses()));
        let spacing_px = 17.5 * size as f64 / 420.0;
        // Rest positions: the layout pin whose projected tip is nearest each detected pin.
        let rest_mm: Vec<Option<[f64; 2]>> =
            tacsim_sim::calibrate::model::match_reference(&renderer, &layout.poses(), &reference_px, spacing_px)
                .into_iter()
                .map(|m| m.map(|i| [layout.pins[i].base.x, layout.pins[i].base.y]))
                .collect();
        let neighbours = tacsim_sim::tracking::nearest_neighbours(&reference_px, 6);
        let last = reference_px.iter().map(|p| Some(*p)).collect();
        let geometry = super::contact_geometry::ContactGeometry::new(&reference_px, spacing_px);
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
            geometry,
            edge: None,
        };
        let img = g.render(press);
        let tracked = g.track(&img, [0.0; 2]).0;
        g.template = g
            .stretch(&tracked)
            .iter()
            .zip(&g.rest_mm)
            .enumerate()
            .filter_map(|(i, (m, r))| Some((i, (*r)?, (*m)?)).filter(|t| t.2 > super::contact_geometry::NO_CONTACT))
            .collect();
        g.reach_mm = g.template.iter().fold(0.0f64, |m, (_, r, _)| m.max(r[0].hypot(r[1])));
        if g.template.len() < 3 {
            anyhow::bail!(
                "the reference press stretched {} pins (at least 3 needed): press deeper (field `depth_mm`)",
                g.template.len()
            );
        }
        Ok(g)
    }

    /// How far the contact reaches from the apex in the reference press (mm).
    pub fn reach_mm(&self) -> f64 {
        self.reach_mm
    }

    /// The contact patch of the image of the latest estimate: whether the skin touches at
    /// each of `points` (contact-plane mm, sensor frame), from the tracked pins' Voronoi
    /// cells ([`super::contact_geometry`], thresholds `TOUCH_SHARE` and `FREE_SHARE`);
    /// `None` where undecided. Free skin on the material's side of the estimated edge is
    /// undecided too: with the dome wholly on the material the indentation fades towards the
    /// rim of the contact as it does towards an edge, and reading that rim as "no material"
    /// punched holes into the footprint (the foil's IoU was 0.894 with it, 0.912 without).
    pub fn touching(&self, points: &[[f64; 2]]) -> Vec<Option<bool>> {
        let mut t = super::contact_geometry::touching(
            &self.geometry.indentation(&self.last, &self.rest_mm),
            FREE_SHARE,
            TOUCH_SHARE,
            points,
        );
        if let Some((n, h)) = self.edge {
            for (t, q) in t.iter_mut().zip(points) {
                if *t == Some(false) && n[0] * q[0] + n[1] * q[1] > h {
                    *t = None;
                }
            }
        }
        t
    }

    /// The image of `pins` as this perception sees it.
    pub fn render(&self, pins: &[tacsim_sim::pins::PinPose]) -> image::GrayImage {
        self.renderer.render(pins)
    }

    /// The estimate from the current pins; `None` when no pin shows contact.
    pub fn estimate(&mut self, pins: &[tacsim_sim::pins::PinPose]) -> Option<EdgeEstimate> {
        let img = self.render(pins);
        self.estimate_image(&img)
    }

    /// Where each reference pin is in `img` (px; `None` where lost) and the tracker's global
    /// shift, tracking from the undeformed pins with the shift `start` as the first guess.
    fn track(&self, img: &image::GrayImage, start: [f64; 2]) -> (Vec<Option<[f64; 2]>>, [f64; 2]) {
        use tacsim_sim::tracking::{Warp, track};
        let detected = tacsim_sim::calibrate::observe::pin_centres(img);
        let t = track(&self.reference_px, &detected, self.spacing_px, &Warp::shift(start));
        let at = t.displacement.iter().zip(&self.reference_px).map(|(d, r)| d.map(|d| [r[0] + d[0], r[1] + d[1]]));
        (at.collect(), t.global_shift)
    }

    /// Each reference pin's local stretch in the tracked positions `at`: the mean distance to
    /// its tracked undeformed neighbours (at least 3) over their undeformed distance, minus
    /// one, at least 0. A sideways drag moves a neighbourhood without stretching it.
    fn stretch(&self, at: &[Option<[f64; 2]>]) -> Vec<Option<f64>> {
        self.neighbours
            .iter()
            .enumerate()
            .map(|(i, nb)| {
                let pi = at[i]?;
                let (mut sum, mut n) = (0.0, 0);
                for &j in nb {
                    if let Some(pj) = at[j] {
                        let rest = (self.reference_px[j][0] - self.reference_px[i][0])
                            .hypot(self.reference_px[j][1] - self.reference_px[i][1]);
                        sum += (pj[0] - pi[0]).hypot(pj[1] - pi[1]) / rest;
                        n += 1;
                    }
                }
                (n >= 3).then(|| (sum / n as f64 - 1.0).max(0.0))
            })
            .collect()
    }

    /// [`Geometric::estimate`] from the current pins' image ([`Geometric::render`]).
    pub fn estimate_image(&mut self, img: &image::GrayImage) -> Option<EdgeEstimate> {
        let (at, shift) = self.track(img, self.shift);
        (self.last, self.shift) = (at, shift);
        self.edge = None;
        let m = self.stretch(&self.last);
        // Template pins the tracker lost say nothing (they are skipped, not guessed).
        let pins: Vec<([f64; 2], f64, f64)> =
            self.template.iter().filter_map(|(i, r, d)| m[*i].map(|m| (*r, *d, m))).collect();
        if !pins.iter().any(|p| p.2 > super::contact_geometry::NO_CONTACT) {
            return None;
        }
        let (n, h) = fit_edge(&pins, self.reach_mm);
        self.edge = Some((n, h));
        // With every template pin on the material the normal is undetermined: no turn.
        let angle_deg = if h <= -self.reach_mm {
            0.0
        } else {
            // Inward normal (towards the material), sensor frame; the sensor frame's y is
            // world -y at zero yaw, so angles in the contact plane are measured with y flipped.
            wrap_deg((-n[1]).atan2(n[0]).to_degrees() - 90.0)
        };
        Some(EdgeEstimate { offset_mm: h, angle_deg })
    }
}
