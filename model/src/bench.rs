//! Throughput of training and inference, for `cargo xtask bench-model`: training samples/s of
//! a self-supervised step (both cycles and the reconstruction), a supervised step (with the
//! patch loss) and a pose-network step, and unshear inference images/s, on random images.
//! Speed is measured here and reported, never asserted in tests.

use std::time::Instant;

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Distribution, Tensor};
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use crate::backend::Backend;
use crate::config::size_of;
use crate::error::Result;
use crate::objective::{self, Weights};
use crate::posenet::PoseNet;
use crate::unshear::Unshear;

/// One measured configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchRow {
    /// Backend.
    pub backend: String,
    /// Image side (px).
    pub size: usize,
    /// Batch size.
    pub batch: usize,
    /// Self-supervised training samples/s.
    pub self_supervised_samples_per_s: f64,
    /// Supervised training samples/s.
    pub supervised_samples_per_s: f64,
    /// Pose-network training samples/s.
    pub posenet_samples_per_s: f64,
    /// Unshear inference (`M`) images/s.
    pub inference_images_per_s: f64,
}

fn rate(samples: usize, mut f: impl FnMut()) -> f64 {
    f(); // warm-up
    let t = Instant::now();
    let mut n = 0;
    while n == 0 || t.elapsed().as_secs_f64() < 3.0 {
        f();
        n += 1;
    }
    (n * samples) as f64 / t.elapsed().as_secs_f64()
}

/// Measures one backend at one size (batch 32, the paper's).
pub fn measure(backend: Backend, size: usize) -> Result<BenchRow> {
    let batch = 32;
    let net = size_of(size)?;
    let device = backend.training_device();
    let w = Weights { patch: 0.1, l1: 1e-7, l2: 1e-6, adversarial: 0.0 };
    let img = || Tensor::<4>::random([batch, 1, size, size], Distribution::Uniform(0.0, 1.0), &device);
    let mut model = Some(Unshear::new(net, &device));
    let mut optim = AdamConfig::new().init();
    let mut step = |supervised: bool| {
        let m = model.take().expect("model");
        let (g, _) = if supervised {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
            let mask = objective::patch_mask(batch, size, 100, (20 * size / 256).max(4), &mut rng, &device);
            objective::supervised(&m, img(), img(), Some(mask), w)
        } else {
            objective::self_supervised(&m, img(), img(), w)
        };
        model = Some(optim.step(1e-4, m, g));
    };
    let ss = rate(batch, || step(false));
    let sup = rate(batch, || step(true));
    // The default labels: x, y and the yaw as (sin, cos).
    let mut pose = Some(PoseNet::new(net, 128, 4, &device));
    let mut popt = AdamConfig::new().init();
    let target = Tensor::<2>::zeros([batch, 4], &device);
    let ps = rate(batch, || {
        let p = pose.take().expect("posenet");
        let loss = (p.forward(img()) - target.clone()).square().mean();
        let g = GradientsParams::from_grads(loss.backward(), &p);
        pose = Some(popt.step(1e-3, p, g));
    });
    let valid = model.expect("model").valid();
    let plain = backend.device();
    let x = Tensor::<4>::random([batch, 1, size, size], Distribution::Uniform(0.0, 1.0), &plain);
    let inf = rate(batch, || {
        let _ = valid.unshear(x.clone()).into_data();
    });
    Ok(BenchRow {
        backend: backend.to_string(),
        size,
        batch,
        self_supervised_samples_per_s: ss,
        supervised_samples_per_s: sup,
        posenet_samples_per_s: ps,
        inference_images_per_s: inf,
    })
}
