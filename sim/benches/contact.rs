//! Influence-operator products, dense on a disc of cells against zero-padded FFT over the grid,
//! for the grid sizes the sensor uses: the measurement behind
//! `contact::normal::DENSE_MAX_CELLS`; and the tangential product on a tap's contact cells, by
//! the operator's dense product against a prebuilt [`CellMatrix`], in double and in single
//! precision (and what building one costs); and the sub-cells' normal product by their matrix,
//! streamed and by a few inputs. Run with `cargo bench -p tacsim-sim --bench contact`.

use criterion::{Criterion, criterion_group, criterion_main};
use tacsim_sim::contact::Elastic;
use tacsim_sim::contact::Grid;
use tacsim_sim::contact::{CellMatrix, Component, HalfSpace, Operator, Pairing, Precision, Product};

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
    bench_shear_products(c);
    bench_subcell_products(c);
}

/// `u_z = A_zz p` on the sub-cells of a `paper` step's edge (about 500 of them, a disc on a
/// 51 x 51 grid, `refine.rs`): by their symmetric single matrix streamed (every input
/// non-zero), and by the same matrix taking five non-zero inputs one by one (the conjugate
/// gradient's jumps; the same bits, `matrix.rs`, `SparseLowerSums`).
fn bench_subcell_products(c: &mut Criterion) {
    let model = HalfSpace { material: Elastic::from_young(1.0, 0.436), pairing: Pairing::RigidIndenter };
    let mut group = c.benchmark_group("subcell-product");
    let grid = Grid::square(51, 1.0);
    let op = Operator::new(&model, grid);
    let centres = grid.centres();
    let cells: Vec<usize> = (0..grid.len()).filter(|&k| centres[k][0].hypot(centres[k][1]) < 12.6).collect();
    let m = cells.len();
    let matrix = CellMatrix::in_precision(&op, &[[Component::Zz]], &cells, Precision::Single);
    let mut out = vec![0.0; m];
    let full: Vec<f64> = (0..m).map(|i| 1.0 + (i % 7) as f64).collect();
    group.bench_function(format!("streamed/{m}-subcells"), |b| b.iter(|| matrix.apply(&full, &mut out)));
    let jumps: Vec<f64> = (0..m).map(|i| if i % (m / 5) == 3 { 0.5 } else { 0.0 }).collect();
    group.bench_function(format!("five-inputs/{m}-subcells"), |b| b.iter(|| matrix.apply(&jumps, &mut out)));
    group.finish();
}

/// `u = A_t q` on a disc of contact cells, the tangential solver's product.
fn bench_shear_products(c: &mut Criterion) {
    let model = HalfSpace { material: Elastic::from_young(1.0, 0.436), pairing: Pairing::RigidIndenter };
    let blocks = [[Component::Xx, Component::Xy], [Component::Xy, Component::Yy]];
    let mut group = c.benchmark_group("shear-product");
    for n in [13usize, 17, 21, 25] {
        let grid = Grid::square(n, 1.0);
        let op = Operator::new(&model, grid);
        // The contact: the disc of 0.7 of the inscribed radius (a Hertz-like tap's).
        let r = 0.35 * n as f64;
        let centres = grid.centres();
        let cells: Vec<usize> = (0..grid.len()).filter(|&k| centres[k][0].hypot(centres[k][1]) < r).collect();
        let qx: Vec<f64> = (0..grid.len()).map(|k| (k % 7) as f64 - 3.0).collect();
        let qy: Vec<f64> = (0..grid.len()).map(|k| (k % 5) as f64 - 2.0).collect();
        let (mut ux, mut uy) = (vec![0.0; grid.len()], vec![0.0; grid.len()]);
        let m = cells.len();
        group.bench_function(format!("dense/{m}-cells"), |b| {
            b.iter(|| {
                let product = Product::Dense { src: &cells, dst: &cells };
                op.apply(&[(Component::Xx, &qx), (Component::Xy, &qy)], &mut ux, product);
                op.apply(&[(Component::Xy, &qx), (Component::Yy, &qy)], &mut uy, product);
            });
        });
        let matrix = CellMatrix::new(&op, &blocks, &cells);
        // The solvers' product: packed vectors on the cells (`x`, then `y`).
        let packed: Vec<f64> = [&qx, &qy].iter().flat_map(|q| cells.iter().map(|&k| q[k])).collect();
        let mut out = vec![0.0; 2 * m];
        group.bench_function(format!("matrix/{m}-cells"), |b| b.iter(|| matrix.apply(&packed, &mut out)));
        // What the engine builds at the model's tolerance where a double matrix would take
        // over 256 KB (above 90 contact cells): the shear is symmetric, so its lower panels.
        let single = CellMatrix::in_precision(&op, &blocks, &cells, Precision::Single);
        group.bench_function(format!("matrix-single/{m}-cells"), |b| b.iter(|| single.apply(&packed, &mut out)));
        group.bench_function(format!("matrix-build/{m}-cells"), |b| b.iter(|| CellMatrix::new(&op, &blocks, &cells)));
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(1));
    targets = bench_products
}
criterion_main!(benches);
