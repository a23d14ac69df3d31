//! The frame a contact is solved in: the sensor frame turned about the dome centre so that its
//! `+z` points along the press.
//!
//! The boundary-element solve treats the skin near the contact as a half-space (or layers)
//! under a plane. Taking that plane as the tangent plane at the apex is right for an untilted
//! press, but a sensor tilted by `a` touches a flat surface at the dome point at polar angle
//! `a`: there the skin is pushed along the surface normal, which has a lateral part `sin a`
//! in the sensor frame, and the apex plane would push it along the sensor's axis instead (the
//! tilted contact's pins then move sideways in the image where a real sensor's hardly do).
//! The dome is a sphere about the frame origin, so turning the frame about the dome centre
//! until `+z` is the press direction leaves the dome where it is and puts the contact at the
//! new frame's apex: grid, gaps, slip and pins are all taken in that frame, and the pins
//! turned back.
//!
//! The press direction of a pose is the world's down (`-z`) seen from the sensor,
//! `d = R^T (0, 0, -1)` with `R` from [`SensorPose::rotation`]; a path uses the mean of its
//! poses' directions, so one frame serves the whole path. Without tilt `d = +z` and the
//! frame is the sensor frame itself (no rotation is applied at all).

use nalgebra::{Matrix3, Point3, Rotation3, Unit, Vector3};

use crate::contact::pose::SensorPose;
use crate::pins::{PinLayout, PinPose};

/// A press direction closer to the sensor's `+z` than this (rad) keeps the sensor frame.
const SAME_AXIS_RAD: f64 = 1e-9;

/// The rotation from the sensor frame to the contact frame (identity without tilt).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactFrame {
    /// `contact = to_contact * sensor`; `None` for the sensor frame itself.
    to_contact: Option<Matrix3<f64>>,
}

impl ContactFrame {
    /// The sensor frame.
    pub const SENSOR: ContactFrame = ContactFrame { to_contact: None };

    /// The frame of a path through `poses`: `+z` along their mean press direction.
    pub fn of_poses(poses: &[SensorPose]) -> Self {
        let sum: Vector3<f64> = poses.iter().map(press_direction).sum();
        let Some(d) = Unit::try_new(sum, 1e-12) else { return Self::SENSOR };
        if d.angle(&Vector3::z()) < SAME_AXIS_RAD {
            return Self::SENSOR;
        }
        // Tilts are within 45 deg, so `d` is never opposite `+z`.
        let r = Rotation3::rotation_between(&d, &Vector3::z()).unwrap_or_else(Rotation3::identity);
        Self { to_contact: Some(r.into_inner()) }
    }

    /// Whether this is the sensor frame.
    pub fn is_sensor(&self) -> bool {
        self.to_contact.is_none()
    }

    /// A sensor-frame vector in the contact frame.
    pub fn to_contact(&self, v: Vector3<f64>) -> Vector3<f64> {
        self.to_contact.map_or(v, |m| m * v)
    }

    /// A contact-frame vector in the sensor frame.
    pub fn to_sensor(&self, v: Vector3<f64>) -> Vector3<f64> {
        self.to_contact.map_or(v, |m| m.transpose() * v)
    }

    /// `layout` (sensor frame) in the contact frame.
    pub fn layout_to_contact(&self, layout: &PinLayout) -> PinLayout {
        let mut out = layout.clone();
        if !self.is_sensor() {
            for pin in &mut out.pins {
                pin.base = Point3::from(self.to_contact(pin.base.coords));
                pin.tip = Point3::from(self.to_contact(pin.tip.coords));
                pin.normal = self.to_contact(pin.normal);
            }
        }
        out
    }

    /// Contact-frame pin poses in the sensor frame.
    pub fn pins_to_sensor(&self, pins: Vec<PinPose>) -> Vec<PinPose> {
        if self.is_sensor() {
            return pins;
        }
        pins.into_iter()
            .map(|p| PinPose { tip: Point3::from(self.to_sensor(p.tip.coords)), axis: self.to_sensor(p.axis) })
            .collect()
    }
}

/// The world's down seen from the sensor at `pose` (unit, sensor frame): where a flat
/// surface under the sensor touches the dome.
pub fn press_direction(pose: &SensorPose) -> Vector3<f64> {
    pose.rotation().transpose() * Vector3::new(0.0, 0.0, -1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_untilted_path_keeps_the_sensor_frame_whatever_its_yaw() {
        let poses = [SensorPose::new(1.0, 2.0, 1.5, 30.0), SensorPose::new(-3.0, 0.0, 2.0, -170.0)];
        assert!(ContactFrame::of_poses(&poses).is_sensor());
        assert!(ContactFrame::of_poses(&[]).is_sensor());
    }

    #[test]
    fn a_tilted_press_direction_becomes_the_contact_z_and_turns_back() {
        let pose = SensorPose { rx_deg: 20.0, ry_deg: -10.0, ..SensorPose::new(0.0, 0.0, 2.0, 40.0) };
        let f = ContactFrame::of_poses(&[pose]);
        let d = press_direction(&pose);
        // The press leaves the apex by the tilt: cos(angle) = cos rx cos ry.
        let expected = (20f64.to_radians().cos() * 10f64.to_radians().cos()).acos();
        assert!((d.angle(&Vector3::z()) - expected).abs() < 1e-12);
        assert!((f.to_contact(d) - Vector3::z()).norm() < 1e-12);
        let v = Vector3::new(0.3, -1.2, 2.5);
        assert!((f.to_sensor(f.to_contact(v)) - v).norm() < 1e-12);
        assert!((f.to_contact(v).norm() - v.norm()).abs() < 1e-12);
    }
}
