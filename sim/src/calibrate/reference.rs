//! The undeformed reference of a lab folder, and the square framing of its images.
//!
//! Calibration measures every recording's pin motion from an undeformed layout. Few lab
//! folders hold an image of the sensor touching nothing, so where none is named the
//! reference is the **consensus** of the shallowest presses: the pixel-wise majority of the
//! [`consensus_count`] recordings with the smallest depth label (`pose z`, mm). Each press moves
//! only the pins near its contact, and the contacts differ from press to press, so the majority
//! keeps each pin where most presses leave it: on the edge taps (1,500, no undeformed image)
//! the consensus of the 75 shallowest shows 330 pins and the camera fit puts 327 of them
//! within 0.35 px RMS at 128 px. Presses that all touch the same pins do not suit it: on the
//! surface recordings, whose undeformed `image_0.png` tells the truth, the consensus of the
//! 30 shallowest of 600 flat presses finds 322 of 327 pins within 2.4 px RMS of it at 420 px,
//! but its central pins are smeared (ring 1 shows 3 of 6), so the ring fit cannot read it
//! (`tests/calibrate.rs`). Name an undeformed image where one exists.
//!
//! Lab images need not be square (a camera frame cropped by the lab's bounding box): the
//! pin field's circle is found on the reference ([`PinField`]) and every image is cut to the
//! square about it ([`SquareCrop`]: cropped, and padded with black where the square leaves the
//! image). Square images are used as they are.

use image::GrayImage;
use tacsim_data::{LabFolder, LabSample};

use crate::detect::detect_pins;
use crate::detect::pin_area_range;
use crate::error::{Result, SimError};
use crate::png_io::read_png;

/// The conventional name of the undeformed reference in a lab folder's `images/`.
pub const DEFAULT_REFERENCE: &str = "image_0.png";
/// Fewest recordings a consensus reference is built from.
pub const CONSENSUS_MIN: usize = 30;
/// Largest image side read (px): a lab image is a processed camera frame.
const MAX_SIDE: u32 = 8192;

/// How many of `n` recordings a consensus reference takes: the shallowest 5%, at least
/// [`CONSENSUS_MIN`] (or all when fewer).
pub fn consensus_count(n: usize) -> usize {
    (n / 20).max(CONSENSUS_MIN).min(n)
}

/// The circle of the pin field in an image (px).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinField {
    /// Centre `[u, v]` (px).
    pub centre: [f64; 2],
    /// Radius (px) reaching the centres of the outermost pins.
    pub radius: f64,
    /// Pin blobs found.
    pub pins: usize,
}

impl PinField {
    /// Finds the pin field of an image of any shape: the pin-sized blobs (sized for the
    /// image's shorter side), their mean as the centre, the 98th percentile of their distances
    /// as the radius; blobs beyond 1.15 radii (rim clutter, specks) are dropped and the circle
    /// found again. `None` with fewer than 7 pins.
    pub fn find(img: &GrayImage) -> Option<Self> {
        let (lo, hi) = pin_area_range(img.width().min(img.height()));
        let mut pts: Vec<[f64; 2]> = detect_pins(img, lo, hi).iter().map(|b| b.centroid).collect();
        let mut field = None;
        for _ in 0..3 {
            if pts.len() < 7 {
                return None;
            }
            let n = pts.len() as f64;
            let centre = [pts.iter().map(|p| p[0]).sum::<f64>() / n, pts.iter().map(|p| p[1]).sum::<f64>() / n];
            let mut d: Vec<f64> = pts.iter().map(|p| (p[0] - centre[0]).hypot(p[1] - centre[1])).collect();
            d.sort_by(f64::total_cmp);
            let radius = d[((d.len() - 1) as f64 * 0.98).round() as usize];
            field = Some(Self { centre, radius, pins: pts.len() });
            pts.retain(|p| (p[0] - centre[0]).hypot(p[1] - centre[1]) <= 1.15 * radius);
        }
        field
    }
}

/// A square cut of an image: the square of side `side` px whose top-left corner sits at
/// `(x0, y0)` of the source (negative or past the edge: padded with black).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SquareCrop {
    /// Source image width and height (px); other sizes are refused.
    pub source: (u32, u32),
    /// Left column of the square in the source (px).
    pub x0: i64,
    /// Top row of the square in the source (px).
    pub y0: i64,
    /// Side (px).
    pub side: u32,
}

impl SquareCrop {
    /// The identity cut of a square image.
    pub fn identity(side: u32) -> Self {
        Self { source: (side, side), x0: 0, y0: 0, side }
    }

    /// The square about `field` in a `w` x `h` image: as large as the shorter side, larger
    /// (padded) where the pin field with a tenth of its radius around it would not fit. A
    /// square image keeps its framing.
    pub fn about(field: &PinField, (w, h): (u32, u32)) -> Self {
        if w == h {
            return Self::identity(w);
        }
        let side = w.min(h).max((2.2 * field.radius).ceil() as u32);
        let corner = |c: f64| (c - 0.5 * side as f64).round() as i64;
        Self { source: (w, h), x0: corner(field.centre[0]), y0: corner(field.centre[1]), side }
    }

    /// Whether the cut changes the image.
    pub fn is_identity(&self) -> bool {
        *self == Self::identity(self.side)
    }

    /// Cuts `img` (of the [`source`](Self::source) size, else an error naming `path`).
    pub fn apply(&self, img: GrayImage, path: &std::path::Path) -> Result<GrayImage> {
        if img.dimensions() != self.source {
            return Err(SimError::Image {
                path: path.to_owned(),
                reason: format!(
                    "is {}x{}, the reference {}x{}: every image of a lab folder has one size",
                    img.width(),
                    img.height(),
                    self.source.0,
                    self.source.1
                ),
            });
        }
        if self.is_identity() {
            return Ok(img);
        }
        let mut out = GrayImage::new(self.side, self.side);
        image::imageops::replace(&mut out, &img, -self.x0, -self.y0);
        Ok(out)
    }
}

/// Where a reference came from.
#[derive(Clone, Debug, PartialEq)]
pub enum ReferenceSource {
    /// An undeformed image of the folder.
    Image(String),
    /// The consensus of these recordings (image names, shallowest first).
    Consensus(Vec<String>),
}

/// The undeformed reference of a lab folder, cut square.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The reference image (square, binary).
    pub image: GrayImage,
    /// The cut applied to every image of the folder.
    pub crop: SquareCrop,
    /// Its pin field in the source image (px of the source).
    pub field: PinField,
    /// Where it came from.
    pub source: ReferenceSource,
}

impl Reference {
    /// The reference of `folder`: the image `name` under `images/`; without a name,
    /// `image_0.png` where it exists, else the consensus of the shallowest recordings.
    pub fn of(folder: &LabFolder, name: Option<&str>) -> Result<Self> {
        let default = folder.dir.join("images").join(DEFAULT_REFERENCE);
        match name {
            Some(n) => Self::image(folder, n),
            None if default.is_file() => Self::image(folder, DEFAULT_REFERENCE),
            None => Self::consensus(folder),
        }
    }

    /// An undeformed image of the folder.
    pub fn image(folder: &LabFolder, name: &str) -> Result<Self> {
        let path = folder.dir.join("images").join(name);
        if !path.is_file() {
            return Err(SimError::Image {
                path,
                reason: "the undeformed reference image is missing: name another, or name none to build the \
                         reference from the shallowest recordings"
                    .to_owned(),
            });
        }
        let raw = read_checked(&path)?;
        Self::framed(raw, &path, ReferenceSource::Image(name.to_owned()))
    }

    /// The pixel-wise majority of the [`consensus_count`] shallowest recordings (smallest
    /// `pose z`; ties by image name).
    pub fn consensus(folder: &LabFolder) -> Result<Self> {
        let mut order: Vec<&LabSample> = folder.samples.iter().collect();
        order.sort_by(|a, b| a.pose[2].total_cmp(&b.pose[2]).then_with(|| a.image.cmp(&b.image)));
        order.truncate(consensus_count(order.len()));
        let first = folder.image_path(order[0]);
        let (mut w, mut h) = (0, 0);
        let mut votes = Vec::new();
        for s in &order {
            let path = folder.image_path(s);
            let img = read_checked(&path)?;
            if votes.is_empty() {
                (w, h) = img.dimensions();
                votes = vec![0u32; (w * h) as usize];
            }
            if img.dimensions() != (w, h) {
                return Err(SimError::Image {
                    path,
                    reason: format!(
                        "is {}x{}, {} {w}x{h}: every image of a lab folder has one size",
                        img.width(),
                        img.height(),
                        first.display()
                    ),
                });
            }
            for (v, p) in votes.iter_mut().zip(img.as_raw()) {
                *v += u32::from(*p >= 128);
            }
        }
        let n = order.len() as u32;
        let raw = GrayImage::from_raw(w, h, votes.iter().map(|&v| if 2 * v > n { 255 } else { 0 }).collect())
            .ok_or_else(|| SimError::Image { path: first.clone(), reason: "image buffer size".to_owned() })?;
        let names = order.iter().map(|s| s.image.clone()).collect();
        Self::framed(raw, &folder.dir.join("images"), ReferenceSource::Consensus(names))
    }

    fn framed(raw: GrayImage, path: &std::path::Path, source: ReferenceSource) -> Result<Self> {
        let field = PinField::find(&raw).ok_or_else(|| SimError::Image {
            path: path.to_owned(),
            reason: "no pin field found (fewer than 7 pin-sized blobs): is it a processed, binary TacTip image?"
                .to_owned(),
        })?;
        let crop = SquareCrop::about(&field, raw.dimensions());
        let image = crop.apply(raw, path)?;
        Ok(Self { image, crop, field, source })
    }

    /// The image name to leave out of the recordings (an undeformed reference listed among
    /// them), if any.
    pub fn image_name(&self) -> Option<&str> {
        match &self.source {
            ReferenceSource::Image(n) => Some(n),
            ReferenceSource::Consensus(_) => None,
        }
    }

    /// A one-line account for reports.
    pub fn describe(&self) -> String {
        let framing = if self.crop.is_identity() {
            String::new()
        } else {
            format!(
                "; images {}x{} cut to the {} px square at ({}, {}) about the pin field (centre ({:.1}, {:.1}), radius {:.1} px)",
                self.crop.source.0,
                self.crop.source.1,
                self.crop.side,
                self.crop.x0,
                self.crop.y0,
                self.field.centre[0],
                self.field.centre[1],
                self.field.radius
            )
        };
        match &self.source {
            ReferenceSource::Image(n) => format!("undeformed image {n}{framing}"),
            ReferenceSource::Consensus(names) => {
                format!("consensus (pixel-wise majority) of the {} shallowest recordings{framing}", names.len())
            }
        }
    }

    /// Reads one recording's image, cut as the reference.
    pub fn read(&self, path: &std::path::Path) -> Result<GrayImage> {
        self.crop.apply(read_checked(path)?, path)
    }
}

/// Reads a PNG, refusing absurd sizes before any work.
fn read_checked(path: &std::path::Path) -> Result<GrayImage> {
    let img = read_png(path)?;
    let (w, h) = img.dimensions();
    if w < 16 || h < 16 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(SimError::Image {
            path: path.to_owned(),
            reason: format!("is {w}x{h}: sides must be in [16, {MAX_SIDE}] px"),
        });
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::PinRenderer;
    use crate::sensor::SensorParams;

    fn sim_reference(size: u32) -> GrayImage {
        PinRenderer::new(&SensorParams::default(), size).expect("renderable").render_undeformed()
    }

    #[test]
    fn the_pin_field_of_a_simulated_image_is_centred_on_the_principal_point() {
        let r = PinRenderer::new(&SensorParams::default(), 256).expect("renderable");
        let f = PinField::find(&r.render_undeformed()).expect("field");
        let p = r.camera().principal;
        assert!((f.centre[0] - p[0]).hypot(f.centre[1] - p[1]) < 0.5, "{f:?} vs {p:?}");
        assert_eq!(f.pins, 331);
    }

    #[test]
    fn a_padded_non_square_image_is_cut_back_to_the_square_about_its_pins() {
        let img = sim_reference(128);
        // Put the 128 px image into a 150 x 136 frame at (9, 3).
        let mut wide = GrayImage::new(150, 136);
        image::imageops::replace(&mut wide, &img, 9, 3);
        let field = PinField::find(&wide).expect("field");
        let crop = SquareCrop::about(&field, wide.dimensions());
        assert_eq!(crop.side, 136);
        let cut = crop.apply(wide, std::path::Path::new("x.png")).expect("cut");
        let f = PinField::find(&cut).expect("field");
        let g = PinField::find(&img).expect("field");
        // The same pins, about the middle of the square.
        assert_eq!(f.pins, g.pins);
        assert!((f.centre[0] - 68.0).abs() <= 1.0 && (f.centre[1] - 68.0).abs() <= 1.0, "{f:?}");
    }

    #[test]
    fn an_image_of_another_size_is_refused_with_its_path() {
        let crop = SquareCrop::identity(64);
        let e = crop.apply(GrayImage::new(64, 60), std::path::Path::new("odd.png")).expect_err("size");
        assert!(e.to_string().contains("odd.png") && e.to_string().contains("64x60"), "{e}");
    }
}
