//! The simulated counterpart of a lab recording: the same labels on a flat surface, the pin
//! displacements in the real image's pixels, and their error against the tracked real ones.
//!
//! The recording's labels live in the robot's frame; a [`RigFrame`] (found from the data,
//! see [`super::frame`]) maps them to the sensor's and a [`Press`] (fitted with the skin) says
//! how the rig pressed ([`crate::rig`]).

use serde::{Deserialize, Serialize};
use tacsim_data::LabSample;

use crate::SensorPath;
use crate::contact::{ContactModel, Simulation};
use crate::detect::tip_pixels;
use crate::error::Result;
use crate::pins::PinPose;
use crate::render::PinRenderer;
pub use crate::rig::{Press, RigFrame};
use crate::scene::Scene;
use crate::sensor::{SensorParams, SkinModel};
use crate::tracking::median;

/// The deformation parameters a calibration fits.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Deformation {
    /// Elastic model.
    pub model: SkinModel,
    /// Pin length (mm). The skin thickness changes with it so that the pin tips, and with
    /// them the undeformed image, stay where the camera fit put them.
    pub pin_length_mm: f64,
    /// Skin-on-gel: gel modulus over skin modulus.
    pub gel_ratio: f64,
    /// Layered models: depth of the rigid base (mm).
    pub base_depth_mm: f64,
    /// Friction coefficient between skin and surface.
    pub friction: f64,
    /// Added to the labelled depth (mm): where the robot's zero sits against first touch.
    pub depth_offset_mm: f64,
    /// Height (mm) above the dome apex, on the sensor's axis, of the point the robot tilts
    /// the sensor about (0: the apex; the dome radius: its centre, so that a tilt keeps the
    /// indentation).
    pub pivot_mm: f64,
    /// The rig's yield under load (mm^-0.5): a commanded indentation `c` (mm) loses
    /// `depth_compliance c^1.5` ([`RigFrame::poses`]).
    #[serde(default)]
    pub depth_compliance: f64,
    /// The tilt's relaxation under load (1/mm): a tilt `t` becomes `t (1 - k c)` at a
    /// commanded indentation `c` (mm) ([`RigFrame::poses`]).
    #[serde(default)]
    pub tilt_relaxation_per_mm: f64,
    /// Where the tilt pivot sits off the sensor's axis (mm, sensor frame `x`, `y`;
    /// [`RigFrame::poses`]); fitted by `--rig-only` calibration, 0 in the full fit.
    #[serde(default)]
    pub pivot_offset_mm: [f64; 2],
    /// The rig's play in tilt (deg): taken off each labelled tilt's size
    /// ([`Press::tilt_play_deg`]).
    #[serde(default)]
    pub tilt_play_deg: f64,
    /// Camera distance behind the dome centre (mm) the camera is refitted at
    /// ([`crate::calibrate::rings::fit_camera_at`]): the undeformed image hardly tells it, the
    /// perspective of pins pressed towards the camera does.
    pub camera_distance_mm: f64,
    /// Poisson's ratio of the skin material (0.5: incompressible; below it, pressure pulls
    /// the surface in towards the contact).
    pub poisson: f64,
}

impl Deformation {
    /// The parameters of `sensor` (friction of the surface `friction`).
    pub fn of(sensor: &SensorParams, friction: f64) -> Self {
        let k = &sensor.skin;
        Self {
            model: k.model,
            pin_length_mm: sensor.pins.length_mm,
            gel_ratio: k.gel_youngs_modulus_mpa / k.youngs_modulus_mpa,
            base_depth_mm: k.base_depth_mm,
            friction,
            depth_offset_mm: 0.0,
            pivot_mm: 0.0,
            depth_compliance: 0.0,
            tilt_relaxation_per_mm: 0.0,
            pivot_offset_mm: [0.0; 2],
            tilt_play_deg: 0.0,
            camera_distance_mm: sensor.camera.distance_mm,
            poisson: k.poisson,
        }
    }

    /// The rig's press of these parameters.
    pub fn press(&self) -> Press {
        Press::new(self.depth_offset_mm, self.pivot_mm, self.depth_compliance, self.tilt_relaxation_per_mm)
            .with_pivot_offset(self.pivot_offset_mm)
            .with_tilt_play(self.tilt_play_deg)
    }

    /// `base` with these parameters (validated).
    pub fn sensor(&self, base: &SensorParams) -> Result<SensorParams> {
        let mut s = base.clone();
        let tip_depth = base.dome.skin_thickness_mm + base.pins.length_mm;
        s.pins.length_mm = self.pin_length_mm;
        s.dome.skin_thickness_mm = tip_depth - self.pin_length_mm;
        s.skin.model = self.model;
        s.skin.gel_youngs_modulus_mpa = self.gel_ratio * base.skin.youngs_modulus_mpa;
        s.skin.base_depth_mm = self.base_depth_mm;
        s.skin.poisson = self.poisson;
        s.validate("calibration")?;
        Ok(s)
    }
}

/// The simulated pins of a recording pressed as `press` says: touch down, slide in steps of
/// at most `step_mm`, capture.
pub fn simulate_pins(
    model: &ContactModel,
    scene: &Scene,
    frame: &RigFrame,
    press: &Deformation,
    sample: &LabSample,
    step_mm: f64,
) -> Result<Vec<PinPose>> {
    let (start, target) = frame.poses(&sample.pose, &sample.shear, &press.press());
    let path = SensorPath::slide_between(start, target, step_mm, 2.0)?;
    let mut sim = Simulation::new(model, scene, &path.poses());
    for s in &path.steps {
        sim.step(s.pose)?;
    }
    Ok(sim.pins())
}

/// Image displacements (px, per sensor pin) of `pins` from the undeformed layout of `model`.
pub fn displacements(model: &ContactModel, renderer: &PinRenderer, pins: &[PinPose]) -> Vec<Option<[f64; 2]>> {
    let rest = tip_pixels(renderer, &model.layout.poses());
    let moved = tip_pixels(renderer, pins);
    rest.iter()
        .zip(&moved)
        .map(|(a, b)| match (a, b) {
            (Some(a), Some(b)) => Some([b[0] - a[0], b[1] - a[1]]),
            _ => None,
        })
        .collect()
}

/// Error of one sample: over the reference pins tracked in the real image and simulated,
/// mean `|d_sim - d_real|` (px), mean `|d_real|` (px), and the global shifts (median
/// displacement, px) of both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SampleError {
    /// Mean per-pin displacement error (px).
    pub error_px: f64,
    /// Mean real displacement magnitude (px).
    pub real_px: f64,
    /// Pins compared.
    pub pins: usize,
    /// Real global shift (px).
    pub real_shift: [f64; 2],
    /// Simulated global shift over the same pins (px).
    pub sim_shift: [f64; 2],
}

impl SampleError {
    /// Error relative to the real displacement magnitude.
    pub fn relative(&self) -> f64 {
        if self.real_px > 0.0 { self.error_px / self.real_px } else { 0.0 }
    }
}

/// `(real, simulated)` displacements of the reference pins tracked in the real image and
/// simulated, through `reference_to_sim`.
fn matched_pairs(
    sim: &[Option<[f64; 2]>],
    real: &[Option<[f64; 2]>],
    reference_to_sim: &[Option<usize>],
) -> Vec<([f64; 2], [f64; 2])> {
    real.iter().zip(reference_to_sim).filter_map(|(r, m)| Some(((*r)?, sim[(*m)?]?))).collect()
}

/// Compares simulated displacements (per sensor pin) with tracked real ones (per reference
/// pin), through `reference_to_sim`.
pub fn compare(sim: &[Option<[f64; 2]>], real: &[Option<[f64; 2]>], reference_to_sim: &[Option<usize>]) -> SampleError {
    let pairs = matched_pairs(sim, real, reference_to_sim);
    let n = pairs.len();
    if n == 0 {
        return SampleError::default();
    }
    let error = pairs.iter().map(|(r, s)| (r[0] - s[0]).hypot(r[1] - s[1])).sum::<f64>() / n as f64;
    let real_px = pairs.iter().map(|(r, _)| r[0].hypot(r[1])).sum::<f64>() / n as f64;
    let col = |which: usize, axis: usize| {
        median(pairs.iter().map(|p| if which == 0 { p.0[axis] } else { p.1[axis] }).collect())
    };
    SampleError {
        error_px: error,
        real_px,
        pins: n,
        real_shift: [col(0, 0), col(0, 1)],
        sim_shift: [col(1, 0), col(1, 1)],
    }
}

/// The relative error left after the best affine map of the simulated field onto the real
/// one (`d_real ~ A d_sim + c`, least squares, 6 numbers per recording): how much of the
/// error is the field's shape rather than a gain, a rotation or a global shift. `None` with
/// fewer than 6 pins compared.
pub fn affine_residual(
    sim: &[Option<[f64; 2]>],
    real: &[Option<[f64; 2]>],
    reference_to_sim: &[Option<usize>],
) -> Option<f64> {
    let pairs = matched_pairs(sim, real, reference_to_sim);
    if pairs.len() < 6 {
        return None;
    }
    let x = nalgebra::DMatrix::from_fn(pairs.len(), 3, |i, j| if j < 2 { pairs[i].1[j] } else { 1.0 });
    let svd = x.clone().svd(true, true);
    let mut residual = vec![[0.0; 2]; pairs.len()];
    for axis in 0..2 {
        let y = nalgebra::DVector::from_fn(pairs.len(), |i, _| pairs[i].0[axis]);
        let beta = svd.solve(&y, 1e-12).ok()?;
        for (i, r) in (&x * beta - y).iter().enumerate() {
            residual[i][axis] = *r;
        }
    }
    let error: f64 = residual.iter().map(|r| r[0].hypot(r[1])).sum();
    let real_px: f64 = pairs.iter().map(|(r, _)| r[0].hypot(r[1])).sum();
    (real_px > 0.0).then(|| error / real_px)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> LabSample {
        LabSample {
            image: "x.png".into(),
            pose: [0.0, 0.0, 2.0, 10.0, -4.0, 0.0],
            shear: [3.0, 1.0, 0.0, 0.0, 0.0, 5.0],
        }
    }

    #[test]
    fn label_frames_map_offsets_as_vectors_and_tilts_as_rotation_vectors() {
        let mut press = Deformation::of(&SensorParams::half_space(), 0.5);
        press.depth_offset_mm = 0.5;
        let (start, target) = RigFrame::IDENTITY.poses(&sample().pose, &sample().shear, &press.press());
        assert_eq!((start.x_mm, start.y_mm, start.yaw_deg, target.depth_mm), (3.0, 1.0, 5.0, 2.5));
        assert_eq!((target.rx_deg, target.ry_deg), (10.0, -4.0));
        let at_zero = Deformation::of(&SensorParams::half_space(), 0.5);
        // A quarter turn: x -> y, y -> -x, for offsets and tilts alike.
        let (s, t) = RigFrame::new(90.0, false).poses(&sample().pose, &sample().shear, &at_zero.press());
        assert!((s.x_mm + 1.0).abs() < 1e-12 && (s.y_mm - 3.0).abs() < 1e-12);
        assert!((t.rx_deg - 4.0).abs() < 1e-12 && (t.ry_deg - 10.0).abs() < 1e-12 && s.yaw_deg == 5.0);
        // A mirror y -> -y flips the offset's y, and the tilt about x and the twist (axial).
        let (s, t) = RigFrame::new(0.0, true).poses(&sample().pose, &sample().shear, &at_zero.press());
        assert_eq!((s.x_mm, s.y_mm, s.yaw_deg), (3.0, -1.0, -5.0));
        assert_eq!((t.rx_deg, t.ry_deg), (-10.0, -4.0));
        // Reversed tilts turn the other way; offsets and twist are unchanged.
        let (s, t) =
            RigFrame::new(0.0, true).with_tilts_reversed(true).poses(&sample().pose, &sample().shear, &at_zero.press());
        assert_eq!((s.x_mm, s.y_mm, s.yaw_deg), (3.0, -1.0, -5.0));
        assert_eq!((t.rx_deg, t.ry_deg), (10.0, 4.0));
    }

    #[test]
    fn an_affine_image_of_the_simulated_field_leaves_no_residual() {
        let sim: Vec<Option<[f64; 2]>> = (0..20).map(|i| Some([(i as f64).sin(), (0.7 * i as f64).cos()])).collect();
        let real: Vec<Option<[f64; 2]>> =
            sim.iter().map(|s| s.map(|s| [2.0 * s[0] - s[1] + 0.5, 0.3 * s[0] + 1.5 * s[1] - 1.0])).collect();
        let map: Vec<Option<usize>> = (0..20).map(Some).collect();
        assert!(affine_residual(&sim, &real, &map).expect("enough pins") < 1e-9);
        let noisy: Vec<Option<[f64; 2]>> =
            real.iter().enumerate().map(|(i, r)| r.map(|r| [r[0] + (i % 2) as f64, r[1]])).collect();
        assert!(affine_residual(&sim, &noisy, &map).expect("enough pins") > 0.05);
        assert!(affine_residual(&sim[..3], &real[..3], &map[..3]).is_none());
    }

    #[test]
    fn a_tilt_about_a_pivot_above_the_apex_raises_the_apex() {
        let mut press = Deformation::of(&SensorParams::half_space(), 0.5);
        press.pivot_mm = 20.0;
        let s = LabSample { image: "x.png".into(), pose: [0.0, 0.0, 2.0, 60.0, 0.0, 0.0], shear: [0.0; 6] };
        let (_, t) = RigFrame::IDENTITY.poses(&s.pose, &s.shear, &press.press());
        assert!((t.depth_mm - (2.0 - 10.0)).abs() < 1e-9, "{t:?}");
        let (_, t) = RigFrame::IDENTITY.poses(&[0.0, 0.0, 2.0, 0.0, 0.0, 0.0], &s.shear, &press.press());
        assert!((t.depth_mm - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_loaded_rig_loses_depth_as_the_load_grows_and_relaxes_its_tilt() {
        let mut press = Deformation::of(&SensorParams::half_space(), 0.5);
        press.depth_offset_mm = 1.0;
        press.depth_compliance = 0.1;
        press.tilt_relaxation_per_mm = 0.05;
        // Commanded 3 mm + 1 mm offset = 4 mm: loses 0.1 * 4^1.5 = 0.8 mm; the tilt keeps
        // 1 - 0.05 * 4 = 80%. The pivot sits at the apex, so the tilt lifts nothing.
        let s = LabSample { image: "x.png".into(), pose: [0.0, 0.0, 3.0, 10.0, -5.0, 0.0], shear: [0.0; 6] };
        let (_, t) = RigFrame::IDENTITY.poses(&s.pose, &s.shear, &press.press());
        assert!((t.depth_mm - 3.2).abs() < 1e-12, "{t:?}");
        assert!((t.rx_deg - 8.0).abs() < 1e-12 && (t.ry_deg + 4.0).abs() < 1e-12, "{t:?}");
        // Above the surface nothing is loaded: no yield, the full tilt.
        let s = LabSample { pose: [0.0, 0.0, -2.0, 10.0, -5.0, 0.0], ..s };
        let (_, t) = RigFrame::IDENTITY.poses(&s.pose, &s.shear, &press.press());
        assert!((t.depth_mm + 1.0).abs() < 1e-12 && t.rx_deg == 10.0, "{t:?}");
    }

    #[test]
    fn the_rigs_play_takes_its_size_off_a_loaded_tilt() {
        let mut press = Deformation::of(&SensorParams::half_space(), 0.5);
        press.tilt_play_deg = 2.0;
        press.tilt_relaxation_per_mm = 0.05;
        // A tilt of size 10 deg (6, -8) keeps 8 deg about the same axis, then 1 - 0.05 * 2 =
        // 90% of it at 2 mm.
        let s = LabSample { image: "x.png".into(), pose: [0.0, 0.0, 2.0, 6.0, -8.0, 0.0], shear: [0.0; 6] };
        let (_, t) = RigFrame::IDENTITY.poses(&s.pose, &s.shear, &press.press());
        assert!((t.rx_deg - 6.0 * 0.8 * 0.9).abs() < 1e-12 && (t.ry_deg + 8.0 * 0.8 * 0.9).abs() < 1e-12, "{t:?}");
        // A tilt within the play is taken up whole; above the surface nothing is.
        let small = LabSample { pose: [0.0, 0.0, 2.0, 1.2, 0.9, 0.0], ..s.clone() };
        let (_, t) = RigFrame::IDENTITY.poses(&small.pose, &small.shear, &press.press());
        assert!(t.rx_deg == 0.0 && t.ry_deg == 0.0, "{t:?}");
        let above = LabSample { pose: [0.0, 0.0, -1.0, 6.0, -8.0, 0.0], ..s };
        let (_, t) = RigFrame::IDENTITY.poses(&above.pose, &above.shear, &press.press());
        assert!(t.rx_deg == 6.0 && t.ry_deg == -8.0, "{t:?}");
    }

    #[test]
    fn a_new_pin_length_keeps_the_tips_where_the_camera_fit_put_them() {
        let base = SensorParams::half_space();
        let mut d = Deformation::of(&base, 0.5);
        d.pin_length_mm = 1.2;
        let s = d.sensor(&base).expect("valid");
        let tip = |p: &SensorParams| p.dome.outer_radius_mm - p.dome.skin_thickness_mm - p.pins.length_mm;
        assert!((tip(&s) - tip(&base)).abs() < 1e-12);
        assert_eq!(s.pins.length_mm, 1.2);
    }
}
