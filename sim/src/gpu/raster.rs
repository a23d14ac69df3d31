//! The batched GPU raster (feature `wgpu`): the binary pin images of many samples in one
//! dispatch, by the rule of the CPU's [`crate::raster::draw_binary`] (a pixel is white when
//! some disc covers at least half of it, exact area; `gpu_raster.wgsl` is the same code in
//! WGSL, in f32 where the CPU works in f64).
//!
//! The interface is the CPU path's: discs in, `size x size` binary images out, one per sample
//! ([`GpuRaster::draw_binary_batch`] against `draw_binary` per image); the framing (rim ring,
//! mask) stays on the CPU ([`crate::PinRenderer::render_batch`]). On a machine without a GPU
//! the adapter is a software Vulkan driver (lavapipe), which the parity tests use: its speed
//! says nothing of a GPU's.
//!
//! f32 against f64: a pixel's decision can differ only where its coverage lies within f32
//! rounding (about 1e-6 of a pixel) of 1/2, or its centre within that of the band's edges
//! (where the exact area decides either way alike); the parity test counts such pixels.

use std::sync::mpsc;

use image::GrayImage;
use wgpu::util::DeviceExt;

use crate::camera::Disc;
use crate::error::{Result, SimError};

/// Largest output of one dispatch (bytes): batches are split below it.
const MAX_OUTPUT_BYTES: u64 = 64 << 20;

/// A GPU device with the raster pipeline.
#[derive(Debug)]
pub struct GpuRaster {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    adapter: String,
}

impl GpuRaster {
    /// The first GPU adapter wgpu finds (a software one, such as lavapipe, included) with the
    /// raster pipeline; an error that says so where there is none.
    pub fn new() -> Result<Self> {
        let instance = wgpu::Instance::default();
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| SimError::Gpu(format!("no GPU adapter ({e}); on a machine without a GPU install a software Vulkan driver (Debian: mesa-vulkan-drivers) or use --device cpu")))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(
            adapter.request_device(&wgpu::DeviceDescriptor { label: Some("tacsim raster"), ..Default::default() }),
        )
        .map_err(|e| SimError::Gpu(format!("the GPU adapter {} refused a device: {e}", info.name)))?;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gpu_raster.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("gpu_raster.wgsl").into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("raster"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let layout = pipeline.get_bind_group_layout(0);
        Ok(Self {
            device,
            queue,
            pipeline,
            layout,
            adapter: format!("{} ({:?}, {:?})", info.name, info.device_type, info.backend),
        })
    }

    /// The adapter's name, type and backend (for reports: a CPU-type adapter is software).
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// The binary images of `batch` (each a sample's discs, px) at `size x size`: the same rule
    /// as [`crate::raster::draw_binary`] on each.
    pub fn draw_binary_batch(&self, batch: &[Vec<Disc>], size: u32) -> Result<Vec<GrayImage>> {
        let per_image = 4 * u64::from(size) * u64::from(size);
        let chunk = ((MAX_OUTPUT_BYTES / per_image.max(1)).max(1) as usize).min(65_535);
        let mut out = Vec::with_capacity(batch.len());
        for part in batch.chunks(chunk.max(1)) {
            out.extend(self.dispatch(part, size)?);
        }
        Ok(out)
    }

    /// One dispatch over `batch`.
    fn dispatch(&self, batch: &[Vec<Disc>], size: u32) -> Result<Vec<GrayImage>> {
        if batch.is_empty() || size == 0 {
            return Ok(batch.iter().map(|_| GrayImage::new(size, size)).collect());
        }
        let mut discs: Vec<[f32; 4]> = Vec::new();
        let mut ranges: Vec<[u32; 2]> = Vec::with_capacity(batch.len());
        for sample in batch {
            let first = discs.len() as u32;
            // The CPU path skips these too.
            discs.extend(
                sample
                    .iter()
                    .filter(|d| d.r > 0.0 && d.u.is_finite() && d.v.is_finite() && d.r.is_finite())
                    .map(|d| [d.u as f32, d.v as f32, d.r as f32, 0.0]),
            );
            ranges.push([first, discs.len() as u32 - first]);
        }
        if discs.is_empty() {
            discs.push([0.0; 4]);
        }
        let images = batch.len() as u32;
        let params = [size, images, 0, 0];
        let init = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage,
            })
        };
        let params = init("params", bytemuck::cast_slice(&params), wgpu::BufferUsages::UNIFORM);
        let discs = init("discs", bytemuck::cast_slice(&discs), wgpu::BufferUsages::STORAGE);
        let ranges = init("ranges", bytemuck::cast_slice(&ranges), wgpu::BufferUsages::STORAGE);
        let bytes = 4 * u64::from(size) * u64::from(size) * u64::from(images);
        let pixels = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pixels"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raster"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: discs.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: ranges.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: pixels.as_entire_binding() },
            ],
        });
        let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("raster") });
        {
            let mut pass = encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("raster"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(size.div_ceil(8), size.div_ceil(8), images);
        }
        encoder.copy_buffer_to_buffer(&pixels, 0, &readback, 0, bytes);
        self.queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        let (tx, rx) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| SimError::Gpu(format!("waiting for the raster: {e}")))?;
        rx.recv()
            .map_err(|e| SimError::Gpu(format!("the raster's readback was dropped: {e}")))?
            .map_err(|e| SimError::Gpu(format!("reading the raster back: {e}")))?;
        let data = slice.get_mapped_range().map_err(|e| SimError::Gpu(format!("reading the raster back: {e}")))?;
        let n = (size * size) as usize;
        let images = data
            .chunks_exact(4 * n)
            .map(|img| {
                let px: Vec<u8> = img.chunks_exact(4).map(|w| w[0]).collect();
                GrayImage::from_raw(size, size, px).unwrap_or_else(|| GrayImage::new(size, size))
            })
            .collect();
        drop(data);
        readback.unmap();
        Ok(images)
    }
}

/// The GPU for a test, or `None` with a message where there is none (a machine without a GPU
/// or a software Vulkan driver); with `TACSIM_REQUIRE_GPU=1` (as `.ci/run` sets) a missing
/// adapter fails instead.
#[doc(hidden)]
pub fn for_tests() -> Option<GpuRaster> {
    match GpuRaster::new() {
        Ok(gpu) => {
            eprintln!("GPU adapter: {}", gpu.adapter());
            Some(gpu)
        }
        Err(e) if std::env::var("TACSIM_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
            panic!("TACSIM_REQUIRE_GPU=1 but {e}")
        }
        Err(e) => {
            eprintln!("skipped: {e}");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{draw_binary, pixel_coverage};

    /// The sweep of `raster.rs`'s `binary_equals_thresholded_exact_coverage` (sub-pixel
    /// centres, radii 0.3 to 25 px, discs clipped by the border), 3,000 one-disc images in one
    /// batch, plus 40 images of 300 overlapping discs: every pixel as the CPU draws it, except
    /// where the exact coverage lies within 5e-4 of 1/2. Why: f32 against f64, and the area of a
    /// disc's slice is a difference of antiderivatives of size `pi r^2 / 4` (490 px^2 at
    /// 25 px), each rounded to about 6e-8 of that (measured: up to 1.3e-4 at 21.6 px). The
    /// sensor's pins (1-5 px) keep that near 1e-6: `sim/tests/gpu.rs` finds no pixel apart.
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
        let images = gpu.draw_binary_batch(&batch, size).expect("dispatch");
        assert_eq!(images.len(), batch.len());
        let (mut differ, mut borderline, mut worst) = (0, 0, 0.0f64);
        let mut cpu = GrayImage::new(1, 1);
        for (discs, got) in batch.iter().zip(&images) {
            draw_binary(discs, size, &mut cpu);
            for (k, (a, b)) in cpu.as_raw().iter().zip(got.as_raw()).enumerate() {
                if a == b {
                    continue;
                }
                differ += 1;
                let (x, y) = ((k % size as usize) as u32, (k / size as usize) as u32);
                let nearest = discs.iter().map(|d| (pixel_coverage(d, x, y) - 0.5).abs()).fold(f64::INFINITY, f64::min);
                worst = worst.max(nearest);
                if nearest < 5e-4 {
                    borderline += 1;
                } else {
                    panic!("pixel ({x}, {y}) of {discs:?}: CPU {a}, GPU {b}, coverage off 1/2 by {nearest:.2e}");
                }
            }
        }
        println!(
            "{differ} of {} pixels differ ({borderline} within 5e-4 of half coverage, the farthest {worst:.2e})",
            images.len() * 4096
        );
    }
}
