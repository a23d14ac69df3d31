//! Optional realism: a grey camera frame (pin coverage over a background, Gaussian blur,
//! Gaussian noise) passed through the lab's processing ([`crate::processing`]), so simulated
//! images carry the same threshold artefacts as real ones. Deterministic for a given seed.

use image::GrayImage;

use crate::error::Result;
use crate::pins::PinPose;
use crate::processing::{LAB_IMAGE_SIZE, LabProcessing};
use crate::raster;
use crate::render::PinRenderer;

/// Realism settings. Pixel sizes refer to the lab's 420 px image and scale with the output.
#[derive(Clone, Debug, PartialEq)]
pub struct Realism {
    /// Grey level of the skin background, 0..=255.
    pub background: f64,
    /// Grey level of a fully covered pin pixel, 0..=255.
    pub pin_level: f64,
    /// Standard deviation of the optical blur (px at 420).
    pub blur_sigma_px420: f64,
    /// Standard deviation of additive Gaussian pixel noise (grey levels).
    pub noise_std: f64,
    /// Noise seed.
    pub seed: u64,
    /// Radius of the bright pin disc in the grey frame relative to the geometric tip. The
    /// lab's adaptive threshold (local mean minus C) cuts a blurred pin below its half-height,
    /// which grows blobs; this factor is fitted so thresholded blobs match the real blob area
    /// (`cargo xtask fit-camera`).
    pub pin_radius_scale: f64,
    /// Processing applied to the grey frame (stated at 420 px, scaled to the output).
    pub processing: LabProcessing,
}

impl Default for Realism {
    fn default() -> Self {
        Self {
            background: 40.0,
            pin_level: 220.0,
            blur_sigma_px420: 1.5,
            noise_std: 4.0,
            seed: 0,
            pin_radius_scale: 0.8089,
            processing: LabProcessing::default(),
        }
    }
}

impl Realism {
    /// The grey frame (before processing) of pins at `pins`.
    pub fn grey_frame(&self, renderer: &PinRenderer, pins: &[PinPose]) -> GrayImage {
        let size = renderer.size();
        let mut discs = renderer.discs(pins);
        for d in &mut discs {
            d.r *= self.pin_radius_scale;
        }
        let cov = raster::draw_coverage(&discs, size);
        let span = self.pin_level - self.background;
        let raw: Vec<u8> =
            cov.iter().map(|&c| (self.background + span * c as f64).round().clamp(0.0, 255.0) as u8).collect();
        let mut img = GrayImage::from_raw(size, size, raw).unwrap_or_else(|| GrayImage::new(size, size));
        let sigma = (self.blur_sigma_px420 * size as f64 / LAB_IMAGE_SIZE as f64) as f32;
        if sigma > 0.0 {
            img = imageproc::filter::gaussian_blur_f32(&img, sigma);
        }
        if self.noise_std > 0.0 {
            imageproc::noise::gaussian_noise_mut(&mut img, 0.0, self.noise_std, self.seed);
        }
        img
    }

    /// The processed binary image of pins at `pins`.
    pub fn render(&self, renderer: &PinRenderer, pins: &[PinPose]) -> Result<GrayImage> {
        let frame = self.grey_frame(renderer, pins);
        self.processing.for_size(renderer.size()).apply(&frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::rings::ring_profile;
    use crate::detect::detect_pins;
    use crate::detect::pin_area_range;
    use crate::sensor::SensorParams;

    #[test]
    fn realistic_render_keeps_every_pin_and_is_seeded() {
        let sensor = SensorParams::half_space();
        let r = PinRenderer::new(&sensor, 256).expect("renderable");
        let tips = r.layout().poses();
        let real = Realism::default();
        let a = real.render(&r, &tips).expect("render");
        let b = real.render(&r, &tips).expect("render");
        assert_eq!(a.as_raw(), b.as_raw());
        let c = Realism { seed: 7, ..Realism::default() }.render(&r, &tips).expect("render");
        assert_ne!(a.as_raw(), c.as_raw());
        // Pin-sized blobs only: the threshold also leaves noise specks at the mask rim, so
        // count the blobs that sit on a pin (the rings), and check every pin has one.
        let (min_area, max_area) = pin_area_range(256);
        let blobs = detect_pins(&a, min_area, max_area);
        for d in r.undeformed_discs() {
            assert!(blobs.iter().any(|b| (b.centroid[0] - d.u).hypot(b.centroid[1] - d.v) < d.r), "pin at {d:?} lost");
        }
        let pins = ring_profile(&a, sensor.pins.rings, "realistic render").expect("profile");
        assert_eq!(pins.pins, 331, "pins found in the realistic render");
    }
}
