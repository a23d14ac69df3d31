//! The operator on one fixed set of cells as an explicit matrix, for a solver that repeats
//! products on that set (the tangential iterations on the contact cells, the normal conjugate
//! gradient on its candidates).
//!
//! [`Operator::apply`]'s dense product reads the Toeplitz table through each call's runs of
//! cells; on the small footprints of the accurate grids (60-300 cells) that bookkeeping, not
//! the multiply-adds, took most of a product's time. Here the coefficients are gathered once,
//! `M[(a, i), (b, j)] = A_{c_ab}(x_i - x_j, y_i - y_j)` (mm/MPa) for output component `a` at
//! cell `i` and input component `b` at cell `j`, and a product is a plain walk over it.
//!
//! Layout: rows in panels of [`LANES`]; a panel stores, column by column, its rows' `LANES`
//! coefficients side by side. A product keeps a panel's `LANES` sums in registers and adds
//! the columns in order with fused multiply-adds (one rounding each, on every vector unit and
//! in the scalar fallback), so every row's sum is the sequential sum over its columns whatever
//! the vector width: the same bits on every CPU. Fused, a column is 8 instructions on AVX2
//! instead of 16 multiplies and adds and the register moves LLVM added around them (issue 31:
//! a `paper` pose 2.237 -> 2.107 G instructions, `docs/experiments/contact.md`).
//!
//! At the model's tolerances a matrix over [`DOUBLE_MAX_BYTES`] in double precision is built
//! in single ([`Precision`], [`MatrixCache::down_to`]): half the bytes, so a 25-cell tap's
//! contact (about 220 cells, 0.77 MB for the shear) and its normal candidates (385, 0.59 MB)
//! fit under [`MAX_BYTES`] where their double matrices (1.5 and 1.2 MB) did not, and twice the
//! lanes per instruction (issue 31: a 25-cell tap's solve on the disk's top 3.75 -> 1.51 ms;
//! `cargo bench -p tacsim-sim --bench tap -- tap-solve`, `docs/experiments/contact.md`,
//! "Single-precision matrices"). Smaller matrices stay double: built often and used for few
//! products, they would cost more to round than they save.
//!
//! A symmetric single matrix (the shear's `[[Xx, Xy], [Xy, Yy]]`, the normal's `Zz`) keeps
//! only its lower panels: each panel's columns up to the end of its own rows, about half the
//! coefficients. A product streams each stored column once and uses it twice ([`LowerSums`]):
//! the products stream from L2 and are bound by its bandwidth, not by the multiply-adds
//! (issue 31: `cargo bench -p tacsim-sim --bench contact -- shear-product/matrix-single`,
//! 241 contact cells 11.0 -> 7.6 us; a 25-cell tap's solve on the disk's top 1.08 -> 0.92 ms,
//! `cargo run --release -p tacsim-sim --example tap_solves -- 25 1000 flat`).

use std::sync::Arc;

use crate::contact::algebra::precision::{Coefficient, Precision};
use crate::contact::body::operator::{Component, Operator, Product};
use crate::contact::geometry::cut::CutCoupling;
use crate::contact::geometry::grid::Grid;

/// Rows per panel.
const LANES: usize = 32;

/// The largest matrix worth building (bytes): beyond about half of a core's L2 cache the
/// products stream from farther away and lose to the operator's own dense product
/// (`cargo bench -p tacsim-sim --bench contact -- shear-product`: 2.2x faster on 177 contact
/// cells, 1.0 MB; slower on 241, 1.9 MB).
const MAX_BYTES: usize = 1 << 20;

/// The largest symmetric single matrix worth building, in the bytes of its lower panels
/// ([`Panels::Lower`]): twice [`MAX_BYTES`], since a product streams each coefficient once
/// for two multiply-adds. On a 33-cell tap (contacts of about 400 cells: a shear matrix of
/// 1.3 MB, the candidates' of 1 MB) the products by these matrices beat the operator's own
/// (issue 31: `cargo run --release -p tacsim-sim --example tap_solves -- 33 200`, least of
/// three, 1.33 s with a cap of 1 MB, 1.09 s with 2 MB, 2.24 s before the lower panels).
const LOWER_MAX_BYTES: usize = 2 << 20;

/// The largest matrix kept in double precision where a cache allows single (bytes in double,
/// [`MatrixCache::down_to`]). Below it a matrix is built for few products (a 13-cell contact's
/// 60 cells, 0.12 MB), and rounding its coefficients to `f32` costs more than its products
/// gain: single everywhere made a `paper` shard (13 cells, `tacsim generate paper --shard
/// 250/600 --threads 1`) 10% slower. Above it, on a 25-cell grid's slides (partial contacts of
/// 100-180 cells, 0.3-1 MB in double) single made them 10% faster.
const DOUBLE_MAX_BYTES: usize = 1 << 18;

/// How many times more cells a kept matrix may have than a solve asks for and still serve it
/// (its other rows are computed and not read). On a `paper` pose (`tacsim generate paper
/// --shard 250/600 --threads 1`) the shear matrices built fall from 1,007 to 534 at 1.25 (then
/// the eigenvalue bound's, on all cells a path had seen, served the contact cells of the step;
/// the bound is now on a round's own contact, whose later rounds it serves), the normal ones
/// from 656 to 540; instructions 2.907 -> 2.865 G (1.5 and 2.0: 2.874 G).
const SUPERSET_RATIO: f64 = 1.25;

/// A [`CellMatrix`]'s panels in its [`Precision`].
#[derive(Clone, Debug)]
enum Panels {
    Double(Vec<f64>),
    Single(Vec<f32>),
    /// A symmetric matrix in single precision: panel `P` stores only its columns up to the
    /// end of its own rows, `min((P + 1) LANES, cols)` ([`LowerSums`]).
    Lower(Vec<f32>),
}

/// The matrix of an operator's components on a cell set (see the module).
#[derive(Clone, Debug)]
pub struct CellMatrix {
    /// The operator's grid.
    grid: Grid,
    /// The components, block row after block row.
    components: Vec<Component>,
    /// The cells (grid indices), in packing order.
    cells: Vec<usize>,
    /// Output components times cells.
    rows: usize,
    /// Input components times cells.
    cols: usize,
    /// `ceil(rows / LANES)` panels of `cols * LANES` coefficients (mm/MPa), zero-padded.
    panels: Panels,
}

impl CellMatrix {
    /// The matrix of `op` on `cells` (grid indices): output block `a`, input block `b` holds
    /// component `blocks[a][b]`. Inputs and outputs are packed: component block after
    /// component block, cells in the order of `cells`.
    pub fn new<const B: usize>(op: &Operator, blocks: &[[Component; B]], cells: &[usize]) -> Self {
        Self::in_precision(op, blocks, cells, Precision::Double)
    }

    /// [`CellMatrix::new`], its coefficients stored in `precision`.
    pub fn in_precision<const B: usize>(
        op: &Operator,
        blocks: &[[Component; B]],
        cells: &[usize],
        precision: Precision,
    ) -> Self {
        let (rows, cols) = (blocks.len() * cells.len(), B * cells.len());
        let panels = match precision {
            _ if keeps_lower(blocks, precision) => Panels::Lower(gather(op, blocks, cells, true)),
            Precision::Double => Panels::Double(gather(op, blocks, cells, false)),
            Precision::Single => Panels::Single(gather(op, blocks, cells, false)),
        };
        let components = blocks.iter().flatten().copied().collect();
        Self { grid: *op.grid(), components, cells: cells.to_vec(), rows, cols, panels }
    }

    /// The precision of its coefficients.
    pub fn precision(&self) -> Precision {
        match self.panels {
            Panels::Double(_) => Precision::Double,
            Panels::Single(_) | Panels::Lower(_) => Precision::Single,
        }
    }
    /// Whether the matrix of `blocks` on `cells` cells is small enough to be worth building in
    /// `precision` (`MAX_BYTES`; `LOWER_MAX_BYTES` of lower panels where it keeps them).
    pub fn worth_building<const B: usize>(blocks: &[[Component; B]], cells: usize, precision: Precision) -> bool {
        if keeps_lower(blocks, precision) {
            let cols = B * cells;
            let columns: usize = (0..cols.div_ceil(LANES)).map(|p| lower_columns(p, cols)).sum();
            columns * LANES * precision.bytes() <= LOWER_MAX_BYTES
        } else {
            Self::bytes(blocks.len(), B, cells, precision) <= MAX_BYTES
        }
    }

    /// The coefficients' bytes of the matrix of `outputs x inputs` components on `cells` cells
    /// in `precision`.
    fn bytes(outputs: usize, inputs: usize, cells: usize, precision: Precision) -> usize {
        outputs * inputs * cells * cells * precision.bytes()
    }

    /// Whether this is the matrix of `blocks` of an operator on `grid`, in `precision`.
    fn has<const B: usize>(&self, grid: &Grid, blocks: &[[Component; B]], precision: Precision) -> bool {
        self.grid == *grid
            && self.precision() == precision
            && self.components.len() == blocks.len() * B
            && self.components.iter().eq(blocks.iter().flatten())
    }

    /// Where `cells` sit among this matrix's when it serves them: `Some(None)` for its own
    /// cells, `Some(Some(positions))` for a subset (both in increasing order, at most
    /// [`SUPERSET_RATIO`] times fewer), `None` otherwise.
    fn serves(&self, cells: &[usize]) -> Option<Option<Vec<usize>>> {
        if self.cells == cells {
            return Some(None);
        }
        let subset = self.cells.len() as f64 <= SUPERSET_RATIO * cells.len() as f64
            && cells.is_sorted()
            && self.cells.is_sorted();
        if subset { positions_in(&self.cells, cells).map(Some) } else { None }
    }

    /// `y = M x` (x packed by input blocks, `y` by output blocks). Columns where `x` is zero
    /// are skipped (they add nothing).
    pub fn apply(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!((x.len(), y.len()), (self.cols, self.rows), "packed lengths of a cell matrix product");
        // The same fused multiply-adds in the same order on every vector unit: the same bits.
        match &self.panels {
            Panels::Double(panels) => pulp::Arch::new().dispatch(PanelSums { panels, cols: self.cols, x, y }),
            Panels::Single(panels) => pulp::Arch::new().dispatch(SinglePanelSums { panels, cols: self.cols, x, y }),
            Panels::Lower(panels) => match sparse_inputs(x) {
                Some(inputs) => pulp::Arch::new().dispatch(SparseLowerSums { panels, inputs: &inputs, y }),
                None => pulp::Arch::new().dispatch(LowerSums { panels, x, y }),
            },
        }
    }
}

/// Whether a matrix of `blocks` in `precision` keeps only its lower panels
/// ([`Panels::Lower`]): a single one that is symmetric.
fn keeps_lower<const B: usize>(blocks: &[[Component; B]], precision: Precision) -> bool {
    precision == Precision::Single && symmetric(blocks)
}

/// The columns panel `p` of a [`Panels::Lower`] matrix of `cols` columns stores: up to the end
/// of its own rows.
fn lower_columns(p: usize, cols: usize) -> usize {
    ((p + 1) * LANES).min(cols)
}

/// Where panel `p` of a [`Panels::Lower`] matrix starts among its coefficients: each panel `q`
/// before the last stores `(q + 1) LANES` columns ([`lower_columns`]), so `LANES^2 p (p + 1) / 2`.
fn lower_panel_start(p: usize) -> usize {
    LANES * LANES * p * (p + 1) / 2
}

/// Whether `blocks` make a symmetric matrix on any cell set: block `(a, b)` the transpose of
/// block `(b, a)`. Each of `Zz`, `Xx`, `Yy` and `Xy` is an even function of the offset
/// between two cells (a symmetric block), and `Xy` is also `Yx`.
fn symmetric<const B: usize>(blocks: &[[Component; B]]) -> bool {
    use Component::{Xx, Xy, Yy, Zz};
    blocks.len() == B
        && (0..B).all(|a| (0..B).all(|b| blocks[a][b] == blocks[b][a] && matches!(blocks[a][b], Zz | Xx | Yy | Xy)))
}

/// The panels of `op`'s `blocks` on `cells` ([`CellMatrix::new`]), each coefficient as `T`;
/// with `lower`, each panel's columns only up to the end of its own rows ([`Panels::Lower`]).
fn gather<T: Gathered, const B: usize>(
    op: &Operator,
    blocks: &[[Component; B]],
    cells: &[usize],
    lower: bool,
) -> Vec<T> {
    let grid = op.grid();
    let (nx, ny) = (grid.nx, grid.ny);
    let wx = 2 * nx - 1;
    let m = cells.len();
    let (rows, cols) = (blocks.len() * m, B * m);
    let panel_count = rows.div_ceil(LANES);
    let columns_of = |p: usize| if lower { lower_columns(p, cols) } else { cols };
    let mut panels = Vec::with_capacity((0..panel_count).map(columns_of).sum::<usize>() * LANES);
    // The coefficient for field cell i from source cell j sits at `at_i - at_j` of the
    // component's table ([`Operator::table`]), with `at_k = (y_k + ny - 1) wx + x_k + nx - 1`
    // for the field cell and `y_k wx + x_k` for the source.
    let field_at: Vec<usize> = cells.iter().map(|&k| (k / nx + ny - 1) * wx + k % nx + nx - 1).collect();
    let source_at: Vec<usize> = cells.iter().map(|&k| (k / nx) * wx + k % nx).collect();
    // Pushed panel by panel, column by column, in storage order (no zero fill first: on
    // the small matrices that fill cost as much as the gathering), the last panel's
    // missing rows as zeros. A panel's lanes that are cells side by side in a grid row
    // read one component at consecutive places of its table: each such segment of a
    // column is one slice copy (issue 31: a third of the build's time on a `paper` pose).
    let mut segments: Vec<(&[T], usize, usize)> = Vec::new(); // (table, first place, lanes)
    for p in 0..panel_count {
        let lanes = p * LANES..((p + 1) * LANES).min(rows);
        let columns = columns_of(p);
        // Input block `b`: each lane's row `a` reads component `blocks[a][b]`.
        (0..B).for_each(|b| {
            let sources = &source_at[..columns.saturating_sub(b * m).min(m)];
            segments.clear();
            for r in lanes.clone() {
                let (table, at) = (T::table(op, blocks[r / m][b]), field_at[r % m]);
                match segments.last_mut() {
                    Some((t, first, len)) if std::ptr::eq(*t, table) && *first + *len == at => *len += 1,
                    _ => segments.push((table, at, 1)),
                }
            }
            for &src in sources {
                for &(table, first, len) in &segments {
                    panels.extend_from_slice(&table[first - src..first - src + len]);
                }
                panels.extend(std::iter::repeat_n(T::default(), LANES - lanes.len()));
            }
        });
    }
    panels
}

/// A matrix coefficient's type and the operator's tables in it ([`gather`] copies slices
/// of them).
trait Gathered: Coefficient {
    /// Component `c`'s table of `op` in this type.
    fn table(op: &Operator, c: Component) -> &[Self];
}

impl Gathered for f64 {
    fn table(op: &Operator, c: Component) -> &[Self] {
        op.table(c)
    }
}

impl Gathered for f32 {
    fn table(op: &Operator, c: Component) -> &[Self] {
        op.table_single(c)
    }
}

/// Products of an operator's blocks on one fixed cell set, on packed vectors (component block
/// after component block, the cells in the set's order): by the set's [`CellMatrix`] where
/// the products are dense and it is worth building, else by the operator's own product
/// through grid fields kept between calls. A solver's iterations work on the packed vectors
/// and allocate nothing (issue 31: without the gathers and scatters of grid fields and a
/// solve's grid-sized vectors, a `paper` pose takes 3.075 -> 2.907 G instructions).
#[derive(Debug)]
pub(crate) struct CellProduct<'a, const B: usize> {
    op: &'a Operator,
    blocks: &'a [[Component; B]; B],
    cells: &'a [usize],
    dense_max_cells: usize,
    matrix: Option<Arc<CellMatrix>>,
    /// Where the cells sit among the matrix's, when it is a superset's.
    positions: Option<Vec<usize>>,
    /// Input and output grid fields of the operator's product (without a matrix), or the
    /// packed vectors of a superset's matrix.
    fields: std::cell::RefCell<[Vec<f64>; 2]>,
    /// Compliance added to the diagonal blocks' diagonals (mm/MPa, packed), where edges cut
    /// cells ([`CellProduct::with_cut`]).
    cut: Option<Vec<f64>>,
    /// The cut cells' coupling to the cells next to them, a change of the operator's
    /// coefficients: `(row, column, change)` (packed, mm/MPa; [`CutCoupling::near`]).
    near: Vec<(usize, usize, f64)>,
}

impl<'a, const B: usize> CellProduct<'a, B> {
    /// Products of `blocks` (output block `a`, input block `b`: `blocks[a][b]`) on `cells`:
    /// by a matrix from `cache` where one is worth building, else by the operator's dense
    /// product up to `dense_max_cells` cells, by FFT above (0: FFT only, no matrix).
    pub(crate) fn new(
        op: &'a Operator,
        blocks: &'a [[Component; B]; B],
        cells: &'a [usize],
        dense_max_cells: usize,
        cache: &mut MatrixCache,
    ) -> Self {
        // A matrix wherever it fits, whatever `dense_max_cells` (the crossover of the
        // operator's own products) unless that is 0 (FFT only): a 25-cell tap's normal
        // solve on 385 candidates took its products by FFT until the single-precision
        // matrix (0.59 MB) served it.
        let dense = !cells.is_empty() && dense_max_cells > 0;
        let precision = if dense { cache.precision_for(blocks, cells.len()) } else { None };
        let (matrix, positions) = match precision.map(|p| cache.get(op, blocks, cells, p)) {
            Some((matrix, positions)) => (Some(matrix), positions),
            None => (None, None),
        };
        let fields = match (&matrix, &positions) {
            (Some(m), Some(_)) => [vec![0.0; m.cols], vec![0.0; m.rows]],
            _ => Default::default(),
        };
        Self {
            op,
            blocks,
            cells,
            dense_max_cells,
            matrix,
            positions,
            fields: std::cell::RefCell::new(fields),
            cut: None,
            near: Vec::new(),
        }
    }

    /// The same products with the cut cells' `coupling` ([`crate::contact::geometry::cut`]): each one's extra
    /// compliance to its own traction (relative to the operator's diagonal) added on the
    /// diagonal blocks' diagonals ([`CellProduct::cut`]), and its coupling to the cells next
    /// to it added to the operator's coefficients ([`CellProduct::apply_operator`]). `None`,
    /// or no cut among the cells: unchanged.
    pub(crate) fn with_cut(mut self, coupling: Option<&CutCoupling>) -> Self {
        let Some(coupling) = coupling else { return self };
        let (cells, m) = (self.cells, self.cells.len());
        let sorted = cells.is_sorted();
        let at = |k: usize| if sorted { cells.binary_search(&k).ok() } else { cells.iter().position(|&c| c == k) };
        // At most two entries per pair and block, reserved at once rather than grown.
        self.near.reserve(2 * B * B * coupling.near.len());
        for (a, b, change) in &coupling.near {
            let (Some(i), Some(j)) = (at(*a), at(*b)) else { continue };
            for (r, row) in self.blocks.iter().enumerate() {
                for (s, &c) in row.iter().enumerate() {
                    let v = self.op.coefficient_of_even_integrals(c, change);
                    self.near.push((r * m + i, s * m + j, v));
                    self.near.push((r * m + j, s * m + i, v));
                }
            }
        }
        let extra = &coupling.extra;
        if self.cells.iter().all(|&k| extra[k] == 0.0) {
            return self;
        }
        let mut packed = Vec::with_capacity(B * self.cells.len());
        for (a, row) in self.blocks.iter().enumerate() {
            let diagonal = self.op.diagonal(row[a]);
            packed.extend(self.cells.iter().map(|&k| diagonal * extra[k]));
        }
        self.cut = Some(packed);
        self
    }

    /// The compliance [`CellProduct::with_cut`] added (mm/MPa, packed), `None` without.
    pub(crate) fn cut(&self) -> Option<&[f64]> {
        self.cut.as_deref()
    }

    /// The cells, in packing order.
    pub(crate) fn cells(&self) -> &'a [usize] {
        self.cells
    }

    /// The operator.
    pub(crate) fn operator(&self) -> &'a Operator {
        self.op
    }

    /// Whether products go through the cells' [`CellMatrix`] (which needs no source cells).
    pub(crate) fn has_matrix(&self) -> bool {
        self.matrix.is_some()
    }

    /// `y = M x` on packed vectors (`B` blocks of the cells each). `src`: the grid cells where
    /// `x` may be non-zero, for the operator's dense product (`None`: all the cells); the
    /// matrix skips zero inputs by itself.
    pub(crate) fn apply(&self, src: Option<&[usize]>, x: &[f64], y: &mut [f64]) {
        self.apply_operator(src, x, y);
        if let Some(cut) = &self.cut {
            for ((y, x), c) in y.iter_mut().zip(x).zip(cut) {
                *y += c * x;
            }
        }
    }

    /// [`CellProduct::apply`] without the cut cells' own compliance (their coupling to the
    /// cells next to them is in).
    pub(crate) fn apply_operator(&self, src: Option<&[usize]>, x: &[f64], y: &mut [f64]) {
        self.apply_whole(src, x, y);
        for &(r, c, v) in &self.near {
            y[r] += v * x[c];
        }
    }

    /// Whether the cut cells change these products ([`CellProduct::with_cut`]).
    pub(crate) fn has_cut(&self) -> bool {
        self.cut.is_some() || !self.near.is_empty()
    }

    /// `y += C x`, `C` what the cut cells change of the whole cells' operator (their own
    /// compliance and their coupling).
    pub(crate) fn add_cut(&self, x: &[f64], y: &mut [f64]) {
        if let Some(cut) = &self.cut {
            for ((y, x), c) in y.iter_mut().zip(x).zip(cut) {
                *y += c * x;
            }
        }
        for &(r, c, v) in &self.near {
            y[r] += v * x[c];
        }
    }

    /// A bound of the largest eigenvalue's change by the cut cells' coupling (mm/MPa): its
    /// largest absolute row sum (Gershgorin; 0 without).
    pub(crate) fn coupling_bound(&self) -> f64 {
        let mut rows = vec![0.0; B * self.cells.len()];
        for &(r, _, v) in &self.near {
            rows[r] += v.abs();
        }
        rows.into_iter().fold(0.0, f64::max)
    }

    /// The whole cells' operator, by the matrix or the operator's own product.
    fn apply_whole(&self, src: Option<&[usize]>, x: &[f64], y: &mut [f64]) {
        let m = self.cells.len();
        if let Some(matrix) = &self.matrix {
            let Some(positions) = &self.positions else { return matrix.apply(x, y) };
            // A superset's matrix: the other cells' inputs stay zero (their columns are
            // skipped), and their rows are not read: the same sums, the same bits.
            let mut fields = self.fields.borrow_mut();
            let [input, output] = &mut *fields;
            let big = matrix.cells.len();
            for (block, x) in input.chunks_exact_mut(big).zip(x.chunks_exact(m)) {
                for (&at, v) in positions.iter().zip(x) {
                    block[at] = *v;
                }
            }
            matrix.apply(input, output);
            for (block, y) in output.chunks_exact(big).zip(y.chunks_exact_mut(m)) {
                for (&at, v) in positions.iter().zip(y) {
                    *v = block[at];
                }
            }
            return;
        }
        let n = self.op.grid().len();
        let mut fields = self.fields.borrow_mut();
        let [input, output] = &mut *fields;
        input.resize(B * n, 0.0);
        output.resize(n, 0.0);
        for (block, field) in x.chunks_exact(m.max(1)).zip(input.chunks_exact_mut(n)) {
            for (&k, v) in self.cells.iter().zip(block) {
                field[k] = *v;
            }
        }
        let src = src.unwrap_or(self.cells);
        let product = Product::by_size(m, self.dense_max_cells, src, self.cells);
        let inputs: Vec<&[f64]> = input.chunks_exact(n).collect();
        for (row, out) in self.blocks.iter().zip(y.chunks_exact_mut(m.max(1))) {
            let terms: [(Component, &[f64]); B] = std::array::from_fn(|b| (row[b], inputs[b]));
            self.op.apply(&terms, output, product);
            for (&k, v) in self.cells.iter().zip(out.iter_mut()) {
                *v = output[k];
            }
        }
    }
}

/// The position in `big` of each of `cells` (both increasing), `None` unless all are there.
fn positions_in(big: &[usize], cells: &[usize]) -> Option<Vec<usize>> {
    let mut positions = Vec::with_capacity(cells.len());
    let mut at = 0;
    for &k in cells {
        while at < big.len() && big[at] < k {
            at += 1;
        }
        if at == big.len() || big[at] != k {
            return None;
        }
        positions.push(at);
    }
    Some(positions)
}

/// Each panel's sums over the non-zero columns of `x` into `y`, compiled for each vector unit
/// ([`pulp::WithSimd`]).
struct PanelSums<'a> {
    panels: &'a [f64],
    cols: usize,
    x: &'a [f64],
    y: &'a mut [f64],
}

impl pulp::WithSimd for PanelSums<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let Self { panels, cols, x, y } = self;
        for (panel, out) in panels.chunks_exact(cols * LANES).zip(y.chunks_mut(LANES)) {
            let mut acc = [0.0; LANES];
            // `LANES` is a multiple of every vector width: no tails.
            let (sums, _) = S::as_mut_simd_f64s(&mut acc);
            for (column, &v) in panel.chunks_exact(LANES).zip(x) {
                if v == 0.0 {
                    continue;
                }
                let (column, _) = S::as_simd_f64s(column);
                let v = simd.splat_f64s(v);
                for (a, c) in sums.iter_mut().zip(column) {
                    *a = simd.mul_add_f64s(*c, v, *a);
                }
            }
            out.copy_from_slice(&acc[..out.len()]);
        }
    }
}

/// [`PanelSums`] in single precision: each input rounded to `f32`, the sums in `f32`, widened
/// into `y`.
struct SinglePanelSums<'a> {
    panels: &'a [f32],
    cols: usize,
    x: &'a [f64],
    y: &'a mut [f64],
}

impl pulp::WithSimd for SinglePanelSums<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let Self { panels, cols, x, y } = self;
        for (panel, out) in panels.chunks_exact(cols * LANES).zip(y.chunks_mut(LANES)) {
            let mut acc = [0.0f32; LANES];
            let (sums, _) = S::as_mut_simd_f32s(&mut acc);
            for (column, &v) in panel.chunks_exact(LANES).zip(x) {
                if v == 0.0 {
                    continue;
                }
                let (column, _) = S::as_simd_f32s(column);
                let v = simd.splat_f32s(v as f32);
                for (a, c) in sums.iter_mut().zip(column) {
                    *a = simd.mul_add_f32s(*c, v, *a);
                }
            }
            for (o, a) in out.iter_mut().zip(acc) {
                *o = f64::from(a);
            }
        }
    }
}

/// [`SinglePanelSums`] on a symmetric matrix stored as its lower panels ([`Panels::Lower`]):
/// half the coefficients to stream. Panel `P`'s column `j` before its own rows serves twice:
/// its rows' sums take `M[P, j] x_j` as [`SinglePanelSums`] does (then its diagonal block's
/// columns), and row `j` takes the column's products with panel `P`'s inputs, `M[j, P] x_P`,
/// into eight partial sums of its own (lane `l` adds the column's rows `l, l + 8, ...` with
/// fused multiply-adds, panel after panel), added pairwise at the end. Whatever the vector
/// unit: one register of eight lanes on AVX2, else the same lanes one by one (a correctly
/// rounded `mul_add`), the same bits on every CPU. A row's sum is its panel's `f32` sum plus
/// its partial sums', in `f64`.
struct LowerSums<'a> {
    panels: &'a [f32],
    x: &'a [f64],
    y: &'a mut [f64],
}

/// The partial sums of a row in [`LowerSums`].
const PARTIALS: usize = 8;

/// A row's [`PARTIALS`] partial sums added pairwise, in the order of pulp's AVX2 sum (the
/// halves, then the pairs): the same bits on every vector unit.
fn partial_total(d: &[f32]) -> f32 {
    ((d[0] + d[4]) + (d[2] + d[6])) + ((d[1] + d[5]) + (d[3] + d[7]))
}

impl pulp::WithSimd for LowerSums<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let Self { panels, x, y } = self;
        let n = x.len();
        let wide = std::mem::size_of::<S::f32s>() == std::mem::size_of::<[f32; PARTIALS]>();
        // Taken out of the thread's slot, not used in a closure: a closure would lose the
        // vector unit's target features (every `simd` call a function call, 20 times slower).
        let mut partial = PARTIAL_SUMS.take();
        partial.clear();
        partial.resize(n * PARTIALS, 0.0);
        let mut start = 0;
        for p in 0..n.div_ceil(LANES) {
            let (first, columns) = (p * LANES, lower_columns(p, n));
            let panel = &panels[start..start + columns * LANES];
            start += columns * LANES;
            // The panel's inputs, zero past the last row.
            let mut own = [0.0f32; LANES];
            for (o, v) in own.iter_mut().zip(&x[first..columns]) {
                *o = *v as f32;
            }
            let transposed = own.iter().any(|v| *v != 0.0);
            let (lower, diagonal) = panel.split_at(first * LANES);
            let (lower_x, diagonal_x) = x[..columns].split_at(first);
            let mut acc = [0.0f32; LANES];
            if wide {
                // AVX2: a panel column is four registers, the partial sums one.
                const K: usize = LANES / PARTIALS;
                let vectors = |c: &[f32]| -> [S::f32s; K] {
                    let (v, _) = S::as_simd_f32s(c);
                    std::array::from_fn(|k| v[k])
                };
                let own_v = vectors(&own);
                let mut sums = [simd.splat_f32s(0.0); K];
                for ((column, &v), slot) in
                    lower.chunks_exact(LANES).zip(lower_x).zip(partial.chunks_exact_mut(PARTIALS))
                {
                    let c = vectors(column);
                    if v != 0.0 {
                        let v = simd.splat_f32s(v as f32);
                        for k in 0..K {
                            sums[k] = simd.mul_add_f32s(c[k], v, sums[k]);
                        }
                    }
                    if transposed {
                        let (slot, _) = S::as_mut_simd_f32s(slot);
                        let mut d = slot[0];
                        for k in 0..K {
                            d = simd.mul_add_f32s(c[k], own_v[k], d);
                        }
                        slot[0] = d;
                    }
                }
                for (column, &v) in diagonal.chunks_exact(LANES).zip(diagonal_x) {
                    if v != 0.0 {
                        let c = vectors(column);
                        let v = simd.splat_f32s(v as f32);
                        for k in 0..K {
                            sums[k] = simd.mul_add_f32s(c[k], v, sums[k]);
                        }
                    }
                }
                let (out, _) = S::as_mut_simd_f32s(&mut acc);
                out.copy_from_slice(&sums);
            } else {
                // Other vector units: the same sums, lane by lane, every stored column in turn.
                for (j, (column, &v)) in panel.chunks_exact(LANES).zip(x).enumerate() {
                    if v != 0.0 {
                        for (a, c) in acc.iter_mut().zip(column) {
                            *a = c.mul_add(v as f32, *a);
                        }
                    }
                    if transposed && j < first {
                        let slot = &mut partial[j * PARTIALS..(j + 1) * PARTIALS];
                        for (c, x) in column.chunks_exact(PARTIALS).zip(own.chunks_exact(PARTIALS)) {
                            for l in 0..PARTIALS {
                                slot[l] = c[l].mul_add(x[l], slot[l]);
                            }
                        }
                    }
                }
            }
            for (o, a) in y[first..columns].iter_mut().zip(acc) {
                *o = f64::from(a);
            }
        }
        if wide {
            // pulp's AVX2 sum: the halves, then the pairs, as below.
            for (y, d) in y.iter_mut().zip(partial.chunks_exact(PARTIALS)) {
                let (d, _) = S::as_simd_f32s(d);
                *y += f64::from(simd.reduce_sum_f32s(d[0]));
            }
        } else {
            for (y, d) in y.iter_mut().zip(partial.chunks_exact(PARTIALS)) {
                *y += f64::from(partial_total(d));
            }
        }
        PARTIAL_SUMS.set(partial);
    }
}

/// A [`Panels::Lower`] product takes its inputs one by one ([`SparseLowerSums`]) where at
/// most one in this many is non-zero: a column's whole use costs about as many multiply-adds
/// as the matrix has rows, against about a sixth of a multiply-add per coefficient for the
/// streamed product ([`LowerSums`]), whose panels read every stored column whenever one of
/// their own inputs is non-zero.
const SPARSE_INPUTS_PER: usize = 16;

/// The non-zero inputs of `x` (position and value in `f32`, ascending) where they are few
/// enough for [`SparseLowerSums`] ([`SPARSE_INPUTS_PER`]), else `None`.
fn sparse_inputs(x: &[f64]) -> Option<Vec<(usize, f32)>> {
    let most = x.len() / SPARSE_INPUTS_PER;
    let mut inputs = Vec::with_capacity(most);
    for (j, &v) in x.iter().enumerate() {
        let v = v as f32;
        if v != 0.0 {
            if inputs.len() == most {
                return None;
            }
            inputs.push((j, v));
        }
    }
    Some(inputs)
}

/// [`LowerSums`] on few non-zero inputs (`inputs`: position and value, ascending), each taken
/// in turn over the whole of its column: the same sums to the bit. A term whose input is zero
/// adds an exact zero in [`LowerSums`] (a sum that starts at `+0` stays as it is), so row `r`
/// of panel `P` is still its panel's `f32` sum over the inputs `j` up to the end of `P`'s rows,
/// `j` ascending, then lane `j mod 8` of its partial sums over the inputs in later panels, `j`
/// ascending, added pairwise (test
/// `a_product_by_few_inputs_has_the_bits_of_the_streamed_one`). Input `j` of panel `Q` meets
/// the rows of panel `Q` and later ones in column `j` of each (its lanes side by side), and the
/// rows before `Q` in lane `j - Q LANES` of panel `Q`'s columns (a stride of [`LANES`]). On a
/// `paper` shard's sub-cell solves (about 500 sub-cells) a third of the products are by the
/// conjugate gradient's jumps, five inputs on average.
struct SparseLowerSums<'a> {
    panels: &'a [f32],
    inputs: &'a [(usize, f32)],
    y: &'a mut [f64],
}

impl pulp::WithSimd for SparseLowerSums<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let Self { panels, inputs, y } = self;
        let n = y.len();
        let count = n.div_ceil(LANES);
        let mut own = vec![0.0f32; count * LANES];
        let mut partial = PARTIAL_SUMS.take();
        partial.clear();
        partial.resize(n * PARTIALS, 0.0);
        for &(j, v) in inputs {
            let q = j / LANES;
            // The rows of panels `q` on: column `j` of each, `LANES` lanes side by side.
            let splat = simd.splat_f32s(v);
            for p in q..count {
                let at = lower_panel_start(p);
                let column = &panels[at + j * LANES..at + (j + 1) * LANES];
                let sums = &mut own[p * LANES..(p + 1) * LANES];
                let (column, _) = S::as_simd_f32s(column);
                let (sums, _) = S::as_mut_simd_f32s(sums);
                for (a, c) in sums.iter_mut().zip(column) {
                    *a = simd.mul_add_f32s(*c, splat, *a);
                }
            }
            // The rows before panel `q`: lane `j - q LANES` of its columns.
            let (lane, slot) = (j - q * LANES, j % PARTIALS);
            let panel = &panels[lower_panel_start(q)..];
            for r in 0..q * LANES {
                let d = &mut partial[r * PARTIALS + slot];
                *d = panel[r * LANES + lane].mul_add(v, *d);
            }
        }
        for ((y, a), d) in y.iter_mut().zip(&own).zip(partial.chunks_exact(PARTIALS)) {
            *y = f64::from(*a) + f64::from(partial_total(d));
        }
        PARTIAL_SUMS.set(partial);
    }
}

thread_local! {
    /// Each worker's partial sums of [`LowerSums`], kept between products (a solver's
    /// iterations allocate nothing).
    static PARTIAL_SUMS: std::cell::Cell<Vec<f32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The last two [`CellMatrix`]es used, handed out again while the operator's grid, the blocks
/// and the cells stay the same (the coupling rounds of a step mostly solve on the same cells;
/// a normal solve on its contact first checks the other candidates with their matrix,
/// `crate::contact::solve::normal::NormalSettings::contact_first`).
#[derive(Clone, Debug, Default)]
pub struct MatrixCache {
    /// The most recently used first.
    kept: [Option<Arc<CellMatrix>>; 2],
    /// Matrices built and handed out again.
    counts: [usize; 2],
    /// The lowest precision it builds in.
    lowest: Precision,
}

impl MatrixCache {
    /// A cache that builds its matrices in double precision up to `DOUBLE_MAX_BYTES`, else
    /// in `lowest` where that fits (`MAX_BYTES`): the default's are all double.
    pub fn down_to(lowest: Precision) -> Self {
        Self { lowest, ..Self::default() }
    }

    /// Forgets the kept matrices and the counts; the precision stays.
    pub fn clear(&mut self) {
        *self = Self { kept: [None, None], counts: [0; 2], ..*self };
    }

    /// The precision of a matrix of `blocks x blocks` components on `cells` cells: double up
    /// to `DOUBLE_MAX_BYTES`, else the lowest allowed where that fits (double where that is
    /// all it allows); `None`: none worth building.
    pub fn precision_for<const B: usize>(&self, blocks: &[[Component; B]], cells: usize) -> Option<Precision> {
        let small = CellMatrix::bytes(blocks.len(), B, cells, Precision::Double) <= DOUBLE_MAX_BYTES;
        let order = if small { [Precision::Double, self.lowest] } else { [self.lowest, Precision::Double] };
        order.into_iter().find(|&p| CellMatrix::worth_building(blocks, cells, p))
    }

    /// Matrices built and matrices handed out again so far (for tests and tuning).
    pub fn counts(&self) -> [usize; 2] {
        self.counts
    }

    /// The matrix of `op`'s `blocks` on `cells` in `precision`, built unless a kept one
    /// serves them (its own cells, or a superset: then with the cells' positions among its
    /// own).
    pub fn get<const B: usize>(
        &mut self,
        op: &Operator,
        blocks: &[[Component; B]],
        cells: &[usize],
        precision: Precision,
    ) -> (Arc<CellMatrix>, Option<Vec<usize>>) {
        for slot in 0..self.kept.len() {
            let kept = self.kept[slot].as_ref().filter(|m| m.has(op.grid(), blocks, precision));
            if let Some((m, positions)) = kept.and_then(|m| m.serves(cells).map(|p| (m.clone(), p))) {
                self.counts[1] += 1;
                self.kept[..=slot].rotate_right(1);
                return (m, positions);
            }
        }
        self.counts[0] += 1;
        let m = Arc::new(CellMatrix::in_precision(op, blocks, cells, precision));
        self.kept.rotate_right(1);
        self.kept[0] = Some(m.clone());
        (m, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::body::operator::{HalfSpace, Pairing, Product};
    use crate::contact::{Elastic, Grid};

    /// A compressible half-space on a 9 x 7 grid of 0.3 mm cells.
    fn op() -> Operator {
        let material = Elastic::from_young(0.3, 0.436);
        Operator::new(
            &HalfSpace { material, pairing: Pairing::RigidIndenter },
            Grid { nx: 9, ny: 7, cell_mm: 0.3, centre_mm: [0.0, 0.0] },
        )
    }

    /// The shear's blocks: a symmetric matrix.
    const SHEAR_BLOCKS: [[Component; 2]; 2] = [[Component::Xx, Component::Xy], [Component::Xy, Component::Yy]];

    /// [`op`], its cells, and the shear's single matrix on all of them (its lower panels).
    fn lower_shear_matrix() -> (Operator, usize, CellMatrix) {
        let op = op();
        let n = op.grid().len();
        let cells: Vec<usize> = (0..n).collect();
        let matrix = CellMatrix::in_precision(&op, &SHEAR_BLOCKS, &cells, Precision::Single);
        (op, n, matrix)
    }

    fn field(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect()
    }

    #[test]
    fn cell_matrix_product_equals_operator_dense_product() {
        let op = op();
        let n = op.grid().len();
        // Scattered cells (not a multiple of the panel height), some tractions zero.
        let cells: Vec<usize> = (0..n).filter(|k| k % 3 != 1).collect();
        let (mut qx, qy) = (field(n, 1), field(n, 2));
        for k in (0..n).step_by(5) {
            qx[k] = 0.0;
        }
        let blocks = [[Component::Xx, Component::Xy], [Component::Xy, Component::Yy], [Component::Zx, Component::Zy]];
        let matrix = CellMatrix::new(&op, &blocks, &cells);
        let (mut ux, mut uy, mut uz) = (vec![7.0; n], vec![7.0; n], vec![7.0; n]);
        // Packed by input blocks in, by output blocks out, the cells in their order.
        let packed: Vec<f64> = [&qx, &qy].iter().flat_map(|q| cells.iter().map(|&k| q[k])).collect();
        let mut out = vec![0.0; blocks.len() * cells.len()];
        matrix.apply(&packed, &mut out);
        for (field, block) in [&mut ux, &mut uy, &mut uz].into_iter().zip(out.chunks_exact(cells.len())) {
            for (&k, v) in cells.iter().zip(block) {
                field[k] = *v;
            }
        }
        for (block, got) in blocks.iter().zip([&ux, &uy, &uz]) {
            let mut want = vec![7.0; n];
            let terms = [(block[0], qx.as_slice()), (block[1], qy.as_slice())];
            op.apply(&terms, &mut want, Product::Dense { src: &cells, dst: &cells });
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for k in 0..n {
                if cells.contains(&k) {
                    assert!((got[k] - want[k]).abs() <= 1e-14 * scale, "cell {k}: {} vs {}", got[k], want[k]);
                } else {
                    assert_eq!(got[k], 7.0, "cell {k} off the set is left untouched");
                }
            }
        }
    }

    /// A kept matrix on a superset of a solve's cells serves it ([`SUPERSET_RATIO`]): its
    /// products are the same bits as those of the cells' own matrix, and the cache builds
    /// nothing for it; a set with cells outside, or too small a share of it, gets its own.
    #[test]
    fn a_superset_matrix_gives_the_bits_of_the_cells_own() {
        let op = op();
        let n = op.grid().len();
        let blocks = [[Component::Xx, Component::Xy], [Component::Xy, Component::Yy]];
        let big: Vec<usize> = (0..n).filter(|k| k % 7 != 3).collect();
        let cells: Vec<usize> = big.iter().copied().filter(|k| k % 11 != 5).collect();
        assert!(cells.len() < big.len() && big.len() as f64 <= SUPERSET_RATIO * cells.len() as f64);
        let mut x = field(2 * cells.len(), 4);
        x[3] = 0.0;
        let mut cache = MatrixCache::default();
        let _ = cache.get(&op, &blocks, &big, Precision::Double);
        let shared = CellProduct::new(&op, &blocks, &cells, 300, &mut cache);
        assert_eq!(cache.counts(), [1, 1], "the superset's matrix is handed out");
        let own = CellProduct::new(&op, &blocks, &cells, 300, &mut MatrixCache::default());
        let (mut a, mut b) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        shared.apply(None, &x, &mut a);
        own.apply(None, &x, &mut b);
        assert_eq!(
            a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        // A cell outside the kept set, and a set too small beside it: built anew.
        let outside: Vec<usize> = (0..n).filter(|k| k % 7 != 2).collect();
        let _ = CellProduct::new(&op, &blocks, &outside, 300, &mut cache);
        let few: Vec<usize> = outside.iter().copied().take(outside.len() / 2).collect();
        let _ = CellProduct::new(&op, &blocks, &few, 300, &mut cache);
        assert_eq!(cache.counts(), [3, 1]);
    }

    /// Single precision ([`Precision::Single`]): every row within its rounding of the double
    /// matrix's (a few `1e-7` of the row's largest sum here, bounded at `1e-5`), the same
    /// bits on a second product, zero inputs skipped; a cache that allows single builds double
    /// up to [`DOUBLE_MAX_BYTES`] and single above, and the precision follows the solver's
    /// tolerance.
    #[test]
    fn a_single_precision_matrix_is_within_its_rounding_of_the_double_one() {
        let op = op();
        let n = op.grid().len();
        let cells: Vec<usize> = (0..n).filter(|k| k % 4 != 2).collect();
        let blocks = [[Component::Xx, Component::Xy], [Component::Xy, Component::Yy]];
        let mut x = field(2 * cells.len(), 5);
        x[7] = 0.0;
        let double = CellMatrix::new(&op, &blocks, &cells);
        let single = CellMatrix::in_precision(&op, &blocks, &cells, Precision::Single);
        assert_eq!((double.precision(), single.precision()), (Precision::Double, Precision::Single));
        let (mut a, mut b, mut again) = (vec![0.0; x.len()], vec![0.0; x.len()], vec![0.0; x.len()]);
        double.apply(&x, &mut a);
        single.apply(&x, &mut b);
        single.apply(&x, &mut again);
        assert_eq!(b, again);
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst > 0.0 && worst <= 1e-5 * scale, "largest difference {worst:e} of {scale:e}");
        // A cache builds double up to 256 KB (90 cells of shear), single above where it fits.
        // Single ones are symmetric here: their lower panels up to 2 MB (496 cells of shear).
        let cache = MatrixCache::down_to(Precision::Single);
        assert_eq!(cache.precision_for(&blocks, cells.len()), Some(Precision::Double));
        assert_eq!(cache.precision_for(&blocks, 90), Some(Precision::Double));
        assert_eq!(cache.precision_for(&blocks, 91), Some(Precision::Single));
        assert_eq!(cache.precision_for(&blocks, 220), Some(Precision::Single));
        assert_eq!(cache.precision_for(&blocks, 496), Some(Precision::Single));
        assert_eq!(cache.precision_for(&blocks, 497), None);
        // Double ones up to 1 MB, all of them.
        assert_eq!(MatrixCache::default().precision_for(&blocks, 220), None);
        assert_eq!(MatrixCache::default().precision_for(&[[Component::Zz]], 362), Some(Precision::Double));
        assert_eq!(MatrixCache::default().precision_for(&[[Component::Zz]], 363), None);
        let mut cache = MatrixCache::default();
        assert_eq!(cache.get(&op, &blocks, &cells, Precision::Single).0.precision(), Precision::Single);
        assert_eq!(cache.get(&op, &blocks, &cells, Precision::Double).0.precision(), Precision::Double);
        assert_eq!(cache.counts(), [2, 0], "a kept matrix serves only its own precision");
        assert_eq!(Precision::for_tolerance(1e-4), Precision::Single);
        assert_eq!(Precision::for_tolerance(1e-9), Precision::Double);
    }

    #[test]
    fn cell_matrix_skips_zero_columns_without_changing_the_sums() {
        let op = op();
        let n = op.grid().len();
        let cells: Vec<usize> = (0..n).collect();
        let matrix = CellMatrix::new(&op, &[[Component::Zz]], &cells);
        let mut x = field(n, 3);
        let mut y = vec![0.0; n];
        matrix.apply(&x, &mut y);
        // The same sums written out: row i's in column order, each term one fused
        // multiply-add.
        for (i, yi) in y.iter().enumerate() {
            let (xi, yi_) = ((i % 9) as isize, (i / 9) as isize);
            let want = (0..n).fold(0.0, |s, j| {
                op.coefficient(Component::Zz, xi - (j % 9) as isize, yi_ - (j / 9) as isize).mul_add(x[j], s)
            });
            assert_eq!(*yi, want, "row {i}");
        }
        x.iter_mut().step_by(2).for_each(|v| *v = 0.0);
        let mut sparse = vec![0.0; n];
        matrix.apply(&x, &mut sparse);
        let mut dense = vec![0.0; n];
        for (i, d) in dense.iter_mut().enumerate() {
            let (xi, yi_) = ((i % 9) as isize, (i / 9) as isize);
            *d = (0..n).filter(|j| j % 2 == 1).fold(0.0, |s, j| {
                op.coefficient(Component::Zz, xi - (j % 9) as isize, yi_ - (j / 9) as isize).mul_add(x[j], s)
            });
        }
        assert_eq!(sparse, dense);
    }

    /// A product of a symmetric single matrix by few non-zero inputs takes them one by one
    /// ([`SparseLowerSums`]) and gives the bits of the streamed product ([`LowerSums`]), on
    /// this CPU's vector unit and on none: inputs in the first, a middle and the last panel,
    /// one that rounds to zero in `f32`, and none at all.
    #[test]
    fn a_product_by_few_inputs_has_the_bits_of_the_streamed_one() {
        let (_, n, matrix) = lower_shear_matrix();
        let Panels::Lower(panels) = &matrix.panels else { panic!("a symmetric single matrix keeps its lower panels") };
        let rows = 2 * n;
        let values = field(rows, 11);
        for picked in [vec![], vec![0], vec![5, 40, 77, 125], vec![31, 32, 33, 100, 101, 110, 120], vec![64, 65]] {
            let mut x = vec![0.0; rows];
            for &j in &picked {
                x[j] = values[j];
            }
            if picked.len() == 2 {
                // Non-zero, but zero in `f32`: no term, as in the streamed product.
                x[90] = 1e-50;
            }
            let inputs = sparse_inputs(&x).expect("few inputs");
            assert_eq!(inputs.len(), picked.len());
            let mut streamed = vec![0.0; rows];
            pulp::Arch::new().dispatch(LowerSums { panels, x: &x, y: &mut streamed });
            let mut sparse = vec![0.0; rows];
            pulp::Arch::new().dispatch(SparseLowerSums { panels, inputs: &inputs, y: &mut sparse });
            let mut scalar = vec![0.0; rows];
            pulp::Simd::vectorize(pulp::Scalar::new(), SparseLowerSums { panels, inputs: &inputs, y: &mut scalar });
            let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&sparse), bits(&streamed), "{picked:?}");
            assert_eq!(bits(&scalar), bits(&streamed), "{picked:?}");
            let mut applied = vec![0.0; rows];
            matrix.apply(&x, &mut applied);
            assert_eq!(bits(&applied), bits(&streamed), "{picked:?}");
        }
        // Too many inputs for one by one: the streamed product.
        assert!(sparse_inputs(&values).is_none());
    }

    /// The symmetric single matrices (the shear's and the normal's at the model's tolerances)
    /// keep only their lower panels, and every row's sum is the one [`LowerSums`] writes down:
    /// its panel's `f32` sum in column order, then eight partial sums, lane by lane and panel
    /// after panel, added pairwise. Written out here one lane at a time, as a CPU without AVX2
    /// runs it: the same bits as the vector unit's.
    #[test]
    fn a_symmetric_single_matrix_keeps_its_lower_panels_and_sums_them_as_written() {
        let (op, n, matrix) = lower_shear_matrix();
        let cells: Vec<usize> = (0..n).collect();
        let blocks = SHEAR_BLOCKS;
        let Panels::Lower(panels) = &matrix.panels else { panic!("a symmetric single matrix keeps its lower panels") };
        let rows = 2 * n;
        let stored: usize = (0..rows.div_ceil(LANES)).map(|p| ((p + 1) * LANES).min(rows)).sum();
        assert_eq!(panels.len(), stored * LANES);
        assert!(4 * panels.len() < 3 * rows * rows, "about half the full matrix's coefficients");
        // Packed row `r` and column `c`: the coefficient rounded to `f32`.
        let coefficient = |r: usize, c: usize| -> f32 {
            let (i, j) = (cells[r % n], cells[c % n]);
            let (dx, dy) = ((i % 9) as isize - (j % 9) as isize, (i / 9) as isize - (j / 9) as isize);
            op.coefficient(blocks[r / n][c / n], dx, dy) as f32
        };
        let mut x = field(rows, 9);
        // Zero inputs: single columns, and the whole of the third panel.
        x[3] = 0.0;
        x[40] = 0.0;
        x[64..96].fill(0.0);
        let mut y = vec![0.0; rows];
        matrix.apply(&x, &mut y);
        // The scalar fallback, whatever this CPU has.
        let mut scalar = vec![0.0; rows];
        pulp::Simd::vectorize(pulp::Scalar::new(), LowerSums { panels, x: &x, y: &mut scalar });
        assert_eq!(scalar, y);
        let input = |r: usize| if r < rows { x[r] as f32 } else { 0.0 };
        for (r, got) in y.iter().enumerate() {
            let own = r / LANES;
            let end = ((own + 1) * LANES).min(rows);
            let sum = (0..end).filter(|&c| x[c] != 0.0).fold(0.0f32, |s, c| coefficient(r, c).mul_add(x[c] as f32, s));
            let mut d = [0.0f32; PARTIALS];
            for q in own + 1..rows.div_ceil(LANES) {
                if (q * LANES..q * LANES + LANES).all(|k| input(k) == 0.0) {
                    continue;
                }
                for k in 0..LANES / PARTIALS {
                    for (l, d) in d.iter_mut().enumerate() {
                        let row = q * LANES + k * PARTIALS + l;
                        let c = if row < rows { coefficient(row, r) } else { 0.0 };
                        *d = c.mul_add(input(row), *d);
                    }
                }
            }
            let tail = ((d[0] + d[4]) + (d[2] + d[6])) + ((d[1] + d[5]) + (d[3] + d[7]));
            assert_eq!(*got, f64::from(sum) + f64::from(tail), "row {r}");
        }
    }
}
