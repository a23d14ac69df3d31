//! Pin motion from the contact tractions: each pin base moves with the skin at its depth
//! inside the body (depth form of the Boussinesq and Cerruti solutions,
//! [`crate::contact::body::kernel::point_load_displacement`], one point force per loaded cell), and the pin,
//! a stiff post, turns with the skin's local rotation `omega = curl(u) / 2` at its base:
//! ```text
//! tip' = tip + u(base) + omega x (tip - base),   axis' = axis + omega x axis
//! ```
//! The lever `tip - base` (pin length, mm) amplifies the skin's rotation, which is why the
//! pins see curvature. Positions are taken relative to the contact plane (the tangent plane at
//! the apex of the contact frame, [`crate::contact::geometry::frame`], in which the layout is given): on a half-space a base at sensor point `X` sits at lateral `(X.x, X.y)` and depth
//! `R - X.z`; on layers ([`crate::contact::body::layered`]) every base sits at the skin's inner surface (the
//! top layer's bottom) under `(X.x, X.y)`: the dome unrolled onto the contact plane, so that
//! the pins stay in the skin that carries them. On the half-space the rotation is in closed
//! form ([`crate::contact::body::kernel::DepthKernel::motion`]), summed with the displacement in one pass; the
//! layered tables have no derivative in closed form and take a forward difference over
//! `STEP_MM` (a stencil of four points). With a skin patch (`pins.patch_radius_mm`
//! `a > 0`) `u(base)` and `omega` are the means over the base and six points on the circle of
//! radius `a` about it, in the contact plane at the base's depth: a stiff skin's bending
//! spreads the turn over that length.
//!
//! Each loaded cell carries a uniform traction `t` over its square of side `h`; far from a
//! point a cell acts as one force `t h^2` at its centre, whose error relative to the square's
//! integral is of order `(h / rho)^2 / 24` at distance `rho`. The pin bases sit under the
//! skin (0.66 mm on the calibrated sensor), within a cell or two of the nearest cells on any
//! practical grid, where that error is tens of percent: cells nearer a point than
//! `NEAR_CELLS` sides (centre to point, depth included) act as `s x s` equal sub-squares
//! (`s` = [`PIN_SUBSQUARES`] by default), each a force `t h^2 / s^2` at its centre (the
//! midpoint rule on the cell). On the bench's taps this takes the largest pin error against a
//! 65-cell reference from 0.77 to 0.026 mm on 13 cells (`tacsim bench`,
//! `docs/experiments/contact.md`). A cell a sharp edge cuts ([`crate::contact::geometry::cut`]) carries the edge's
//! singular pressure over its covered rectangle ([`edge_profile`]); the loaded cells along an
//! edge, solved again at sub-cells ([`crate::contact::geometry::refine`]), act as their sub-cells' point forces
//! near a pin instead.

use nalgebra::Vector3;
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
use crate::contact::algebra::lanes::Avx2Lanes;
use crate::contact::algebra::lanes::{LANES, Lanes, Real};
use crate::contact::body::PinKernel;
use crate::contact::body::kernel::DepthKernel;
use crate::contact::body::layered::LayeredKernels;
use crate::contact::geometry::cut::Cut;
use crate::contact::geometry::grid::Grid;
use crate::contact::geometry::refine::Refinement;
use crate::pins::{Pin, PinLayout, PinPose};

/// Finite-difference step for the rotation (mm).
const STEP_MM: f64 = 1e-3;

/// Side of the blocks of cells that far pins see as one point force (cells); blocks of
/// `SUPER x SUPER` blocks are seen as one force from farther still.
const BLOCK: usize = 2;
/// Side of a super-block (blocks).
const SUPER: usize = 2;
/// A pin sees a group as one force when farther than this many group diagonals from its
/// centroid (the monopole's relative error is of order `(diagonal / distance)^2`).
const FAR_DIAGONALS: f64 = 2.0;

/// A group of loaded cells (or blocks): their total force at the load-weighted centroid, and
/// the range of its members.
#[derive(Clone, Debug)]
pub(crate) struct Group {
    pub x: f64,
    pub y: f64,
    pub f: [f64; 3],
    pub members: std::ops::Range<usize>,
}

impl Group {
    /// The group of `members` (positions and forces), weighted by force magnitude.
    fn of(members: std::ops::Range<usize>, at: impl Fn(usize) -> (f64, f64, [f64; 3])) -> Self {
        let (mut sx, mut sy, mut w) = (0.0, 0.0, 0.0);
        let (mut mx, mut my) = (0.0, 0.0);
        let mut total = [0.0; 3];
        for k in members.clone() {
            let (x, y, f) = at(k);
            let weight = f[2].abs() + f[0].hypot(f[1]);
            sx += weight * x;
            sy += weight * y;
            w += weight;
            mx += x;
            my += y;
            for (t, v) in total.iter_mut().zip(f) {
                *t += v;
            }
        }
        let n = members.len() as f64;
        let (x, y) = if w > 0.0 { (sx / w, sy / w) } else { (mx / n, my / n) };
        Self { x, y, f: total, members }
    }
}

/// Cells nearer a point than this many cell sides act as sub-squares.
const NEAR_CELLS: f64 = 2.0;
/// Sub-squares per side of a cell near a pin, by default (odd: one sits at the centre; 1 is
/// one point force at the cell's centre, the product before the sub-squares).
pub const PIN_SUBSQUARES: usize = 3;

/// Point forces of the loaded cells, stored as separate arrays (positions `(x, y)` in mm,
/// forces `(Qx, Qy, P)` in N), grouped in blocks of `BLOCK x BLOCK` cells and super-blocks of
/// `SUPER x SUPER` blocks.
#[derive(Clone, Debug, Default)]
pub struct CellForces {
    pub(crate) x: Vec<f64>,
    pub(crate) y: Vec<f64>,
    pub(crate) f: Vec<[f64; 3]>,
    pub(crate) blocks: Vec<Group>,
    pub(crate) supers: Vec<Group>,
    pub(crate) far2: f64,
    pub(crate) super_far2: f64,
    /// Cell side (mm).
    pub(crate) cell_mm: f64,
    /// Sub-squares per side of a near cell.
    pub(crate) subsquares: usize,
    /// Per cell, its sub-squares' layout `[first_x, first_y, step_x, step_y, curve_x,
    /// curve_y]` (mm): sub-square `(i, j)` sits at the cell's point plus `first + i step +
    /// i^2 curve` along `x` (`j` along `y`), each with an equal share of the force:
    /// [`CellForces::near_rule`]'s squares for a whole cell (no curve), [`edge_profile`]'s
    /// strips for one an edge cuts ([`crate::contact::geometry::cut`]). No step (`[start, count, 0, 0, 0, 0]`):
    /// a refined cell ([`crate::contact::geometry::refine`]), whose sub-cells are `count` of [`CellForces::points`]
    /// from `start`.
    pub(crate) subs: Vec<[f64; 6]>,
    /// The refined cells' sub-cells as point forces: `[x, y, Qx, Qy, P]` (mm, N).
    pub(crate) points: Vec<[f64; 5]>,
}

impl CellForces {
    /// Collects the cells with non-zero traction; cells near a pin act as `subsquares` x
    /// `subsquares` sub-squares (at least 1). A cell an edge cuts (`cuts`, per grid cell)
    /// acts at its covered part's centroid, near ones as sub-rectangles of its covered
    /// rectangle. A refined cell (`refined`) acts as its sub-cells' point forces instead.
    pub(crate) fn new(
        grid: &Grid,
        (pressure, qx, qy): (&[f64], &[f64], &[f64]),
        cuts: Option<&[Option<Cut>]>,
        refined: Option<&Refinement>,
        subsquares: usize,
    ) -> Self {
        let area = grid.cell_area_mm2();
        let mut out = Self { cell_mm: grid.cell_mm, subsquares: subsquares.max(1), ..Self::default() };
        let (_, sub_mm, first_mm) = out.near_rule();
        let diagonal = (BLOCK as f64) * grid.cell_mm * std::f64::consts::SQRT_2;
        out.far2 = (FAR_DIAGONALS * diagonal).powi(2);
        out.super_far2 = (FAR_DIAGONALS * diagonal * SUPER as f64).powi(2);
        let side = BLOCK * SUPER;
        for sj in (0..grid.ny).step_by(side) {
            for si in (0..grid.nx).step_by(side) {
                let first_block = out.blocks.len();
                for bj in (sj..(sj + side).min(grid.ny)).step_by(BLOCK) {
                    for bi in (si..(si + side).min(grid.nx)).step_by(BLOCK) {
                        let start = out.f.len();
                        for j in bj..(bj + BLOCK).min(grid.ny) {
                            for i in bi..(bi + BLOCK).min(grid.nx) {
                                let k = j * grid.nx + i;
                                // A refined cell may be loaded at its sub-cells alone (the
                                // contact's edge past the coarse one's, `refine.rs`).
                                let sub_cells = refined.and_then(|r| r.of(k));
                                if pressure[k] == 0.0 && qx[k] == 0.0 && qy[k] == 0.0 && sub_cells.is_none() {
                                    continue;
                                }
                                if let Some(range) = sub_cells {
                                    // Its force went to the other refined cells' sub-cells
                                    // where the second solve left none of its own loaded.
                                    if range.is_empty() {
                                        continue;
                                    }
                                    let r = refined.expect("a refined cell's refinement");
                                    let (x, y, f, subs) = out.refined_cell(r, range);
                                    out.x.push(x);
                                    out.y.push(y);
                                    out.f.push(f);
                                    out.subs.push(subs);
                                    continue;
                                }
                                let c = grid.centre(k);
                                match cuts.and_then(|c| c[k]) {
                                    None => {
                                        out.x.push(c[0]);
                                        out.y.push(c[1]);
                                        out.subs.push([first_mm, first_mm, sub_mm, sub_mm, 0.0, 0.0]);
                                    }
                                    Some(cut) => {
                                        let (point, subs) = edge_profile(&cut, out.subsquares);
                                        out.x.push(c[0] + point[0]);
                                        out.y.push(c[1] + point[1]);
                                        out.subs.push(subs);
                                    }
                                }
                                out.f.push([qx[k] * area, qy[k] * area, pressure[k] * area]);
                            }
                        }
                        if out.f.len() > start {
                            let g = Group::of(start..out.f.len(), |k| (out.x[k], out.y[k], out.f[k]));
                            out.blocks.push(g);
                        }
                    }
                }
                if out.blocks.len() > first_block {
                    let blocks = &out.blocks;
                    let g = Group::of(first_block..blocks.len(), |b| (blocks[b].x, blocks[b].y, blocks[b].f));
                    out.supers.push(g);
                }
            }
        }
        out
    }

    /// A refined cell's entry from its sub-cells' forces `range` of `refined`: their total at
    /// their centroid (weighted by force, as [`Group::of`]), and near a pin the sub-cells'
    /// own point forces (appended to [`CellForces::points`]; `subs` says where).
    fn refined_cell(&mut self, refined: &Refinement, range: std::ops::Range<usize>) -> (f64, f64, [f64; 3], [f64; 6]) {
        let start = self.points.len();
        for s in range.clone() {
            let f = refined.f[s];
            self.points.push([refined.x[s], refined.y[s], f[0], f[1], f[2]]);
        }
        let whole = Group::of(range, |s| (refined.x[s], refined.y[s], refined.f[s]));
        (whole.x, whole.y, whole.f, [start as f64, (self.points.len() - start) as f64, 0.0, 0.0, 0.0, 0.0])
    }

    /// The near cells' rule: squared distance (mm^2) within which a cell acts as sub-squares,
    /// the sub-square's side (mm) and the offset of the first sub-square's centre from the
    /// cell's (mm).
    pub(crate) fn near_rule(&self) -> (f64, f64, f64) {
        let sub_mm = self.cell_mm / self.subsquares as f64;
        ((NEAR_CELLS * self.cell_mm).powi(2), sub_mm, -0.5 * self.cell_mm + 0.5 * sub_mm)
    }

    /// Whether no cell is loaded.
    pub fn is_empty(&self) -> bool {
        self.f.is_empty()
    }

    /// Displacements (mm, in the grid's frame) at the points `at` (close together: the
    /// first decides near and far; their depths from `depth`), in one pass over
    /// [`CellForces::each_force`].
    pub fn displacements<const N: usize>(
        &self,
        kernel: &PinKernel<'_>,
        at: &[Vector3<f64>; N],
        depth: &[f64; N],
        exact: bool,
    ) -> [Vector3<f64>; N] {
        let mut u = [[0.0; 3]; N];
        self.each_force(&at[0], depth[0], exact, |cx, cy, f| {
            for ((p, z), acc) in at.iter().zip(depth).zip(u.iter_mut()) {
                let d = kernel.displacement(f, [p.x - cx, p.y - cy, *z]);
                acc[0] += d[0];
                acc[1] += d[1];
                acc[2] += d[2];
            }
        });
        u.map(sensor_displacement)
    }

    /// Displacement (mm) and rotation (rad) of the half-space at `at`, `depth` (mm) under the
    /// contact plane, both in the grid's frame, with the closed-form rotation
    /// [`DepthKernel::motion`] evaluated on [`LANES`] forces at once: the forces the point
    /// sees are gathered first ([`CellForces::each_force`]), then summed in `LANES` running
    /// sums, added together at the end. Only the order of the additions differs from one force
    /// at a time (the tests' `one_force_at_a_time`): within 1e-12 of it
    /// relative to its size (test `pins_by_lanes_match_one_force_at_a_time`), in about 60% of
    /// the time (issue 31: the pins were half of a 13-cell tap; `cargo bench --bench tap --
    /// tap-pins`).
    pub fn motion_by_lanes(
        &self,
        kernel: &DepthKernel,
        at: &Vector3<f64>,
        depth: f64,
        exact: bool,
    ) -> (Vector3<f64>, Vector3<f64>) {
        SEEN.with_borrow_mut(|seen| {
            seen.clear();
            self.each_force(at, depth, exact, |cx, cy, f| seen.push(at.x - cx, at.y - cy, f));
            let (u, w) = kernel_sums(kernel, seen, depth);
            sensor_motion(u, w)
        })
    }

    /// Hands every point force that a point at `p` (its depth `depth`, mm) sees to `add`
    /// (position `(x, y)` mm, force N), in a fixed order: super-blocks and blocks far from the
    /// point as one force each, near ones cell by cell, and the nearest cells (within
    /// `NEAR_CELLS` sides) as sub-squares. With `exact`, no group acts as one.
    pub(crate) fn each_force(
        &self,
        p: &Vector3<f64>,
        depth: f64,
        exact: bool,
        mut add: impl FnMut(f64, f64, [f64; 3]),
    ) {
        let dist2 = |x: f64, y: f64| (p.x - x).powi(2) + (p.y - y).powi(2) + depth * depth;
        let (near2, _, _) = self.near_rule();
        let sub = self.subsquares;
        let sub_force = |f: [f64; 3]| f.map(|v| v / (sub * sub) as f64);
        for s in &self.supers {
            if !exact && dist2(s.x, s.y) > self.super_far2 {
                add(s.x, s.y, s.f);
                continue;
            }
            for b in &self.blocks[s.members.clone()] {
                if !exact && dist2(b.x, b.y) > self.far2 {
                    add(b.x, b.y, b.f);
                    continue;
                }
                for k in b.members.clone() {
                    let (x, y, f) = (self.x[k], self.y[k], self.f[k]);
                    if sub == 1 || dist2(x, y) >= near2 {
                        add(x, y, f);
                        continue;
                    }
                    let [first_x, first_y, step_x, step_y, curve_x, curve_y] = self.subs[k];
                    if step_x == 0.0 && step_y == 0.0 {
                        // A refined cell: its sub-cells.
                        for p in &self.points[first_x as usize..(first_x + first_y) as usize] {
                            add(p[0], p[1], [p[2], p[3], p[4]]);
                        }
                        continue;
                    }
                    let part = sub_force(f);
                    for i in 0..sub {
                        let i = i as f64;
                        for j in 0..sub {
                            let j = j as f64;
                            add(
                                x + first_x + i * step_x + i * i * curve_x,
                                y + first_y + j * step_y + j * j * curve_y,
                                part,
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Where a cut cell's force acts ([`crate::contact::geometry::cut`]): its point (offset from the cell's centre,
/// mm) and its sub-squares' layout ([`CellForces::subs`]) for `n` a side. A sharp edge's
/// pressure is singular, `p ~ s^(-1/2)` at a distance `s` from it (a rigid punch's edge,
/// Johnson 1985 sec. 2.8), so over the covered rectangle of width `w` across the edge the
/// force is taken with that profile: its centroid lies `w / 3` from the edge, and the `n`
/// strips of equal force (bounded at `s = w (i / n)^2`) have their centroids at
/// `s_i = w (3 i^2 + 3 i + 1) / (3 n^2)`, quadratic in `i`. Along the edge the rectangle is
/// split evenly. Spread evenly instead, a cut cell's force put 90% of the pin error across
/// an edge: on the bench's worst tap across the disk's rim, 13 cells were 0.46 mm off 65
/// cells, and 0.045 mm with each cut cell's force spread as 65 cells spread it; with this
/// profile 0.30 mm (test `a_cut_cells_force_leans_to_the_edge_for_the_pins`,
/// `docs/experiments/contact.md`, "The edge's profile in the pins"). On a skin the cut's
/// [`crate::contact::geometry::cut::EdgeProfile`] decays: its strips' centroids, nearer the
/// edge, are laid out by the quadratic through strips 0, `n / 2` and `n - 1`, exact for the
/// default 3 sub-squares.
fn edge_profile(cut: &Cut, n: usize) -> ([f64; 2], [f64; 6]) {
    let nf = n as f64;
    let mut subs = [0.0; 6];
    for axis in 0..2 {
        let t = cut.toward_edge[axis];
        let side = cut.sides_mm[axis];
        if t == 0.0 {
            // Along the edge: even squares of the rectangle.
            let step = side / nf;
            subs[axis] = 0.5 * (step - side);
            subs[2 + axis] = step;
        } else if !cut.profile.decay_mm.is_finite() {
            // Across: from the load point, w / 3 in from the edge ([`Cut::load_point_mm`]),
            // s_i - w / 3 = w (3 i^2 + 3 i + 1 - n^2) / (3 n^2), away from the edge (-t).
            let unit = -t * side / (nf * nf);
            subs[axis] = unit * (1.0 - nf * nf) / 3.0;
            subs[2 + axis] = unit;
            subs[4 + axis] = unit;
        } else {
            // A decaying profile: the strips' centroids `s_i` less the load point's, away from
            // the edge, as the quadratic through strips 0, n / 2 and n - 1 (exact for n <= 3).
            let s = cut.profile.strip_centroids_mm(side, n);
            let load = cut.profile.centroid_mm(0.0, side);
            let v = |i: usize| -t * (s[i] - load);
            let [first, step, curve] = quadratic_through(n, v);
            subs[axis] = first;
            subs[2 + axis] = step;
            subs[4 + axis] = curve;
        }
    }
    (cut.load_point_mm(), subs)
}

/// `[c0, c1, c2]` of the quadratic `c0 + c1 i + c2 i^2` through `v(i)` at `i` = 0, `n / 2`
/// and `n - 1` (through the points there are for `n < 3`).
fn quadratic_through(n: usize, v: impl Fn(usize) -> f64) -> [f64; 3] {
    match n {
        0 | 1 => [v(0), 0.0, 0.0],
        2 => [v(0), v(1) - v(0), 0.0],
        _ => {
            let (m, l) = (n / 2, n - 1);
            let (x1, x2) = (m as f64, l as f64);
            let (y0, y1, y2) = (v(0), v(m), v(l));
            // Divided differences.
            let d1 = (y1 - y0) / x1;
            let d2 = ((y2 - y1) / (x2 - x1) - d1) / x2;
            [y0, d1 - d2 * x1, d2]
        }
    }
}

/// The point forces one point sees, as offsets from it (mm) and forces (N), in lane-sized
/// runs.
#[derive(Default)]
struct SeenForces {
    dx: Vec<f64>,
    dy: Vec<f64>,
    f: [Vec<f64>; 3],
}

thread_local! {
    /// Each worker's [`SeenForces`], kept between points (a pin product allocates nothing).
    static SEEN: std::cell::RefCell<SeenForces> = std::cell::RefCell::new(SeenForces::default());
}

impl SeenForces {
    fn clear(&mut self) {
        self.dx.clear();
        self.dy.clear();
        self.f.iter_mut().for_each(Vec::clear);
    }

    fn push(&mut self, dx: f64, dy: f64, f: [f64; 3]) {
        self.dx.push(dx);
        self.dy.push(dy);
        for (v, f) in self.f.iter_mut().zip(f) {
            v.push(f);
        }
    }
}

/// The kernel's displacement and rotation summed over [`SeenForces`], [`LANES`] at a time in
/// `LANES` running sums, added together in lane order at the end; the forces after the last
/// full run one at a time. `lanes` makes a run's values into the lanes' type: every type
/// gives the same bits.
#[inline(always)]
fn lane_sums<T: Real>(
    kernel: &DepthKernel,
    seen: &SeenForces,
    depth: f64,
    lanes: impl Fn([f64; LANES]) -> T,
    values: impl Fn(T) -> [f64; LANES],
) -> ([f64; 3], [f64; 3]) {
    let zero = lanes([0.0; LANES]);
    let (mut u, mut w) = ([zero; 3], [zero; 3]);
    let run = |v: &[f64], start: usize| lanes(std::array::from_fn(|l| v[start + l]));
    let n = seen.dx.len() / LANES * LANES;
    for start in (0..n).step_by(LANES) {
        let offset = [run(&seen.dx, start), run(&seen.dy, start), zero.splat_like(depth)];
        let force = [run(&seen.f[0], start), run(&seen.f[1], start), run(&seen.f[2], start)];
        let (d, r) = kernel.motion(force, offset);
        for i in 0..3 {
            u[i] = u[i] + d[i];
            w[i] = w[i] + r[i];
        }
    }
    let total = |v: T| values(v).iter().sum::<f64>();
    let (mut u, mut w) = (u.map(total), w.map(total));
    for k in n..seen.dx.len() {
        let force = [seen.f[0][k], seen.f[1][k], seen.f[2][k]];
        let (d, r) = kernel.motion(force, [seen.dx[k], seen.dy[k], depth]);
        for i in 0..3 {
            u[i] += d[i];
            w[i] += r[i];
        }
    }
    (u, w)
}

/// [`lane_sums`] on AVX2 ([`pulp::WithSimd`] compiles it with the unit's instructions).
#[cfg(target_arch = "x86_64")]
struct Avx2Sums<'a> {
    simd: pulp::x86::V3,
    kernel: &'a DepthKernel,
    seen: &'a SeenForces,
    depth: f64,
}

#[cfg(target_arch = "x86_64")]
impl pulp::WithSimd for Avx2Sums<'_> {
    type Output = ([f64; 3], [f64; 3]);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let simd = self.simd;
        lane_sums(self.kernel, self.seen, self.depth, |v| Avx2Lanes::new(simd, v), Avx2Lanes::to_array)
    }
}

/// [`lane_sums`] on the best lanes this CPU has: AVX2, else [`Lanes`] (the same bits).
fn kernel_sums(kernel: &DepthKernel, seen: &SeenForces, depth: f64) -> ([f64; 3], [f64; 3]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return pulp::Simd::vectorize(simd, Avx2Sums { simd, kernel, seen, depth });
    }
    lane_sums(kernel, seen, depth, Lanes, |v| v.0)
}

/// The near field's displacement and its gradient ([`LayeredKernels::displacement_and_gradient`])
/// summed over [`SeenForces`], [`LANES`] forces at a time in `LANES` running sums, added
/// together in lane order at the end, as [`lane_sums`] does the half-space's; a run with a
/// force right at the point (whose angles need the scalar limit) and the forces after the
/// last full run one at a time. Every kind of lanes gives the same bits.
#[inline(always)]
fn near_field_lane_sums<T: Real>(
    kernel: &LayeredKernels,
    seen: &SeenForces,
    lanes: impl Fn([f64; LANES]) -> T,
    values: impl Fn(T) -> [f64; LANES],
) -> ([f64; 3], [[f64; 3]; 3]) {
    let zero = lanes([0.0; LANES]);
    let (mut u, mut grad) = ([zero; 3], [[zero; 3]; 3]);
    let (mut one_u, mut one_grad) = ([0.0; 3], [[0.0; 3]; 3]);
    let mut one_at_a_time = |k: usize| {
        let force = [seen.f[0][k], seen.f[1][k], seen.f[2][k]];
        let (v, g) = kernel.displacement_and_gradient(force, seen.dx[k], seen.dy[k]);
        for c in 0..3 {
            one_u[c] += v[c];
            for d in 0..3 {
                one_grad[d][c] += g[d][c];
            }
        }
    };
    let n = seen.dx.len() / LANES * LANES;
    for start in (0..n).step_by(LANES) {
        let run = |v: &[f64]| -> [f64; LANES] { std::array::from_fn(|l| v[start + l]) };
        let (dx, dy) = (run(&seen.dx), run(&seen.dy));
        if (0..LANES).any(|l| dx[l] * dx[l] + dy[l] * dy[l] == 0.0) {
            (start..start + LANES).for_each(&mut one_at_a_time);
            continue;
        }
        let force = [lanes(run(&seen.f[0])), lanes(run(&seen.f[1])), lanes(run(&seen.f[2]))];
        let (v, g) = kernel.displacement_and_gradient_lanes(force, (dx, dy), &lanes);
        for c in 0..3 {
            u[c] = u[c] + v[c];
            for d in 0..3 {
                grad[d][c] = grad[d][c] + g[d][c];
            }
        }
    }
    (n..seen.dx.len()).for_each(&mut one_at_a_time);
    let total = |v: T| values(v).iter().sum::<f64>();
    let u: [f64; 3] = std::array::from_fn(|c| total(u[c]) + one_u[c]);
    let grad: [[f64; 3]; 3] = std::array::from_fn(|d| std::array::from_fn(|c| total(grad[d][c]) + one_grad[d][c]));
    (u, grad)
}

/// [`near_field_lane_sums`] on AVX2.
#[cfg(target_arch = "x86_64")]
struct Avx2NearSums<'a> {
    simd: pulp::x86::V3,
    kernel: &'a LayeredKernels,
    seen: &'a SeenForces,
}

#[cfg(target_arch = "x86_64")]
impl pulp::WithSimd for Avx2NearSums<'_> {
    type Output = ([f64; 3], [[f64; 3]; 3]);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let simd = self.simd;
        near_field_lane_sums(self.kernel, self.seen, |v| Avx2Lanes::new(simd, v), Avx2Lanes::to_array)
    }
}

/// [`near_field_lane_sums`] on the best lanes this CPU has: AVX2, else [`Lanes`] (the same
/// bits).
fn near_field_sums(kernel: &LayeredKernels, seen: &SeenForces) -> ([f64; 3], [[f64; 3]; 3]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return pulp::Simd::vectorize(simd, Avx2NearSums { simd, kernel, seen });
    }
    near_field_lane_sums(kernel, seen, Lanes, |v| v.0)
}

/// The half-space's displacement and rotation (kernel frame, `z` into the body) in the grid's
/// frame, where into the body is `-z`: the mirror turns `u_z` and, the rotation being an axial
/// vector, `omega_x` and `omega_y`.
pub(crate) fn sensor_motion(u: [f64; 3], omega: [f64; 3]) -> (Vector3<f64>, Vector3<f64>) {
    (sensor_displacement(u), Vector3::new(-omega[0], -omega[1], omega[2]))
}

/// A displacement of the kernels' frame (`z` into the body) in the grid's, where into the body
/// is `-z`.
pub(crate) fn sensor_displacement(u: [f64; 3]) -> Vector3<f64> {
    Vector3::new(u[0], u[1], -u[2])
}

/// Deformed pin poses (in the frame of `layout` and the grid) for the given cell forces;
/// `exact` sums every cell for every pin instead of grouping far cells in blocks.
pub fn displaced_pins(
    layout: &PinLayout,
    kernel: &PinKernel<'_>,
    dome_radius_mm: f64,
    forces: &CellForces,
    exact: bool,
) -> Vec<PinPose> {
    if forces.is_empty() {
        return layout.poses();
    }
    layout
        .pins
        .iter()
        .zip(pin_motions(layout, kernel, dome_radius_mm, forces, exact))
        .map(|(pin, motion)| moved_pin(pin, &[motion]))
        .collect()
}

/// Every pin's skin motion (displacement mm, rotation rad; the means over its
/// [`patch_points`]) in the frame of `layout` and the grid, for the given cell forces.
pub(crate) fn pin_motions(
    layout: &PinLayout,
    kernel: &PinKernel<'_>,
    dome_radius_mm: f64,
    forces: &CellForces,
    exact: bool,
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    patch_means(layout, |base, at| skin_motion(kernel, dome_radius_mm, forces, exact, base, at))
}

/// Each pin's mean of `motion(base, point)` over its [`patch_points`], on all cores.
fn patch_means(
    layout: &PinLayout,
    motion: impl Fn(&Vector3<f64>, Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) + Sync,
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    layout
        .pins
        .par_iter()
        .map(|pin| {
            let base = pin.base.coords;
            let motions: Vec<_> = patch_points(layout, &base).map(|at| motion(&base, at)).collect();
            mean_motion(&motions)
        })
        .collect()
}

/// Every pin's near-field skin motion (displacement mm, rotation rad; the means over its
/// [`patch_points`]) in the frame of `layout` and the grid, from the layered near-field
/// tables `kernel` (the dome body's, `body/dome.rs`): the rotation from the displacement's
/// gradient in closed form ([`LayeredKernels::displacement_and_gradient`]), one table lookup per
/// force where the four-point stencil of [`pin_motions`] takes four. The dome's pins run on
/// the CPU only, so no GPU kernel mirrors the stencil here (`Simulation::has_dome`).
pub(crate) fn near_field_motions(
    layout: &PinLayout,
    kernel: &LayeredKernels,
    forces: &CellForces,
    exact: bool,
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    patch_means(layout, |_, at| near_field_motion(kernel, forces, exact, at))
}

/// The near-field skin motion at `at` (a point at the pins' depth, as every patch point is).
fn near_field_motion(
    kernel: &LayeredKernels,
    forces: &CellForces,
    exact: bool,
    at: Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let (u, grad) = SEEN.with_borrow_mut(|seen| {
        seen.clear();
        forces.each_force(&at, kernel.pin_depth_mm(), exact, |cx, cy, f| seen.push(at.x - cx, at.y - cy, f));
        near_field_sums(kernel, seen)
    });
    // The grid's frame: z out of the body, so depth falls as z rises.
    let [gx, gy, gd] = grad.map(sensor_displacement);
    let gz = -gd;
    (sensor_displacement(u), 0.5 * Vector3::new(gy.z - gz.y, gz.x - gx.z, gx.y - gy.x))
}

/// The mean of skin motions (displacement, rotation).
fn mean_motion(motions: &[(Vector3<f64>, Vector3<f64>)]) -> (Vector3<f64>, Vector3<f64>) {
    let n = motions.len() as f64;
    let (u, omega) = motions.iter().fold((Vector3::zeros(), Vector3::zeros()), |s, m| (s.0 + m.0, s.1 + m.1));
    (u / n, omega / n)
}

/// The points whose skin motion moves the pin with base `base`: the base, then with a skin
/// patch (`layout.patch_radius_mm > 0`) six points on the patch's circle (in the contact
/// plane's x, y, at the base's depth).
pub(crate) fn patch_points(layout: &PinLayout, base: &Vector3<f64>) -> impl Iterator<Item = Vector3<f64>> {
    let (base, a) = (*base, layout.patch_radius_mm);
    let ring = if a > 0.0 { 6 } else { 0 };
    std::iter::once(base).chain((0..ring).map(move |k| {
        let (s, c) = (std::f64::consts::FRAC_PI_3 * k as f64).sin_cos();
        base + Vector3::new(c, s, 0.0) * a
    }))
}

/// The pin moved by the skin motions (displacement mm, rotation rad) at its
/// [`patch_points`], in their order: their mean displaces the base and turns the post.
pub(crate) fn moved_pin(pin: &Pin, motions: &[(Vector3<f64>, Vector3<f64>)]) -> PinPose {
    let (u, omega) = mean_motion(motions);
    let lever = pin.tip.coords - pin.base.coords;
    let axis = (pin.normal + omega.cross(&pin.normal)).normalize();
    PinPose { tip: (pin.tip.coords + u + omega.cross(&lever)).into(), axis }
}

/// Displacement (mm) and rotation `omega = curl(u) / 2` (rad) of the skin at `at`, near the pin
/// base `base` (whose depth rule applies).
fn skin_motion(
    kernel: &PinKernel<'_>,
    dome_radius_mm: f64,
    forces: &CellForces,
    exact: bool,
    base: &Vector3<f64>,
    at: Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    match kernel {
        PinKernel::HalfSpace(k) => forces.motion_by_lanes(k, &at, kernel.depth(dome_radius_mm, base, &at), exact),
        // The tables have no derivative in closed form: a forward difference.
        PinKernel::Layered(_) => {
            let points = stencil(at);
            let depth = points.map(|p| kernel.depth(dome_radius_mm, base, &p));
            motion_from_stencil(&forces.displacements(kernel, &points, &depth, exact))
        }
    }
}

/// The finite-difference stencil at `at`: the point, then one step (`STEP_MM`) along x, y, z.
pub(crate) fn stencil(at: Vector3<f64>) -> [Vector3<f64>; 4] {
    [at, at + Vector3::x() * STEP_MM, at + Vector3::y() * STEP_MM, at + Vector3::z() * STEP_MM]
}

/// Displacement and rotation from the displacements at the [`stencil`]'s points.
pub(crate) fn motion_from_stencil(u: &[Vector3<f64>; 4]) -> (Vector3<f64>, Vector3<f64>) {
    let [u, ux, uy, uz] = *u;
    // Gradient by forward differences: column k = d u / d x_k.
    let (gx, gy, gz) = ((ux - u) / STEP_MM, (uy - u) / STEP_MM, (uz - u) / STEP_MM);
    (u, 0.5 * Vector3::new(gy.z - gz.y, gz.x - gx.z, gx.y - gy.x))
}

/// What the pins of one contact state depend on, handed whole to the GPU (`crate::gpu`).
pub(crate) struct PinLoad<'a> {
    /// The pins, in the grid's frame.
    pub layout: &'a PinLayout,
    pub kernel: PinKernel<'a>,
    pub dome_radius_mm: f64,
    pub forces: CellForces,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::body::kernel::Elastic;
    use crate::contact::geometry::cut::EdgeProfile;

    /// A cut cell's sub-squares follow the edge's `s^(-1/2)` profile: equal forces at the
    /// strips' centroids `w (3 i^2 + 3 i + 1) / (3 n^2)` from the edge, whose mean is the
    /// cell's point `w / 3` in from it, all on the covered part; along the edge, even
    /// squares. Both orientations and both sides.
    #[test]
    fn a_cut_cells_force_leans_to_the_edge_as_its_singular_pressure() {
        let h = 1.2;
        for (d, a, b) in [(-0.1, 1.0, 0.0), (-0.1, -1.0, 0.0), (0.3, 0.1, 1.0), (0.3, 0.1, -1.0)] {
            let cut = Cut::of_half_plane(h, d, a, b, EdgeProfile::SINGULAR).expect("cut");
            let (axis, t) = cut.across();
            let w = cut.sides_mm[axis];
            let edge = cut.centroid_mm[axis] + 0.5 * t * w;
            for n in [1usize, 3, 5] {
                let (point, subs) = edge_profile(&cut, n);
                assert!(((edge - point[axis]) * t - w / 3.0).abs() < 1e-12, "{cut:?} n {n}: {point:?}");
                assert!((point[1 - axis] - cut.centroid_mm[1 - axis]).abs() < 1e-12, "{cut:?} n {n}");
                let mut mean = 0.0;
                for i in 0..n {
                    let fi = i as f64;
                    let at = point[axis] + subs[axis] + fi * subs[2 + axis] + fi * fi * subs[4 + axis];
                    let s = (edge - at) * t;
                    let nf = n as f64;
                    let expected = w * (3.0 * fi * fi + 3.0 * fi + 1.0) / (3.0 * nf * nf);
                    assert!((s - expected).abs() < 1e-12 && s > 0.0 && s < w, "{cut:?} n {n} strip {i}: s {s}");
                    mean += at / nf;
                    // Along the edge: centres of n even squares of the side.
                    let along = subs[1 - axis] + fi * subs[3 - axis] + fi * fi * subs[5 - axis];
                    let side = cut.sides_mm[1 - axis];
                    assert!((along - (fi + 0.5 - 0.5 * nf) * side / nf).abs() < 1e-12, "{cut:?} n {n}");
                }
                assert!((mean - point[axis]).abs() < 1e-12, "{cut:?} n {n}: mean {mean}");
            }
        }
    }

    /// On a skin the cut cell's force leans further to the edge ([`EdgeProfile::of_skin`]):
    /// its point at the profile's centroid, nearer than `w / 3`, and with 3 sub-squares a
    /// side (the default) at the centroids of the profile's three strips of equal force.
    #[test]
    fn a_cut_cells_force_on_a_skin_gathers_at_the_edge() {
        let profile = EdgeProfile::of_skin(0.66);
        for (d, a, b) in [(-0.1, 1.0, 0.0), (0.3, 0.1, -1.0)] {
            let cut = Cut::of_half_plane(1.2, d, a, b, profile).expect("cut");
            let (axis, t) = cut.across();
            let w = cut.sides_mm[axis];
            let edge = cut.centroid_mm[axis] + 0.5 * t * w;
            let (point, subs) = edge_profile(&cut, 3);
            let from_edge = (edge - point[axis]) * t;
            assert!((from_edge - profile.centroid_mm(0.0, w)).abs() < 1e-12 && from_edge < 0.9 * w / 3.0, "{cut:?}");
            let strips = profile.strip_centroids_mm(w, 3);
            for (i, expected) in strips.iter().enumerate() {
                let fi = i as f64;
                let at = point[axis] + subs[axis] + fi * subs[2 + axis] + fi * fi * subs[4 + axis];
                assert!(((edge - at) * t - expected).abs() < 1e-12, "{cut:?} strip {i}");
            }
        }
    }

    /// The reference of [`CellForces::motion_by_lanes`]: the same forces
    /// ([`CellForces::each_force`]) summed one at a time.
    fn one_force_at_a_time(
        forces: &CellForces,
        kernel: &DepthKernel,
        at: &Vector3<f64>,
        depth: f64,
        exact: bool,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let (mut u, mut w) = ([0.0; 3], [0.0; 3]);
        forces.each_force(at, depth, exact, |cx, cy, f| {
            let (d, r) = kernel.motion(f, [at.x - cx, at.y - cy, depth]);
            for i in 0..3 {
                u[i] += d[i];
                w[i] += r[i];
            }
        });
        sensor_motion(u, w)
    }

    /// A cell's displacement at a point under it by a fine midpoint rule over its square
    /// (400 x 400 points: the square's integral to well under 0.1%).
    fn square_integral(kernel: &PinKernel<'_>, h: f64, force: [f64; 3], at: [f64; 3]) -> [f64; 3] {
        let n = 400;
        let mut u = [0.0; 3];
        let part = force.map(|f| f / (n * n) as f64);
        for i in 0..n {
            for j in 0..n {
                let (x, y) = ((i as f64 + 0.5) / n as f64 - 0.5, (j as f64 + 0.5) / n as f64 - 0.5);
                let d = kernel.displacement(part, [at[0] - x * h, at[1] - y * h, at[2]]);
                for (a, b) in u.iter_mut().zip(d) {
                    *a += b;
                }
            }
        }
        u
    }

    /// A loaded 17 x 17 grid of 0.3 mm cells: pressure over a disc and shear, some cells
    /// unloaded.
    fn loaded_forces() -> CellForces {
        let grid = Grid::square(17, 0.3);
        let n = grid.len();
        let (mut p, mut qx, mut qy) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            let c = grid.centre(k);
            let r2 = c[0] * c[0] + c[1] * c[1];
            if r2 < 5.0 {
                p[k] = 0.2 * (5.0 - r2);
                qx[k] = 0.03 * (5.0 - r2) - 0.01 * c[1];
                qy[k] = 0.02 * c[0];
            }
        }
        CellForces::new(&grid, (&p, &qx, &qy), None, None, PIN_SUBSQUARES)
    }

    /// The dome's near field takes each pin's rotation from the tables' gradient in closed
    /// form instead of the four-point stencil (2.5x faster pins, `tacsim bench --skin dome`):
    /// the displacements agree to rounding (the stencil's depth `d + z - z` is not `d` to the
    /// last bit), the rotations within 1e-3 of the largest (the
    /// stencil's forward differences of 1e-3 mm are what differ), for pins with and without a
    /// skin patch, grouped and `exact`.
    #[test]
    fn the_domes_near_field_rotation_is_the_stencils_without_its_differences() {
        let tables = near_field_tables();
        let forces = loaded_forces();
        for patch in [0.0, 1.5] {
            let mut sensor = crate::sensor::SensorParams::half_space();
            sensor.pins.patch_radius_mm = patch;
            let layout = PinLayout::new(&sensor);
            for exact in [false, true] {
                let closed = near_field_motions(&layout, &tables, &forces, exact);
                let stencil = pin_motions(&layout, &PinKernel::Layered(&tables), 20.0, &forces, exact);
                let largest = stencil.iter().fold(0.0f64, |m, s| m.max(s.1.norm()));
                let farthest = stencil.iter().fold(0.0f64, |m, s| m.max(s.0.norm()));
                for (a, b) in closed.iter().zip(&stencil) {
                    assert!(
                        (a.0 - b.0).norm() <= 1e-12 * farthest,
                        "patch {patch}, exact {exact}: {:?} vs {:?}",
                        a.0,
                        b.0
                    );
                    assert!(
                        (a.1 - b.1).norm() <= 1e-3 * largest,
                        "patch {patch}, exact {exact}: {:?} vs {:?}",
                        a.1,
                        b.1
                    );
                }
            }
        }
    }

    /// What changed: the kernel is evaluated on `LANES` forces at once, in `LANES` running
    /// sums. Near (sub-squares), inside and far from the load, grouped and `exact`, the motion
    /// stays within 1e-12 of one force at a time, relative to its size (the sums' order is all
    /// that differs).
    #[test]
    fn pins_by_lanes_match_one_force_at_a_time() {
        let kernel = DepthKernel::new(&Elastic::from_young(0.3, 0.436));
        let forces = loaded_forces();
        let mut seen = 0;
        for (x, y, depth) in
            [(0.05, -0.1, 0.66), (1.4, 0.9, 0.66), (-4.0, 3.0, 0.66), (9.0, -12.0, 1.0), (0.0, 0.0, 0.2)]
        {
            let at = Vector3::new(x, y, 0.0);
            for exact in [false, true] {
                let (u, w) = one_force_at_a_time(&forces, &kernel, &at, depth, exact);
                let (ul, wl) = forces.motion_by_lanes(&kernel, &at, depth, exact);
                assert!((u - ul).norm() <= 1e-12 * u.norm(), "at {at:?} exact {exact}: {u:?} vs {ul:?}");
                assert!((w - wl).norm() <= 1e-12 * w.norm(), "at {at:?} exact {exact}: {w:?} vs {wl:?}");
                assert!(u.norm() > 0.0 && w.norm() > 0.0);
                seen += 1;
            }
        }
        assert_eq!(seen, 10);
    }

    /// The AVX2 lanes are [`Lanes`] on the vector unit: the same bits, forces in full runs and
    /// a remainder alike (skipped, saying so, on a CPU without AVX2).
    #[test]
    fn avx2_lanes_give_the_bits_of_plain_lanes() {
        #[cfg(target_arch = "x86_64")]
        {
            let Some(simd) = pulp::x86::V3::try_new() else {
                println!("skipped: this CPU has no AVX2");
                return;
            };
            let kernel = DepthKernel::new(&Elastic::from_young(0.3, 0.436));
            let forces = loaded_forces();
            let mut remainders = 0;
            for (x, y) in [(0.05, -0.1), (1.4, 0.9), (-4.0, 3.0)] {
                for drop in 0..LANES {
                    // The forces the point sees, less the last `drop`: every remainder.
                    let mut seen = SeenForces::default();
                    forces.each_force(&Vector3::new(x, y, 0.0), 0.66, false, |cx, cy, f| seen.push(x - cx, y - cy, f));
                    let keep = seen.dx.len() - drop;
                    seen.dx.truncate(keep);
                    seen.dy.truncate(keep);
                    seen.f.iter_mut().for_each(|v| v.truncate(keep));
                    remainders += usize::from(keep % LANES != 0);
                    let avx2 =
                        pulp::Simd::vectorize(simd, Avx2Sums { simd, kernel: &kernel, seen: &seen, depth: 0.66 });
                    let plain = lane_sums(&kernel, &seen, 0.66, Lanes, |v| v.0);
                    let bits =
                        |(u, w): ([f64; 3], [f64; 3])| u.iter().chain(&w).map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(avx2), bits(plain), "at ({x}, {y}), {keep} forces");
                }
            }
            assert!(remainders >= 6, "{remainders} runs with a remainder");
        }
    }

    /// The dome's near-field tables of the test above (a 0.66 mm skin on a soft gel).
    fn near_field_tables() -> std::sync::Arc<LayeredKernels> {
        use crate::contact::body::layered::{Layer, LayeredBody};
        let body = LayeredBody {
            layers: vec![
                Layer { thickness_mm: 0.66, material: Elastic::from_young(1.0, 0.436) },
                Layer { thickness_mm: 19.34, material: Elastic::from_young(0.02, 0.4999) },
            ],
        };
        LayeredKernels::near_field(&body, 0.66, 60.0, 2.9)
    }

    /// The forces a point at `(x, y)` sees, as the pins gather them.
    fn seen_at(forces: &CellForces, (x, y): (f64, f64), exact: bool) -> SeenForces {
        let mut seen = SeenForces::default();
        forces.each_force(&Vector3::new(x, y, 0.0), 0.66, exact, |cx, cy, f| seen.push(x - cx, y - cy, f));
        seen
    }

    /// What changed: the near field's displacement and gradient are evaluated on `LANES`
    /// forces at once. Each lane is the scalar formula's bits (offsets inside the table, past
    /// its end, and on its first interval), and over the forces a point sees (near, inside
    /// and far from the load, grouped and `exact`, one force right at the point) the sums
    /// stay within 1e-12 of one force at a time relative to their size.
    #[test]
    fn the_near_field_by_lanes_matches_one_force_at_a_time() {
        let tables = near_field_tables();
        let beyond = tables.r_max_mm() + 3.0;
        let (x, y) = ([0.01, -1.3, 7.5, beyond], [0.02, 0.7, -4.0, 1.0]);
        let force = [[0.1, -0.2, 0.3], [-0.05, 0.0, 1.0], [0.0, 0.3, 0.2], [0.2, 0.1, 0.5]];
        let f = |c: usize| Lanes(std::array::from_fn(|l| force[l][c]));
        let (u, g) = tables.displacement_and_gradient_lanes([f(0), f(1), f(2)], (x, y), Lanes);
        for l in 0..LANES {
            let (us, gs) = tables.displacement_and_gradient(force[l], x[l], y[l]);
            for c in 0..3 {
                assert_eq!(u[c].0[l].to_bits(), us[c].to_bits(), "lane {l}, u[{c}]");
                for d in 0..3 {
                    assert_eq!(g[d][c].0[l].to_bits(), gs[d][c].to_bits(), "lane {l}, grad[{d}][{c}]");
                }
            }
        }
        let forces = loaded_forces();
        let mut runs_at_the_point = 0;
        for at in [(0.05, -0.1), (1.4, 0.9), (-4.0, 3.0), (9.0, -12.0), (forces.x[0], forces.y[0])] {
            for exact in [false, true] {
                let seen = seen_at(&forces, at, exact);
                runs_at_the_point += usize::from(seen.dx.iter().zip(&seen.dy).any(|(x, y)| *x == 0.0 && *y == 0.0));
                let (mut u1, mut g1) = ([0.0; 3], [[0.0; 3]; 3]);
                for k in 0..seen.dx.len() {
                    let f = [seen.f[0][k], seen.f[1][k], seen.f[2][k]];
                    let (v, g) = tables.displacement_and_gradient(f, seen.dx[k], seen.dy[k]);
                    (0..3).for_each(|c| u1[c] += v[c]);
                    (0..9).for_each(|i| g1[i / 3][i % 3] += g[i / 3][i % 3]);
                }
                let (u, g) = near_field_lane_sums(&tables, &seen, Lanes, |v| v.0);
                let norm = |v: &[f64]| v.iter().map(|v| v * v).sum::<f64>().sqrt();
                let diff = |a: &[f64], b: &[f64]| norm(&a.iter().zip(b).map(|(a, b)| a - b).collect::<Vec<_>>());
                assert!(diff(&u, &u1) <= 1e-12 * norm(&u1), "at {at:?} exact {exact}: {u:?} vs {u1:?}");
                let (g, g1) = (g.concat(), g1.concat());
                assert!(diff(&g, &g1) <= 1e-12 * norm(&g1), "at {at:?} exact {exact}: {g:?} vs {g1:?}");
                assert!(norm(&u1) > 0.0 && norm(&g1) > 0.0);
            }
        }
        assert!(runs_at_the_point > 0, "no force right at a point");
    }

    /// The near field's AVX2 lanes give the bits of plain [`Lanes`], for every remainder
    /// (skipped, saying so, on a CPU without AVX2).
    #[test]
    fn the_near_fields_avx2_lanes_give_the_bits_of_plain_lanes() {
        #[cfg(target_arch = "x86_64")]
        {
            let Some(simd) = pulp::x86::V3::try_new() else {
                println!("skipped: this CPU has no AVX2");
                return;
            };
            let (tables, forces) = (near_field_tables(), loaded_forces());
            let mut remainders = 0;
            for at in [(0.05, -0.1), (1.4, 0.9), (-4.0, 3.0), (forces.x[0], forces.y[0])] {
                for drop in 0..LANES {
                    let mut seen = seen_at(&forces, at, false);
                    let keep = seen.dx.len() - drop;
                    seen.dx.truncate(keep);
                    seen.dy.truncate(keep);
                    seen.f.iter_mut().for_each(|v| v.truncate(keep));
                    remainders += usize::from(!keep.is_multiple_of(LANES));
                    let avx2 = pulp::Simd::vectorize(simd, Avx2NearSums { simd, kernel: &tables, seen: &seen });
                    let plain = near_field_lane_sums(&tables, &seen, Lanes, |v| v.0);
                    let bits = |(u, g): ([f64; 3], [[f64; 3]; 3])| {
                        u.iter().chain(g.concat().iter()).map(|v| v.to_bits()).collect::<Vec<_>>()
                    };
                    assert_eq!(bits(avx2), bits(plain), "at {at:?}, {keep} forces");
                }
            }
            assert!(remainders >= 6, "{remainders} runs with a remainder");
        }
    }

    /// The half-space's one-pass motion (closed-form rotation) against central differences of
    /// the same sums' displacements (step 1e-5 mm; the same near and far groups, decided at
    /// the point): the rotation within 1e-6 of its size, the displacement the same bits.
    #[test]
    fn half_space_rotation_is_half_the_curl_of_the_summed_displacements() {
        let depth_kernel = DepthKernel::new(&Elastic::from_young(1.0, 0.436));
        let kernel = PinKernel::HalfSpace(depth_kernel);
        let h = 0.4;
        let grid = Grid::square(9, h);
        let n = grid.nx * grid.ny;
        let (mut p, mut qx, mut qy) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            let c = grid.centre(k);
            let r2 = c[0] * c[0] + c[1] * c[1];
            if r2 < 1.5 {
                p[k] = 0.3 * (1.5 - r2);
                qx[k] = 0.05 * (1.5 - r2) + 0.01 * c[1];
                qy[k] = -0.02 * c[0];
            }
        }
        let forces = CellForces::new(&grid, (&p, &qx, &qy), None, None, PIN_SUBSQUARES);
        let step = 1e-5;
        for (at, depth) in [
            (Vector3::new(0.1, -0.2, 0.0), 0.66),
            (Vector3::new(1.3, 0.4, 0.0), 0.66),
            (Vector3::new(-2.9, 1.7, 0.0), 1.0),
        ] {
            for exact in [false, true] {
                let d = [Vector3::x(), -Vector3::x(), Vector3::y(), -Vector3::y(), Vector3::z(), -Vector3::z()];
                let points: [Vector3<f64>; 7] = std::array::from_fn(|i| if i == 0 { at } else { at + d[i - 1] * step });
                // The grid's z is out of the body: a step up is a step less deep.
                let depths = points.map(|q| depth - (q.z - at.z));
                let u = forces.displacements(&kernel, &points, &depths, exact);
                let grad = |i: usize| (u[2 * i + 1] - u[2 * i + 2]) / (2.0 * step);
                let (gx, gy, gz) = (grad(0), grad(1), grad(2));
                let curl = 0.5 * Vector3::new(gy.z - gz.y, gz.x - gx.z, gx.y - gy.x);
                let (disp, omega) = one_force_at_a_time(&forces, &depth_kernel, &at, depth, exact);
                assert_eq!(disp, u[0], "at {at:?}: the displacement must be the same bits");
                assert!(
                    (omega - curl).norm() < 1e-6 * curl.norm(),
                    "at {at:?} depth {depth} exact {exact}: {omega:?} against {curl:?}"
                );
            }
        }
    }

    /// What broke: pins 0.66 mm under the skin saw each nearby cell as one point force at its
    /// centre, 0.77 mm off a 65-cell reference on 13 cells. A cell's load at a point a cell
    /// side or less below it must be its square's, not its centre's.
    #[test]
    fn pins_under_a_cell_feel_its_square_not_a_point_force() {
        let kernel = PinKernel::HalfSpace(DepthKernel::new(&Elastic::from_young(1.0, 0.436)));
        let h = 1.0;
        let grid = Grid::square(5, h);
        let centre = 12;
        let (mut p, mut qx, qy) = (vec![0.0; 25], vec![0.0; 25], vec![0.0; 25]);
        p[centre] = 0.2;
        qx[centre] = 0.05;
        let forces = CellForces::new(&grid, (&p, &qx, &qy), None, None, PIN_SUBSQUARES);
        let force = [0.05 * h * h, 0.0, 0.2 * h * h];
        for (x, depth) in [(0.0, 0.66), (0.3, 0.66), (0.8, 1.0), (0.2, 0.4)] {
            let at = Vector3::new(x, 0.1, 0.0);
            let [u] = forces.displacements(&kernel, &[at], &[depth], false);
            let exact = square_integral(&kernel, h, force, [x, 0.1, depth]);
            let point = kernel.displacement(force, [x, 0.1, depth]);
            let err = |v: [f64; 3]| {
                ((v[0] - exact[0]).powi(2) + (v[1] - exact[1]).powi(2) + (v[2] - exact[2]).powi(2)).sqrt()
            };
            let norm = (exact[0].powi(2) + exact[1].powi(2) + exact[2].powi(2)).sqrt();
            // `displacements` turns z out of the body.
            let got = [u.x, u.y, -u.z];
            // Measured: 0.6-1.9% with the sub-squares, 5-50% as one point force.
            assert!(err(got) < 0.03 * norm, "at x {x} depth {depth}: {got:?} against {exact:?}");
            assert!(err(point) > 5.0 * err(got), "the point force should be the worse: {point:?} against {got:?}");
        }
    }
}
