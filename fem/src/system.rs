//! The assembled stiffness of a mesh with some degrees of freedom held, and its sparse
//! Cholesky factor (faer's supernodal `L L^T`, fill-reducing AMD order).
//!
//! Degrees of freedom are `3 node + direction`; the held ones (zero displacement) are left out
//! of the system, and so are a tied node's ([`crate::Tie`]: its displacement is its masters'
//! weighted sum, its stiffness and loads go to them); the others are numbered in the same order
//! ("free" indices). The matrix is kept as its upper triangle, column by column. Every product
//! and solve here runs its columns in fixed blocks, each block on one thread: the bytes do not
//! depend on the thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use rayon::prelude::*;

use crate::element::{ElementMatrices, matrices};
use crate::error::{FemError, Result};
use crate::material::Material;
use crate::mesh::{Mesh, Region};

/// Elements whose matrices are computed together (in parallel) before they are added in
/// element order.
const ELEMENT_BATCH: usize = 2048;
/// Right-hand sides solved together on one thread.
pub const SOLVE_BLOCK: usize = 32;
const HELD: usize = usize::MAX;
const TIED: usize = usize::MAX - 1;

/// The stiffness matrix of a mesh (N/mm) over its free degrees of freedom.
#[derive(Clone)]
pub struct Stiffness {
    /// Free index of each degree of freedom (`3 x nodes`), `usize::MAX` where held.
    free: Vec<usize>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    /// Each element's volume-change row `b` (see [`crate::element`]).
    volume_change: Vec<[f64; 30]>,
    /// The tied nodes' masters (node, weight), by node; empty where a node is its own.
    ties: Vec<Vec<(usize, f64)>>,
}

impl Stiffness {
    /// Assembles the stiffness of `mesh` with each region's material; `held[d]` holds degree
    /// of freedom `d` at zero displacement.
    pub fn assemble(mesh: &Mesh, material: impl Fn(Region) -> Material + Sync, held: &[bool]) -> Result<Self> {
        Self::assemble_with(mesh, held, |e| matrices(&mesh.element_nodes(e), &material(mesh.regions[e])))
    }

    /// Assembles the element matrices `element(e)` of every element of `mesh` (the tangent of
    /// a nonlinear material, say); `held[d]` holds degree of freedom `d` at zero displacement.
    pub fn assemble_with(
        mesh: &Mesh,
        held: &[bool],
        element: impl Fn(usize) -> ElementMatrices + Sync,
    ) -> Result<Self> {
        let dofs = 3 * mesh.nodes.len();
        let mut ties: Vec<Vec<(usize, f64)>> = vec![Vec::new(); mesh.nodes.len()];
        for tie in &mesh.ties {
            if tie.masters.len() > MAX_MASTERS {
                let expected = "at most 6 masters a tied node (a face's nodes)";
                return Err(FemError::Parameter { field: "ties", value: tie.masters.len() as f64, expected });
            }
            ties[tie.node].clone_from(&tie.masters);
        }
        let mut free = vec![HELD; dofs];
        let mut free_count = 0;
        for (d, slot) in free.iter_mut().enumerate() {
            if held.get(d).copied().unwrap_or(false) {
                continue;
            }
            if ties[d / 3].is_empty() {
                *slot = free_count;
                free_count += 1;
            } else {
                *slot = TIED;
            }
        }
        // Node adjacency (a tied node's through its masters), then the upper triangle's pattern
        // column by column.
        let mut adjacent: Vec<Vec<usize>> = vec![Vec::new(); mesh.nodes.len()];
        for el in &mesh.elements {
            let own: Vec<usize> = el
                .iter()
                .flat_map(|&a| if ties[a].is_empty() { vec![a] } else { ties[a].iter().map(|m| m.0).collect() })
                .collect();
            for &a in &own {
                adjacent[a].extend_from_slice(&own);
            }
        }
        for list in &mut adjacent {
            list.sort_unstable();
            list.dedup();
        }
        let mut col_ptr = Vec::with_capacity(free_count + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (d, &fc) in free.iter().enumerate() {
            if fc >= TIED {
                continue;
            }
            for &a in &adjacent[d / 3] {
                for i in 0..3 {
                    let fr = free[3 * a + i];
                    if fr < TIED && fr <= fc {
                        row_idx.push(fr);
                    }
                }
            }
            col_ptr.push(row_idx.len());
        }
        drop(adjacent);
        let mut values = vec![0.0; row_idx.len()];
        let mut volume_change = Vec::with_capacity(mesh.elements.len());
        for start in (0..mesh.elements.len()).step_by(ELEMENT_BATCH) {
            let end = (start + ELEMENT_BATCH).min(mesh.elements.len());
            let batch: Vec<ElementMatrices> = (start..end).into_par_iter().map(&element).collect();
            for (offset, m) in batch.into_iter().enumerate() {
                let e = start + offset;
                if m.min_jacobian.is_nan() || m.min_jacobian <= 0.0 {
                    return Err(FemError::Degenerate { element: e, jacobian: m.min_jacobian });
                }
                // Each element row's free degrees of freedom and weights.
                let terms: [Terms; 30] =
                    std::array::from_fn(|r| Self::terms_of(&free, &ties, 3 * mesh.elements[e][r / 3] + r % 3));
                for (r, row) in terms.iter().enumerate() {
                    for (c, col_terms) in terms.iter().enumerate() {
                        let k = m.stiffness[r][c];
                        for &(fr, wr) in row.iter() {
                            for &(fc, wc) in col_terms.iter() {
                                if fr > fc {
                                    continue;
                                }
                                let col = &row_idx[col_ptr[fc]..col_ptr[fc + 1]];
                                if let Ok(pos) = col.binary_search(&fr) {
                                    values[col_ptr[fc] + pos] += wr * wc * k;
                                }
                            }
                        }
                    }
                }
                volume_change.push(m.volume_change);
            }
        }
        Ok(Self { free, col_ptr, row_idx, values, volume_change, ties })
    }

    /// The free degrees of freedom and weights a degree of freedom moves with: itself, none
    /// where held, its masters' where its node is tied.
    fn terms_of(free: &[usize], ties: &[Vec<(usize, f64)>], dof: usize) -> Terms {
        let mut terms = Terms::default();
        match free[dof] {
            HELD => {}
            TIED => {
                for &(n, w) in &ties[dof / 3] {
                    let f = free[3 * n + dof % 3];
                    if f < TIED {
                        terms.push(f, w);
                    }
                }
            }
            f => terms.push(f, 1.0),
        }
        terms
    }

    /// The free degrees of freedom and weights that degree of freedom `3 node + direction`
    /// moves with: itself, none where held, its masters' where its node is tied.
    pub fn terms(&self, dof: usize) -> Terms {
        Self::terms_of(&self.free, &self.ties, dof)
    }

    /// The displacement (mm) of degree of freedom `3 node + direction` in a solution over the
    /// free ones.
    pub fn value(&self, solution: &[f64], dof: usize) -> f64 {
        self.terms(dof).iter().map(|&(f, w)| w * solution[f]).sum()
    }

    /// Whether each degree of freedom (`3 node + direction`) is held.
    pub fn held(&self) -> Vec<bool> {
        self.free.iter().map(|&f| f == HELD).collect()
    }

    /// The product `K x` (N) over the free degrees of freedom, `x` in mm.
    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.size()];
        for c in 0..self.size() {
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let (r, v) = (self.row_idx[p], self.values[p]);
                y[r] += v * x[c];
                if r != c {
                    y[c] += v * x[r];
                }
            }
        }
        y
    }

    /// Adds `value` (N/mm) to the diagonal entry of free degree of freedom `free` (a spring to
    /// the ground: a penalty).
    pub fn add_to_diagonal(&mut self, free: usize, value: f64) {
        // Rows are sorted and at most the column: the diagonal is a column's last entry.
        let last = self.col_ptr[free + 1] - 1;
        debug_assert_eq!(self.row_idx[last], free);
        self.values[last] += value;
    }

    /// Free degrees of freedom (the system's size).
    pub fn size(&self) -> usize {
        self.col_ptr.len() - 1
    }

    /// Stored entries of the upper triangle.
    pub fn stored(&self) -> usize {
        self.values.len()
    }

    /// The free index of degree of freedom `3 node + direction`, `None` where held or tied
    /// (see [`Stiffness::terms`]).
    pub fn free_index(&self, dof: usize) -> Option<usize> {
        self.free.get(dof).copied().filter(|&f| f < TIED)
    }

    /// The free right-hand side (N) of nodal forces on every node (held ones dropped: the base
    /// takes them).
    pub fn load(&self, forces: &[[f64; 3]]) -> Vec<f64> {
        let mut rhs = vec![0.0; self.size()];
        for (n, f) in forces.iter().enumerate() {
            for (c, fc) in f.iter().enumerate() {
                for &(i, w) in self.terms(3 * n + c).iter() {
                    rhs[i] += w * fc;
                }
            }
        }
        rhs
    }

    /// Nodal displacements (mm) of every degree of freedom from a solution over the free ones
    /// (held ones zero).
    pub fn expand(&self, solution: &[f64]) -> Vec<[f64; 3]> {
        let mut u = vec![[0.0; 3]; self.free.len() / 3];
        for d in 0..self.free.len() {
            u[d / 3][d % 3] = self.value(solution, d);
        }
        u
    }

    /// An element's volume change (mm^3) under nodal displacements `u` (mm): `b . u_e`.
    pub fn volume_change(&self, mesh: &Mesh, e: usize, u: &[[f64; 3]]) -> f64 {
        let b = &self.volume_change[e];
        let mut v = 0.0;
        for (a, &n) in mesh.elements[e].iter().enumerate() {
            for i in 0..3 {
                v += b[3 * a + i] * u[n][i];
            }
        }
        v
    }

    fn matrix(&self) -> SparseColMatRef<'_, usize, f64> {
        let n = self.size();
        let symbolic = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        SparseColMatRef::new(symbolic, &self.values)
    }

    /// The sparse Cholesky factor.
    pub fn factor(&self) -> Result<Factor> {
        let a = self.matrix();
        let symbolic = factorize_symbolic_cholesky(
            a.symbolic(),
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| FemError::Factorisation(format!("{e:?}")))?;
        let mut values = vec![0.0; symbolic.len_val()];
        let par = Par::rayon(0);
        let mut mem = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
        symbolic
            .factorize_numeric_llt(
                &mut values,
                a,
                Side::Upper,
                LltRegularization::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| FemError::Factorisation(format!("{e:?}")))?;
        Ok(Factor { symbolic, values })
    }
}

/// Most masters a tied node has: a face's six nodes ([`crate::Tie`]).
const MAX_MASTERS: usize = 6;

/// The free degrees of freedom a degree of freedom moves with, and their weights
/// ([`Stiffness::terms`]): itself with weight 1, none where held, up to six masters where tied.
#[derive(Clone, Copy, Debug, Default)]
pub struct Terms {
    items: [(usize, f64); MAX_MASTERS],
    len: usize,
}

impl Terms {
    fn push(&mut self, free: usize, weight: f64) {
        self.items[self.len] = (free, weight);
        self.len += 1;
    }

    /// The (free index, weight) pairs.
    pub fn iter(&self) -> std::slice::Iter<'_, (usize, f64)> {
        self.items[..self.len].iter()
    }
}

/// A sparse Cholesky factor of a [`Stiffness`].
pub struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
}

impl Factor {
    /// Nonzeros of the factor `L`.
    pub fn factor_entries(&self) -> usize {
        self.values.len()
    }

    /// Solves `K X = B` in place for the columns of `rhs` (column-major, `size` rows each),
    /// [`SOLVE_BLOCK`] columns per thread.
    pub fn solve_in_place(&self, rhs: &mut [f64]) {
        let n = self.symbolic.nrows();
        if n == 0 {
            return;
        }
        rhs.par_chunks_mut(n * SOLVE_BLOCK).for_each(|block| self.solve_block(block));
    }

    /// Solves `K X = B` in place for the columns of `block` (column-major, `size` rows each) on
    /// this thread.
    pub fn solve_block(&self, block: &mut [f64]) {
        let n = self.symbolic.nrows();
        if n == 0 {
            return;
        }
        let k = block.len() / n;
        let mut mem = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
        let mat = MatMut::from_column_major_slice_mut(block, n, k);
        LltRef::<'_, usize, f64>::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            mat,
            Par::Seq,
            MemStack::new(&mut mem),
        );
    }
}
