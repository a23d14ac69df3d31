//! The normal contact problem: pressures `p >= 0` with gap `g = g0 + u_z(p) >= 0` and
//! `p g = 0`, by the constrained conjugate gradient of Polonsky & Keer (Wear 231, 1999),
//! under indentation control (the rigid approach is part of `g0`) or load control (the approach
//! is found so that the total force `h^2 sum p` equals the load).
//!
//! Only candidate cells are solved for: under indentation control the cells with `g0 < 0`
//! (outside them the gap stays open, since `u_z >= 0` under any `p >= 0`), under load control
//! every cell. Products are dense on the candidates when there are few, FFT otherwise
//! ([`ProductChoice`]).

use crate::contact::algebra::lanes::lane_sum;
use crate::contact::algebra::matrix::{CellProduct, MatrixCache};
use crate::contact::algebra::stencil::Preconditioner;
use crate::contact::body::operator::{Component, Operator};
use crate::contact::geometry::cut::CutCoupling;
use crate::error::{Result, SimError};

/// How the normal problem is driven.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Control {
    /// `g0` already holds the rigid approach (mm); find the pressures.
    Indentation,
    /// Total normal force (N); the rigid approach is found with the pressures.
    Load(f64),
}

/// When to switch from dense to FFT products, by number of candidate cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProductChoice {
    /// Dense products up to this many candidate cells, FFT above; see [`DENSE_MAX_CELLS`].
    /// A matrix of the candidates serves them at any size where it fits (`CellMatrix`),
    /// unless this is 0: FFT products only.
    pub dense_max_cells: usize,
}

/// The measured crossover between dense and FFT products (cells).
/// `cargo bench -p tacsim-sim --bench contact` on the 2-core development machine: 225 candidate
/// cells dense 8.6 us vs FFT 10.3 us per product; 349 cells 17.4 vs 10.5 us; 489 cells 30.7 vs
/// 16.5 us.
pub const DENSE_MAX_CELLS: usize = 300;

impl Default for ProductChoice {
    fn default() -> Self {
        Self { dense_max_cells: DENSE_MAX_CELLS }
    }
}

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalSettings {
    /// Stop when `sum |p_new - p_old| / sum p` falls below this.
    pub tolerance: f64,
    /// Give up after this many iterations.
    pub max_iterations: usize,
    /// Dense or FFT products.
    pub products: ProductChoice,
    /// The warm start's contact is expected to hold (a coupling round after the first): solve
    /// on its cells alone first, then check the other candidates' gaps with one product
    /// ([`Problem::on_contact_first`]).
    pub contact_first: bool,
}

impl Default for NormalSettings {
    fn default() -> Self {
        Self { tolerance: 1e-10, max_iterations: 2000, products: ProductChoice::default(), contact_first: false }
    }
}

/// Result of a normal solve; fields are grid fields (see [`crate::contact::geometry::grid::Grid`]).
#[derive(Clone, Debug, PartialEq)]
pub struct NormalSolution {
    /// Contact pressure per cell (MPa), zero off contact.
    pub pressure: Vec<f64>,
    /// Gap after deformation per candidate cell (mm); `f64::INFINITY` off the candidates.
    pub gap: Vec<f64>,
    /// Rigid approach added to `g0` under load control (mm, positive closes the gap); 0 under
    /// indentation control.
    pub approach_mm: f64,
    /// Total normal force (N).
    pub force_n: f64,
    /// Iterations used.
    pub iterations: usize,
}

impl NormalSolution {
    /// Indices of the cells in contact (`p > 0`).
    pub fn contact_cells(&self) -> Vec<usize> {
        self.pressure.iter().enumerate().filter(|(_, p)| **p > 0.0).map(|(k, _)| k).collect()
    }
}

/// What adds to the gap besides the pressures' displacement through the operator.
#[derive(Clone, Copy, Debug, Default)]
pub struct Extra<'a> {
    /// A normal displacement per cell (mm, e.g. from tangential tractions).
    pub displacement: Option<&'a [f64]>,
    /// The cells an edge cuts ([`crate::contact::geometry::cut`]): their own compliance beyond the operator's
    /// diagonal, and their coupling to the cells next to them.
    pub(crate) cut: Option<&'a CutCoupling>,
}

/// Solves for the pressures. `g0` is the gap per cell (mm, `+inf` where nothing can touch),
/// `extra` what else adds to the gap ([`Extra`]), `warm` a
/// starting pressure field (MPa). The stages: the candidate cells ([`Problem::new`]), the
/// start (warm or a Jacobi guess, [`Problem::start`]), with [`NormalSettings::contact_first`]
/// a solve on the start's contact ([`Problem::on_contact_first`]), then the constrained
/// conjugate gradient to convergence ([`Problem::conjugate_gradient`]) and the gaps
/// ([`Problem::finish`]). Dense products go through
/// `cache` ([`MatrixCache`]).
pub fn solve(
    op: &Operator,
    g0: &[f64],
    extra: Extra<'_>,
    control: Control,
    warm: Option<&[f64]>,
    settings: &NormalSettings,
    cache: &mut MatrixCache,
) -> Result<NormalSolution> {
    let problem = Problem::new(op, g0, extra.displacement, control, settings);
    if problem.candidates.is_empty() || matches!(control, Control::Load(l) if l <= 0.0) {
        return Ok(problem.unloaded());
    }
    let mut pressure = problem.start(warm);
    let mut iterations = 0;
    if settings.contact_first {
        match problem.on_contact_first(pressure, extra.cut, cache)? {
            ContactFirst::Solved(solution) => return Ok(solution),
            ContactFirst::GoOn(p, used) => (pressure, iterations) = (p, used),
        }
    }
    let product = problem.product(cache).with_cut(extra.cut);
    let (pressure, more) = problem.conjugate_gradient(pressure, &product)?;
    let mut u = vec![0.0; pressure.len()];
    problem.displacement(&pressure, &product, &mut u);
    Ok(problem.finish(pressure, iterations + more, &u))
}

/// Iterations without a new smallest residual after which the conjugate gradient turns to
/// damped steepest descent ([`Problem::conjugate_gradient`]). No `paper` solve (shard 250)
/// stalls so long, and 2 of `edge-2d`'s (their images the same); it is for the few contact
/// sets a full step keeps swapping.
const STALL_ITERATIONS: usize = 20;

/// Iterations after which the conjugate gradient takes the displacement from a whole product
/// again instead of its update in place, so that the updates' rounding does not build up.
const REFRESH_ITERATIONS: usize = 10;

/// What a solve on the start's contact first ([`Problem::on_contact_first`]) leaves.
enum ContactFirst {
    /// No other candidate overlaps: the solution.
    Solved(NormalSolution),
    /// The pressures to go on from over all the candidates, and the iterations used so far.
    GoOn(Vec<f64>, usize),
}

/// The normal block: `u_z` from `p`.
const NORMAL_BLOCK: [[Component; 1]; 1] = [[Component::Zz]];

/// One normal solve's fixed data; vectors on the candidates are packed in their order.
struct Problem<'a> {
    op: &'a Operator,
    control: Control,
    settings: &'a NormalSettings,
    /// Grid cells.
    n: usize,
    /// The cells solved for: where `g0 + extra < 0` under indentation control, every finite
    /// one under load control.
    candidates: Vec<usize>,
    /// `g0 + extra` on the candidates (mm).
    base: Vec<f64>,
    /// Cell area (mm^2).
    area: f64,
}

impl<'a> Problem<'a> {
    fn new(
        op: &'a Operator,
        g0: &[f64],
        extra: Option<&[f64]>,
        control: Control,
        settings: &'a NormalSettings,
    ) -> Self {
        let n = op.grid().len();
        let at = |k: usize| g0[k] + extra.map_or(0.0, |e| e[k]);
        let candidates: Vec<usize> = match control {
            Control::Indentation => (0..n).filter(|&k| at(k) < 0.0).collect(),
            Control::Load(_) => (0..n).filter(|&k| at(k).is_finite()).collect(),
        };
        let base = candidates.iter().map(|&k| at(k)).collect();
        Self { op, control, settings, n, candidates, base, area: op.grid().cell_area_mm2() }
    }

    /// `A_zz` on the candidates (the matrix through `cache`).
    fn product(&self, cache: &mut MatrixCache) -> CellProduct<'_, 1> {
        CellProduct::new(self.op, &NORMAL_BLOCK, &self.candidates, self.settings.products.dense_max_cells, cache)
    }

    /// Where the start's contact is a proper part of the candidates: the problem on its cells
    /// alone (the products on the contact's block: a 25-cell tap's 213 contact cells of 385
    /// candidates, a matrix a third the size), then one product of its pressures on all the
    /// candidates. No other candidate overlapping: the solution, its gaps from that product.
    /// Else the pressures to go on from over all the candidates, and the iterations used.
    fn on_contact_first(
        &self,
        pressure: Vec<f64>,
        cut: Option<&CutCoupling>,
        cache: &mut MatrixCache,
    ) -> Result<ContactFirst> {
        let inside: Vec<usize> = (0..pressure.len()).filter(|&i| pressure[i] > 0.0).collect();
        if inside.is_empty() || inside.len() == pressure.len() {
            return Ok(ContactFirst::GoOn(pressure, 0));
        }
        let contact = Problem {
            candidates: inside.iter().map(|&i| self.candidates[i]).collect(),
            base: inside.iter().map(|&i| self.base[i]).collect(),
            ..*self
        };
        let start = inside.iter().map(|&i| pressure[i]).collect();
        let solved = contact.conjugate_gradient(start, &contact.product(cache).with_cut(cut));
        let (packed, iterations) = match solved {
            Ok(solved) => solved,
            // Over all the candidates from the start, as without this stage.
            Err(SimError::NoConvergence { .. }) => return Ok(ContactFirst::GoOn(pressure, 0)),
            Err(e) => return Err(e),
        };
        let mut pressure = vec![0.0; self.base.len()];
        for (&i, p) in inside.iter().zip(packed) {
            pressure[i] = p;
        }
        let product = self.product(cache).with_cut(cut);
        let mut u = vec![0.0; pressure.len()];
        self.displacement(&pressure, &product, &mut u);
        let approach = self.approach(&pressure, &u);
        let overlap = (0..pressure.len()).any(|i| pressure[i] == 0.0 && u[i] + self.base[i] - approach < 0.0);
        Ok(if overlap {
            ContactFirst::GoOn(pressure, iterations)
        } else {
            ContactFirst::Solved(self.finish(pressure, iterations, &u))
        })
    }

    /// A grid field from values on the candidates, `fill` elsewhere.
    fn scatter(&self, packed: &[f64], fill: f64) -> Vec<f64> {
        let mut field = vec![fill; self.n];
        for (&k, v) in self.candidates.iter().zip(packed) {
            field[k] = *v;
        }
        field
    }

    /// No load: zero pressure, the gap as it is.
    fn unloaded(&self) -> NormalSolution {
        NormalSolution {
            pressure: vec![0.0; self.n],
            gap: self.scatter(&self.base, f64::INFINITY),
            approach_mm: 0.0,
            force_n: 0.0,
            iterations: 0,
        }
    }

    /// Under load control, scales the candidates' pressures to the load.
    /// Returns the factor (1 without).
    fn rescale_to_load(&self, pressure: &mut [f64]) -> f64 {
        if let Control::Load(load) = self.control {
            let total: f64 = pressure.iter().sum::<f64>() * self.area;
            if total > 0.0 {
                let factor = load / total;
                for p in pressure.iter_mut() {
                    *p *= factor;
                }
                return factor;
            }
        }
        1.0
    }

    /// The starting pressures on the candidates: the warm ones, else Hertz's on the overlap
    /// ([`Problem::hertz_start`]; uniform under load control), scaled to the load.
    fn start(&self, warm: Option<&[f64]>) -> Vec<f64> {
        let mut pressure = match warm {
            Some(w) => self.candidates.iter().map(|&k| w[k].max(0.0)).collect(),
            None => vec![0.0; self.candidates.len()],
        };
        if pressure.iter().all(|p| *p <= 0.0) {
            match self.control {
                Control::Indentation => self.hertz_start(&mut pressure),
                Control::Load(_) => pressure.fill(1.0),
            }
        }
        if let Control::Load(load) = self.control {
            let total: f64 = pressure.iter().sum::<f64>() * self.area;
            for p in pressure.iter_mut() {
                *p *= load / total;
            }
        }
        pressure
    }

    /// A first touch's pressures (MPa), on the candidates (their overlap `o = -(g0 + extra)`,
    /// mm): Hertz's, as if the overlap were a sphere's. A sphere pressed `d` into a half-space
    /// touches where the overlap exceeds `d / 2` (`a^2 = R d`, against the overlap's `2 R d`),
    /// with `p = p0 sqrt((o - d/2) / (d/2))` there and `p0 = (2 / pi) E* d / a`; a uniformly
    /// loaded cell's centre sinks by `c = 4 asinh(1) h / (pi E*)` per MPa (the operator's
    /// diagonal), so `p0 = (2 / pi) (4 asinh(1) / pi) (h / a) d / c`, with `a = h sqrt(N / pi)`
    /// from the `N` candidates over `d / 2`. Off a sphere it is a guess all the same, and the
    /// iterations correct it. Issue 31: the Jacobi guess it replaced (half the overlap over
    /// the diagonal) carried nine times the force on the test's paraboloid; over the
    /// bench's 200 taps on the disk's top at 25 cells the normal iterations fell 3,664 -> 2,640
    /// and over its 40 across the rim 809 -> 681 (13 / 17 / 33 cells: -25 / -24 / -32% and -13
    /// / -16 / -15%), the tangential within 0.6% (`docs/experiments/contact.md`, "A first touch from
    /// Hertz's pressure"); test `a_first_touch_starts_near_hertzs_pressure`.
    fn hertz_start(&self, pressure: &mut [f64]) {
        let depth = self.base.iter().map(|b| -b).fold(0.0, f64::max);
        let touching = self.base.iter().filter(|b| -**b > 0.5 * depth).count().max(1);
        let shape = 2.0 / std::f64::consts::PI * 4.0 * 1f64.asinh() / std::f64::consts::PI;
        let p0 = shape * (std::f64::consts::PI / touching as f64).sqrt() * depth / self.op.diagonal(Component::Zz);
        for (p, base) in pressure.iter_mut().zip(&self.base) {
            *p = p0 * ((-base - 0.5 * depth).max(0.0) / (0.5 * depth)).sqrt();
        }
    }

    /// The candidates in contact (`p > 0`): positions among them and, where the product is
    /// the operator's, grid cells.
    fn active(&self, pressure: &[f64], product: &CellProduct<'_, 1>, active: &mut Vec<usize>, cells: &mut Vec<usize>) {
        active.clear();
        active.extend((0..pressure.len()).filter(|&i| pressure[i] > 0.0));
        cells.clear();
        if !product.has_matrix() {
            cells.extend(active.iter().map(|&i| self.candidates[i]));
        }
    }

    /// Polonsky-Keer iterations from `pressure` until the relative pressure change falls
    /// below the tolerance: conjugate directions on the cells in contact, cells that overlap
    /// while unloaded re-entered (resetting the conjugacy), the mean gap removed under load
    /// control. A cut cell's change counts `1 + c / a` times (`c` its extra compliance, `a`
    /// a whole cell's own): what bounds is the change of each cell's own displacement, and a
    /// sliver's pressure moves its gap that many times more (regression test
    /// `cut_cells_close_their_gaps_as_whole_cells_do`). The directions are the gaps
    /// preconditioned by the operator's truncated inverse ([`Preconditioner`]), each tap
    /// scaled by the cells' `1 / sqrt(w_i w_j)` where cut cells make the diagonal uneven
    /// (`w = 1 + c / a`, Jacobi's part: the sub-cells along an edge of `paper`'s shard 250 at
    /// 25 cells took 11.3 iterations with it alone against 17.1 without).
    ///
    /// Where the residual finds no new low in [`STALL_ITERATIONS`] iterations the steps are
    /// halved and their conjugacy dropped (halved again at each further stall), and the
    /// residual is the change a full step would make. A full step can swap two contact sets
    /// for ever: on the edge quick fit's taps a few cut sub-cells under 0.02 N, one cell
    /// loaded while two others took turns to re-enter and leave, each at a full step's length
    /// (regression test `a_sub_cell_solve_that_swapped_two_contact_sets_converges`).
    fn conjugate_gradient(&self, mut pressure: Vec<f64>, product: &CellProduct<'_, 1>) -> Result<(Vec<f64>, usize)> {
        let base = &self.base;
        let m = base.len();
        let load_control = matches!(self.control, Control::Load(_));
        let diag = self.op.diagonal(Component::Zz);
        let weight: Option<Vec<f64>> = product.cut().map(|c| c.iter().map(|c| 1.0 + c / diag).collect());
        let (mut u, mut r, mut t, mut g) = (vec![0.0; m], vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        // The preconditioned gaps.
        let grid = self.op.grid();
        let mut preconditioner =
            Preconditioner::new(self.op.normal_stencil(), grid.nx, grid.ny, &self.candidates, weight.as_deref());
        let mut z = vec![0.0; m];
        let (mut delta, mut g_old) = (0.0, 1.0);
        let mut residual = f64::INFINITY;
        // The steps' factor: 1 until the residual stalls, halved at each stall.
        let (mut best, mut since_best, mut step) = (f64::INFINITY, 0usize, 1.0f64);
        let (mut active, mut cells) = (Vec::with_capacity(m), Vec::new());
        // The pressures' jumps off the line `p - tau t` (packed; zero elsewhere).
        let mut jump = vec![0.0; m];
        // Each candidate's change of pressure in an iteration (weighted for a cut cell).
        let mut moved = vec![0.0; m];
        for iteration in 1..=self.settings.max_iterations {
            self.active(&pressure, product, &mut active, &mut cells);
            if iteration % REFRESH_ITERATIONS == 1 {
                product.apply(Some(&cells), &pressure, &mut u);
            }
            for i in 0..m {
                g[i] = u[i] + base[i];
            }
            if load_control && !active.is_empty() {
                let g_mean = lane_sum(active.iter().map(|&i| g[i])) / active.len() as f64;
                for gi in g.iter_mut() {
                    *gi -= g_mean;
                }
            }
            preconditioner.apply(&g, &active, load_control, &mut z);
            let gg = lane_sum(active.iter().map(|&i| g[i] * z[i]));
            for i in 0..m {
                t[i] = if pressure[i] > 0.0 { z[i] + delta * (gg / g_old) * t[i] } else { 0.0 };
            }
            g_old = gg;
            product.apply(Some(&cells), &t, &mut r);
            let mut r_mean = 0.0;
            if load_control && !active.is_empty() {
                r_mean = lane_sum(active.iter().map(|&i| r[i])) / active.len() as f64;
            }
            let num = lane_sum(active.iter().map(|&i| g[i] * t[i]));
            // `r` is kept as the product (for the update of `u`); the load's mean is taken
            // off here.
            let den = lane_sum(active.iter().map(|&i| (r[i] - r_mean) * t[i]));
            let tau = if den > 0.0 { step * num / den } else { 0.0 };
            let mut overlap = false;
            let mut any_jump = false;
            for i in 0..m {
                let old = pressure[i];
                let mut p = old;
                if old > 0.0 {
                    let stepped = old - tau * t[i];
                    p = stepped.max(0.0);
                    if p != stepped {
                        jump[i] = p - stepped;
                        any_jump = true;
                    }
                } else if g[i] < 0.0 {
                    p = -tau.max(diag.recip() * 1e-3) * g[i];
                    overlap = true;
                    jump[i] = p;
                    any_jump = true;
                }
                moved[i] = match &weight {
                    Some(w) => (p - old).abs() * w[i],
                    None => (p - old).abs(),
                };
                pressure[i] = p;
            }
            let change = lane_sum(moved.iter().copied());
            delta = if overlap || step < 1.0 { 0.0 } else { 1.0 };
            // The new displacement is `u - tau A t` plus the product of the jumps off that
            // line (cells clipped to zero, cells re-entered), scaled with the pressures under
            // load control: one product of the few jumped cells instead of a whole one
            // (issue 31), a whole one every [`REFRESH_ITERATIONS`].
            for i in 0..m {
                u[i] -= tau * r[i];
            }
            if any_jump {
                cells.clear();
                if !product.has_matrix() {
                    cells.extend((0..m).filter(|&i| jump[i] != 0.0).map(|i| self.candidates[i]));
                }
                product.apply(Some(&cells), &jump, &mut r);
                for i in 0..m {
                    u[i] += r[i];
                }
                jump.fill(0.0);
            }
            let factor = self.rescale_to_load(&mut pressure);
            if factor != 1.0 {
                u.iter_mut().for_each(|u| *u *= factor);
            }
            let total = lane_sum(pressure.iter().copied());
            // A damped step's change, as the full step's would be: damping does not converge.
            residual = if total > 0.0 { change / total / step } else { 0.0 };
            if !residual.is_finite() {
                break;
            }
            if residual < self.settings.tolerance {
                return Ok((pressure, iteration));
            }
            if residual < best {
                (best, since_best) = (residual, 0);
            } else {
                since_best += 1;
                if since_best == STALL_ITERATIONS {
                    (step, since_best) = (0.5 * step, 0);
                }
            }
        }
        Err(SimError::NoConvergence { solver: "normal", iterations: self.settings.max_iterations, residual })
    }

    /// `u = A p` on the candidates.
    fn displacement(&self, pressure: &[f64], product: &CellProduct<'_, 1>, u: &mut [f64]) {
        let (mut active, mut cells) = (Vec::with_capacity(pressure.len()), Vec::new());
        self.active(pressure, product, &mut active, &mut cells);
        product.apply(Some(&cells), pressure, u);
    }

    /// Under load control, the rigid approach: the mean of `u + g0` over the cells in contact
    /// (mm); 0 under indentation control.
    fn approach(&self, pressure: &[f64], u: &[f64]) -> f64 {
        if !matches!(self.control, Control::Load(_)) {
            return 0.0;
        }
        let active = || (0..pressure.len()).filter(|&i| pressure[i] > 0.0);
        match active().count() {
            0 => 0.0,
            count => active().map(|i| u[i] + self.base[i]).sum::<f64>() / count as f64,
        }
    }

    /// The solution from converged pressures on the candidates and their displacement `u`:
    /// the gaps and, under load control, the approach taken again from the contact cells (the
    /// final rescaling changed the pressures slightly).
    fn finish(&self, pressure: Vec<f64>, iterations: usize, u: &[f64]) -> NormalSolution {
        let m = self.base.len();
        let total = lane_sum(pressure.iter().copied());
        let approach = self.approach(&pressure, u);
        let gap: Vec<f64> = (0..m).map(|i| u[i] + self.base[i] - approach).collect();
        NormalSolution {
            pressure: self.scatter(&pressure, 0.0),
            gap: self.scatter(&gap, f64::INFINITY),
            approach_mm: approach,
            force_n: total * self.area,
            iterations,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::body::operator::{HalfSpace, Pairing};
    use crate::contact::{Elastic, Grid};

    /// A paraboloid (radius 50 mm) on a compressible half-space, 33 x 33 cells of 0.09 mm.
    fn setup() -> (Operator, Grid) {
        let material = Elastic { shear_modulus_mpa: 1.0, poisson: 0.436 };
        let grid = Grid::square(33, 0.09);
        (Operator::new(&HalfSpace { material, pairing: Pairing::IdenticalBodies }, grid), grid)
    }

    fn gap(grid: &Grid, approach_mm: f64) -> Vec<f64> {
        grid.centres().iter().map(|c| (c[0] * c[0] + c[1] * c[1]) / 100.0 - approach_mm).collect()
    }

    /// A solve on the warm start's contact first ([`NormalSettings::contact_first`]) ends at
    /// the plain solve's pressures: where that contact holds (the same press again, a
    /// shallower one whose contact shrinks, the same force under load control) and where it
    /// grows (a deeper press, a larger load: the check finds the ring outside overlapping and
    /// the solve goes on over all the candidates; without the check the ring would stay
    /// unloaded).
    #[test]
    fn a_solve_on_the_contact_first_ends_where_the_plain_solve_does() {
        let (op, grid) = setup();
        let plain = NormalSettings { tolerance: 1e-10, ..NormalSettings::default() };
        let first = NormalSettings { contact_first: true, ..plain };
        let solve_with = |g0: &[f64], control: Control, warm: Option<&[f64]>, settings: &NormalSettings| {
            solve(&op, g0, Extra::default(), control, warm, settings, &mut MatrixCache::default())
                .expect("normal solve")
        };
        let d = 0.012;
        let start = solve_with(&gap(&grid, d), Control::Indentation, None, &plain);
        let cases = [
            ("the same press", d, None),
            ("a shallower press", 0.9 * d, None),
            ("a deeper press", 1.3 * d, None),
            ("the same force", d, Some(start.force_n)),
            ("a larger force", d, Some(1.5 * start.force_n)),
        ];
        let mut grew = 0;
        for (name, approach, load) in cases {
            let g0 = gap(&grid, approach);
            let control = load.map_or(Control::Indentation, Control::Load);
            let want = solve_with(&g0, control, Some(&start.pressure), &plain);
            let got = solve_with(&g0, control, Some(&start.pressure), &first);
            let scale = want.pressure.iter().fold(0.0f64, |m, p| m.max(*p));
            let worst = want.pressure.iter().zip(&got.pressure).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(worst <= 1e-6 * scale, "{name}: pressures {worst:e} MPa apart, of {scale:e}");
            assert_eq!(got.contact_cells(), want.contact_cells(), "{name}: the contact");
            assert!((got.force_n - want.force_n).abs() <= 1e-6 * want.force_n, "{name}: force");
            assert!((got.approach_mm - want.approach_mm).abs() <= 1e-9, "{name}: approach");
            for (a, b) in want.gap.iter().zip(&got.gap) {
                assert!(a == b || (a - b).abs() <= 1e-9, "{name}: gap {a} vs {b} mm");
            }
            grew += usize::from(want.contact_cells().len() > start.contact_cells().len());
        }
        assert_eq!(grew, 2, "two cases grow the contact beyond the start's");
    }

    /// A first touch starts from Hertz's pressure ([`Problem::hertz_start`]): on the
    /// paraboloid it carries 0.98 of the converged solve's force, its pressures 1.7% of the
    /// peak off (root mean square over the contact), where the Jacobi guess it replaced (half
    /// the overlap over each cell's own compliance) carried nine times the force, four peaks
    /// off.
    #[test]
    fn a_first_touch_starts_near_hertzs_pressure() {
        let (op, grid) = setup();
        let settings = NormalSettings { tolerance: 1e-10, ..NormalSettings::default() };
        let g0 = gap(&grid, 0.012);
        let problem = Problem::new(&op, &g0, None, Control::Indentation, &settings);
        let start = problem.scatter(&problem.start(None), 0.0);
        let solved =
            solve(&op, &g0, Extra::default(), Control::Indentation, None, &settings, &mut MatrixCache::default())
                .expect("normal solve");
        let jacobi: Vec<f64> = g0.iter().map(|g| (-g).max(0.0) / op.diagonal(Component::Zz) * 0.5).collect();
        let force = |p: &[f64]| p.iter().sum::<f64>() * grid.cell_area_mm2();
        let peak = solved.pressure.iter().fold(0.0f64, |m, p| m.max(*p));
        let rms = |p: &[f64]| {
            (p.iter().zip(&solved.pressure).map(|(a, b)| (a - b).powi(2)).sum::<f64>()
                / solved.contact_cells().len() as f64)
                .sqrt()
                / peak
        };
        let (hertz_force, jacobi_force) = (force(&start) / solved.force_n, force(&jacobi) / solved.force_n);
        println!(
            "start / solved force: Hertz {hertz_force:.3}, Jacobi {jacobi_force:.3}; rms off, of the peak: Hertz {:.3}, Jacobi {:.3}",
            rms(&start),
            rms(&jacobi)
        );
        assert!((hertz_force - 1.0).abs() < 0.05, "Hertz's start carries {hertz_force} of the force");
        assert!(rms(&start) < 0.05, "Hertz's start is {} of the peak off", rms(&start));
        assert!(jacobi_force > 5.0 && rms(&jacobi) > 1.0, "the Jacobi guess was {} off", rms(&jacobi));
    }
}
