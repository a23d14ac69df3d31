//! Where the sensor is: [`SensorPose`] and the transform from the sensor frame to the world.
//!
//! The sensor presses down: its `+z` (camera towards apex) is world `-z`, its `+x` is world
//! `+x` and its `+y` world `-y` at zero yaw and tilt. The pose rotates that about the world
//! axes: `R = Rz(yaw) Rx(rx) Ry(ry) diag(1, -1, -1)`, and places the dome apex at
//! `(x, y, z_top - depth)`, `z_top` being the highest stimulus top in the scene
//! ([`crate::scene::Scene::top_height_mm`]). So `depth` is the indentation of a flat stimulus
//! under the apex (mm), the paper's `pose_z`.

use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{Result, SimError};

/// Largest tilt accepted (deg).
pub const MAX_TILT_DEG: f64 = 45.0;

/// The largest lateral position and height above the stimulus (mm) a pose may take: 10 m, far
/// beyond any scene, so that a value such as 1e300 (which touches nothing and rendered an
/// undeformed image) is refused (issue 88).
pub const MAX_POSITION_MM: f64 = 1e4;

/// The largest yaw (deg) a pose may take: a closed loop turning around a contour for its whole
/// run stays far within it; beyond it (1e300 was taken) the angle's digits are lost.
pub const MAX_YAW_DEG: f64 = 1e6;

/// A sensor pose (mm, deg).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorPose {
    /// Apex position along world `x` (mm).
    pub x_mm: f64,
    /// Apex position along world `y` (mm).
    pub y_mm: f64,
    /// Indentation below the highest stimulus top (mm); negative is above it.
    pub depth_mm: f64,
    /// Rotation about world `z` (deg).
    pub yaw_deg: f64,
    /// Tilt about world `x` (deg).
    pub rx_deg: f64,
    /// Tilt about world `y` (deg).
    pub ry_deg: f64,
}

impl SensorPose {
    /// A pose without tilt.
    pub fn new(x_mm: f64, y_mm: f64, depth_mm: f64, yaw_deg: f64) -> Self {
        Self { x_mm, y_mm, depth_mm, yaw_deg, rx_deg: 0.0, ry_deg: 0.0 }
    }

    /// The pose of `x, y, depth, yaw` or `x, y, depth, yaw, rx, ry` (mm, deg); `Err` says how
    /// many values were given. Check it with [`SensorPose::validate`].
    pub fn from_values(v: &[f64]) -> std::result::Result<Self, String> {
        match v {
            [x, y, d, yaw] => Ok(Self::new(*x, *y, *d, *yaw)),
            [x, y, d, yaw, rx, ry] => {
                Ok(Self { x_mm: *x, y_mm: *y, depth_mm: *d, yaw_deg: *yaw, rx_deg: *rx, ry_deg: *ry })
            }
            _ => Err(format!("expected x,y,depth,yaw or x,y,depth,yaw,rx,ry (mm, deg), got {} values", v.len())),
        }
    }

    /// Checks that every field is finite, the position within [`MAX_POSITION_MM`], the depth at
    /// most half the dome radius (and the height above at most [`MAX_POSITION_MM`]), the yaw
    /// within [`MAX_YAW_DEG`] and the tilt within [`MAX_TILT_DEG`].
    pub fn validate(&self, source_name: &str, dome_radius_mm: f64) -> Result<()> {
        for (field, v) in [
            ("pose.x_mm", self.x_mm),
            ("pose.y_mm", self.y_mm),
            ("pose.depth_mm", self.depth_mm),
            ("pose.yaw_deg", self.yaw_deg),
            ("pose.rx_deg", self.rx_deg),
            ("pose.ry_deg", self.ry_deg),
        ] {
            if !v.is_finite() {
                return Err(SimError::invalid(source_name, field, format!("must be a finite number, got {v}")));
            }
        }
        for (field, v, most, unit) in [
            ("pose.x_mm", self.x_mm, MAX_POSITION_MM, "mm"),
            ("pose.y_mm", self.y_mm, MAX_POSITION_MM, "mm"),
            ("pose.depth_mm", self.depth_mm, MAX_POSITION_MM, "mm"),
            ("pose.yaw_deg", self.yaw_deg, MAX_YAW_DEG, "deg"),
        ] {
            if v.abs() > most {
                return Err(SimError::invalid(
                    source_name,
                    field,
                    format!("must be within +-{most:e} {unit}, got {v:e}"),
                ));
            }
        }
        if self.depth_mm > 0.5 * dome_radius_mm {
            return Err(SimError::invalid(
                source_name,
                "pose.depth_mm",
                format!("must be at most half the dome radius ({} mm), got {}", 0.5 * dome_radius_mm, self.depth_mm),
            ));
        }
        for (field, v) in [("pose.rx_deg", self.rx_deg), ("pose.ry_deg", self.ry_deg)] {
            if v.abs() > MAX_TILT_DEG {
                return Err(SimError::invalid(
                    source_name,
                    field,
                    format!("must be within +-{MAX_TILT_DEG} deg, got {v}"),
                ));
            }
        }
        Ok(())
    }

    /// Rotation taking sensor-frame vectors to the world.
    pub fn rotation(&self) -> Matrix3<f64> {
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), self.yaw_deg.to_radians());
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), self.rx_deg.to_radians());
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), self.ry_deg.to_radians());
        (rz * rx * ry).into_inner() * Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
    }

    /// World position of the sensor frame's origin (the dome centre) for a dome of outer radius
    /// `dome_radius_mm` over a scene whose highest top is at `top_mm`.
    pub fn origin_world(&self, dome_radius_mm: f64, top_mm: f64) -> Vector3<f64> {
        let apex = Vector3::new(self.x_mm, self.y_mm, top_mm - self.depth_mm);
        apex - self.rotation() * Vector3::new(0.0, 0.0, dome_radius_mm)
    }

    /// Straight-line interpolation towards `other` (`t` in [0, 1]).
    pub fn lerp(&self, other: &SensorPose, t: f64) -> SensorPose {
        let l = |a: f64, b: f64| a + (b - a) * t;
        SensorPose {
            x_mm: l(self.x_mm, other.x_mm),
            y_mm: l(self.y_mm, other.y_mm),
            depth_mm: l(self.depth_mm, other.depth_mm),
            yaw_deg: l(self.yaw_deg, other.yaw_deg),
            rx_deg: l(self.rx_deg, other.rx_deg),
            ry_deg: l(self.ry_deg, other.ry_deg),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn untilted_sensor_presses_down_with_image_up_along_world_y() {
        let pose = SensorPose::new(3.0, -2.0, 1.5, 0.0);
        let r = pose.rotation();
        assert!((r * Vector3::z() + Vector3::z()).norm() < 1e-12);
        assert!((r * Vector3::y() + Vector3::y()).norm() < 1e-12);
        let o = pose.origin_world(20.0, 10.0);
        assert!((o - Vector3::new(3.0, -2.0, 10.0 - 1.5 + 20.0)).norm() < 1e-12);
        assert!((r.determinant() - 1.0).abs() < 1e-12);
    }
}
