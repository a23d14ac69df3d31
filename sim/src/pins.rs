//! Pin layout of the undeformed sensor, in the sensor frame (see [`crate::sensor`]).

use nalgebra::{Point3, Vector3};

use crate::sensor::SensorParams;

/// One pin of the undeformed sensor.
#[derive(Clone, Debug, PartialEq)]
pub struct Pin {
    /// Ring index: 0 for the centre pin, 1..=K outwards.
    pub ring: u32,
    /// Index within the ring, 0..6k, increasing with azimuth.
    pub index_in_ring: u32,
    /// Polar angle of the pin base from `+z` (rad).
    pub polar_rad: f64,
    /// Azimuth from `+x` towards `+y` (rad).
    pub azimuth_rad: f64,
    /// Pin base on the inner skin surface (mm, sensor frame).
    pub base: Point3<f64>,
    /// Outward unit normal of the skin at the base; the pin points along `-normal`.
    pub normal: Vector3<f64>,
    /// Centre of the pin tip (mm, sensor frame): `base - length * normal`.
    pub tip: Point3<f64>,
}

/// Where a pin is: its tip centre and its axis (the direction of the tip's face normal, the
/// skin's outward normal for an undeformed pin), in the sensor frame (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinPose {
    /// Tip centre (mm).
    pub tip: Point3<f64>,
    /// Unit axis.
    pub axis: Vector3<f64>,
}

/// All pins of a sensor, ring by ring (centre first), azimuth increasing within a ring.
#[derive(Clone, Debug, PartialEq)]
pub struct PinLayout {
    /// The pins.
    pub pins: Vec<Pin>,
    /// Radius of the spherical pin tips (mm).
    pub tip_radius_mm: f64,
    /// Radius of the skin patch each pin moves and turns with (mm; `pins.patch_radius_mm`).
    pub patch_radius_mm: f64,
}

impl PinLayout {
    /// Builds the undeformed layout. The parameters are assumed validated.
    pub fn new(sensor: &SensorParams) -> Self {
        let inner = sensor.dome.outer_radius_mm - sensor.dome.skin_thickness_mm;
        let length = sensor.pins.length_mm;
        let phase = sensor.pins.phase_deg.to_radians();
        let mut pins = Vec::with_capacity(sensor.pin_count());
        let mut push = |ring: u32, index_in_ring: u32, polar_rad: f64, azimuth_rad: f64| {
            let normal =
                Vector3::new(polar_rad.sin() * azimuth_rad.cos(), polar_rad.sin() * azimuth_rad.sin(), polar_rad.cos());
            let base = Point3::from(normal * inner);
            let tip = base - normal * length;
            pins.push(Pin { ring, index_in_ring, polar_rad, azimuth_rad, base, normal, tip });
        };
        push(0, 0, 0.0, phase);
        for (k, theta) in sensor.ring_polar_rad().into_iter().enumerate() {
            let ring = k as u32 + 1;
            let n = 6 * ring;
            for j in 0..n {
                push(ring, j, theta, phase + std::f64::consts::TAU * j as f64 / n as f64);
            }
        }
        Self { pins, tip_radius_mm: sensor.pins.tip_radius_mm, patch_radius_mm: sensor.pins.patch_radius_mm }
    }

    /// Undeformed pin poses, in pin order.
    pub fn poses(&self) -> Vec<PinPose> {
        self.pins.iter().map(|p| PinPose { tip: p.tip, axis: p.normal }).collect()
    }

    /// Number of pins in each ring, centre first.
    pub fn ring_sizes(&self) -> Vec<usize> {
        let rings = self.pins.iter().map(|p| p.ring).max().map_or(0, |k| k as usize + 1);
        let mut sizes = vec![0; rings];
        for p in &self.pins {
            sizes[p.ring as usize] += 1;
        }
        sizes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rings_hold_6k_pins_on_the_inner_surface() {
        let s = SensorParams::half_space();
        let layout = PinLayout::new(&s);
        assert_eq!(layout.pins.len(), 331);
        assert_eq!(layout.ring_sizes(), (0..=10).map(|k| if k == 0 { 1 } else { 6 * k }).collect::<Vec<_>>());
        let inner = s.dome.outer_radius_mm - s.dome.skin_thickness_mm;
        for p in &layout.pins {
            assert!((p.base.coords.norm() - inner).abs() < 1e-12);
            assert!((p.tip.coords.norm() - s.tip_radius_from_centre_mm()).abs() < 1e-12);
        }
    }
}
