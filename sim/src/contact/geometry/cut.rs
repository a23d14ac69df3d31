//! Cells cut by a stimulus's sharp edge (issue 31).
//!
//! A cell is in or out of contact by the gap at its centre, so without this the contact's edge
//! along a stimulus's edge moves in steps of a cell, and the pins next to it follow on their
//! lever. A cut cell instead carries its traction on the part of its square over the stimulus's
//! top face: the edge, locally straight, is the line `d + a u + b v = 0` (`d` the signed
//! distance of the cell's centre from the top face's contour, mm, negative over the material;
//! `(a, b)` its change per mm of the cell's `(u, v)` offsets from the centre in the grid's
//! frame). The covered part is taken as a rectangle of the cell's side across the edge's
//! direction and `phi h` along it (`phi` the covered fraction), at the covered part's
//! centroid, loaded with the edge's singular profile across it (`p ~ s^(-1/2)` at a distance
//! `s` from the edge, a half-space's), whose force acts a third of the width in from the edge
//! ([`Cut::load_point_mm`]):
//! - its gap is the gap at that point, where its own load acts (at the centroid instead, the
//!   bench's rim taps were 0.212 / 0.080 mm off 65 cells on 13 / 25 cells, against 0.196 /
//!   0.067: `docs/experiments/contact.md`, "The near field of cut cells");
//! - its compliance to its own traction (the cell-average traction `t`, force `t h^2`) is
//!   that of a square of the covered area under the same force: a uniformly loaded square of
//!   side `c` on a half-space sinks at its centre by `4 asinh(1) (1 - nu^2) F / (pi E c)`
//!   (Love 1929), so the cut cell is `1 / sqrt(phi)` times as compliant as a whole one
//!   ([`compliance_ratio`]). Measured against the rectangle itself (Love's
//!   `(phi asinh(1/phi) + asinh(phi)) / (2 phi asinh 1)`) and against `1 / phi` on the bench's
//!   taps across the disk's rim, this one is closest to finer grids
//!   (`docs/experiments/contact.md`, "Cut cells");
//! - the cells next to it see its coupling to them ([`CutCoupling`]); the pins see its force
//!   at the sub-cells of a second solve along the edge ([`crate::contact::geometry::refine`]; with the profile
//!   of `pins::motion::edge_profile` without it).
//!
//! On a body with a skin the edge's pressure is the skin's line load, gathered within a fraction
//! of its thickness: there the profile is `p ~ s^(-1/2) exp(-s / lambda)` ([`EdgeProfile`]),
//! its centroid nearer the edge than a third, and every place above takes it. On the bench's
//! rim taps with the calibrated preset's 0.66 mm skin over a gel it took the pins' largest
//! error against 65 cells from 0.436 / 0.332 / 0.196 mm to 0.305 / 0.207 / 0.092 at 13 / 17 /
//! 25 cells (`docs/guide/fem.md`, "The contact grid").
//!
//! Every value is continuous in the edge's position as long as the edge stays in the cell; as
//! the cell becomes whole its load point moves from a third of the side in from its border to
//! its centre. On taps across the disk's rim the pins still move smoothly with the edge (test
//! `an_edge_moves_the_contact_smoothly_across_a_cell`).

use crate::contact::body::kernel::Kernel;
use crate::contact::body::operator::Operator;

/// Lines across the cell on which the covered length is taken exactly (the covered fraction
/// and centroid are their midpoint sums, continuous in `d`).
const LINES: usize = 16;

/// The part of a cell over a stimulus's top face, where an edge crosses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cut {
    /// Covered fraction of the cell's area, in `(0, 1)`.
    pub fraction: f64,
    /// The covered part's centroid, offset from the cell's centre (mm, grid frame).
    pub centroid_mm: [f64; 2],
    /// Sides (mm, along the grid's `x` and `y`) of the rectangle that stands for the covered
    /// part: the cell's side across the edge, `fraction` of it along the other axis.
    pub sides_mm: [f64; 2],
    /// Unit vector along the grid axis across the edge, from the covered part towards the
    /// edge (one of `(+-1, 0)`, `(0, +-1)`).
    pub toward_edge: [f64; 2],
    /// The edge's line `d + a u + b v = 0` as `[d, a, b]` (mm, and per mm of the offsets
    /// `(u, v)` from the cell's centre): the half-plane it was found from.
    pub line: [f64; 3],
    /// The pressure's profile across the edge (the body's).
    pub profile: EdgeProfile,
}

impl Cut {
    /// The cut of a square cell of side `side_mm` by the half-plane `d + a u + b v < 0`
    /// (offsets `(u, v)` from its centre, mm), loaded with `profile` across the edge: `None`
    /// when the cell is wholly on one side (within `1e-9` of its area).
    pub(crate) fn of_half_plane(side_mm: f64, d: f64, a: f64, b: f64, profile: EdgeProfile) -> Option<Self> {
        // Integrate exactly along the axis the line is steepest in: `w` along it, `s` across.
        let along_x = steepest_axis(a, b) == 0;
        let (g_across, g_along) = if along_x { (b, a) } else { (a, b) };
        if g_along == 0.0 {
            return None;
        }
        let h = side_mm;
        let (mut area, mut first_w, mut first_s) = (0.0, 0.0, 0.0);
        let dl = h / LINES as f64;
        for i in 0..LINES {
            let s = -0.5 * h + (i as f64 + 0.5) * dl;
            // Covered where `d + g_across s + g_along w < 0`.
            let w_edge = -(d + g_across * s) / g_along;
            let (lo, hi) =
                if g_along > 0.0 { (-0.5 * h, w_edge.min(0.5 * h)) } else { (w_edge.max(-0.5 * h), 0.5 * h) };
            let length = (hi - lo).max(0.0);
            area += length * dl;
            first_w += length * 0.5 * (lo + hi) * dl;
            first_s += length * s * dl;
        }
        let fraction = area / (h * h);
        if !(1e-9..=1.0 - 1e-9).contains(&fraction) {
            return None;
        }
        let (cw, cs) = (first_w / area, first_s / area);
        let (centroid_mm, sides_mm) =
            if along_x { ([cw, cs], [fraction * h, h]) } else { ([cs, cw], [h, fraction * h]) };
        let toward = g_along.signum();
        let toward_edge = if along_x { [toward, 0.0] } else { [0.0, toward] };
        Some(Self { fraction, centroid_mm, sides_mm, toward_edge, line: [d, a, b], profile })
    }

    /// Where the edge's profile puts the cell's force (offset from the cell's centre, mm, grid
    /// frame): the profile's centroid across the covered width (a third of it in from the edge
    /// where `p ~ s^(-1/2)`, the module's docs; nearer on a skin, [`EdgeProfile`]), at the
    /// covered part's centroid along it. The pins see the force there
    /// (`pins::motion::edge_profile`), and the cell's gap and displacement are taken there.
    pub(crate) fn load_point_mm(&self) -> [f64; 2] {
        let mut point = self.centroid_mm;
        let (axis, t) = self.across();
        let w = self.sides_mm[axis];
        point[axis] += if self.profile.decay_mm.is_finite() {
            t * (0.5 * w - self.profile.centroid_mm(0.0, w))
        } else {
            t * w * (0.5 - 1.0 / 3.0)
        };
        point
    }

    /// The grid axis across the edge (0 for `x`, 1 for `y`) and the direction along it from
    /// the covered part towards the edge (`+-1`): [`Cut::toward_edge`] as an axis and a sign.
    pub(crate) fn across(&self) -> (usize, f64) {
        let axis = if self.toward_edge[0] != 0.0 { 0 } else { 1 };
        (axis, self.toward_edge[axis])
    }

    /// Extra compliance of the cell to its own traction, relative to the whole cell's
    /// ([`compliance_ratio`] less one, `>= 0`).
    pub(crate) fn extra_compliance(&self) -> f64 {
        compliance_ratio(self.fraction) - 1.0
    }
}

/// Where the edge's profile (`p ~ s^(-1/2)` at a distance `s` from the edge, the module's
/// docs) puts the force of the band from `w` to `w + h` off the edge (mm): its centroid's
/// distance from the edge,
/// ```text
/// s_c = ((w + h)^(3/2) - w^(3/2)) / (3 ((w + h)^(1/2) - w^(1/2)))
/// ```
/// `h / 3` for a band that starts at the edge ([`Cut::load_point_mm`]'s third of the covered
/// width), nearer its middle the farther it starts: `0.4714 h` past the middle's `0.5 h`
/// from its start at `w = h`.
pub(crate) fn profile_centroid_mm(w: f64, h: f64) -> f64 {
    ((w + h).powf(1.5) - w.powf(1.5)) / (3.0 * ((w + h).sqrt() - w.sqrt()))
}

/// The pressure's profile across a sharp edge, `p(s) ~ s^(-1/2) exp(-s / decay_mm)` at a
/// distance `s` (mm) from it: a rigid punch's singular edge (Johnson 1985 sec. 2.8) where
/// `decay_mm` is infinite, the half-space's, and on a body with a skin a line load the skin
/// gathers within a fraction of its thickness ([`EdgeProfile::of_skin`]).
///
/// With `s = u^2` the force over a band is `2 int exp(-u^2 / decay) du`, so every figure here
/// is in closed form through `erfc`: the centroid of the band `u` in `[a, b]` is
/// ```text
/// s_c = decay / 2 - (decay / 2) (b e^(-b^2 / decay) - a e^(-a^2 / decay)) / int_a^b e^(-u^2 / decay) du
/// ```
/// and the equal-force strips' bounds are found by Newton steps on the integral.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EdgeProfile {
    /// The line load's decay length (mm; infinite: the singular profile alone).
    pub decay_mm: f64,
}

impl EdgeProfile {
    /// A half-space's: `p ~ s^(-1/2)` all the way.
    pub(crate) const SINGULAR: Self = Self { decay_mm: f64::INFINITY };

    /// The profile across a stimulus's edge on a skin `thickness_mm` thick over a softer body:
    /// decaying over [`DECAY_PER_SKIN`] of the thickness.
    pub(crate) fn of_skin(thickness_mm: f64) -> Self {
        Self { decay_mm: DECAY_PER_SKIN * thickness_mm }
    }

    /// The same profile on lengths `1 / unit_mm` as large (a grid in units of `unit_mm`).
    pub(crate) fn in_units(self, unit_mm: f64) -> Self {
        Self { decay_mm: self.decay_mm / unit_mm }
    }

    /// The profile's force over `u` in `[a, b]` (`s = u^2`), up to a constant factor:
    /// `int_a^b exp(-u^2 / decay) du`.
    fn band_force(&self, a: f64, b: f64) -> f64 {
        let r = self.decay_mm.sqrt();
        0.5 * std::f64::consts::PI.sqrt() * r * (libm::erfc(a / r) - libm::erfc(b / r))
    }

    /// The centroid's distance from the edge (mm) of the band from `w` to `w + h` off it.
    /// Singular: [`profile_centroid_mm`], which also stands in where the band ends within
    /// `1e-6` of the decay from the edge (the two part by about that fraction of its width).
    pub(crate) fn centroid_mm(&self, w: f64, h: f64) -> f64 {
        let (a, b) = (w.sqrt(), (w + h).sqrt());
        if !self.decay_mm.is_finite() || b * b < 1e-6 * self.decay_mm {
            return profile_centroid_mm(w, h);
        }
        let k = self.decay_mm;
        let force = self.band_force(a, b);
        let moment = 0.5 * k * (force - (b * (-b * b / k).exp() - a * (-a * a / k).exp()));
        moment / force
    }

    /// The centroids' distances from the edge (mm) of `n` strips of equal force across a band
    /// `width` mm wide that starts at the edge, nearest the edge first: singular,
    /// `width (3 i^2 + 3 i + 1) / (3 n^2)`.
    pub(crate) fn strip_centroids_mm(&self, width: f64, n: usize) -> Vec<f64> {
        let bounds = self.strip_bounds_mm(width, n);
        bounds.windows(2).map(|b| self.centroid_mm(b[0], b[1] - b[0])).collect()
    }

    /// The bounds (mm from the edge, `n + 1` of them, `0` to `width`) of `n` strips of equal
    /// force across a band `width` wide that starts at the edge: singular, `width (i / n)^2`.
    pub(crate) fn strip_bounds_mm(&self, width: f64, n: usize) -> Vec<f64> {
        let nf = n as f64;
        if !self.decay_mm.is_finite() {
            return (0..=n).map(|i| width * (i as f64 / nf).powi(2)).collect();
        }
        let top = width.sqrt();
        let whole = self.band_force(0.0, top);
        (0..=n)
            .map(|i| {
                let x = i as f64 / nf;
                if i == 0 || i == n {
                    return width * x * x;
                }
                // Newton on `u` from the singular profile's bound (`u = x top`), the force's
                // derivative the density `exp(-u^2 / decay)`; kept within `[0, top]`.
                let target = whole * x;
                let mut u = x * top;
                for _ in 0..NEWTON_STEPS {
                    let step = (self.band_force(0.0, u) - target) / (-u * u / self.decay_mm).exp();
                    u = (u - step).clamp(0.0, top);
                    if step.abs() <= 1e-13 * top {
                        break;
                    }
                }
                u * u
            })
            .collect()
    }
}

/// Newton steps at most for a strip's bound ([`EdgeProfile::strip_bounds_mm`]), each stopped
/// once a step is under `1e-13` of the band (the force is concave in `u`: a few steps).
const NEWTON_STEPS: usize = 30;

/// The edge profile's decay length on a skin over a softer body, as a fraction of the skin's
/// thickness ([`EdgeProfile::of_skin`]). On a skin the rim's pressure is a line load: on 65
/// cells 0.32-0.45 MPa in the column at the edge, 0.17 in the next, about 0.05 in the third
/// (`docs/experiments/fem-dome.md`), where the singular profile would keep 0.41 and 0.32 of
/// the first column's. Chosen on the bench's 40 rim taps with the calibrated half-space preset's skin
/// (0.66 mm) over a gel (`cargo run --release -p tacsim-sim --example grid_pins --
/// skin-on-gel 40 rim`): the largest pin error against 65 cells at 13 / 17 / 19 / 25 / 33
/// cells 0.305 / 0.207 / 0.172 / 0.092 / 0.064 mm, 0.436 / 0.332 / 0.283 / 0.196 / 0.091 with
/// the singular profile; decays of 0.2 to 1.0 mm (0.3 to 1.5 of the skin) tried with the load
/// points alone, 0.3-0.4 mm best (`docs/experiments/fem-dome.md`); on other taps and the
/// fitted dome's 1.86 mm skin: `docs/guide/fem.md`, "The contact grid".
pub(crate) const DECAY_PER_SKIN: f64 = 0.45;

/// The grid axis (0 for `x`, 1 for `y`) along which the line `d + a u + b v = 0` changes
/// fastest: the one a cut is taken across.
fn steepest_axis(a: f64, b: f64) -> usize {
    if a.abs() >= b.abs() { 0 } else { 1 }
}

/// The load point's offset (mm, grid frame) of a whole square of side `side_mm` on the
/// covered side of an edge, `d` (mm, as [`Cut::line`]'s, at the square's centre; `(a, b)` its
/// change per mm of the grid's `x, y`) the edge's line there: for the square right behind the
/// edge (its side nearest the edge within one side of it, across [`steepest_axis`], as a cut
/// is taken) the centroid of the edge's `profile` over it ([`EdgeProfile::centroid_mm`]), zero for
/// the others and past the edge.
///
/// A cut square carries that profile over its covered part (its load a third of the covered
/// width in from the edge), but the whole one behind it took its force at its centre, half a
/// side in: where the cut one covers little, most of the edge's load sits in the whole one,
/// and too far from the edge. Where the edge meets its side this gives `h / 3` from the edge,
/// as a barely cut square has. With the edge along the grid (17 cells, a 3.4 mm tap across
/// the disk's rim) the refinement's sub-cells (`refine.rs`, their only user) had the largest
/// pin error against 65 cells peak at 0.043 and 0.063 mm with the edge just past a sub-cell's
/// side (0.4 and 0.7 of its cell), against 0.017-0.028 elsewhere (regression test
/// `a_whole_sub_cell_behind_the_edge_takes_its_force_where_the_profile_puts_it`;
/// `docs/experiments/contact.md`, "The edge's profile behind a cut sub-cell").
pub(crate) fn behind_edge_mm(d: f64, [a, b]: [f64; 2], side_mm: f64, profile: EdgeProfile) -> [f64; 2] {
    let axis = steepest_axis(a, b);
    let slope = [a, b][axis];
    // The square's centre lies `t` from the edge across `axis`, its nearer side `w`.
    let t = -d / slope.abs();
    let w = t - 0.5 * side_mm;
    let mut offset = [0.0; 2];
    if d < 0.0 && (0.0..side_mm).contains(&w) {
        // Towards the edge: along `axis`, the way `d` grows.
        offset[axis] = (t - profile.centroid_mm(w, side_mm)) * slope.signum();
    }
    offset
}

/// Centre displacement of a square of area `phi h^2` carrying a whole `h x h` cell's force,
/// relative to the cell's own (Love's square, module docs): `1 / sqrt(phi)`.
pub(crate) fn compliance_ratio(phi: f64) -> f64 {
    phi.sqrt().recip()
}

/// Strips of equal force a cut cell's load is taken in across the edge for the solves' near
/// field on the contact grid ([`CutCoupling`]; the sub-cells along an edge take fewer,
/// `refine.rs`): the edge's profile, as the pins see it
/// (`pins::motion::edge_profile`), strip `i` from `s = w (i / n)^2` to `w ((i + 1) / n)^2`.
pub(crate) const STRIPS: usize = 3;

/// The cells around a cut cell whose coupling to it is taken from the covered part: those
/// within this many cells (sides and corners).
const NEAR_CELLS: usize = 1;

/// A step's cut cells as the solves see them: each one's own compliance, and its coupling to
/// the cells next to it.
///
/// Without the coupling a cut cell acts on the other cells from its centre, as a whole cell;
/// only its own compliance knew the cut, and on the bench's worst tap across the disk's rim
/// half of the pins' error at 13 cells came from the solve (`docs/experiments/contact.md`, "The
/// near field of cut cells"). Here the coefficient between a cut cell and a cell next to it
/// is the covered part's: its load with the edge's profile over the covered rectangle
/// ([`STRIPS`] strips), its displacement at its load point ([`Cut::load_point_mm`], where its
/// gap is taken), the two ways of a pair averaged so that the operator stays symmetric
/// (reciprocity). Farther cells keep the
/// whole cells' coefficients. Only the normal and in-plane blocks take it (the
/// normal-tangential coupling's odd components keep the whole cells').
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct CutCoupling {
    /// Per grid cell, its compliance to its own traction beyond the operator's diagonal,
    /// relative to it ([`Cut::extra_compliance`]; 0 for a whole cell).
    pub extra: Vec<f64>,
    /// Pairs of grid cells `(a, b)` next to each other, one at least cut, with the change of
    /// the even kernels' integrals ([`Kernel::even_antiderivatives`], in cell units: a unit
    /// cell's force, lengths in cells) between them, the same both ways.
    pub near: Vec<(usize, usize, [f64; 4])>,
}

impl CutCoupling {
    /// The coupling of the cut cells `cuts` (cells of `op`'s grid, ascending, each with its
    /// cut) among the cells the stimulus reaches into (`reached`: only they can carry a load
    /// or a gap the solves use), a cut cell's load taken in `strips` strips of the edge's
    /// profile ([`STRIPS`] on the contact grid); `None` without a cut. A list, not a grid
    /// field: the sub-cells along an edge are a few hundred of a fine grid's thousands.
    pub(crate) fn new(
        op: &Operator,
        cuts: &[(usize, Cut)],
        reached: impl Fn(usize) -> bool,
        strips: usize,
    ) -> Option<Self> {
        if cuts.is_empty() {
            return None;
        }
        debug_assert!(cuts.windows(2).all(|w| w[0].0 < w[1].0), "cut cells in ascending order");
        let grid = op.grid();
        let mut extra = vec![0.0; grid.len()];
        for (k, c) in cuts {
            extra[*k] = c.extra_compliance();
        }
        let (nx, ny, h) = (grid.nx, grid.ny, grid.cell_mm);
        let cut = |k: usize| cuts.binary_search_by_key(&k, |(c, _)| *c).ok();
        // The cut cells' patches once: each takes part in up to eight pairs.
        let cut_patches: Vec<Patch> = cuts.iter().map(|(k, c)| Patch::of(k % nx, k / nx, Some(c), h, strips)).collect();
        let patch = |k: usize| cut(k).map_or_else(|| Patch::of(k % nx, k / nx, None, h, strips), |i| cut_patches[i]);
        let mut near = Vec::new();
        for &(k, _) in cuts.iter().filter(|(k, _)| reached(*k)) {
            let (i, j) = (k % nx, k / nx);
            for nj in j.saturating_sub(NEAR_CELLS)..(j + NEAR_CELLS + 1).min(ny) {
                for ni in i.saturating_sub(NEAR_CELLS)..(i + NEAR_CELLS + 1).min(nx) {
                    let other = nj * nx + ni;
                    // Each pair once: from its cut cell of lower index.
                    if other == k || !reached(other) || (other < k && cut(other).is_some()) {
                        continue;
                    }
                    let (a, b) = (k.min(other), k.max(other));
                    let (pa, pb) = (patch(a), patch(b));
                    let (ab, ba) = (pa.seen_from(&pb), pb.seen_from(&pa));
                    let whole =
                        op.unit_integrals((a % nx) as isize - (b % nx) as isize, (a / nx) as isize - (b / nx) as isize);
                    near.push((a, b, std::array::from_fn(|m| 0.5 * (ab[m] + ba[m]) - whole[m])));
                }
            }
        }
        Some(Self { extra, near })
    }

    /// [`CutCoupling::new`] from a grid field of cuts (`None` where whole; empty without any)
    /// and the cells' initial gaps `g0` (mm: the stimulus reaches into a cell where
    /// `g0 < 0`).
    pub(crate) fn of_field(op: &Operator, cuts: &[Option<Cut>], g0: &[f64], strips: usize) -> Option<Self> {
        let listed: Vec<(usize, Cut)> = cuts.iter().enumerate().filter_map(|(k, c)| c.map(|c| (k, c))).collect();
        Self::new(op, &listed, |k| g0[k] < 0.0, strips)
    }
}

/// A cell, or a cut cell's covered part, in cell units (the grid's origin cell at 0).
#[derive(Clone, Copy, Debug)]
struct Patch {
    /// Centre (a cut cell's centroid: its covered rectangle's centre).
    centre: [f64; 2],
    /// Where its displacement is taken (a cut cell's [`Cut::load_point_mm`]).
    field: [f64; 2],
    /// Sides along the grid's axes.
    sides: [f64; 2],
    /// A cut cell's axis across the edge and its direction towards it.
    toward_edge: Option<(usize, f64)>,
    /// A cut cell's strips of equal force across the edge: their number and their bounds'
    /// distances from the edge (cell units, [`EdgeProfile::strip_bounds_mm`]), found once.
    strips: usize,
    bounds: [f64; MAX_STRIPS + 1],
}

/// The most strips a cut cell's coupling takes ([`STRIPS`] on the contact grid, fewer on the
/// sub-cells along an edge).
const MAX_STRIPS: usize = 3;

impl Patch {
    /// Cell `(i, j)`, or its part `cut` covers, a cut one's load in `strips` strips (at most
    /// [`MAX_STRIPS`]).
    fn of(i: usize, j: usize, cut: Option<&Cut>, cell_mm: f64, strips: usize) -> Self {
        let centre = [i as f64, j as f64];
        let whole =
            Self { centre, field: centre, sides: [1.0, 1.0], toward_edge: None, strips, bounds: [0.0; MAX_STRIPS + 1] };
        let Some(c) = cut else { return whole };
        assert!((1..=MAX_STRIPS).contains(&strips), "{strips} strips");
        let in_cells = |offset_mm: [f64; 2]| [centre[0] + offset_mm[0] / cell_mm, centre[1] + offset_mm[1] / cell_mm];
        let (axis, toward) = c.across();
        let sides = c.sides_mm.map(|v| v / cell_mm);
        let mut bounds = [0.0; MAX_STRIPS + 1];
        bounds[..=strips].copy_from_slice(&c.profile.in_units(cell_mm).strip_bounds_mm(sides[axis], strips));
        Self {
            centre: in_cells(c.centroid_mm),
            field: in_cells(c.load_point_mm()),
            sides,
            toward_edge: Some((axis, toward)),
            strips,
            bounds,
        }
    }

    /// The even kernels' integrals at this patch's field point from the unit force (a whole
    /// cell's at unit traction) on `source`: uniform over a whole cell, with the edge's
    /// profile over a covered part (in its strips).
    fn seen_from(&self, source: &Patch) -> [f64; 4] {
        let d = [self.field[0] - source.centre[0], self.field[1] - source.centre[1]];
        let Some((axis, toward)) = source.toward_edge else {
            return Kernel::even_rectangles(d[0], d[1], source.sides[0], source.sides[1]);
        };
        // Across the edge (`u` along `axis`, from the centre), `G(u)` is the antiderivatives'
        // difference over the other axis, and a strip from `lo` to `hi` integrates to
        // `G(lo) - G(hi)`.
        let (across, along) = (source.sides[axis], source.sides[1 - axis]);
        let g = |u: f64| {
            let (x, y) = if axis == 0 {
                ([d[0] - u; 2], [d[1] + 0.5 * along, d[1] - 0.5 * along])
            } else {
                ([d[0] + 0.5 * along, d[0] - 0.5 * along], [d[1] - u; 2])
            };
            let (p, q) = (Kernel::even_antiderivatives(x[0], y[0]), Kernel::even_antiderivatives(x[1], y[1]));
            std::array::from_fn::<f64, 4, _>(|m| p[m] - q[m])
        };
        let edge = 0.5 * toward * across;
        let (strips, bounds) = (source.strips, &source.bounds);
        let at = |b: usize| edge - toward * bounds[b];
        let mut sum = [0.0; 4];
        let mut last = (at(0), g(at(0)));
        for b in 1..=strips {
            let u = at(b);
            let next = (u, g(u));
            let ((lo, g_lo), (hi, g_hi)) = if last.0 < next.0 { (last, next) } else { (next, last) };
            // A unit force, `1 / strips` of it on the strip: its traction over the strip's area.
            let traction = 1.0 / (strips as f64 * (hi - lo) * along);
            for (s, (a, b)) in sum.iter_mut().zip(g_lo.iter().zip(&g_hi)) {
                *s += traction * (a - b);
            }
            last = next;
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::algebra::matrix::{CellProduct, MatrixCache};
    use crate::contact::body::kernel::Elastic;
    use crate::contact::body::operator::{Component, HalfSpace, Operator, Pairing};
    use crate::contact::geometry::grid::Grid;

    /// The decaying profile's band centroids and equal-force strips against a fine midpoint
    /// sum of `s^(-1/2) exp(-s / decay)` (with `s = u^2`), and the singular profile's closed
    /// forms where the decay is infinite or long against the band.
    #[test]
    fn the_edge_profiles_centroids_and_strips_match_its_integral() {
        let p = EdgeProfile { decay_mm: 0.3 };
        let sums = |w: f64, h: f64| {
            let (a, b, n) = (w.sqrt(), (w + h).sqrt(), 100_000);
            let du = (b - a) / n as f64;
            (0..n).fold((0.0, 0.0), |(f, m), i| {
                let u = a + (i as f64 + 0.5) * du;
                let g = (-u * u / p.decay_mm).exp() * du;
                (f + g, m + g * u * u)
            })
        };
        for (w, h) in [(0.0, 0.1), (0.0, 0.67), (0.2, 0.5), (1.0, 2.0), (3.0, 1.0)] {
            let (f, m) = sums(w, h);
            let c = p.centroid_mm(w, h);
            assert!((c - m / f).abs() < 1e-6 * h && c > w && c < w + h, "band {w} + {h}: {c} against {}", m / f);
            // Nearer the band's start than the singular profile's.
            assert!(c < profile_centroid_mm(w, h), "band {w} + {h}");
        }
        for width in [0.67, 3.0] {
            let bounds = p.strip_bounds_mm(width, 3);
            let whole = sums(0.0, width).0;
            assert_eq!((bounds[0], bounds[3]), (0.0, width));
            for (i, b) in bounds.windows(2).enumerate() {
                assert!((sums(b[0], b[1] - b[0]).0 - whole / 3.0).abs() < 1e-6 * whole, "strip {i}: {bounds:?}");
            }
        }
        let width = 0.67;
        let singular = EdgeProfile::SINGULAR;
        for (i, c) in singular.strip_centroids_mm(width, 3).iter().enumerate() {
            let fi = i as f64;
            assert!((c - width * (3.0 * fi * fi + 3.0 * fi + 1.0) / 27.0).abs() < 1e-12, "singular strip {i}");
        }
        assert_eq!(singular.strip_bounds_mm(width, 2), vec![0.0, width / 4.0, width]);
        let long = EdgeProfile { decay_mm: 1e9 };
        assert!((long.centroid_mm(0.0, width) - width / 3.0).abs() < 1e-9);
        assert!((long.centroid_mm(0.5, width) - profile_centroid_mm(0.5, width)).abs() < 1e-9);
    }

    /// A straight edge across `x`: the covered fraction is the covered width over the side,
    /// the centroid halfway along it, and both move continuously as the edge crosses.
    #[test]
    fn an_edge_along_y_covers_the_width_on_its_side() {
        let h = 0.8;
        // Covered where `x - 0.1 < 0`: `u` from -0.4 to 0.1.
        let c = Cut::of_half_plane(h, -0.1, 1.0, 0.0, EdgeProfile::SINGULAR).expect("cut");
        assert!((c.fraction - 0.625).abs() < 1e-12, "{c:?}");
        assert!((c.centroid_mm[0] - -0.15).abs() < 1e-12 && c.centroid_mm[1].abs() < 1e-12, "{c:?}");
        assert!((c.sides_mm[0] - 0.5).abs() < 1e-12 && (c.sides_mm[1] - h).abs() < 1e-12, "{c:?}");
        // Material on the other side: the mirror image.
        let m = Cut::of_half_plane(h, -0.1, -1.0, 0.0, EdgeProfile::SINGULAR).expect("cut");
        assert!((m.fraction - 0.625).abs() < 1e-12 && (m.centroid_mm[0] - 0.15).abs() < 1e-12, "{m:?}");
        // Wholly in or out.
        assert_eq!(Cut::of_half_plane(h, -0.5, 1.0, 0.0, EdgeProfile::SINGULAR), None);
        assert_eq!(Cut::of_half_plane(h, 0.5, 1.0, 0.0, EdgeProfile::SINGULAR), None);
    }

    /// A diagonal edge through the centre covers half the cell, its centroid on the covered
    /// side's diagonal at a third of the half-diagonal (the triangle's), within the lines'
    /// midpoint rule.
    #[test]
    fn a_diagonal_edge_covers_a_triangle() {
        let h = 1.0;
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let c = Cut::of_half_plane(h, 0.0, s, s, EdgeProfile::SINGULAR).expect("cut");
        assert!((c.fraction - 0.5).abs() < 1e-12, "{c:?}");
        // The triangle (-1/2, -1/2), (1/2, -1/2), (-1/2, 1/2): centroid (-1/6, -1/6).
        for v in c.centroid_mm {
            assert!((v - -1.0 / 6.0).abs() < 2e-3, "{c:?}");
        }
    }

    /// The covered fraction is continuous as the edge sweeps across: no step larger than
    /// the sweep's own.
    #[test]
    fn the_fraction_moves_smoothly_with_the_edge() {
        let h = 1.0;
        let (a, b) = (0.96, 0.28);
        let mut last = 1.0;
        for i in 0..=200 {
            let d = -0.75 + 1.5 * i as f64 / 200.0;
            let f = Cut::of_half_plane(h, d, a, b, EdgeProfile::SINGULAR)
                .map_or(if d < 0.0 { 1.0 } else { 0.0 }, |c| c.fraction);
            assert!((f - last).abs() <= 1.5 / 200.0 * 1.2, "d {d}: {f} after {last}");
            last = f;
        }
    }

    /// Love's square: 1 for the whole cell, growing as the covered part shrinks, as the
    /// square root of the area it loses.
    #[test]
    fn a_smaller_covered_part_is_more_compliant() {
        assert!((compliance_ratio(1.0) - 1.0).abs() < 1e-15);
        assert!((compliance_ratio(0.25) - 2.0).abs() < 1e-15);
        let c = Cut::of_half_plane(1.0, 0.25, -1.0, 0.0, EdgeProfile::SINGULAR).expect("cut");
        assert!((c.fraction - 0.25).abs() < 1e-12 && (c.extra_compliance() - 1.0).abs() < 1e-12, "{c:?}");
    }

    /// A whole cell is seen as the operator's tables see it (`Kernel::rectangle` on the unit
    /// cell; the even kernels).
    #[test]
    fn a_whole_cell_is_seen_as_the_tables_see_it() {
        let source = Patch::of(3, 4, None, 0.7, STRIPS);
        for (i, j) in [(3, 4), (4, 4), (2, 6), (9, 1)] {
            let seen = Patch::of(i, j, None, 0.7, STRIPS).seen_from(&source);
            for (k, v) in Kernel::ALL.iter().zip(seen) {
                let want = k.rectangle(i as f64 - 3.0, j as f64 - 4.0, 1.0, 1.0);
                assert!((v - want).abs() < 1e-12 * (1.0 + want.abs()), "{k:?} at ({i}, {j}): {v} vs {want}");
            }
        }
    }

    /// Far from a cut cell its load acts as one force where the edge's profile puts it, a
    /// third of the covered width in from the edge (the strips' own centroid is 0.352 of it,
    /// `19 / 54`: within the tolerance's 1e-3 at 40 cells), not at the covered part's
    /// centroid (half the width in, about 3e-3 off here).
    #[test]
    fn a_cut_cells_load_acts_a_third_of_its_width_in_from_the_edge() {
        let h = 0.5;
        // Covered where `u - 0.1 < 0` (mm from the cell's centre): 0.35 mm wide, the edge at
        // u = 0.1 mm.
        let cut = Cut::of_half_plane(h, -0.1, 1.0, 0.0, EdgeProfile::SINGULAR).expect("cut");
        let source = Patch::of(50, 50, Some(&cut), h, STRIPS);
        let force_at = [50.0 + (0.1 - 0.35 / 3.0) / h, 50.0];
        for (i, j) in [(90, 50), (50, 90), (20, 75), (10, 50)] {
            let seen = Patch::of(i, j, None, h, STRIPS).seen_from(&source);
            let (x, y) = (i as f64 - force_at[0], j as f64 - force_at[1]);
            let point: [f64; 4] = std::array::from_fn(|m| Kernel::ALL[m].value(x, y));
            let scale = point.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for ((k, v), want) in Kernel::ALL.iter().zip(seen).zip(point) {
                assert!((v - want).abs() < 1e-3 * scale, "{k:?} at ({i}, {j}): {v} vs {want}");
            }
        }
    }

    /// The cut cells' coupling keeps the operator symmetric (reciprocity, and what the
    /// normal solve's conjugate gradient needs): `y.(M x) = x.(M y)` on the normal block and
    /// the in-plane blocks, with an edge across a grid, and it changes the operator next to
    /// the edge only.
    #[test]
    fn the_coupled_operator_stays_symmetric() {
        let (n, h) = (7, 0.5);
        let grid = Grid::square(n, h);
        // The edge `0.3 x + 0.954 y = 0.12` (mm, from the grid's first cell), material below.
        let (a, b) = (0.3, 0.954);
        let cuts: Vec<Option<Cut>> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64 * h - 1.2, (k / n) as f64 * h - 1.4);
                Cut::of_half_plane(h, a * x + b * y - 0.12, a, b, EdgeProfile::SINGULAR)
            })
            .collect();
        assert!(cuts.iter().filter(|c| c.is_some()).count() >= n, "the edge must cut a row of cells");
        let op = Operator::new(
            &HalfSpace {
                material: Elastic { shear_modulus_mpa: 0.1, poisson: 0.436 },
                pairing: Pairing::RigidIndenter,
            },
            grid,
        );
        let reached = vec![-0.1; n * n];
        let coupling = CutCoupling::of_field(&op, &cuts, &reached, STRIPS).expect("cut cells");
        assert!(!coupling.near.is_empty());
        assert_eq!(CutCoupling::of_field(&op, &vec![None; n * n], &reached, STRIPS), None);
        // Cells the stimulus does not reach into (the last column) take no coupling.
        let mut last_open = reached.clone();
        (0..n).for_each(|j| last_open[j * n + n - 1] = 0.0);
        let partial = CutCoupling::of_field(&op, &cuts, &last_open, STRIPS).expect("cut cells");
        assert!(partial.near.iter().all(|&(a, b, _)| a % n != n - 1 && b % n != n - 1));
        assert!(partial.near.len() < coupling.near.len());
        let cells: Vec<usize> = (0..n * n).collect();
        let field = |seed: u64, len: usize| -> Vec<f64> {
            (0..len).map(|k| (((k as u64 * 2654435761 + seed) % 1000) as f64) / 1000.0 - 0.4).collect()
        };
        let mut cache = MatrixCache::default();
        let normal = [[Component::Zz]];
        let shear = [[Component::Xx, Component::Xy], [Component::Xy, Component::Yy]];
        let check = |product_x: &dyn Fn(&[f64], &mut [f64]), len: usize| {
            let (x, y) = (field(1, len), field(2, len));
            let (mut mx, mut my) = (vec![0.0; len], vec![0.0; len]);
            product_x(&x, &mut mx);
            product_x(&y, &mut my);
            let (a, b): (f64, f64) =
                (y.iter().zip(&mx).map(|(p, q)| p * q).sum(), x.iter().zip(&my).map(|(p, q)| p * q).sum());
            assert!((a - b).abs() < 1e-12 * a.abs().max(b.abs()), "{a} vs {b}");
        };
        let p = CellProduct::new(&op, &normal, &cells, usize::MAX, &mut cache).with_cut(Some(&coupling));
        check(&|x, y| p.apply(None, x, y), n * n);
        let plain = CellProduct::new(&op, &normal, &cells, usize::MAX, &mut cache);
        let (x, mut with, mut without) = (field(3, n * n), vec![0.0; n * n], vec![0.0; n * n]);
        p.apply_operator(None, &x, &mut with);
        plain.apply_operator(None, &x, &mut without);
        for (k, (w, o)) in with.iter().zip(&without).enumerate() {
            let (i, j) = (k % n, k / n);
            let near_cut = (i.saturating_sub(1)..(i + 2).min(n))
                .any(|ci| (j.saturating_sub(1)..(j + 2).min(n)).any(|cj| cuts[cj * n + ci].is_some()));
            assert_eq!(near_cut, w != o, "cell ({i}, {j}): {w} vs {o}");
        }
        let s = CellProduct::new(&op, &shear, &cells, usize::MAX, &mut cache).with_cut(Some(&coupling));
        check(&|x, y| s.apply(None, x, y), 2 * n * n);
    }

    /// The edge's profile behind a cut square continues the cut's: a whole square whose side
    /// the edge barely misses takes its force where a cut one that barely misses being whole
    /// does (a sixth of a side off its centre, a third of one from the edge), the next one in
    /// stays at its centre, and a square past the edge or with the edge far stays too.
    #[test]
    fn the_profile_behind_the_edge_continues_the_cuts() {
        let h = 0.4;
        assert!((profile_centroid_mm(0.0, h) - h / 3.0).abs() < 1e-15);
        // The edge `x = h / 2 + 1e-10` (the covered side at lower `x`, `d` growing along +x):
        // just past the whole square's side, and just past a cut one's whole (the profile's
        // centroid moves as the square root of the gap there: 2e-4 mm at 1e-6 mm).
        let d = -(0.5 * h + 1e-10);
        let behind = behind_edge_mm(d, [1.0, 0.0], h, EdgeProfile::SINGULAR);
        let cut = Cut::of_half_plane(h, -(0.5 * h - 1e-6), 1.0, 0.0, EdgeProfile::SINGULAR).expect("barely cut");
        assert!((behind[0] - h / 6.0).abs() < 1e-5 && behind[1] == 0.0, "{behind:?}");
        assert!((behind[0] - cut.load_point_mm()[0]).abs() < 1e-5, "{behind:?} {:?}", cut.load_point_mm());
        // The same edge along `y`, the covered side at higher `y`: towards `-y`.
        let down = behind_edge_mm(d, [0.0, -1.0], h, EdgeProfile::SINGULAR);
        assert!((down[1] + h / 6.0).abs() < 1e-5 && down[0] == 0.0, "{down:?}");
        // One square farther in (its side a whole side from the edge), past the edge, far.
        assert_eq!(behind_edge_mm(d - h, [1.0, 0.0], h, EdgeProfile::SINGULAR), [0.0; 2]);
        assert_eq!(behind_edge_mm(d + h, [1.0, 0.0], h, EdgeProfile::SINGULAR), [0.0; 2]);
        assert_eq!(behind_edge_mm(d - 5.0 * h, [1.0, 0.0], h, EdgeProfile::SINGULAR), [0.0; 2]);
    }
}
