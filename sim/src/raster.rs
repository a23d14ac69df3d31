//! Rasterisation of filled discs with exact anti-aliased coverage.
//!
//! The coverage of pixel `[x, x+1] x [y, y+1]` by a disc is the exact area of their
//! intersection ([`pixel_coverage`]). The binary image sets a pixel when any disc covers at
//! least half of it, so results do not depend on where a pin centre falls within a pixel
//! beyond that rule. Deciding it needs no integration almost everywhere: with `d` the distance
//! from the disc centre to the pixel centre, the half-coverage boundary lies at
//! `r - d = L^2 / (24 r) + O(r^-3)` (see [`draw_binary`]), so pixels clearly inside or outside
//! that are decided by `d`, and only a thin band is integrated exactly. Two proven bounds
//! hold for any radius and are used below 1 px:
//!
//! - `d >= r`: the disc lies in the half-plane tangent to it facing the pixel, whose boundary
//!   passes beyond the pixel centre, so coverage < 1/2;
//! - `d^2 <= r^2 - 1/2`: the disc contains the pixel's part of the half-plane whose boundary is
//!   at distance `sqrt(r^2 - 1/2)` from the centre, which covers at least half.

use image::GrayImage;

use crate::camera::Disc;

/// Antiderivative of `sqrt(r^2 - x^2)` for `|x| <= r`.
fn semicircle_integral(x: f64, r: f64) -> f64 {
    let x = x.clamp(-r, r);
    0.5 * (x * (r * r - x * x).max(0.0).sqrt() + r * r * (x / r).asin())
}

/// Exact area (px^2) of the intersection of `disc` with the axis-aligned box
/// `[x0, x1] x [y0, y1]` (px).
pub fn box_coverage(disc: &Disc, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let r = disc.r;
    // Disc at the origin.
    let (a0, a1) = ((x0 - disc.u).max(-r), (x1 - disc.u).min(r));
    let (b0, b1) = (y0 - disc.v, y1 - disc.v);
    if a0 >= a1 || b0 >= r || b1 <= -r || b0 >= b1 {
        return 0.0;
    }
    // Split [a0, a1] where the circle's half-height h(x) = sqrt(r^2 - x^2) crosses |b0|, |b1|;
    // inside each piece the integrand min(b1, h) - max(b0, -h) has a fixed form.
    let mut cuts = [a0, a1, a1, a1, a1, a1];
    let mut n = 1;
    for b in [b0, b1] {
        if b.abs() < r {
            let w = (r * r - b * b).sqrt();
            for c in [-w, w] {
                if c > a0 && c < a1 {
                    cuts[n] = c;
                    n += 1;
                }
            }
        }
    }
    cuts[n] = a1;
    let cuts = &mut cuts[..=n];
    cuts.sort_by(f64::total_cmp);
    let mut area = 0.0;
    for w in cuts.windows(2) {
        let (s, t) = (w[0], w[1]);
        if t <= s {
            continue;
        }
        let m = 0.5 * (s + t);
        let h = (r * r - m * m).max(0.0).sqrt();
        let top_is_circle = h < b1;
        let bottom_is_circle = -h > b0;
        let top_m = if top_is_circle { h } else { b1 };
        let bottom_m = if bottom_is_circle { -h } else { b0 };
        if top_m <= bottom_m {
            continue;
        }
        let hint = semicircle_integral(t, r) - semicircle_integral(s, r);
        let top = if top_is_circle { hint } else { b1 * (t - s) };
        let bottom = if bottom_is_circle { -hint } else { b0 * (t - s) };
        area += top - bottom;
    }
    area.max(0.0)
}

/// Exact fraction of pixel `(x, y)` covered by `disc`.
pub fn pixel_coverage(disc: &Disc, x: u32, y: u32) -> f64 {
    let (x, y) = (x as f64, y as f64);
    box_coverage(disc, x, x + 1.0, y, y + 1.0)
}

/// Pixel index ranges a disc can touch, clipped to the image.
fn bounds(disc: &Disc, size: u32) -> Option<(u32, u32, u32, u32)> {
    let s = size as f64;
    let (x0, x1) = ((disc.u - disc.r).floor().max(0.0), (disc.u + disc.r).ceil().min(s));
    let (y0, y1) = ((disc.v - disc.r).floor().max(0.0), (disc.v + disc.r).ceil().min(s));
    if !(x0 < x1 && y0 < y1) {
        return None;
    }
    Some((x0 as u32, x1 as u32, y0 as u32, y1 as u32))
}

/// Offsets (px x r) from the circle, inside it, between which the half-coverage boundary of a
/// pixel lies: `r - d` in `(BAND_OUTER / r, BAND_INNER / r)` for discs of radius >= 1 px.
///
/// For a pixel whose centre is at distance `d` from the disc centre, the circle bulges away
/// from its tangent by `t^2 / 2r` at lateral offset `t`, so the coverage reaches 1/2 when
/// `r - d = L^2 / (24 r) + O(r^-3)`, where `L`, in `[1, sqrt 2]`, is the pixel's chord through
/// its centre across the radius: `r - d` in `[0.0417, 0.0833] / r`. The band `(0.03, 0.12) / r`
/// contains it with margin (measured over radii 0.75..30 px and all orientations: `[0.042,
/// 0.083]`; the test `binary_equals_thresholded_exact_coverage` sweeps radii and offsets).
const BAND_OUTER: f64 = 0.03;
/// See [`BAND_OUTER`].
const BAND_INNER: f64 = 0.12;

/// Clears `out` (resizing it to `size` x `size`) and draws the discs in white (255) on black
/// (0): a pixel is white when some disc covers at least half of it (exact area). Pixels whose
/// centre is well inside or outside a disc are decided by distance; the thin band where the
/// half-coverage boundary lies is decided by [`pixel_coverage`].
pub fn draw_binary(discs: &[Disc], size: u32, out: &mut GrayImage) {
    if out.width() != size || out.height() != size {
        *out = GrayImage::new(size, size);
    } else {
        out.fill(0);
    }
    let stride = size as usize;
    let buf: &mut [u8] = out;
    for disc in discs {
        if !(disc.r > 0.0 && disc.u.is_finite() && disc.v.is_finite() && disc.r.is_finite()) {
            continue;
        }
        let Some((x0, x1, y0, y1)) = bounds(disc, size) else { continue };
        let r = disc.r;
        // Squared distances: on for d^2 <= inner2, off for d^2 >= outer2, exact between. Small
        // discs use the provable band (r^2 - 1/2, r^2) of the module docs.
        let (inner2, outer2) =
            if r >= 1.0 { ((r - BAND_INNER / r).powi(2), (r - BAND_OUTER / r).powi(2)) } else { (r * r - 0.5, r * r) };
        for y in y0..y1 {
            let dy = y as f64 + 0.5 - disc.v;
            let dy2 = dy * dy;
            if dy2 >= outer2 {
                continue;
            }
            let row = &mut buf[y as usize * stride..(y as usize + 1) * stride];
            for x in x0..x1 {
                let dx = x as f64 + 0.5 - disc.u;
                let d2 = dx * dx + dy2;
                let on = d2 <= inner2 || (d2 < outer2 && row[x as usize] == 0 && pixel_coverage(disc, x, y) >= 0.5);
                if on {
                    row[x as usize] = 255;
                }
            }
        }
    }
}

/// Exact coverage image (row-major, `size * size`, values in [0, 1]): the sum of the discs'
/// coverages, clipped to 1.
pub fn draw_coverage(discs: &[Disc], size: u32) -> Vec<f32> {
    let mut cov = vec![0.0f32; size as usize * size as usize];
    for disc in discs {
        let Some((x0, x1, y0, y1)) = bounds(disc, size) else { continue };
        for y in y0..y1 {
            for x in x0..x1 {
                let c = pixel_coverage(disc, x, y) as f32;
                let px = &mut cov[y as usize * size as usize + x as usize];
                *px = (*px + c).min(1.0);
            }
        }
    }
    cov
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: with the old minimum radius of 0.75 px a random sensor lost a pin at 128 px
    /// (disc r = 0.776 px centred near a pixel corner: four quarters of 0.47 coverage each).
    /// At the minimum radius every sub-pixel position keeps at least one pixel.
    #[test]
    fn smallest_accepted_disc_never_vanishes_at_a_pixel_corner() {
        let lost = Disc { u: 10.0, v: 10.0, r: 0.776 };
        let mut img = GrayImage::new(20, 20);
        draw_binary(&[lost], 20, &mut img);
        assert!(img.as_raw().iter().all(|&p| p == 0), "0.776 px at a corner renders nothing");
        let r = crate::render::MIN_PIN_RADIUS_PX;
        for i in 0..=20 {
            for j in 0..=20 {
                let d = Disc { u: 10.0 + i as f64 / 20.0, v: 10.0 + j as f64 / 20.0, r };
                let mut img = GrayImage::new(20, 20);
                draw_binary(&[d], 20, &mut img);
                assert!(img.as_raw().contains(&255), "disc {d:?} vanished");
            }
        }
    }

    #[test]
    fn box_coverage_matches_known_areas() {
        let d = Disc { u: 0.0, v: 0.0, r: 2.0 };
        let full = box_coverage(&d, -3.0, 3.0, -3.0, 3.0);
        assert!((full - std::f64::consts::PI * 4.0).abs() < 1e-12, "{full}");
        let quarter = box_coverage(&d, 0.0, 3.0, 0.0, 3.0);
        assert!((quarter - std::f64::consts::PI).abs() < 1e-12);
        // Box inside the disc.
        assert!((box_coverage(&d, -1.0, 0.0, 0.0, 1.0) - 1.0).abs() < 1e-12);
        // Box outside.
        assert_eq!(box_coverage(&d, 2.5, 3.0, 0.0, 1.0), 0.0);
        // Half-strip below the diameter: half the disc.
        let half = box_coverage(&d, -5.0, 5.0, -5.0, 0.0);
        assert!((half - 2.0 * std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn coverage_sums_to_disc_area_for_any_offset() {
        for &(u, v, r) in &[(10.3, 7.9, 3.7), (5.5, 5.5, 1.2), (20.01, 19.77, 8.3)] {
            let d = Disc { u, v, r };
            let cov = draw_coverage(&[d], 32);
            let sum: f64 = cov.iter().map(|&c| c as f64).sum();
            let exact = std::f64::consts::PI * r * r;
            assert!((sum - exact).abs() < 1e-4 * exact, "{sum} vs {exact}");
        }
    }

    #[test]
    fn binary_equals_thresholded_exact_coverage() {
        // Deterministic sweep of sub-pixel centres and radii from 0.3 to 25 px, including discs
        // clipped by the image border.
        let mut img = GrayImage::new(1, 1);
        let size = 64;
        for i in 0..3000 {
            let t = i as f64;
            let r = 0.3 + (t * 0.0371) % 25.0;
            let d = Disc { u: 32.0 + (t * 0.618).fract() * (1.0 + r), v: 32.0 + (t * 0.414).fract() * 40.0 - 20.0, r };
            draw_binary(&[d], size, &mut img);
            for y in 0..size {
                for x in 0..size {
                    let on = img.get_pixel(x, y).0[0] == 255;
                    assert_eq!(on, pixel_coverage(&d, x, y) >= 0.5, "disc {d:?} pixel ({x}, {y})");
                }
            }
        }
    }
}
