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

/// Model-free edge estimate from the sensor's image: detect the pins, track them against the
/// undeformed image (nearest neighbours), take the pins whose neighbourhood dilated by more
/// than `CONTACT_FRACTION` of the largest dilation as the contact patch, and read the edge off the
/// patch: the direction from the apex to the patch's centroid is the inward edge normal, and
/// the patch's share of the pins within the contact radius `a = sqrt(R d)` (a flat face
/// pressed `d` deep) gives the offset through the area of a disc segment.
#[derive(Clone, Debug)]
pub struct Geometric {
    renderer: tacsim_sim::PinRenderer,
    reference_px: Vec<[f64; 2]>,
    /// Rest position (contact-plane mm, sensor frame) of each reference pin.
    rest_mm: Vec<Option<[f64; 2]>>,
    spacing_px: f64,
    radius_mm: f64,
    /// The six nearest reference pins of each reference pin.
    neighbours: Vec<Vec<usize>>,
    /// Where each reference pin was last seen (px): pins are tracked frame to frame, so a
    /// slide's drag, which builds up over many frames, never has to be matched in one jump.
    last: Vec<Option<[f64; 2]>>,
    /// The undeformed Voronoi tessellation, for the contact patch.
    geometry: super::contact_geometry::ContactGeometry,
    /// The edge of the latest estimate: inward normal (contact-plane, sensor frame) and the
    /// edge's distance from the apex along it (mm).
    edge: Option<([f64; 2], f64)>,
}

/// Share of the largest local dilation above which a pin counts as in contact.
const CONTACT_FRACTION: f64 = 0.3;

/// The contact patch read off the pins' Voronoi cells: the skin touches where the cells grew
/// (`A / A0 - 1`) by more than this share of the largest growth in the image...
const TOUCH_SHARE: f64 = 0.65;
/// ...and is free where they grew by less than this share; between, undecided. Chosen on the
/// 7 geometric scenarios (IoU of the pins' footprint): single thresholds either took the free
/// skin bent over the edge for contact (a band about 1-2 mm wide, IoU 0.83-0.96) or the
/// faint rim of the contact for free skin, which emptied the interior (IoU below 0.2).
const FREE_SHARE: f64 = 0.12;

impl Geometric {
    /// Perception for `sensor` pressed `depth_mm` deep, rendering at `size` px.
    pub fn new(sensor: &tacsim_sim::SensorParams, depth_mm: f64, size: u32) -> anyhow::Result<Self> {
        use tacsim_sim::pins::PinLayout;
        let renderer = tacsim_sim::PinRenderer::new(sensor, size)?;
        let layout = PinLayout::new(sensor);
        let reference_px = tacsim_sim::calibrate::observe::pin_centres(&renderer.render(&layout.poses()));
        let spacing_px = 17.5 * size as f64 / 420.0;
        // Rest positions: the layout pin whose projected tip is nearest each detected pin.
        let rest_mm =
            tacsim_sim::calibrate::model::match_reference(&renderer, &layout.poses(), &reference_px, spacing_px)
                .into_iter()
                .map(|m| m.map(|i| [layout.pins[i].base.x, layout.pins[i].base.y]))
                .collect();
        let radius_mm = (sensor.dome.outer_radius_mm * depth_mm).sqrt();
        let neighbours = tacsim_sim::tracking::nearest_neighbours(&reference_px, 6);
        let last = reference_px.iter().map(|p| Some(*p)).collect();
        let geometry = super::contact_geometry::ContactGeometry::new(&reference_px, spacing_px);
        Ok(Self { renderer, reference_px, rest_mm, spacing_px, radius_mm, neighbours, last, geometry, edge: None })
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

    /// [`Geometric::estimate`] from the current pins' image ([`Geometric::render`]).
    pub fn estimate_image(&mut self, img: &image::GrayImage) -> Option<EdgeEstimate> {
        self.estimate_with(img, CONTACT_FRACTION)
    }

    /// [`Geometric::estimate_image`] with another contact threshold (share of the largest
    /// motion).
    pub fn estimate_with(&mut self, img: &image::GrayImage, fraction: f64) -> Option<EdgeEstimate> {
        let detected = tacsim_sim::calibrate::observe::pin_centres(img);
        // Track from where each pin was last seen (its reference position when lost).
        let from: Vec<[f64; 2]> = self.last.iter().zip(&self.reference_px).map(|(l, r)| l.unwrap_or(*r)).collect();
        let step = tacsim_sim::tracking::track_nearest(&from, &detected, self.spacing_px);
        self.last = from.iter().zip(&step).map(|(f, d)| d.map(|d| [f[0] + d[0], f[1] + d[1]])).collect();
        // Local dilation: how much each pin's neighbourhood grew in the image (pins pressed
        // towards the camera spread apart). A sideways drag (sliding shear) moves a
        // neighbourhood without growing it, so the signal ignores the shear.
        let mags: Vec<Option<f64>> = self
            .neighbours
            .iter()
            .enumerate()
            .map(|(i, nb)| {
                let pi = self.last[i]?;
                let (mut sum, mut n) = (0.0, 0);
                for &j in nb {
                    if let Some(pj) = self.last[j] {
                        let rest = (self.reference_px[j][0] - self.reference_px[i][0])
                            .hypot(self.reference_px[j][1] - self.reference_px[i][1]);
                        sum += (pj[0] - pi[0]).hypot(pj[1] - pi[1]) / rest;
                        n += 1;
                    }
                }
                (n >= 3).then(|| (sum / n as f64 - 1.0).max(0.0))
            })
            .collect();
        let max = mags.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        self.edge = None;
        if max <= 0.0 {
            return None;
        }
        // The pins in contact and those not, within the contact disc.
        let (mut inn, mut out): (Vec<[f64; 2]>, Vec<[f64; 2]>) = (Vec::new(), Vec::new());
        for (m, r) in mags.iter().zip(&self.rest_mm) {
            let Some(r) = r else { continue };
            if r[0].hypot(r[1]) > self.radius_mm {
                continue;
            }
            // An untracked pin inside the disc moved too far to match: contact.
            if m.is_none_or(|m| m > fraction * max) { inn.push(*r) } else { out.push(*r) }
        }
        let (contact, within) = (inn.len(), inn.len() + out.len());
        if contact == 0 || within == 0 {
            return None;
        }
        let mean = |v: &[[f64; 2]]| {
            let n = v.len().max(1) as f64;
            [v.iter().map(|p| p[0]).sum::<f64>() / n, v.iter().map(|p| p[1]).sum::<f64>() / n]
        };
        let (ci, co) = (mean(&inn), mean(&out));
        // The edge runs along the long axis of the smaller part (a disc segment is long along
        // its chord); the inward normal points from the free pins to the touching ones.
        let part = if inn.len() <= out.len() { &inn } else { &out };
        let c = mean(part);
        let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
        for p in part {
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
        let along = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let mut n = [-along.sin(), along.cos()];
        if part.len() < 3 || (n[0] * (ci[0] - co[0]) + n[1] * (ci[1] - co[1])).abs() < 1e-12 {
            n = [ci[0] - co[0], ci[1] - co[1]];
        } else if n[0] * (ci[0] - co[0]) + n[1] * (ci[1] - co[1]) < 0.0 {
            n = [-n[0], -n[1]];
        }
        let (cx, cy) = (n[0], n[1]);
        // Inward normal (towards the material), sensor frame; the sensor frame's y is world -y
        // at zero yaw, so angles in the sensor's contact plane are measured with y flipped.
        let normal_deg = (-cy).atan2(cx).to_degrees();
        let tangent_deg = normal_deg - 90.0;
        // Offset from the covered share of the disc: segment area fraction f(h) for a line at
        // distance h from the centre (material beyond it), solved by bisection.
        let share = (contact as f64 / within as f64).clamp(0.0, 1.0);
        let a = self.radius_mm;
        let f = |h: f64| {
            let h = h.clamp(-a, a);
            (a * a * (h / a).acos() - h * (a * a - h * h).sqrt()) / (std::f64::consts::PI * a * a)
        };
        let (mut lo, mut hi) = (-a, a);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > share { lo = mid } else { hi = mid }
        }
        let h = 0.5 * (lo + hi);
        self.edge = Some(([cx, cy], h));
        Some(EdgeEstimate { offset_mm: h, angle_deg: wrap_deg(tangent_deg) })
    }
}
