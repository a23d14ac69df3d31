//! Camera-only calibration: a sensor's camera, ring layout and image framing fitted to a
//! lab's undeformed reference alone (no deformation fit), for a TacTip whose recordings are
//! not of a flat surface. In order: the camera ([`fit_camera_at`], its distance kept: an
//! undeformed image hardly tells it), each ring's polar angle ([`fit_ring_angles`]), the
//! image size set to the reference's, the rim ring and mask ([`fit_framing`]).

use image::GrayImage;

use super::reference::Reference;
use crate::calibrate::rings::{
    Comparison, RingProfile, compare_sensor, fit_camera_at, fit_framing, fit_ring_angles, ring_profile,
};
use crate::camera::Disc;
use crate::detect::{match_reference, pin_centres, tip_pixels};
use crate::error::Result;
use crate::motion::SPACING_PX420;
use crate::render::{MIN_OFFSET_GAP_PX, PinRenderer, closest_pair};
use crate::sensor::{MAX_IMAGE_OFFSET, SensorParams};

/// The result of [`fit_camera_only`].
#[derive(Clone, Debug)]
pub struct CameraFit {
    /// The fitted sensor (its name is the base's).
    pub sensor: SensorParams,
    /// Ring profiles compared.
    pub comparison: Comparison,
    /// The simulated undeformed image's ring profile.
    pub sim: RingProfile,
    /// The reference's ring profile.
    pub real: RingProfile,
    /// Pins detected in the reference.
    pub pins_found: usize,
    /// Of those, the pins with a simulated pin within half a spacing.
    pub pins_matched: usize,
    /// RMS distance of the matched pins from their simulated pins (px at the reference's size).
    pub pin_rms_px: f64,
    /// The fitted sensor's undeformed image, framed.
    pub simulated: GrayImage,
}

impl CameraFit {
    /// One line: pins matched and their RMS, ring radii, blob area, framing.
    pub fn summary(&self) -> String {
        let side = self.real.size as f64;
        let f = &self.sensor.framing;
        let framing = match (f.rim_radius, f.rim_width) {
            (Some(r), Some(w)) => format!(
                "rim at {:.1} px, {:.1} px wide, mask beyond {:.1} px",
                r * side,
                w * side,
                f.mask_radius.unwrap_or(0.0) * side
            ),
            _ => "no rim found (none drawn)".to_owned(),
        };
        format!(
            "{} pins in the reference, {} matched within half a spacing: RMS {:.2} px at {side} px ({:.2} px at 420); \
             ring radius RMS {:.2} px, blob area error {:+.1}%; {framing}",
            self.pins_found,
            self.pins_matched,
            self.pin_rms_px,
            self.pin_rms_px * 420.0 / side,
            self.comparison.ring_radius_rms_px,
            100.0 * self.comparison.area_rel_err,
        )
    }
}

/// Fits `base`'s camera, ring angles and framing to `reference` (see the module doc).
pub fn fit_camera_only(base: &SensorParams, reference: &Reference) -> Result<CameraFit> {
    let name = reference.describe();
    let side = reference.image.width();
    let camera = fit_camera_at(base, &reference.image, &name, Some(base.camera.distance_mm))?;
    let mut sensor = fit_ring_angles(&camera, &ring_profile(&reference.image, base.pins.rings, &name)?)?;
    sensor.camera.image_size = side;
    let unframed = PinRenderer::new(&sensor, side)?;
    let principal = unframed.camera().principal;
    let field =
        unframed.undeformed_discs().iter().map(|d| (d.u - principal[0]).hypot(d.v - principal[1])).fold(0.0, f64::max);
    sensor.framing = fit_framing(&reference.image, principal, field);
    sensor.validate("camera fit")?;
    measure(sensor, reference)
}

/// Fits each pin's image offset (`pins.image_offsets`) to `reference`, keeping `base`'s
/// camera, rings and framing: three rounds of moving each simulated pin's blob onto the real
/// pin matched to it, measured blob to blob as the real pins are seen (so the binary discs'
/// quantisation is fitted away too). A pin moves only where both blobs lie within a third of
/// a spacing of each other and clear of the mask (the mask cuts blobs at the rim, which moves
/// their centres); the others keep their offset.
pub fn fit_pin_offsets(base: &SensorParams, reference: &Reference) -> Result<CameraFit> {
    let side = reference.image.width();
    let mut sensor = base.clone();
    sensor.camera.image_size = side;
    let n = sensor.pin_count();
    let mut offsets =
        if sensor.pins.image_offsets.len() == n { sensor.pins.image_offsets.clone() } else { vec![[0.0; 2]; n] };
    let found = pin_centres(&reference.image);
    let spacing = SPACING_PX420 * side as f64 / 420.0;
    let radius = 0.5 * spacing;
    for _ in 0..3 {
        sensor.pins.image_offsets.clone_from(&offsets);
        let renderer = PinRenderer::new(&sensor, side)?;
        let layout = renderer.layout().poses();
        let by_pin = |points: &[[f64; 2]]| {
            let mut out = vec![None; n];
            for (p, m) in points.iter().zip(match_reference(&renderer, &layout, points, radius)) {
                if let Some(i) = m {
                    out[i] = Some(*p);
                }
            }
            out
        };
        let (real, sim) = (by_pin(&found), by_pin(&pin_centres(&renderer.render_undeformed())));
        let principal = renderer.camera().principal;
        let clear = |d: &Disc| match sensor.framing.mask_radius {
            Some(m) => (d.u - principal[0]).hypot(d.v - principal[1]) + d.r + 1.0 < m * side as f64,
            None => true,
        };
        let discs = renderer.undeformed_discs();
        let mut next = offsets.clone();
        for (i, (r, s)) in real.iter().zip(&sim).enumerate() {
            if let (Some(r), Some(s)) = (r, s)
                && (r[0] - s[0]).hypot(r[1] - s[1]) < spacing / 3.0
                && clear(&discs[i])
            {
                for k in 0..2 {
                    next[i][k] =
                        (offsets[i][k] + (r[k] - s[k]) / side as f64).clamp(-MAX_IMAGE_OFFSET, MAX_IMAGE_OFFSET);
                }
            }
        }
        // Pins keep the renderer's smallest gap with offsets: the pins of the closest pair, when
        // too close, keep their offsets (one at least moved this round: the round started apart).
        let moved = |next: &[[f64; 2]]| -> Vec<Disc> {
            discs
                .iter()
                .zip(next.iter().zip(&offsets))
                .map(|(d, (o, old))| Disc {
                    u: d.u + (o[0] - old[0]) * side as f64,
                    v: d.v + (o[1] - old[1]) * side as f64,
                    ..*d
                })
                .collect()
        };
        while let Some((i, j, _)) = closest_pair(&moved(&next)).filter(|c| c.2 < MIN_OFFSET_GAP_PX) {
            next[i] = offsets[i];
            next[j] = offsets[j];
        }
        offsets = next;
    }
    sensor.pins.image_offsets = offsets;
    sensor.validate("pin offsets")?;
    measure(sensor, reference)
}

/// `sensor` against `reference`: ring profiles, and pin by pin each real pin's nearest
/// simulated pin within half a spacing.
fn measure(sensor: SensorParams, reference: &Reference) -> Result<CameraFit> {
    let (name, side) = (reference.describe(), reference.image.width());
    let renderer = PinRenderer::new(&sensor, side)?;
    let (comparison, sim, real) = compare_sensor(&sensor, &reference.image, &name)?;
    let found = pin_centres(&reference.image);
    let layout = renderer.layout().poses();
    let tips = tip_pixels(&renderer, &layout);
    let matched = match_reference(&renderer, &layout, &found, 0.5 * SPACING_PX420 * side as f64 / 420.0);
    let d2: Vec<f64> = found
        .iter()
        .zip(&matched)
        .filter_map(|(p, m)| m.and_then(|i| tips[i]).map(|t| (t[0] - p[0]).powi(2) + (t[1] - p[1]).powi(2)))
        .collect();
    Ok(CameraFit {
        pin_rms_px: (d2.iter().sum::<f64>() / d2.len().max(1) as f64).sqrt(),
        pins_found: found.len(),
        pins_matched: d2.len(),
        simulated: renderer.render_undeformed(),
        sensor,
        comparison,
        sim,
        real,
    })
}
