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
