//! Paths through poses (press, slide, lift) and running them: the trajectory API.

use super::engine::Simulation;
use super::model::ContactModel;
use super::pose::SensorPose;
use super::solve::coupled::StepReport;
use crate::error::{Result, SimError};
use crate::pins::PinPose;
use crate::scene::Scene;

/// One pose of a path and whether to capture pins (and an image) there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathStep {
    /// The pose.
    pub pose: SensorPose,
    /// Capture the pins after this step.
    pub capture: bool,
}

/// A sequence of poses, solved in order with contact history.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorPath {
    /// The steps.
    pub steps: Vec<PathStep>,
}

/// Most steps a path may have (a 2 mm slide in 1 um steps): every step is a contact solve, so
/// a path's length is bounded before any work starts.
pub const MAX_PATH_STEPS: usize = 2_000;

/// The smallest step (mm) of [`SensorPath::slide`] (a recipe's `slides.step_mm` too).
pub const MIN_STEP_MM: f64 = 0.01;
/// The largest step (mm) of [`SensorPath::slide`] (a recipe's `slides.step_mm` too; a step of
/// 1e300 mm was taken).
pub const MAX_STEP_MM: f64 = 10.0;
/// The longest slide (mm) of [`SensorPath::slide`] (a slide from 1e300 mm blamed the step).
pub const MAX_SLIDE_MM: f64 = 100.0;

impl SensorPath {
    /// A tap: straight down onto `target` from out of contact, captured there.
    pub fn tap(target: SensorPose) -> Self {
        Self { steps: vec![PathStep { pose: target, capture: true }] }
    }

    /// The paper's slide: touch down at `target` shifted by `from_mm` (world `x, y`), then slide
    /// in a straight line to `target` in steps of at most `step_mm`, captured at the end.
    /// `step_mm` in [[`MIN_STEP_MM`], [`MAX_STEP_MM`]], the slide at most [`MAX_SLIDE_MM`] long
    /// (as a recipe's slides).
    pub fn slide(target: SensorPose, from_mm: [f64; 2], step_mm: f64) -> Result<Self> {
        if !(step_mm.is_finite() && (MIN_STEP_MM..=MAX_STEP_MM).contains(&step_mm)) {
            return Err(SimError::invalid(
                "path",
                "step_mm",
                format!("must be in [{MIN_STEP_MM}, {MAX_STEP_MM}] mm, got {step_mm:e}"),
            ));
        }
        let length = from_mm[0].hypot(from_mm[1]);
        if !(length.is_finite() && length <= MAX_SLIDE_MM) {
            return Err(SimError::invalid(
                "path",
                "slide_from",
                format!("must be at most {MAX_SLIDE_MM} mm from the pose, got {from_mm:?} ({length:e} mm)"),
            ));
        }
        let start = SensorPose { x_mm: target.x_mm + from_mm[0], y_mm: target.y_mm + from_mm[1], ..target };
        Self::slide_between(start, target, step_mm, f64::INFINITY)
    }

    /// Touch down at `start`, then move in a straight line (lateral position, depth, yaw and
    /// tilt interpolated together) to `target` in steps of at most `step_mm` laterally and
    /// `step_deg` in yaw, captured at the end. Twisting while sliding is rotational shear.
    pub fn slide_between(start: SensorPose, target: SensorPose, step_mm: f64, step_deg: f64) -> Result<Self> {
        if !(step_mm.is_finite() && step_mm > 0.0) {
            return Err(SimError::invalid("path", "step_mm", format!("must be a positive number, got {step_mm}")));
        }
        if step_deg.is_nan() || step_deg <= 0.0 {
            return Err(SimError::invalid("path", "step_deg", format!("must be positive, got {step_deg}")));
        }
        let lateral = (target.x_mm - start.x_mm).hypot(target.y_mm - start.y_mm);
        let twist = (target.yaw_deg - start.yaw_deg).abs();
        if !(lateral.is_finite() && twist.is_finite()) {
            return Err(SimError::invalid("path", "start", format!("must be finite, got {start:?}")));
        }
        let n = (lateral / step_mm).ceil().max((twist / step_deg).ceil()).max(1.0);
        if n > MAX_PATH_STEPS as f64 {
            return Err(SimError::invalid(
                "path",
                "step_mm",
                format!(
                    "a slide of {lateral:.3} mm and {twist:.2} deg in steps of at most {step_mm} mm and {step_deg} deg \
                     takes {n:.0} steps, more than the {MAX_PATH_STEPS} a path may have: use a larger step"
                ),
            ));
        }
        let n = n as usize;
        let mut steps = vec![PathStep { pose: start, capture: false }];
        steps.extend((1..=n).map(|i| PathStep { pose: start.lerp(&target, i as f64 / n as f64), capture: i == n }));
        Ok(Self { steps })
    }

    /// Appends lifting the sensor `height_mm` straight up from the last pose, captured.
    pub fn then_lift(mut self, height_mm: f64) -> Self {
        if let Some(last) = self.steps.last().copied() {
            let pose = SensorPose { depth_mm: last.pose.depth_mm - height_mm, ..last.pose };
            self.steps.push(PathStep { pose, capture: true });
        }
        self
    }

    /// The poses, in order.
    pub fn poses(&self) -> Vec<SensorPose> {
        self.steps.iter().map(|s| s.pose).collect()
    }
}

/// What was captured at a step.
#[derive(Clone, Debug)]
pub struct Capture {
    /// Index of the step in the path.
    pub step: usize,
    /// The pose.
    pub pose: SensorPose,
    /// Contact summary.
    pub report: StepReport,
    /// Pin poses (sensor frame).
    pub pins: Vec<PinPose>,
}

impl SensorPath {
    /// Runs the path over `scene`, returning what was captured (the pins: rendering them is
    /// the image stage's, downstream).
    pub fn run(&self, model: &ContactModel, scene: &Scene) -> Result<Vec<Capture>> {
        let mut sim = Simulation::new(model, scene, &self.poses());
        let mut captures = Vec::new();
        for (i, s) in self.steps.iter().enumerate() {
            let report = sim.step(s.pose)?.clone();
            if s.capture {
                captures.push(Capture { step: i, pose: s.pose, report, pins: sim.pins() });
            }
        }
        Ok(captures)
    }
}
