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
//! centroid:
//! - its gap is the gap at the centroid;
//! - its compliance to its own traction (the cell-average traction `t`, force `t h^2`) is
//!   that of a square of the covered area under the same force: a uniformly loaded square of
//!   side `c` on a half-space sinks at its centre by `4 asinh(1) (1 - nu^2) F / (pi E c)`
//!   (Love 1929), so the cut cell is `1 / sqrt(phi)` times as compliant as a whole one
//!   ([`compliance_ratio`]). Measured against the rectangle itself (Love's
//!   `(phi asinh(1/phi) + asinh(phi)) / (2 phi asinh 1)`) and against `1 / phi` on the bench's
//!   taps across the disk's rim, this one is closest to finer grids
//!   (`docs/guide/contact.md`, "Cut cells");
//! - the pins see its force with the edge's singular profile across the rectangle, `w / 3`
//!   from the edge (`pin_motion::edge_profile`).
//!
//! Every value is continuous in the edge's position, so the contact and the pins move
//! smoothly as the edge crosses a cell.

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
}

impl Cut {
    /// The cut of a square cell of side `side_mm` by the half-plane `d + a u + b v < 0`
    /// (offsets `(u, v)` from its centre, mm): `None` when the cell is wholly on one side
    /// (within `1e-9` of its area).
    pub(crate) fn of_half_plane(side_mm: f64, d: f64, a: f64, b: f64) -> Option<Self> {
        // Integrate exactly along the axis the line is steepest in: `w` along it, `s` across.
        let along_x = a.abs() >= b.abs();
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
        Some(Self { fraction, centroid_mm, sides_mm, toward_edge })
    }

    /// Extra compliance of the cell to its own traction, relative to the whole cell's
    /// ([`compliance_ratio`] less one, `>= 0`).
    pub(crate) fn extra_compliance(&self) -> f64 {
        compliance_ratio(self.fraction) - 1.0
    }
}

/// Centre displacement of a square of area `phi h^2` carrying a whole `h x h` cell's force,
/// relative to the cell's own (Love's square, module docs): `1 / sqrt(phi)`.
pub(crate) fn compliance_ratio(phi: f64) -> f64 {
    phi.sqrt().recip()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight edge across `x`: the covered fraction is the covered width over the side,
    /// the centroid halfway along it, and both move continuously as the edge crosses.
    #[test]
    fn an_edge_along_y_covers_the_width_on_its_side() {
        let h = 0.8;
        // Covered where `x - 0.1 < 0`: `u` from -0.4 to 0.1.
        let c = Cut::of_half_plane(h, -0.1, 1.0, 0.0).expect("cut");
        assert!((c.fraction - 0.625).abs() < 1e-12, "{c:?}");
        assert!((c.centroid_mm[0] - -0.15).abs() < 1e-12 && c.centroid_mm[1].abs() < 1e-12, "{c:?}");
        assert!((c.sides_mm[0] - 0.5).abs() < 1e-12 && (c.sides_mm[1] - h).abs() < 1e-12, "{c:?}");
        // Material on the other side: the mirror image.
        let m = Cut::of_half_plane(h, -0.1, -1.0, 0.0).expect("cut");
        assert!((m.fraction - 0.625).abs() < 1e-12 && (m.centroid_mm[0] - 0.15).abs() < 1e-12, "{m:?}");
        // Wholly in or out.
        assert_eq!(Cut::of_half_plane(h, -0.5, 1.0, 0.0), None);
        assert_eq!(Cut::of_half_plane(h, 0.5, 1.0, 0.0), None);
    }

    /// A diagonal edge through the centre covers half the cell, its centroid on the covered
    /// side's diagonal at a third of the half-diagonal (the triangle's), within the lines'
    /// midpoint rule.
    #[test]
    fn a_diagonal_edge_covers_a_triangle() {
        let h = 1.0;
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let c = Cut::of_half_plane(h, 0.0, s, s).expect("cut");
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
            let f = Cut::of_half_plane(h, d, a, b).map_or(if d < 0.0 { 1.0 } else { 0.0 }, |c| c.fraction);
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
        let c = Cut::of_half_plane(1.0, 0.25, -1.0, 0.0).expect("cut");
        assert!((c.fraction - 0.25).abs() < 1e-12 && (c.extra_compliance() - 1.0).abs() < 1e-12, "{c:?}");
    }
}
