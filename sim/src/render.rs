//! The pin-image renderer: pin tips (sensor frame) -> camera -> discs -> binary image.

use crate::pins::PinPose;
use image::GrayImage;

use crate::camera::{Camera, Disc};
use crate::error::{Result, SimError};
use crate::pins::PinLayout;

use crate::raster;
use crate::sensor::SensorParams;

/// Smallest projected pin radius the renderer accepts (px). A disc centred on a pixel corner
/// covers its four pixels equally, `pi r^2 / 4` each, which is the worst case for the best-covered
/// pixel; the binary image keeps the pin only if that reaches 1/2, i.e. `r >= sqrt(2 / pi)`
/// = 0.7979 px. (0.75 px let a pin vanish: see the regression test in `raster`.)
pub const MIN_PIN_RADIUS_PX: f64 = 0.8;
/// Smallest gap between two undeformed pins' discs (px). Above sqrt(2), pixels of two pins
/// are never 8-connected, so the pins stay separate blobs.
pub const MIN_PIN_GAP_PX: f64 = 1.5;

/// Renders one sensor at one image size. Building it checks that the undeformed pins are
/// separate, large enough and inside the image, so every undeformed render shows exactly
/// `pin_count` blobs.
#[derive(Clone, Debug)]
pub struct PinRenderer {
    camera: Camera,
    layout: PinLayout,
    undeformed: Vec<Disc>,
}

impl PinRenderer {
    /// A renderer for `sensor` at `size` x `size` px. `sensor` must be validated.
    pub fn new(sensor: &SensorParams, size: u32) -> Result<Self> {
        let fail = |reason: String| SimError::Render { source_name: sensor.name.clone(), size, reason };
        if !(crate::sensor::IMAGE_SIZE_RANGE.0..=crate::sensor::IMAGE_SIZE_RANGE.1).contains(&size) {
            return Err(fail(format!(
                "image size must be in [{}, {}] px",
                crate::sensor::IMAGE_SIZE_RANGE.0,
                crate::sensor::IMAGE_SIZE_RANGE.1
            )));
        }
        let camera = Camera::new(&sensor.camera, size);
        let layout = PinLayout::new(sensor);
        let mut undeformed = Vec::with_capacity(layout.pins.len());
        for pin in &layout.pins {
            let disc = camera
                .project_disc(&pin.tip, &pin.normal, layout.tip_radius_mm)
                .ok_or_else(|| fail(format!("pin ring {} is behind the camera", pin.ring)))?;
            if disc.r < MIN_PIN_RADIUS_PX {
                return Err(fail(format!(
                    "pins of ring {} are {:.2} px in radius (< {MIN_PIN_RADIUS_PX}): use a larger image or pin tips",
                    pin.ring, disc.r
                )));
            }
            let s = size as f64;
            if disc.u - disc.r < 0.0 || disc.v - disc.r < 0.0 || disc.u + disc.r > s || disc.v + disc.r > s {
                return Err(fail(format!(
                    "pin ring {} leaves the image: widen camera.fov_deg or reduce the ring pitch",
                    pin.ring
                )));
            }
            undeformed.push(disc);
        }
        for (i, a) in undeformed.iter().enumerate() {
            for b in &undeformed[i + 1..] {
                let gap = ((a.u - b.u).powi(2) + (a.v - b.v).powi(2)).sqrt() - a.r - b.r;
                if gap < MIN_PIN_GAP_PX {
                    return Err(fail(format!(
                        "neighbouring pins are {gap:.2} px apart (< {MIN_PIN_GAP_PX}): they would merge; use a larger image, smaller tips or a wider ring pitch"
                    )));
                }
            }
        }
        Ok(Self { camera, layout, undeformed })
    }

    /// The camera in use.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The undeformed pin layout.
    pub fn layout(&self) -> &PinLayout {
        &self.layout
    }

    /// Image size (px).
    pub fn size(&self) -> u32 {
        self.camera.size
    }

    /// Discs of the undeformed pins.
    pub fn undeformed_discs(&self) -> &[Disc] {
        &self.undeformed
    }

    /// Projects pins (tip centre and axis in the sensor frame, any count) to discs; pins
    /// behind the camera are dropped.
    pub fn discs(&self, pins: &[PinPose]) -> Vec<Disc> {
        pins.iter().filter_map(|p| self.camera.project_disc(&p.tip, &p.axis, self.layout.tip_radius_mm)).collect()
    }

    /// Renders the binary image of pins at `pins` into `out`.
    pub fn render_pins(&self, pins: &[PinPose], out: &mut GrayImage) {
        raster::draw_binary(&self.discs(pins), self.camera.size, out);
    }

    /// Renders the binary image of pins at `pins` into a new image.
    pub fn render(&self, pins: &[PinPose]) -> GrayImage {
        let mut out = GrayImage::new(self.camera.size, self.camera.size);
        self.render_pins(pins, &mut out);
        out
    }

    /// Renders the undeformed sensor into `out` (reusing its buffer).
    pub fn render_undeformed_into(&self, out: &mut GrayImage) {
        raster::draw_binary(&self.undeformed, self.camera.size, out);
    }

    /// Renders the undeformed sensor.
    pub fn render_undeformed(&self) -> GrayImage {
        let mut out = GrayImage::new(self.camera.size, self.camera.size);
        self.render_undeformed_into(&mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rendering_is_deterministic_and_binary() {
        let r = PinRenderer::new(&SensorParams::default(), 256).expect("renderable");
        let a = r.render_undeformed();
        let b = r.render_undeformed();
        assert_eq!(a.as_raw(), b.as_raw());
        assert!(a.as_raw().iter().all(|&p| p == 0 || p == 255));
    }

    #[test]
    fn too_small_image_is_a_clear_error() {
        let e = PinRenderer::new(&SensorParams::default(), 16).expect_err("16 px is too small");
        assert!(e.to_string().contains("16x16"), "{e}");
    }
}
