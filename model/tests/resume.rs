//! Interrupted training resumes to the same model. This test has a binary of its own: with
//! other trainings running concurrently in the same process, burn's batch-norm running
//! statistics (kept per thread and folded in lazily) were seen to drift apart even though the
//! weights stayed bit-identical.

mod common;

use std::cell::Cell;
use std::path::Path;

use burn::module::Module;
use burn::tensor::Device;
use tacsim_model::{
    Backend, Corpus, Mode, ModelError, Progress, Silent, Size, Unshear, UnshearConfig, load_weights, to_images,
    train_unshear,
};

/// Stops after a number of steps, like Ctrl-C.
struct StopAfter {
    left: Cell<usize>,
}

impl Progress for StopAfter {
    fn step(&mut self, _: &tacsim_model::StepLosses) {
        self.left.set(self.left.get().saturating_sub(1));
    }
    fn stop(&self) -> bool {
        self.left.get() == 0
    }
}

/// The model's unsheared outputs on a fixed batch, from its saved weights.
fn outputs(corpus: &Corpus, run: &Path) -> Vec<Vec<f32>> {
    let device = Device::flex();
    let model = load_weights(Unshear::new(Size::S64, &device), &run.join("model.safetensors")).expect("weights");
    to_images(model.valid().unshear(corpus.batch(&[0, 5, 9, 30], &[(0, 0); 4], &device)))
}

#[test]
fn interrupted_run_resumes_to_the_same_weights_and_refuses_a_changed_config() {
    let dir = common::scratch("resume");
    common::write_dataset(&dir.join("data"), 64, 12, 2, 4, 2);
    let corpus = Corpus::open(&dir.join("data"), 64).expect("open synthetic dataset");
    let cfg = UnshearConfig {
        mode: Mode::SemiSupervised,
        size: 64,
        batch: 8,
        self_supervised_epochs: 2,
        supervised_epochs: 2,
        label_fraction: 0.25,
        patch_count: 10,
        ..UnshearConfig::default()
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    train_unshear(&corpus, &cfg, Backend::Flex, &a, false, None, &mut Silent).expect("uninterrupted");
    // Interrupt mid-epoch (3 batches per self-supervised epoch), then across the phase change.
    for stop in [2, 4] {
        let err =
            train_unshear(&corpus, &cfg, Backend::Flex, &b, stop != 2, None, &mut StopAfter { left: Cell::new(stop) })
                .expect_err("stops");
        assert!(matches!(err, ModelError::Interrupted { .. }), "{err}");
    }
    let err = train_unshear(&corpus, &cfg, Backend::Flex, &b, false, None, &mut Silent).expect_err("needs --resume");
    assert!(err.to_string().contains("--resume"), "{err}");
    let other = UnshearConfig { seed: 9, ..cfg.clone() };
    let err = train_unshear(&corpus, &other, Backend::Flex, &b, true, None, &mut Silent).expect_err("other config");
    assert!(err.to_string().contains("another config"), "{err}");
    // Resuming on other data silently went on with it (issue 32): refused by its fingerprint.
    common::write_dataset(&dir.join("other"), 64, 12, 2, 4, 3);
    let other_data = Corpus::open(&dir.join("other"), 64).expect("open the other dataset");
    assert_ne!(other_data.fingerprint(), corpus.fingerprint());
    let err = train_unshear(&other_data, &cfg, Backend::Flex, &b, true, None, &mut Silent).expect_err("other data");
    assert!(err.to_string().contains("other data") && err.to_string().contains("data.json"), "{err}");
    train_unshear(&corpus, &cfg, Backend::Flex, &b, true, None, &mut Silent).expect("resumed");
    assert!(outputs(&corpus, &a) == outputs(&corpus, &b), "resumed run ended elsewhere");
}
