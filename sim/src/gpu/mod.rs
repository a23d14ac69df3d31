//! The batched GPU path (feature `wgpu`): one device and its compute pipelines, each with the
//! interface of a CPU path it stands in for.
//!
//! - [`Gpu::draw_binary_batch`] (`raster.rs`, `raster.wgsl`): the binary pin images of many
//!   samples in one dispatch, by the rule of [`crate::raster::draw_binary`], in f64 where the
//!   adapter has it (`SHADER_F64`), else in f32.
//! - [`Gpu::pins_batch`] (`pins.rs`, `pins.wgsl`): the pin poses of many contact states from
//!   their tractions (the pin influence product of `contact/pins/motion.rs`), in f64 where
//!   the adapter has it (`SHADER_F64`).
//!
//! On a machine without a GPU the adapter is a software Vulkan driver (lavapipe), which the
//! parity tests use: its speed says nothing of a GPU's.

mod pins;
mod raster;

use std::sync::mpsc;

use wgpu::util::DeviceExt;

use crate::error::{Result, SimError};

/// A GPU device with the simulator's pipelines.
#[derive(Debug)]
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    raster: wgpu::ComputePipeline,
    /// The raster in f64, and the pin product; `None` where the adapter has no f64 in shaders.
    raster64: Option<wgpu::ComputePipeline>,
    pins: Option<wgpu::ComputePipeline>,
    adapter: String,
}

impl Gpu {
    /// The first GPU adapter wgpu finds (a software one, such as lavapipe, included) with the
    /// pipelines; an error that says so where there is none.
    pub fn new() -> Result<Self> {
        let instance = wgpu::Instance::default();
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| SimError::Gpu(format!("no GPU adapter ({e}); on a machine without a GPU install a software Vulkan driver (Debian: mesa-vulkan-drivers) or use --device cpu")))?;
        let info = adapter.get_info();
        let f64_shaders = adapter.features().contains(wgpu::Features::SHADER_F64);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("tacsim"),
            required_features: if f64_shaders { wgpu::Features::SHADER_F64 } else { wgpu::Features::empty() },
            ..Default::default()
        }))
        .map_err(|e| SimError::Gpu(format!("the GPU adapter {} refused a device: {e}", info.name)))?;
        let pipeline = |label: &str, source: &str| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let raster = pipeline("raster.wgsl", include_str!("raster.wgsl"));
        let raster64 =
            f64_shaders.then(|| pipeline("raster.wgsl in f64", &include_str!("raster.wgsl").replace("f32", "f64")));
        let pins = f64_shaders.then(|| pipeline("pins.wgsl", include_str!("pins.wgsl")));
        Ok(Self {
            device,
            queue,
            raster,
            raster64,
            pins,
            adapter: format!("{} ({:?}, {:?})", info.name, info.device_type, info.backend),
        })
    }

    /// The adapter's name, type and backend (for reports: a CPU-type adapter is software).
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// Whether [`Gpu::pins_batch`] runs here and the raster works in f64 (the adapter has f64
    /// in shaders).
    pub fn has_pins(&self) -> bool {
        self.pins.is_some()
    }

    /// One dispatch of `pipeline` over `groups` workgroups: binding 0 the uniform `params`,
    /// then the read-only storage `inputs` in order, then an output of `output_bytes`, which
    /// comes back.
    fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        params: &[u8],
        inputs: &[&[u8]],
        output_bytes: u64,
        groups: [u32; 3],
    ) -> Result<Vec<u8>> {
        let init = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage,
            })
        };
        let mut buffers = vec![init("params", params, wgpu::BufferUsages::UNIFORM)];
        buffers.extend(inputs.iter().map(|b| init("input", b, wgpu::BufferUsages::STORAGE)));
        let output = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("output"),
            size: output_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: output_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        buffers.push(output);
        let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() })
            .collect();
        let layout = pipeline.get_bind_group_layout(0);
        let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &entries,
        });
        let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        }
        let output = buffers.last().expect("the output buffer");
        encoder.copy_buffer_to_buffer(output, 0, &readback, 0, output_bytes);
        self.queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        let (tx, rx) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| SimError::Gpu(format!("waiting for the GPU: {e}")))?;
        rx.recv()
            .map_err(|e| SimError::Gpu(format!("the GPU's readback was dropped: {e}")))?
            .map_err(|e| SimError::Gpu(format!("reading the GPU's output back: {e}")))?;
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| SimError::Gpu(format!("reading the GPU's output back: {e}")))?
            .to_vec();
        readback.unmap();
        Ok(bytes)
    }
}

/// The GPU for a test, or `None` with a message where there is none (a machine without a GPU
/// or a software Vulkan driver); with `TACSIM_REQUIRE_GPU=1` (as `.ci/run` sets) a missing
/// adapter fails instead.
#[doc(hidden)]
pub fn for_tests() -> Option<Gpu> {
    match Gpu::new() {
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
