//! The in-plane contour of a planar (prism) stimulus: the boundary loops of its flat top
//! face, with signed distance and edge tangent queries for ground-truth poses.
//!
//! Conventions: object frame, mm. Loops run counter-clockwise around material (holes
//! clockwise), so the material is on the left of the tangent and the outward normal is the
//! tangent turned clockwise. Signed distance is negative inside the material.

use std::collections::{HashMap, HashSet};

use super::mesh::winding_number;
use crate::error::{Result, SimError};
use crate::stimulus::Mesh;
use crate::stimulus::{perimeter, signed_area};

/// Boundary of the top face of a planar stimulus.
#[derive(Clone, Debug, PartialEq)]
pub struct Contour {
    /// Closed loops (no repeated closing vertex).
    pub loops: Vec<Vec<[f64; 2]>>,
    /// Height of the top face (mm).
    pub top_z_mm: f64,
}

/// Nearest point of a contour to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgePoint {
    /// Signed distance (mm), negative inside the material.
    pub signed_distance_mm: f64,
    /// Closest point on the contour (mm).
    pub point: [f64; 2],
    /// Unit tangent at that point, material on its left.
    pub tangent: [f64; 2],
}

impl Contour {
    /// Extracts the top-face boundary of a prism-like mesh: the triangles at the highest `z`
    /// whose normals point up, and the edges of those triangles not shared within that set.
    pub fn from_mesh(mesh: &Mesh, source_name: &str) -> Result<Self> {
        let (_, hi) = mesh.bounds();
        let top_z = hi[2];
        let tol = 1e-6 * (1.0 + top_z.abs());
        let mut directed: HashSet<(u32, u32)> = HashSet::new();
        let mut count = 0usize;
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
            if [a, b, c].iter().any(|v| (v[2] - top_z).abs() > tol) {
                continue;
            }
            let nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if nz <= 0.0 {
                continue;
            }
            count += 1;
            for (p, q) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                // An interior edge appears in both directions and cancels.
                if !directed.remove(&(q, p)) {
                    directed.insert((p, q));
                }
            }
        }
        if count == 0 {
            return Err(SimError::mesh(
                source_name,
                "no flat top face: a planar stimulus needs an upward face at its highest z",
            ));
        }
        let mut edges: HashMap<u32, u32> = HashMap::new();
        for (p, q) in directed {
            if let Some(prev) = edges.insert(p, q) {
                return Err(SimError::mesh(
                    source_name,
                    format!("top face boundary branches at vertex {} (to {} and {})", p + 1, prev + 1, q + 1),
                ));
            }
        }
        let mut loops = Vec::new();
        while let Some(&start) = edges.keys().min() {
            let mut lp = Vec::new();
            let mut v = start;
            loop {
                let p = mesh.vertices[v as usize];
                lp.push([p[0], p[1]]);
                let Some(next) = edges.remove(&v) else {
                    return Err(SimError::mesh(source_name, "top face boundary is not closed"));
                };
                v = next;
                if v == start {
                    break;
                }
            }
            loops.push(lp);
        }
        // Outer loops first.
        loops.sort_by(|a, b| signed_area(b).total_cmp(&signed_area(a)));
        Ok(Self { loops, top_z_mm: top_z })
    }

    /// Material area of the top face (mm^2).
    pub fn area_mm2(&self) -> f64 {
        self.loops.iter().map(|l| signed_area(l)).sum()
    }

    /// Total boundary length (mm).
    pub fn perimeter_mm(&self) -> f64 {
        self.loops.iter().map(|l| perimeter(l)).sum()
    }

    /// Whether `p` lies on the material (non-zero winding).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.loops.iter().map(|l| winding_number(l, p)).sum::<i32>() != 0
    }

    /// Nearest contour point, signed distance and tangent. At a polygon vertex the tangent is
    /// the mean of the two adjacent edge directions.
    pub fn nearest(&self, p: [f64; 2]) -> EdgePoint {
        let mut best = (f64::INFINITY, [0.0; 2], [1.0, 0.0]);
        for lp in &self.loops {
            let n = lp.len();
            for i in 0..n {
                let (a, b) = (lp[i], lp[(i + 1) % n]);
                let Some(SegmentPoint { t, point: q, distance2: d2, length: len }) = project_on_segment(a, b, p) else {
                    continue;
                };
                if d2 < best.0 {
                    best = (d2, q, tangent_at([lp[(i + n - 1) % n], a, b, lp[(i + 2) % n]], t, len));
                }
            }
        }
        let d = best.0.sqrt();
        EdgePoint { signed_distance_mm: if self.contains(p) { -d } else { d }, point: best.1, tangent: best.2 }
    }

    /// Signed distance to the edge (mm), negative inside the material.
    pub fn signed_distance(&self, p: [f64; 2]) -> f64 {
        self.nearest(p).signed_distance_mm
    }

    /// The segments that come within `margin_mm` of the box `[lo, hi]` (mm): where
    /// [`NearContour::nearest`] answers [`Contour::nearest`]'s question for the points in the
    /// box, in time for those segments only (one pass over the contour's segments, comparing
    /// boxes), sorted into square buckets of about the margin's side over the box, each
    /// listing the segments within the margin of it.
    pub fn near(&self, lo: [f64; 2], hi: [f64; 2], margin_mm: f64) -> NearContour {
        let (lo, hi) = ([lo[0] - margin_mm, lo[1] - margin_mm], [hi[0] + margin_mm, hi[1] + margin_mm]);
        let mut segments = Vec::new();
        for lp in &self.loops {
            let n = lp.len();
            for i in 0..n {
                let (a, b) = (lp[i], lp[(i + 1) % n]);
                if a[0].max(b[0]) < lo[0] || a[0].min(b[0]) > hi[0] || a[1].max(b[1]) < lo[1] || a[1].min(b[1]) > hi[1]
                {
                    continue;
                }
                segments.push([lp[(i + n - 1) % n], a, b, lp[(i + 2) % n]]);
            }
        }
        NearContour::bucketed(segments, lo, hi, margin_mm)
    }
}

/// The part of a [`Contour`] near a box ([`Contour::near`]): each segment with the vertices
/// before and after it (object frame, mm), and the buckets that list them by place.
#[derive(Clone, Debug, Default)]
pub struct NearContour {
    segments: Vec<[[f64; 2]; 4]>,
    margin_mm: f64,
    /// The buckets' grid: lower corner (mm), side (mm), columns and rows.
    origin: [f64; 2],
    side_mm: f64,
    shape: [usize; 2],
    /// Per bucket (row-major), the segments whose box comes within the margin of the bucket,
    /// in increasing order: `items[starts[k]..starts[k + 1]]`.
    starts: Vec<usize>,
    items: Vec<u32>,
}

/// Most buckets along a side of [`NearContour`]'s grid.
const MAX_BUCKETS_ACROSS: usize = 32;

impl NearContour {
    /// `segments` near the box `[lo, hi]` (grown by the margin already), in buckets of about
    /// the margin's side.
    fn bucketed(segments: Vec<[[f64; 2]; 4]>, lo: [f64; 2], hi: [f64; 2], margin_mm: f64) -> Self {
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(0.0);
        let side_mm = margin_mm.max(extent / MAX_BUCKETS_ACROSS as f64).max(1e-9);
        let shape = [0, 1].map(|k| (((hi[k] - lo[k]) / side_mm).ceil() as usize).clamp(1, MAX_BUCKETS_ACROSS + 1));
        let bucket = |v: f64, k: usize| (((v - lo[k]) / side_mm).floor().max(0.0) as usize).min(shape[k] - 1);
        // Each segment's bucket range: its box grown by the margin (and a hair more, so that
        // rounding cannot leave out a segment at the margin's distance).
        let grow = margin_mm * (1.0 + 1e-9) + 1e-12;
        let ranges: Vec<[usize; 4]> = segments
            .iter()
            .map(|&[_, a, b, _]| {
                let (x0, x1) = (a[0].min(b[0]) - grow, a[0].max(b[0]) + grow);
                let (y0, y1) = (a[1].min(b[1]) - grow, a[1].max(b[1]) + grow);
                [bucket(x0, 0), bucket(x1, 0), bucket(y0, 1), bucket(y1, 1)]
            })
            .collect();
        let mut counts = vec![0usize; shape[0] * shape[1] + 1];
        for r in &ranges {
            for j in r[2]..=r[3] {
                for i in r[0]..=r[1] {
                    counts[j * shape[0] + i + 1] += 1;
                }
            }
        }
        for k in 1..counts.len() {
            counts[k] += counts[k - 1];
        }
        let starts = counts.clone();
        let mut items = vec![0u32; counts[counts.len() - 1]];
        for (s, r) in ranges.iter().enumerate() {
            for j in r[2]..=r[3] {
                for i in r[0]..=r[1] {
                    let at = &mut counts[j * shape[0] + i];
                    items[*at] = s as u32;
                    *at += 1;
                }
            }
        }
        Self { segments, margin_mm, origin: lo, side_mm, shape, starts, items }
    }

    /// The segments that can be within the margin of `p`, in increasing order: its bucket's;
    /// `None` for a point outside the buckets' grid.
    fn candidates(&self, p: [f64; 2]) -> Option<&[u32]> {
        let (i, j) = ((p[0] - self.origin[0]) / self.side_mm, (p[1] - self.origin[1]) / self.side_mm);
        if !(i >= 0.0 && j >= 0.0 && i < self.shape[0] as f64 && j < self.shape[1] as f64) || self.starts.len() < 2 {
            return None;
        }
        let k = j as usize * self.shape[0] + i as usize;
        Some(&self.items[self.starts[k]..self.starts[k + 1]])
    }

    /// [`Contour::nearest`] for a point `p` of the box within the margin of the contour
    /// (`None` farther): the same nearest point and tangent, the sign from the side of the
    /// tangent `p` lies on (material on its left) instead of a winding number, which agree
    /// off the contour (test `near_contours_answer_as_the_whole`).
    pub fn nearest(&self, p: [f64; 2]) -> Option<EdgePoint> {
        match self.candidates(p) {
            Some(near) => self.nearest_of(p, near.iter().map(|&s| &self.segments[s as usize])),
            None => self.nearest_of(p, self.segments.iter()),
        }
    }

    /// [`NearContour::nearest`] among `segments`, taken in the contour's order (the first of
    /// equally near ones wins, as in [`Contour::nearest`]).
    fn nearest_of<'s>(&self, p: [f64; 2], segments: impl Iterator<Item = &'s [[f64; 2]; 4]>) -> Option<EdgePoint> {
        let mut best: Option<(f64, [f64; 2], [f64; 2])> = None;
        for &[before, a, b, after] in segments {
            // A segment whose box is farther than the best so far cannot be nearer.
            let gap = |lo: f64, hi: f64, v: f64| (lo - v).max(v - hi).max(0.0);
            let (gx, gy) = (gap(a[0].min(b[0]), a[0].max(b[0]), p[0]), gap(a[1].min(b[1]), a[1].max(b[1]), p[1]));
            if gx * gx + gy * gy > best.map_or(self.margin_mm * self.margin_mm, |(d, _, _)| d) {
                continue;
            }
            let Some(SegmentPoint { t, point: q, distance2: d2, length: len }) = project_on_segment(a, b, p) else {
                continue;
            };
            if best.is_some_and(|(d, _, _)| d2 >= d) {
                continue;
            }
            best = Some((d2, q, tangent_at([before, a, b, after], t, len)));
        }
        let (d2, point, tangent) = best?;
        let d = d2.sqrt();
        if d > self.margin_mm {
            return None;
        }
        // Material on the tangent's left: a point there is inside.
        let left = tangent[0] * (p[1] - point[1]) - tangent[1] * (p[0] - point[0]) > 0.0;
        Some(EdgePoint { signed_distance_mm: if left { -d } else { d }, point, tangent })
    }
}

/// The unit tangent at `t` along segment `a`-`b` (length `len`, mm) of `[before, a, b,
/// after]`: the segment's direction, and at a vertex (`t` 0 or 1) its mean with the
/// neighbouring segment's.
fn tangent_at([before, a, b, after]: [[f64; 2]; 4], t: f64, len: f64) -> [f64; 2] {
    let dir = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
    if t != 0.0 && t != 1.0 {
        return dir;
    }
    let (c, d) = if t == 0.0 { (before, a) } else { (b, after) };
    let (fx, fy) = (d[0] - c[0], d[1] - c[1]);
    let fl = fx.hypot(fy).max(1e-300);
    let (mx, my) = (dir[0] + fx / fl, dir[1] + fy / fl);
    let ml = mx.hypot(my);
    if ml > 1e-12 { [mx / ml, my / ml] } else { dir }
}

/// The point of segment `a`-`b` nearest `p` (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentPoint {
    /// Where along the segment, 0 at `a` to 1 at `b`.
    pub t: f64,
    /// The point.
    pub point: [f64; 2],
    /// Its squared distance from `p` (mm^2).
    pub distance2: f64,
    /// The segment's length (mm).
    pub length: f64,
}

/// The point of segment `a`-`b` nearest `p`: `a + t (b - a)` with `t` the projection clamped
/// to `[0, 1]`; `None` for a segment of zero length. Every walk over a polyline that asks
/// "where on it is `p`" ([`Contour::nearest`], the closed loop's progress) projects here.
pub fn project_on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> Option<SegmentPoint> {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let len2 = ex * ex + ey * ey;
    if len2 == 0.0 {
        return None;
    }
    let t = (((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / len2).clamp(0.0, 1.0);
    let point = [a[0] + t * ex, a[1] + t * ey];
    let distance2 = (p[0] - point[0]).powi(2) + (p[1] - point[1]).powi(2);
    Some(SegmentPoint { t, point, distance2, length: len2.sqrt() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stimulus::Outline;

    #[test]
    fn a_point_projects_inside_a_segment_or_onto_its_nearer_end() {
        let (a, b) = ([0.0, 0.0], [4.0, 0.0]);
        let inside = project_on_segment(a, b, [1.0, 3.0]).expect("a segment of length 4 mm");
        assert_eq!((inside.t, inside.point, inside.distance2, inside.length), (0.25, [1.0, 0.0], 9.0, 4.0));
        let past = project_on_segment(a, b, [7.0, -4.0]).expect("a segment of length 4 mm");
        assert_eq!((past.t, past.point, past.distance2), (1.0, b, 25.0));
        assert_eq!(project_on_segment(a, a, [1.0, 1.0]), None);
    }

    #[test]
    fn disk_contour_distance_and_tangent() {
        let poly = Outline::Disk { radius_mm: 50.0 }.polygon(0.5);
        let mesh = Mesh::prism(&poly, 10.0, "disk").expect("prism");
        let c = Contour::from_mesh(&mesh, "disk").expect("contour");
        assert_eq!(c.loops.len(), 1);
        assert_eq!(c.top_z_mm, 10.0);
        let e = c.nearest([60.0, 0.0]);
        assert!((e.signed_distance_mm - 10.0).abs() < 1e-3, "{e:?}");
        assert!((e.tangent[0]).abs() < 1e-3 && (e.tangent[1] - 1.0).abs() < 1e-3, "{e:?}");
        let inside = c.nearest([0.0, 45.0]);
        assert!((inside.signed_distance_mm + 5.0).abs() < 1e-3 && inside.tangent[0] < -0.999, "{inside:?}");
    }

    /// The near part of a contour gives the whole's nearest point, tangent and signed distance
    /// for every point of its box within its margin, and nothing farther: every built-in
    /// shape, 2 mm boxes across its edge (and a few wholly inside or outside).
    #[test]
    fn near_contours_answer_as_the_whole() {
        use rand::{Rng, SeedableRng};
        let catalogue = crate::builtin_catalogue().expect("shapes");
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (mut answered, mut none) = (0, 0);
        for name in catalogue.names() {
            let c = &catalogue.get(&name).expect("a built-in").contour;
            for _ in 0..40 {
                // A box about a random point near a random vertex: 2 mm across, or one in four
                // 20-60 mm (a grid of buckets wider than the margin).
                let lp = &c.loops[rng.random_range(0..c.loops.len())];
                let v = lp[rng.random_range(0..lp.len())];
                let centre = [v[0] + rng.random_range(-3.0..3.0), v[1] + rng.random_range(-3.0..3.0)];
                let half = if rng.random_bool(0.25) { rng.random_range(10.0..30.0) } else { 1.0 };
                let (lo, hi) = ([centre[0] - half, centre[1] - half], [centre[0] + half, centre[1] + half]);
                let near = c.near(lo, hi, 1.5);
                for _ in 0..20 {
                    let p = [rng.random_range(lo[0]..hi[0]), rng.random_range(lo[1]..hi[1])];
                    let whole = c.nearest(p);
                    match near.nearest(p) {
                        Some(e) => {
                            answered += 1;
                            assert!(whole.signed_distance_mm.abs() <= 1.5, "{name} {p:?}");
                            assert!(
                                (e.signed_distance_mm - whole.signed_distance_mm).abs() < 1e-12,
                                "{name} {p:?}: {e:?} {whole:?}"
                            );
                            assert_eq!((e.point, e.tangent), (whole.point, whole.tangent), "{name} {p:?}");
                        }
                        None => {
                            none += 1;
                            assert!(whole.signed_distance_mm.abs() > 1.5, "{name} {p:?}: {whole:?}");
                        }
                    }
                }
            }
        }
        assert!(answered > 1000 && none > 100, "{answered} {none}");
    }
}
