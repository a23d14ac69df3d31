//! Sub-cells along a sharp edge, for the pins (issue 31).
//!
//! A cut cell ([`crate::contact::geometry::cut`]) carries the right force for its neighbours and itself, but the
//! pins, 0.66 mm under the skin on the calibrated sensor, also see *where* in the cell it
//! acts, and on a coarse grid a cell is 1.5-2 mm wide: the dome's pressure rises several-fold
//! across it towards the contact's centre, and the edge runs at a slant through it. The edge's
//! one-dimensional profile (`pins::motion::edge_profile`) cannot place that. Here the cells next
//! to an edge are solved again at `r x r` sub-cells each (the sensor's `skin.edge_subcells`,
//! [`crate::sensor::SkinParams::edge_subcells`], 3 by default), with the coarse
//! solution around them held (a global-local step):
//! - the refined cells: every loaded cell within [`BAND_CELLS`] cells of a loaded cut cell
//!   (diagonals included);
//! - each sub-cell's initial gap is its own ray's (the engine's rays, at the sub-cell's
//!   centre), and what the coarse tractions around make it: the pressure of the cells not
//!   refined and the shear of all cells (each uniform over its cell), through the fine grid's
//!   operator summed over a cell's sub-cells ([`FineGrid`]);
//! - the sub-cells' pressures are the normal contact problem on them
//!   ([`crate::contact::solve::normal::solve`]) under the refined cells' total force (load control: the coarse
//!   solve's force stays, its rigid offset is found);
//! - each refined cell's shear follows its sub-cells' pressure (`q_s = q p_s / mean p_s`).
//!
//! The pins then see each loaded sub-cell as one point force when near (at its centre, a cut
//! one at its load point, a whole one right behind the edge where the edge's profile puts its
//! force: `cut::behind_edge_mm`), the cell's total at its centroid farther off ([`Refinement`],
//! `pins::motion::CellForces`); the solve's tractions, its report and forces are the coarse
//! ones. On the bench's three worst taps across the disk's rim, 13 cells were 0.137 / 0.077 /
//! 0.032 mm off 65 cells' pins; with 3 x 3 sub-cells 0.056 / 0.030 / 0.023, at 0.17 ms more
//! solve on such a tap (`docs/experiments/contact.md`, "Sub-cells along an edge").
//!
//! On a body with a skin (the layers' and the dome's, whose pins read the layers' tables) the
//! contact's own edge is refined too, where no stimulus edge cuts it: there the pressure stays
//! nearly flat out to the edge and drops to zero within a skin thickness, so the coarse cells
//! move the edge in steps of a cell and a pin within a skin thickness of it turns with the step.
//! The refined cells add every cell on the contact's edge (loaded, with an unloaded side
//! neighbour) and its side neighbours, loaded (inwards) and unloaded (the edge may lie in them),
//! so the sub-cells' solve places the edge. On the bench's flat taps with the dome the pins'
//! largest error against 65 cells went from 0.171 / 0.094 mm at 17 / 25 cells to 0.031 / 0.022
//! (`cargo run --release -p tacsim-sim --example grid_pins -- dome 40 flat`;
//! `docs/guide/fem.md`, "The contact grid"); with the diagonal neighbours too, within 0.002 mm
//! of that at 17-33 cells for 10% more time; with the edge's cells and their unloaded neighbours
//! alone, 0.072 / 0.028 mm (`docs/experiments/fem-dome.md`). A half-space's pressure falls as a
//! square root to the edge, and its pins are already within 0.03 mm at 17 cells: it is not
//! refined there.

use std::ops::Range;

use crate::contact::algebra::matrix::MatrixCache;
use crate::contact::algebra::precision::Precision;
use crate::contact::body::operator::{Component, Operator};
use crate::contact::geometry::cut::{Cut, CutCoupling, EdgeProfile, behind_edge_mm};
use crate::contact::geometry::grid::Grid;
use crate::contact::solve::normal::{self, Control, NormalSettings, ProductChoice};

/// How far from a loaded cut cell the refined cells reach: every loaded cell within this many
/// cells of one along both axes (a `(2 B + 1)`-cell square about it). The pins' error across
/// an edge is the normal problem's on the coarse cells near it (on the bench's rim taps
/// without friction 0.041 / 0.032 mm at 17 / 25 cells against 0.016 on flat tops), and holding
/// the coarse solution just past the cut cells' side neighbours left it there: the bench's 40
/// rim taps against 65 cells (`cargo run --release --example pin_errors -- rim 65
/// 13,17,25,33`), largest pin error 0.078 / 0.033 / 0.029 / 0.030 mm at 13 / 17 / 25 / 33 cells
/// with the side neighbours, 0.031 / 0.025 at 17 / 25 cells with `B = 2`, 0.082 / 0.029 /
/// 0.025 / 0.024 with 3: 17 cells keep every pin within 0.03 mm, the first grid under 25 to
/// (issue 31, `docs/experiments/contact.md`, "A wider band of sub-cells").
const BAND_CELLS: usize = 3;

/// A sub-cell is solved for when its initial gap is below this many coarse cell sides (a ray
/// past the edge that reaches the stimulus's side or the ground is farther).
const CANDIDATE_GAP_SIDES: f64 = 0.5;

/// Strips of the edge's profile in the fine cut cells' coupling to their neighbours (the
/// coarse grid's take [`crate::contact::geometry::cut::STRIPS`], 3): a sub-cell is a third of a cell wide, and on
/// the bench's taps across the disk's rim 2 strips move the pins' largest error against 65
/// cells by under 0.001 mm on 13-33 cells (1: 0.082 / 0.040 / 0.029 mm on 13 / 17 / 25 cells
/// against 0.088 / 0.038 / 0.028), for a quarter fewer kernel integrals (`paper`'s shard 250:
/// 3.839 -> 3.787 G instructions).
const FINE_STRIPS: usize = 2;

/// The normal components the refinement needs, in [`FineGrid::boxes`]' order: `u_z` from `p`,
/// `q_x` and `q_y`.
const BOX_COMPONENTS: [Component; 3] = [Component::Zz, Component::Zx, Component::Zy];

/// The solve's tolerance on the sub-cells' pressures (relative change, as
/// [`NormalSettings::tolerance`]) where a stimulus's edge cuts a loaded cell: looser than the
/// coarse solve's 1e-5, which moved no pin by more than 1e-3 mm on the bench's worst taps
/// across the disk's rim and took a third more iterations. At 1e-2 the dome's rim taps moved
/// by up to 0.04 mm (33 cells: 0.092 -> 0.131 mm off 65 cells; `cargo run --release -p
/// tacsim-sim --example grid_pins -- dome 40 rim`).
const TOLERANCE: f64 = 1e-3;

/// The solve's tolerance where only the contact's own edge is refined (no loaded cut cell; a
/// body with a skin): its pressure steps down smoothly and its sub-cells converge in half the
/// iterations. On the bench's flat dome taps the pins moved by at most 0.002 mm from
/// [`TOLERANCE`]'s (against 65 cells: 0.052 / 0.031 / 0.026 / 0.022 mm at 13 / 17 / 19 / 25
/// cells with 1e-3, 0.054 / 0.033 / 0.026 / 0.022 with 1e-2; `cargo run --release -p
/// tacsim-sim --example grid_pins -- dome 40 flat`), 12.3 -> 5.7 iterations and 2.08 -> 1.94 ms
/// a tap on one thread at 19 cells (`RAYON_NUM_THREADS=1 cargo run --release -p tacsim-sim
/// --example dome_taps -- 200 3 19`, 2026-12-05).
const CONTACT_EDGE_TOLERANCE: f64 = 1e-2;

/// Sub-cell rows kept of an unloaded refined cell (one beside the contact's edge), counted from
/// each loaded side neighbour: the edge moves into the first at most. On the bench's 200 flat
/// dome taps at 19 cells, 27 sub-cells of each tap's 362 in such cells ended loaded, all but 2
/// of the 5,376 in the row next to the contact; keeping that row alone (150 sub-cells a tap
/// instead of 362) left every pin within 2e-4 mm and took a tap on one thread from 2.37 to
/// 2.08 ms (`RAYON_NUM_THREADS=1 cargo run --release -p tacsim-sim --example dome_taps -- 200
/// 3 19`, 2026-12-05): the sub-cells' solve is dense, its cost the square of their number.
const OUTER_ROWS: usize = 1;

/// A coarse grid's shape `r` times finer, for every step of every path on grids of that shape:
/// the operator on the sub-cells, and the displacements of a coarse cell's uniform traction at
/// each sub-cell (the operator's tables summed over the cell's sub-cells). The operator is at
/// the cell side it was built for: a half-space's coefficients scale with the cell side, so
/// one built at 1 mm serves every grid of the shape ([`FineGrid::unit_mm`]); a layered body's
/// do not, and it is built at the grid's own side.
#[derive(Debug)]
pub(crate) struct FineGrid {
    /// Sub-cells per side of a cell.
    r: usize,
    op: Operator,
    /// Per [`BOX_COMPONENTS`], the displacement (mm/MPa) at sub-cell `(fi, fj)` of a unit
    /// traction on the coarse cell whose first sub-cell is `(si, sj)`, at the offset
    /// `(dx, dy) = (fi - si, fj - sj)`: row-major from `(-(N - r), -(M - r))`, `2 N - r` wide
    /// (`N x M` sub-cells).
    boxes: Vec<[f64; 3]>,
}

impl FineGrid {
    /// The sub-cells of grids of `nx x ny` cells, `r` a side; `op` the operator on them (a
    /// grid of `r nx x r ny` cells, any side).
    pub(crate) fn new(nx: usize, ny: usize, r: usize, op: Operator) -> Self {
        let fine = *op.grid();
        assert!(fine.nx == r * nx && fine.ny == r * ny, "the operator's grid is the sub-cells'");
        let (n, m) = (fine.nx as isize, fine.ny as isize);
        let ri = r as isize;
        let (wx, wy) = (2 * n - ri, 2 * m - ri);
        let boxes = BOX_COMPONENTS.map(|c| {
            let table = op.table(c);
            let tx = (2 * n - 1) as usize;
            // Along x first (every table row), then along y.
            let rows = (2 * m - 1) as usize;
            let mut along_x = vec![0.0; wx as usize * rows];
            for row in 0..rows {
                let line = &table[row * tx..(row + 1) * tx];
                for col in 0..wx as usize {
                    // Offset `dx = col - (n - r)`; the table's `dx - a` sits at `dx - a + n - 1`.
                    let at = col + ri as usize - 1;
                    along_x[row * wx as usize + col] = line[at + 1 - r..=at].iter().sum();
                }
            }
            let mut out = vec![0.0; (wx * wy) as usize];
            for row in 0..wy as usize {
                let at = row + ri as usize - 1;
                for b in 0..r {
                    let src = &along_x[(at - b) * wx as usize..(at - b + 1) * wx as usize];
                    for (o, v) in out[row * wx as usize..(row + 1) * wx as usize].iter_mut().zip(src) {
                        *o += v;
                    }
                }
            }
            out
        });
        // Interleaved, the three components of an offset side by side: the refinement's sum
        // over the held cells reads one place per cell instead of three tables.
        let boxes = (0..boxes[0].len()).map(|i| [boxes[0][i], boxes[1][i], boxes[2][i]]).collect();
        Self { r, op, boxes }
    }

    /// Millimetres per unit of the operator's lengths for a coarse grid of cell side
    /// `cell_mm`; also the factor from the operator's coefficients to that grid's (a
    /// half-space's scale with the cell side; 1 where it was built for that grid).
    fn unit_mm(&self, cell_mm: f64) -> f64 {
        cell_mm / self.r as f64 / self.op.grid().cell_mm
    }
}

/// The fine grids of a model's paths ([`FineGrid`]), shared by its simulations: a half-space's
/// per grid shape, a layered body's per shape and cell side (the last [`KEPT`] of them). A
/// clone of the model starts with none.
#[derive(Debug, Default)]
pub(crate) struct FineGrids(std::sync::Mutex<Vec<(FineKey, std::sync::Arc<FineGrid>)>>);

/// A fine grid's shape, sub-cells and cell side (its bits).
type FineKey = (usize, usize, usize, u64);

/// Fine grids kept per model. A layered body's are per cell side, and a run's taps share a few
/// dozen sides (`crate::contact::body::kept`): with 8 the bench's 200 dome taps over 9 sides
/// built one for nearly every refinement. A fine grid's dense products make no spectra: the
/// edge recipe with the dome (61 sides) peaked at 178 MB with 64 kept against 175 MB without
/// the contact's edge refined.
const KEPT: usize = 64;

impl Clone for FineGrids {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl FineGrids {
    /// The fine grid of `coarse` at `r` sub-cells a side; `scale_free` when the operator's
    /// coefficients scale with the cell side (a half-space), `operator` builds one on a grid.
    pub(crate) fn get(
        &self,
        coarse: &Grid,
        r: usize,
        scale_free: bool,
        operator: impl FnOnce(Grid) -> Operator,
    ) -> std::sync::Arc<FineGrid> {
        let side = if scale_free { 1.0 } else { coarse.cell_mm / r as f64 };
        let key = (coarse.nx, coarse.ny, r, side.to_bits());
        let mut kept = self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, f)) = kept.iter().find(|(k, _)| *k == key) {
            return f.clone();
        }
        let grid = Grid { nx: r * coarse.nx, ny: r * coarse.ny, cell_mm: side, centre_mm: [0.0; 2] };
        let fine = std::sync::Arc::new(FineGrid::new(coarse.nx, coarse.ny, r, operator(grid)));
        if kept.len() == KEPT {
            kept.remove(0);
        }
        kept.push((key, fine.clone()));
        fine
    }
}

/// The coarse solution a refinement starts from (grid fields: MPa, and the cut cells).
pub(crate) struct Coarse<'a> {
    pub grid: &'a Grid,
    pub pressure: &'a [f64],
    pub qx: &'a [f64],
    pub qy: &'a [f64],
    pub cuts: &'a [Option<Cut>],
    /// Whether the contact's own edge is refined too (a body with a skin; module docs).
    pub contact_edge: bool,
    /// The pressure's profile across a stimulus's edge (the body's, mm).
    pub profile: EdgeProfile,
}

/// A step's refined cells: each one's loaded sub-cells as point forces (grid frame: positions
/// mm, forces `(Qx, Qy, P)` N), for the pins.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Refinement {
    /// The refined cells (coarse indices, ascending) and the range of their sub-cells' forces.
    cells: Vec<(usize, Range<usize>)>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub f: Vec<[f64; 3]>,
}

impl Refinement {
    /// The number of refined cells.
    pub(crate) fn len(&self) -> usize {
        self.cells.len()
    }

    /// The range of coarse cell `k`'s sub-cell forces, `None` when it is not refined.
    pub(crate) fn of(&self, k: usize) -> Option<Range<usize>> {
        self.cells.binary_search_by_key(&k, |(c, _)| *c).ok().map(|i| self.cells[i].1.clone())
    }
}

/// The cells a step refines (coarse indices, ascending): every loaded cell within
/// [`BAND_CELLS`] of a loaded cut cell along both axes (once the cut cells and their side
/// neighbours only: with the corners too, on the sub-cells' first version, the bench's worst
/// rim taps were 0.058 / 0.032 / 0.025 mm off 65 cells against 0.056 / 0.030 / 0.023; a wider
/// band pays where the coarse solve's error sits, past the neighbours); with
/// [`Coarse::contact_edge`], also every loaded cell with an unloaded side neighbour (an edge of
/// the contact) and its side neighbours, loaded or not. Empty where none of these is. Also
/// whether a loaded cut cell is among them.
fn refined_cells(coarse: &Coarse<'_>) -> (Vec<usize>, bool) {
    let grid = coarse.grid;
    let loaded = |k: usize| coarse.pressure[k] > 0.0;
    let loaded_cut = |k: usize| loaded(k) && coarse.cuts.get(k).is_some_and(Option::is_some);
    // The loaded cells on the contact's edge: a side neighbour unloaded or off the grid.
    let edge: Vec<bool> = (0..grid.len())
        .map(|k| coarse.contact_edge && loaded(k) && grid.sides(k).iter().any(|n| n.is_none_or(|n| !loaded(n))))
        .collect();
    let any_cut = (0..grid.len()).any(loaded_cut);
    let near_cut = |k: usize| {
        let (i, j) = grid.column_row(k);
        let near = |c: usize, n: usize| c.saturating_sub(BAND_CELLS)..(c + BAND_CELLS + 1).min(n);
        near(i, grid.nx).any(|a| near(j, grid.ny).any(|b| loaded_cut(b * grid.nx + a)))
    };
    let cells = (0..grid.len())
        .filter(|&k| {
            (any_cut && loaded(k) && near_cut(k)) || edge[k] || grid.sides(k).into_iter().flatten().any(|n| edge[n])
        })
        .collect();
    (cells, any_cut)
}

/// A sub-cell of a refined cell.
#[derive(Clone, Copy, Debug)]
struct Sub {
    /// Column and row on the fine grid.
    at: (usize, usize),
    /// The refined cell (coarse index).
    cell: usize,
    /// Its cut by the cell's edge, in the fine operator's units (its cell side).
    cut: Option<Cut>,
    /// A whole sub-cell's load point, offset from its centre (mm, grid frame): towards the
    /// edge for one right behind it (`cut::behind_edge_mm`), else zero.
    offset_mm: [f64; 2],
}

/// The edge's line `d + a u + b v = 0` (as [`Cut::line`]: `d` mm, `(u, v)` mm offsets from
/// the cell's centre) that crosses refined cell `cell` or the nearest of its cut neighbours
/// (sides and corners; the one whose line passes nearest the cell's centre); `None` without
/// one.
fn edge_line(coarse: &Coarse<'_>, cell: usize) -> Option<[f64; 3]> {
    let grid = coarse.grid;
    let cut = |k: usize| coarse.cuts.get(k).copied().flatten();
    if let Some(c) = cut(cell) {
        return Some(c.line);
    }
    let (i, j) = grid.column_row(cell);
    let mut nearest: Option<[f64; 3]> = None;
    for nj in j.saturating_sub(1)..(j + 2).min(grid.ny) {
        for ni in i.saturating_sub(1)..(i + 2).min(grid.nx) {
            let Some(c) = cut(nj * grid.nx + ni) else { continue };
            // The neighbour's line about this cell's centre.
            let [d, a, b] = c.line;
            let h = grid.cell_mm;
            let d = d + a * (i as f64 - ni as f64) * h + b * (j as f64 - nj as f64) * h;
            if nearest.is_none_or(|n| d.abs() < n[0].abs()) {
                nearest = Some([d, a, b]);
            }
        }
    }
    nearest
}

/// Refines the cells along the loaded cut cells of `coarse` (module docs) on the fine grid
/// `fine` gives; `gaps` gives the initial gap (mm, `+inf` where nothing can touch) at points
/// of the contact plane (grid frame, mm). `None` without a loaded cut cell, or where the
/// sub-cells' solve does not converge (the coarse placement stands). The fine grid is asked
/// for only where a cell is refined: a contact with cut cells but none loaded (a flat press
/// whose footprint reaches the dome's steep rim) builds no fine operator (issue 31: 150 M
/// instructions, once per grid shape, that a run of flat taps never used).
pub(crate) fn refine(
    fine: impl FnOnce() -> std::sync::Arc<FineGrid>,
    coarse: &Coarse<'_>,
    gaps: impl FnOnce(&[[f64; 2]]) -> Vec<f64>,
    settings: &NormalSettings,
) -> Option<Refinement> {
    let grid = coarse.grid;
    let (cells, cut) = refined_cells(coarse);
    if cells.is_empty() {
        return None;
    }
    let fine = &*fine();
    let op_grid = *fine.op.grid();
    // Lengths (mm) per unit of the fine operator's, and its coefficients' factor to the grid's.
    let unit_mm = fine.unit_mm(grid.cell_mm);
    let subs = subcells(fine, coarse, &cells);
    let points: Vec<[f64; 2]> = subs.iter().map(|s| point_mm(grid, fine.r, unit_mm, s)).collect();
    let g0 = gaps(&points);
    let limit = CANDIDATE_GAP_SIDES * grid.cell_mm;
    let refined = |k: usize| cells.binary_search(&k).is_ok();
    let (n, m, r) = (op_grid.nx as isize, op_grid.ny as isize, fine.r as isize);
    let width = 2 * n - r;
    // The coarse tractions held: the pressure of the cells not refined, all cells' shear
    // (traction, and its first sub-cell's `sj width + si`).
    let held: Vec<([f64; 3], isize)> = (0..grid.len())
        .filter_map(|k| {
            let p = if refined(k) { 0.0 } else { coarse.pressure[k] };
            let t = [p, coarse.qx[k], coarse.qy[k]];
            let (i, j) = grid.column_row(k);
            t.iter().any(|v| *v != 0.0).then_some((t, (fine.r * j) as isize * width + (fine.r * i) as isize))
        })
        .collect();
    let mut gap = vec![f64::INFINITY; op_grid.len()];
    let mut warm = vec![0.0; op_grid.len()];
    // The cut sub-cells among the candidates (fine grid indices, ascending).
    let mut cuts: Vec<(usize, Cut)> = Vec::new();
    // The sub-cells solved for, each with its place in the box tables less a held cell's
    // `sj width + si`: the held cells' displacement at each, held cell after held cell in
    // the same order for every sub-cell (the sums' bits). The held cells are the inner loop:
    // the sum stays in a register, and the places a sub-cell reads step back `r` boxes per
    // held cell along a row, a stride the prefetcher follows (with the sub-cells inside, a
    // `paper` shard spent 6.4-6.9% of its time here, mostly on loads from the tables, against
    // 3.1-3.2%).
    let chosen: Vec<(usize, isize)> = (0..subs.len())
        .filter(|&i| g0[i].is_finite() && g0[i] < limit)
        .map(|i| (i, (subs[i].at.1 as isize + m - r) * width + subs[i].at.0 as isize + n - r))
        .collect();
    for &(i, place) in &chosen {
        let u = held.iter().fold(0.0, |u, (t, shift)| {
            let b = fine.boxes[(place - shift) as usize];
            u + (b[0] * t[0] + b[1] * t[1] + b[2] * t[2])
        });
        let s = &subs[i];
        let f = s.at.1 * op_grid.nx + s.at.0;
        // In the fine operator's units: its displacements are `1 / unit_mm` of the grid's.
        gap[f] = (g0[i] + unit_mm * u) / unit_mm;
        warm[f] = coarse.pressure[s.cell];
        cuts.extend(s.cut.map(|c| (f, c)));
    }
    cuts.sort_unstable_by_key(|(f, _)| *f);
    // The sub-cells' cut coupling, among the candidates.
    let coupling = CutCoupling::new(&fine.op, &cuts, |f| gap[f].is_finite(), FINE_STRIPS);
    // The refined cells' force, as the fine operator's cell area carries it.
    let load = cells.iter().map(|&k| coarse.pressure[k]).sum::<f64>() * grid.cell_area_mm2() / (unit_mm * unit_mm);
    // Dense products on any number of sub-cells: the fine grid's FFT would transform the
    // whole footprint for a few hundred of them.
    let tolerance = if cut { TOLERANCE } else { CONTACT_EDGE_TOLERANCE };
    let settings = NormalSettings { products: ProductChoice { dense_max_cells: usize::MAX }, tolerance, ..*settings };
    let solved = normal::solve(
        &fine.op,
        &gap,
        normal::Extra { displacement: None, cut: coupling.as_ref() },
        Control::Load(load),
        Some(&warm),
        &settings,
        &mut MatrixCache::down_to(Precision::for_tolerance(tolerance)),
    );
    // The coarse placement stands where the sub-cells' solve does not converge, the one way
    // the normal solve fails (seen on a few sub-cells, all cut, under a small load, the edge
    // quick fit's taps, before the normal solve damped its steps after a stall; test
    // `a_refinement_that_does_not_converge_leaves_the_coarse_placement`).
    let sol = solved.ok()?;
    Some(forces(coarse, fine.r, unit_mm, &cells, &subs, &sol.pressure))
}

/// The sub-cells of the refined `cells` (cell after cell, row by row), each with its cut where
/// its cell's edge ([`Cut::line`]) crosses it; a sub-cell wholly past the edge is left out, and
/// of an unloaded uncut cell all but its [`OUTER_ROWS`] next to a loaded side neighbour.
fn subcells(fine: &FineGrid, coarse: &Coarse<'_>, cells: &[usize]) -> Vec<Sub> {
    let grid = coarse.grid;
    let r = fine.r;
    let side = fine.op.grid().cell_mm;
    let unit_mm = fine.unit_mm(grid.cell_mm);
    let mut subs = Vec::new();
    for &cell in cells {
        let (ci, cj) = grid.column_row(cell);
        let cut = coarse.cuts.get(cell).copied().flatten();
        let line = edge_line(coarse, cell);
        let kept = outer_rows(coarse, cell, r);
        for b in 0..r {
            for a in 0..r {
                if !kept(a, b) {
                    continue;
                }
                let offset_mm =
                    [(a as f64 + 0.5) / r as f64 - 0.5, (b as f64 + 0.5) / r as f64 - 0.5].map(|o| o * grid.cell_mm);
                // The edge's line at the sub-cell's centre (the cell's own where it is cut).
                let at = line.map(|[d, da, db]| (d + da * offset_mm[0] + db * offset_mm[1], [da, db]));
                let sub_cut = match (cut, at) {
                    (Some(_), Some((d, [da, db]))) => {
                        match Cut::of_half_plane(side, d / unit_mm, da, db, coarse.profile.in_units(unit_mm)) {
                            Some(sub) => Some(sub),
                            // Wholly past the edge.
                            None if d > 0.0 => continue,
                            None => None,
                        }
                    }
                    _ => None,
                };
                let offset_mm = match (sub_cut, at) {
                    (None, Some((d, slope))) => behind_edge_mm(d, slope, grid.cell_mm / r as f64, coarse.profile),
                    _ => [0.0; 2],
                };
                subs.push(Sub { at: (r * ci + a, r * cj + b), cell, cut: sub_cut, offset_mm });
            }
        }
    }
    subs
}

/// Whether sub-cell `(a, b)` (column and row in the cell, `r` a side) of refined cell `cell`
/// is kept: every one of a loaded or cut cell, of an unloaded one those within [`OUTER_ROWS`]
/// of a loaded side neighbour.
fn outer_rows(coarse: &Coarse<'_>, cell: usize, r: usize) -> impl Fn(usize, usize) -> bool {
    let whole = coarse.pressure[cell] > 0.0 || coarse.cuts.get(cell).is_some_and(Option::is_some);
    // Left, right, below, above.
    let sides = coarse.grid.sides(cell).map(|n| n.is_some_and(|n| coarse.pressure[n] > 0.0));
    let far = r.saturating_sub(OUTER_ROWS);
    move |a, b| {
        whole
            || (sides[0] && a < OUTER_ROWS)
            || (sides[1] && a >= far)
            || (sides[2] && b < OUTER_ROWS)
            || (sides[3] && b >= far)
    }
}

/// Where a sub-cell's gap is taken and its force acts (grid frame, mm): its centre offset by
/// [`Sub::offset_mm`], or a cut one's load point ([`Cut::load_point_mm`], in the fine
/// operator's units of `unit_mm`).
fn point_mm(grid: &Grid, r: usize, unit_mm: f64, sub: &Sub) -> [f64; 2] {
    let h = grid.cell_mm / r as f64;
    let [u, v] = sub.cut.map_or(sub.offset_mm, |c| c.load_point_mm().map(|o| o * unit_mm));
    let first = [0, 1].map(|a| grid.centre_mm[a] - 0.5 * h * (r * [grid.nx, grid.ny][a] - 1) as f64);
    [first[0] + sub.at.0 as f64 * h + u, first[1] + sub.at.1 as f64 * h + v]
}

/// The refined cells' sub-cell forces from the sub-cells' pressures `pressure` (a field of
/// the fine operator's grid, MPa): each cell's shear follows its sub-cells' pressure; a cell
/// the solve left unloaded keeps its shear evenly over its sub-cells.
fn forces(coarse: &Coarse<'_>, r: usize, unit_mm: f64, cells: &[usize], subs: &[Sub], pressure: &[f64]) -> Refinement {
    let grid = coarse.grid;
    let nx = r * grid.nx;
    let area = (grid.cell_mm / r as f64).powi(2);
    let p = |s: &Sub| pressure[s.at.1 * nx + s.at.0];
    let mut out = Refinement::default();
    let mut rest = subs;
    for &cell in cells {
        let count = rest.iter().take_while(|s| s.cell == cell).count();
        let (own, next) = rest.split_at(count);
        rest = next;
        let start = out.f.len();
        let total: f64 = own.iter().map(p).sum();
        for s in own {
            let share = (r * r) as f64 * if total > 0.0 { p(s) / total } else { 1.0 / count as f64 };
            let t = [coarse.qx[cell] * share, coarse.qy[cell] * share, p(s)];
            if t.iter().all(|v| *v == 0.0) {
                continue;
            }
            let [x, y] = point_mm(grid, r, unit_mm, s);
            out.x.push(x);
            out.y.push(y);
            out.f.push(t.map(|v| v * area));
        }
        out.cells.push((cell, start..out.f.len()));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::body::kernel::Elastic;
    use crate::contact::body::operator::{HalfSpace, Pairing};

    /// A step's coarse solution with no shear unless given, the half-space's edge profile.
    fn coarse_of<'a>(
        grid: &'a Grid,
        pressure: &'a [f64],
        shear: &'a [f64],
        cuts: &'a [Option<Cut>],
        contact_edge: bool,
    ) -> Coarse<'a> {
        Coarse { grid, pressure, qx: shear, qy: shear, cuts, contact_edge, profile: EdgeProfile::SINGULAR }
    }

    fn half_space(grid: Grid) -> Operator {
        let material = Elastic::from_young(1.0, 0.436);
        Operator::new(&HalfSpace { material, pairing: Pairing::RigidIndenter }, grid)
    }

    /// With the contact's edge refined (a body with a skin), a 5 x 5 loaded block in a 9 x 9
    /// grid refines its rim, the cells beside it inside (all but the centre) and the unloaded
    /// cells beside it outside (not past its corners); without, and no cut, nothing.
    #[test]
    fn the_contacts_own_edge_is_refined_with_its_unloaded_side_neighbours() {
        let grid = Grid { nx: 9, ny: 9, cell_mm: 1.0, centre_mm: [0.0; 2] };
        let block = |i: usize, j: usize| (2..=6).contains(&i) && (2..=6).contains(&j);
        let pressure: Vec<f64> =
            (0..grid.len()).map(|k| grid.column_row(k)).map(|(i, j)| if block(i, j) { 0.1 } else { 0.0 }).collect();
        let (zero, cuts) = (vec![0.0; grid.len()], vec![None; grid.len()]);
        let coarse = |contact_edge| coarse_of(&grid, &pressure, &zero, &cuts, contact_edge);
        assert_eq!(refined_cells(&coarse(false)), (vec![], false));
        let (cells, cut) = refined_cells(&coarse(true));
        assert!(!cut);
        let at = |i: usize, j: usize| j * grid.nx + i;
        let beside = |i: usize, j: usize| {
            !block(i, j)
                && [(i + 1, j), (i.wrapping_sub(1), j), (i, j + 1), (i, j.wrapping_sub(1))]
                    .iter()
                    .any(|&(a, b)| block(a, b))
        };
        let expected: Vec<usize> = (0..grid.len())
            .filter(|&k| {
                let (i, j) = grid.column_row(k);
                (block(i, j) && (i, j) != (4, 4)) || beside(i, j)
            })
            .collect();
        assert_eq!(cells, expected);
        assert_eq!(cells.len(), 24 + 20);
        assert!(!cells.contains(&at(4, 4)) && !cells.contains(&at(1, 1)) && cells.contains(&at(1, 4)));
    }

    /// Of an unloaded cell beside the contact (a 5 x 5 loaded block in a 9 x 9 grid, its edge
    /// refined) only the row of sub-cells next to its loaded neighbour is kept; a loaded cell
    /// keeps all of its own. A loaded cut cell among the refined ones is reported (the
    /// sub-cells' solve then takes the tighter tolerance).
    #[test]
    fn an_unloaded_cell_beside_the_contact_keeps_the_subcells_next_to_it() {
        let (n, r) = (9, 3);
        let grid = Grid { nx: n, ny: n, cell_mm: 1.0, centre_mm: [0.0; 2] };
        let fine = FineGrid::new(n, n, r, half_space(Grid { nx: r * n, ny: r * n, cell_mm: 1.0, centre_mm: [0.0; 2] }));
        let block = |i: usize, j: usize| (2..=6).contains(&i) && (2..=6).contains(&j);
        let pressure: Vec<f64> =
            (0..grid.len()).map(|k| grid.column_row(k)).map(|(i, j)| if block(i, j) { 0.1 } else { 0.0 }).collect();
        let (zero, mut cuts) = (vec![0.0; grid.len()], vec![None; grid.len()]);
        let coarse = coarse_of(&grid, &pressure, &zero, &cuts, true);
        let (cells, cut) = refined_cells(&coarse);
        assert!(!cut);
        let subs = subcells(&fine, &coarse, &cells);
        let count = |cell: usize| subs.iter().filter(|s| s.cell == cell).count();
        for &cell in &cells {
            let (i, j) = grid.column_row(cell);
            assert_eq!(count(cell), if block(i, j) { r * r } else { r }, "cell ({i}, {j})");
        }
        // Left of the block: the sub-cells' column next to it, every row.
        let left = 4 * n + 1;
        let kept: Vec<(usize, usize)> = subs.iter().filter(|s| s.cell == left).map(|s| s.at).collect();
        assert_eq!(kept, vec![(5, 12), (5, 13), (5, 14)]);
        cuts[4 * n + 4] = Cut::of_half_plane(1.0, 0.1, 0.8, 0.6, EdgeProfile::SINGULAR);
        let coarse = coarse_of(&grid, &pressure, &zero, &cuts, true);
        assert!(refined_cells(&coarse).1, "a loaded cut cell");
    }

    /// A coarse cell's box coefficient is the sum of the fine operator's coefficients over its
    /// sub-cells, at every sub-cell of the grid, for the three components.
    #[test]
    fn a_cells_box_sums_its_subcells() {
        let (nx, ny, r) = (4, 3, 3);
        let fine =
            FineGrid::new(nx, ny, r, half_space(Grid { nx: r * nx, ny: r * ny, cell_mm: 0.4, centre_mm: [0.0; 2] }));
        let g = *fine.op.grid();
        let (n, m, ri) = (g.nx as isize, g.ny as isize, r as isize);
        for (ci, cj) in (0..nx).flat_map(|i| (0..ny).map(move |j| (i, j))) {
            for f in 0..g.len() {
                let (fi, fj) = g.column_row(f);
                for (c, comp) in BOX_COMPONENTS.iter().enumerate() {
                    let mut direct = 0.0;
                    for (a, b) in (0..r).flat_map(|a| (0..r).map(move |b| (a, b))) {
                        let (dx, dy) = (fi as isize - (r * ci + a) as isize, fj as isize - (r * cj + b) as isize);
                        direct += fine.op.coefficient(*comp, dx, dy);
                    }
                    let (dx, dy) = (fi as isize - ri * ci as isize, fj as isize - ri * cj as isize);
                    let boxed = fine.boxes[((dy + m - ri) * (2 * n - ri) + dx + n - ri) as usize][c];
                    // Relative to the largest coefficient: the odd components cancel to 0.
                    let scale = fine.op.diagonal(Component::Zz);
                    assert!((boxed - direct).abs() <= 1e-12 * scale, "{comp:?} {ci} {cj} {f}: {boxed} vs {direct}");
                }
            }
        }
    }

    /// Where the sub-cells' normal solve does not converge (here: one iteration allowed) the
    /// step keeps the coarse placement: no refinement, and no error.
    #[test]
    fn a_refinement_that_does_not_converge_leaves_the_coarse_placement() {
        let (n, r) = (3, 3);
        let grid = Grid { nx: n, ny: n, cell_mm: 1.0, centre_mm: [0.0; 2] };
        let fine = std::sync::Arc::new(FineGrid::new(
            n,
            n,
            r,
            half_space(Grid { nx: r * n, ny: r * n, cell_mm: 1.0, centre_mm: [0.0; 2] }),
        ));
        // Every cell loaded, the middle one cut by an edge at a slant.
        let pressure = vec![0.1; n * n];
        let shear = vec![0.0; n * n];
        let mut cuts = vec![None; n * n];
        cuts[4] = Cut::of_half_plane(1.0, 0.1, 0.8, 0.6, EdgeProfile::SINGULAR);
        assert!(cuts[4].is_some());
        let coarse = coarse_of(&grid, &pressure, &shear, &cuts, false);
        // A dome's gap: deeper towards the centre.
        let gaps = |points: &[[f64; 2]]| points.iter().map(|[x, y]| 0.02 * (x * x + y * y) - 0.05).collect();
        let converged = NormalSettings::default();
        assert!(refine(|| fine.clone(), &coarse, gaps, &converged).is_some());
        let one = NormalSettings { max_iterations: 1, ..converged };
        assert_eq!(refine(|| fine.clone(), &coarse, gaps, &one), None);
    }

    /// The refinement's sub-cell centres tile each cell of the coarse grid: they average to
    /// its centre, a sub-cell side apart.
    #[test]
    fn subcells_tile_their_cell() {
        let grid = Grid { nx: 3, ny: 5, cell_mm: 2.0, centre_mm: [1.0, 0.5] };
        let r = 5;
        for k in 0..grid.len() {
            let (ci, cj) = grid.column_row(k);
            let c = grid.centre(k);
            let subs: Vec<[f64; 2]> = (0..r * r)
                .map(|s| {
                    point_mm(
                        &grid,
                        r,
                        1.0,
                        &Sub { at: (r * ci + s % r, r * cj + s / r), cell: k, cut: None, offset_mm: [0.0; 2] },
                    )
                })
                .collect();
            let mean = [0, 1].map(|a| subs.iter().map(|s| s[a]).sum::<f64>() / subs.len() as f64);
            assert!((mean[0] - c[0]).abs() < 1e-12 && (mean[1] - c[1]).abs() < 1e-12, "{k}: {mean:?} {c:?}");
            assert!((subs[1][0] - subs[0][0] - 0.4).abs() < 1e-12 && (subs[r][1] - subs[0][1] - 0.4).abs() < 1e-12);
        }
    }
}
