//! The bench's samples: taps and slides on the built-in disk's top and taps across its rim,
//! from fixed seeds, and the disk's scene.

use crate::error::Result;
use crate::{ObjectPose, Scene, SensorPose};

/// Slide length of the paper's protocol (mm).
pub const SLIDE_MM: f64 = 2.5;
/// Default slide step (mm).
pub const STEP_MM: f64 = 0.25;

/// Deterministic generator (SplitMix64) for the sample poses.
struct Rng(tacsim_data::SplitMix64);

impl Rng {
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.next_f64()
    }
}

/// The seed of the bench's taps and slides on the disk's top ([`samples`]).
pub const SAMPLES_SEED: u64 = 1;
/// The seed of the bench's taps across the disk's rim ([`rim_samples`]).
pub const RIM_SEED: u64 = 2;

/// Sample poses over the disk: the paper's tap ranges (depth 1-5 mm, any yaw), centre within
/// 20 mm of the disk's centre, and a slide direction. The bench's: `n` from [`SAMPLES_SEED`]
/// (its grid curve takes the first 40).
pub fn samples(n: usize, seed: u64) -> Vec<(SensorPose, [f64; 2])> {
    let mut rng = Rng(tacsim_data::SplitMix64(seed));
    (0..n)
        .map(|_| {
            let pose = SensorPose::new(
                rng.range(-20.0, 20.0),
                rng.range(-20.0, 20.0),
                rng.range(1.0, 5.0),
                rng.range(-180.0, 180.0),
            );
            let a = rng.range(0.0, std::f64::consts::TAU);
            (pose, [SLIDE_MM * a.cos(), SLIDE_MM * a.sin()])
        })
        .collect()
}

/// Taps across the disk's rim (its edge at x = 50 mm): centre 44-54 mm from the disk's centre
/// (the edge 6 mm inside to 4 mm outside the apex), depth 1-5 mm, any yaw. The bench's: 40
/// from [`RIM_SEED`].
pub fn rim_samples(n: usize, seed: u64) -> Vec<(SensorPose, [f64; 2])> {
    let mut rng = Rng(tacsim_data::SplitMix64(seed));
    (0..n)
        .map(|_| {
            let pose = SensorPose::new(
                rng.range(44.0, 54.0),
                rng.range(-5.0, 5.0),
                rng.range(1.0, 5.0),
                rng.range(-180.0, 180.0),
            );
            (pose, [0.0, 0.0])
        })
        .collect()
}

/// The bench's scene: the built-in `disk` (100 mm across) at the origin.
pub fn disk_scene() -> Result<Scene> {
    disk_scene_with_friction(None)
}

/// [`disk_scene`] with the skin-stimulus friction `friction` where one is given (`Some(0.0)`:
/// no shear but the coupling's), else the disk's own.
pub fn disk_scene_with_friction(friction: Option<f64>) -> Result<Scene> {
    let catalogue = crate::builtin_catalogue()?;
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk")?.with_friction(friction), ObjectPose::default())?;
    Ok(scene)
}
