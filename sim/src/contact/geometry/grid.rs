//! The contact grid: square cells on the contact plane (the plane tangent to the undeformed dome
//! at the apex of the path's [`crate::contact::geometry::frame::ContactFrame`]), in that frame's `(x, y)` axes (the
//! sensor's for an untilted path).
//!
//! Cell `(i, j)` (column `i` along `x`, row `j` along `y`) has its centre at
//! `centre_mm + ((i - (nx - 1)/2) h, (j - (ny - 1)/2) h)` with `h = cell_mm`; fields on the grid
//! are stored row by row, index `j * nx + i`. With odd `nx`, `ny` a cell is centred on the apex.

/// A uniform grid of square cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Cells along `x`.
    pub nx: usize,
    /// Cells along `y`.
    pub ny: usize,
    /// Cell side (mm).
    pub cell_mm: f64,
    /// Centre of the grid (mm, sensor `x, y`).
    pub centre_mm: [f64; 2],
}

impl Grid {
    /// A grid of `n x n` cells of side `cell_mm` centred at the origin.
    pub fn square(n: usize, cell_mm: f64) -> Self {
        Self { nx: n, ny: n, cell_mm, centre_mm: [0.0, 0.0] }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// Whether the grid has no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Cell area (mm^2).
    pub fn cell_area_mm2(&self) -> f64 {
        self.cell_mm * self.cell_mm
    }

    /// Column and row of cell `k`.
    pub fn column_row(&self, k: usize) -> (usize, usize) {
        (k % self.nx, k / self.nx)
    }

    /// The side neighbours of cell `k`: left (`-x`), right, below (`-y`) and above; `None` off
    /// the grid.
    pub fn sides(&self, k: usize) -> [Option<usize>; 4] {
        let (i, j) = self.column_row(k);
        [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)]
            .map(|(a, b)| (a < self.nx && b < self.ny).then(|| b * self.nx + a))
    }

    /// Centre of cell `k` (mm).
    pub fn centre(&self, k: usize) -> [f64; 2] {
        let (i, j) = self.column_row(k);
        [
            self.centre_mm[0] + (i as f64 - 0.5 * (self.nx as f64 - 1.0)) * self.cell_mm,
            self.centre_mm[1] + (j as f64 - 0.5 * (self.ny as f64 - 1.0)) * self.cell_mm,
        ]
    }

    /// Centres of all cells, in storage order.
    pub fn centres(&self) -> Vec<[f64; 2]> {
        (0..self.len()).map(|k| self.centre(k)).collect()
    }
}
