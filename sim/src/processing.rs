//! The lab's image processing, as applied to real TacTip frames before they are stored
//! (`../shared/data/real-tactip-surface3d/README.md`): grey frame, crop to a bounding box,
//! OpenCV `adaptiveThreshold(MEAN_C, BINARY, block, C)`, then everything outside a centred
//! circle set to black. Sizes are given for the lab's 420 px processed image and scale with
//! [`LabProcessing::for_size`].

use image::GrayImage;

use crate::error::{Result, SimError};

/// Reference size (px) of the lab's processed images, for which the defaults are stated.
pub const LAB_IMAGE_SIZE: u32 = 420;

/// The lab's processing steps.
#[derive(Clone, Debug, PartialEq)]
pub struct LabProcessing {
    /// Crop box `[x0, y0, x1, y1]` (px, end exclusive) applied first; `None` keeps the frame.
    pub crop: Option<[u32; 4]>,
    /// Adaptive threshold block size (px, odd, >= 3).
    pub block: u32,
    /// Adaptive threshold constant C (grey levels): white where `pixel > mean - C`.
    pub c: f64,
    /// Radius of the circular mask (px) around the image centre; `None` disables it.
    pub mask_radius_px: Option<f64>,
}

impl Default for LabProcessing {
    /// The lab's settings (`processed_image_params.json`): block 61, C 5, mask radius 210, on
    /// an already-cropped 420 px image.
    fn default() -> Self {
        Self { crop: None, block: 61, c: 5.0, mask_radius_px: Some(210.0) }
    }
}

impl LabProcessing {
    /// The same processing scaled from the 420 px reference to a `size` px image (block size
    /// kept odd and >= 3).
    pub fn for_size(&self, size: u32) -> Self {
        let k = size as f64 / LAB_IMAGE_SIZE as f64;
        let block = ((self.block as f64 * k / 2.0).round() as u32 * 2 + 1).max(3);
        Self { crop: None, block, c: self.c, mask_radius_px: self.mask_radius_px.map(|r| r * k) }
    }

    /// Applies crop, adaptive threshold and mask.
    pub fn apply(&self, frame: &GrayImage) -> Result<GrayImage> {
        let img = match self.crop {
            Some([x0, y0, x1, y1]) => {
                if !(x0 < x1 && y0 < y1 && x1 <= frame.width() && y1 <= frame.height()) {
                    return Err(SimError::invalid(
                        "lab processing",
                        "crop",
                        format!(
                            "box [{x0}, {y0}, {x1}, {y1}] does not fit a {}x{} frame",
                            frame.width(),
                            frame.height()
                        ),
                    ));
                }
                image::imageops::crop_imm(frame, x0, y0, x1 - x0, y1 - y0).to_image()
            }
            None => frame.clone(),
        };
        if self.block < 3 || self.block.is_multiple_of(2) {
            return Err(SimError::invalid(
                "lab processing",
                "block",
                format!("must be odd and >= 3, got {}", self.block),
            ));
        }
        let mut out = adaptive_threshold_mean(&img, self.block, self.c);
        if let Some(r) = self.mask_radius_px {
            circle_mask(&mut out, r);
        }
        Ok(out)
    }
}

/// OpenCV's `adaptiveThreshold(src, 255, ADAPTIVE_THRESH_MEAN_C, THRESH_BINARY, block, C)`:
/// the local mean is the `block` x `block` box mean with replicated borders, rounded to the
/// nearest integer (ties to even, like `cvRound`), and a pixel is white when
/// `src - mean > -ceil(C)`.
pub fn adaptive_threshold_mean(img: &GrayImage, block: u32, c: f64) -> GrayImage {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let half = (block / 2) as isize;
    let src = img.as_raw();
    // Integral image over the replicate-padded image.
    let pw = w + 2 * half as usize;
    let ph = h + 2 * half as usize;
    let at = |x: isize, y: isize| -> u64 {
        let xi = (x - half).clamp(0, w as isize - 1) as usize;
        let yi = (y - half).clamp(0, h as isize - 1) as usize;
        src[yi * w + xi] as u64
    };
    let mut integral = vec![0u64; (pw + 1) * (ph + 1)];
    for y in 0..ph {
        let mut row = 0u64;
        for x in 0..pw {
            row += at(x as isize, y as isize);
            integral[(y + 1) * (pw + 1) + x + 1] = integral[y * (pw + 1) + x + 1] + row;
        }
    }
    let area = (block * block) as f64;
    let idelta = c.ceil() as i64;
    let b = block as usize;
    let mut out = GrayImage::new(w as u32, h as u32);
    for y in 0..h {
        for x in 0..w {
            // Box [x, x + b) x [y, y + b) in padded coordinates is centred on (x, y).
            let s = integral[(y + b) * (pw + 1) + x + b] + integral[y * (pw + 1) + x]
                - integral[y * (pw + 1) + x + b]
                - integral[(y + b) * (pw + 1) + x];
            let mean = (s as f64 / area).round_ties_even() as i64;
            if src[y * w + x] as i64 - mean > -idelta {
                out.as_mut()[y * w + x] = 255;
            }
        }
    }
    out
}

/// Sets every pixel whose centre lies farther than `radius` px from the image centre to 0.
pub fn circle_mask(img: &mut GrayImage, radius: f64) {
    let (cx, cy) = (img.width() as f64 / 2.0, img.height() as f64 / 2.0);
    for (x, y, p) in img.enumerate_pixels_mut() {
        let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
        if dx * dx + dy * dy > radius * radius {
            p.0[0] = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    #[test]
    fn adaptive_threshold_matches_brute_force() {
        let mut img = GrayImage::new(23, 17);
        for (x, y, p) in img.enumerate_pixels_mut() {
            p.0[0] = ((x * 37 + y * 91 + x * y * 13) % 256) as u8;
        }
        let out = adaptive_threshold_mean(&img, 7, 5.0);
        for y in 0..17i64 {
            for x in 0..23i64 {
                let mut s = 0u64;
                for dy in -3..=3 {
                    for dx in -3..=3 {
                        let (xx, yy) = ((x + dx).clamp(0, 22), (y + dy).clamp(0, 16));
                        s += img.get_pixel(xx as u32, yy as u32).0[0] as u64;
                    }
                }
                let mean = (s as f64 / 49.0).round_ties_even() as i64;
                let expect = img.get_pixel(x as u32, y as u32).0[0] as i64 > mean - 5;
                assert_eq!(out.get_pixel(x as u32, y as u32).0[0] == 255, expect, "({x}, {y})");
            }
        }
    }

    #[test]
    fn mask_and_crop() {
        let mut img = GrayImage::from_pixel(10, 10, Luma([255]));
        circle_mask(&mut img, 3.0);
        assert_eq!(img.get_pixel(0, 0).0[0], 0);
        assert_eq!(img.get_pixel(5, 5).0[0], 255);
        let p = LabProcessing { crop: Some([2, 2, 8, 8]), block: 3, c: 5.0, mask_radius_px: None };
        assert_eq!(p.apply(&img).expect("fits").dimensions(), (6, 6));
        let bad = LabProcessing { crop: Some([2, 2, 80, 8]), ..p };
        assert!(bad.apply(&img).expect_err("too big").to_string().contains("crop"));
    }

    #[test]
    fn scaling_keeps_block_odd() {
        let p = LabProcessing::default().for_size(256);
        assert_eq!(p.block % 2, 1);
        assert!((p.mask_radius_px.expect("mask") - 128.0).abs() < 1e-9);
    }
}
