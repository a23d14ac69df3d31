//! Pin detection in binary images: 8-connected components of white pixels, with centroid and
//! area. Used for calibration, real-data checks and (later) Voronoi contact geometry.

use image::{GrayImage, Luma};
use imageproc::region_labelling::{Connectivity, connected_components};

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
