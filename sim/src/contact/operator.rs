//! The elastic influence operator of a grid: surface displacements from cell tractions,
//! `u = A t`, with all nine components, as a dense product over chosen cells or as a
//! zero-padded FFT product over the whole grid (DC-FFT, Liu, Wang & Liu 2000).
//!
//! Cells carry uniform tractions; displacements are taken at cell centres. The coefficient
//! `A_ab(d)` (mm/MPa) gives the displacement component `a` at a cell offset by `d` cells from a
//! cell loaded with unit traction component `b`. On a half-space it is the exact rectangle
//! integral of the point-load kernel ([`super::kernel`]), so the operator is block-Toeplitz and
//! scales linearly with the cell size: the unit-cell integrals are computed once per grid shape
//! and cached.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};

use rustfft::num_complex::Complex64;

use super::fft2::Fft2;
use super::grid::Grid;
use super::kernel::{Elastic, Kernel};

/// A displacement component from a traction component: `Xz` is `u_x` from pressure `p`, `Zx`
/// is `u_z` from shear traction `q_x`, and so on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Component {
    /// `u_z` from `p`.
    Zz,
    /// `u_x` from `q_x`.
    Xx,
    /// `u_y` from `q_y`.
    Yy,
    /// `u_x` from `q_y` (equal to `u_y` from `q_x`).
    Xy,
    /// `u_z` from `q_x`.
    Zx,
    /// `u_z` from `q_y`.
    Zy,
    /// `u_x` from `p`.
    Xz,
    /// `u_y` from `p`.
    Yz,
}

impl Component {
    /// All eight distinct components (`Yx` equals `Xy`).
    pub const ALL: [Component; 8] = [
        Component::Zz,
        Component::Xx,
        Component::Yy,
        Component::Xy,
        Component::Zx,
        Component::Zy,
        Component::Xz,
        Component::Yz,
    ];
}

/// Which bodies deform.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pairing {
    /// A rigid stimulus on the elastic sensor (the simulator's case).
    RigidIndenter,
    /// Two elastic bodies of the same material (CONTACT's validation cases): compliances
    /// double and the normal-tangential coupling cancels.
    IdenticalBodies,
}

/// An elastic half-space (the influence model with closed-form coefficients).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfSpace {
    /// The material.
    pub material: Elastic,
    /// Which bodies deform.
    pub pairing: Pairing,
}

impl HalfSpace {
    /// Compliance factors (mm^2/N) of the unit kernels for `zz`, the `1/r` part of `xx`/`yy`,
    /// the `nu` part, and the coupling.
    fn factors(&self) -> [f64; 4] {
        let g = self.material.shear_modulus_mpa;
        let nu = self.material.poisson;
        let c = 1.0 / (2.0 * PI * g);
        match self.pairing {
            Pairing::RigidIndenter => [c * (1.0 - nu), c * (1.0 - nu), c * nu, 0.5 * c * (1.0 - 2.0 * nu)],
            Pairing::IdenticalBodies => [2.0 * c * (1.0 - nu), 2.0 * c * (1.0 - nu), 2.0 * c * nu, 0.0],
        }
    }
}

/// Unit-cell integrals of the six kernels for every offset of an `nx x ny` grid.
#[derive(Debug)]
struct UnitTables {
    nx: usize,
    ny: usize,
    /// Per offset `(dx, dy)`, index `(dy + ny - 1) * (2 nx - 1) + dx + nx - 1`.
    values: Vec<[f64; 6]>,
    /// Spectra of the six kernels on the `2 nx x 2 ny` padded grid, built on first FFT use.
    spectra: OnceLock<(Fft2, [Vec<Complex64>; 6])>,
}

impl UnitTables {
    fn new(nx: usize, ny: usize) -> Self {
        let wx = 2 * nx - 1;
        let mut values = vec![[0.0; 6]; wx * (2 * ny - 1)];
        for (idx, v) in values.iter_mut().enumerate() {
            let dx = (idx % wx) as f64 - (nx as f64 - 1.0);
            let dy = (idx / wx) as f64 - (ny as f64 - 1.0);
            for (slot, k) in v.iter_mut().zip(Kernel::ALL) {
                *slot = k.rectangle(dx, dy, 1.0, 1.0);
            }
        }
        Self { nx, ny, values, spectra: OnceLock::new() }
    }

    /// Cached tables for a grid shape.
    fn get(nx: usize, ny: usize) -> Arc<UnitTables> {
        type Cache = Mutex<HashMap<(usize, usize), Arc<UnitTables>>>;
        static CACHE: OnceLock<Cache> = OnceLock::new();
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        let mut map = match cache.lock() {
            Ok(m) => m,
            Err(poisoned) => poisoned.into_inner(),
        };
        map.entry((nx, ny)).or_insert_with(|| Arc::new(UnitTables::new(nx, ny))).clone()
    }

    fn spectra(&self) -> &(Fft2, [Vec<Complex64>; 6]) {
        self.spectra.get_or_init(|| {
            let (m, n) = (2 * self.nx, 2 * self.ny);
            let fft = Fft2::new(m, n);
            let wx = 2 * self.nx - 1;
            let spectra = std::array::from_fn(|k| {
                // Circulant embedding: offset d sits at index d mod 2n; index n stays zero.
                let mut a = vec![0.0; m * n];
                for (idx, v) in self.values.iter().enumerate() {
                    let dx = (idx % wx) as isize - (self.nx as isize - 1);
                    let dy = (idx / wx) as isize - (self.ny as isize - 1);
                    let x = dx.rem_euclid(m as isize) as usize;
                    let y = dy.rem_euclid(n as isize) as usize;
                    a[y * m + x] = v[k];
                }
                fft.forward(&a)
            });
            (fft, spectra)
        })
    }
}

/// How a product is evaluated.
#[derive(Clone, Copy, Debug)]
pub enum Product<'a> {
    /// Sum over the source cells `src` (where the tractions may be non-zero), evaluated at the
    /// cells `dst`; other outputs are left untouched. Cost `|src| |dst|`.
    Dense {
        /// Cells whose tractions may be non-zero.
        src: &'a [usize],
        /// Cells where the displacement is wanted.
        dst: &'a [usize],
    },
    /// Whole grid by zero-padded FFT. Cost `O(N log N)`.
    Fft,
}

impl<'a> Product<'a> {
    /// Dense over `src -> dst` when the problem has at most `dense_max_cells` cells (`cells`),
    /// FFT otherwise: the one place the choice is made (crossover measured in
    /// `crate::contact::normal::DENSE_MAX_CELLS`).
    pub fn by_size(cells: usize, dense_max_cells: usize, src: &'a [usize], dst: &'a [usize]) -> Self {
        if cells <= dense_max_cells { Product::Dense { src, dst } } else { Product::Fft }
    }
}

/// The influence operator of a [`HalfSpace`] on a [`Grid`].
#[derive(Debug, Clone)]
pub struct Operator {
    grid: Grid,
    tables: Arc<UnitTables>,
    /// Factors times cell size (mm/MPa).
    factors: [f64; 4],
    /// Per component, coefficient per offset (mm/MPa).
    coefficients: [Vec<f64>; 8],
    /// The same with `dx` mirrored (`A(-dx, dy)` at the place of `(dx, dy)`), so that a row of
    /// sources is a forward, contiguous slice of the table.
    mirrored: [Vec<f64>; 8],
}

impl Operator {
    /// The operator of `model` on `grid`.
    pub fn new(model: &HalfSpace, grid: Grid) -> Self {
        let tables = UnitTables::get(grid.nx, grid.ny);
        let factors = model.factors().map(|f| f * grid.cell_mm);
        let coefficients: [Vec<f64>; 8] =
            Component::ALL.map(|c| tables.values.iter().map(|t| Self::combine(factors, c, t)).collect());
        let wx = 2 * grid.nx - 1;
        let mirrored = coefficients.clone().map(|table| {
            let mut m = table.clone();
            for (row, out) in table.chunks(wx).zip(m.chunks_mut(wx)) {
                for (o, v) in out.iter_mut().zip(row.iter().rev()) {
                    *o = *v;
                }
            }
            m
        });
        Self { grid, tables, factors, coefficients, mirrored }
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    fn combine<T>(f: [f64; 4], c: Component, t: &[T; 6]) -> T
    where
        T: Copy + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T> + std::ops::Neg<Output = T>,
    {
        match c {
            Component::Zz => t[0] * f[0],
            Component::Xx => t[0] * f[1] + t[1] * f[2],
            Component::Yy => t[0] * f[1] + t[2] * f[2],
            Component::Xy => t[3] * f[2],
            Component::Zx => t[4] * f[3],
            Component::Zy => t[5] * f[3],
            Component::Xz => -(t[4] * f[3]),
            Component::Yz => -(t[5] * f[3]),
        }
    }

    /// Whether the normal-tangential coupling vanishes (`nu = 0.5` or identical bodies).
    pub fn uncoupled(&self) -> bool {
        self.factors[3] == 0.0
    }

    /// Coefficient `A_c` (mm/MPa) for a field cell offset `(dx, dy)` cells from the loaded one.
    pub fn coefficient(&self, c: Component, dx: isize, dy: isize) -> f64 {
        let wx = 2 * self.grid.nx - 1;
        let idx = (dy + self.grid.ny as isize - 1) as usize * wx + (dx + self.grid.nx as isize - 1) as usize;
        self.coefficients[c as usize][idx]
    }

    /// Self-influence `A_c(0, 0)` (mm/MPa).
    pub fn diagonal(&self, c: Component) -> f64 {
        self.coefficient(c, 0, 0)
    }

    /// `out = sum_k A_{c_k} t_k` for the given terms (each a grid field in MPa), in mm.
    pub fn apply(&self, terms: &[(Component, &[f64])], out: &mut [f64], product: Product<'_>) {
        match product {
            Product::Dense { src, dst } => self.apply_dense(terms, out, src, dst),
            Product::Fft => self.apply_fft(terms, out),
        }
    }

    fn apply_dense(&self, terms: &[(Component, &[f64])], out: &mut [f64], src: &[usize], dst: &[usize]) {
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        let wx = 2 * nx - 1;
        // Group the sources into runs of consecutive cells of one row; pack their tractions.
        // For a run starting at column i0 of row sj, seen from (di, dj), the coefficient of the
        // t-th cell sits at mirrored[(dj - sj + ny - 1) wx + (i0 + t - di + nx - 1)]: forward.
        let mut runs: Vec<(usize, usize, usize, usize)> = Vec::new(); // (row, i0, len, start)
        let mut sorted = src.to_vec();
        if !sorted.is_sorted() {
            sorted.sort_unstable();
        }
        for (pos, &s) in sorted.iter().enumerate() {
            let (i, j) = (s % nx, s / nx);
            match runs.last_mut() {
                Some(r) if r.0 == j && r.1 + r.2 == i => r.2 += 1,
                _ => runs.push((j, i, 1, pos)),
            }
        }
        let values: Vec<Vec<f64>> = terms.iter().map(|(_, t)| sorted.iter().map(|&s| t[s]).collect()).collect();
        for &d in dst {
            let (di, dj) = (d % nx, d / nx);
            let mut sum = 0.0;
            for ((c, _), vals) in terms.iter().zip(&values) {
                let coef = &self.mirrored[*c as usize];
                for &(sj, i0, len, start) in &runs {
                    let at = (dj + ny - 1 - sj) * wx + i0 + nx - 1 - di;
                    let row = &coef[at..at + len];
                    let v = &vals[start..start + len];
                    // Four partial sums let the compiler vectorise the dot product.
                    let mut acc = [0.0; 4];
                    let (rc, vc) = (row.chunks_exact(4), v.chunks_exact(4));
                    let (rr, vr) = (rc.remainder(), vc.remainder());
                    for (a, b) in rc.zip(vc) {
                        for k in 0..4 {
                            acc[k] += a[k] * b[k];
                        }
                    }
                    sum += acc.iter().sum::<f64>() + rr.iter().zip(vr).map(|(a, b)| a * b).sum::<f64>();
                }
            }
            out[d] = sum;
        }
    }

    fn apply_fft(&self, terms: &[(Component, &[f64])], out: &mut [f64]) {
        let (fft, spectra) = self.tables.spectra();
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        let m = 2 * nx;
        let mut acc = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        let mut padded = vec![0.0; m * 2 * ny];
        for &(c, t) in terms {
            for j in 0..ny {
                padded[j * m..j * m + nx].copy_from_slice(&t[j * nx..(j + 1) * nx]);
            }
            let ft = fft.forward(&padded);
            for (k, (a, x)) in acc.iter_mut().zip(&ft).enumerate() {
                let s = [spectra[0][k], spectra[1][k], spectra[2][k], spectra[3][k], spectra[4][k], spectra[5][k]];
                *a += Self::combine(self.factors, c, &s) * x;
            }
        }
        let mut full = vec![0.0; m * 2 * ny];
        fft.inverse(acc, &mut full);
        for j in 0..ny {
            out[j * nx..(j + 1) * nx].copy_from_slice(&full[j * m..j * m + nx]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::kernel::point_load_displacement;

    fn op(nu: f64, pairing: Pairing, n: usize, h: f64) -> Operator {
        Operator::new(
            &HalfSpace { material: Elastic { shear_modulus_mpa: 3.0, poisson: nu }, pairing },
            Grid::square(n, h),
        )
    }

    fn field(n: usize, seed: u64) -> Vec<f64> {
        (0..n).map(|k| (((k as u64 * 2654435761 + seed) % 1000) as f64) / 1000.0 - 0.3).collect()
    }

    #[test]
    fn reciprocity_of_all_components() {
        let a = op(0.3, Pairing::RigidIndenter, 9, 0.4);
        for (dx, dy) in [(1, 0), (2, -3), (-4, 1), (0, 5)] {
            for c in [Component::Zz, Component::Xx, Component::Yy, Component::Xy] {
                assert!((a.coefficient(c, dx, dy) - a.coefficient(c, -dx, -dy)).abs() < 1e-15, "{c:?}");
            }
            // u_x at i from p at j equals u_z at j from q_x at i.
            assert!((a.coefficient(Component::Xz, dx, dy) - a.coefficient(Component::Zx, -dx, -dy)).abs() < 1e-15);
            assert!((a.coefficient(Component::Yz, dx, dy) - a.coefficient(Component::Zy, -dx, -dy)).abs() < 1e-15);
        }
        assert!(!a.uncoupled());
        assert!(op(0.5, Pairing::RigidIndenter, 3, 1.0).uncoupled());
        assert!(op(0.3, Pairing::IdenticalBodies, 3, 1.0).uncoupled());
    }

    #[test]
    fn far_field_equals_point_load_formulas() {
        let h = 0.25;
        let a = op(0.35, Pairing::RigidIndenter, 41, h);
        let m = Elastic { shear_modulus_mpa: 3.0, poisson: 0.35 };
        let (dx, dy) = (37isize, -21isize);
        let offset = [dx as f64 * h, dy as f64 * h, 0.0];
        let area = h * h;
        let from_p = point_load_displacement(&m, [0.0, 0.0, area], offset);
        let from_qx = point_load_displacement(&m, [area, 0.0, 0.0], offset);
        let from_qy = point_load_displacement(&m, [0.0, area, 0.0], offset);
        let checks = [
            (Component::Zz, from_p[2]),
            (Component::Xz, from_p[0]),
            (Component::Yz, from_p[1]),
            (Component::Xx, from_qx[0]),
            (Component::Xy, from_qx[1]),
            (Component::Zx, from_qx[2]),
            (Component::Yy, from_qy[1]),
            (Component::Zy, from_qy[2]),
        ];
        for (c, point) in checks {
            let cell = a.coefficient(c, dx, dy);
            assert!((cell - point).abs() < 1e-4 * point.abs().max(1e-6), "{c:?}: {cell} vs {point}");
        }
    }

    #[test]
    fn fft_product_equals_dense_product() {
        let n = 13;
        let a = op(0.3, Pairing::RigidIndenter, n, 0.3);
        let all: Vec<usize> = (0..n * n).collect();
        let (p, qx, qy) = (field(n * n, 1), field(n * n, 2), field(n * n, 3));
        for terms in [
            vec![(Component::Zz, p.as_slice()), (Component::Zx, qx.as_slice()), (Component::Zy, qy.as_slice())],
            vec![(Component::Xx, qx.as_slice()), (Component::Xy, qy.as_slice()), (Component::Xz, p.as_slice())],
            vec![(Component::Xy, qx.as_slice()), (Component::Yy, qy.as_slice()), (Component::Yz, p.as_slice())],
        ] {
            let mut dense = vec![0.0; n * n];
            let mut fft = vec![0.0; n * n];
            a.apply(&terms, &mut dense, Product::Dense { src: &all, dst: &all });
            a.apply(&terms, &mut fft, Product::Fft);
            let scale = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (d, f) in dense.iter().zip(&fft) {
                assert!((d - f).abs() < 1e-12 * scale, "{d} vs {f}");
            }
        }
    }

    #[test]
    fn operator_scales_with_cell_size_and_is_positive_on_pressure() {
        let a = op(0.3, Pairing::RigidIndenter, 5, 0.5);
        let b = op(0.3, Pairing::RigidIndenter, 5, 1.0);
        assert!((2.0 * a.diagonal(Component::Zz) - b.diagonal(Component::Zz)).abs() < 1e-15);
        assert!(a.diagonal(Component::Zz) > a.coefficient(Component::Zz, 1, 0));
        assert!(a.coefficient(Component::Zz, 4, 4) > 0.0);
    }
}
