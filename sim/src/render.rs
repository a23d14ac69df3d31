//! The pin-image renderer: pin tips (sensor frame) -> camera -> discs -> binary image.

use crate::pins::PinPose;
use image::GrayImage;

use crate::camera::{Camera, Disc};
use crate::error::{Result, SimError};
use crate::pins::PinLayout;

use crate::raster;
use crate::sensor::{FramingParams, SensorParams};
use crate::variation::Variation;

/// Smallest projected pin radius the renderer accepts (px). A disc centred on a pixel corner
/// covers its four pixels equally, `pi r^2 / 4` each, which is the worst case for the best-covered
/// pixel; the binary image keeps the pin only if that reaches 1/2, i.e. `r >= sqrt(2 / pi)`
/// = 0.7979 px. (0.75 px let a pin vanish: see the regression test in `raster`.)
pub const MIN_PIN_RADIUS_PX: f64 = 0.8;
/// Smallest gap between two undeformed pins' discs (px). Above sqrt(2), pixels of two pins
/// are never 8-connected (a pixel is white only when its centre lies inside a disc), so the
/// pins stay separate blobs. (It was 1.5, which refused the edge recordings' TacTip at their
/// 128 px: its outer rings' pins are 1.44 px apart there, and separate in the real images.)
pub const MIN_PIN_GAP_PX: f64 = std::f64::consts::SQRT_2;

/// Smallest gap between two undeformed pins' discs with their image offsets
/// (`pins.image_offsets`, px): real pins fitted at the pixel may sit closer than the ring
/// layout's [`MIN_PIN_GAP_PX`] and still image apart.
pub const MIN_OFFSET_GAP_PX: f64 = 0.5;

/// Renders one sensor at one image size. Building it checks that the undeformed pins are
/// separate, large enough and inside the image, so every undeformed render shows exactly
/// `pin_count` blobs.
///
/// ```
/// use tacsim_sim::{PinRenderer, SensorParams};
///
/// let sensor = SensorParams::default();
/// let renderer = PinRenderer::new(&sensor, 128)?;
/// // The undeformed pins, as the camera inside the dome sees them: white blobs on black.
/// let image = renderer.render(&renderer.layout().poses());
/// assert_eq!(image.dimensions(), (128, 128));
/// assert!(image.pixels().any(|p| p.0[0] == 255) && image.pixels().any(|p| p.0[0] == 0));
/// # Ok::<(), tacsim_sim::SimError>(())
/// ```
#[derive(Clone, Debug)]
pub struct PinRenderer {
    camera: Camera,
    layout: PinLayout,
    undeformed: Vec<Disc>,
    /// Each layout pin's image offset (px at this size; `pins.image_offsets`), or none.
    offsets_px: Vec<[f64; 2]>,
    /// The framing's pixels as runs `(first, end, value)` of raster indices, found once.
    framing: Vec<(usize, usize, u8)>,
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
        if let Some((a, b, gap)) = closest_pair(&undeformed).filter(|c| c.2 < MIN_PIN_GAP_PX) {
            return Err(fail(format!(
                "neighbouring pins {a} and {b} are {gap:.2} px apart (< {MIN_PIN_GAP_PX:.3}): they would merge; use a larger image, smaller tips or a wider ring pitch"
            )));
        }
        // Measured image offsets may bring two pins a little closer than the ring layout does,
        // as the real pins they were fitted to are.
        let s = size as f64;
        let offsets_px: Vec<[f64; 2]> = sensor.pins.image_offsets.iter().map(|o| [o[0] * s, o[1] * s]).collect();
        if !offsets_px.is_empty() {
            for (d, o) in undeformed.iter_mut().zip(&offsets_px) {
                *d = offset_disc(*d, Some(o));
            }
            if let Some((a, b, gap)) = closest_pair(&undeformed).filter(|c| c.2 < MIN_OFFSET_GAP_PX) {
                return Err(fail(format!(
                    "pins {a} and {b} are {gap:.2} px apart with their image offsets (< {MIN_OFFSET_GAP_PX}): smaller pins.image_offsets"
                )));
            }
        }
        let framing = framing_runs(&sensor.framing, camera.principal, size);
        Ok(Self { camera, layout, undeformed, offsets_px, framing })
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

    /// Projects pins (tip centre and axis in the sensor frame, any count) to discs, each moved
    /// by its image offset when `pins` are the layout's (`pins.image_offsets`); pins behind the
    /// camera are dropped.
    pub fn discs(&self, pins: &[PinPose]) -> Vec<Disc> {
        pins.iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let d = self.camera.project_disc(&p.tip, &p.axis, self.layout.tip_radius_mm)?;
                Some(offset_disc(d, self.image_offset(i, pins.len())))
            })
            .collect()
    }

    /// The image offset (px) of pin `i` of a set of `count` pins: its `pins.image_offsets`
    /// entry when the set is the layout's, else none.
    pub(crate) fn image_offset(&self, i: usize, count: usize) -> Option<&[f64; 2]> {
        if count == self.layout.pins.len() { self.offsets_px.get(i) } else { None }
    }

    /// Renders the binary image of pins at `pins` into `out`, framed as the sensor's
    /// [`FramingParams`] say.
    pub fn render_pins(&self, pins: &[PinPose], out: &mut GrayImage) {
        raster::draw_binary(&self.discs(pins), self.camera.size, out);
        self.frame(out);
    }

    /// Draws the rim ring and applies the mask of [`FramingParams`].
    fn frame(&self, out: &mut GrayImage) {
        let buf: &mut [u8] = out;
        for &(first, end, value) in &self.framing {
            buf[first..end].fill(value);
        }
    }

    /// Renders the binary image of pins at `pins` into a new image.
    pub fn render(&self, pins: &[PinPose]) -> GrayImage {
        let mut out = GrayImage::new(self.camera.size, self.camera.size);
        self.render_pins(pins, &mut out);
        out
    }

    /// Renders pins at `pins` with a sample's [`Variation`]: pins rolled about the camera
    /// axis, tips scaled, each pin offset by its jitter, the field shifted; specks added over the pin field; then either the
    /// binary coverage test or, with blur or another threshold, coverage blurred and cut at
    /// the threshold; framed as [`Self::render`]. Equal to [`Self::render`] for
    /// [`Variation::NOMINAL`].
    pub fn render_varied(&self, pins: &[PinPose], v: &Variation) -> GrayImage {
        if *v == Variation::NOMINAL {
            return self.render(pins);
        }
        let discs = self.varied_discs(pins, v);
        let size = self.camera.size;
        let mut out = GrayImage::new(size, size);
        if v.needs_coverage() {
            let cov = raster::draw_coverage(&discs, size);
            let grey: Vec<u8> = cov.iter().map(|&c| (255.0 * c).round() as u8).collect();
            let mut img = GrayImage::from_raw(size, size, grey).unwrap_or_else(|| GrayImage::new(size, size));
            if v.blur_px > 0.0 {
                img = imageproc::filter::gaussian_blur_f32(&img, v.blur_px as f32);
            }
            let cut = (255.0 * v.threshold).round().clamp(1.0, 255.0) as u8;
            for (o, g) in out.pixels_mut().zip(img.pixels()) {
                o.0[0] = if g.0[0] >= cut { 255 } else { 0 };
            }
        } else {
            raster::draw_binary(&discs, size, &mut out);
        }
        self.frame(&mut out);
        out
    }

    /// The discs of [`Self::render_varied`]: pins rolled, scaled, jittered and shifted, specks
    /// added.
    pub(crate) fn varied_discs(&self, pins: &[PinPose], v: &Variation) -> Vec<Disc> {
        if *v == Variation::NOMINAL {
            return self.discs(pins);
        }
        let (sin, cos) = v.roll_deg.to_radians().sin_cos();
        let roll = |x: f64, y: f64| (cos * x - sin * y, sin * x + cos * y);
        let size = self.camera.size;
        // Only where the sample jitters: no allocation on the renderer's path otherwise.
        let jitter = (v.pin_jitter_px > 0.0).then(|| v.pin_jitter(pins.len()));
        let mut discs: Vec<Disc> = pins
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let (tx, ty) = roll(p.tip.x, p.tip.y);
                let (ax, ay) = roll(p.axis.x, p.axis.y);
                let tip = nalgebra::Point3::new(tx, ty, p.tip.z);
                let axis = nalgebra::Vector3::new(ax, ay, p.axis.z);
                let d = self.camera.project_disc(&tip, &axis, self.layout.tip_radius_mm * v.pin_scale)?;
                // A pin's offset turns with the roll, as the pins do.
                let offset = self.image_offset(i, pins.len()).map(|o| {
                    let (du, dv) = roll(o[0], o[1]);
                    [du, dv]
                });
                let d = offset_disc(d, offset.as_ref());
                Some(match &jitter {
                    Some(j) => Disc { u: d.u + j[i][0], v: d.v + j[i][1], ..d },
                    None => d,
                })
            })
            .map(|d| Disc { u: d.u + v.shift_px[0], v: d.v + v.shift_px[1], ..d })
            .collect();
        if v.specks > 0 {
            let field_px = self
                .undeformed
                .iter()
                .map(|d| (d.u - self.camera.principal[0]).hypot(d.v - self.camera.principal[1]) + d.r)
                .fold(0.0, f64::max);
            discs.extend(v.speck_discs(self.camera.principal, field_px, size));
        }
        discs
    }

    /// [`Self::render_varied`] for a batch of samples (pins and variation each), the binary
    /// ones rasterised on the GPU in one dispatch (feature `wgpu`; `gpu/raster.rs`), those
    /// whose variation blurs or thresholds otherwise on the CPU; framed on the CPU.
    #[cfg(feature = "wgpu")]
    pub fn render_batch(&self, gpu: &crate::gpu::Gpu, batch: &[(&[PinPose], &Variation)]) -> Result<Vec<GrayImage>> {
        let binary: Vec<usize> = (0..batch.len()).filter(|&k| !batch[k].1.needs_coverage()).collect();
        let discs: Vec<Vec<Disc>> = binary.iter().map(|&k| self.varied_discs(batch[k].0, batch[k].1)).collect();
        let mut drawn = gpu.draw_binary_batch(&discs, self.camera.size)?.into_iter();
        let mut out = Vec::with_capacity(batch.len());
        for (pins, v) in batch {
            if v.needs_coverage() {
                out.push(self.render_varied(pins, v));
                continue;
            }
            let Some(mut image) = drawn.next() else {
                return Err(SimError::Gpu("the raster returned fewer images than it was given".into()));
            };
            self.frame(&mut image);
            out.push(image);
        }
        Ok(out)
    }

    /// Renders the undeformed sensor into `out` (reusing its buffer).
    pub fn render_undeformed_into(&self, out: &mut GrayImage) {
        raster::draw_binary(&self.undeformed, self.camera.size, out);
        self.frame(out);
    }

    /// Renders the undeformed sensor.
    pub fn render_undeformed(&self) -> GrayImage {
        let mut out = GrayImage::new(self.camera.size, self.camera.size);
        self.render_undeformed_into(&mut out);
        out
    }
}

/// The two discs with the smallest gap between their edges (px), and that gap.
pub(crate) fn closest_pair(discs: &[Disc]) -> Option<(usize, usize, f64)> {
    let mut best: Option<(usize, usize, f64)> = None;
    for (i, a) in discs.iter().enumerate() {
        for (j, b) in discs.iter().enumerate().skip(i + 1) {
            let gap = (a.u - b.u).hypot(a.v - b.v) - a.r - b.r;
            if best.is_none_or(|c| gap < c.2) {
                best = Some((i, j, gap));
            }
        }
    }
    best
}

/// `d` moved by `offset` (px), if any.
fn offset_disc(d: Disc, offset: Option<&[f64; 2]>) -> Disc {
    match offset {
        Some(o) => Disc { u: d.u + o[0], v: d.v + o[1], ..d },
        None => d,
    }
}

/// The pixels [`FramingParams`] sets in a `size` px image, as runs `(first, end, value)` of
/// raster indices: black beyond the mask, else white on the rim ring; circles about the
/// principal point `centre` (px), a pixel belonging to them by its centre.
fn framing_runs(f: &FramingParams, centre: [f64; 2], size: u32) -> Vec<(usize, usize, u8)> {
    if f.rim_radius.is_none() && f.mask_radius.is_none() {
        return Vec::new();
    }
    let s = size as f64;
    let rim = f.rim_radius.zip(f.rim_width).map(|(r, w)| ((r - 0.5 * w) * s, (r + 0.5 * w) * s));
    let mask = f.mask_radius.map(|m| m * s);
    let mut runs: Vec<(usize, usize, u8)> = Vec::new();
    for y in 0..size {
        for x in 0..size {
            let d = (x as f64 + 0.5 - centre[0]).hypot(y as f64 + 0.5 - centre[1]);
            let value = if mask.is_some_and(|m| d > m) {
                0
            } else if rim.is_some_and(|(lo, hi)| d >= lo && d <= hi) {
                255
            } else {
                continue;
            };
            let i = (y * size + x) as usize;
            match runs.last_mut() {
                Some(run) if run.1 == i && run.2 == value => run.1 += 1,
                _ => runs.push((i, i + 1, value)),
            }
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rendering_is_deterministic_and_binary() {
        let r = PinRenderer::new(&SensorParams::half_space(), 256).expect("renderable");
        let a = r.render_undeformed();
        let b = r.render_undeformed();
        assert_eq!(a.as_raw(), b.as_raw());
        assert!(a.as_raw().iter().all(|&p| p == 0 || p == 255));
    }

    #[test]
    fn framing_draws_the_rim_ring_and_masks_outside_its_circle() {
        let sensor = SensorParams {
            framing: FramingParams { rim_radius: Some(0.46), rim_width: Some(0.02), mask_radius: Some(0.48) },
            ..SensorParams::half_space()
        };
        let plain = PinRenderer::new(&SensorParams::half_space(), 128).expect("renderable").render_undeformed();
        let r = PinRenderer::new(&sensor, 128).expect("renderable");
        let framed = r.render_undeformed();
        let [cu, cv] = r.camera().principal;
        let (mut rim, mut rim_white, mut outside_white) = (0, 0, 0);
        for (x, y, p) in framed.enumerate_pixels() {
            let d = (x as f64 + 0.5 - cu).hypot(y as f64 + 0.5 - cv) / 128.0;
            if (d - 0.46).abs() <= 0.01 {
                rim += 1;
                rim_white += usize::from(p.0[0] == 255);
            } else if d > 0.48 {
                outside_white += usize::from(p.0[0] == 255);
            } else {
                // Inside the rim, the pins are untouched.
                assert_eq!(p.0[0], plain.get_pixel(x, y).0[0], "pixel {x},{y}");
            }
        }
        // The ring's area 2 pi r w = 2 pi 0.46 0.02 128^2 = 947 px.
        assert!((rim as f64 - 947.0).abs() < 60.0 && rim_white == rim, "{rim} {rim_white}");
        assert_eq!(outside_white, 0);
    }

    #[test]
    fn the_framing_fit_recovers_a_rendered_rim_and_finds_none_without_one() {
        // A wider view than the default's keeps the pins (out to 0.37 of the image, at 192 px) inside the rim.
        let mut sensor = SensorParams::half_space();
        sensor.camera.fov_deg *= 1.2;
        sensor.framing = FramingParams { rim_radius: Some(0.46), rim_width: Some(0.025), mask_radius: Some(0.48) };
        let r = PinRenderer::new(&sensor, 192).expect("renderable");
        let field =
            r.undeformed_discs().iter().map(|d| (d.u - r.camera().principal[0]).hypot(d.v - r.camera().principal[1]));
        let field = field.fold(0.0, f64::max);
        let f = crate::calibrate::rings::fit_framing(&r.render_undeformed(), r.camera().principal, field);
        let (radius, width) = (f.rim_radius.expect("rim"), f.rim_width.expect("rim"));
        // Within a pixel of 192 in radius, half a pixel in width.
        assert!((radius - 0.46).abs() < 1.0 / 192.0 && (width - 0.025).abs() < 0.5 / 192.0, "{f:?}");
        sensor.framing = FramingParams::default();
        let plain = PinRenderer::new(&sensor, 192).expect("renderable");
        let none = crate::calibrate::rings::fit_framing(&plain.render_undeformed(), plain.camera().principal, field);
        assert_eq!(none, FramingParams::default());
    }

    #[test]
    fn a_nominal_variation_renders_as_the_binary_renderer_and_others_change_the_image() {
        let r = PinRenderer::new(&SensorParams::edge2d().expect("preset"), 128).expect("renderable");
        let pins = r.layout().poses();
        let nominal = r.render(&pins);
        assert_eq!(r.render_varied(&pins, &Variation::NOMINAL), nominal);
        let count = |img: &GrayImage| crate::detect::detect_blobs(img).len();
        // Shifted by a whole pixel: the same pins, one column to the right (the rim stays).
        let shifted = r.render_varied(&pins, &Variation { shift_px: [1.0, 0.0], ..Variation::NOMINAL });
        let inside = |img: &GrayImage, x: u32, y: u32| img.get_pixel(x, y).0[0];
        let (mut same, mut total) = (0, 0);
        for y in 20..108 {
            for x in 20..107 {
                if (f64::from(x) - 64.0).hypot(f64::from(y) - 64.0) > 45.0 {
                    continue;
                }
                total += 1;
                same += usize::from(inside(&nominal, x, y) == inside(&shifted, x + 1, y));
            }
        }
        assert_eq!(same, total, "a 1 px shift moves every pin pixel by one column");
        // Larger tips, blur and a low threshold grow the white area; specks add blobs.
        let white = |img: &GrayImage| img.pixels().filter(|p| p.0[0] > 0).count();
        let bigger = r.render_varied(&pins, &Variation { pin_scale: 1.2, ..Variation::NOMINAL });
        let blurred = r.render_varied(&pins, &Variation { blur_px: 0.8, threshold: 0.3, ..Variation::NOMINAL });
        assert!(white(&bigger) > white(&nominal) && white(&blurred) > white(&nominal));
        let specks = r.render_varied(&pins, &Variation { specks: 40, speck_seed: 3, ..Variation::NOMINAL });
        assert!(count(&specks) > count(&nominal), "{} vs {}", count(&specks), count(&nominal));
        // A roll turns the pin field: another image, the same for the same roll.
        let rolled = Variation { roll_deg: 7.0, ..Variation::NOMINAL };
        assert_ne!(r.render_varied(&pins, &rolled), nominal);
        assert_eq!(r.render_varied(&pins, &rolled), r.render_varied(&pins, &rolled));
    }

    #[test]
    fn pin_jitter_moves_each_pin_by_its_own_normal_draw() {
        let r = PinRenderer::new(&SensorParams::half_space(), 128).expect("renderer");
        let pins = r.layout().poses();
        let nominal = r.discs(&pins);
        let v = Variation { pin_jitter_px: 0.5, jitter_seed: 9, ..Variation::NOMINAL };
        let jittered = r.varied_discs(&pins, &v);
        let draws = v.pin_jitter(pins.len());
        assert_eq!((jittered.len(), nominal.len()), (pins.len(), pins.len()));
        for ((j, n), d) in jittered.iter().zip(&nominal).zip(&draws) {
            assert!((j.u - n.u - d[0]).abs() < 1e-12 && (j.v - n.v - d[1]).abs() < 1e-12 && j.r == n.r);
        }
        // 662 normal draws: mean 0 and standard deviation 0.5 px, within 5 standard errors.
        let all: Vec<f64> = draws.iter().flatten().copied().collect();
        let mean = all.iter().sum::<f64>() / all.len() as f64;
        let sd = (all.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (all.len() - 1) as f64).sqrt();
        assert!(mean.abs() < 5.0 * 0.5 / (all.len() as f64).sqrt(), "mean {mean}");
        assert!((sd - 0.5).abs() < 5.0 * 0.5 / (2.0 * all.len() as f64).sqrt(), "sd {sd}");
        // The same seed draws the same offsets, another seed others.
        assert_eq!(r.render_varied(&pins, &v), r.render_varied(&pins, &v));
        assert_ne!(draws, Variation { jitter_seed: 10, ..v }.pin_jitter(pins.len()));
        assert_ne!(r.render_varied(&pins, &v), r.render(&pins));
    }

    #[test]
    fn image_offsets_move_each_layout_pin_and_nothing_else() {
        let plain = SensorParams::half_space();
        let mut offset = plain.clone();
        let n = offset.pin_count();
        offset.pins.image_offsets = (0..n).map(|i| [0.002 * (i % 3) as f64, -0.001 * (i % 2) as f64]).collect();
        let (a, b) = (PinRenderer::new(&plain, 200).expect("plain"), PinRenderer::new(&offset, 200).expect("offset"));
        for (i, (p, q)) in a.undeformed_discs().iter().zip(b.undeformed_discs()).enumerate() {
            let o = offset.pins.image_offsets[i];
            assert!((q.u - p.u - 200.0 * o[0]).abs() < 1e-12 && (q.v - p.v - 200.0 * o[1]).abs() < 1e-12, "pin {i}");
        }
        // The layout's pins, moved, carry their offsets; any other set of pins does not.
        let pins = a.layout().poses();
        assert_eq!(b.discs(&pins), b.undeformed_discs());
        assert_eq!(b.discs(&pins[..5]), a.discs(&pins[..5]));
        // Too close with their offsets: a clear error naming the pins.
        offset.pins.image_offsets = vec![[0.0; 2]; n];
        offset.pins.image_offsets[1] = [-0.02, 0.0];
        offset.pins.image_offsets[0] = [0.02, 0.0];
        let e = PinRenderer::new(&offset, 200).expect_err("overlapping").to_string();
        assert!(e.contains("image offsets"), "{e}");
    }

    #[test]
    fn too_small_image_is_a_clear_error() {
        let e = PinRenderer::new(&SensorParams::half_space(), 16).expect_err("16 px is too small");
        assert!(e.to_string().contains("16x16"), "{e}");
    }
}
