//! How the labels' lateral axes map to the image: the least-squares linear map from a slide's
//! touch-down offset `(shear_x, shear_y)` (mm) to the global pin shift (px), on samples with
//! little tilt, split into scale, rotation and handedness.

use super::observe::Observations;

/// Largest tilt (deg) of the samples used.
pub const MAX_TILT_DEG: f64 = 8.0;

/// The fitted map.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameMap {
    /// `shift = m * shear`, row-major (px/mm).
    pub m: [[f64; 2]; 2],
    /// Rotation (deg) of the closest rotation (or reflection) to `m`.
    pub rotation_deg: f64,
    /// Whether the map mirrors (negative determinant).
    pub mirrored: bool,
    /// Mean scale (px per mm of offset).
    pub scale_px_per_mm: f64,
    /// Samples used.
    pub samples: usize,
    /// RMS residual of the fit (px).
    pub rms_px: f64,
}

/// Fits the map on `obs` (samples with tilt below [`MAX_TILT_DEG`]); `None` with fewer than
/// three usable samples.
pub fn fit(obs: &Observations) -> Option<FrameMap> {
    let used: Vec<([f64; 2], [f64; 2])> = obs
        .samples
        .iter()
        .filter(|o| o.sample.pose[3].abs().max(o.sample.pose[4].abs()) <= MAX_TILT_DEG)
        .map(|o| ([o.sample.shear[0], o.sample.shear[1]], o.tracking.global_shift))
        .collect();
    if used.len() < 3 {
        return None;
    }
    // Normal equations for each output row: shift_k = m_k . shear.
    let (mut a, mut b) = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
    for (s, d) in &used {
        for i in 0..2 {
            for j in 0..2 {
                a[i][j] += s[i] * s[j];
            }
            for k in 0..2 {
                b[k][i] += d[k] * s[i];
            }
        }
    }
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]];
    let m: [[f64; 2]; 2] = std::array::from_fn(|k| std::array::from_fn(|j| b[k][0] * inv[0][j] + b[k][1] * inv[1][j]));
    let mdet = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let mirrored = mdet < 0.0;
    // Closest rotation of m (or of m with its second column negated when mirrored).
    let (c0, c1) =
        if mirrored { ([m[0][0], m[1][0]], [-m[0][1], -m[1][1]]) } else { ([m[0][0], m[1][0]], [m[0][1], m[1][1]]) };
    let rotation = (c0[1] - c1[0]).atan2(c0[0] + c1[1]);
    let scale = 0.5 * (c0[0].hypot(c0[1]) + c1[0].hypot(c1[1]));
    let rms = (used
        .iter()
        .map(|(s, d)| {
            let p = [m[0][0] * s[0] + m[0][1] * s[1], m[1][0] * s[0] + m[1][1] * s[1]];
            (p[0] - d[0]).powi(2) + (p[1] - d[1]).powi(2)
        })
        .sum::<f64>()
        / used.len() as f64)
        .sqrt();
    Some(FrameMap {
        m,
        rotation_deg: rotation.to_degrees(),
        mirrored,
        scale_px_per_mm: scale,
        samples: used.len(),
        rms_px: rms,
    })
}
