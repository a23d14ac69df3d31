//! PNG input and output. Writes are atomic ([`crate::atomic`]); binary images can be stored
//! as 1-bit PNGs (8x smaller, lossless for 0/255 images).

use std::path::Path;

use image::GrayImage;

use crate::atomic::write_atomic;
use crate::error::{Result, SimError};

/// Bit depth of a written PNG.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PngDepth {
    /// 1 bit per pixel: pixels >= 128 are white. For binary images.
    OneBit,
    /// 8-bit grey.
    Grey8,
}

/// Encodes `img` as PNG bytes.
pub fn encode_png(img: &GrayImage, depth: PngDepth) -> Result<Vec<u8>> {
    let (w, h) = img.dimensions();
    let mut bytes = Vec::new();
    let fail = |e: png::EncodingError| SimError::Image {
        path: "<memory>".into(),
        reason: format!("PNG encoding failed: {e}"),
    };
    {
        let mut enc = png::Encoder::new(&mut bytes, w, h);
        enc.set_color(png::ColorType::Grayscale);
        let data: Vec<u8> = match depth {
            PngDepth::OneBit => {
                enc.set_depth(png::BitDepth::One);
                let row_bytes = (w as usize).div_ceil(8);
                let mut packed = vec![0u8; row_bytes * h as usize];
                for (y, row) in img.as_raw().chunks_exact(w as usize).enumerate() {
                    for (x, &p) in row.iter().enumerate() {
                        if p >= 128 {
                            packed[y * row_bytes + x / 8] |= 0x80 >> (x % 8);
                        }
                    }
                }
                packed
            }
            PngDepth::Grey8 => {
                enc.set_depth(png::BitDepth::Eight);
                img.as_raw().clone()
            }
        };
        // `Fastest`: one fixed filter (`Up`) instead of the adaptive choice per row, which
        // took 4% of a `paper` run (issue 31); the same pixels, files about 3% larger.
        enc.set_compression(png::Compression::Fastest);
        let mut writer = enc.write_header().map_err(fail)?;
        writer.write_image_data(&data).map_err(fail)?;
        writer.finish().map_err(fail)?;
    }
    Ok(bytes)
}

/// Writes `img` to `path` as PNG, atomically.
pub fn write_png(path: &Path, img: &GrayImage, depth: PngDepth) -> Result<()> {
    let bytes = encode_png(img, depth).map_err(|e| match e {
        SimError::Image { reason, .. } => SimError::Image { path: path.to_owned(), reason },
        other => other,
    })?;
    Ok(write_atomic(path, &bytes)?)
}

/// Decodes PNG bytes (any bit depth or colour type) to 8-bit grey.
pub fn decode_png(bytes: &[u8], source_name: &Path) -> Result<GrayImage> {
    image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map(|img| img.to_luma8())
        .map_err(|e| SimError::Image { path: source_name.to_owned(), reason: format!("not a readable PNG: {e}") })
}

/// Reads a PNG file (any bit depth or colour type) as 8-bit grey.
pub fn read_png(path: &Path) -> Result<GrayImage> {
    let bytes = std::fs::read(path).map_err(|e| SimError::io(path, "read", e))?;
    decode_png(&bytes, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_bit_round_trip_is_lossless() {
        let mut img = GrayImage::new(13, 5);
        for (i, p) in img.pixels_mut().enumerate() {
            p.0[0] = if (i * 7) % 3 == 0 { 255 } else { 0 };
        }
        for depth in [PngDepth::OneBit, PngDepth::Grey8] {
            let bytes = encode_png(&img, depth).expect("encode");
            let back = decode_png(&bytes, Path::new("mem")).expect("decode");
            assert_eq!(back.as_raw(), img.as_raw());
        }
    }

    #[test]
    fn garbage_is_a_clear_error() {
        let e = decode_png(b"not a png", Path::new("bad.png")).expect_err("garbage");
        assert!(e.to_string().contains("bad.png"), "{e}");
    }
}
