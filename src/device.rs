//! `--device cpu|gpu|auto` of `tacsim generate` and `tacsim bench`: where the pin images are
//! rasterised. `gpu` is the batched GPU raster of the simulator crate (feature `wgpu`:
//! `cargo build --release --features wgpu`); on a machine without a GPU adapter it stops with
//! a message, and only `auto` falls back to the CPU. The contact solve and the pins stay on the
//! CPU threads either way.

use anyhow::Result;

/// Where the images are rasterised.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum DeviceChoice {
    /// The CPU, image by image on the worker threads (the default).
    #[default]
    Cpu,
    /// The GPU, in batches; an error where there is none.
    Gpu,
    /// The GPU where there is one, else the CPU (said on stderr).
    Auto,
}

/// The GPU raster `choice` asks for: `None` for the CPU; checked before any work starts.
#[cfg(feature = "wgpu")]
pub fn gpu_raster(choice: DeviceChoice) -> Result<Option<tacsim_sim::GpuRaster>> {
    match choice {
        DeviceChoice::Cpu => Ok(None),
        DeviceChoice::Gpu => Ok(Some(tacsim_sim::GpuRaster::new()?)),
        DeviceChoice::Auto => match tacsim_sim::GpuRaster::new() {
            Ok(gpu) => {
                eprintln!("--device auto: rasterising on {}", gpu.adapter());
                Ok(Some(gpu))
            }
            Err(e) => {
                eprintln!("--device auto: {e}; rasterising on the CPU");
                Ok(None)
            }
        },
    }
}

/// Without the GPU path: `gpu` is an error that says how to build it, `auto` the CPU.
#[cfg(not(feature = "wgpu"))]
pub fn check(choice: DeviceChoice) -> Result<()> {
    match choice {
        DeviceChoice::Cpu => Ok(()),
        DeviceChoice::Gpu => anyhow::bail!(
            "--device gpu: this tacsim was built without the GPU path; rebuild with `cargo build --release --features wgpu`"
        ),
        DeviceChoice::Auto => {
            eprintln!(
                "--device auto: this tacsim was built without the GPU path (feature wgpu); rasterising on the CPU"
            );
            Ok(())
        }
    }
}
