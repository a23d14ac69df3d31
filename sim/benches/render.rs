//! Renderer throughput (frames/s): project 331 pins and rasterise the binary image, on one
//! thread and on all threads (rayon, one image buffer per worker). Run with
//! `cargo xtask bench` (or `cargo bench -p tacsim-sim --bench render`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use image::GrayImage;
use rayon::prelude::*;
use tacsim_sim::{PinRenderer, SensorParams};

/// Frames per parallel batch.
const BATCH: usize = 512;

fn bench_render(c: &mut Criterion) {
    let sensor = SensorParams::half_space();
    let mut group = c.benchmark_group("render");
    for size in [128u32, 256, 420] {
        let renderer = PinRenderer::new(&sensor, size).expect("renderable");
        // Slightly displaced pins so every frame projects and rasterises from scratch.
        let mut pins = renderer.layout().poses();
        for (i, p) in pins.iter_mut().enumerate() {
            p.tip.x += 0.01 * ((i * 7) % 11) as f64;
        }
        group.throughput(Throughput::Elements(1));
        group.bench_function(format!("{size}px/1-thread"), |b| {
            let mut img = GrayImage::new(size, size);
            b.iter(|| renderer.render_pins(std::hint::black_box(&pins), &mut img));
        });
        group.throughput(Throughput::Elements(BATCH as u64));
        group.bench_function(format!("{size}px/{}-threads", rayon::current_num_threads()), |b| {
            b.iter(|| {
                (0..BATCH).into_par_iter().for_each_init(
                    || GrayImage::new(size, size),
                    |img, _| renderer.render_pins(std::hint::black_box(&pins), img),
                )
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
