//! The shear-removal model: the four networks of [`crate::network`] and the paper's mappings
//! between the tap domain T and the sheared domain S (Methods, "Formulation"):
//!
//! - `M: S -> T`, `M(x_s) = D_T(pose(E_S(x_s)))`: removes shear ([`Unshear::unshear`]);
//! - `N: S -> S`, `N(x_s) = D_S(E_S(x_s))`: reconstructs the sheared input
//!   ([`Unshear::reconstruct`]);
//! - `K: T -> S`, `K(x_t; z_s) = D_S(E_T(x_t), z_s)`: adds the shear code `z_s` of a sheared
//!   sample to a tap image ([`Unshear::shear`]).
//!
//! A model trained with the optional adversarial term (not in the paper, off by default)
//! also holds that term's critic; inference never uses it.

use burn::module::Module;
use burn::tensor::{Device, Tensor};

use crate::checkpoint::canonical_ids;
use crate::network::{Critic, ShearDecoder, ShearEncoder, Size, TapDecoder, TapEncoder};

/// The paper's model: shear encoder, tap decoder, shear decoder and tap encoder.
#[derive(Module, Debug)]
pub struct Unshear {
    /// `E_S`: sheared image to pose and shear codes.
    pub es: ShearEncoder,
    /// `D_T`: pose code to unsheared image.
    pub dt: TapDecoder,
    /// `D_S`: pose and shear codes to sheared image.
    pub ds: ShearDecoder,
    /// `E_T`: unsheared image to pose code.
    pub et: TapEncoder,
    /// The critic of the adversarial term, when training uses it (last, so that the four
    /// networks' parameter ids are the same with and without it).
    pub critic: Option<Critic>,
}

impl Unshear {
    /// A freshly initialised model for `size` images, N(0, 0.02) weights. Its parameters
    /// are materialised and numbered in module order (`checkpoint::canonical_ids`): the
    /// self-supervised objective's no-gradient copy of D_S relies on the first, checkpoints
    /// on the second.
    pub fn new(size: Size, device: &Device) -> Self {
        canonical_ids(Self {
            es: ShearEncoder::new(size, device),
            dt: TapDecoder::new(size, device),
            ds: ShearDecoder::new(size, device),
            et: TapEncoder::new(size, device),
            critic: None,
        })
    }

    /// The model with a fresh critic for the adversarial term (replacing any it had), its
    /// four networks as they are: a run that starts from another run's weights gets its
    /// critic after loading them. Weights saved from it load into a model without one (the
    /// critic's are left unused).
    pub fn with_critic(self, size: Size, device: &Device) -> Self {
        canonical_ids(Self { critic: Some(Critic::new(size, device)), ..self })
    }

    /// `E_S(x_s)`: the pose and shear codes of sheared images.
    pub fn codes(&self, sheared: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        self.es.forward(sheared)
    }

    /// `M(x_s)`: the unsheared images.
    pub fn unshear(&self, sheared: Tensor<4>) -> Tensor<4> {
        self.dt.forward(self.es.forward(sheared).0)
    }

    /// `N(x_s)`: the reconstructed sheared images.
    pub fn reconstruct(&self, sheared: Tensor<4>) -> Tensor<4> {
        let (pose, shear) = self.es.forward(sheared);
        self.ds.forward(pose, shear)
    }

    /// `K(x_t; z_s)`: tap images with the shear code `z_s` added.
    pub fn shear(&self, taps: Tensor<4>, shear_code: Tensor<4>) -> Tensor<4> {
        self.ds.forward(self.et.forward(taps), shear_code)
    }

    /// Disentanglement ablation 1: the unsheared image decoded from the *shear* code,
    /// `D_T(shear(E_S(x_s)))`.
    pub fn unshear_from_shear_code(&self, sheared: Tensor<4>) -> Tensor<4> {
        self.dt.forward(self.es.forward(sheared).1)
    }

    /// Disentanglement ablation 2: the sheared image decoded from the pose code alone (shear
    /// code zeroed), `D_S(pose(E_S(x_s)), 0)`.
    pub fn reconstruct_from_pose_code(&self, sheared: Tensor<4>) -> Tensor<4> {
        let (pose, shear) = self.es.forward(sheared);
        self.ds.forward(pose, shear.zeros_like())
    }
}
