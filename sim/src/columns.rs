//! Rays straight down a mesh, without its BVH: the triangles binned by where they lie over the
//! `(x, y)` plane of the mesh's frame, so that a ray along `-z` tests only the triangles over
//! its bin.
//!
//! The contact engine casts every ray of a footprint probe and of a gap field along one
//! direction, for an untilted sensor straight down. parry's BVH walk costs about 2,400
//! instructions a ray that reaches a built-in stimulus (`docs/experiments/contact.md`), whose flat
//! tops are long thin triangles (a constrained Delaunay triangulation of the outline alone)
//! with overlapping boxes; the triangles a ray tests over its bin (about 0.5 mm) are about
//! five. Those whose footprint, grown by [`MARGIN_MM`], does not hold the ray are skipped
//! (parry's test misses them too); each other goes through parry's own triangle ray cast
//! and, where it hits, parry's own box test, and the nearest hit is kept; where parry's
//! traversal could keep another (near-equal hits) the caller asks the BVH instead: the same
//! time of impact to the bit (`scene.rs`, test `straight_down_rays_hit_what_parrys_bvh_hits`).
//!
//! Binning is conservative: a triangle goes in every bin whose square, grown by
//! [`MARGIN_MM`], its footprint overlaps (row by row: the triangle's `x` extent
//! within the row's band), so rounding in a ray's bin or in parry's inside test
//! (f32, about 1e-5 mm at these sizes) never loses a triangle the ray could hit.

use rapier3d::math::Vector;
use rapier3d::parry::query::{Ray, RayCast};
use rapier3d::parry::shape::{TriMesh, Triangle};

/// How far (mm) beyond its square a bin still takes triangles.
const MARGIN_MM: f64 = 1e-3;
/// Bins per triangle, about: the bin side is `sqrt(area / (BINS_PER_TRIANGLE triangles))`.
const BINS_PER_TRIANGLE: f64 = 16.0;
/// Most bins per side (a very elongated mesh's bins grow instead).
const MAX_BINS_PER_SIDE: usize = 1024;

/// A mesh's triangles binned over its `(x, y)` plane (mesh frame, mm).
#[derive(Clone, Debug)]
pub(crate) struct ColumnIndex {
    /// Lower corner of bin `(0, 0)` (mm).
    min: [f64; 2],
    /// Bin side (mm).
    bin_mm: f64,
    nx: usize,
    ny: usize,
    /// Bin `j * nx + i` holds `items[starts[b]..starts[b + 1]]`.
    starts: Vec<u32>,
    /// Places in `facets`, bin after bin, each bin's triangles from the highest top down
    /// (then in mesh order).
    items: Vec<u32>,
    /// The triangles in any bin, in the order the bins first name them, each with what a
    /// ray tests of it.
    facets: Vec<Facet>,
}

/// A triangle with what a ray down its column tests first, together in two cache lines.
///
/// A step's rays (a few hundred, a bin each) reach the index after the solver's matrices have
/// passed through the core's cache: each triangle a ray tests is a load from farther away.
/// Kept apart (the tops, the sides and the triangles, three arrays in mesh order) a triangle
/// was three or four cache lines; together, two adjacent ones, which
/// [`ColumnIndex::fetch_ahead`] asks for ahead of the ray (issue 31, `docs/experiments/contact.md`,
/// "Rays down the column index").
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Facet {
    /// The highest `z` of the triangle (mm).
    top_mm: f64,
    /// Its footprint as its three sides' lines `[a, b, c]`, `a x + b y + c` the signed
    /// distance (mm) of `(x, y)` from the side, positive inwards; `None` for a footprint
    /// narrower than [`FLAT_MM`] (a wall's), which every ray over its bin tests.
    sides: Option<[[f64; 3]; 3]>,
    triangle: Triangle,
}

/// The stages of [`ColumnIndex::fetch_ahead`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ahead {
    /// The bin's place in the lists' starts.
    List,
    /// The first line of its list.
    Items,
    /// Its triangles.
    Facets,
}

/// A request to the cache for a line ahead of its use (x86's prefetch into every level): it
/// changes no value, only when a load finds its line near. A no-op elsewhere, and as
/// `Prefetch::default()`.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Prefetch {
    #[cfg(target_arch = "x86_64")]
    sse: Option<pulp::core_arch::x86::Sse>,
}

impl Prefetch {
    /// The requests of this CPU.
    pub(crate) fn new() -> Self {
        Self {
            #[cfg(target_arch = "x86_64")]
            sse: pulp::core_arch::x86::Sse::try_new(),
        }
    }

    /// Asks for the line holding `value`.
    #[inline(always)]
    fn line<T>(self, value: &T) {
        #[cfg(target_arch = "x86_64")]
        if let Some(sse) = self.sse {
            sse._mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(std::ptr::from_ref(value).cast());
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = value;
    }
}

/// A triangle whose footprint is narrower than this (mm, its least height) has no sides
/// ([`ColumnIndex::sides`]).
const FLAT_MM: f64 = 1e-6;

impl ColumnIndex {
    /// The index of `mesh` (its own frame).
    pub(crate) fn new(mesh: &TriMesh) -> Self {
        let triangles: Vec<Triangle> = mesh.triangles().collect();
        let aabb = mesh.local_aabb();
        let min = [aabb.mins.x as f64 - MARGIN_MM, aabb.mins.y as f64 - MARGIN_MM];
        let size = [aabb.maxs.x as f64 + MARGIN_MM - min[0], aabb.maxs.y as f64 + MARGIN_MM - min[1]];
        let area = (size[0] * size[1]).max(f64::MIN_POSITIVE);
        let mut bin_mm = (area / (BINS_PER_TRIANGLE * triangles.len().max(1) as f64)).sqrt();
        bin_mm = bin_mm.max(size[0].max(size[1]) / MAX_BINS_PER_SIDE as f64);
        let nx = ((size[0] / bin_mm).ceil() as usize).clamp(1, MAX_BINS_PER_SIDE);
        let ny = ((size[1] / bin_mm).ceil() as usize).clamp(1, MAX_BINS_PER_SIDE);
        let top_mm: Vec<f64> = triangles.iter().map(|t| t.a.z.max(t.b.z).max(t.c.z) as f64).collect();
        // Triangles from the highest top down (then in mesh order), so each bin's list is too.
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        order.sort_by(|a, b| top_mm[*b as usize].total_cmp(&top_mm[*a as usize]));
        // Two passes over the same bins: count, then fill.
        let each_bin = |tri: &Triangle, f: &mut dyn FnMut(usize)| {
            let corners = [tri.a, tri.b, tri.c].map(|v| [v.x as f64, v.y as f64]);
            let (lo, hi) =
                corners.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), c| (l.min(c[1]), h.max(c[1])));
            for j in bin_range(lo - MARGIN_MM, hi + MARGIN_MM, min[1], bin_mm, ny) {
                let band = [min[1] + j as f64 * bin_mm - MARGIN_MM, min[1] + (j + 1) as f64 * bin_mm + MARGIN_MM];
                let Some((x0, x1)) = x_extent(&corners, band) else { continue };
                for i in bin_range(x0 - MARGIN_MM, x1 + MARGIN_MM, min[0], bin_mm, nx) {
                    f(j * nx + i);
                }
            }
        };
        let mut starts = vec![0u32; nx * ny + 1];
        for &t in &order {
            each_bin(&triangles[t as usize], &mut |b| starts[b + 1] += 1);
        }
        for b in 0..nx * ny {
            starts[b + 1] += starts[b];
        }
        let mut items = vec![0u32; starts[nx * ny] as usize];
        let mut cursor: Vec<u32> = starts[..nx * ny].to_vec();
        for &t in &order {
            each_bin(&triangles[t as usize], &mut |b| {
                items[cursor[b] as usize] = t;
                cursor[b] += 1;
            });
        }
        // The facets in the order the bins first name them, bin after bin: a row of rays
        // reads them forwards.
        let mut place = vec![u32::MAX; triangles.len()];
        let mut facets = Vec::with_capacity(triangles.len());
        for t in &mut items {
            if place[*t as usize] == u32::MAX {
                place[*t as usize] = facets.len() as u32;
                let triangle = triangles[*t as usize];
                facets.push(Facet { top_mm: top_mm[*t as usize], sides: footprint_sides(&triangle), triangle });
            }
            *t = place[*t as usize];
        }
        Self { min, bin_mm, nx, ny, starts, items, facets }
    }

    /// The bin under `(x, y)` (mesh frame, mm), `None` off the index.
    pub(crate) fn bin_of(&self, x: f64, y: f64) -> Option<usize> {
        let (x, y) = ((x - self.min[0]) / self.bin_mm, (y - self.min[1]) / self.bin_mm);
        (x >= 0.0 && y >= 0.0 && x < self.nx as f64 && y < self.ny as f64).then(|| y as usize * self.nx + x as usize)
    }

    /// Asks the cache ahead for what a ray over bin `b` reads, stage by stage, each stage
    /// reading only what the one before fetched: [`Ahead::List`] its place in `starts`,
    /// [`Ahead::Items`] its list, [`Ahead::Facets`] its triangles. The caller takes the
    /// stages for bins further and further ahead of the ray it casts ([`crate::Scene`]'s
    /// rays down); a bin off the index (`usize::MAX`) fetches nothing.
    #[inline]
    pub(crate) fn fetch_ahead(&self, cache: Prefetch, stage: Ahead, b: usize) {
        if b >= self.nx * self.ny {
            return;
        }
        let list = || self.starts[b] as usize..self.starts[b + 1] as usize;
        match stage {
            Ahead::List => cache.line(&self.starts[b]),
            Ahead::Items => {
                // A list of up to 16 places spans at most two lines: its first and last.
                if let Some(items) = self.items.get(list())
                    && let (Some(first), Some(last)) = (items.first(), items.last())
                {
                    cache.line(first);
                    cache.line(last);
                }
            }
            Ahead::Facets => {
                for &t in &self.items[list()] {
                    let facet = &self.facets[t as usize];
                    cache.line(facet);
                    cache.line(&facet.triangle);
                }
            }
        }
    }

    /// Whether a ray straight down at `(x, y)` (mesh frame, mm) can hit `facet`'s triangle:
    /// its footprint, grown by [`MARGIN_MM`] (far above parry's f32 rounding), holds the point.
    /// One that does not is missed by parry's own test too, so it is skipped before it.
    fn over(facet: &Facet, x: f64, y: f64) -> bool {
        facet.sides.is_none_or(|sides| sides.iter().all(|[a, b, c]| a * x + b * y + c >= -MARGIN_MM))
    }

    /// The time of impact of `ray` (mesh frame, direction exactly `-z`) on the nearest triangle
    /// hit before `reach_mm` (`Some(None)` when none is), or `None` where parry's BVH might
    /// answer otherwise: two hits within [`MARGIN_MM`] of each other (triangles meeting under
    /// the ray, whose hits differ by rounding: the BVH keeps the first its traversal meets).
    /// A triangle counts only where parry's walk reaches it: where the ray passes its box by
    /// parry's own slab test ([`reaches_box`]). The bin's triangles are tried from the highest
    /// down, and the search stops at the first whose top lies farther below the ray's origin
    /// than the best hit by more than [`MARGIN_MM`] (it, and all after it, can only be hit
    /// farther: a flat top's hit skips the bottom face).
    pub(crate) fn cast_down(&self, ray: &Ray, reach_mm: f32) -> Option<Option<f32>> {
        debug_assert_eq!(ray.dir, Vector::new(0.0, 0.0, -1.0), "a column ray goes straight down");
        let Some(b) = self.bin_of(ray.origin.x as f64, ray.origin.y as f64) else { return Some(None) };
        let inv_dir =
            ray.dir.to_array().map(|r| if r.abs() < f32::EPSILON { r.signum() / f32::EPSILON } else { 1.0 / r });
        let at = [ray.origin.x as f64, ray.origin.y as f64];
        let mut nearest = Nearest::default();
        for &t in &self.items[self.starts[b] as usize..self.starts[b + 1] as usize] {
            let facet = &self.facets[t as usize];
            let best = nearest.best();
            if ray.origin.z as f64 - facet.top_mm > best.unwrap_or(reach_mm) as f64 + MARGIN_MM {
                break;
            }
            if !Self::over(facet, at[0], at[1]) {
                continue;
            }
            let triangle = &facet.triangle;
            // Hits up to a tie above the best are looked at too.
            let limit = best.map_or(reach_mm, |b| (b as f64 + MARGIN_MM) as f32);
            let Some(toi) = triangle.cast_local_ray(ray, limit, true) else { continue };
            if !reaches_box(triangle, ray, inv_dir) || best.is_none() && toi >= reach_mm {
                continue;
            }
            nearest.offer(toi, ());
        }
        nearest.unless_tied(MARGIN_MM).map(|hit| hit.map(|(toi, ())| toi))
    }
}

/// The nearest of several hits (time of impact in f32 mm, and what was hit), and whether
/// another came within a tie of it: where two hits lie that close, which one parry's BVH
/// keeps depends on its traversal, so the caller asks the BVH.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Nearest<T> {
    best: Option<(f32, T)>,
    /// The nearest of the other hits.
    next: f32,
}

impl<T> Default for Nearest<T> {
    fn default() -> Self {
        Self { best: None, next: f32::INFINITY }
    }
}

impl<T: Copy> Nearest<T> {
    /// The nearest time of impact so far.
    pub(crate) fn best(&self) -> Option<f32> {
        self.best.map(|(toi, _)| toi)
    }

    /// Takes a hit at `toi` on `what`.
    pub(crate) fn offer(&mut self, toi: f32, what: T) {
        match self.best {
            Some((b, _)) if toi >= b => self.next = self.next.min(toi),
            _ => {
                self.next = self.next.min(self.best().unwrap_or(f32::INFINITY));
                self.best = Some((toi, what));
            }
        }
    }

    /// The nearest hit (`Some(None)` when there was none), or `None` where another lies
    /// within `tie_mm` of it.
    pub(crate) fn unless_tied(self, tie_mm: f64) -> Option<Option<(f32, T)>> {
        match self.best {
            Some((b, _)) if self.next as f64 <= b as f64 + tie_mm => None,
            best => Some(best),
        }
    }
}

/// Whether parry's BVH walk reaches `triangle`'s box with `ray`: its slab test
/// (`BvhNode::cast_inv_ray_simd`) in the same f32 operations, with a zero direction component's
/// inverse `+-1 / f32::EPSILON` (`inv_dir`) as parry takes it: a ray straight down is taken
/// as drifting `f32::EPSILON` per mm of travel along `+x` and `+y`, so one that passes within
/// about 1e-5 mm of a box's side at 100 mm misses or meets the box by that drift, whatever
/// the triangle test says. A box reached passes its ancestors' tests too (theirs are larger).
fn reaches_box(triangle: &Triangle, ray: &Ray, inv_dir: [f32; 3]) -> bool {
    let (a, b, c) = (triangle.a.to_array(), triangle.b.to_array(), triangle.c.to_array());
    let origin = ray.origin.to_array();
    let (mut tmin, mut tmax) = (f32::NEG_INFINITY, f32::INFINITY);
    for k in 0..3 {
        // Finite values throughout: plain comparisons order them as parry's min and max do.
        let (lo, hi) = (least(least(a[k], b[k]), c[k]), most(most(a[k], b[k]), c[k]));
        let (t1, t2) = ((lo - origin[k]) * inv_dir[k], (hi - origin[k]) * inv_dir[k]);
        let (near, far) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
        if near > tmin {
            tmin = near;
        }
        if far < tmax {
            tmax = far;
        }
    }
    tmax >= tmin && tmax >= 0.0
}

/// The sides of `triangle`'s footprint ([`ColumnIndex::sides`]), `None` where it is narrower
/// than [`FLAT_MM`].
fn footprint_sides(triangle: &Triangle) -> Option<[[f64; 3]; 3]> {
    let corners = [triangle.a, triangle.b, triangle.c].map(|v| [v.x as f64, v.y as f64]);
    let edge = |k: usize| {
        let (p, q) = (corners[k], corners[(k + 1) % 3]);
        ([q[0] - p[0], q[1] - p[1]], p)
    };
    // Twice the signed area: positive when the corners run anticlockwise.
    let ([ux, uy], _) = edge(0);
    let ([vx, vy], _) = edge(1);
    let twice_area = ux * vy - uy * vx;
    let lengths = [0, 1, 2].map(|k| edge(k).0[0].hypot(edge(k).0[1]));
    let longest = lengths.iter().copied().fold(0.0, f64::max);
    if twice_area.abs() <= FLAT_MM * longest {
        return None;
    }
    let inwards = twice_area.signum();
    Some(std::array::from_fn(|k| {
        let ([dx, dy], p) = edge(k);
        // The inward normal of an anticlockwise side is its direction turned left.
        let (a, b) = (-dy * inwards / lengths[k], dx * inwards / lengths[k]);
        [a, b, -(a * p[0] + b * p[1])]
    }))
}

/// The lesser of two finite values.
fn least(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// The greater of two finite values.
fn most(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

/// The bins `i` (of `n` from `origin`, side `bin_mm`) whose span meets `[lo, hi]` (mm).
fn bin_range(lo: f64, hi: f64, origin: f64, bin_mm: f64, n: usize) -> std::ops::Range<usize> {
    let first = ((lo - origin) / bin_mm).floor().max(0.0) as usize;
    let last = ((hi - origin) / bin_mm).floor();
    if last < 0.0 {
        return 0..0;
    }
    first.min(n)..(last as usize + 1).min(n)
}

/// The `x` extent (mm) of the triangle `corners` (its footprint) within the band
/// `band[0] <= y <= band[1]`: over its corners inside the band and its edges' crossings of the
/// band's two lines. `None` when it misses the band.
fn x_extent(corners: &[[f64; 2]; 3], band: [f64; 2]) -> Option<(f64, f64)> {
    let mut xs = (f64::INFINITY, f64::NEG_INFINITY);
    let mut take = |x: f64| xs = (xs.0.min(x), xs.1.max(x));
    for (k, a) in corners.iter().enumerate() {
        if a[1] >= band[0] && a[1] <= band[1] {
            take(a[0]);
        }
        let b = corners[(k + 1) % 3];
        for y in band {
            if (a[1] - y) * (b[1] - y) < 0.0 {
                take(a[0] + (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]));
            }
        }
    }
    (xs.0 <= xs.1).then_some(xs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray whose point lies outside a triangle's footprint by more than the margin is one
    /// parry misses too; inside, both take it; a wall (a footprint without width) is always
    /// tested.
    #[test]
    fn a_ray_off_a_footprint_is_one_parry_misses() {
        let v = |x: f32, y: f32, z: f32| Vector::new(x, y, z);
        let triangle = Triangle::new(v(40.0, -3.0, 5.0), v(60.0, -2.0, 5.0), v(41.0, 30.0, 5.0));
        let mesh = TriMesh::new(vec![triangle.a, triangle.b, triangle.c], vec![[0, 1, 2]]).expect("mesh");
        let index = ColumnIndex::new(&mesh);
        let facet = &index.facets[0];
        let sides = facet.sides.expect("a footprint");
        let mut checked = 0;
        for i in 0..=80 {
            for j in 0..=80 {
                let (x, y) = (38.0 + 0.3 * i as f32, -5.0 + 0.45 * j as f32);
                let ray = Ray::new(v(x, y, 100.0), v(0.0, 0.0, -1.0));
                let hit = triangle.cast_local_ray(&ray, 1000.0, true);
                if !ColumnIndex::over(facet, x as f64, y as f64) {
                    assert_eq!(hit, None, "({x}, {y})");
                    checked += 1;
                } else if sides.iter().all(|[a, b, c]| a * x as f64 + b * y as f64 + c > 1e-3) {
                    assert!(hit.is_some(), "({x}, {y})");
                }
            }
        }
        assert!(checked > 1000, "{checked}");
        // Just outside the side from (40, -3) to (60, -2): more than the margin off, skipped.
        let (a, b, c) = ([40.0, -3.0], [60.0, -2.0], 1.0 / 401f64.sqrt());
        let off = [0.5 * (a[0] + b[0]) + 2e-3 * c, 0.5 * (a[1] + b[1]) - 2e-3 * 20.0 * c];
        assert!(!ColumnIndex::over(facet, off[0], off[1]));
        let wall = Triangle::new(v(0.0, 0.0, 0.0), v(10.0, 0.0, 0.0), v(10.0, 0.0, 5.0));
        assert_eq!(footprint_sides(&wall), None);
    }

    /// Fetching ahead reads only inside the index: every bin of a mesh at every stage, and
    /// the bin of a ray off it (`usize::MAX`), with and without the CPU's prefetch.
    #[test]
    fn fetching_ahead_reads_only_inside_the_index() {
        let v = |x: f32, y: f32, z: f32| Vector::new(x, y, z);
        let mesh = TriMesh::new(
            vec![v(0.0, 0.0, 1.0), v(4.0, 0.0, 1.0), v(0.0, 3.0, 2.0), v(4.0, 3.0, 0.5)],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .expect("mesh");
        let index = ColumnIndex::new(&mesh);
        for cache in [Prefetch::new(), Prefetch::default()] {
            for b in (0..index.nx * index.ny + 2).chain([usize::MAX]) {
                for stage in [Ahead::List, Ahead::Items, Ahead::Facets] {
                    index.fetch_ahead(cache, stage, b);
                }
            }
        }
        assert_eq!(index.bin_of(-1.0, 1.0), None);
        assert_eq!(index.bin_of(1.0, 1.0).map(|b| b < index.nx * index.ny), Some(true));
        // Every triangle in some bin has a facet, named in the order the bins first name them.
        assert_eq!(index.facets.len(), 2);
        let mut seen = 0;
        for &t in &index.items {
            assert!(t as usize <= seen, "facet {t} named before facet {seen}");
            seen = seen.max(t as usize + 1);
        }
    }
}
