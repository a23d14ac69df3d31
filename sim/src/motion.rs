//! Pin motion: each pin's displacement from an undeformed reference image of the same sensor,
//! tracked ([`crate::track`]), and drawn as an image a network reads in place of the pin
//! image.
//!
//! A network trained on pin images reads where the pins are; a sensor whose pins sit off the
//! simulated lattice by a fraction of a pixel (every real TacTip) shows it a pattern it learnt
//! as pressure. Motion from each domain's own reference does not carry the lattice: on the
//! whole-turn edge taps the simulator-trained network's lateral error fell from 1.04 to 0.85 mm
//! and its depth error from 0.23 to 0.14 mm with it, the yaw's rose from 12.65 to 18.61 deg
//! (`tacsim sim2real --input motion`, docs/experiments/sim2real.md, 2026-12-06).
//!
//! The motion image of side `S` (even): the displacement (px, scaled to a 128 px image) is
//! spread on a grid of `S/2 x S/2` points over the image, each point the Gaussian-weighted mean
//! of the tracked pins near it (`sigma` = [`SIGMA_PX128`] at 128 px), fading to 0 where no pin
//! is near (the weights' sum plus [`FADE`] divides); rows `0..S/2` hold the motion along `+x`
//! (image columns), rows `S/2..S` along `+y` (image rows), each grid column drawn two pixels
//! wide; grey `= 255 (0.5 + d / GREY_PX128)`, clipped to `[0, 255]`.

use image::{GrayImage, Luma};

use crate::detect::pin_centres;
use crate::error::{Result, SimError};
use crate::tracking::{Tracking, global_warp, track};

/// Pin spacing of the lab's 420 px images (px), scaled with the image size.
pub const SPACING_PX420: f64 = 17.5;

/// Largest spread of the pins about the image centre a press is searched for (12%: the
/// outermost ring moves out by up to about 16 px of 185 in the lab's deepest recordings).
const MAX_SPREAD: f64 = 1.12;

/// Width of a pin's Gaussian weight on the motion grid (px of a 128 px image).
pub const SIGMA_PX128: f64 = 3.0;

/// Added to the weights' sum, so that the motion fades to 0 where no pin is near.
pub const FADE: f64 = 0.1;

/// Motion (px of a 128 px image) from mid-grey to white.
pub const GREY_PX128: f64 = 8.0;

/// The part of the pin field a motion image is drawn from by default (`PinMotion::within`;
/// `tacsim sim2real --motion-field` sets another): the pins within this fraction of the
/// half-side of the image's centre (44 px of 64 at 128 px; the 331-pin TacTips' outer ring
/// sits at 48 px, next to the rim, where a deep press spreads it into the rim's clutter in the
/// real edge images; the surface presses read better with it, at 1).
pub const MOTION_FIELD: f64 = 44.0 / 64.0;

/// The smallest part of the pin field a motion image is drawn from (a fraction of the
/// half-side, as [`MOTION_FIELD`]): about 20 pins of a 331-pin TacTip.
pub const MIN_MOTION_FIELD: f64 = 0.2;

/// The reference pins of a sensor's undeformed image, to track its other images from.
#[derive(Clone, Debug)]
pub struct PinMotion {
    reference: Vec<[f64; 2]>,
    spacing: f64,
    size: (u32, u32),
}

impl PinMotion {
    /// The pins of `reference` (a binary pin image; `source` names it in errors).
    pub fn new(reference: &GrayImage, source: &str) -> Result<Self> {
        let pins = pin_centres(reference);
        if pins.len() < 7 {
            return Err(SimError::Analysis {
                source_name: source.into(),
                reason: format!("{} pins found in the reference: too few to track", pins.len()),
            });
        }
        let size = reference.dimensions();
        Ok(Self { reference: pins, spacing: SPACING_PX420 * size.0 as f64 / 420.0, size })
    }

    /// The same, tracking only the reference pins within `fraction` of the half-side from the
    /// image's centre (the motion image's [`MOTION_FIELD`]).
    pub fn within(mut self, fraction: f64) -> Self {
        let (cx, cy) = (0.5 * self.size.0 as f64, 0.5 * self.size.1 as f64);
        let r = fraction * cx.min(cy);
        self.reference.retain(|p| (p[0] - cx).hypot(p[1] - cy) <= r);
        self
    }

    /// The reference pins' centres (px).
    pub fn reference(&self) -> &[[f64; 2]] {
        &self.reference
    }

    /// Every reference pin tracked into `img` (an image of the reference's size): the best
    /// spread and shift about the image centre first (a deep press spreads the outer rings by
    /// most of a spacing), then [`track`].
    pub fn track(&self, img: &GrayImage) -> Tracking {
        let detected = pin_centres(img);
        let centre = [0.5 * self.size.0 as f64, 0.5 * self.size.1 as f64];
        let start = global_warp(&self.reference, &detected, self.spacing, centre, MAX_SPREAD);
        track(&self.reference, &detected, self.spacing, &start)
    }

    /// The motion image (side `side`, see the module's docs) of `img`; `source` names it in
    /// errors.
    pub fn image(&self, img: &GrayImage, side: u32, source: &str) -> Result<GrayImage> {
        if img.dimensions() != self.size {
            return Err(SimError::Analysis {
                source_name: source.into(),
                reason: format!(
                    "{}x{} px, its reference {}x{} px: pin motion needs both at one size",
                    img.width(),
                    img.height(),
                    self.size.0,
                    self.size.1
                ),
            });
        }
        Ok(self.draw(&self.track(img), side))
    }

    /// The motion image of side `side` (even, at least 2) of a tracking of these reference pins.
    pub fn draw(&self, tracking: &Tracking, side: u32) -> GrayImage {
        let half = (side / 2).max(1);
        let (w, h) = (self.size.0 as f64, self.size.1 as f64);
        let to128 = 128.0 / w;
        let sigma = SIGMA_PX128 / to128;
        let reach2 = (3.0 * sigma).powi(2);
        let moved: Vec<([f64; 2], [f64; 2])> = self
            .reference
            .iter()
            .zip(&tracking.displacement)
            .filter_map(|(&p, d)| d.map(|d| (p, [d[0] * to128, d[1] * to128])))
            .collect();
        let mut field = vec![[0.0f64; 2]; (half * half) as usize];
        for gy in 0..half {
            for gx in 0..half {
                let at = [(gx as f64 + 0.5) * w / half as f64, (gy as f64 + 0.5) * h / half as f64];
                let (mut sum, mut weight) = ([0.0, 0.0], 0.0);
                for (p, d) in &moved {
                    let r2 = (p[0] - at[0]).powi(2) + (p[1] - at[1]).powi(2);
                    if r2 < reach2 {
                        let k = (-r2 / (2.0 * sigma * sigma)).exp();
                        sum = [sum[0] + k * d[0], sum[1] + k * d[1]];
                        weight += k;
                    }
                }
                field[(gy * half + gx) as usize] = [sum[0] / (weight + FADE), sum[1] / (weight + FADE)];
            }
        }
        GrayImage::from_fn(side, side, |x, y| {
            let (axis, gy) = if y < half { (0, y) } else { (1, (y - half).min(half - 1)) };
            let gx = (x / 2).min(half - 1);
            let d = field[(gy * half + gx) as usize][axis];
            Luma([((0.5 + d / GREY_PX128).clamp(0.0, 1.0) * 255.0).round() as u8])
        })
    }
}

/// A motion image as a network reads it (values `0..1`, `side` x `side`, the layout of
/// [`PinMotion::draw`]) turned about the image's centre by `angle_rad` (image axes: `+x`
/// turns towards `+y`): each grid point takes the motion at the point turned back (bilinear
/// between grid points, none beyond the grid) and turns it by the same angle,
///
/// ```text
/// d'(q) = R(a) d(R(-a) q),   R(a) = [cos a, -sin a; sin a, cos a],
/// ```
///
/// `q` about the grid's centre. A quarter turn moves every grid point onto another, so four of
/// them give the image back. Values that are not a `side` x `side` image come back unchanged.
pub fn turn_motion(values: &[f32], side: usize, angle_rad: f64) -> Vec<f32> {
    let half = side / 2;
    if half == 0 || values.len() != side * side {
        return values.to_vec();
    }
    let (c, s) = (angle_rad.cos(), angle_rad.sin());
    let mid = (half as f64 - 1.0) / 2.0;
    // The motion along `axis` at grid point (gx, gy); mid-grey (none) beyond the grid.
    let at = |axis: usize, gx: i64, gy: i64| -> f64 {
        if gx < 0 || gy < 0 || gx >= half as i64 || gy >= half as i64 {
            return 0.0;
        }
        f64::from(values[(axis * half + gy as usize) * side + 2 * gx as usize]) - 0.5
    };
    let sample = |axis: usize, x: f64, y: f64| -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        at(axis, i, j) * (1.0 - fx) * (1.0 - fy)
            + at(axis, i + 1, j) * fx * (1.0 - fy)
            + at(axis, i, j + 1) * (1.0 - fx) * fy
            + at(axis, i + 1, j + 1) * fx * fy
    };
    let mut out = vec![0.5f32; side * side];
    for gy in 0..half {
        for gx in 0..half {
            let (qx, qy) = (gx as f64 - mid, gy as f64 - mid);
            let (px, py) = (c * qx + s * qy + mid, -s * qx + c * qy + mid);
            let (dx, dy) = (sample(0, px, py), sample(1, px, py));
            let turned = [c * dx - s * dy, s * dx + c * dy];
            for (axis, d) in turned.into_iter().enumerate() {
                let row = (axis * half + gy) * side;
                let v = (0.5 + d).clamp(0.0, 1.0) as f32;
                out[row + 2 * gx] = v;
                if 2 * gx + 1 < side {
                    out[row + 2 * gx + 1] = v;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 128 px image of discs of radius 1.6 px on a hexagonal lattice 5.3 px apart within 44
    /// px of the centre, each moved by `shift(x, y)`.
    fn lattice(shift: impl Fn(f64, f64) -> [f64; 2]) -> GrayImage {
        let mut centres = Vec::new();
        let pitch = 5.3;
        for j in -10i32..=10 {
            for i in -10i32..=10 {
                let x = 64.0 + pitch * (i as f64 + 0.5 * j as f64);
                let y = 64.0 + pitch * 0.866 * j as f64;
                if (x - 64.0).hypot(y - 64.0) < 44.0 {
                    let d = shift(x, y);
                    centres.push([x + d[0], y + d[1]]);
                }
            }
        }
        GrayImage::from_fn(128, 128, |x, y| {
            let (u, v) = (x as f64 + 0.5, y as f64 + 0.5);
            let inside = centres.iter().any(|c| (u - c[0]).hypot(v - c[1]) < 1.6);
            Luma([if inside { 255 } else { 0 }])
        })
    }

    #[test]
    fn the_reference_itself_moves_nothing() {
        let reference = lattice(|_, _| [0.0, 0.0]);
        let motion = PinMotion::new(&reference, "test").expect("a lattice of pins");
        let img = motion.image(&reference, 64, "test").expect("a motion image");
        assert!(img.pixels().all(|p| p.0[0] == 128), "mid-grey everywhere");
    }

    #[test]
    fn a_shift_of_every_pin_is_read_on_its_axis_where_the_pins_are() {
        let reference = lattice(|_, _| [0.0, 0.0]);
        let motion = PinMotion::new(&reference, "test").expect("a lattice of pins");
        let moved = lattice(|_, _| [1.0, 0.0]);
        let t = motion.track(&moved);
        assert_eq!(t.unmatched(), 0);
        let img = motion.image(&moved, 64, "test").expect("a motion image");
        // The grid point at the image centre, well inside the pins: 1 px along x, weights
        // summing to about 2.6 (so the fade takes about 4%).
        let dx = img.get_pixel(32, 16).0[0] as f64 / 255.0 - 0.5;
        let dy = img.get_pixel(32, 48).0[0] as f64 / 255.0 - 0.5;
        assert!((dx * GREY_PX128 - 1.0).abs() < 0.1, "dx {}", dx * GREY_PX128);
        assert!((dy * GREY_PX128).abs() < 0.02, "dy {}", dy * GREY_PX128);
        // Far outside the pin field nothing moves.
        assert_eq!(img.get_pixel(0, 0).0[0], 128);
        assert_eq!(img.get_pixel(0, 32).0[0], 128);
    }

    #[test]
    fn within_keeps_the_pins_of_the_inner_field_and_draws_nothing_beyond_them() {
        let reference = lattice(|_, _| [0.0, 0.0]);
        let all = PinMotion::new(&reference, "test").expect("a lattice of pins");
        let inner = all.clone().within(0.5);
        assert!(inner.reference().len() < all.reference().len() && inner.reference().len() >= 7);
        assert!(inner.reference().iter().all(|p| (p[0] - 64.0).hypot(p[1] - 64.0) <= 32.0));
        // Every pin moved by 1 px along y: read near the centre, nothing 40 px out.
        let moved = lattice(|_, _| [0.0, 1.0]);
        let img = inner.image(&moved, 64, "test").expect("a motion image");
        let dy = |x: u32, y: u32| (img.get_pixel(x, 32 + y).0[0] as f64 / 255.0 - 0.5) * GREY_PX128;
        assert!((dy(32, 16) - 1.0).abs() < 0.1, "centre {}", dy(32, 16));
        assert!(dy(2, 16).abs() < 0.02, "40 px out {}", dy(2, 16));
    }

    #[test]
    fn an_image_of_another_size_is_refused_with_both_sizes() {
        let reference = lattice(|_, _| [0.0, 0.0]);
        let motion = PinMotion::new(&reference, "ref.png").expect("a lattice of pins");
        let small = GrayImage::new(64, 64);
        let e = motion.image(&small, 64, "small.png").expect_err("refused").to_string();
        assert!(e.contains("small.png") && e.contains("64x64") && e.contains("128x128"), "{e}");
    }

    /// A motion image's values (0..1) as a network reads them.
    fn values(img: &GrayImage) -> Vec<f32> {
        img.pixels().map(|p| f32::from(p.0[0]) / 255.0).collect()
    }

    #[test]
    fn four_quarter_turns_give_the_motion_image_back() {
        let reference = lattice(|_, _| [0.0, 0.0]);
        let motion = PinMotion::new(&reference, "test").expect("a lattice of pins");
        // A press: every pin pushed out from a point left of the centre, more near it.
        let moved = lattice(|x, y| {
            let (u, v) = (x - 50.0, y - 64.0);
            let r = u.hypot(v).max(1.0);
            [2.0 * u / r * (-r / 30.0).exp(), 2.0 * v / r * (-r / 30.0).exp()]
        });
        let img = values(&motion.image(&moved, 64, "test").expect("a motion image"));
        let mut turned = img.clone();
        for _ in 0..4 {
            turned = turn_motion(&turned, 64, std::f64::consts::FRAC_PI_2);
        }
        let worst = img.iter().zip(&turned).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-6, "four quarter turns: largest change {worst}");
        assert_ne!(turn_motion(&img, 64, std::f64::consts::FRAC_PI_2), img, "a quarter turn moves the press");
    }

    #[test]
    fn a_quarter_turn_turns_a_shift_along_x_into_one_along_y() {
        let reference = lattice(|_, _| [0.0, 0.0]);
        let motion = PinMotion::new(&reference, "test").expect("a lattice of pins");
        let img = values(&motion.image(&lattice(|_, _| [1.0, 0.0]), 64, "test").expect("a motion image"));
        let turned = turn_motion(&img, 64, std::f64::consts::FRAC_PI_2);
        // The grid point at the centre, as in the shift test above: +x turns towards +y.
        let d = |v: &[f32], x: usize, y: usize| (f64::from(v[y * 64 + x]) - 0.5) * GREY_PX128;
        assert!((d(&turned, 32, 48) - d(&img, 32, 16)).abs() < 0.01, "dy {}", d(&turned, 32, 48));
        assert!(d(&turned, 32, 16).abs() < 0.02, "dx {}", d(&turned, 32, 16));
        // Half a turn: the shift reversed.
        let back = turn_motion(&img, 64, std::f64::consts::PI);
        assert!((d(&back, 32, 16) + d(&img, 32, 16)).abs() < 0.01, "dx {}", d(&back, 32, 16));
    }

    #[test]
    fn values_of_another_size_come_back_unchanged() {
        let v = vec![0.25f32; 10];
        assert_eq!(turn_motion(&v, 64, 1.0), v);
        assert_eq!(turn_motion(&v, 0, 1.0), v);
    }

    #[test]
    fn a_reference_without_pins_is_refused() {
        let e = PinMotion::new(&GrayImage::new(128, 128), "blank.png").expect_err("refused").to_string();
        assert!(e.contains("blank.png") && e.contains("0 pins"), "{e}");
    }
}
