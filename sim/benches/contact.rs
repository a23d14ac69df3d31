//! Influence-operator products, dense on a disc of cells against zero-padded FFT over the grid,
//! for the grid sizes the sensor uses: the measurement behind
//! `contact::normal::DENSE_MAX_CELLS`. Run with `cargo bench -p tacsim-sim --bench contact`.

use criterion::{Criterion, criterion_group, criterion_main};
use tacsim_sim::contact::Elastic;
use tacsim_sim::contact::Grid;
use tacsim_sim::contact::{Component, HalfSpace, Operator, Pairing, Product};

fn bench_products(c: &mut Criterion) {
    let model = HalfSpace { material: Elastic::from_young(1.0, 0.5), pairing: Pairing::RigidIndenter };
    let mut group = c.benchmark_group("normal-product");
    for n in [13usize, 17, 21, 25, 33] {
        let grid = Grid::square(n, 1.0);
        let op = Operator::new(&model, grid);
        // Candidates: the inscribed disc (a tap's footprint); sources: the inner half of its
        // radius squared, as in a Hertz-like contact.
        let r = 0.5 * n as f64;
        let centres = grid.centres();
        let cand: Vec<usize> = (0..grid.len()).filter(|&k| centres[k][0].hypot(centres[k][1]) < r).collect();
        let src: Vec<usize> = cand.iter().copied().filter(|&k| centres[k][0].hypot(centres[k][1]) < 0.7 * r).collect();
        let p: Vec<f64> = (0..grid.len()).map(|k| if src.contains(&k) { 1.0 } else { 0.0 }).collect();
        let mut out = vec![0.0; grid.len()];
        group.bench_function(format!("dense/{}x{}", cand.len(), src.len()), |b| {
            b.iter(|| op.apply(&[(Component::Zz, &p)], &mut out, Product::Dense { src: &src, dst: &cand }));
        });
        group.bench_function(format!("fft/{}-candidates", cand.len()), |b| {
            b.iter(|| op.apply(&[(Component::Zz, &p)], &mut out, Product::Fft));
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(1));
    targets = bench_products
}
criterion_main!(benches);
