//! Domain randomisation: one sample's departure from the nominal sensor and image, so that a
//! network trained on simulated images meets, during training, the spread between TacTips
//! (camera mounting, pin size, optics, processing, rig) that real images carry.
//!
//! Drawn per sample from a recipe's `[randomise]` ranges (`dataset::recipe::RandomiseSpec`),
//! applied by [`crate::PinRenderer::render_varied`] (image side) and by the plan (the rig's
//! depth offset). Units: px at the rendered image size, deg, mm.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::camera::Disc;

/// One sample's variation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variation {
    /// Shift of the pin field in the image `[right, down]` (px): the camera's principal
    /// point off the dome's axis, or a crop centred elsewhere.
    pub shift_px: [f64; 2],
    /// Roll of the pins about the sensor's z axis, the camera's axis (deg, right-handed): a
    /// camera mounted at another angle to the dome; the labels keep the sensor's frame.
    pub roll_deg: f64,
    /// Factor on the pin tips' radius.
    pub pin_scale: f64,
    /// Added to the pressed depth (mm), the label unchanged: a rig whose depth zero is not
    /// the first contact.
    pub depth_offset_mm: f64,
    /// Standard deviation of a Gaussian blur of the pin coverage before the threshold (px).
    pub blur_px: f64,
    /// Coverage at which a pixel turns white (0.5: the nominal binary renderer).
    pub threshold: f64,
    /// Bright specks (dust, glare) drawn into the image.
    pub specks: u32,
    /// Seed of the specks' places and sizes.
    pub speck_seed: u64,
    /// Standard deviation (px, each axis) of a random offset of every pin in the image: a pin
    /// lattice that, as a real TacTip's, sits off the perfect layout pin by pin (0: none).
    pub pin_jitter_px: f64,
    /// Seed of the pins' offsets.
    pub jitter_seed: u64,
}

impl Variation {
    /// No variation: the nominal sensor and binary renderer.
    pub const NOMINAL: Variation = Variation {
        shift_px: [0.0, 0.0],
        roll_deg: 0.0,
        pin_scale: 1.0,
        depth_offset_mm: 0.0,
        blur_px: 0.0,
        threshold: 0.5,
        specks: 0,
        speck_seed: 0,
        pin_jitter_px: 0.0,
        jitter_seed: 0,
    };

    /// Whether the image needs the coverage path (blur or a threshold other than 1/2).
    pub fn needs_coverage(&self) -> bool {
        self.blur_px > 0.0 || self.threshold != 0.5
    }

    /// The specks as discs: centres uniform over the disc of radius `field_px` about
    /// `centre`, radii uniform in `[0.4, 1.2]` px per 128 px of image `size`.
    pub fn speck_discs(&self, centre: [f64; 2], field_px: f64, size: u32) -> Vec<Disc> {
        let mut rng = ChaCha8Rng::seed_from_u64(self.speck_seed);
        let k = f64::from(size) / 128.0;
        (0..self.specks)
            .map(|_| {
                let (a, t, r): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
                let rho = field_px * t.sqrt();
                let phi = std::f64::consts::TAU * a;
                Disc { u: centre[0] + rho * phi.cos(), v: centre[1] + rho * phi.sin(), r: k * (0.4 + 0.8 * r) }
            })
            .collect()
    }
}

impl Variation {
    /// Each of `count` pins' image offset `[du, dv]` (px): independent normal draws of
    /// standard deviation [`Self::pin_jitter_px`] (Box-Muller on the jitter's own stream), all
    /// zero without jitter.
    pub fn pin_jitter(&self, count: usize) -> Vec<[f64; 2]> {
        if self.pin_jitter_px <= 0.0 {
            return vec![[0.0; 2]; count];
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.jitter_seed);
        (0..count)
            .map(|_| {
                // 1 - u in (0, 1]: the logarithm stays finite.
                let (u, a): (f64, f64) = (rng.random(), rng.random());
                let rho = self.pin_jitter_px * (-2.0 * (1.0 - u).ln()).sqrt();
                let phi = std::f64::consts::TAU * a;
                [rho * phi.cos(), rho * phi.sin()]
            })
            .collect()
    }
}

impl Default for Variation {
    fn default() -> Self {
        Self::NOMINAL
    }
}
