//! The elastic influence operator of a grid: surface displacements from cell tractions,
//! `u = A t`, with all nine components, as a dense product over chosen cells or as a
//! zero-padded FFT product over the whole grid (DC-FFT, Liu, Wang & Liu 2000).
//!
//! Cells carry uniform tractions; displacements are taken at cell centres. The coefficient
//! `A_ab(d)` (mm/MPa) gives the displacement component `a` at a cell offset by `d` cells from a
//! cell loaded with unit traction component `b`. On a half-space it is the exact rectangle
//! integral of the point-load kernel ([`crate::contact::body::kernel`]), so the operator is block-Toeplitz and
//! scales linearly with the cell size: the unit-cell integrals are computed once per grid shape
//! and cached.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};

use rustfft::num_complex::Complex64;

#[cfg(target_arch = "x86_64")]
use crate::contact::algebra::lanes::Avx2Lanes;
use crate::contact::algebra::lanes::{LANES, Lanes, Real};
use crate::contact::algebra::precision::{Coefficient, Precision};
use crate::contact::algebra::stencil::InverseStencil;
use crate::contact::body::fft2::Fft2;
use crate::contact::body::kernel::{Elastic, Kernel};
use crate::contact::body::layered::{LayeredKernels, angular, gauss_legendre};
use crate::contact::geometry::grid::Grid;

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
            let spectra = std::array::from_fn(|k| {
                let table: Vec<f64> = self.values.iter().map(|v| v[k]).collect();
                self.embed(&fft, &table)
            });
            (fft, spectra)
        })
    }

    /// Spectrum of a table of coefficients per offset, by circulant embedding: offset `d`
    /// sits at index `d mod 2n`; index `n` stays zero.
    fn embed(&self, fft: &Fft2, table: &[f64]) -> Vec<Complex64> {
        let (m, n) = (2 * self.nx, 2 * self.ny);
        let wx = 2 * self.nx - 1;
        let mut a = vec![0.0; m * n];
        for (idx, v) in table.iter().enumerate() {
            let dx = (idx % wx) as isize - (self.nx as isize - 1);
            let dy = (idx / wx) as isize - (self.ny as isize - 1);
            let x = dx.rem_euclid(m as isize) as usize;
            let y = dy.rem_euclid(n as isize) as usize;
            a[y * m + x] = *v;
        }
        fft.forward(&a)
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
    /// [`Product::Dense`] in single precision: the table's coefficients, the tractions and
    /// each cell's sum in `f32` (about `1e-7` relative per term, a few `1e-6` over a sum of
    /// hundreds, as [`Precision::Single`]), widened into `out`. Half the bytes and twice the
    /// lanes per instruction. For the products between a step's solves at the model's
    /// tolerances ([`Product::in_precision`]).
    DenseSingle {
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
    /// `crate::contact::solve::normal::DENSE_MAX_CELLS`).
    pub fn by_size(cells: usize, dense_max_cells: usize, src: &'a [usize], dst: &'a [usize]) -> Self {
        if cells <= dense_max_cells { Product::Dense { src, dst } } else { Product::Fft }
    }

    /// Dense over `src -> dst` for `components` terms summed into one output where its
    /// `components |src| |dst|` multiply-adds cost less than the FFT's `components` forward
    /// transforms and one inverse, FFT otherwise; the costs scaled from the square problem's
    /// crossover `dense_max_cells` (`D`: `D^2` multiply-adds against two transforms), so dense
    /// where `components |src| |dst| <= (components + 1) / 2 D^2`. For a few sources seen at
    /// many cells: the normal displacement of a step's shear on its contact (`paper`'s shard
    /// 250 at 25 cells: 128 sources, 407 field cells; 363 thousand instructions a product
    /// dense, 556 thousand by FFT).
    pub fn by_pairs(components: usize, dense_max_cells: usize, src: &'a [usize], dst: &'a [usize]) -> Self {
        let (c, d) = (components as f64, dense_max_cells as f64);
        let dense = c * src.len() as f64 * dst.len() as f64 <= 0.5 * (c + 1.0) * d * d;
        if dense { Product::Dense { src, dst } } else { Product::Fft }
    }

    /// The same product in `precision`: a dense one in single precision becomes
    /// [`Product::DenseSingle`]; an FFT stays one (double).
    pub fn in_precision(self, precision: Precision) -> Self {
        match (self, precision) {
            (Product::Dense { src, dst }, Precision::Single) => Product::DenseSingle { src, dst },
            (Product::DenseSingle { src, dst }, Precision::Double) => Product::Dense { src, dst },
            (other, _) => other,
        }
    }
}

/// The influence operator of a [`HalfSpace`] or of layers on a rigid base
/// (`layered.rs`) on a [`Grid`].
#[derive(Debug, Clone)]
pub struct Operator {
    grid: Grid,
    tables: Arc<UnitTables>,
    /// Factors times cell size (mm/MPa).
    factors: [f64; 4],
    /// Layered bodies: the correction to the top layer's half-space, per component and offset
    /// (mm/MPa), and its spectra (built on first FFT use).
    correction: Option<Arc<Correction>>,
    /// Per component, coefficient per offset (mm/MPa) (shared by clones).
    coefficients: Arc<[Vec<f64>; 8]>,
    /// [`Operator::checkerboard`] (mm/MPa).
    checkerboard: f64,
    /// The tables made from the coefficients on first use, shared by clones: an operator kept
    /// by the model for the paths on its grid's shape and cell side
    /// ([`crate::contact::body::kept::KeptOperators`]) makes each of them once.
    derived: Arc<Derived>,
}

/// The tables an [`Operator`] makes from its coefficients on first use (the same values
/// whichever product asks first, so the same bits).
#[derive(Debug, Default)]
struct Derived {
    /// The coefficients with `dx` mirrored (`A(-dx, dy)` at the place of `(dx, dy)`), so that a
    /// row of sources is a forward, contiguous slice of the table; made on a component's first
    /// dense product ([`Operator::mirrored`]): most paths use a few components densely, if
    /// any (issue 31).
    mirrored: [OnceLock<Vec<f64>>; 8],
    /// The same in `f32` ([`Operator::table_single`] mirrored), for [`Product::DenseSingle`],
    /// made likewise.
    mirrored_single: [OnceLock<Vec<f32>>; 8],
    /// The coefficients rounded to `f32`, for the single-precision cell matrices
    /// ([`Operator::table_single`]), made on a component's first matrix.
    single: [OnceLock<Vec<f32>>; 8],
    /// Per component, its spectrum on the padded grid: the unit tables' spectra combined
    /// with [`Operator::factors`] once, on the component's first FFT product, instead of at
    /// every product.
    spectra: [OnceLock<Vec<Complex64>>; 8],
    /// [`Operator::normal_stencil`], found on first use.
    normal_stencil: OnceLock<InverseStencil>,
}

/// The layered correction of an operator.
#[derive(Debug)]
struct Correction {
    coefficients: [Vec<f64>; 8],
    spectra: OnceLock<[Vec<Complex64>; 8]>,
}

/// Gauss points per side of a cell for the layered correction (smooth over the top layer's
/// thickness, so a few points per cell suffice; `layered_coefficients_equal_fine_quadrature`).
const CORRECTION_GAUSS: usize = 4;

impl Operator {
    /// The operator of `model` on `grid`.
    pub fn new(model: &HalfSpace, grid: Grid) -> Self {
        let tables = UnitTables::get(grid.nx, grid.ny);
        let factors = model.factors().map(|f| f * grid.cell_mm);
        let coefficients: [Vec<f64>; 8] =
            Component::ALL.map(|c| tables.values.iter().map(|t| Self::combine(factors, c, t)).collect());
        let checkerboard = Self::checkerboard_of(&grid, &coefficients);
        Self {
            grid,
            tables,
            factors,
            correction: None,
            coefficients: Arc::new(coefficients),
            checkerboard,
            derived: Arc::default(),
        }
    }

    /// The operator of layers on a rigid base (a rigid indenter on the top layer): the top
    /// layer's exact half-space coefficients plus the cell integral (Gauss-Legendre) of the
    /// tabulated correction.
    pub fn layered(kernels: &LayeredKernels, grid: Grid) -> Self {
        Self::layered_with::<NoCorrection>(kernels, grid, None)
    }

    /// [`Operator::layered`] with a smooth correction of the body's own added to the layers'
    /// (`extra`, [`RadialCorrection`]), integrated over each cell by the same rule: the
    /// finite-element dome's far field ([`crate::contact::body::DomeContact`]).
    pub(crate) fn layered_with<E: RadialCorrection>(kernels: &LayeredKernels, grid: Grid, extra: Option<&E>) -> Self {
        let top = kernels.body().layers[0].material;
        let mut op = Self::new(&HalfSpace { material: top, pairing: Pairing::RigidIndenter }, grid);
        let (nx, ny) = (grid.nx, grid.ny);
        let wx = 2 * nx - 1;
        let mut corr: [Vec<f64>; 8] = std::array::from_fn(|_| vec![0.0; wx * (2 * ny - 1)]);
        // The offsets of one quadrant, then mirrored: the Gauss points are symmetric, Xy is
        // odd in x and y, Xz/Zx odd in x, Yz/Zy odd in y.
        let sums = cell_integrals(kernels, extra, &grid);
        for j in 0..ny {
            for i in 0..nx {
                let sum = sums[j * nx + i];
                for (sx, sy) in [(1isize, 1isize), (-1, 1), (1, -1), (-1, -1)] {
                    let at = (sy * j as isize + ny as isize - 1) as usize * wx
                        + (sx * i as isize + nx as isize - 1) as usize;
                    let signs = [1, 1, 1, sx * sy, sx, sy, sx, sy];
                    for ((table, v), sign) in corr.iter_mut().zip(sum).zip(signs) {
                        table[at] = sign as f64 * v;
                    }
                }
            }
        }
        for (table, c) in Arc::make_mut(&mut op.coefficients).iter_mut().zip(&corr) {
            for (a, b) in table.iter_mut().zip(c) {
                *a += b;
            }
        }
        op.checkerboard = Self::checkerboard_of(&grid, &op.coefficients);
        op.correction = Some(Arc::new(Correction { coefficients: corr, spectra: OnceLock::new() }));
        op
    }

    /// Component `c`'s table with `dx` mirrored ([`Operator::mirrored`]'s field), made on
    /// first use.
    fn mirrored(&self, c: Component) -> &[f64] {
        self.derived.mirrored[c as usize].get_or_init(|| self.mirror(self.table(c)))
    }

    /// [`Operator::mirrored`] in `f32`: [`Operator::table_single`] mirrored (rounding and
    /// mirroring commute), made on first use.
    fn mirrored_single(&self, c: Component) -> &[f32] {
        self.derived.mirrored_single[c as usize].get_or_init(|| self.mirror(self.table_single(c)))
    }

    /// A table (row-major over the offsets, [`Operator::table`]) with each row reversed:
    /// `A(-dx, dy)` at the place of `(dx, dy)`.
    fn mirror<T: Copy>(&self, table: &[T]) -> Vec<T> {
        let wx = 2 * self.grid.nx - 1;
        table.chunks(wx).flat_map(|row| row.iter().rev().copied()).collect()
    }

    /// The in-plane blocks' symbol at the grid's highest frequency, `sum_d A(d) (-1)^(dx + dy)`
    /// over the table's offsets, the lesser of `Xx` and `Yy` (`Xy`'s is zero: it is odd in
    /// `dx` and `dy`).
    fn checkerboard_of(grid: &Grid, coefficients: &[Vec<f64>; 8]) -> f64 {
        let wx = 2 * grid.nx - 1;
        let alternating = |c: Component| {
            let rows = coefficients[c as usize].chunks(wx).enumerate();
            rows.map(|(j, row)| {
                row.iter().enumerate().map(|(i, a)| if (i + j) % 2 == 0 { *a } else { -a }).sum::<f64>()
            })
            .sum::<f64>()
        };
        alternating(Component::Xx).min(alternating(Component::Yy))
    }

    /// How the in-plane blocks (`[[Xx, Xy], [Xy, Yy]]`, mm/MPa) act on a checkerboard of
    /// tractions, cell against cell: their symbol at the grid's highest frequency `(pi, pi)`
    /// (the lesser of its two eigenvalues). A uniform traction sinks every cell together (the
    /// symbol at `(0, 0)`, which grows with the footprint); a checkerboard's cells mostly undo
    /// each other's, so it is about the smallest response a cell set has, and the tangential
    /// solver takes it for its smallest eigenvalue (`crate::contact::solve::tangential`). It is an
    /// estimate, not a bound: the truncated table's symbol dips below it elsewhere.
    pub fn checkerboard(&self) -> f64 {
        self.checkerboard
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The same operator on `grid`, a grid of the same shape and cell side elsewhere (the
    /// coefficients depend on the offsets alone), sharing every table: the same bits as one
    /// built on `grid`.
    pub(crate) fn on(&self, grid: Grid) -> Operator {
        debug_assert!(
            (grid.nx, grid.ny, grid.cell_mm.to_bits()) == (self.grid.nx, self.grid.ny, self.grid.cell_mm.to_bits()),
            "{grid:?} against {:?}",
            self.grid
        );
        Operator { grid, ..self.clone() }
    }

    /// The most memory (bytes) an operator on an `nx x ny` grid holds once every table it can
    /// make is made: per component the coefficients, the layered correction's, their `f64`
    /// mirror, two `f32` copies and two spectra on the padded grid (the inverse stencil and
    /// the unit tables, shared by every operator of the shape, left out).
    pub(crate) fn bytes_at_most(nx: usize, ny: usize) -> usize {
        let offsets = (2 * nx - 1) * (2 * ny - 1);
        let spectrum = (nx + 1) * 2 * ny;
        8 * (offsets * (3 * size_of::<f64>() + 2 * size_of::<f32>()) + 2 * spectrum * size_of::<Complex64>())
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

    /// Whether the normal-tangential coupling vanishes (a half-space at `nu = 0.5`, or
    /// identical bodies; layers on a rigid base couple even when incompressible).
    pub fn uncoupled(&self) -> bool {
        self.factors[3] == 0.0 && self.correction.is_none()
    }

    /// Coefficient `A_c` (mm/MPa) for a field cell offset `(dx, dy)` cells from the loaded one.
    pub fn coefficient(&self, c: Component, dx: isize, dy: isize) -> f64 {
        let wx = 2 * self.grid.nx - 1;
        let idx = (dy + self.grid.ny as isize - 1) as usize * wx + (dx + self.grid.nx as isize - 1) as usize;
        self.coefficients[c as usize][idx]
    }

    /// Component `c`'s coefficients (mm/MPa), row-major over the offsets `(dx, dy)` from
    /// `(-(nx - 1), -(ny - 1))`: offset `(dx, dy)` at `(dy + ny - 1) (2 nx - 1) + dx + nx - 1`.
    pub(crate) fn table(&self, c: Component) -> &[f64] {
        &self.coefficients[c as usize]
    }

    /// [`Operator::table`] rounded to `f32` (each coefficient `v as f32`, as a matrix built
    /// from the double table rounds it), made on first use: a single-precision cell matrix
    /// copies its coefficients instead of rounding each one it gathers (issue 31).
    pub(crate) fn table_single(&self, c: Component) -> &[f32] {
        self.derived.single[c as usize].get_or_init(|| self.table(c).iter().map(|v| *v as f32).collect())
    }

    /// The even kernels' unit-cell integrals ([`Kernel::ALL`]'s first four, in cell units) at
    /// a field cell offset `(dx, dy)` cells from the loaded one: the tables' values.
    pub(crate) fn unit_integrals(&self, dx: isize, dy: isize) -> [f64; 4] {
        let wx = 2 * self.grid.nx - 1;
        let idx = (dy + self.grid.ny as isize - 1) as usize * wx + (dx + self.grid.nx as isize - 1) as usize;
        let t = &self.tables.values[idx];
        [t[0], t[1], t[2], t[3]]
    }

    /// Component `c`'s half-space coefficient (mm/MPa) from the even kernels' integrals `t`
    /// in cell units (a unit cell's force, lengths in cells), as the tables' (a layered body's
    /// correction, smooth over a cell, is not in it). `c` is one of the normal and in-plane
    /// components (`Zz`, `Xx`, `Yy`, `Xy`), which take no odd kernel.
    pub(crate) fn coefficient_of_even_integrals(&self, c: Component, t: &[f64; 4]) -> f64 {
        debug_assert!(matches!(c, Component::Zz | Component::Xx | Component::Yy | Component::Xy), "{c:?}");
        Self::combine(self.factors, c, &[t[0], t[1], t[2], t[3], 0.0, 0.0])
    }

    /// The truncated inverse of `A_zz`, scaled by its diagonal: the normal solve's
    /// preconditioner ([`InverseStencil`]), found on the operator's first call. A
    /// half-space's depends only on the side of the grid's square it is found on (its
    /// coefficients scale together with the material and the cell side): it is found from
    /// the unit tables, the same bits whichever operator asks first, and kept per side for
    /// every operator. A layered body's is its own.
    pub(crate) fn normal_stencil(&self) -> InverseStencil {
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        *self.derived.normal_stencil.get_or_init(|| match self.correction {
            None => {
                type Cache = Mutex<HashMap<usize, InverseStencil>>;
                static CACHE: OnceLock<Cache> = OnceLock::new();
                let n = InverseStencil::square(nx, ny);
                let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
                let mut kept = cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                *kept.entry(n).or_insert_with(|| {
                    let wx = 2 * nx as isize - 1;
                    InverseStencil::of(n, n, |dx, dy| {
                        self.tables.values[((dy + ny as isize - 1) * wx + dx + nx as isize - 1) as usize][0]
                    })
                })
            }
            Some(_) => InverseStencil::of(nx, ny, |dx, dy| self.coefficient(Component::Zz, dx, dy)),
        })
    }

    /// Self-influence `A_c(0, 0)` (mm/MPa).
    pub fn diagonal(&self, c: Component) -> f64 {
        self.coefficient(c, 0, 0)
    }

    /// `out = sum_k A_{c_k} t_k` for the given terms (each a grid field in MPa), in mm.
    pub fn apply(&self, terms: &[(Component, &[f64])], out: &mut [f64], product: Product<'_>) {
        match product {
            Product::Dense { src, dst } => {
                let tables: Vec<&[f64]> = terms.iter().map(|(c, _)| self.mirrored(*c)).collect();
                self.apply_dense(&tables, terms, out, src, dst)
            }
            Product::DenseSingle { src, dst } => {
                let tables: Vec<&[f32]> = terms.iter().map(|(c, _)| self.mirrored_single(*c)).collect();
                self.apply_dense(&tables, terms, out, src, dst)
            }
            Product::Fft => self.apply_fft(terms, out),
        }
    }

    fn apply_dense<T: Coefficient>(
        &self,
        tables: &[&[T]],
        terms: &[(Component, &[f64])],
        out: &mut [f64],
        src: &[usize],
        dst: &[usize],
    ) {
        let nx = self.grid.nx;
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
        let values: Vec<Vec<T>> = terms.iter().map(|(_, t)| sorted.iter().map(|&s| T::of(t[s])).collect()).collect();
        let mut targets = dst.to_vec();
        if !targets.is_sorted() {
            targets.sort_unstable();
        }
        // A repeated cell would pass for a neighbour in the run test below.
        targets.dedup();
        // Compiled for each vector unit ([`pulp::WithSimd`]): plain multiplies and adds in
        // the same order on every one (Rust never fuses them), so the same bits, on AVX2 eight
        // `f32` lanes an instruction where the baseline build has four.
        let sums = DenseSums { nx: self.grid.nx, ny: self.grid.ny, tables, values: &values, runs: &runs };
        pulp::Arch::new().dispatch(DenseTargets { sums, targets: &targets, out });
    }

    fn apply_fft(&self, terms: &[(Component, &[f64])], out: &mut [f64]) {
        let (fft, spectra) = self.tables.spectra();
        let corrections = self
            .correction
            .as_ref()
            .map(|c| c.spectra.get_or_init(|| c.coefficients.clone().map(|t| self.tables.embed(fft, &t))));
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        let m = 2 * nx;
        let mut acc = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        // The padded input's rows past `ny` are zero and its output's are not read: the
        // transforms skip their row transforms (`Fft2::forward`, `Fft2::inverse`).
        let mut padded = vec![0.0; m * ny];
        for &(c, t) in terms {
            for j in 0..ny {
                padded[j * m..j * m + nx].copy_from_slice(&t[j * nx..(j + 1) * nx]);
            }
            let ft = fft.forward(&padded);
            let spectrum = self.derived.spectra[c as usize].get_or_init(|| {
                (0..ft.len())
                    .map(|k| {
                        let s =
                            [spectra[0][k], spectra[1][k], spectra[2][k], spectra[3][k], spectra[4][k], spectra[5][k]];
                        Self::combine(self.factors, c, &s)
                    })
                    .collect()
            });
            for (a, (s, x)) in acc.iter_mut().zip(spectrum.iter().zip(&ft)) {
                *a += s * x;
            }
            if let Some(corr) = corrections {
                for (a, (s, x)) in acc.iter_mut().zip(corr[c as usize].iter().zip(&ft)) {
                    *a += s * x;
                }
            }
        }
        let mut full = vec![0.0; m * ny];
        fft.inverse(acc, &mut full);
        for j in 0..ny {
            out[j * nx..(j + 1) * nx].copy_from_slice(&full[j * m..j * m + nx]);
        }
    }
}

/// A body's own smooth part of the contact plane's kernel, added to the layers' in
/// [`Operator::layered_with`] (the finite-element dome's far field): radial functions
/// `[F_zz, F_pr, F_s, F_d]` (mm/N, the layered kernels' conventions) at `N` radii (mm) at
/// once, each lane the bits of its radius alone (`N = 1` on `f64`: one radius).
pub(crate) trait RadialCorrection: Sync {
    /// The functions at the radii `r`; `lanes` makes values into `T`.
    fn radial<T: Real, const N: usize>(&self, r: [f64; N], lanes: &impl Fn([f64; N]) -> T) -> [T; 4];
}

/// No correction: the layers alone ([`Operator::layered`]).
pub(crate) enum NoCorrection {}

impl RadialCorrection for NoCorrection {
    fn radial<T: Real, const N: usize>(&self, _: [f64; N], _: &impl Fn([f64; N]) -> T) -> [T; 4] {
        match *self {}
    }
}

// The cell integral takes one row of Gauss points per run of lanes.
const _: () = assert!(CORRECTION_GAUSS == LANES);

/// The layered correction (and `extra`) integrated over the cell at each offset `(i, j)` of
/// one quadrant (`sums[j * nx + i]`: `Zz, Xx, Yy, Xy, Zx, Zy, Xz, Yz`, mm/MPa) by
/// [`CORRECTION_GAUSS`] x [`CORRECTION_GAUSS`] Gauss-Legendre points: a row of points along
/// `y` at once ([`LANES`]), the radial tables looked up per lane, the sums taken point by
/// point in the rule's order: the bits of one point at a time. On AVX2 where the CPU has it.
fn cell_integrals<E: RadialCorrection>(kernels: &LayeredKernels, extra: Option<&E>, grid: &Grid) -> Vec<[f64; 8]> {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return pulp::Simd::vectorize(simd, Avx2Integrals { simd, kernels, extra, grid });
    }
    integrals_on(kernels, extra, grid, Lanes, |v| v.0)
}

/// [`cell_integrals`] on AVX2.
#[cfg(target_arch = "x86_64")]
struct Avx2Integrals<'a, E> {
    simd: pulp::x86::V3,
    kernels: &'a LayeredKernels,
    extra: Option<&'a E>,
    grid: &'a Grid,
}

#[cfg(target_arch = "x86_64")]
impl<E: RadialCorrection> pulp::WithSimd for Avx2Integrals<'_, E> {
    type Output = Vec<[f64; 8]>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let simd = self.simd;
        integrals_on(self.kernels, self.extra, self.grid, |v| Avx2Lanes::new(simd, v), Avx2Lanes::to_array)
    }
}

/// [`cell_integrals`] on the lanes `T`.
#[inline(always)]
fn integrals_on<T: Real, E: RadialCorrection>(
    kernels: &LayeredKernels,
    extra: Option<&E>,
    grid: &Grid,
    lanes: impl Fn([f64; LANES]) -> T,
    values: impl Fn(T) -> [f64; LANES],
) -> Vec<[f64; 8]> {
    let (nx, ny, h) = (grid.nx, grid.ny, grid.cell_mm);
    let gl = gauss_legendre(CORRECTION_GAUSS);
    let area = h * h;
    let mut sums = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (dx, dy) = (i as f64 * h, j as f64 * h);
            let y: [f64; LANES] = std::array::from_fn(|l| dy - (gl[l].0 - 0.5) * h);
            let mut sum = [0.0; 8];
            for &(s, ws) in &gl {
                let x = dx - (s - 0.5) * h;
                let r: [f64; LANES] = std::array::from_fn(|l| x.hypot(y[l]));
                let mut radial = kernels.surface_radial_lanes(r, &lanes);
                if let Some(extra) = extra {
                    let more = extra.radial(r, &lanes);
                    for (a, b) in radial.iter_mut().zip(more) {
                        *a = *a + b;
                    }
                }
                let [zz, pr, sh, d] = radial;
                let angles: [(f64, f64, f64, f64); LANES] = std::array::from_fn(|l| angular(x, y[l]));
                let (c, sn) = (lanes(angles.map(|a| a.0)), lanes(angles.map(|a| a.1)));
                let (c2, s2) = (lanes(angles.map(|a| a.2)), lanes(angles.map(|a| a.3)));
                // Zz, Xx, Yy, Xy, Zx, Zy, Xz, Yz.
                let v = [zz, sh - c2 * d, sh + c2 * d, -s2 * d, -pr * c, -pr * sn, pr * c, pr * sn].map(&values);
                for (l, &(_, wt)) in gl.iter().enumerate() {
                    let w = ws * wt * area;
                    for (o, v) in sum.iter_mut().zip(&v) {
                        *o += w * v[l];
                    }
                }
            }
            sums.push(sum);
        }
    }
    sums
}

/// What a dense product's sums read ([`Operator::apply`]'s `Dense` products): the grid's
/// shape, the terms' mirrored tables, their values on the sorted sources, and the sources'
/// runs (row, first column, length, start in `values`).
#[derive(Clone, Copy)]
struct DenseSums<'a, T> {
    nx: usize,
    ny: usize,
    tables: &'a [&'a [T]],
    values: &'a [Vec<T>],
    runs: &'a [(usize, usize, usize, usize)],
}

impl<T: Coefficient> DenseSums<'_, T> {
    /// The sums of `L` field cells side by side in a row from `d` on (lane `L - 1 - m` for
    /// cell `d + m`) into `out`; returns `L`, the cells done.
    #[inline(always)]
    fn row_run<const L: usize>(&self, d: usize, out: &mut [f64]) -> usize {
        let (nx, ny) = (self.nx, self.ny);
        let wx = 2 * nx - 1;
        let (di, dj) = (d % nx, d / nx);
        let mut acc = [T::default(); L];
        for (coef, vals) in self.tables.iter().zip(self.values) {
            for &(sj, i0, len, start) in self.runs {
                // The window of the last cell (m = L - 1) starts at `at >= 0`: it is a field
                // cell of the grid, so its offset to every source is in the table.
                let at = (dj + ny - 1 - sj) * wx + i0 + nx - di - L;
                let v = &vals[start..start + len];
                for (w, &x) in coef[at..at + len + L - 1].windows(L).zip(v) {
                    for lane in 0..L {
                        acc[lane] += x * w[lane];
                    }
                }
            }
        }
        for (m, a) in acc.iter().rev().enumerate() {
            out[d + m] = a.wide();
        }
        L
    }

    /// The sum of field cell `d` alone.
    #[inline(always)]
    fn cell(&self, d: usize) -> f64 {
        let (nx, ny) = (self.nx, self.ny);
        let wx = 2 * nx - 1;
        let (di, dj) = (d % nx, d / nx);
        let mut sum = T::default();
        for (coef, vals) in self.tables.iter().zip(self.values) {
            for &(sj, i0, len, start) in self.runs {
                let at = (dj + ny - 1 - sj) * wx + i0 + nx - 1 - di;
                let row = &coef[at..at + len];
                let v = &vals[start..start + len];
                // Four partial sums let the compiler vectorise the dot product.
                let mut acc = [T::default(); 4];
                let (rc, vc) = (row.chunks_exact(4), v.chunks_exact(4));
                let (rr, vr) = (rc.remainder(), vc.remainder());
                for (a, b) in rc.zip(vc) {
                    for k in 0..4 {
                        acc[k] += a[k] * b[k];
                    }
                }
                sum += acc.iter().copied().sum::<T>() + rr.iter().zip(vr).map(|(a, b)| *a * *b).sum::<T>();
            }
        }
        sum.wide()
    }
}

/// A dense product's field cells (sorted, distinct): field cells side by side in a row share
/// each source's traction: seen from (di + m, dj), m = 0..L-1, the t-th source's coefficient
/// sits at `at - m + t`, so the L lie in one forward window `[at + t - L + 1, at + t]` of the
/// table (lane k for m = L - 1 - k): one window load and L multiply-adds per source. Runs of
/// eight cells go eight at a time, then runs of four, then single cells; each cell's sum is
/// the same whatever its run.
struct DenseTargets<'a, T> {
    sums: DenseSums<'a, T>,
    targets: &'a [usize],
    out: &'a mut [f64],
}

impl<T: Coefficient> pulp::WithSimd for DenseTargets<'_, T> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let Self { sums, targets, out } = self;
        let nx = sums.nx;
        let run_of = |k: usize, len: usize| {
            let d = targets[k];
            k + len - 1 < targets.len() && targets[k + len - 1] == d + len - 1 && (d % nx) + len - 1 < nx
        };
        let mut k = 0;
        while k < targets.len() {
            let d = targets[k];
            if run_of(k, 8) {
                k += sums.row_run::<8>(d, out);
            } else if run_of(k, 4) {
                k += sums.row_run::<4>(d, out);
            } else {
                out[d] = sums.cell(d);
                k += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::point_load_displacement;

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
        let (p, qx, qy) = (field(n * n, 1), field(n * n, 2), field(n * n, 3));
        for terms in [
            vec![(Component::Zz, p.as_slice()), (Component::Zx, qx.as_slice()), (Component::Zy, qy.as_slice())],
            vec![(Component::Xx, qx.as_slice()), (Component::Xy, qy.as_slice()), (Component::Xz, p.as_slice())],
            vec![(Component::Xy, qx.as_slice()), (Component::Yy, qy.as_slice()), (Component::Yz, p.as_slice())],
        ] {
            assert_fft_equals_dense(&a, &terms);
        }
    }

    /// What could break: the dense product takes four field cells of a row at once; on any
    /// source and field sets (runs of every length, row ends, gaps) it must be the direct sum
    /// of the coefficients and leave the other outputs alone.
    /// A few sources seen at many cells go dense (the normal displacement of a step's shear);
    /// one term on a square problem keeps `by_size`'s crossover; no dense products at 0.
    #[test]
    fn few_sources_seen_at_many_cells_go_dense() {
        let (few, many): (Vec<usize>, Vec<usize>) = ((0..128).collect(), (0..407).collect());
        assert!(matches!(Product::by_pairs(2, 300, &few, &many), Product::Dense { .. }));
        assert!(matches!(Product::by_pairs(2, 300, &many, &many), Product::Fft));
        assert!(matches!(Product::by_pairs(2, 0, &few, &many), Product::Fft));
        let (at, past): (Vec<usize>, Vec<usize>) = ((0..300).collect(), (0..301).collect());
        assert!(matches!(Product::by_pairs(1, 300, &at, &at), Product::Dense { .. }));
        assert!(matches!(Product::by_pairs(1, 300, &past, &past), Product::Fft));
    }

    #[test]
    fn dense_product_on_scattered_cells_is_the_direct_sum() {
        let n = 11;
        let a = op(0.3, Pairing::RigidIndenter, n, 0.3);
        let (p, qx) = (field(n * n, 4), field(n * n, 5));
        let src: Vec<usize> = (0..n * n).filter(|k| k % 7 != 3 && k % 5 != 0).collect();
        let mut dst: Vec<usize> = (0..n * n).filter(|k| (k * 2654435761) % 13 < 9).rev().collect();
        // Repeated cells must not pass for a run: 35, 36, 36, 38 (one row) is not 35..=38.
        dst.extend([36, 36, 35, 38]);
        dst.retain(|&k| k != 37);
        // A whole row (eleven cells: a run of eight, then single ones) and one of seven (a run
        // of four, then three).
        dst.extend((77..88).chain(100..107));
        let terms = [(Component::Xx, p.as_slice()), (Component::Xz, qx.as_slice())];
        let mut out = vec![f64::NAN; n * n];
        a.apply(&terms, &mut out, Product::Dense { src: &src, dst: &dst });
        for (d, &got) in out.iter().enumerate() {
            if !dst.contains(&d) {
                assert!(got.is_nan(), "cell {d} is not a field cell but was written");
                continue;
            }
            let (di, dj) = ((d % n) as isize, (d / n) as isize);
            let want: f64 = src
                .iter()
                .map(|&s| {
                    let (si, sj) = ((s % n) as isize, (s / n) as isize);
                    terms.iter().map(|(c, t)| a.coefficient(*c, di - si, dj - sj) * t[s]).sum::<f64>()
                })
                .sum();
            assert!((got - want).abs() < 1e-13 * (1.0 + want.abs()), "cell {d}: {got} vs {want}");
        }
    }

    /// A single-precision dense product writes the same cells as the double one, each within
    /// single rounding of it (`2e-6` of the largest output; 3.0e-7 measured, sums over about
    /// 90 sources of two components), runs and single cells alike; `in_precision` turns only
    /// dense products.
    #[test]
    fn a_single_dense_product_is_the_double_one_within_single_rounding() {
        let n = 11;
        let a = op(0.436, Pairing::RigidIndenter, n, 0.3);
        let (p, qx) = (field(n * n, 4), field(n * n, 5));
        let src: Vec<usize> = (0..n * n).filter(|k| k % 7 != 3 && k % 5 != 0).collect();
        let dst: Vec<usize> = (0..n * n).filter(|k| (k * 2654435761) % 13 < 9).chain(77..88).collect();
        let terms = [(Component::Zx, p.as_slice()), (Component::Zy, qx.as_slice())];
        let (mut double, mut single) = (vec![f64::NAN; n * n], vec![f64::NAN; n * n]);
        let dense = Product::Dense { src: &src, dst: &dst };
        a.apply(&terms, &mut double, dense);
        a.apply(&terms, &mut single, dense.in_precision(Precision::Single));
        let scale = double.iter().filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 0.0);
        for (d, (x, y)) in double.iter().zip(&single).enumerate() {
            assert_eq!(x.is_nan(), y.is_nan(), "cell {d} written by one product only");
            if x.is_finite() {
                assert!((x - y).abs() <= 2e-6 * scale, "cell {d}: {y} vs {x} (scale {scale})");
            }
        }
        assert!(matches!(dense.in_precision(Precision::Single), Product::DenseSingle { .. }));
        let back = dense.in_precision(Precision::Single).in_precision(Precision::Double);
        assert!(matches!(back, Product::Dense { .. }));
        assert!(matches!(Product::Fft.in_precision(Precision::Single), Product::Fft));
    }

    /// The FFT product of `terms` equals the dense product over the whole grid (1e-12).
    fn assert_fft_equals_dense(a: &Operator, terms: &[(Component, &[f64])]) {
        let n = a.grid().len();
        let all: Vec<usize> = (0..n).collect();
        let mut dense = vec![0.0; n];
        let mut fft = vec![0.0; n];
        a.apply(terms, &mut dense, Product::Dense { src: &all, dst: &all });
        a.apply(terms, &mut fft, Product::Fft);
        let scale = dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (d, f) in dense.iter().zip(&fft) {
            assert!((d - f).abs() < 1e-12 * scale, "{d} vs {f}");
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

    fn layered(layers: &[(f64, f64, f64)], pin_depth: f64, r_max: f64) -> Arc<LayeredKernels> {
        use crate::contact::body::layered::{Layer, LayeredBody};
        let body = LayeredBody {
            layers: layers
                .iter()
                .map(|&(h, e, nu)| Layer { thickness_mm: h, material: Elastic::from_young(e, nu) })
                .collect(),
        };
        LayeredKernels::get(&body, pin_depth, r_max)
    }

    /// A smooth correction for the cell integrals' test: the same formula on every lane.
    struct Smooth;

    impl RadialCorrection for Smooth {
        fn radial<T: Real, const N: usize>(&self, r: [f64; N], lanes: &impl Fn([f64; N]) -> T) -> [T; 4] {
            let r = lanes(r);
            let g = r.splat_like(1.0) / (r.splat_like(1.0) + r * r * 0.1);
            [g, g * 0.5, -(g * 0.25), g * r * 0.01]
        }
    }

    /// What changed: the cell integrals of the layered correction (and a body's own, as the
    /// dome's far field) take a row of Gauss points at once. They are the bits of one point at
    /// a time in the rule's order (the loop they replaced, written out here), on plain lanes
    /// and on AVX2 alike, with and without the body's own correction.
    #[test]
    fn the_cell_integrals_by_lanes_are_one_point_at_a_time() {
        let k = layered(&[(0.66, 1.0, 0.436), (19.34, 0.02, 0.4999)], 0.66, 30.0);
        let grid = Grid { nx: 7, ny: 5, cell_mm: 0.37, centre_mm: [0.0, 0.0] };
        let gl = gauss_legendre(CORRECTION_GAUSS);
        for extra in [None, Some(&Smooth)] {
            let mut want = Vec::new();
            for j in 0..grid.ny {
                for i in 0..grid.nx {
                    let (dx, dy, h) = (i as f64 * grid.cell_mm, j as f64 * grid.cell_mm, grid.cell_mm);
                    let mut sum = [0.0; 8];
                    for &(s, ws) in &gl {
                        for &(t, wt) in &gl {
                            let (x, y) = (dx - (s - 0.5) * h, dy - (t - 0.5) * h);
                            let w = ws * wt * (h * h);
                            let mut radial = k.surface_radial(x.hypot(y));
                            if let Some(e) = extra {
                                let more = e.radial([x.hypot(y); LANES], &Lanes);
                                for (a, b) in radial.iter_mut().zip(more) {
                                    *a += b.0[0];
                                }
                            }
                            let [zz, pr, sh, d] = radial;
                            let (c, sn, c2, s2) = angular(x, y);
                            let v = [zz, sh - c2 * d, sh + c2 * d, -s2 * d, -pr * c, -pr * sn, pr * c, pr * sn];
                            for (o, v) in sum.iter_mut().zip(v) {
                                *o += w * v;
                            }
                        }
                    }
                    want.push(sum);
                }
            }
            let bits = |v: &[[f64; 8]]| v.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&integrals_on(&k, extra, &grid, Lanes, |v| v.0)), bits(&want), "plain lanes");
            assert_eq!(bits(&cell_integrals(&k, extra, &grid)), bits(&want), "this CPU's lanes");
            assert!(want.iter().flatten().any(|v| *v != 0.0));
        }
    }

    #[test]
    fn layered_coefficients_equal_fine_quadrature() {
        let k = layered(&[(1.5, 1.0, 0.45), (18.5, 0.1, 0.45)], 1.5, 30.0);
        let h = 0.8;
        let a = Operator::layered(&k, Grid::square(9, h));
        let hs = Operator::new(
            &HalfSpace { material: Elastic::from_young(1.0, 0.45), pairing: Pairing::RigidIndenter },
            Grid::square(9, h),
        );
        let n = 40;
        for (dx, dy) in [(0isize, 0isize), (1, 0), (-2, 3), (5, -1)] {
            let mut fine = [0.0; 3];
            for i in 0..n {
                for j in 0..n {
                    let x = dx as f64 * h - h * ((i as f64 + 0.5) / n as f64 - 0.5);
                    let y = dy as f64 * h - h * ((j as f64 + 0.5) / n as f64 - 0.5);
                    let w = h * h / (n * n) as f64;
                    let u = k.surface_correction([w, 0.3 * w, 0.7 * w], x, y);
                    for (f, v) in fine.iter_mut().zip(u) {
                        *f += v;
                    }
                }
            }
            let op = |c1, c2, c3| {
                a.coefficient(c1, dx, dy) - hs.coefficient(c1, dx, dy)
                    + 0.3 * (a.coefficient(c2, dx, dy) - hs.coefficient(c2, dx, dy))
                    + 0.7 * (a.coefficient(c3, dx, dy) - hs.coefficient(c3, dx, dy))
            };
            let got = [
                op(Component::Xx, Component::Xy, Component::Xz),
                op(Component::Xy, Component::Yy, Component::Yz),
                op(Component::Zx, Component::Zy, Component::Zz),
            ];
            let scale = hs.diagonal(Component::Zz);
            for (g, f) in got.iter().zip(fine) {
                assert!((g - f).abs() < 1e-4 * scale, "({dx}, {dy}): {got:?} vs {fine:?}");
            }
        }
    }

    #[test]
    fn thick_layer_operator_is_the_half_space() {
        let k = layered(&[(400.0, 1.0, 0.3)], 1.5, 12.0);
        let grid = Grid::square(11, 0.5);
        let a = Operator::layered(&k, grid);
        let hs = Operator::new(
            &HalfSpace { material: Elastic::from_young(1.0, 0.3), pairing: Pairing::RigidIndenter },
            grid,
        );
        // The rigid base 400 mm down shifts every coefficient by about (1 - nu) / (2 pi G H):
        // a constant offset, below 1% of the self-influence.
        let scale = hs.diagonal(Component::Zz);
        for c in Component::ALL {
            for (dx, dy) in [(0, 0), (3, 1), (-7, 9)] {
                let (x, y) = (a.coefficient(c, dx, dy), hs.coefficient(c, dx, dy));
                assert!((x - y).abs() < 1e-2 * scale, "{c:?} ({dx}, {dy}): {x} vs {y}");
            }
        }
    }

    #[test]
    fn thin_layer_under_uniform_load_compresses_uniaxially_and_far_field_vanishes() {
        // Layer 0.5 mm on a rigid base, pressure over a 20 mm square: u_z = p h / M in the
        // middle (M = 2 G (1 - nu) / (1 - 2 nu)), and shear q gives u = q h / G.
        let (h, nu) = (0.5, 0.3);
        let k = layered(&[(h, 1.0, nu)], 0.25, 40.0);
        let n = 81;
        let grid = Grid::square(n, 0.25);
        let a = Operator::layered(&k, grid);
        let m = Elastic::from_young(1.0, nu);
        let g = m.shear_modulus_mpa;
        let pwave = 2.0 * g * (1.0 - nu) / (1.0 - 2.0 * nu);
        let ones = vec![1.0; n * n];
        let mut u = vec![0.0; n * n];
        a.apply(&[(Component::Zz, &ones)], &mut u, Product::Fft);
        let mid = n * n / 2;
        assert!((u[mid] / (h / pwave) - 1.0).abs() < 1e-3, "{} vs {}", u[mid], h / pwave);
        a.apply(&[(Component::Xx, &ones)], &mut u, Product::Fft);
        assert!((u[mid] / (h / g) - 1.0).abs() < 1e-3, "{} vs {}", u[mid], h / g);
        // Far from a loaded cell (20 layer thicknesses) the surface does not move, where the
        // half-space would.
        for c in [Component::Zz, Component::Xx, Component::Zx] {
            let far = a.coefficient(c, 40, 0).abs();
            assert!(far < 1e-6 * a.diagonal(Component::Zz), "{c:?}: {far}");
        }
    }

    #[test]
    fn layered_fft_product_equals_dense_product() {
        let k = layered(&[(1.5, 1.0, 0.5), (18.5, 0.1, 0.5)], 1.5, 30.0);
        let n = 13;
        let a = Operator::layered(&k, Grid::square(n, 0.9));
        assert!(!a.uncoupled(), "an incompressible layer on a rigid base couples");
        let (p, qx, qy) = (field(n * n, 1), field(n * n, 2), field(n * n, 3));
        assert_fft_equals_dense(
            &a,
            &[(Component::Xx, qx.as_slice()), (Component::Xy, qy.as_slice()), (Component::Xz, p.as_slice())],
        );
        for (dx, dy) in [(1, 0), (2, -3)] {
            let (xz, zx) = (a.coefficient(Component::Xz, dx, dy), a.coefficient(Component::Zx, -dx, -dy));
            assert!((xz - zx).abs() < 1e-12 * xz.abs(), "reciprocity: {xz} vs {zx}");
        }
    }
}
