//! Images held in memory at the networks' size, and batches made from them.
//!
//! Pixels are 8-bit grey scaled to `[0, 1]` when batched (the paper scales its binary images
//! to `[0, 1]`). Images of another size are preprocessed as the lab does: an optional crop,
//! an area-weighted resize to the network side, then an optional threshold back to binary.

use burn::tensor::{Device, Tensor, TensorData};
use image::GrayImage;
use image::imageops::FilterType;
use rayon::prelude::*;

use crate::error::{ModelError, Result};

/// The lab's preprocessing of a camera image before it reaches a network.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Preprocess {
    /// Crop `[left, top, width, height]` (px of the source image) before resizing.
    pub crop: Option<[u32; 4]>,
    /// Side of the square network input (px).
    pub side: u32,
    /// Threshold (0-255) applied after resizing; `None` keeps the resized grey levels.
    pub threshold: Option<u8>,
}

impl Preprocess {
    /// Resize only: an area-weighted average, kept grey (at 64 px a 331-pin image has pins
    /// under 2 px apart, and thresholding would merge them).
    pub fn resize(side: u32) -> Self {
        Self { crop: None, side, threshold: None }
    }

    /// Applies the crop, resize and threshold to one image. Images already at the side with no
    /// crop pass through unchanged.
    pub fn apply(&self, img: &GrayImage, name: &str) -> Result<GrayImage> {
        let cropped = match self.crop {
            Some([x, y, w, h]) => {
                if w == 0 || h == 0 || x + w > img.width() || y + h > img.height() {
                    return Err(ModelError::config(
                        "crop",
                        format!(
                            "[{x}, {y}, {w}, {h}] does not fit {name} ({}x{} px): give left, top, width, height inside the image",
                            img.width(),
                            img.height()
                        ),
                    ));
                }
                image::imageops::crop_imm(img, x, y, w, h).to_image()
            }
            None => img.clone(),
        };
        if cropped.width() == self.side && cropped.height() == self.side {
            return Ok(cropped);
        }
        let mut out = image::imageops::resize(&cropped, self.side, self.side, FilterType::Triangle);
        if let Some(t) = self.threshold {
            for p in out.pixels_mut() {
                p.0[0] = if p.0[0] >= t { 255 } else { 0 };
            }
        }
        Ok(out)
    }
}

/// A set of square 8-bit images of one side, addressed by slot.
#[derive(Clone, Debug)]
pub struct ImageSet {
    side: usize,
    pixels: Vec<u8>,
}

impl ImageSet {
    /// Loads images with `load(k)` for `k in 0..count` (in parallel), preprocessed to `pre`.
    pub fn load<F>(count: usize, pre: &Preprocess, load: F) -> Result<Self>
    where
        F: Fn(usize) -> Result<(GrayImage, String)> + Sync,
    {
        let side = pre.side as usize;
        let images: Vec<Vec<u8>> = (0..count)
            .into_par_iter()
            .map(|k| {
                let (img, name) = load(k)?;
                Ok(pre.apply(&img, &name)?.into_raw())
            })
            .collect::<Result<_>>()?;
        let mut pixels = Vec::with_capacity(count * side * side);
        for img in images {
            pixels.extend_from_slice(&img);
        }
        Ok(Self { side, pixels })
    }

    /// A set from raw images, each `side * side` bytes.
    pub fn from_raw(side: usize, images: &[Vec<u8>]) -> Result<Self> {
        let mut pixels = Vec::with_capacity(images.len() * side * side);
        for (k, img) in images.iter().enumerate() {
            if img.len() != side * side {
                return Err(ModelError::config(
                    "images",
                    format!("image {k} has {} bytes, expected {side}x{side}", img.len()),
                ));
            }
            pixels.extend_from_slice(img);
        }
        Ok(Self { side, pixels })
    }

    /// Appends the images of `other` at `slots`, in that order; both sets must have one side.
    pub fn append(&mut self, other: &ImageSet, slots: &[usize]) -> Result<()> {
        if other.side != self.side {
            return Err(ModelError::config(
                "images",
                format!("images of {} px cannot join a set of {} px", other.side, self.side),
            ));
        }
        self.pixels.reserve(slots.len() * self.side * self.side);
        for &slot in slots {
            self.pixels.extend_from_slice(other.image(slot));
        }
        Ok(())
    }

    /// Image side (px).
    pub fn side(&self) -> usize {
        self.side
    }

    /// Number of images.
    pub fn len(&self) -> usize {
        self.pixels.len() / (self.side * self.side).max(1)
    }

    /// True when there are no images.
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The bytes of image `slot`.
    pub fn image(&self, slot: usize) -> &[u8] {
        let n = self.side * self.side;
        &self.pixels[slot * n..(slot + 1) * n]
    }

    /// A `[slots.len(), 1, side, side]` batch in `[0, 1]`, image `k` shifted by `shifts[k]`
    /// (px, right and down; uncovered pixels are 0, the background of binary TacTip images;
    /// images past the end of `shifts` are not shifted).
    pub fn batch(&self, slots: &[usize], shifts: &[(i32, i32)], device: &Device) -> Tensor<4> {
        let s = self.side;
        let mut data = vec![0f32; slots.len() * s * s];
        for (k, &slot) in slots.iter().enumerate() {
            let src = self.image(slot);
            let (dx, dy) = shifts.get(k).copied().unwrap_or((0, 0));
            let dst = &mut data[k * s * s..(k + 1) * s * s];
            shift_into(src, dst, s, dx, dy);
        }
        Tensor::from_data(TensorData::new(data, [slots.len(), 1, s, s]), device)
    }
}

/// Copies `src` (side `s`, bytes) into `dst` (floats in `[0, 1]`) shifted by `(dx, dy)` px.
fn shift_into(src: &[u8], dst: &mut [f32], s: usize, dx: i32, dy: i32) {
    let si = s as i64;
    for y in 0..si {
        let sy = y - dy as i64;
        if !(0..si).contains(&sy) {
            continue;
        }
        for x in 0..si {
            let sx = x - dx as i64;
            if (0..si).contains(&sx) {
                dst[(y * si + x) as usize] = f32::from(src[(sy * si + sx) as usize]) / 255.0;
            }
        }
    }
}

/// Floats of a `[batch, 1, s, s]` tensor, image by image.
pub fn to_images(t: Tensor<4>) -> Vec<Vec<f32>> {
    let [b, _, h, w] = t.dims();
    let data = t.into_data();
    let values: Vec<f32> = data.try_to_vec::<f32>().unwrap_or_default();
    (0..b).map(|k| values[k * h * w..(k + 1) * h * w].to_vec()).collect()
}

/// Images (each `side x side` values in [0, 1], row by row) as one batch tensor
/// `[n, 1, side, side]` on `device`: the networks' input.
pub(crate) fn stack(images: &[Vec<f32>], side: usize, device: &Device) -> Tensor<4> {
    let flat: Vec<f32> = images.iter().flatten().copied().collect();
    Tensor::from_data(TensorData::new(flat, [images.len(), 1, side, side]), device)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shifts_move_pixels_and_fill_with_background() {
        let side = 4;
        let mut img = vec![0u8; 16];
        img[5] = 255; // (x 1, y 1)
        let set = ImageSet::from_raw(side, &[img]).expect("set");
        let b = set.batch(&[0, 0], &[(0, 0), (2, 1)], &Device::flex());
        let imgs = to_images(b);
        assert_eq!(imgs[0][5], 1.0);
        assert_eq!(imgs[1][2 * 4 + 3], 1.0);
        assert_eq!(imgs[1].iter().sum::<f32>(), 1.0);
    }

    #[test]
    fn preprocessing_crops_resizes_and_thresholds() {
        let mut img = GrayImage::new(8, 8);
        for y in 2..6 {
            for x in 2..6 {
                img.put_pixel(x, y, image::Luma([255]));
            }
        }
        let pre = Preprocess { crop: Some([2, 2, 4, 4]), side: 2, threshold: Some(128) };
        let out = pre.apply(&img, "x.png").expect("apply");
        assert_eq!(out.into_raw(), vec![255; 4]);
        let bad = Preprocess { crop: Some([6, 6, 4, 4]), side: 2, threshold: None };
        let err = bad.apply(&img, "x.png").expect_err("crop outside");
        assert!(err.to_string().contains("x.png"), "{err}");
    }
}
