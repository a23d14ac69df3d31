//! Pin detection in binary images: 8-connected components of white pixels, with centroid and
//! area; pin centres; and which sensor pin a detected one is (through the camera). Used by
//! calibration, real-data checks and the closed loop's image-based perception.

use image::{GrayImage, Luma};
use imageproc::region_labelling::{Connectivity, connected_components};

use crate::pins::PinPose;
use crate::render::PinRenderer;

/// One connected white region.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blob {
    /// Centroid `[u, v]` in continuous pixel coordinates (pixel `(i, j)` has centre
    /// `(i + 0.5, j + 0.5)`).
    pub centroid: [f64; 2],
    /// Area (px).
    pub area: u32,
    /// Bounding box `[x0, y0, x1, y1]` (inclusive pixel indices).
    pub bbox: [u32; 4],
}

impl Blob {
    /// Whether the blob touches the image border (a clipped pin).
    pub fn touches_border(&self, width: u32, height: u32) -> bool {
        self.bbox[0] == 0 || self.bbox[1] == 0 || self.bbox[2] + 1 == width || self.bbox[3] + 1 == height
    }
}

/// All 8-connected components of pixels >= 128, in raster order of their first pixel.
pub fn detect_blobs(img: &GrayImage) -> Vec<Blob> {
    let mut bin = img.clone();
    for p in bin.pixels_mut() {
        p.0[0] = if p.0[0] >= 128 { 255 } else { 0 };
    }
    let labels = connected_components(&bin, Connectivity::Eight, Luma([0u8]));
    let n = labels.pixels().map(|p| p.0[0]).max().unwrap_or(0) as usize;
    let mut acc = vec![(0.0f64, 0.0f64, 0u32, [u32::MAX, u32::MAX, 0u32, 0u32]); n];
    for (x, y, p) in labels.enumerate_pixels() {
        let l = p.0[0] as usize;
        if l == 0 {
            continue;
        }
        let a = &mut acc[l - 1];
        a.0 += x as f64 + 0.5;
        a.1 += y as f64 + 0.5;
        a.2 += 1;
        a.3 = [a.3[0].min(x), a.3[1].min(y), a.3[2].max(x), a.3[3].max(y)];
    }
    acc.into_iter()
        .filter(|a| a.2 > 0)
        .map(|(sx, sy, area, bbox)| Blob { centroid: [sx / area as f64, sy / area as f64], area, bbox })
        .collect()
}

/// Blobs whose area lies in `[min_area, max_area]` (px): pins, without specks and merged
/// clutter.
pub fn detect_pins(img: &GrayImage, min_area: u32, max_area: u32) -> Vec<Blob> {
    detect_blobs(img).into_iter().filter(|b| b.area >= min_area && b.area <= max_area).collect()
}

/// Pin blobs in a processed 420 px image are about 115 px; these bounds reject specks and
/// merged rim clutter.
pub const PIN_AREA_RANGE_PX420: (f64, f64) = (0.4 * 117.0, 2.0 * 117.0);

/// [`PIN_AREA_RANGE_PX420`] scaled to a `size` px image: `(min, max)` blob area (px) of a pin.
pub fn pin_area_range(size: u32) -> (u32, u32) {
    let k = (size as f64 / 420.0).powi(2);
    ((PIN_AREA_RANGE_PX420.0 * k).floor().max(1.0) as u32, (PIN_AREA_RANGE_PX420.1 * k).ceil() as u32)
}

/// Pin centres of a binary image (px): its blobs of a pin's area (`pin_area_range`: about a pin's size at this image size).
pub fn pin_centres(img: &GrayImage) -> Vec<[f64; 2]> {
    let (lo, hi) = pin_area_range(img.width());
    detect_pins(img, lo, hi).iter().map(|b| b.centroid).collect()
}

/// Image positions (px) of the pin tips of `pins` as `renderer`'s camera sees them, with each
/// layout pin's image offset (`pins.image_offsets`) when `pins` are the layout's (`None`
/// where a tip leaves the view).
pub fn tip_pixels(renderer: &PinRenderer, pins: &[PinPose]) -> Vec<Option<[f64; 2]>> {
    pins.iter()
        .enumerate()
        .map(|(i, p)| {
            let t = renderer.camera().project(&p.tip)?;
            Some(match renderer.image_offset(i, pins.len()) {
                Some(o) => [t[0] + o[0], t[1] + o[1]],
                None => t,
            })
        })
        .collect()
}

/// For each real reference pin, the sensor pin whose undeformed image lies nearest, within
/// `radius` px (the camera fit puts them within a pixel).
pub fn match_reference(
    renderer: &PinRenderer,
    layout_pins: &[PinPose],
    reference: &[[f64; 2]],
    radius: f64,
) -> Vec<Option<usize>> {
    let sim = tip_pixels(renderer, layout_pins);
    reference
        .iter()
        .map(|r| {
            sim.iter()
                .enumerate()
                .filter_map(|(i, p)| p.map(|p| (i, (p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2))))
                .filter(|(_, d2)| *d2 <= radius * radius)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(i, _)| i)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_separate_squares_with_exact_centroids() {
        let mut img = GrayImage::new(20, 10);
        for (x0, y0, s) in [(1u32, 1u32, 3u32), (10, 4, 4)] {
            for y in y0..y0 + s {
                for x in x0..x0 + s {
                    img.put_pixel(x, y, Luma([255]));
                }
            }
        }
        let blobs = detect_blobs(&img);
        assert_eq!(blobs.len(), 2);
        assert_eq!(blobs[0].area, 9);
        assert_eq!(blobs[0].centroid, [2.5, 2.5]);
        assert_eq!(blobs[1].area, 16);
        assert_eq!(blobs[1].centroid, [12.0, 6.0]);
        assert_eq!(detect_pins(&img, 10, 100).len(), 1);
    }

    #[test]
    fn diagonal_neighbours_are_one_blob() {
        let mut img = GrayImage::new(4, 4);
        img.put_pixel(1, 1, Luma([255]));
        img.put_pixel(2, 2, Luma([255]));
        assert_eq!(detect_blobs(&img).len(), 1);
    }
}
