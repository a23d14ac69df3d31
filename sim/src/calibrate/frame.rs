//! Frame mapping from the data: how the labels' lateral axes relate to the sensor's.
//!
//! A recording's global shift `g` (px, median pin displacement) answers its slide offset `s`
//! and tilt `t` (label frame, mm and deg) about linearly while the skin sticks. Regressing
//! `g = A s + B t + c` over recordings gives the label-to-image map `A`; its nearest
//! orthogonal map `Q` (polar decomposition) is a rotation, mirrored when `det Q < 0`. The same
//! regression on recordings simulated with the identity [`RigFrame`] gives the
//! sensor-to-image map `Q_sim`, and the label frame is `F = Q_sim^T Q` (simulating with `F`
//! then moves the image as the real recordings do).

use nalgebra::{DMatrix, DVector, Matrix2};
use serde::{Deserialize, Serialize};

use tacsim_data::LabSample;

use super::model::{RigFrame, SampleError};

/// `m v` for a row-major 2x2 matrix.
fn mul(m: &[[f64; 2]; 2], v: [f64; 2]) -> [f64; 2] {
    [m[0][0] * v[0] + m[0][1] * v[1], m[1][0] * v[0] + m[1][1] * v[1]]
}

/// One recording for the regression: slide offset (mm), tilt `[Rx, Ry]` (deg) and global
/// shift (px).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftSample {
    /// Slide offset `[x, y]` (mm).
    pub offset_mm: [f64; 2],
    /// Tilt `[Rx, Ry]` (deg).
    pub tilt_deg: [f64; 2],
    /// Global shift of the pins (px).
    pub shift_px: [f64; 2],
}

/// The regression samples of recordings `labels` with their errors `errors` (same order):
/// `[real, simulated]` global shifts against the labels.
pub fn shift_samples<'a>(
    labels: impl IntoIterator<Item = &'a LabSample>,
    errors: &[SampleError],
) -> [Vec<ShiftSample>; 2] {
    let mut out = [Vec::new(), Vec::new()];
    for (s, e) in labels.into_iter().zip(errors) {
        for (v, shift) in out.iter_mut().zip([e.real_shift, e.sim_shift]) {
            v.push(ShiftSample {
                offset_mm: [s.shear[0], s.shear[1]],
                tilt_deg: [s.pose[3], s.pose[4]],
                shift_px: shift,
            });
        }
    }
    out
}

/// The fitted map from label offsets to image shifts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImageMap {
    /// Nearest orthogonal map, `image direction = q * label direction` (row-major).
    pub q: [[f64; 2]; 2],
    /// Rotation (deg) of `q`, after mirroring `y` when `mirrored`.
    pub rotation_deg: f64,
    /// Whether `q` flips handedness.
    pub mirrored: bool,
    /// Mean gain (px of shift per mm of offset): the singular values' mean.
    pub gain_px_per_mm: f64,
    /// How far the linear map is from orthogonal: smaller over larger singular value (1:
    /// a pure rotation and scale).
    pub isotropy: f64,
    /// RMS residual of the regression (px).
    pub rms_px: f64,
    /// Recordings used.
    pub samples: usize,
    /// The fitted linear maps: shift per offset `a` (px/mm) and per tilt `b` (px/deg).
    pub a: [[f64; 2]; 2],
    /// See `a`.
    pub b: [[f64; 2]; 2],
}

impl ImageMap {
    /// Fits the map over `samples`; `None` with fewer than 8 samples or a singular system.
    pub fn fit(samples: &[ShiftSample]) -> Option<Self> {
        let n = samples.len();
        if n < 8 {
            return None;
        }
        // Columns: offset x, offset y, tilt x, tilt y, 1.
        let x = DMatrix::from_fn(n, 5, |i, j| {
            let s = &samples[i];
            match j {
                0 => s.offset_mm[0],
                1 => s.offset_mm[1],
                2 => s.tilt_deg[0],
                3 => s.tilt_deg[1],
                _ => 1.0,
            }
        });
        let svd = x.clone().svd(true, true);
        let (mut a, mut b) = (Matrix2::zeros(), Matrix2::zeros());
        let mut sq = 0.0;
        for k in 0..2 {
            let y = DVector::from_fn(n, |i, _| samples[i].shift_px[k]);
            let beta = svd.solve(&y, 1e-9).ok()?;
            a[(k, 0)] = beta[0];
            a[(k, 1)] = beta[1];
            b[(k, 0)] = beta[2];
            b[(k, 1)] = beta[3];
            sq += (&x * &beta - &y).norm_squared();
        }
        let polar = a.svd(true, true);
        let (u, v_t) = (polar.u?, polar.v_t?);
        let q = u * v_t;
        let det = q.determinant();
        let mirrored = det < 0.0;
        // q = R(theta) diag(1, -1) when mirrored (as RigFrame::new), R(theta) otherwise.
        let r = if mirrored { q * Matrix2::new(1.0, 0.0, 0.0, -1.0) } else { q };
        let s = polar.singular_values;
        Some(Self {
            q: [[q[(0, 0)], q[(0, 1)]], [q[(1, 0)], q[(1, 1)]]],
            rotation_deg: r[(1, 0)].atan2(r[(0, 0)]).to_degrees(),
            mirrored,
            gain_px_per_mm: 0.5 * (s[0] + s[1]),
            isotropy: s[0].min(s[1]) / s[0].max(s[1]).max(f64::MIN_POSITIVE),
            rms_px: (sq / (2 * n) as f64).sqrt(),
            samples: n,
            a: [[a[(0, 0)], a[(0, 1)]], [a[(1, 0)], a[(1, 1)]]],
            b: [[b[(0, 0)], b[(0, 1)]], [b[(1, 0)], b[(1, 1)]]],
        })
    }
}

/// The label frame found by [`best_frame`], with the gains that fit it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameFit {
    /// The frame, its tilts reversed where the fitted tilt gain is negative.
    pub frame: RigFrame,
    /// Its rotation (deg), after mirroring `y` when `mirrored`.
    pub rotation_deg: f64,
    /// Whether it flips handedness.
    pub mirrored: bool,
    /// Real over simulated slide response (positive by construction).
    pub slide_gain: f64,
    /// Real over simulated tilt response: negative when the real tilt moves the image the
    /// other way from the simulated one, that is when the labels' tilt sign convention differs.
    pub tilt_gain: f64,
    /// RMS residual of the real shifts (px).
    pub rms_px: f64,
}

/// The label frame, searched over rotations (1 deg steps) and both handednesses, under which
/// the simulation's maps `sim` (fitted with the identity frame) best predict the real
/// recordings' shifts: `g = alpha A F s + beta det(F) B F t + c` (offsets map as vectors,
/// tilts as rotation vectors), with `alpha`, `beta`, `c` fitted per candidate since the
/// simulation's gains are not yet the real ones. A frame turned by half a turn fits as well
/// with both gains negated; the one with `alpha >= 0` (the slide moves the image as simulated)
/// is returned, and `beta`'s sign tells whether the tilt does too. Uses the tilt response as
/// well as the slide response, which sliding friction keeps small.
pub fn best_frame(real: &[ShiftSample], sim: &ImageMap) -> Option<FrameFit> {
    let n = real.len();
    if n < 8 {
        return None;
    }
    let y = DVector::from_fn(2 * n, |r, _| real[r / 2].shift_px[r % 2]);
    let mut best: Option<FrameFit> = None;
    for mirrored in [false, true] {
        for deg in -179..=180 {
            let frame = RigFrame::new(f64::from(deg), mirrored);
            let d = if mirrored { -1.0 } else { 1.0 };
            // Columns: alpha, beta, c_x, c_y.
            let x = DMatrix::from_fn(2 * n, 4, |r, j| {
                let s = &real[r / 2];
                let k = r % 2;
                match j {
                    0 => mul(&sim.a, mul(&frame.m, s.offset_mm))[k],
                    1 => d * mul(&sim.b, mul(&frame.m, s.tilt_deg))[k],
                    _ => f64::from(u8::from(j - 2 == k)),
                }
            });
            let Ok(beta) = x.clone().svd(true, true).solve(&y, 1e-9) else { continue };
            if beta[0] < 0.0 {
                continue;
            }
            let rms_px = ((&x * &beta - &y).norm_squared() / (2 * n) as f64).sqrt();
            if best.as_ref().is_none_or(|b| rms_px < b.rms_px) {
                best = Some(FrameFit {
                    frame: frame.with_tilts_reversed(beta[1] < 0.0),
                    rotation_deg: f64::from(deg),
                    mirrored,
                    slide_gain: beta[0],
                    tilt_gain: beta[1],
                    rms_px,
                });
            }
        }
    }
    best
}

/// The label frame that makes the simulation (image map `sim`, fitted on recordings simulated
/// with the identity frame) move the image as the real recordings do (image map `real`):
/// `F = Q_sim^T Q_real`.
pub fn label_frame(real: &ImageMap, sim: &ImageMap) -> RigFrame {
    let (r, s) = (real.q, sim.q);
    let mut m = [[0.0; 2]; 2];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = s[0][i] * r[0][j] + s[1][i] * r[1][j];
        }
    }
    RigFrame { m, tilt_sign: 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples whose shift is `gain * R(deg) [mirror] offset` plus a tilt term and a small
    /// deterministic wobble.
    fn samples(deg: f64, mirrored: bool, gain: f64) -> Vec<ShiftSample> {
        let frame = RigFrame::new(deg, mirrored);
        (0..60)
            .map(|i| {
                let f = i as f64;
                let offset = [4.0 * (0.37 * f).sin(), 4.0 * (0.91 * f + 1.0).cos()];
                let tilt = [20.0 * (0.53 * f + 2.0).sin(), 20.0 * (0.29 * f).cos()];
                let m = frame.m;
                let wobble = 0.2 * (1.7 * f).sin();
                let shift = [
                    gain * (m[0][0] * offset[0] + m[0][1] * offset[1]) + 0.1 * tilt[1] + wobble,
                    gain * (m[1][0] * offset[0] + m[1][1] * offset[1]) - 0.1 * tilt[0] - wobble,
                ];
                ShiftSample { offset_mm: offset, tilt_deg: tilt, shift_px: shift }
            })
            .collect()
    }

    #[test]
    fn the_rotation_and_handedness_of_a_known_map_are_recovered() {
        for (deg, mirrored) in [(0.0, false), (90.0, false), (-135.0, true), (30.0, true)] {
            let map = ImageMap::fit(&samples(deg, mirrored, 2.5)).expect("fit");
            assert_eq!(map.mirrored, mirrored, "{deg} {mirrored}: {map:?}");
            let err = (map.rotation_deg - deg + 540.0).rem_euclid(360.0) - 180.0;
            assert!(err.abs() < 0.5, "{deg} {mirrored}: {map:?}");
            assert!((map.gain_px_per_mm - 2.5).abs() < 0.05 && map.isotropy > 0.98, "{map:?}");
        }
        assert!(ImageMap::fit(&samples(0.0, false, 1.0)[..5]).is_none());
    }

    #[test]
    fn the_best_frame_predicts_real_shifts_from_the_simulated_maps() {
        // Simulation: offsets and tilts map to the image as in `samples` with the identity.
        let sim = ImageMap::fit(&samples(0.0, false, 3.0)).expect("sim");
        // Real labels in a frame rotated by 40 deg and mirrored: the shifts the simulation
        // gives for the sensor-frame labels F s, F t (tilts as rotation vectors: det F).
        let f = RigFrame::new(40.0, true);
        let real: Vec<ShiftSample> = samples(0.0, false, 1.0)
            .into_iter()
            .map(|s| {
                let (o, t) = (mul(&f.m, s.offset_mm), mul(&f.m, s.tilt_deg).map(|v| -v));
                let g = [0.5 * mul(&sim.a, o)[0] + mul(&sim.b, t)[0], 0.5 * mul(&sim.a, o)[1] + mul(&sim.b, t)[1]];
                ShiftSample { shift_px: g, ..s }
            })
            .collect();
        let fit = best_frame(&real, &sim).expect("frame");
        assert!(fit.mirrored && (fit.rotation_deg - 40.0).abs() < 0.5 && fit.rms_px < 1e-6, "{fit:?}");
        assert!((fit.slide_gain - 0.5).abs() < 1e-6 && (fit.tilt_gain - 1.0).abs() < 1e-6, "{fit:?}");
    }

    #[test]
    fn the_label_frame_composes_the_real_map_with_the_simulated_one() {
        // The simulation maps sensor offsets to the image rotated by 90 deg; the real data maps
        // label offsets mirrored and rotated by 30: the label frame is their difference.
        let sim = ImageMap::fit(&samples(90.0, false, 3.0)).expect("sim");
        let real = ImageMap::fit(&samples(30.0, true, 2.0)).expect("real");
        let f = label_frame(&real, &sim);
        let want = RigFrame::new(-60.0, true);
        for i in 0..2 {
            for j in 0..2 {
                assert!((f.m[i][j] - want.m[i][j]).abs() < 1e-3, "{f:?} vs {want:?}");
            }
        }
    }
}
