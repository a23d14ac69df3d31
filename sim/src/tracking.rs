//! Pin tracking between a reference image's pins and a deformed image's detected pins.
//!
//! Pins of a TacTip move by up to about half their spacing between images, and more as a
//! whole when the skin is sheared, so plain nearest neighbours mismatch. The tracker:
//! 1. starts from a [`Warp`]: a shift ([`global_shift`] estimates a large one) and, for
//!    presses, a spread about the image centre ([`global_warp`]): a deep press spreads the
//!    outer pins by most of a spacing, which a shift alone mismatches by one pin;
//! 2. grows the matches best first: each untracked pin's position is predicted from the
//!    local affine field of its tracked neighbours (from the warp while it has none), and the
//!    pin whose nearest free detection beats the runner-up by the widest margin is matched
//!    next. Clear pins decide the ambiguous ones: under a deep press the pins near the
//!    contact spread by up to a spacing over a few rings (the skin there comes towards the
//!    camera and is magnified), which no single warp fits and which the neighbours' median
//!    of a patch matched one ring off would keep confirming;
//! 3. re-assigns all pins to their local predictions by minimum total squared distance
//!    (Kuhn-Munkres), a pin farther than `MATCH_FRACTION` of the spacing from every free
//!    detection staying unmatched: a whole-image assignment cannot slide the lattice by one
//!    pin, as nearest neighbours can;
//! 4. rejects matches whose displacement departs from their neighbours' median by more than
//!    `SMOOTH_FRACTION` of the spacing.
//!
//! Pins left without a trustworthy match are reported as unmatched, never guessed.
//! Coordinates are image pixels.

/// Largest distance from prediction to detection for a match, in pin spacings.
const MATCH_FRACTION: f64 = 0.45;
/// Largest departure of a pin's displacement from its neighbours' median, in pin spacings.
const SMOOTH_FRACTION: f64 = 0.35;
/// Neighbours used for the smooth prediction and check.
const NEIGHBOURS: usize = 6;
/// Prediction-assignment passes after the growth.
const PASSES: usize = 3;
/// Reference neighbours within this many spacings inform a pin's local prediction.
const LOCAL_RADIUS: f64 = 2.5;
/// Reference neighbours within this many spacings are tracked pins' growth front.
const FRONT_RADIUS: f64 = 1.5;
/// Smallest margin (spacings) by which a growth step's detection must beat the runner-up.
const MIN_MARGIN: f64 = 0.1;

/// The result of tracking.
#[derive(Clone, Debug, PartialEq)]
pub struct Tracking {
    /// Per reference pin: its displacement (px), or `None` when unmatched.
    pub displacement: Vec<Option<[f64; 2]>>,
    /// Per reference pin: index of the matched detection.
    pub matched: Vec<Option<usize>>,
    /// Global shift (px): the median displacement of the matched pins.
    pub global_shift: [f64; 2],
}

impl Tracking {
    /// Reference pins without a match.
    pub fn unmatched(&self) -> usize {
        self.matched.iter().filter(|m| m.is_none()).count()
    }
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Median of `v` (0 when empty).
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// A uniform bucket grid over points, for nearest-neighbour queries.
struct Buckets {
    cell: f64,
    origin: [f64; 2],
    nx: usize,
    ny: usize,
    cells: Vec<Vec<usize>>,
}

impl Buckets {
    fn new(points: &[[f64; 2]], cell: f64) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if points.is_empty() {
            lo = [0.0; 2];
            hi = [0.0; 2];
        }
        let nx = ((hi[0] - lo[0]) / cell).floor() as usize + 1;
        let ny = ((hi[1] - lo[1]) / cell).floor() as usize + 1;
        let mut cells = vec![Vec::new(); nx * ny];
        for (i, p) in points.iter().enumerate() {
            let (cx, cy) = (((p[0] - lo[0]) / cell) as usize, ((p[1] - lo[1]) / cell) as usize);
            cells[cy * nx + cx].push(i);
        }
        Self { cell, origin: lo, nx, ny, cells }
    }

    /// The nearest point to `q` within `radius` (squared distance, index).
    fn nearest(&self, points: &[[f64; 2]], q: [f64; 2], radius: f64) -> Option<(f64, usize)> {
        self.nearest_two(points, q, radius, |_| true).map(|(best, _)| best)
    }

    /// The two nearest points to `q` within `radius` that `free` accepts: (squared distance,
    /// index) of the nearest and the runner-up's squared distance (infinite when none).
    fn nearest_two(
        &self,
        points: &[[f64; 2]],
        q: [f64; 2],
        radius: f64,
        free: impl Fn(usize) -> bool,
    ) -> Option<((f64, usize), f64)> {
        let r = (radius / self.cell).ceil() as isize;
        let cx = ((q[0] - self.origin[0]) / self.cell).floor() as isize;
        let cy = ((q[1] - self.origin[1]) / self.cell).floor() as isize;
        let (mut best, mut second): (Option<(f64, usize)>, f64) = (None, f64::INFINITY);
        for y in (cy - r).max(0)..=(cy + r).min(self.ny as isize - 1) {
            for x in (cx - r).max(0)..=(cx + r).min(self.nx as isize - 1) {
                for &i in &self.cells[y as usize * self.nx + x as usize] {
                    let d = dist2(points[i], q);
                    if d > radius * radius || !free(i) {
                        continue;
                    }
                    match best {
                        Some(b) if d >= b.0 => second = second.min(d),
                        _ => {
                            second = best.map_or(second, |b| b.0);
                            best = Some((d, i));
                        }
                    }
                }
            }
        }
        best.map(|b| (b, second))
    }
}

/// Global shift (px) of `detected` relative to `reference` by a coarse search within
/// `max_shift` px (step a quarter spacing), then median refinement.
pub fn global_shift(reference: &[[f64; 2]], detected: &[[f64; 2]], spacing: f64, max_shift: f64) -> [f64; 2] {
    let cap = 0.5 * spacing;
    let buckets = Buckets::new(detected, spacing);
    let score = |s: [f64; 2]| -> f64 {
        reference
            .iter()
            .map(|p| buckets.nearest(detected, [p[0] + s[0], p[1] + s[1]], cap).map_or(cap * cap, |(d, _)| d))
            .sum()
    };
    let step = 0.25 * spacing;
    let n = (max_shift / step).ceil() as i64;
    let mut best = ([0.0, 0.0], score([0.0, 0.0]));
    for j in -n..=n {
        for i in -n..=n {
            let s = [i as f64 * step, j as f64 * step];
            let v = score(s);
            if v < best.1 {
                best = (s, v);
            }
        }
    }
    let mut shift = best.0;
    for _ in 0..4 {
        let (mut dx, mut dy) = (Vec::new(), Vec::new());
        for p in reference {
            let q = [p[0] + shift[0], p[1] + shift[1]];
            if let Some((_, i)) = buckets.nearest(detected, q, cap) {
                dx.push(detected[i][0] - p[0]);
                dy.push(detected[i][1] - p[1]);
            }
        }
        shift = [median(dx), median(dy)];
    }
    shift
}

/// A first guess of where reference pins went: spread by `scale` about `centre`, then
/// shifted by `shift` (px).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Warp {
    /// Centre of the spread (px).
    pub centre: [f64; 2],
    /// Spread factor (1: none).
    pub scale: f64,
    /// Shift (px).
    pub shift: [f64; 2],
}

impl Warp {
    /// A pure shift (px).
    pub fn shift(shift: [f64; 2]) -> Self {
        Self { centre: [0.0, 0.0], scale: 1.0, shift }
    }

    /// Where `p` goes (px).
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.centre[0] + self.scale * (p[0] - self.centre[0]) + self.shift[0],
            self.centre[1] + self.scale * (p[1] - self.centre[1]) + self.shift[1],
        ]
    }
}

/// The [`Warp`] about `centre` that best lays `reference` onto `detected`: a coarse search
/// over spreads `1..=max_scale` (steps of 1%) and shifts within half a spacing (steps of a
/// quarter), scored by the capped nearest-detection distances, then least-squares
/// refinement on the nearest pairs.
pub fn global_warp(
    reference: &[[f64; 2]],
    detected: &[[f64; 2]],
    spacing: f64,
    centre: [f64; 2],
    max_scale: f64,
) -> Warp {
    let cap = 0.5 * spacing;
    let buckets = Buckets::new(detected, spacing);
    let score = |w: &Warp| -> f64 {
        reference.iter().map(|p| buckets.nearest(detected, w.apply(*p), cap).map_or(cap * cap, |(d, _)| d)).sum()
    };
    let mut best = (Warp { centre, scale: 1.0, shift: [0.0, 0.0] }, f64::INFINITY);
    let scales = ((max_scale - 1.0) / 0.01).round().max(0.0) as i64;
    for k in 0..=scales {
        for j in -2..=2 {
            for i in -2..=2 {
                let w = Warp {
                    centre,
                    scale: 1.0 + 0.01 * k as f64,
                    shift: [0.25 * spacing * i as f64, 0.25 * spacing * j as f64],
                };
                let v = score(&w);
                if v < best.1 {
                    best = (w, v);
                }
            }
        }
    }
    // Refine: q - c = s (p - c) + t over the nearest pairs, in closed form.
    let mut w = best.0;
    for _ in 0..4 {
        let pairs: Vec<([f64; 2], [f64; 2])> = reference
            .iter()
            .filter_map(|p| {
                buckets.nearest(detected, w.apply(*p), 0.35 * spacing).map(|(_, i)| {
                    ([p[0] - centre[0], p[1] - centre[1]], [detected[i][0] - centre[0], detected[i][1] - centre[1]])
                })
            })
            .collect();
        let n = pairs.len() as f64;
        if n < 3.0 {
            break;
        }
        let mp = pairs.iter().fold([0.0; 2], |m, (p, _)| [m[0] + p[0] / n, m[1] + p[1] / n]);
        let mq = pairs.iter().fold([0.0; 2], |m, (_, q)| [m[0] + q[0] / n, m[1] + q[1] / n]);
        let (mut num, mut den) = (0.0, 0.0);
        for (p, q) in &pairs {
            let (dp, dq) = ([p[0] - mp[0], p[1] - mp[1]], [q[0] - mq[0], q[1] - mq[1]]);
            num += dp[0] * dq[0] + dp[1] * dq[1];
            den += dp[0] * dp[0] + dp[1] * dp[1];
        }
        if den <= 0.0 {
            break;
        }
        let scale = num / den;
        w = Warp { centre, scale, shift: [mq[0] - scale * mp[0], mq[1] - scale * mp[1]] };
    }
    w
}

/// The other points of `points` by distance from point `i` (squared distance, index),
/// nearest first.
fn others_by_distance(points: &[[f64; 2]], i: usize) -> Vec<(f64, usize)> {
    let mut d: Vec<(f64, usize)> =
        (0..points.len()).filter(|&j| j != i).map(|j| (dist2(points[i], points[j]), j)).collect();
    d.sort_by(|a, b| a.0.total_cmp(&b.0));
    d
}

/// The `k` nearest other points of each point, nearest first.
pub fn nearest_neighbours(points: &[[f64; 2]], k: usize) -> Vec<Vec<usize>> {
    (0..points.len()).map(|i| others_by_distance(points, i).into_iter().take(k).map(|(_, j)| j).collect()).collect()
}

/// Minimum-cost assignment of `predicted` points to `detected` ones within `radius`.
fn assign(predicted: &[[f64; 2]], detected: &[[f64; 2]], radius: f64) -> Vec<Option<usize>> {
    use pathfinding::kuhn_munkres::kuhn_munkres_min;
    use pathfinding::matrix::Matrix;
    let (n, m) = (predicted.len(), detected.len());
    if n == 0 {
        return Vec::new();
    }
    // Costs in hundredths of px^2; one private "unmatched" column per row.
    const SCALE: f64 = 100.0;
    const FORBIDDEN: i64 = 1 << 40;
    let miss = (radius * radius * SCALE).round() as i64;
    let mut w = Matrix::new(n, m + n, FORBIDDEN);
    for (i, p) in predicted.iter().enumerate() {
        w[(i, m + i)] = miss;
        for (k, d) in detected.iter().enumerate() {
            let d2 = dist2(*p, *d);
            if d2 < radius * radius {
                w[(i, k)] = (d2 * SCALE).round() as i64;
            }
        }
    }
    let (_, cols) = kuhn_munkres_min(&w);
    cols.into_iter().map(|k| (k < m).then_some(k)).collect()
}

/// Reference neighbours of each pin within `radius` (px), nearest first.
fn neighbours_within(points: &[[f64; 2]], radius: f64) -> Vec<Vec<usize>> {
    (0..points.len())
        .map(|i| {
            others_by_distance(points, i)
                .into_iter()
                .take_while(|(d, _)| *d <= radius * radius)
                .map(|(_, j)| j)
                .collect()
        })
        .collect()
}

/// Displacement (px) of reference pin `i` predicted from the tracked pins among `near[i]`:
/// the weighted least-squares affine field `d(p) = a + B (p - p_i)` (weights
/// `1 / (1 + (r / spacing)^2)`), whose value at `p_i` is `a`, when the tracked neighbours
/// span the plane (smallest weighted positional variance above a tenth of a spacing
/// squared); else their weighted mean; `None` when none is tracked.
fn local_prediction(
    i: usize,
    reference: &[[f64; 2]],
    disp: &[Option<[f64; 2]>],
    near: &[usize],
    spacing: f64,
) -> Option<[f64; 2]> {
    let (mut sw, mut mp, mut md) = (0.0, [0.0; 2], [0.0; 2]);
    let pts: Vec<(f64, [f64; 2], [f64; 2])> = near
        .iter()
        .filter_map(|&j| {
            let d = disp[j]?;
            let p = sub(reference[j], reference[i]);
            Some((1.0 / (1.0 + (p[0] * p[0] + p[1] * p[1]) / (spacing * spacing)), p, d))
        })
        .collect();
    for (w, p, d) in &pts {
        sw += w;
        for k in 0..2 {
            mp[k] += w * p[k];
            md[k] += w * d[k];
        }
    }
    if sw == 0.0 {
        return None;
    }
    mp = mp.map(|v| v / sw);
    md = md.map(|v| v / sw);
    if pts.len() < 4 {
        return Some(md);
    }
    // Weighted covariances: positions C (2x2), displacement against position S (2x2).
    let (mut c, mut cs) = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
    for (w, p, d) in &pts {
        let (dp, dd) = (sub(*p, mp), sub(*d, md));
        for a in 0..2 {
            for b in 0..2 {
                c[a][b] += w * dp[a] * dp[b] / sw;
                cs[a][b] += w * dd[a] * dp[b] / sw;
            }
        }
    }
    let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
    let half_trace = 0.5 * (c[0][0] + c[1][1]);
    let min_eig = half_trace - (half_trace * half_trace - det).max(0.0).sqrt();
    if min_eig < 0.1 * spacing * spacing {
        return Some(md);
    }
    // B = S C^-1; the field at p_i (relative position 0): md + B (0 - mp).
    let inv = [[c[1][1] / det, -c[0][1] / det], [-c[1][0] / det, c[0][0] / det]];
    let b = |r: usize, k: usize| cs[r][0] * inv[0][k] + cs[r][1] * inv[1][k];
    Some([md[0] - b(0, 0) * mp[0] - b(0, 1) * mp[1], md[1] - b(1, 0) * mp[0] - b(1, 1) * mp[1]])
}

/// Best-first growth of matches (step 2 of the module docs): per reference pin, the index of
/// its detection, or `None` where no detection beat its runner-up clearly enough.
fn grow(
    reference: &[[f64; 2]],
    detected: &[[f64; 2]],
    spacing: f64,
    start: &Warp,
    near: &[Vec<usize>],
) -> Vec<Option<usize>> {
    let n = reference.len();
    let buckets = Buckets::new(detected, spacing);
    let radius = MATCH_FRACTION * spacing;
    let front2 = (FRONT_RADIUS * spacing).powi(2);
    let mut matched: Vec<Option<usize>> = vec![None; n];
    let mut disp: Vec<Option<[f64; 2]>> = vec![None; n];
    let mut taken = vec![false; detected.len()];
    // Per untracked pin: (margin over the runner-up in px, nearest free detection), or None.
    let candidate = |i: usize, disp: &[Option<[f64; 2]>], taken: &[bool]| -> Option<(f64, usize)> {
        let d = if near[i].iter().any(|&j| disp[j].is_some() && dist2(reference[i], reference[j]) <= front2) {
            local_prediction(i, reference, disp, &near[i], spacing)?
        } else {
            sub(start.apply(reference[i]), reference[i])
        };
        let q = [reference[i][0] + d[0], reference[i][1] + d[1]];
        let ((d1, k), d2) = buckets.nearest_two(detected, q, 2.0 * spacing, |k| !taken[k])?;
        let (d1, d2) = (d1.sqrt(), d2.sqrt());
        (d1 <= radius && d2 - d1 >= MIN_MARGIN * spacing).then_some((d2 - d1, k))
    };
    let mut cand: Vec<Option<(f64, usize)>> = (0..n).map(|i| candidate(i, &disp, &taken)).collect();
    loop {
        let best = (0..n)
            .filter(|&i| matched[i].is_none())
            .filter_map(|i| cand[i].map(|(m, k)| (m, i, k)))
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((_, i, k)) = best else { break };
        matched[i] = Some(k);
        disp[i] = Some(sub(detected[k], reference[i]));
        taken[k] = true;
        cand[i] = None;
        // Pins near the new match predict anew; pins that wanted its detection look again.
        for j in 0..n {
            if matched[j].is_none() && (near[i].contains(&j) || cand[j].is_some_and(|c| c.1 == k)) {
                cand[j] = candidate(j, &disp, &taken);
            }
        }
    }
    matched
}

/// Tracks `reference` pins into `detected` pins (px) starting from the guess `start`;
/// `spacing` is the typical distance between neighbouring pins (px).
pub fn track(reference: &[[f64; 2]], detected: &[[f64; 2]], spacing: f64, start: &Warp) -> Tracking {
    let n = reference.len();
    let near = neighbours_within(reference, LOCAL_RADIUS * spacing);
    let neighbours = nearest_neighbours(reference, NEIGHBOURS);
    let radius = MATCH_FRACTION * spacing;
    let mut matched = grow(reference, detected, spacing, start, &near);
    let mut disp: Vec<Option<[f64; 2]>> = (0..n).map(|i| matched[i].map(|k| sub(detected[k], reference[i]))).collect();
    for _ in 0..PASSES {
        let predicted: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let d = local_prediction(i, reference, &disp, &near[i], spacing)
                    .unwrap_or_else(|| sub(start.apply(reference[i]), reference[i]));
                [reference[i][0] + d[0], reference[i][1] + d[1]]
            })
            .collect();
        matched = assign(&predicted, detected, radius);
        disp = (0..n).map(|i| matched[i].map(|k| sub(detected[k], reference[i]))).collect();
    }
    // Smoothness check against the neighbours' median.
    let limit2 = (SMOOTH_FRACTION * spacing).powi(2);
    let checked: Vec<bool> = (0..n)
        .map(|i| {
            let Some(d) = disp[i] else { return false };
            let (dx, dy): (Vec<f64>, Vec<f64>) =
                neighbours[i].iter().filter_map(|&j| disp[j]).map(|d| (d[0], d[1])).unzip();
            dx.len() < 2 || dist2(d, [median(dx), median(dy)]) <= limit2
        })
        .collect();
    for i in 0..n {
        if !checked[i] {
            disp[i] = None;
            matched[i] = None;
        }
    }
    let (dx, dy): (Vec<f64>, Vec<f64>) = disp.iter().flatten().map(|d| (d[0], d[1])).unzip();
    Tracking { displacement: disp, matched, global_shift: [median(dx), median(dy)] }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice() -> Vec<[f64; 2]> {
        let mut v = Vec::new();
        for j in -8..=8 {
            for i in -8..=8 {
                let (x, y) = (i as f64 * 18.0 + if j % 2 == 0 { 0.0 } else { 9.0 }, j as f64 * 15.6);
                if x.hypot(y) < 150.0 {
                    v.push([210.0 + x, 210.0 + y]);
                }
            }
        }
        v
    }

    #[test]
    fn recovers_a_large_shift_plus_a_smooth_swirl_and_reports_missing_pins() {
        let r = lattice();
        // A shift of 1.5 spacings plus a local swirl of up to 0.45 spacing.
        let moved: Vec<[f64; 2]> = r
            .iter()
            .map(|p| {
                let (x, y) = (p[0] - 210.0, p[1] - 210.0);
                let w = 8.0 * (-(x * x + y * y) / (2.0 * 60.0f64.powi(2))).exp();
                [p[0] + 27.0 - w * y / 60.0, p[1] - 10.0 + w * x / 60.0]
            })
            .collect();
        // Drop every 13th detection, add two specks.
        let mut detected: Vec<[f64; 2]> =
            moved.iter().enumerate().filter(|(i, _)| i % 13 != 5).map(|(_, p)| *p).collect();
        detected.push([5.0, 5.0]);
        detected.push([400.0, 30.0]);
        let start = global_shift(&r, &detected, 18.0, 60.0);
        let t = track(&r, &detected, 18.0, &Warp::shift(start));
        assert!((t.global_shift[0] - 27.0).abs() < 1.0 && (t.global_shift[1] + 10.0).abs() < 1.0, "{t:?}");
        let mut right = 0;
        for (i, d) in t.displacement.iter().enumerate() {
            if let Some(d) = d {
                let truth = [moved[i][0] - r[i][0], moved[i][1] - r[i][1]];
                assert!(dist2(*d, truth) < 1e-12, "pin {i}: {d:?} vs {truth:?}");
                right += 1;
            } else {
                continue;
            }
        }
        let dropped = (0..r.len()).filter(|i| i % 13 == 5).count();
        assert_eq!(t.unmatched(), dropped, "exactly the dropped pins are unmatched");
        assert_eq!(right + dropped, r.len());
    }

    #[test]
    fn a_spread_of_most_of_a_spacing_at_the_rim_is_tracked_from_the_global_warp() {
        let r = lattice();
        // A press: every pin spread 9% about the centre (up to 0.75 spacing at the rim),
        // plus a small shift.
        let moved: Vec<[f64; 2]> =
            r.iter().map(|p| [210.0 + 1.09 * (p[0] - 210.0) + 2.0, 210.0 + 1.09 * (p[1] - 210.0) - 1.0]).collect();
        let w = global_warp(&r, &moved, 18.0, [210.0, 210.0], 1.12);
        assert!(
            (w.scale - 1.09).abs() < 1e-6 && (w.shift[0] - 2.0).abs() < 1e-4 && (w.shift[1] + 1.0).abs() < 1e-4,
            "{w:?}"
        );
        let right = |t: &Tracking| {
            t.displacement
                .iter()
                .zip(r.iter().zip(&moved))
                .filter(|(d, (p, q))| d.is_some_and(|d| dist2(d, sub(**q, **p)) < 1e-12))
                .count()
        };
        assert_eq!(right(&track(&r, &moved, 18.0, &w)), r.len());
        // The growth from clear pins recovers it even from no warp at all.
        assert_eq!(right(&track(&r, &moved, 18.0, &Warp::shift([0.0, 0.0]))), r.len());
    }

    /// Regression: under deep tilted presses the pins about the off-centre contact spread by
    /// most of a spacing within a few rings (magnified as the skin comes towards the camera).
    /// No global warp fits that, and the neighbours' median of a patch matched one ring off
    /// kept confirming it: the real centre seemed to stand still (2.2 px against 8 px).
    #[test]
    fn a_local_spread_about_an_off_centre_contact_is_tracked_pin_for_pin() {
        let r = lattice();
        let (c, sigma, gain) = ([250.0, 190.0], 60.0, 0.45);
        let moved: Vec<[f64; 2]> = r
            .iter()
            .map(|p| {
                let (x, y) = (p[0] - c[0], p[1] - c[1]);
                let m = gain * (-(x * x + y * y) / (2.0 * sigma * sigma)).exp();
                [p[0] + m * x + 3.0, p[1] + m * y - 2.0]
            })
            .collect();
        let largest = r.iter().zip(&moved).map(|(p, q)| dist2(*p, *q).sqrt()).fold(0.0, f64::max);
        assert!(largest > 0.85 * 18.0, "the field moves pins by {largest} px");
        let w = global_warp(&r, &moved, 18.0, [210.0, 210.0], 1.12);
        let t = track(&r, &moved, 18.0, &w);
        for (i, d) in t.displacement.iter().enumerate() {
            let truth = sub(moved[i], r[i]);
            assert!(d.is_some_and(|d| dist2(d, truth) < 1e-12), "pin {i}: {d:?} vs {truth:?}");
        }
    }
}
