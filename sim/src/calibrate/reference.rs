//! The undeformed reference of a lab folder, and the square framing of its images.
//!
//! Calibration measures every recording's pin motion from an undeformed layout. Few lab
//! folders hold an image of the sensor touching nothing, so where none is named the
//! reference is the **consensus** of the most alike shallow recordings: among the shallowest
//! half (smallest depth label, `pose z`, mm), the one whose [`CONSENSUS_MIN`]-th nearest
//! neighbour (pixels that differ) is nearest, and the pixel-wise majority of it and those
//! neighbours ([`Reference::consensus`]). Taps that touch nothing are alike whatever their yaw
//! and lateral offset, so where a folder holds some they are the tightest group: on the edge
//! taps (1,500, no undeformed image) the group is 30 taps 4.4-6 mm beside the edge (their
//! images differ from each other in 0.8% of the pin field's pixels), where the 75 shallowest, which an
//! earlier rule took, had pressed the material and moved the central pins by up to 0.4 px
//! (`docs/guide/sim2real.md`). Where every recording presses, the tightest group is of the
//! shallowest flat presses. Presses that all touch the same pins do not suit it: on the
//! surface recordings, whose undeformed `image_0.png` tells the truth, the consensus of 600
//! flat presses still finds most pins, but its central pins are smeared and the ring fit
//! cannot read it (`tests/calibrate.rs`). Name an undeformed image where one exists.
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
/// Which recordings a consensus reference is the majority of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ConsensusRule {
    /// The [`CONSENSUS_MIN`] most alike of the shallowest half ([`Reference::consensus`]):
    /// taps that touch nothing, where the folder holds some.
    #[default]
    Alike,
    /// The shallowest 5% (at least [`CONSENSUS_MIN`]), whatever they touch: the rule before
    /// `Alike`. On the edge taps those press the material, so the layout is a pressed one.
    Shallowest,
}

impl ConsensusRule {
    /// The recordings a consensus of `n` by this rule takes, in words.
    pub fn describe(self, n: usize) -> String {
        match self {
            Self::Alike => format!("{n} most alike shallow recordings"),
            Self::Shallowest => format!("{n} shallowest recordings"),
        }
    }
}

impl std::str::FromStr for ConsensusRule {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "alike" => Ok(Self::Alike),
            "shallowest" => Ok(Self::Shallowest),
            _ => Err(format!("unknown consensus rule `{s}`: accepted `alike`, `shallowest`")),
        }
    }
}

/// How many recordings a consensus reference is built from (or all, when fewer).
pub const CONSENSUS_MIN: usize = 30;
/// Most recordings a consensus reference is chosen among (the shallowest).
pub const CONSENSUS_POOL: usize = 600;
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
        tacsim_data::check_lab_image_alike(path, img.dimensions(), self.source, "the reference")?;
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
    /// The consensus of these recordings (image names) by this rule.
    Consensus(ConsensusRule, Vec<String>),
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
    /// `image_0.png` where it exists, else the consensus of the recordings by `rule`.
    pub fn of(folder: &LabFolder, name: Option<&str>, rule: ConsensusRule) -> Result<Self> {
        let default = folder.dir.join("images").join(DEFAULT_REFERENCE);
        match name {
            Some(n) => Self::image(folder, n),
            None if default.is_file() => Self::image(folder, DEFAULT_REFERENCE),
            None => Self::consensus(folder, rule),
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

    /// The pixel-wise majority of the most alike shallow recordings: of the shallowest half
    /// (smallest `pose z`; ties by image name; at least [`CONSENSUS_MIN`], at most
    /// [`CONSENSUS_POOL`]), the recording whose [`CONSENSUS_MIN`]-th nearest other (pixels
    /// that differ) is nearest, with those nearest others ([`CONSENSUS_MIN`] recordings in all, or every one when fewer). Ties go
    /// to the shallower recording, so the choice does not depend on the order of the rows.
    /// With [`ConsensusRule::Shallowest`], the majority of the shallowest 5% (at least
    /// [`CONSENSUS_MIN`]).
    pub fn consensus(folder: &LabFolder, rule: ConsensusRule) -> Result<Self> {
        let mut order: Vec<&LabSample> = folder.samples.iter().collect();
        order.sort_by(|a, b| a.pose[2].total_cmp(&b.pose[2]).then_with(|| a.image.cmp(&b.image)));
        let n = order.len();
        order.truncate(match rule {
            ConsensusRule::Alike => (n / 2).clamp(CONSENSUS_MIN, CONSENSUS_POOL).min(n),
            ConsensusRule::Shallowest => (n / 20).max(CONSENSUS_MIN).min(n),
        });
        let first = folder.image_path(order[0]);
        let mut size = None;
        let mut bits: Vec<Vec<u64>> = Vec::with_capacity(order.len());
        for s in &order {
            let path = folder.image_path(s);
            let img = read_checked(&path)?;
            let expected = *size.get_or_insert(img.dimensions());
            tacsim_data::check_lab_image_alike(&path, img.dimensions(), expected, &first.display().to_string())?;
            bits.push(packed(&img));
        }
        let (w, h) = size.unwrap_or((0, 0));
        let group = match rule {
            ConsensusRule::Alike => tightest_group(&bits, CONSENSUS_MIN),
            ConsensusRule::Shallowest => (0..bits.len()).collect(),
        };
        let n = group.len();
        let raw = GrayImage::from_fn(w, h, |x, y| {
            let i = (y * w + x) as usize;
            let votes = group.iter().filter(|&&g| bits[g][i / 64] >> (i % 64) & 1 == 1).count();
            image::Luma([if 2 * votes > n { 255 } else { 0 }])
        });
        let names = group.iter().map(|&g| order[g].image.clone()).collect();
        Self::framed(raw, &folder.dir.join("images"), ReferenceSource::Consensus(rule, names))
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
            ReferenceSource::Consensus(..) => None,
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
            ReferenceSource::Consensus(rule, names) => {
                format!("consensus (pixel-wise majority) of the {}{framing}", rule.describe(names.len()))
            }
        }
    }

    /// Reads one recording's image, cut as the reference.
    pub fn read(&self, path: &std::path::Path) -> Result<GrayImage> {
        self.crop.apply(read_checked(path)?, path)
    }
}

/// An image's pixels as bits (on: grey >= 128), row-major, 64 to a word.
fn packed(img: &GrayImage) -> Vec<u64> {
    let mut bits = vec![0u64; img.as_raw().len().div_ceil(64)];
    for (i, &p) in img.as_raw().iter().enumerate() {
        bits[i / 64] |= u64::from(p >= 128) << (i % 64);
    }
    bits
}

/// The tightest group of `k` among `images` (bit-packed, in order of preference): the image
/// whose `k - 1`-th nearest other (pixels that differ) is nearest, and those nearest others
/// (nearer first, ties by index). Every image when there are `k` or fewer.
fn tightest_group(images: &[Vec<u64>], k: usize) -> Vec<usize> {
    let n = images.len();
    if n <= k {
        return (0..n).collect();
    }
    let differ = |a: &[u64], b: &[u64]| a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones()).sum::<u32>();
    let mut table = vec![0u32; n * n];
    for i in 0..n {
        for j in i + 1..n {
            let d = differ(&images[i], &images[j]);
            table[i * n + j] = d;
            table[j * n + i] = d;
        }
    }
    let nearest = |i: usize| {
        let mut d: Vec<(u32, usize)> = (0..n).filter(|&j| j != i).map(|j| (table[i * n + j], j)).collect();
        d.sort_unstable();
        d.truncate(k - 1);
        d
    };
    let (best, others) = (0..n)
        .map(|i| (i, nearest(i)))
        .min_by_key(|(i, d)| (d.last().map_or(0, |l| l.0), *i))
        .unwrap_or((0, Vec::new()));
    std::iter::once(best).chain(others.into_iter().map(|(_, j)| j)).collect()
}

/// Reads a PNG, refusing absurd sizes before any work.
fn read_checked(path: &std::path::Path) -> Result<GrayImage> {
    let img = read_png(path)?;
    let (w, h) = img.dimensions();
    tacsim_data::check_lab_image_size(path, w, h)?;
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::PinRenderer;
    use crate::sensor::SensorParams;

    fn sim_reference(size: u32) -> GrayImage {
        PinRenderer::new(&SensorParams::half_space(), size).expect("renderable").render_undeformed()
    }

    #[test]
    fn the_pin_field_of_a_simulated_image_is_centred_on_the_principal_point() {
        let r = PinRenderer::new(&SensorParams::half_space(), 256).expect("renderable");
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
    fn the_consensus_takes_the_alike_untouched_images_not_the_shallowest_pressed_ones() {
        // Twelve images that differ from each other in a few pixels each (touching nothing,
        // thresholding noise) and twenty that differ in many, each its own way (presses at
        // other places), listed first as the shallower ones are.
        let base: Vec<u64> = (0..64u64).map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15)).collect();
        let with = |flips: &[usize]| {
            let mut b = base.clone();
            for &f in flips {
                b[f / 64] ^= 1 << (f % 64);
            }
            b
        };
        let mut images: Vec<Vec<u64>> =
            (0..20).map(|i| with(&(0..200).map(|j| (i * 97 + j * 13) % 4096).collect::<Vec<_>>())).collect();
        images.extend((0..12).map(|i| with(&[i * 7, 1000 + i])));
        let group = tightest_group(&images, 10);
        assert_eq!(group.len(), 10);
        assert!(group.iter().all(|&g| g >= 20), "{group:?}");
        // With as many images as the group takes, every one is in it.
        assert_eq!(tightest_group(&images[..5], 10), vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn an_image_of_another_size_is_refused_with_its_path() {
        let crop = SquareCrop::identity(64);
        let e = crop.apply(GrayImage::new(64, 60), std::path::Path::new("odd.png")).expect_err("size");
        assert!(e.to_string().contains("odd.png") && e.to_string().contains("64x60"), "{e}");
    }
}
