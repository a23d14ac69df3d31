//! Parametric outlines of the built-in planar stimuli (mm, object frame, counter-clockwise
//! seen from above), with their exact area and perimeter where a closed form exists.
//! `cargo xtask shapes` extrudes them into the OBJ prisms of `shapes/`.

use std::f64::consts::{PI, TAU};

/// A closed planar outline.
#[derive(Clone, Debug, PartialEq)]
pub enum Outline {
    /// Circle of `radius_mm`.
    Disk {
        /// Radius (mm).
        radius_mm: f64,
    },
    /// Axis-aligned square of side `side_mm`, sharp corners.
    Square {
        /// Side (mm).
        side_mm: f64,
    },
    /// Polar rose `r = base + amplitude cos(lobes theta)`.
    Clover {
        /// Mean radius (mm).
        base_mm: f64,
        /// Lobe amplitude (mm).
        amplitude_mm: f64,
        /// Number of lobes.
        lobes: u32,
    },
    /// Convex hull of a circle of `big_radius_mm` at the origin and one of `small_radius_mm`
    /// at `(distance_mm, 0)`.
    Teardrop {
        /// Radius of the round end (mm).
        big_radius_mm: f64,
        /// Radius of the rounded tip (mm).
        small_radius_mm: f64,
        /// Distance between the two centres (mm).
        distance_mm: f64,
    },
    /// Symmetric NACA 4-digit aerofoil with a closed trailing edge, chord along x, centred.
    Foil {
        /// Chord length (mm).
        chord_mm: f64,
        /// Maximum thickness as a fraction of the chord.
        thickness: f64,
    },
    /// Strip of constant `width_mm` around the Archimedean spiral `r = start + pitch theta /
    /// 2 pi`, `theta` in `[0, 2 pi turns]`, with semicircular end caps.
    Spiral {
        /// Radius where the centre line starts (mm).
        start_radius_mm: f64,
        /// Radial growth per turn (mm).
        pitch_mm: f64,
        /// Number of turns of the centre line.
        turns: f64,
        /// Strip width (mm).
        width_mm: f64,
    },
}

fn polygon_area(p: &[[f64; 2]]) -> f64 {
    0.5 * (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
}

fn polygon_perimeter(p: &[[f64; 2]]) -> f64 {
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            (b[0] - a[0]).hypot(b[1] - a[1])
        })
        .sum()
}

/// Signed area (mm^2, positive counter-clockwise) of a closed polygon.
pub fn signed_area(p: &[[f64; 2]]) -> f64 {
    polygon_area(p)
}

/// Perimeter (mm) of a closed polygon.
pub fn perimeter(p: &[[f64; 2]]) -> f64 {
    polygon_perimeter(p)
}

impl Outline {
    /// Tessellates the outline into a counter-clockwise polygon (no repeated closing vertex)
    /// with segments of about `max_segment_mm` or shorter (at least 64 vertices).
    pub fn polygon(&self, max_segment_mm: f64) -> Vec<[f64; 2]> {
        let steps = |length: f64| ((length / max_segment_mm).ceil() as usize).max(64);
        let mut pts = match *self {
            Outline::Disk { radius_mm: r } => {
                let n = steps(TAU * r);
                (0..n)
                    .map(|i| {
                        let t = TAU * i as f64 / n as f64;
                        [r * t.cos(), r * t.sin()]
                    })
                    .collect()
            }
            Outline::Square { side_mm: s } => {
                let h = 0.5 * s;
                let per_side = steps(s) / 4 + 1;
                let corners = [[-h, -h], [h, -h], [h, h], [-h, h]];
                let mut v = Vec::new();
                for c in 0..4 {
                    let (a, b) = (corners[c], corners[(c + 1) % 4]);
                    for i in 0..per_side {
                        let t = i as f64 / per_side as f64;
                        v.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
                    }
                }
                v
            }
            Outline::Clover { base_mm: a, amplitude_mm: b, lobes } => {
                let n = steps(TAU * (a + b)) * 2;
                (0..n)
                    .map(|i| {
                        let t = TAU * i as f64 / n as f64;
                        let r = a + b * (lobes as f64 * t).cos();
                        [r * t.cos(), r * t.sin()]
                    })
                    .collect()
            }
            Outline::Teardrop { big_radius_mm: big, small_radius_mm: small, distance_mm: d } => {
                let beta = ((big - small) / d).acos();
                let mut v = Vec::new();
                // Small arc from -beta to beta, then the upper tangent, the big arc from beta to
                // 2 pi - beta, and the lower tangent back (closing edge).
                let n_small = steps(2.0 * beta * small);
                for i in 0..=n_small {
                    let t = -beta + 2.0 * beta * i as f64 / n_small as f64;
                    v.push([d + small * t.cos(), small * t.sin()]);
                }
                let tangent = (d * d - (big - small).powi(2)).sqrt();
                let n_tan = steps(tangent) / 2;
                let (p, q) = ([d + small * beta.cos(), small * beta.sin()], [big * beta.cos(), big * beta.sin()]);
                for i in 1..n_tan {
                    let t = i as f64 / n_tan as f64;
                    v.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
                }
                let n_big = steps((TAU - 2.0 * beta) * big);
                for i in 0..=n_big {
                    let t = beta + (TAU - 2.0 * beta) * i as f64 / n_big as f64;
                    v.push([big * t.cos(), big * t.sin()]);
                }
                let (p, q) = ([big * beta.cos(), -big * beta.sin()], [d + small * beta.cos(), -small * beta.sin()]);
                for i in 1..n_tan {
                    let t = i as f64 / n_tan as f64;
                    v.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
                }
                v
            }
            Outline::Foil { chord_mm: c, thickness: t } => {
                let half = steps(2.0 * c) / 2;
                let y = |x: f64| {
                    5.0 * t
                        * c
                        * (0.2969 * x.sqrt() - 0.1260 * x - 0.3516 * x * x + 0.2843 * x.powi(3) - 0.1036 * x.powi(4))
                };
                let mut v = Vec::new();
                // Cosine spacing: fine at both edges. Lower surface from the trailing edge to
                // the leading edge, then the upper surface back (counter-clockwise).
                for i in 0..half {
                    let x = 0.5 * (1.0 + (PI * i as f64 / half as f64).cos());
                    v.push([c * x - 0.5 * c, -y(x)]);
                }
                for i in 0..half {
                    let x = 0.5 * (1.0 - (PI * i as f64 / half as f64).cos());
                    v.push([c * x - 0.5 * c, y(x)]);
                }
                v
            }
            Outline::Spiral { start_radius_mm: r0, pitch_mm: p, turns, width_mm: w } => {
                let b = p / TAU;
                let end = TAU * turns;
                let centre = |t: f64| [(r0 + b * t) * t.cos(), (r0 + b * t) * t.sin()];
                let normal = |t: f64| {
                    // Left normal of the centre line's tangent (d/dt of centre).
                    let r = r0 + b * t;
                    let (dx, dy) = (b * t.cos() - r * t.sin(), b * t.sin() + r * t.cos());
                    let n = dx.hypot(dy);
                    [-dy / n, dx / n]
                };
                let length = spiral_length(r0, b, end);
                let n = steps(length);
                let hw = 0.5 * w;
                let mut v = Vec::new();
                // Right side forwards, end cap, left side backwards, start cap.
                for i in 0..=n {
                    let t = end * i as f64 / n as f64;
                    let (c, m) = (centre(t), normal(t));
                    v.push([c[0] - hw * m[0], c[1] - hw * m[1]]);
                }
                let caps = steps(PI * hw) / 2;
                let cap = |v: &mut Vec<[f64; 2]>, t: f64, from: [f64; 2]| {
                    let c = centre(t);
                    let a0 = (from[1]).atan2(from[0]);
                    for i in 1..caps {
                        let a = a0 + PI * i as f64 / caps as f64;
                        v.push([c[0] + hw * a.cos(), c[1] + hw * a.sin()]);
                    }
                };
                let m = normal(end);
                cap(&mut v, end, [-m[0], -m[1]]);
                for i in (0..=n).rev() {
                    let t = end * i as f64 / n as f64;
                    let (c, m) = (centre(t), normal(t));
                    v.push([c[0] + hw * m[0], c[1] + hw * m[1]]);
                }
                cap(&mut v, 0.0, normal(0.0));
                v
            }
        };
        if polygon_area(&pts) < 0.0 {
            pts.reverse();
        }
        pts
    }

    /// Exact area (mm^2), where a closed form exists.
    pub fn exact_area(&self) -> Option<f64> {
        match *self {
            Outline::Disk { radius_mm: r } => Some(PI * r * r),
            Outline::Square { side_mm: s } => Some(s * s),
            Outline::Clover { base_mm: a, amplitude_mm: b, .. } => Some(PI * (a * a + 0.5 * b * b)),
            Outline::Teardrop { big_radius_mm: big, small_radius_mm: small, distance_mm: d } => {
                let beta = ((big - small) / d).acos();
                let tangent = (d * d - (big - small).powi(2)).sqrt();
                Some(big * big * (PI - beta) + small * small * beta + (big + small) * tangent)
            }
            Outline::Foil { .. } => None,
            // Offset strip of a curve without self-overlap: width x centre-line length, plus
            // the two semicircular caps.
            Outline::Spiral { start_radius_mm: r0, pitch_mm: p, turns, width_mm: w } => {
                Some(w * spiral_length(r0, p / TAU, TAU * turns) + PI * w * w / 4.0)
            }
        }
    }

    /// Exact perimeter (mm), where a closed form exists.
    pub fn exact_perimeter(&self) -> Option<f64> {
        match *self {
            Outline::Disk { radius_mm: r } => Some(TAU * r),
            Outline::Square { side_mm: s } => Some(4.0 * s),
            Outline::Clover { .. } | Outline::Foil { .. } => None,
            Outline::Teardrop { big_radius_mm: big, small_radius_mm: small, distance_mm: d } => {
                let beta = ((big - small) / d).acos();
                let tangent = (d * d - (big - small).powi(2)).sqrt();
                Some(big * (TAU - 2.0 * beta) + small * 2.0 * beta + 2.0 * tangent)
            }
            // The two offset sides are L +- (w/2) x (total turning); they sum to 2L.
            Outline::Spiral { start_radius_mm: r0, pitch_mm: p, turns, width_mm: w } => {
                Some(2.0 * spiral_length(r0, p / TAU, TAU * turns) + PI * w)
            }
        }
    }

    /// Reference area (mm^2): exact where known, else from a 0.005 mm tessellation.
    pub fn reference_area(&self) -> f64 {
        self.exact_area().unwrap_or_else(|| polygon_area(&self.polygon(0.005)))
    }

    /// Reference perimeter (mm): exact where known, else from a 0.005 mm tessellation.
    pub fn reference_perimeter(&self) -> f64 {
        self.exact_perimeter().unwrap_or_else(|| polygon_perimeter(&self.polygon(0.005)))
    }
}

/// Arc length of `r = r0 + b theta` for `theta` in `[0, end]`.
fn spiral_length(r0: f64, b: f64, end: f64) -> f64 {
    // ds = sqrt(r^2 + b^2) dtheta = sqrt(r^2 + b^2) dr / b.
    let f = |r: f64| {
        let s = (r * r + b * b).sqrt();
        (r * s + b * b * (r + s).ln()) / (2.0 * b)
    };
    f(r0 + b * end) - f(r0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms_agree_with_fine_tessellation() {
        let shapes = [
            Outline::Disk { radius_mm: 50.0 },
            Outline::Square { side_mm: 90.0 },
            Outline::Clover { base_mm: 42.0, amplitude_mm: 8.0, lobes: 4 },
            Outline::Teardrop { big_radius_mm: 30.0, small_radius_mm: 6.0, distance_mm: 62.0 },
            Outline::Spiral { start_radius_mm: 10.0, pitch_mm: 40.0, turns: 1.25, width_mm: 14.0 },
        ];
        for s in &shapes {
            let p = s.polygon(0.002);
            let (a, l) = (polygon_area(&p), polygon_perimeter(&p));
            let ea = s.exact_area().expect("every shape here has an exact area");
            assert!((a - ea).abs() < 1e-5 * ea, "{s:?}: area {a} vs {ea}");
            if let Some(el) = s.exact_perimeter() {
                assert!((l - el).abs() < 1e-5 * el, "{s:?}: perimeter {l} vs {el}");
            }
        }
    }
}
