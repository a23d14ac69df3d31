//! `--device cpu|gpu|auto` of `tacsim generate` and `tacsim bench`: where the pins are moved
//! and the pin images rasterised. `gpu` is the batched GPU path of the simulator crate
//! (feature `wgpu`: `cargo build --release --features wgpu`): the pin product (where the
//! adapter has f64 in shaders; else the pins stay on the CPU, said on stderr) and the raster;
//! on a machine without a GPU adapter it stops with a message, and only `auto` falls back to
//! the CPU. The contact solve stays on the CPU threads either way.

use anyhow::Result;

/// Where the pins are moved and the images rasterised.
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

/// The GPU `choice` asks for: `None` for the CPU; checked before any work starts.
#[cfg(feature = "wgpu")]
pub fn gpu(choice: DeviceChoice) -> Result<Option<tacsim_sim::Gpu>> {
    let said = |gpu: tacsim_sim::Gpu| {
        if !gpu.has_pins() {
            eprintln!(
                "--device {}: {} has no f64 in shaders (SHADER_F64); the pins are moved on the CPU, the images \
                 rasterised on the GPU",
                if choice == DeviceChoice::Gpu { "gpu" } else { "auto" },
                gpu.adapter()
            );
        }
        gpu
    };
    match choice {
        DeviceChoice::Cpu => Ok(None),
        DeviceChoice::Gpu => Ok(Some(said(tacsim_sim::Gpu::new()?))),
        DeviceChoice::Auto => match tacsim_sim::Gpu::new() {
            Ok(gpu) => {
                eprintln!("--device auto: on {}", gpu.adapter());
                Ok(Some(said(gpu)))
            }
            Err(e) => {
                eprintln!("--device auto: {e}; on the CPU");
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
            eprintln!("--device auto: this tacsim was built without the GPU path (feature wgpu); on the CPU");
            Ok(())
        }
    }
}
