//! Pose-based tactile servoing (the lab's contour following): each step moves `step_mm` along
//! the estimated edge tangent, and corrects the lateral offset and the yaw toward their
//! references with PI laws whose integral terms are clipped.

use tacsim_sim::SensorPose;

use crate::perception::EdgeEstimate;
use crate::scenario::Control;

/// The servo and its integrators.
#[derive(Clone, Debug)]
pub struct Servo {
    gains: Control,
    step_mm: f64,
    integral_offset: f64,
    integral_angle: f64,
}

impl Servo {
    /// A servo with `gains`, stepping `step_mm` per call.
    pub fn new(gains: &Control, step_mm: f64) -> Self {
        Self { gains: gains.clone(), step_mm, integral_offset: 0.0, integral_angle: 0.0 }
    }

    /// The next pose from the current one and the estimate.
    pub fn next(&mut self, pose: &SensorPose, e: &EdgeEstimate) -> SensorPose {
        let g = &self.gains;
        let clip = |v: f64| v.clamp(-g.integral_clip, g.integral_clip);
        // Lateral: positive moves off the material along the edge normal.
        let err_offset = g.offset_ref_mm - e.offset_mm;
        self.integral_offset += err_offset;
        let lateral = g.kp_offset * err_offset + clip(g.ki_offset * self.integral_offset);
        if g.ki_offset > 0.0 {
            self.integral_offset = clip(g.ki_offset * self.integral_offset) / g.ki_offset;
        }
        // Yaw: turn so that the edge runs along the sensor's x axis.
        let err_angle = e.angle_deg;
        self.integral_angle += err_angle;
        let turn = g.kp_angle * err_angle + clip(g.ki_angle * self.integral_angle);
        if g.ki_angle > 0.0 {
            self.integral_angle = clip(g.ki_angle * self.integral_angle) / g.ki_angle;
        }
        let tangent = (pose.yaw_deg + e.angle_deg).to_radians();
        let (t, n) = ([tangent.cos(), tangent.sin()], [tangent.sin(), -tangent.cos()]);
        SensorPose {
            x_mm: pose.x_mm + self.step_mm * t[0] + lateral * n[0],
            y_mm: pose.y_mm + self.step_mm * t[1] + lateral * n[1],
            // Yaw stays continuous (no wrap), so straight moves interpolate it the short way.
            yaw_deg: pose.yaw_deg + turn,
            ..*pose
        }
    }
}
