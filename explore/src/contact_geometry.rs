//! Contact geometry from the pins alone: the Voronoi tessellation of the tracked pins (spade),
//! each cell's area against its undeformed area as the local indentation, and a surface over
//! the cells' rest centroids (natural-neighbour interpolation) that says where the skin
//! touches.
//!
//! A pin pressed towards the camera moves apart from its neighbours in the image, so its
//! Voronoi cell grows; a sideways drag (sliding shear) moves a neighbourhood without growing
//! it. The indentation signal of pin `i` is `A_i / A0_i - 1`, with `A` its cell's area in the
//! current image and `A0` in the undeformed one (dimensionless; clamped at 0).
//!
//! Hull pins have unbounded cells, and the cells of pins next to the hull can reach far out
//! through the circumcentres of thin hull triangles: a cell counts only when it is bounded
//! and every corner lies within `reach` of its pin; other pins get no value (they are
//! skipped, not guessed).

use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};

/// A value at a point of the plane, for natural-neighbour interpolation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample {
    pub(crate) p: Point2<f64>,
    pub(crate) value: f64,
}

impl HasPosition for Sample {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.p
    }
}

/// A point of the tessellation with the index of its pin.
#[derive(Clone, Copy, Debug)]
struct Site {
    p: Point2<f64>,
    pin: usize,
}

impl HasPosition for Site {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.p
    }
}

/// The area of each pin's Voronoi cell among `points` (px^2, or the points' unit squared);
/// `None` for a missing pin, a hull pin, a cell with a corner farther than `reach` from its
/// pin, or a pin that shares its position with an earlier one.
pub fn cell_areas(points: &[Option<[f64; 2]>], reach: f64) -> Vec<Option<f64>> {
    let mut tri = DelaunayTriangulation::<Site>::new();
    for (pin, p) in points.iter().enumerate() {
        if let Some(p) = p
            && p[0].is_finite()
            && p[1].is_finite()
        {
            // A duplicate position keeps the earlier pin; the later one gets no cell.
            let _ = tri.insert(Site { p: Point2::new(p[0], p[1]), pin });
        }
    }
    let mut out = vec![None; points.len()];
    for v in tri.vertices() {
        let site = *v.data();
        if points[site.pin].is_none_or(|p| p != [site.p.x, site.p.y]) {
            continue;
        }
        let mut corners = Vec::new();
        let mut bounded = true;
        for e in v.out_edges() {
            match e.face().as_inner() {
                Some(f) => corners.push(f.circumcenter()),
                None => {
                    bounded = false;
                    break;
                }
            }
        }
        if !bounded || corners.len() < 3 {
            continue;
        }
        if corners.iter().any(|c| (c.x - site.p.x).hypot(c.y - site.p.y) > reach) {
            continue;
        }
        let mut twice = 0.0;
        for k in 0..corners.len() {
            let (a, b) = (corners[k], corners[(k + 1) % corners.len()]);
            twice += a.x * b.y - b.x * a.y;
        }
        out[site.pin] = Some(0.5 * twice.abs());
    }
    out
}

/// The undeformed tessellation of a sensor's pins.
#[derive(Clone, Debug)]
pub struct ContactGeometry {
    reference_area: Vec<Option<f64>>,
    reach_px: f64,
}

/// A pin's contact estimate: where it rests (contact-plane mm, sensor frame) and its local
/// indentation signal (cell area ratio minus one, at least 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinIndentation {
    /// Rest position (mm, sensor frame).
    pub rest_mm: [f64; 2],
    /// `A / A0 - 1`, clamped at 0.
    pub dilation: f64,
}

impl ContactGeometry {
    /// The tessellation of the undeformed pins `reference_px` (image px), with cells allowed
    /// to reach `1.5 spacing_px` from their pin.
    pub fn new(reference_px: &[[f64; 2]], spacing_px: f64) -> Self {
        let reach_px = 1.5 * spacing_px;
        let points: Vec<Option<[f64; 2]>> = reference_px.iter().map(|p| Some(*p)).collect();
        Self { reference_area: cell_areas(&points, reach_px), reach_px }
    }

    /// Pins with a cell in both images and a rest position: their indentation signal from the
    /// tracked positions `current_px` (same order as the reference; `None` where a pin was
    /// lost), placed at their rest positions `rest_mm` (same order).
    pub fn indentation(&self, current_px: &[Option<[f64; 2]>], rest_mm: &[Option<[f64; 2]>]) -> Vec<PinIndentation> {
        // A dilated cell may reach further than an undeformed one.
        let areas = cell_areas(current_px, 2.0 * self.reach_px);
        areas
            .iter()
            .zip(&self.reference_area)
            .zip(rest_mm)
            .filter_map(|((a, a0), r)| {
                let (a, a0, r) = ((*a)?, (*a0)?, (*r)?);
                (a0 > 0.0).then(|| PinIndentation { rest_mm: r, dilation: (a / a0 - 1.0).max(0.0) })
            })
            .collect()
    }
}

/// Largest cell growth (`A / A0 - 1`) read as no contact at all: pin detection jitter.
pub const NO_CONTACT: f64 = 0.02;

/// The indentation surface over the pins' rest positions (natural-neighbour interpolation of
/// their dilation), read with hysteresis against the largest dilation `max`: at each of
/// `points` (mm, sensor frame), `Some(true)` (the skin touches) above `touch * max`,
/// `Some(false)` (free skin) below `free * max`, `None` between (undecided: the rim of the
/// contact, where the indentation fades, and the free skin bent over an edge both dilate
/// somewhat) and outside the pins. All free when no cell grew by more than `NO_CONTACT`.
pub fn touching(pins: &[PinIndentation], free: f64, touch: f64, points: &[[f64; 2]]) -> Vec<Option<bool>> {
    let max = pins.iter().fold(0.0f64, |m, p| m.max(p.dilation));
    if max <= NO_CONTACT {
        return vec![Some(false); points.len()];
    }
    let samples: Vec<Sample> =
        pins.iter().map(|p| Sample { p: Point2::new(p.rest_mm[0], p.rest_mm[1]), value: p.dilation }).collect();
    let Ok(tri) = DelaunayTriangulation::<Sample>::bulk_load_stable(samples) else {
        return vec![None; points.len()];
    };
    let nn = tri.natural_neighbor();
    points
        .iter()
        .map(|q| {
            let v = nn.interpolate(|v| v.data().value, Point2::new(q[0], q[1]))?;
            if v > touch * max {
                Some(true)
            } else if v < free * max {
                Some(false)
            } else {
                None
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hexagonal lattice of spacing `s` within radius `r`.
    fn lattice(s: f64, r: f64) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        let n = (r / s) as i32 + 1;
        for j in -n..=n {
            for i in -n..=n {
                let p = [s * (f64::from(i) + 0.5 * f64::from(j)), s * f64::from(j) * 3f64.sqrt() / 2.0];
                if p[0].hypot(p[1]) <= r {
                    out.push(p);
                }
            }
        }
        out
    }

    #[test]
    fn voronoi_cells_of_a_hexagonal_lattice_are_its_hexagons_and_hull_pins_are_skipped() {
        let pts: Vec<Option<[f64; 2]>> = lattice(2.0, 10.0).into_iter().map(Some).collect();
        let areas = cell_areas(&pts, 3.0);
        // A regular hexagon around each inner pin: area sqrt(3)/2 s^2.
        let hex = 3f64.sqrt() / 2.0 * 4.0;
        let mut inner = 0;
        for (p, a) in pts.iter().zip(&areas) {
            let p = p.unwrap_or_default();
            if p[0].hypot(p[1]) < 6.0 {
                let a = a.unwrap_or(f64::NAN);
                assert!((a - hex).abs() < 1e-9, "pin {p:?}: area {a}, expected {hex}");
                inner += 1;
            }
            // No cell is huge: hull cells are skipped, thin ones next to the hull clipped.
            assert!(a.is_none_or(|a| a < 1.5 * hex), "pin {p:?}: area {a:?}");
        }
        assert!(inner > 20);
        // The extreme pins lie on the hull: unbounded cells, none.
        for extreme in [[10.0, 0.0], [-10.0, 0.0]] {
            let k = pts.iter().position(|p| *p == Some(extreme)).unwrap_or(usize::MAX);
            assert_eq!(areas.get(k).copied().flatten(), None, "hull pin {extreme:?}");
        }
        // A missing pin leaves a hole: its neighbours' cells grow, it has none.
        let mut holed = pts.clone();
        holed[pts.iter().position(|p| *p == Some([0.0, 0.0])).unwrap_or(0)] = None;
        let a = cell_areas(&holed, 3.0);
        assert!(a.iter().flatten().any(|v| *v > hex * 1.1));
    }

    #[test]
    fn a_pressed_spot_dilates_its_cells_and_a_uniform_drag_does_not() {
        let rest = lattice(2.0, 12.0);
        let rest_mm: Vec<Option<[f64; 2]>> = rest.iter().map(|p| Some(*p)).collect();
        let geometry = ContactGeometry::new(&rest, 2.0);
        // A drag: every pin shifted by 0.7 px.
        let dragged: Vec<Option<[f64; 2]>> = rest.iter().map(|p| Some([p[0] + 0.7, p[1] - 0.3])).collect();
        assert!(geometry.indentation(&dragged, &rest_mm).iter().all(|p| p.dilation < 1e-9));
        // A press around (4, 0): pins pushed radially apart, more near the centre.
        let c = [4.0, 0.0];
        let pressed: Vec<Option<[f64; 2]>> = rest
            .iter()
            .map(|p| {
                let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
                let g = 1.0 + 0.3 * (-(dx * dx + dy * dy) / 8.0).exp();
                Some([c[0] + g * dx, c[1] + g * dy])
            })
            .collect();
        let pins = geometry.indentation(&pressed, &rest_mm);
        let near = pins.iter().find(|p| p.rest_mm == [4.0, 0.0]).map_or(0.0, |p| p.dilation);
        let far = pins.iter().find(|p| p.rest_mm == [-6.0, 0.0]).map_or(1.0, |p| p.dilation);
        assert!(near > 0.3 && far < 0.01, "near {near}, far {far}");
        let t = touching(&pins, 0.1, 0.6, &[[4.0, 0.5], [-6.0, 0.0], [40.0, 0.0]]);
        assert_eq!(t, vec![Some(true), Some(false), None]);
        assert_eq!(touching(&geometry.indentation(&dragged, &rest_mm), 0.1, 0.6, &[[4.0, 0.0]]), vec![Some(false)]);
    }
}
