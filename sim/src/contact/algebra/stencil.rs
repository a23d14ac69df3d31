//! A preconditioner for the normal contact problem (issue 31): the normal operator `A_zz`
//! inverted on an unbounded grid of its cells, truncated to a cell's nearest neighbours.
//!
//! The normal operator's symbol falls as `1 / |k|` (the kernel `1 / r`), so its condition on
//! `n` cells in contact grows as `sqrt(n)`, and so do the conjugate gradient's iterations. Its
//! inverse's symbol rises as `|k|`, a kernel that falls as `1 / r^3`: most of it lies on a
//! cell and its eight neighbours. The stencil is that inverse's centre, from the kernel's
//! table `A(dx, dy)` (the operator's offsets within a square of its grid, `|dx|, |dy| < n`,
//! `n = min(nx, ny, 32)`) on a periodic grid of `P = 2 n` cells a side:
//!
//! ```text
//! a(k) = sum_d A(d) cos(2 pi kx dx / P) cos(2 pi ky dy / P)   (the table's symbol; even)
//! m(d) = A(0) / P^2 sum_k cos(2 pi kx dx / P) cos(2 pi ky dy / P) / a(k)   for |dx|, |dy| <= RADIUS
//! ```
//!
//! scaled by the operator's diagonal `A(0)`, so that `M A` is about the identity and the
//! solver's step keeps its units (MPa per mm). Truncated, the stencil's own symbol must stay
//! positive for `M` to be positive definite on every cell set (a principal block of a positive
//! definite convolution): it is checked on the same grid, and the centre raised where it is
//! not. On the calibrated sensor's 25-cell grid the centre is 1.33, a side -0.20, a corner
//! -0.07, the truncated symbol 0.23..1.85.
//!
//! `docs/experiments/contact.md`, "The normal operator's inverse as a preconditioner".

/// Neighbours a side of the stencil: 1, a cell and its eight neighbours. Two (25 taps) took
/// 135 normal iterations on the bench's slide against 138, and 19 against 21 on its tap across
/// the disk's rim (24 -> 18 on the flat top either way; 206 and 34 unpreconditioned).
pub(crate) const RADIUS: usize = 1;

/// Taps a side.
const WIDTH: usize = 2 * RADIUS + 1;

/// The truncated inverse of a normal operator (the module's `m(d)`): taps row-major from
/// `(-RADIUS, -RADIUS)`, dimensionless.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct InverseStencil {
    taps: [f64; WIDTH * WIDTH],
}

impl InverseStencil {
    /// The stencil of the kernel `table(dx, dy)` (any unit) of an `nx x ny` grid.
    pub(crate) fn of(nx: usize, ny: usize, table: impl Fn(isize, isize) -> f64) -> Self {
        // A square of the table: a long, narrow grid's is cut short across, and its symbol
        // then far from the kernel's (a 40 x 9 grid's centre 11.9, its sides +4.0).
        let n = Self::square(nx, ny);
        let cos = Cosines::of(n);
        let p = cos.period();
        let offsets = || -(n as isize - 1)..n as isize;
        // Every frequency's cosines at the square's offsets, looked up once: the sums below
        // take the same values in the same order.
        let width = 2 * n - 1;
        let square = cos.reaching(n - 1);
        // Along x first, `b(kx, dy)`, then along y.
        let mut along_x = vec![0.0; p * width];
        for (row, dy) in offsets().enumerate() {
            let line: Vec<f64> = offsets().map(|dx| table(dx, dy)).collect();
            for kx in 0..p {
                along_x[row * p + kx] = line.iter().zip(square.row(kx)).map(|(v, c)| v * c).sum();
            }
        }
        let largest = table(0, 0).abs();
        let mut inverse = vec![0.0; p * p];
        for ky in 0..p {
            let cy = square.row(ky);
            for kx in 0..p {
                let a: f64 = (0..width).map(|row| along_x[row * p + kx] * cy[row]).sum();
                // The table's symbol is positive (the operator is); where a truncated far
                // field rounds it near zero, it is held off it.
                inverse[ky * p + kx] = 1.0 / a.max(1e-3 * largest);
            }
        }
        let mut taps = [0.0; WIDTH * WIDTH];
        let near = cos.reaching(RADIUS);
        for (slot, tap) in taps.iter_mut().enumerate() {
            let (dx, dy) = offset(slot);
            let mut sum = 0.0;
            for ky in 0..p {
                let row: f64 = (0..p).map(|kx| inverse[ky * p + kx] * near.at(kx, dx)).sum();
                sum += row * near.at(ky, dy);
            }
            *tap = sum * table(0, 0) / (p * p) as f64;
        }
        let mut stencil = Self { taps };
        // Positive definite on every cell set: the truncated symbol above zero. Raised by
        // `delta`, its lowest is `MIN_SYMBOL` of the new centre.
        let lowest = stencil.lowest_symbol(&near);
        let centre = RADIUS * WIDTH + RADIUS;
        if lowest < MIN_SYMBOL * stencil.taps[centre] {
            stencil.taps[centre] += (MIN_SYMBOL * stencil.taps[centre] - lowest) / (1.0 - MIN_SYMBOL);
        }
        stencil
    }

    /// The side of the table's square a stencil of an `nx x ny` grid is found on: the grid's
    /// shorter side, at most [`MAX_SQUARE`].
    pub(crate) fn square(nx: usize, ny: usize) -> usize {
        nx.min(ny).min(MAX_SQUARE)
    }

    /// The lowest of the stencil's symbol over the frequencies of the periodic grid `near`
    /// (its cosines at the stencil's offsets).
    fn lowest_symbol(&self, near: &OffsetCosines) -> f64 {
        let mut lowest = f64::INFINITY;
        for ky in 0..near.period() {
            for kx in 0..near.period() {
                let symbol: f64 = self
                    .taps
                    .iter()
                    .enumerate()
                    .map(|(slot, m)| {
                        let (dx, dy) = offset(slot);
                        m * near.at(kx, dx) * near.at(ky, dy)
                    })
                    .sum();
                lowest = lowest.min(symbol);
            }
        }
        lowest
    }

    /// The tap at offset `(dx, dy)` (`|dx|, |dy| <= RADIUS`).
    #[cfg(test)]
    fn tap(&self, dx: isize, dy: isize) -> f64 {
        let r = RADIUS as isize;
        self.taps[((dy + r) * WIDTH as isize + dx + r) as usize]
    }
}

/// The offset `(dx, dy)` of a stencil's tap `slot`.
fn offset(slot: usize) -> (isize, isize) {
    let r = RADIUS as isize;
    ((slot % WIDTH) as isize - r, (slot / WIDTH) as isize - r)
}

/// The periodic grid the stencil is found on, `P = 2 n` cells a side for the table's square
/// of `n`: the cosines `cos(2 pi k d / P)`.
struct Cosines(Vec<f64>);

impl Cosines {
    fn of(n: usize) -> Self {
        let p = 2 * n;
        Self((0..p).map(|i| (2.0 * std::f64::consts::PI * i as f64 / p as f64).cos()).collect())
    }

    fn period(&self) -> usize {
        self.0.len()
    }

    /// `cos(2 pi k d / P)`.
    fn at(&self, k: usize, d: isize) -> f64 {
        self.0[(k as isize * d).rem_euclid(self.0.len() as isize) as usize]
    }

    /// The cosines at the offsets `|d| <= reach`, looked up once.
    fn reaching(&self, reach: usize) -> OffsetCosines {
        let r = reach as isize;
        let values = (0..self.period()).flat_map(|k| (-r..=r).map(move |d| self.at(k, d))).collect();
        OffsetCosines { reach, values }
    }
}

/// [`Cosines::at`] for the offsets `|d| <= reach`, by index: each frequency's row of them.
struct OffsetCosines {
    reach: usize,
    values: Vec<f64>,
}

impl OffsetCosines {
    fn width(&self) -> usize {
        2 * self.reach + 1
    }

    fn period(&self) -> usize {
        self.values.len() / self.width()
    }

    /// Frequency `k`'s cosines, offsets `-reach..=reach` in order.
    fn row(&self, k: usize) -> &[f64] {
        &self.values[k * self.width()..(k + 1) * self.width()]
    }

    /// `cos(2 pi k d / P)`, `|d| <= reach`.
    fn at(&self, k: usize, d: isize) -> f64 {
        self.row(k)[(d + self.reach as isize) as usize]
    }
}

/// The largest square of the table a stencil is found on (cells a side). The sub-cells' grids
/// are 75 cells across at 25 coarse cells, and a stencil found on all of them took 160 M
/// instructions, 2% of a `paper` shard; the taps on 25 and on 32 cells differ by under 0.006
/// (centre 1.329 against 1.324).
const MAX_SQUARE: usize = 32;

/// The smallest the truncated stencil's symbol may be, relative to its centre.
const MIN_SYMBOL: f64 = 0.05;

/// An [`InverseStencil`] on a set of cells (packed: position `i` is grid cell `cells[i]`),
/// each tap scaled by `1 / sqrt(w_i w_j)` for per-cell weights `w` (a cut cell's compliance
/// relative to a whole one's, Jacobi's part): `M = W^(-1/2) S W^(-1/2)`, symmetric. It runs
/// on a copy of the grid with a border of [`RADIUS`] cells, so that every cell's taps are
/// at the same offsets and none is out of bounds.
#[derive(Clone, Debug)]
pub(crate) struct Preconditioner {
    taps: [f64; WIDTH * WIDTH],
    /// Each packed cell's place on the bordered grid.
    places: Vec<usize>,
    /// `1 / sqrt(w)` per packed cell; empty where all weights are 1.
    scale: Vec<f64>,
    /// The bordered grid's width.
    width: usize,
    /// The bordered grid: the input on the active cells, zero elsewhere (between calls).
    field: Vec<f64>,
}

impl Preconditioner {
    /// `stencil` on the `cells` of a grid `nx` cells wide and `ny` high, with the cells'
    /// weights (`None`: all 1).
    pub(crate) fn new(stencil: InverseStencil, nx: usize, ny: usize, cells: &[usize], weight: Option<&[f64]>) -> Self {
        let width = nx + 2 * RADIUS;
        let places = cells.iter().map(|&k| (k / nx + RADIUS) * width + k % nx + RADIUS).collect();
        let scale = weight.map_or_else(Vec::new, |w| w.iter().map(|w| w.sqrt().recip()).collect());
        Self { taps: stencil.taps, places, scale, width, field: vec![0.0; width * (ny + 2 * RADIUS)] }
    }

    /// `z = P M P g` on the `active` cells (`z` elsewhere untouched), `M` on the active cells
    /// alone, `P` under `load_control` the projection that takes off the mean over them
    /// (the directions then keep the load; without it, the identity). `g` is expected with
    /// its mean already off under load control.
    pub(crate) fn apply(&mut self, g: &[f64], active: &[usize], load_control: bool, z: &mut [f64]) {
        let Self { taps, places, scale, width, field } = self;
        let scaled = |i: usize| if scale.is_empty() { 1.0 } else { scale[i] };
        for &i in active {
            field[places[i]] = g[i] * scaled(i);
        }
        let w = *width;
        let mut total = 0.0;
        for &i in active {
            let top = places[i] - RADIUS * w - RADIUS;
            let mut sum = 0.0;
            for (b, row) in taps.chunks_exact(WIDTH).enumerate() {
                let line = &field[top + b * w..top + b * w + WIDTH];
                sum += row.iter().zip(line).map(|(m, v)| m * v).sum::<f64>();
            }
            z[i] = sum * scaled(i);
            total += z[i];
        }
        if load_control && !active.is_empty() {
            let mean = total / active.len() as f64;
            for &i in active {
                z[i] -= mean;
            }
        }
        for &i in active {
            field[places[i]] = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;
    use crate::contact::body::operator::{Component, HalfSpace, Operator, Pairing};
    use crate::contact::{Elastic, Grid};

    /// The calibrated sensor's half-space on a grid of `n` cells a side.
    fn half_space(n: usize) -> Operator {
        let material = Elastic { shear_modulus_mpa: 1.0, poisson: 0.436 };
        Operator::new(&HalfSpace { material, pairing: Pairing::RigidIndenter }, Grid::square(n, 0.12))
    }

    /// The cells within `radius` cells of the centre of an `n`-cell grid (a contact patch).
    fn disk(n: usize, radius: f64) -> Vec<usize> {
        let c = (n as f64 - 1.0) / 2.0;
        (0..n * n).filter(|k| ((k % n) as f64 - c).hypot((k / n) as f64 - c) <= radius).collect()
    }

    /// `op`'s `A_zz` and the stencil's `M` on `cells`, dense.
    fn matrices(op: &Operator, cells: &[usize]) -> (DMatrix<f64>, DMatrix<f64>) {
        let n = op.grid().nx;
        let offset = |i: usize, j: usize| {
            let (a, b) = (cells[i], cells[j]);
            ((a % n) as isize - (b % n) as isize, (a / n) as isize - (b / n) as isize)
        };
        let stencil = op.normal_stencil();
        let r = RADIUS as isize;
        let a = DMatrix::from_fn(cells.len(), cells.len(), |i, j| {
            let (dx, dy) = offset(i, j);
            op.coefficient(Component::Zz, dx, dy)
        });
        let m = DMatrix::from_fn(cells.len(), cells.len(), |i, j| {
            let (dx, dy) = offset(i, j);
            if dx.abs() <= r && dy.abs() <= r { stencil.tap(dx, dy) } else { 0.0 }
        });
        (a, m)
    }

    /// The condition numbers of `A` and of `M A` (as `L^T A L`, `M = L L^T`; `None` where `M`
    /// is not positive definite).
    fn conditions(a: &DMatrix<f64>, m: &DMatrix<f64>) -> (f64, Option<f64>) {
        let condition = |s: DMatrix<f64>| {
            let e = s.symmetric_eigen().eigenvalues;
            e.max() / e.min()
        };
        let plain = condition(a.clone());
        let l = m.clone().cholesky().map(|c| c.l());
        (plain, l.map(|l| condition(l.transpose() * a * &l)))
    }

    /// On a contact patch of the calibrated sensor's grids the stencil is positive definite
    /// and leaves the normal operator under a quarter as ill-conditioned (the conjugate
    /// gradient's iterations go with the square root): measured 23.4 -> 3.95 on 197 cells of
    /// 25, 32.5 -> 5.14 on 377 of 33, 11.5 -> 2.57 on 49 of 13.
    #[test]
    fn the_inverse_stencil_conditions_the_normal_operator() {
        for (n, radius) in [(25, 8.0), (33, 11.0), (13, 4.0)] {
            let op = half_space(n);
            let (a, m) = matrices(&op, &disk(n, radius));
            let (plain, preconditioned) = conditions(&a, &m);
            let preconditioned = preconditioned.expect("the stencil is positive definite");
            assert!(preconditioned < 0.25 * plain, "{n} cells: {preconditioned:.2} against {plain:.2}");
        }
    }

    /// The stencil hardly changes past 25 cells a side ([`MAX_SQUARE`]): measured under 0.006.
    #[test]
    fn the_stencil_settles_with_the_square() {
        let (a, b) = (half_space(25).normal_stencil(), half_space(75).normal_stencil());
        for (x, y) in a.taps.iter().zip(&b.taps) {
            assert!((x - y).abs() < 0.01, "{:?} against {:?}", a.taps, b.taps);
        }
    }

    /// The stencil's truncated symbol stays above zero on any grid shape (so `M` is positive
    /// definite on every cell set), and a half-space's does not depend on its material.
    #[test]
    fn the_stencil_is_positive_definite_and_scale_free() {
        for (nx, ny) in [(5, 5), (13, 13), (25, 31), (40, 9), (75, 75)] {
            let grid = Grid { nx, ny, cell_mm: 0.2, centre_mm: [0.0; 2] };
            let soft = HalfSpace {
                material: Elastic { shear_modulus_mpa: 0.1, poisson: 0.3 },
                pairing: Pairing::RigidIndenter,
            };
            let op = Operator::new(&soft, grid);
            let stencil = op.normal_stencil();
            let direct = InverseStencil::of(nx, ny, |dx, dy| op.coefficient(Component::Zz, dx, dy));
            for (s, d) in stencil.taps.iter().zip(&direct.taps) {
                assert!((s - d).abs() < 1e-12, "{nx} x {ny}: {s} against {d}");
            }
            let n = InverseStencil::square(nx, ny);
            let lowest = stencil.lowest_symbol(&Cosines::of(n).reaching(RADIUS));
            assert!(lowest >= 0.999 * MIN_SYMBOL * stencil.tap(0, 0), "{nx} x {ny}: {lowest}");
        }
    }

    /// Under load control the preconditioned gaps sum to zero over the active cells, and
    /// equal `P M P g` with `M` on the active cells alone (weights and all).
    #[test]
    fn preconditioned_gaps_keep_the_load() {
        let n = 13;
        let op = half_space(n);
        let cells = disk(n, 5.0);
        let weight: Vec<f64> = (0..cells.len()).map(|i| 1.0 + (i % 7) as f64).collect();
        let mut pre = Preconditioner::new(op.normal_stencil(), n, n, &cells, Some(&weight));
        let active: Vec<usize> = (0..cells.len()).filter(|i| i % 5 != 0).collect();
        let mut g: Vec<f64> = (0..cells.len()).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let mean = active.iter().map(|&i| g[i]).sum::<f64>() / active.len() as f64;
        active.iter().for_each(|&i| g[i] -= mean);
        let mut z = vec![f64::NAN; cells.len()];
        for load_control in [false, true] {
            pre.apply(&g, &active, load_control, &mut z);
            let scale: f64 = active.iter().map(|&i| z[i].abs()).sum();
            // Dense: M on the active cells, scaled by the weights.
            let (_, m) = matrices(&op, &active.iter().map(|&i| cells[i]).collect::<Vec<_>>());
            let w = |a: usize| weight[active[a]].sqrt();
            let m = DMatrix::from_fn(active.len(), active.len(), |a, b| m[(a, b)] / (w(a) * w(b)));
            let mg = &m * nalgebra::DVector::from_iterator(active.len(), active.iter().map(|&i| g[i]));
            let off = if load_control { mg.mean() } else { 0.0 };
            for (a, &i) in active.iter().enumerate() {
                let expected = mg[a] - off;
                assert!((z[i] - expected).abs() < 1e-12 * scale, "cell {i}: {} against {expected}", z[i]);
            }
            if load_control {
                let total: f64 = active.iter().map(|&i| z[i]).sum();
                assert!(total.abs() < 1e-12 * scale, "{total}");
            }
            // Inactive cells untouched.
            assert!((0..cells.len()).filter(|i| i % 5 == 0).all(|i| z[i].is_nan()));
        }
    }
}
