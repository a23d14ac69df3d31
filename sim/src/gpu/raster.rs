//! The batched GPU raster: the binary pin images of many samples in one dispatch, by the rule
//! of the CPU's [`crate::raster::draw_binary`] (a pixel is white when some disc covers at
//! least half of it, exact area; `raster.wgsl` is the same code in WGSL, in f32 where the CPU
//! works in f64).
//!
//! The interface is the CPU path's: discs in, `size x size` binary images out, one per sample
//! ([`Gpu::draw_binary_batch`] against `draw_binary` per image); the framing (rim ring, mask)
//! stays on the CPU ([`crate::PinRenderer::render_batch`]).
//!
//! f32 against f64: a pixel's decision can differ only where its coverage lies within f32
//! rounding of 1/2, or its centre within that of the band's edges (where the exact area
//! decides either way alike); the parity test counts such pixels. The disc centres go up as
//! f32 plus the f32 of what that rounding left, so that the pixel's offset from the centre
//! is good to about 1e-7 px (a plain f32 centre at 100 px is off by up to 4e-6 px, and so is
//! the coverage).

use image::GrayImage;

use super::Gpu;
use crate::camera::Disc;
use crate::error::Result;

/// Largest output of one dispatch (bytes): batches are split below it.
const MAX_OUTPUT_BYTES: u64 = 64 << 20;

impl Gpu {
    /// The binary images of `batch` (each a sample's discs, px) at `size x size`: the same rule
    /// as [`crate::raster::draw_binary`] on each.
    pub fn draw_binary_batch(&self, batch: &[Vec<Disc>], size: u32) -> Result<Vec<GrayImage>> {
        self.draw_binary_batch_in(batch, size, self.raster64.is_none())
    }

    /// [`Gpu::draw_binary_batch`], in f32 where `f32_only` though the adapter has f64 (the
    /// parity tests of the f32 raster).
    pub(crate) fn draw_binary_batch_in(
        &self,
        batch: &[Vec<Disc>],
        size: u32,
        f32_only: bool,
    ) -> Result<Vec<GrayImage>> {
        let per_image = 4 * u64::from(size) * u64::from(size);
        let chunk = ((MAX_OUTPUT_BYTES / per_image.max(1)).max(1) as usize).min(65_535);
        let mut out = Vec::with_capacity(batch.len());
        for part in batch.chunks(chunk.max(1)) {
            out.extend(self.raster_dispatch(part, size, f32_only)?);
        }
        Ok(out)
    }

    /// One dispatch over `batch`, in f64 unless `f32_only` or the adapter lacks it.
    fn raster_dispatch(&self, batch: &[Vec<Disc>], size: u32, f32_only: bool) -> Result<Vec<GrayImage>> {
        if batch.is_empty() || size == 0 {
            return Ok(batch.iter().map(|_| GrayImage::new(size, size)).collect());
        }
        let wide = self.raster64.as_ref().filter(|_| !f32_only);
        // Per disc two entries, as `raster.wgsl` reads them.
        let (mut narrow, mut exact): (Vec<[f32; 4]>, Vec<[f64; 4]>) = (Vec::new(), Vec::new());
        let mut ranges: Vec<[u32; 2]> = Vec::with_capacity(batch.len());
        for sample in batch {
            let first = (narrow.len() + exact.len()) as u32 / 2;
            // The CPU path skips these too.
            for d in sample.iter().filter(|d| d.r > 0.0 && d.u.is_finite() && d.v.is_finite() && d.r.is_finite()) {
                if wide.is_some() {
                    exact.extend([[d.u, d.v, d.r, 0.0], [0.0; 4]]);
                } else {
                    let (u, v) = (d.u as f32, d.v as f32);
                    narrow.extend([
                        [u, v, d.r as f32, 0.0],
                        [(d.u - f64::from(u)) as f32, (d.v - f64::from(v)) as f32, 0.0, 0.0],
                    ]);
                }
            }
            ranges.push([first, (narrow.len() + exact.len()) as u32 / 2 - first]);
        }
        narrow.extend([[0.0; 4]; 2]);
        exact.extend([[0.0; 4]; 2]);
        let discs: &[u8] = if wide.is_some() { bytemuck::cast_slice(&exact) } else { bytemuck::cast_slice(&narrow) };
        let images = batch.len() as u32;
        let params = [size, images, 0, 0];
        let bytes = 4 * u64::from(size) * u64::from(size) * u64::from(images);
        let data = self.dispatch(
            wide.unwrap_or(&self.raster),
            bytemuck::cast_slice(&params),
            &[discs, bytemuck::cast_slice(&ranges)],
            bytes,
            [size.div_ceil(8), size.div_ceil(8), images],
        )?;
        let n = (size * size) as usize;
        Ok(data
            .chunks_exact(4 * n)
            .map(|img| {
                let px: Vec<u8> = img.chunks_exact(4).map(|w| w[0]).collect();
                GrayImage::from_raw(size, size, px).unwrap_or_else(|| GrayImage::new(size, size))
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::for_tests;
    use crate::raster::{draw_binary, pixel_coverage};

    /// The sweep of `raster.rs`'s `binary_equals_thresholded_exact_coverage` (sub-pixel
    /// centres, radii 0.3 to 25 px, discs clipped by the border), 3,000 one-disc images in one
    /// batch, plus 40 images of 300 overlapping discs: every pixel as the CPU draws it, except
    /// where the exact coverage lies within a bound of 1/2.
    ///
    /// In f64 (adapters with SHADER_F64, lavapipe's included) the bound is 1e-9: the CPU's
    /// arithmetic but for the last bits. In f32 it is 1e-2, for two reasons: the area of a
    /// disc's slice is a difference of antiderivatives of size `pi r^2 / 4` (490 px^2 at
    /// 25 px), each rounded to about 6e-8 of that, and where a pixel's edge meets the circle
    /// near its tangent point `sqrt(r^2 - b^2)` cancels. Measured on lavapipe: up to 1.3e-4;
    /// on an NVIDIA H100, whose f32 arithmetic (fused, approximate division and square root)
    /// is not lavapipe's, up to the figure in `docs/guide/gpu.md`.
    #[test]
    fn gpu_raster_draws_what_the_cpu_draws() {
        let Some(gpu) = for_tests() else { return };
        let size = 64;
        let mut batch: Vec<Vec<Disc>> = (0..3000)
            .map(|i| {
                let t = i as f64;
                let r = 0.3 + (t * 0.0371) % 25.0;
                vec![Disc { u: 32.0 + (t * 0.618).fract() * (1.0 + r), v: 32.0 + (t * 0.414).fract() * 40.0 - 20.0, r }]
            })
            .collect();
        batch.extend((0..40).map(|i| {
            (0..300)
                .map(|k| {
                    let t = (i * 300 + k) as f64;
                    Disc {
                        u: (t * 0.7548).fract() * 70.0 - 3.0,
                        v: (t * 0.5698).fract() * 70.0 - 3.0,
                        r: 0.5 + (t * 0.31).fract() * 3.0,
                    }
                })
                .collect()
        }));
        let mut precisions = vec![(true, 1e-2)];
        if gpu.has_pins() {
            precisions.insert(0, (false, 1e-9));
        }
        for (f32_only, bound) in precisions {
            let images = gpu.draw_binary_batch_in(&batch, size, f32_only).expect("dispatch");
            assert_eq!(images.len(), batch.len());
            let (mut differ, mut worst) = (0, 0.0f64);
            let mut cpu = GrayImage::new(1, 1);
            for (discs, got) in batch.iter().zip(&images) {
                draw_binary(discs, size, &mut cpu);
                for (k, (a, b)) in cpu.as_raw().iter().zip(got.as_raw()).enumerate() {
                    if a == b {
                        continue;
                    }
                    differ += 1;
                    let (x, y) = ((k % size as usize) as u32, (k / size as usize) as u32);
                    let off = discs.iter().map(|d| (pixel_coverage(d, x, y) - 0.5).abs()).fold(f64::INFINITY, f64::min);
                    worst = worst.max(off);
                    assert!(
                        off < bound,
                        "pixel ({x}, {y}) of {discs:?}: CPU {a}, GPU {b}, coverage off 1/2 by {off:.2e}"
                    );
                }
            }
            println!(
                "{}: {differ} of {} pixels differ, the farthest {worst:.2e} from half coverage (bound {bound:.0e})",
                if f32_only { "f32" } else { "f64" },
                images.len() * 4096
            );
        }
    }
}
