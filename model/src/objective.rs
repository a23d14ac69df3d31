//! The paper's losses and per-module objectives (Methods, "Formulation").
//!
//! With `x_s` sheared and `x_t` tap images and the mappings of [`crate::unshear`]:
//!
//! - cycle consistency `L_cyc = E|x_s - K(M(x_s); z_s(x_s))|^2 + E|x_t - M(K(x_t; z_s(x_s')))|^2`
//!   (forward and backward cycles; the backward cycle borrows the shear code of the batch's
//!   sheared sample `x_s'`, unpaired in the self-supervised phase);
//! - reconstruction `L_rec = E|x_s - N(x_s)|^2`;
//! - supervised `L_sup = E|x_t - M(x_s)|^2` on true pairs;
//! - patch `L_patch = E|crops(x_t) - crops(M(x_s))|_1` over `patch_count` random square crops
//!   per image, weighted by lambda = `patch_weight`;
//! - weight regularisation `l1 sum|w| + l2 sum w^2` over every conv and linear weight.
//!
//! Not in the paper, off by default (`adversarial_weight = 0`): an adversarial term in the
//! self-supervised phase, as CycleGAN pairs its cycle losses with. The paper's cycles and
//! reconstruction are all met by `M` close to the identity with the shear left in the pose
//! code (docs/guide/learning.md, "The CPU-scale study"); a critic `C` that tells tap images from `M`'s output
//! rules that out. Least-squares GAN losses over `C`'s 8x8 patch scores:
//!
//! - critic `L_C = (E(C(x_t) - 1)^2 + E C(M(x_s))^2) / 2`, with `M(x_s)` detached;
//! - generator `L_adv = E(C(M(x_s)) - 1)^2`, weighted by `adversarial_weight`, through a
//!   no-gradient copy of `C` (as the cycles' copy of D_S), so E_S and D_T learn from it and
//!   `C` from `L_C` alone.
//!
//! The squared norms are per-pixel means (MSE). Per-module objectives: E_S minimises every
//! term, E_T `L_cyc`, D_T `L_cyc + L_sup + lambda L_patch` and D_S `L_rec` alone. One backward
//! pass over the sum gives exactly these gradients: in the supervised phase no other term
//! reaches D_S, and in the self-supervised phase the cycles run through a copy of D_S whose
//! parameters take no gradient (gradients still flow through it to E_T and E_S). The copy
//! shares D_S's parameters, so they must be materialised first, or the copy's `no_grad()`
//! would switch them off in D_S too: [`Unshear::new`] materialises them.

use burn::module::{Module, ModuleVisitor, Param};
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor, TensorData};
use rand::Rng;

use crate::unshear::Unshear;

/// The loss terms of one step (batch means), for logs and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct StepLosses {
    /// Forward cycle `x_s -> M -> K -> x_s`.
    pub cycle_forward: f64,
    /// Backward cycle `x_t -> K -> M -> x_t`.
    pub cycle_backward: f64,
    /// Sheared reconstruction `L_rec`.
    pub reconstruction: f64,
    /// Supervised L2 `L_sup`.
    pub supervised: f64,
    /// L1 patch loss (unweighted).
    pub patch: f64,
    /// Weight regularisation (weighted).
    pub regularisation: f64,
    /// Adversarial generator term `L_adv` (unweighted; 0 without the critic).
    pub adversarial: f64,
    /// The critic's loss `L_C` (0 without the critic).
    pub critic: f64,
    /// The sum that was minimised.
    pub total: f64,
}

impl StepLosses {
    /// Every term combined with the same term of `other` by `f` (sums, means).
    pub fn combine(&self, other: &StepLosses, f: impl Fn(f64, f64) -> f64) -> StepLosses {
        StepLosses {
            cycle_forward: f(self.cycle_forward, other.cycle_forward),
            cycle_backward: f(self.cycle_backward, other.cycle_backward),
            reconstruction: f(self.reconstruction, other.reconstruction),
            supervised: f(self.supervised, other.supervised),
            patch: f(self.patch, other.patch),
            regularisation: f(self.regularisation, other.regularisation),
            adversarial: f(self.adversarial, other.adversarial),
            critic: f(self.critic, other.critic),
            total: f(self.total, other.total),
        }
    }
}

/// Weights of the terms that are not on/off by phase.
#[derive(Clone, Copy, Debug)]
pub struct Weights {
    /// lambda of the patch loss.
    pub patch: f64,
    /// L1 weight penalty.
    pub l1: f64,
    /// L2 weight penalty.
    pub l2: f64,
    /// Weight of the adversarial generator term (0: the paper's objective).
    pub adversarial: f64,
}

/// Mean squared error (a scalar tensor).
pub fn mse(a: Tensor<4>, b: Tensor<4>) -> Tensor<1> {
    (a - b).square().mean()
}

fn scalar(t: &Tensor<1>) -> f64 {
    t.clone().into_scalar::<f32>() as f64
}

/// The self-supervised objective on a batch of unpaired sheared and tap images: the
/// gradients of every module's objective, and the loss values.
pub fn self_supervised(
    model: &Unshear,
    sheared: Tensor<4>,
    taps: Tensor<4>,
    w: Weights,
) -> (GradientsParams, StepLosses) {
    // The cycles run through a no-gradient copy of D_S (module docs): D_S learns from L_rec.
    let ds_cycle = model.ds.clone().no_grad();
    let (pose, shear) = model.es.forward(sheared.clone());
    // Forward cycle: x_s -> M(x_s) -> K(M(x_s); z_s).
    let unsheared = model.dt.forward(pose.clone());
    let back = ds_cycle.forward(model.et.forward(unsheared.clone()), shear.clone());
    let cycle_forward = mse(back, sheared.clone());
    let reconstruction = mse(model.ds.forward(pose, shear.clone()), sheared);
    // Backward cycle: x_t -> K(x_t; z_s) -> M(K(x_t)).
    let k = ds_cycle.forward(model.et.forward(taps.clone()), shear);
    let cycle_backward = mse(model.unshear(k), taps.clone());
    let mut objective = cycle_forward.clone() + cycle_backward.clone() + reconstruction.clone();
    let (mut adversarial_value, mut critic_value) = (0.0, 0.0);
    if let Some(critic) = model.critic.as_ref().filter(|_| w.adversarial > 0.0) {
        let real = critic.forward(taps);
        let fake = critic.forward(unsheared.clone().detach());
        let critic_loss = (real.sub_scalar(1.0).square().mean() + fake.square().mean()).mul_scalar(0.5);
        let adversarial = critic.clone().no_grad().forward(unsheared).sub_scalar(1.0).square().mean();
        (adversarial_value, critic_value) = (scalar(&adversarial), scalar(&critic_loss));
        objective = objective + adversarial.mul_scalar(w.adversarial) + critic_loss;
    }
    let (total, reg) = with_regularisation(objective, model, w);
    let losses = StepLosses {
        cycle_forward: scalar(&cycle_forward),
        cycle_backward: scalar(&cycle_backward),
        reconstruction: scalar(&reconstruction),
        regularisation: reg,
        adversarial: adversarial_value,
        critic: critic_value,
        total: scalar(&total),
        ..StepLosses::default()
    };
    (GradientsParams::from_grads(total.backward(), model), losses)
}

/// The supervised objective on true pairs; `mask` is the patch-crop coverage of
/// [`patch_mask`] (or `None` when the patch loss is off). Returns the gradients and the loss
/// values.
pub fn supervised(
    model: &Unshear,
    sheared: Tensor<4>,
    taps: Tensor<4>,
    mask: Option<(Tensor<4>, f64)>,
    w: Weights,
) -> (GradientsParams, StepLosses) {
    let (pose, shear) = model.es.forward(sheared.clone());
    let unsheared = model.dt.forward(pose.clone());
    let reconstruction = mse(model.ds.forward(pose, shear), sheared);
    let sup = mse(unsheared.clone(), taps.clone());
    let (mut total, reg) = with_regularisation(reconstruction.clone() + sup.clone(), model, w);
    let mut patch_value = 0.0;
    if let Some((mask, norm)) = mask {
        let patch = ((unsheared - taps).abs() * mask).sum().div_scalar(norm);
        patch_value = scalar(&patch);
        total = total + patch.mul_scalar(w.patch);
    }
    let losses = StepLosses {
        reconstruction: scalar(&reconstruction),
        supervised: scalar(&sup),
        patch: patch_value,
        regularisation: reg,
        total: scalar(&total),
        ..StepLosses::default()
    };
    (GradientsParams::from_grads(total.backward(), model), losses)
}

/// Coverage mask of `count` random `crop x crop` squares per image of a `[batch, 1, side,
/// side]` batch, and the normaliser `batch * count * crop^2`: `sum(mask * |a - b|) / norm`
/// is the mean L1 over all crops, crops overlapping where they fall.
pub fn patch_mask<R: Rng>(
    batch: usize,
    side: usize,
    count: usize,
    crop: usize,
    rng: &mut R,
    device: &Device,
) -> (Tensor<4>, f64) {
    let mut mask = vec![0f32; batch * side * side];
    let span = side - crop + 1;
    for b in 0..batch {
        let img = &mut mask[b * side * side..(b + 1) * side * side];
        for _ in 0..count {
            let (x0, y0) = (rng.random_range(0..span), rng.random_range(0..span));
            for y in y0..y0 + crop {
                for v in &mut img[y * side + x0..y * side + x0 + crop] {
                    *v += 1.0;
                }
            }
        }
    }
    let norm = (batch * count * crop * crop) as f64;
    (Tensor::from_data(TensorData::new(mask, [batch, 1, side, side]), device), norm)
}

/// `loss` plus the weight regularisation of `module`, and the regularisation's value.
pub fn with_regularisation<M: Module>(loss: Tensor<1>, module: &M, w: Weights) -> (Tensor<1>, f64) {
    match regularisation(module, w) {
        Some(reg) => {
            let value = scalar(&reg);
            (loss + reg, value)
        }
        None => (loss, 0.0),
    }
}

/// `l1 sum|w| + l2 sum w^2` over the module's weights of rank 2 and above (convolutions and
/// linear layers; biases and batch-norm parameters are not penalised); `None` when both
/// weights are 0.
pub fn regularisation<M: Module>(module: &M, w: Weights) -> Option<Tensor<1>> {
    if w.l1 == 0.0 && w.l2 == 0.0 {
        return None;
    }
    struct Penalty {
        l1: f64,
        l2: f64,
        sum: Option<Tensor<1>>,
    }
    impl ModuleVisitor for Penalty {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            if D < 2 {
                return;
            }
            let v = param.val();
            let term = v.clone().abs().sum().mul_scalar(self.l1) + v.square().sum().mul_scalar(self.l2);
            self.sum = Some(match self.sum.take() {
                Some(s) => s + term,
                None => term,
            });
        }
    }
    let mut p = Penalty { l1: w.l1, l2: w.l2, sum: None };
    module.visit(&mut p);
    p.sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::Size;
    use burn::tensor::Distribution;
    use rand::SeedableRng;

    /// Every gradient a `GradientsParams` holds for a module's parameters, flattened.
    fn grads_of<M: Module>(m: &M, grads: &GradientsParams) -> Vec<f32> {
        struct Collect<'a>(&'a GradientsParams, Vec<f32>);
        impl ModuleVisitor for Collect<'_> {
            fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
                if let Some(g) = self.0.get::<D>(param.id) {
                    self.1.extend(g.into_data().try_to_vec::<f32>().unwrap_or_default());
                }
            }
        }
        let mut c = Collect(grads, Vec::new());
        m.visit(&mut c);
        c.1
    }

    /// The largest difference between two gradient lists, and the largest magnitude of `b`.
    fn max_diff(a: &[f32], b: &[f32]) -> (f32, f32) {
        assert_eq!(a.len(), b.len());
        let err = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        (err, b.iter().map(|g| g.abs()).fold(0.0f32, f32::max))
    }

    /// The per-module objectives: the gradients handed to the optimizer give D_S exactly the
    /// gradient of `L_rec`, while E_S, E_T and D_T learn from the cycles too. Regression: on a
    /// module with lazily initialised parameters the cycles' `no_grad()` copy of D_S switched
    /// off D_S's own gradients; `Unshear::new` now materialises them.
    #[test]
    fn shear_decoder_learns_from_the_reconstruction_loss_alone() {
        let device = Device::flex().autodiff();
        let model = Unshear::new(Size::S64, &device);
        let s = Tensor::<4>::random([4, 1, 64, 64], Distribution::Uniform(0.0, 1.0), &device);
        let t = Tensor::<4>::random([4, 1, 64, 64], Distribution::Uniform(0.0, 1.0), &device);
        let w = Weights { patch: 0.1, l1: 0.0, l2: 0.0, adversarial: 0.0 };
        let (grads, _) = self_supervised(&model, s.clone(), t, w);
        let (pose, shear) = model.es.forward(s.clone());
        let rec = GradientsParams::from_grads(mse(model.ds.forward(pose, shear), s).backward(), &model);
        let (from_step, from_rec) = (grads_of(&model.ds, &grads), grads_of(&model.ds, &rec));
        assert!(!from_rec.is_empty() && from_rec.iter().any(|g| *g != 0.0));
        let (err, scale) = max_diff(&from_step, &from_rec);
        assert!(err <= 1e-5 * scale, "D_S gradient differs from L_rec's: {err} (scale {scale})");
        // Every other module learns from the step too.
        for g in [grads_of(&model.es, &grads), grads_of(&model.et, &grads), grads_of(&model.dt, &grads)] {
            assert!(g.iter().any(|v| *v != 0.0));
        }
    }

    /// The adversarial term: the critic's gradient is that of `L_C` alone (the generator's
    /// term reaches it through a no-gradient copy), while the term changes what D_T learns;
    /// D_S still learns from `L_rec` alone.
    #[test]
    fn critic_learns_from_its_own_loss_alone_and_the_tap_decoder_from_the_adversarial_term() {
        let device = Device::flex().autodiff();
        let model = Unshear::new(Size::S64, &device).with_critic(Size::S64, &device);
        let s = Tensor::<4>::random([4, 1, 64, 64], Distribution::Uniform(0.0, 1.0), &device);
        let t = Tensor::<4>::random([4, 1, 64, 64], Distribution::Uniform(0.0, 1.0), &device);
        let w = Weights { patch: 0.1, l1: 0.0, l2: 0.0, adversarial: 0.5 };
        let (grads, losses) = self_supervised(&model, s.clone(), t.clone(), w);
        assert!(losses.critic > 0.0 && losses.adversarial > 0.0, "{losses:?}");
        let critic = model.critic.as_ref().expect("critic");
        let fake = model.unshear(s.clone()).detach();
        let own = (critic.forward(t.clone()).sub_scalar(1.0).square().mean() + critic.forward(fake).square().mean())
            .mul_scalar(0.5);
        let own = GradientsParams::from_grads(own.backward(), &model);
        let (from_step, from_own) = (grads_of(critic, &grads), grads_of(critic, &own));
        assert!(!from_own.is_empty() && from_own.iter().any(|g| *g != 0.0));
        let (err, scale) = max_diff(&from_step, &from_own);
        assert!(err <= 1e-5 * scale, "critic gradient differs from L_C's: {err} (scale {scale})");
        let (paper, paper_losses) = self_supervised(&model, s, t, Weights { adversarial: 0.0, ..w });
        assert_eq!((paper_losses.critic, paper_losses.adversarial), (0.0, 0.0));
        assert!(grads_of(critic, &paper).is_empty(), "the paper's objective trained the critic");
        assert_ne!(grads_of(&model.dt, &grads), grads_of(&model.dt, &paper));
        let (err, scale) = max_diff(&grads_of(&model.ds, &grads), &grads_of(&model.ds, &paper));
        assert!(err <= 1e-5 * scale, "the adversarial term reached D_S: {err} (scale {scale})");
    }

    #[test]
    fn patch_mask_is_the_mean_l1_over_crops() {
        let device = Device::flex();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let (mask, norm) = patch_mask(2, 16, 5, 4, &mut rng, &device);
        // |a - b| = 1 everywhere: every crop's mean L1 is 1.
        let ones = Tensor::<4>::ones([2, 1, 16, 16], &device);
        let v = (ones * mask.clone()).sum().div_scalar(norm).into_scalar::<f32>();
        assert!((v - 1.0).abs() < 1e-6, "{v}");
        assert_eq!(mask.sum().into_scalar::<f32>() as f64, norm);
    }
}
