//! The pose network: a CNN regressing the contact pose (lateral position x, y and yaw) from
//! tap images, as the paper's PoseNet (used there to score unsheared images).
//!
//! Architecture: the tap encoder's convolution stack (32, 32, 64, 64, 64 at 256 px; kernel 4,
//! stride 2, batch norm, ReLU; to 8x8x64), then a linear layer of `hidden` units with ReLU and
//! a linear output of 4 values: x and y normalised to `[-1, 1]` from the recipe's ranges, and
//! the yaw as `(sin a, cos a)` of an angle `a` on the unit circle, decoded with `atan2`.
//!
//! The yaw's angle: a range narrower than a full turn (the recipes' `[-45, 45]` deg) maps to
//! half a turn, `a = (pi / 2) n` for the normalised yaw `n` in `[-1, 1]`, so that the ends of
//! the range stay half a turn apart and an overshoot past either end decodes as an overshoot.
//! A range of a full turn or more is periodic in itself and uses the yaw's own angle.

use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use crate::network::{CODE_CHANNELS, ConvStack, Size, encoder_channels};

/// The pose network.
#[derive(Module, Debug)]
pub struct PoseNet {
    trunk: ConvStack,
    hidden: Linear,
    out: Linear,
}

impl PoseNet {
    /// A fresh network for `size` images with `hidden` units.
    pub fn new(size: Size, hidden: usize, device: &Device) -> Self {
        let features = CODE_CHANNELS * 8 * 8;
        Self {
            trunk: ConvStack::new(1, &encoder_channels(&[32, 32, 64, 64, 64], size), device),
            hidden: LinearConfig::new(features, hidden).init(device),
            out: LinearConfig::new(hidden, 4).init(device),
        }
    }

    /// `[batch, 1, s, s]` images to `[batch, 4]` normalised outputs.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        let h = self.trunk.forward(x);
        let h: Tensor<2> = h.flatten(1, 3);
        self.out.forward(relu(self.hidden.forward(h)))
    }
}

/// A pose label: lateral position (mm) and yaw (deg), in the sensor frame of the dataset
/// (`pose_x`, `pose_y`, `pose_rz` of `targets.csv`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// x (mm).
    pub x_mm: f64,
    /// y (mm).
    pub y_mm: f64,
    /// Yaw (deg).
    pub yaw_deg: f64,
}

/// The label ranges that map poses to `[-1, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseScale {
    /// Range of x (mm).
    pub x_mm: [f64; 2],
    /// Range of y (mm).
    pub y_mm: [f64; 2],
    /// Range of yaw (deg).
    pub yaw_deg: [f64; 2],
}

fn norm(v: f64, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo { 2.0 * (v - lo) / (hi - lo) - 1.0 } else { 0.0 }
}

fn denorm(n: f64, [lo, hi]: [f64; 2]) -> f64 {
    lo + (n + 1.0) * 0.5 * (hi - lo)
}

impl PoseScale {
    /// The smallest ranges holding every pose (for data without a recipe).
    pub fn covering(poses: &[Pose]) -> Self {
        let range = |f: &dyn Fn(&Pose) -> f64| {
            let lo = poses.iter().map(f).fold(f64::INFINITY, f64::min);
            let hi = poses.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
            if lo.is_finite() { [lo, hi] } else { [-1.0, 1.0] }
        };
        Self { x_mm: range(&|p| p.x_mm), y_mm: range(&|p| p.y_mm), yaw_deg: range(&|p| p.yaw_deg) }
    }

    /// Whether the yaw range is a full turn or more, so periodic in itself.
    fn yaw_periodic(&self) -> bool {
        self.yaw_deg[1] - self.yaw_deg[0] >= 360.0
    }

    /// The yaw's angle on the unit circle (rad): see the module documentation.
    fn yaw_angle(&self, yaw_deg: f64) -> f64 {
        if self.yaw_periodic() {
            yaw_deg.to_radians()
        } else {
            std::f64::consts::FRAC_PI_2 * norm(yaw_deg, self.yaw_deg)
        }
    }

    /// The yaw (deg) of an angle on the unit circle (rad), inverse of [`Self::yaw_angle`].
    fn yaw_of_angle(&self, a: f64) -> f64 {
        if self.yaw_periodic() { a.to_degrees() } else { denorm(a / std::f64::consts::FRAC_PI_2, self.yaw_deg) }
    }

    /// The network's 4 targets for a pose.
    pub fn encode(&self, p: &Pose) -> [f32; 4] {
        let a = self.yaw_angle(p.yaw_deg);
        [norm(p.x_mm, self.x_mm) as f32, norm(p.y_mm, self.y_mm) as f32, a.sin() as f32, a.cos() as f32]
    }

    /// The pose from the network's 4 outputs.
    pub fn decode(&self, o: &[f32]) -> Pose {
        Pose {
            x_mm: denorm(f64::from(o[0]), self.x_mm),
            y_mm: denorm(f64::from(o[1]), self.y_mm),
            yaw_deg: self.yaw_of_angle(f64::from(o[2]).atan2(f64::from(o[3]))),
        }
    }

    /// A `[poses.len(), 4]` target tensor.
    pub fn targets(&self, poses: &[Pose], device: &Device) -> Tensor<2> {
        let data: Vec<f32> = poses.iter().flat_map(|p| self.encode(p)).collect();
        Tensor::from_data(TensorData::new(data, [poses.len(), 4]), device)
    }
}

/// Poses from a `[batch, 4]` output tensor.
pub fn decode_batch(scale: &PoseScale, out: Tensor<2>) -> Vec<Pose> {
    let values: Vec<f32> = out.into_data().try_to_vec::<f32>().unwrap_or_default();
    values.chunks(4).map(|o| scale.decode(o)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_encoding_round_trips_over_the_range() {
        let scale = PoseScale { x_mm: [-5.0, 5.0], y_mm: [-5.0, 5.0], yaw_deg: [-45.0, 45.0] };
        for p in [
            Pose { x_mm: -5.0, y_mm: 5.0, yaw_deg: -44.9 },
            Pose { x_mm: 1.25, y_mm: -0.5, yaw_deg: 0.0 },
            Pose { x_mm: 4.0, y_mm: 2.0, yaw_deg: 44.9 },
        ] {
            let e = scale.encode(&p);
            assert!(e.iter().all(|v| (-1.0..=1.0).contains(v)), "{e:?}");
            let q = scale.decode(&e);
            assert!((q.x_mm - p.x_mm).abs() < 1e-5 && (q.y_mm - p.y_mm).abs() < 1e-5, "{q:?}");
            assert!((q.yaw_deg - p.yaw_deg).abs() < 1e-4, "{q:?}");
        }
        let full = PoseScale { yaw_deg: [-180.0, 180.0], ..scale };
        for yaw_deg in [-179.0, 0.0, 120.0] {
            let q = full.decode(&full.encode(&Pose { x_mm: 0.0, y_mm: 0.0, yaw_deg }));
            assert!((q.yaw_deg - yaw_deg).abs() < 1e-4, "{q:?}");
        }
        let net = PoseNet::new(Size::S64, 16, &Device::flex());
        assert_eq!(net.forward(Tensor::zeros([3, 1, 64, 64], &Device::flex())).dims(), [3, 4]);
    }

    /// The yaw used to take the full turn for the recipe's range, which put -45 deg and +45 deg
    /// on the same point: an output 1 deg past +45 deg decoded as -44 deg, an 89 deg error, and
    /// the study's yaw MAE counted those.
    #[test]
    fn yaw_just_past_the_range_decoded_at_the_other_end() {
        let scale = PoseScale { x_mm: [-5.0, 5.0], y_mm: [-5.0, 5.0], yaw_deg: [-45.0, 45.0] };
        let edge = scale.encode(&Pose { x_mm: 0.0, y_mm: 0.0, yaw_deg: 44.0 });
        let other = scale.encode(&Pose { x_mm: 0.0, y_mm: 0.0, yaw_deg: -44.0 });
        let d = ((edge[2] - other[2]).powi(2) + (edge[3] - other[3]).powi(2)).sqrt();
        assert!(d > 1.9, "the range's ends are {d} apart on the unit circle");
        for yaw_deg in [46.0, 60.0, -50.0] {
            let past = scale.encode(&Pose { x_mm: 0.0, y_mm: 0.0, yaw_deg });
            let q = scale.decode(&past);
            assert!((q.yaw_deg - yaw_deg).abs() < 1e-3, "{yaw_deg} decoded as {}", q.yaw_deg);
        }
    }
}
