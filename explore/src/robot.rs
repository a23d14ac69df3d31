//! A kinematic end effector: the sensor at `(x, y, depth, yaw)`, moved in straight segments
//! cut into contact-engine sub-steps so that it stays in contact and every step carries
//! sliding history.

use tacsim_sim::SensorPose;

/// The robot: where the sensor is and how far it has travelled.
#[derive(Clone, Debug)]
pub struct Robot {
    /// Current pose.
    pub pose: SensorPose,
    /// Distance travelled (mm).
    pub travelled_mm: f64,
    /// Largest sub-step (mm); yaw sub-steps are at most 2 deg.
    pub substep_mm: f64,
}

/// Largest yaw sub-step (deg).
const SUBSTEP_DEG: f64 = 2.0;

impl Robot {
    /// A robot at `pose`.
    pub fn new(pose: SensorPose, substep_mm: f64) -> Self {
        Self { pose, travelled_mm: 0.0, substep_mm }
    }

    /// The sub-poses of a straight move to `target` (ending at it); the robot is then there.
    pub fn move_to(&mut self, target: SensorPose) -> Vec<SensorPose> {
        let from = self.pose;
        let dist = (target.x_mm - from.x_mm).hypot(target.y_mm - from.y_mm);
        let n =
            (dist / self.substep_mm).ceil().max(((target.yaw_deg - from.yaw_deg).abs() / SUBSTEP_DEG).ceil()).max(1.0)
                as usize;
        self.pose = target;
        self.travelled_mm += dist;
        (1..=n).map(|i| from.lerp(&target, i as f64 / n as f64)).collect()
    }
}
