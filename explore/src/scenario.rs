//! Exploration scenario files: the shape, where and how to start, the servo, the perception
//! and the pass criteria. Every field has a default; unknown fields are errors.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{ExploreError, Result};

/// Returns a [`ExploreError::Scenario`] for scenario `$s`: field and value in the message.
macro_rules! bail {
    ($s:expr, $($arg:tt)*) => {
        return Err(ExploreError::scenario(format!("scenario {}", $s.name), format!($($arg)*)))
    };
}

/// How the pose relative to the edge is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PerceptionKind {
    /// The true pose from the shape's geometry; no image is rendered.
    Oracle,
    /// Model-free: the contact patch read off the tracked pins of the rendered image
    /// ([`crate::perception::Geometric`]).
    Geometric,
    /// The shear-removal model, then the pose network, on the rendered image
    /// (a [`crate::LearnedPerception`] the caller supplies; checkpoints in `[models]`).
    Learned,
    /// The pose network on the rendered (sheared) image directly.
    LearnedRaw,
}

/// A scenario (`scenarios/explore/*.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Name in reports (default: the file stem).
    pub name: String,
    /// Stimulus (`tacsim shapes`).
    pub shape: String,
    /// Start point near the edge (world mm); default: the catalogue's contact location, or the
    /// contour point nearest `+x`.
    pub start_mm: Option<[f64; 2]>,
    /// Pressing depth (mm).
    pub depth_mm: f64,
    /// Robot speed (mm/s), for the simulated time.
    pub speed_mm_s: f64,
    /// Distance moved along the edge per servo step (mm).
    pub step_mm: f64,
    /// Largest contact-engine sub-step within a move (mm).
    pub substep_mm: f64,
    /// Friction coefficient, overriding the stimulus's.
    pub friction: Option<f64>,
    /// Sensor file (TOML), relative to the scenario file; default: the sensor `tacsim run`
    /// is given (`--sensor`, else the built-in calibrated TacTip over a half-space,
    /// `tactip-331-calibrated`).
    pub sensor: Option<PathBuf>,
    /// Perception.
    pub perception: PerceptionKind,
    /// Image size (px) for image-based perception; learned perception renders at this size
    /// and resizes to its networks' side, as `tacsim train` resized the dataset (use the
    /// training recipe's `image_size`).
    pub image_size: u32,
    /// Trained runs for `learned` and `learned-raw` perception.
    pub models: Models,
    /// Noise added to the estimates.
    pub noise: Noise,
    /// Servo gains and references.
    pub control: Control,
    /// Step limit.
    pub max_steps: usize,
    /// Seed of the noise.
    pub seed: u64,
    /// Pass criteria.
    pub criteria: Criteria,
}

/// The trained run directories of learned perception (`tacsim train` outputs). Relative
/// paths are taken from the current directory. Defaults: the runs `cargo xtask explore`
/// trains on the `explore` recipe (poses in the edge frame).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Models {
    /// Pose network run (`tacsim train posenet`), trained on edge-frame labels.
    pub posenet: PathBuf,
    /// Shear-removal model run (`tacsim train unshear` or `baseline`), for `learned`.
    pub unshear: PathBuf,
}

impl Models {
    /// The same runs, by their directory names, under `dir` (`tacsim run --models DIR`):
    /// `target/explore/runs/baseline` becomes `DIR/baseline`.
    pub fn under(&self, dir: &std::path::Path) -> Self {
        let moved = |p: &PathBuf| p.file_name().map_or_else(|| dir.to_path_buf(), |name| dir.join(name));
        Self { posenet: moved(&self.posenet), unshear: moved(&self.unshear) }
    }
}

impl Default for Models {
    fn default() -> Self {
        Self { posenet: "target/explore/runs/posenet".into(), unshear: "target/explore/runs/unshear".into() }
    }
}

/// Most contact sub-steps per robot step (`step_mm / substep_mm`).
pub const MAX_SUBSTEPS: usize = 1000;

/// Gaussian noise on the perceived pose.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Noise {
    /// Standard deviation of the lateral offset (mm).
    pub offset_mm: f64,
    /// Standard deviation of the edge angle (deg).
    pub angle_deg: f64,
    /// Estimates arrive this many steps late.
    pub latency_steps: usize,
}

/// The PI servo of the lab's tactile servoing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Control {
    /// Lateral offset reference (mm, positive off the material).
    pub offset_ref_mm: f64,
    /// Proportional gain on the lateral offset.
    pub kp_offset: f64,
    /// Integral gain on the lateral offset.
    pub ki_offset: f64,
    /// Proportional gain on the edge angle.
    pub kp_angle: f64,
    /// Integral gain on the edge angle.
    pub ki_angle: f64,
    /// Clip of each integral term's contribution (mm, deg).
    pub integral_clip: f64,
}

/// What a run must achieve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Criteria {
    /// Smallest fraction of the contour covered before closing.
    pub completion: f64,
    /// Largest mean distance of the sensor centre from the contour (mm).
    pub mean_deviation_mm: f64,
    /// Largest distance of the sensor centre from the contour (mm).
    pub max_deviation_mm: f64,
    /// Largest mean yaw error against the edge (deg).
    pub yaw_error_deg: f64,
    /// Smallest IoU of the reconstructed footprint with the true one.
    pub iou: f64,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            name: String::new(),
            shape: "disk".into(),
            start_mm: None,
            depth_mm: 1.5,
            speed_mm_s: 20.0,
            step_mm: 2.0,
            substep_mm: 0.5,
            friction: None,
            sensor: None,
            perception: PerceptionKind::Oracle,
            image_size: 256,
            models: Models::default(),
            noise: Noise::default(),
            control: Control::default(),
            max_steps: 600,
            seed: 0,
            criteria: Criteria::default(),
        }
    }
}

impl Default for Noise {
    fn default() -> Self {
        Self { offset_mm: 0.0, angle_deg: 0.0, latency_steps: 0 }
    }
}

impl Default for Control {
    fn default() -> Self {
        Self { offset_ref_mm: 0.0, kp_offset: 0.5, ki_offset: 0.3, kp_angle: 0.5, ki_angle: 0.1, integral_clip: 5.0 }
    }
}

impl Default for Criteria {
    fn default() -> Self {
        Self { completion: 0.95, mean_deviation_mm: 1.0, max_deviation_mm: 3.0, yaw_error_deg: 10.0, iou: 0.9 }
    }
}

impl Scenario {
    /// Loads and validates a scenario file; the name defaults to the file stem.
    pub fn load(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).map_err(|source| ExploreError::Io { path: path.to_owned(), source })?;
        let bad = |reason: String| ExploreError::scenario(format!("{}: bad scenario", path.display()), reason);
        let mut s: Scenario = toml::from_str(&text).map_err(|e| bad(e.to_string()))?;
        if s.name.is_empty() {
            s.name = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        }
        if let Some(sensor) = &mut s.sensor {
            *sensor = path.parent().unwrap_or(Path::new("")).join(&*sensor);
        }
        s.validate().map_err(|e| match e {
            ExploreError::Scenario { reason, .. } => bad(reason),
            e => e,
        })?;
        Ok(s)
    }

    /// The scenario's own sensor (field `sensor`), else `default`.
    pub fn sensor_or<'a>(&self, default: &'a tacsim_sim::SensorParams) -> Result<Cow<'a, tacsim_sim::SensorParams>> {
        match &self.sensor {
            Some(p) => Ok(Cow::Owned(
                tacsim_sim::SensorParams::load(p)
                    .map_err(ExploreError::sim(format!("scenario {}: field `sensor`", self.name)))?,
            )),
            None => Ok(Cow::Borrowed(default)),
        }
    }

    /// Checks every value, naming the field and its range.
    pub fn validate(&self) -> Result<()> {
        let positive = |field: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!(self, "field `{field}` must be a positive number, got {v}");
            }
            Ok(())
        };
        positive("depth_mm", self.depth_mm)?;
        if self.depth_mm > 8.0 {
            bail!(self, "field `depth_mm` must be at most 8 mm, got {}", self.depth_mm);
        }
        positive("speed_mm_s", self.speed_mm_s)?;
        positive("step_mm", self.step_mm)?;
        positive("substep_mm", self.substep_mm)?;
        if let Some(f) = self.friction
            && !(f.is_finite() && f >= 0.0)
        {
            bail!(self, "field `friction` must be >= 0, got {f}");
        }
        if let Some(p) = self.start_mm
            && !p.iter().all(|v| v.is_finite())
        {
            bail!(self, "field `start_mm` must be finite, got {p:?}");
        }
        for (field, v) in [
            ("noise.offset_mm", self.noise.offset_mm),
            ("noise.angle_deg", self.noise.angle_deg),
            ("control.kp_offset", self.control.kp_offset),
            ("control.ki_offset", self.control.ki_offset),
            ("control.kp_angle", self.control.kp_angle),
            ("control.ki_angle", self.control.ki_angle),
            ("control.integral_clip", self.control.integral_clip),
            ("criteria.mean_deviation_mm", self.criteria.mean_deviation_mm),
            ("criteria.max_deviation_mm", self.criteria.max_deviation_mm),
            ("criteria.yaw_error_deg", self.criteria.yaw_error_deg),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                bail!(self, "field `{field}` must be a finite number >= 0, got {v}");
            }
        }
        if !self.control.offset_ref_mm.is_finite() {
            bail!(self, "field `control.offset_ref_mm` must be finite");
        }
        for (field, v) in [("criteria.completion", self.criteria.completion), ("criteria.iou", self.criteria.iou)] {
            if !(0.0..=1.0).contains(&v) {
                bail!(self, "field `{field}` must be a fraction in [0, 1], got {v}");
            }
        }
        // Practical ranges: each bounds a loop or a draw whose size the run follows.
        for (field, v, hi) in [
            ("step_mm", self.step_mm, 10.0),
            ("speed_mm_s", self.speed_mm_s, 1000.0),
            ("noise.offset_mm", self.noise.offset_mm, 10.0),
            ("noise.angle_deg", self.noise.angle_deg, 90.0),
            ("control.kp_offset", self.control.kp_offset, 10.0),
            ("control.ki_offset", self.control.ki_offset, 10.0),
            ("control.kp_angle", self.control.kp_angle, 10.0),
            ("control.ki_angle", self.control.ki_angle, 10.0),
            ("control.integral_clip", self.control.integral_clip, 50.0),
        ] {
            if v > hi {
                bail!(self, "field `{field}` must be at most {hi}, got {v}");
            }
        }
        if self.control.offset_ref_mm.abs() > 10.0 {
            bail!(self, "field `control.offset_ref_mm` must be in [-10, 10] mm, got {}", self.control.offset_ref_mm);
        }
        if self.step_mm / self.substep_mm > MAX_SUBSTEPS as f64 {
            bail!(
                self,
                "field `substep_mm` = {} makes {:.0} contact sub-steps per {} mm step, more than {MAX_SUBSTEPS}: use a \
                 larger sub-step",
                self.substep_mm,
                (self.step_mm / self.substep_mm).ceil(),
                self.step_mm
            );
        }
        if self.noise.latency_steps > 100 {
            bail!(self, "field `noise.latency_steps` must be at most 100, got {}", self.noise.latency_steps);
        }
        if self.max_steps > 100_000 {
            bail!(self, "field `max_steps` must be at most 100000, got {}", self.max_steps);
        }
        if !(16..=2048).contains(&self.image_size) {
            bail!(self, "field `image_size` must be in [16, 2048] px, got {}", self.image_size);
        }
        if self.max_steps == 0 {
            bail!(self, "field `max_steps` must be at least 1");
        }
        Ok(())
    }
}
