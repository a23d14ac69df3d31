//! The paper's networks (Methods, Fig. 2), at 256x256 by default: kernel 4, stride 2, batch
//! norm and ReLU after every layer but the outputs, sigmoid on the images, weights from
//! N(0, 0.02).
//!
//! - Shear encoder `E_S`: Conv 32, 64, 64, 128, then two Conv heads to the pose code and the
//!   shear code (8x8x64 each).
//! - Tap decoder `D_T`: TConv 64, 64, 32, 32, 1 from the pose code to the unsheared image.
//! - Shear decoder `D_S`: TConv 128, 64, 64, 32, 1 from the pose and shear codes (stacked,
//!   8x8x128) to the sheared image.
//! - Tap encoder `E_T`: Conv 32, 32, 64, 64, 64 from an unsheared image to its pose code.
//!
//! [`Size`] scales the number of stride-2 stages for 128 and 64 px inputs with the same 8x8
//! codes: each halving of the input drops the first encoder stage and the last decoder stage
//! before the output.
//!
//! Parameter counts (burn's `num_params`, batch-norm running statistics included; printed by
//! `cargo test -p tacsim-model network -- --nocapture`):
//!
//! | size | E_S | D_T | D_S | E_T |
//! |---|---|---|---|---|
//! | 256 | 494,112 | 181,697 | 493,473 | 182,016 |
//! | 128 | 461,696 | 165,153 | 461,057 | 165,472 |
//! | 64 | 395,840 | 132,737 | 395,201 | 133,056 |

use burn::module::{Initializer, Module, RunningState};
use burn::nn::conv::{Conv2d, Conv2dConfig, ConvTranspose2d, ConvTranspose2dConfig};
use burn::nn::{BatchNorm, BatchNormConfig, PaddingConfig2d};
use burn::tensor::activation::{relu, sigmoid};
use burn::tensor::{Device, Tensor, TensorData};

/// Image side the networks take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// 256x256 (the paper's).
    S256,
    /// 128x128 (the lab's usual network size).
    S128,
    /// 64x64.
    S64,
    /// 32x32: each pixel a 4x4 block of a 128 px image, about one pin spacing across, so the
    /// network sees how densely the pins lie, not the pins.
    S32,
}

impl Size {
    /// Side (px).
    pub fn px(self) -> usize {
        match self {
            Size::S256 => 256,
            Size::S128 => 128,
            Size::S64 => 64,
            Size::S32 => 32,
        }
    }

    /// Stages dropped relative to 256 px.
    fn dropped(self) -> usize {
        match self {
            Size::S256 => 0,
            Size::S128 => 1,
            Size::S64 => 2,
            Size::S32 => 3,
        }
    }
}

/// Channels of the latent codes (8x8 each).
pub const CODE_CHANNELS: usize = 64;

fn init() -> Initializer {
    Initializer::Normal { mean: 0.0, std: 0.02 }
}

fn conv(cin: usize, cout: usize, device: &Device) -> Conv2d {
    Conv2dConfig::new([cin, cout], [4, 4])
        .with_stride([2, 2])
        .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
        .with_initializer(init())
        .init(device)
}

fn tconv(cin: usize, cout: usize, device: &Device) -> ConvTranspose2d {
    ConvTranspose2dConfig::new([cin, cout], [4, 4])
        .with_stride([2, 2])
        .with_padding([1, 1])
        .with_initializer(init())
        .init(device)
}

/// A stack of stride-2 convolutions, each with batch norm and ReLU.
#[derive(Module, Debug)]
pub struct ConvStack {
    convs: Vec<Conv2d>,
    norms: Vec<BatchNorm>,
}

impl ConvStack {
    /// Stride-2 convolutions from `cin` channels through `channels`.
    pub(crate) fn new(cin: usize, channels: &[usize], device: &Device) -> Self {
        let mut prev = cin;
        let (mut convs, mut norms) = (Vec::new(), Vec::new());
        for &c in channels {
            convs.push(conv(prev, c, device));
            norms.push(BatchNormConfig::new(c).init(device));
            prev = c;
        }
        Self { convs, norms }
    }

    /// Each layer's ReLU input ([`PoseNet::relu_inputs`](crate::PoseNet::relu_inputs)) and
    /// the stack's output.
    pub(crate) fn relu_inputs(&self, x: Tensor<4>) -> (Vec<Tensor<4>>, Tensor<4>) {
        let mut inputs = Vec::with_capacity(self.convs.len());
        let out = self.run(x, |z| inputs.push(z.clone()));
        (inputs, out)
    }

    /// Runs the stack.
    pub(crate) fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.run(x, |_| {})
    }

    /// The layers in turn, each ReLU's input shown to `seen` before the ReLU takes it.
    fn run(&self, mut x: Tensor<4>, mut seen: impl FnMut(&Tensor<4>)) -> Tensor<4> {
        for (c, n) in self.convs.iter().zip(&self.norms) {
            let z = n.forward(c.forward(x));
            seen(&z);
            x = relu(z);
        }
        x
    }

    /// The stack with each batch norm's running statistics taken from `batches` instead of
    /// the training images (AdaBN, Li et al. 2016): layer by layer, first to last, the mean
    /// and variance per channel of the layer's convolution output over every image of every
    /// batch, the layers before it already re-estimated. Learnt weights are untouched; no
    /// label is read.
    pub(crate) fn adapt_norms(mut self, batches: &[Tensor<4>]) -> Self {
        for layer in 0..self.norms.len() {
            let mut sums: Vec<[f64; 2]> = Vec::new();
            let mut count = 0usize;
            for batch in batches {
                let mut x = batch.clone();
                for (c, n) in self.convs.iter().zip(&self.norms).take(layer) {
                    x = relu(n.forward(c.forward(x)));
                }
                let y = self.convs[layer].forward(x);
                let [b, channels, h, w] = y.dims();
                sums.resize(channels, [0.0; 2]);
                let values: Vec<f32> = y.into_data().try_to_vec::<f32>().unwrap_or_default();
                for (k, v) in values.iter().enumerate() {
                    let s = &mut sums[(k / (h * w)) % channels];
                    s[0] += f64::from(*v);
                    s[1] += f64::from(*v) * f64::from(*v);
                }
                count += b * h * w;
            }
            if count == 0 {
                return self;
            }
            let n = count as f64;
            let mean: Vec<f32> = sums.iter().map(|s| (s[0] / n) as f32).collect();
            let var: Vec<f32> = sums.iter().map(|s| (s[1] / n - (s[0] / n).powi(2)).max(0.0) as f32).collect();
            let device = self.norms[layer].gamma.val().device();
            let norm = &mut self.norms[layer];
            norm.running_mean = RunningState::new(Tensor::from_data(TensorData::new(mean, [sums.len()]), &device));
            norm.running_var = RunningState::new(Tensor::from_data(TensorData::new(var, [sums.len()]), &device));
        }
        self
    }
}

/// A stack of stride-2 transposed convolutions, batch norm and ReLU after each but the last,
/// sigmoid at the end.
#[derive(Module, Debug)]
pub struct Upsampler {
    tconvs: Vec<ConvTranspose2d>,
    norms: Vec<BatchNorm>,
}

impl Upsampler {
    fn new(cin: usize, channels: &[usize], device: &Device) -> Self {
        let mut prev = cin;
        let (mut tconvs, mut norms) = (Vec::new(), Vec::new());
        for (k, &c) in channels.iter().enumerate() {
            tconvs.push(tconv(prev, c, device));
            if k + 1 < channels.len() {
                norms.push(BatchNormConfig::new(c).init(device));
            }
            prev = c;
        }
        Self { tconvs, norms }
    }

    fn forward(&self, mut x: Tensor<4>) -> Tensor<4> {
        let last = self.tconvs.len() - 1;
        for (k, t) in self.tconvs.iter().enumerate() {
            x = t.forward(x);
            x = if k < last { relu(self.norms[k].forward(x)) } else { sigmoid(x) };
        }
        x
    }
}

/// Drops the first `n` encoder stages (or, for decoders, the stages before the output).
pub(crate) fn encoder_channels(full: &[usize], size: Size) -> Vec<usize> {
    full[size.dropped()..].to_vec()
}

fn decoder_channels(full: &[usize], size: Size) -> Vec<usize> {
    let keep = full.len() - size.dropped();
    let mut v: Vec<usize> = full[..keep - 1].to_vec();
    v.push(*full.last().unwrap_or(&1));
    v
}

/// Shear encoder `E_S`: sheared image to (pose code, shear code).
#[derive(Module, Debug)]
pub struct ShearEncoder {
    trunk: ConvStack,
    pose: Conv2d,
    pose_norm: BatchNorm,
    shear: Conv2d,
    shear_norm: BatchNorm,
}

impl ShearEncoder {
    /// The encoder for `size` inputs.
    pub fn new(size: Size, device: &Device) -> Self {
        let ch = encoder_channels(&[32, 64, 64, 128], size);
        let last = *ch.last().unwrap_or(&128);
        Self {
            trunk: ConvStack::new(1, &ch, device),
            pose: conv(last, CODE_CHANNELS, device),
            pose_norm: BatchNormConfig::new(CODE_CHANNELS).init(device),
            shear: conv(last, CODE_CHANNELS, device),
            shear_norm: BatchNormConfig::new(CODE_CHANNELS).init(device),
        }
    }

    /// `[batch, 1, s, s]` to two `[batch, 64, 8, 8]` codes.
    pub fn forward(&self, x: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        let h = self.trunk.forward(x);
        (
            relu(self.pose_norm.forward(self.pose.forward(h.clone()))),
            relu(self.shear_norm.forward(self.shear.forward(h))),
        )
    }
}

/// Tap decoder `D_T`: pose code to unsheared image.
#[derive(Module, Debug)]
pub struct TapDecoder {
    up: Upsampler,
}

impl TapDecoder {
    /// The decoder for `size` outputs.
    pub fn new(size: Size, device: &Device) -> Self {
        Self { up: Upsampler::new(CODE_CHANNELS, &decoder_channels(&[64, 64, 32, 32, 1], size), device) }
    }

    /// `[batch, 64, 8, 8]` to `[batch, 1, s, s]` in `(0, 1)`.
    pub fn forward(&self, pose: Tensor<4>) -> Tensor<4> {
        self.up.forward(pose)
    }
}

/// Shear decoder `D_S`: pose and shear codes to sheared image.
#[derive(Module, Debug)]
pub struct ShearDecoder {
    up: Upsampler,
}

impl ShearDecoder {
    /// The decoder for `size` outputs.
    pub fn new(size: Size, device: &Device) -> Self {
        Self { up: Upsampler::new(2 * CODE_CHANNELS, &decoder_channels(&[128, 64, 64, 32, 1], size), device) }
    }

    /// Two `[batch, 64, 8, 8]` codes to `[batch, 1, s, s]` in `(0, 1)`.
    pub fn forward(&self, pose: Tensor<4>, shear: Tensor<4>) -> Tensor<4> {
        self.up.forward(Tensor::cat(vec![pose, shear], 1))
    }
}

/// Critic `C` of the optional adversarial term (not in the paper; see
/// [`crate::objective`]): a patch critic scoring every 8x8 cell of an image for how much it
/// looks like a tap image, as CycleGAN's discriminators do. Conv 32, 32, 64, 64 (batch norm,
/// ReLU), then a linear stride-2 Conv to one channel: `[batch, 1, 8, 8]` scores.
#[derive(Module, Debug)]
pub struct Critic {
    trunk: ConvStack,
    score: Conv2d,
}

impl Critic {
    /// The critic for `size` inputs.
    pub fn new(size: Size, device: &Device) -> Self {
        let ch = encoder_channels(&[32, 32, 64, 64], size);
        let last = *ch.last().unwrap_or(&64);
        Self { trunk: ConvStack::new(1, &ch, device), score: conv(last, 1, device) }
    }

    /// `[batch, 1, s, s]` to `[batch, 1, 8, 8]` unbounded scores (least-squares targets: 1
    /// for taps, 0 for unsheared images).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.score.forward(self.trunk.forward(x))
    }
}

/// Tap encoder `E_T`: unsheared image to pose code.
#[derive(Module, Debug)]
pub struct TapEncoder {
    trunk: ConvStack,
}

impl TapEncoder {
    /// The encoder for `size` inputs.
    pub fn new(size: Size, device: &Device) -> Self {
        Self { trunk: ConvStack::new(1, &encoder_channels(&[32, 32, 64, 64, 64], size), device) }
    }

    /// `[batch, 1, s, s]` to `[batch, 64, 8, 8]`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.trunk.forward(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_follow_the_paper_at_every_size_and_parameter_counts_are_documented() {
        let device = Device::flex();
        let mut counts = Vec::new();
        for size in [Size::S256, Size::S128, Size::S64, Size::S32] {
            let s = size.px();
            let x = Tensor::<4>::zeros([2, 1, s, s], &device);
            let (es, dt, ds, et) = (
                ShearEncoder::new(size, &device),
                TapDecoder::new(size, &device),
                ShearDecoder::new(size, &device),
                TapEncoder::new(size, &device),
            );
            let (pose, shear) = es.forward(x.clone());
            assert_eq!(pose.dims(), [2, CODE_CHANNELS, 8, 8], "{size:?}");
            assert_eq!(shear.dims(), [2, CODE_CHANNELS, 8, 8]);
            assert_eq!(dt.forward(pose.clone()).dims(), [2, 1, s, s]);
            assert_eq!(ds.forward(pose, shear).dims(), [2, 1, s, s]);
            assert_eq!(et.forward(x.clone()).dims(), [2, CODE_CHANNELS, 8, 8]);
            assert_eq!(Critic::new(size, &device).forward(x).dims(), [2, 1, 8, 8]);
            counts.push((size, es.num_params(), dt.num_params(), ds.num_params(), et.num_params()));
        }
        for c in &counts {
            println!("{:?}: E_S {}, D_T {}, D_S {}, E_T {}", c.0, c.1, c.2, c.3, c.4);
        }
        // 256 px, by hand: E_S convs (1-32-64-64-128, then two 128-64 heads, 4x4 kernels with
        // bias) plus batch norms (burn counts 4 values per channel: scale, shift and the two
        // running statistics).
        let conv = |a: usize, b: usize| 16 * a * b + b;
        let es = conv(1, 32)
            + conv(32, 64)
            + conv(64, 64)
            + conv(64, 128)
            + 2 * conv(128, 64)
            + 4 * (32 + 64 + 64 + 128 + 64 + 64);
        assert_eq!(counts[0].1, es);
    }

    /// Per-channel mean and variance (over batch and pixels) of `y`, by tensor ops.
    fn channel_statistics(y: Tensor<4>) -> (Vec<f32>, Vec<f32>) {
        let [_, c, _, _] = y.dims();
        let flat: Tensor<2> = y.swap_dims(0, 1).reshape([c as i32, -1]);
        let mean = flat.clone().mean_dim(1);
        let var = (flat - mean.clone()).powi_scalar(2).mean_dim(1);
        let v = |t: Tensor<2>| t.into_data().try_to_vec::<f32>().unwrap_or_default();
        (v(mean), v(var))
    }

    #[test]
    fn adapted_norms_hold_the_new_images_statistics_layer_by_layer() {
        let device = Device::flex();
        let stack = ConvStack::new(1, &[4, 6], &device);
        let images: Vec<f32> = (0..24 * 16 * 16).map(|k| ((k * 7919 % 1000) as f32 / 1000.0).powi(3)).collect();
        let all = Tensor::<4>::from_data(TensorData::new(images, [24, 1, 16, 16]), &device);
        let batches = [all.clone().narrow(0, 0, 16), all.clone().narrow(0, 16, 8)];
        let adapted = stack.adapt_norms(&batches);
        let mut x = all;
        for (c, n) in adapted.convs.iter().zip(&adapted.norms) {
            let y = c.forward(x);
            let (mean, var) = channel_statistics(y.clone());
            let v = |t: Tensor<1>| t.into_data().try_to_vec::<f32>().unwrap_or_default();
            let (rm, rv) = (v(n.running_mean.value()), v(n.running_var.value()));
            for k in 0..mean.len() {
                assert!((rm[k] - mean[k]).abs() < 1e-4 * (1.0 + mean[k].abs()), "mean {k}: {} vs {}", rm[k], mean[k]);
                assert!((rv[k] - var[k]).abs() < 1e-3 * var[k], "variance {k}: {} vs {}", rv[k], var[k]);
            }
            // A fresh norm holds 0 and 1: the statistics must have moved.
            assert!(rv.iter().any(|&v| (v - 1.0).abs() > 0.01));
            x = relu(n.forward(y));
        }
    }
}
