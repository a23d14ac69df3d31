//! The pose network: a CNN regressing labels of `targets.csv` from images: by default the
//! contact pose's lateral position x, y and yaw from tap images, as the paper's PoseNet (used
//! there to score unsheared images); any set of [`Column`]s (depth, tilt, slide offsets) for
//! other data.
//!
//! Architecture: the tap encoder's convolution stack (32, 32, 64, 64, 64 at 256 px; kernel 4,
//! stride 2, batch norm, ReLU; to 8x8x64), then a linear layer of `hidden` units with ReLU and
//! a linear output layer: one value per position label, normalised to `[-1, 1]` from its
//! range, and two per rotation label, `(sin a, cos a)` of an angle `a` on the unit circle,
//! decoded with `atan2`.
//!
//! A rotation's angle: a range narrower than a full turn (the recipes' `[-45, 45]` deg) maps to
//! half a turn, `a = (pi / 2) n` for the normalised value `n` in `[-1, 1]`, so that the ends of
//! the range stay half a turn apart and an overshoot past either end decodes as an overshoot.
//! A range of a full turn or more is periodic in itself and uses the rotation's own angle.

use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};
pub use tacsim_data::Column;
use tacsim_data::Row;

use crate::network::{CODE_CHANNELS, ConvStack, Size, encoder_channels};

/// The pose network.
#[derive(Module, Debug)]
pub struct PoseNet {
    trunk: ConvStack,
    hidden: Linear,
    out: Linear,
}

impl PoseNet {
    /// A fresh network for `size` images with `hidden` units and `outputs` outputs
    /// ([`PoseScale::width`]).
    pub fn new(size: Size, hidden: usize, outputs: usize, device: &Device) -> Self {
        let features = CODE_CHANNELS * 8 * 8;
        Self {
            trunk: ConvStack::new(1, &encoder_channels(&[32, 32, 64, 64, 64], size), device),
            hidden: LinearConfig::new(features, hidden).init(device),
            out: LinearConfig::new(hidden, outputs).init(device),
        }
    }

    /// The network with its batch norms' statistics re-estimated on `images` (side `side`,
    /// values in [0, 1]; `ConvStack::adapt_norms`): unlabelled images of another domain,
    /// the weights trained on one.
    pub fn adapt_norms(self, images: &[Vec<f32>], side: usize, device: &Device) -> Self {
        let batches: Vec<Tensor<4>> = images.chunks(64).map(|c| crate::images::stack(c, side, device)).collect();
        Self { trunk: self.trunk.adapt_norms(&batches), ..self }
    }

    /// `[batch, 1, s, s]` images to `[batch, outputs]` normalised outputs.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        let h = self.trunk.forward(x);
        let h: Tensor<2> = h.flatten(1, 3);
        self.out.forward(relu(self.hidden.forward(h)))
    }

    /// What each ReLU of the network takes for `[batch, 1, s, s]` images, one `[batch,
    /// features]` tensor per ReLU: the trunk's batch-normed convolution outputs, first layer to
    /// last, then the hidden layer's (on an autodiff device the batch norms use the batch's
    /// statistics, as in training). A ReLU's gradient is a step at 0, so an input within
    /// rounding of 0 is where two backends' gradients may part by more than rounding.
    pub fn relu_inputs(&self, x: Tensor<4>) -> Vec<Tensor<2>> {
        let (trunk, h) = self.trunk.relu_inputs(x);
        let mut inputs: Vec<Tensor<2>> = trunk.into_iter().map(|z| z.flatten(1, 3)).collect();
        inputs.push(self.hidden.forward(h.flatten(1, 3)));
        inputs
    }
}

/// The labels of a sample, one value per [`Column`] (mm or deg); a network's reading sets
/// the columns it reads and leaves the others 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    values: [f64; Column::COUNT],
}

impl Pose {
    /// A pose with lateral position x, y (mm) and yaw (deg), every other label 0.
    pub fn planar(x_mm: f64, y_mm: f64, yaw_deg: f64) -> Self {
        let mut p = Self::default();
        p.set(Column::PoseX, x_mm);
        p.set(Column::PoseY, y_mm);
        p.set(Column::PoseRz, yaw_deg);
        p
    }

    /// The labels of a `targets.csv` row.
    pub fn of_row(r: &Row) -> Self {
        let mut p = Self::default();
        for c in Column::ALL {
            p.set(c, c.of(r));
        }
        p
    }

    /// One label (mm or deg).
    pub fn get(&self, c: Column) -> f64 {
        self.values[c.index()]
    }

    /// Sets one label (mm or deg).
    pub fn set(&mut self, c: Column, v: f64) {
        self.values[c.index()] = v;
    }

    /// Lateral x (mm), `pose_x`.
    pub fn x_mm(&self) -> f64 {
        self.get(Column::PoseX)
    }

    /// Lateral y (mm), `pose_y`.
    pub fn y_mm(&self) -> f64 {
        self.get(Column::PoseY)
    }

    /// Yaw (deg), `pose_Rz`.
    pub fn yaw_deg(&self) -> f64 {
        self.get(Column::PoseRz)
    }
}

/// One label the network reads and the range that maps it to `[-1, 1]` (mm or deg).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelRange {
    /// The label.
    pub column: Column,
    /// Its range (mm or deg).
    pub range: [f64; 2],
}

/// The labels a pose network reads, in output order, with their ranges (`scale.json` of a run).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseScale {
    /// The labels.
    pub labels: Vec<LabelRange>,
}

fn norm(v: f64, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo { 2.0 * (v - lo) / (hi - lo) - 1.0 } else { 0.0 }
}

fn denorm(n: f64, [lo, hi]: [f64; 2]) -> f64 {
    lo + (n + 1.0) * 0.5 * (hi - lo)
}

impl LabelRange {
    /// Whether a rotation's range is a full turn or more, so periodic in itself.
    fn periodic(&self) -> bool {
        self.range[1] - self.range[0] >= 360.0
    }

    /// A rotation's angle on the unit circle (rad): see the module documentation.
    fn angle(&self, deg: f64) -> f64 {
        if self.periodic() { deg.to_radians() } else { std::f64::consts::FRAC_PI_2 * norm(deg, self.range) }
    }

    /// The rotation (deg) of an angle on the unit circle (rad), inverse of [`Self::angle`].
    fn of_angle(&self, a: f64) -> f64 {
        if self.periodic() { a.to_degrees() } else { denorm(a / std::f64::consts::FRAC_PI_2, self.range) }
    }

    /// Outputs of the label: 2 for a rotation, 1 for a position.
    fn width(&self) -> usize {
        if self.column.is_angle() { 2 } else { 1 }
    }
}

impl PoseScale {
    /// The smallest ranges of `labels` holding every pose.
    pub fn covering(labels: &[Column], poses: &[Pose]) -> Self {
        let labels = labels
            .iter()
            .map(|&column| {
                let lo = poses.iter().map(|p| p.get(column)).fold(f64::INFINITY, f64::min);
                let hi = poses.iter().map(|p| p.get(column)).fold(f64::NEG_INFINITY, f64::max);
                LabelRange { column, range: if lo.is_finite() { [lo, hi] } else { [-1.0, 1.0] } }
            })
            .collect();
        Self { labels }
    }

    /// The labels read, in order.
    pub fn columns(&self) -> Vec<Column> {
        self.labels.iter().map(|l| l.column).collect()
    }

    /// Whether the network reads `column`.
    pub fn reads(&self, column: Column) -> bool {
        self.labels.iter().any(|l| l.column == column)
    }

    /// An error naming `run` unless the network reads every label of `needed` (what `use`
    /// needs them for).
    pub fn require(&self, needed: &[Column], run: &std::path::Path, r#use: &str) -> crate::error::Result<()> {
        if needed.iter().all(|&c| self.reads(c)) {
            return Ok(());
        }
        let names = |cs: &[Column]| cs.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ");
        Err(crate::error::ModelError::config(
            "labels",
            format!(
                "{} reads {}; {use} needs {} (train it with the default labels)",
                run.display(),
                names(&self.columns()),
                names(needed)
            ),
        ))
    }

    /// The network's output count.
    pub fn width(&self) -> usize {
        self.labels.iter().map(LabelRange::width).sum()
    }

    /// The network's targets for a pose.
    pub fn encode(&self, p: &Pose) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.width());
        for l in &self.labels {
            let v = p.get(l.column);
            if l.column.is_angle() {
                let a = l.angle(v);
                out.extend([a.sin() as f32, a.cos() as f32]);
            } else {
                out.push(norm(v, l.range) as f32);
            }
        }
        out
    }

    /// The pose from the network's outputs (labels not read are 0).
    pub fn decode(&self, o: &[f32]) -> Pose {
        let mut p = Pose::default();
        let mut k = 0;
        for l in &self.labels {
            let v = if l.column.is_angle() {
                l.of_angle(f64::from(o[k]).atan2(f64::from(o[k + 1])))
            } else {
                denorm(f64::from(o[k]), l.range)
            };
            p.set(l.column, v);
            k += l.width();
        }
        p
    }

    /// Weight of each output in the loss: `weight(column)` for each of a label's outputs,
    /// scaled so that the weights average 1.
    pub fn output_weights(&self, weight: impl Fn(Column) -> f64) -> Vec<f32> {
        let w: Vec<f64> = self.labels.iter().flat_map(|l| vec![weight(l.column); l.width()]).collect();
        let mean = w.iter().sum::<f64>() / w.len().max(1) as f64;
        w.iter().map(|v| if mean > 0.0 { (v / mean) as f32 } else { 1.0 }).collect()
    }

    /// A `[poses.len(), width]` target tensor.
    pub fn targets(&self, poses: &[Pose], device: &Device) -> Tensor<2> {
        let data: Vec<f32> = poses.iter().flat_map(|p| self.encode(p)).collect();
        Tensor::from_data(TensorData::new(data, [poses.len(), self.width()]), device)
    }
}

/// Poses from a `[batch, width]` output tensor.
pub fn decode_batch(scale: &PoseScale, out: Tensor<2>) -> Vec<Pose> {
    let values: Vec<f32> = out.into_data().try_to_vec::<f32>().unwrap_or_default();
    values.chunks(scale.width().max(1)).map(|o| scale.decode(o)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn planar_scale(yaw_deg: [f64; 2]) -> PoseScale {
        PoseScale {
            labels: vec![
                LabelRange { column: Column::PoseX, range: [-5.0, 5.0] },
                LabelRange { column: Column::PoseY, range: [-5.0, 5.0] },
                LabelRange { column: Column::PoseRz, range: yaw_deg },
            ],
        }
    }

    #[test]
    fn pose_encoding_round_trips_over_the_range() {
        let scale = planar_scale([-45.0, 45.0]);
        assert_eq!(scale.width(), 4);
        for p in [Pose::planar(-5.0, 5.0, -44.9), Pose::planar(1.25, -0.5, 0.0), Pose::planar(4.0, 2.0, 44.9)] {
            let e = scale.encode(&p);
            assert!(e.iter().all(|v| (-1.0..=1.0).contains(v)), "{e:?}");
            let q = scale.decode(&e);
            assert!((q.x_mm() - p.x_mm()).abs() < 1e-5 && (q.y_mm() - p.y_mm()).abs() < 1e-5, "{q:?}");
            assert!((q.yaw_deg() - p.yaw_deg()).abs() < 1e-4, "{q:?}");
        }
        let full = planar_scale([-180.0, 180.0]);
        for yaw_deg in [-179.0, 0.0, 120.0] {
            let q = full.decode(&full.encode(&Pose::planar(0.0, 0.0, yaw_deg)));
            assert!((q.yaw_deg() - yaw_deg).abs() < 1e-4, "{q:?}");
        }
        let net = PoseNet::new(Size::S64, 16, scale.width(), &Device::flex());
        assert_eq!(net.forward(Tensor::zeros([3, 1, 64, 64], &Device::flex())).dims(), [3, 4]);
    }

    /// What could break: `relu_inputs` must be the inputs of the ReLUs `forward` applies,
    /// else the wgpu step test would check the signs of other numbers. The last one, through
    /// its ReLU and the output layer, must give `forward`'s outputs (the same bits), and every
    /// one must have the layer's shape.
    #[test]
    fn relu_inputs_are_what_forward_feeds_its_relus() {
        let device = Device::flex();
        let net = PoseNet::new(Size::S64, 16, 4, &device);
        let x: Tensor<4> = Tensor::from_data(
            TensorData::new((0..2 * 64 * 64).map(|k| ((k * 37 % 101) as f32) / 101.0).collect(), [2, 1, 64, 64]),
            &device,
        );
        let inputs = net.relu_inputs(x.clone());
        let dims: Vec<[usize; 2]> = inputs.iter().map(|z| z.dims()).collect();
        assert_eq!(dims, [[2, 64 * 32 * 32], [2, 64 * 16 * 16], [2, 64 * 8 * 8], [2, 16]]);
        let hidden = inputs.last().expect("the hidden layer's").clone();
        let via_inputs = net.out.forward(relu(hidden)).into_data().try_to_vec::<f32>().expect("f32");
        let direct = net.forward(x).into_data().try_to_vec::<f32>().expect("f32");
        assert_eq!(via_inputs, direct);
        // Some inputs on each side of 0: the signs are what the test reads.
        for z in inputs {
            let v = z.into_data().try_to_vec::<f32>().expect("f32");
            assert!(v.iter().any(|a| *a > 0.0) && v.iter().any(|a| *a < 0.0));
        }
    }

    #[test]
    fn any_label_set_round_trips_and_unread_labels_decode_to_zero() {
        let row = Row {
            pose_z: 3.2,
            pose_rx: -12.0,
            pose_ry: 20.0,
            shear_x: -4.0,
            shear_y: 1.0,
            shear_rz: 3.0,
            ..Row::default()
        };
        let truth = Pose::of_row(&row);
        let labels = [Column::PoseZ, Column::PoseRx, Column::PoseRy, Column::ShearX, Column::ShearY, Column::ShearRz];
        let other = Pose::of_row(&Row {
            pose_z: 1.0,
            pose_rx: 25.0,
            pose_ry: -25.0,
            shear_x: 5.0,
            shear_y: -5.0,
            shear_rz: -5.0,
            ..Row::default()
        });
        let scale = PoseScale::covering(&labels, &[truth, other]);
        assert_eq!(scale.width(), 3 + 2 * 3);
        let q = scale.decode(&scale.encode(&truth));
        for c in labels {
            assert!((q.get(c) - truth.get(c)).abs() < 1e-4, "{c}: {} for {}", q.get(c), truth.get(c));
        }
        assert_eq!(q.x_mm(), 0.0);
        // A reader of depth, tilt and slide offsets is refused where x and yaw are needed.
        let e = scale.require(&[Column::PoseX, Column::PoseRz], std::path::Path::new("runs/s"), "edge perception");
        let e = e.expect_err("no x, no yaw").to_string();
        assert!(
            e.contains("runs/s") && e.contains("pose_z") && e.contains("edge perception needs pose_x, pose_Rz"),
            "{e}"
        );
        assert!(scale.require(&labels[..2], std::path::Path::new("runs/s"), "x").is_ok());
        let w = scale.output_weights(|c| if c == Column::PoseZ { 4.0 } else { 1.0 });
        assert_eq!(w.len(), 9);
        assert!((w.iter().sum::<f32>() - 9.0).abs() < 1e-4 && w[0] > w[1], "{w:?}");
    }

    /// The yaw used to take the full turn for the recipe's range, which put -45 deg and +45 deg
    /// on the same point: an output 1 deg past +45 deg decoded as -44 deg, an 89 deg error, and
    /// the study's yaw MAE counted those.
    #[test]
    fn yaw_just_past_the_range_decoded_at_the_other_end() {
        let scale = planar_scale([-45.0, 45.0]);
        let edge = scale.encode(&Pose::planar(0.0, 0.0, 44.0));
        let other = scale.encode(&Pose::planar(0.0, 0.0, -44.0));
        let d = ((edge[2] - other[2]).powi(2) + (edge[3] - other[3]).powi(2)).sqrt();
        assert!(d > 1.9, "the range's ends are {d} apart on the unit circle");
        for yaw_deg in [46.0, 60.0, -50.0] {
            let past = scale.encode(&Pose::planar(0.0, 0.0, yaw_deg));
            let q = scale.decode(&past);
            assert!((q.yaw_deg() - yaw_deg).abs() < 1e-3, "{yaw_deg} decoded as {}", q.yaw_deg());
        }
    }
}
