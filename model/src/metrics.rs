//! Image similarity for evaluation: SSIM (Wang et al. 2004) with an 11-tap Gaussian window
//! (sigma 1.5), `K1 = 0.01`, `K2 = 0.03`, population covariances and data range 1, averaged
//! over the valid (unpadded) region; MS-SSIM (Wang, Simoncelli & Bovik 2003) with the standard
//! five weights `(0.0448, 0.2856, 0.3001, 0.2363, 0.1333)` and 2x2 average pooling between
//! scales (odd sizes zero-padded); and MSE. Images are row-major `f32` in `[0, 1]`.
//!
//! MS-SSIM needs the last scale to be at least the window (11 px): 256 px images get 5
//! scales, 128 px get 4 and 64 px get 3, with the first weights renormalised; [`ms_ssim`]
//! returns how many it used. Values are checked against scikit-image (SSIM) and a numpy
//! implementation of pytorch-msssim's algorithm (MS-SSIM) in `reference/ssim_reference.py`.

use thiserror::Error;

/// Errors of the metrics.
#[derive(Debug, Error, PartialEq)]
pub enum MetricError {
    /// The images differ in size or do not match their stated size.
    #[error("images must both be {width}x{height} (= {expected} values), got {a} and {b} values")]
    Size {
        /// Stated width.
        width: usize,
        /// Stated height.
        height: usize,
        /// Values expected.
        expected: usize,
        /// Values of the first image.
        a: usize,
        /// Values of the second image.
        b: usize,
    },
    /// The images are smaller than the window.
    #[error("images of {width}x{height} px are smaller than the {WINDOW} px SSIM window")]
    TooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
}

/// Side of the Gaussian window (px).
pub const WINDOW: usize = 11;
/// Standard deviation of the window (px).
pub const SIGMA: f64 = 1.5;
/// Stability constants.
pub const K1: f64 = 0.01;
/// See [`K1`].
pub const K2: f64 = 0.03;
/// MS-SSIM scale weights, finest first.
pub const MS_WEIGHTS: [f64; 5] = [0.0448, 0.2856, 0.3001, 0.2363, 0.1333];

fn check(a: &[f32], b: &[f32], width: usize, height: usize) -> Result<(), MetricError> {
    let expected = width * height;
    if a.len() != expected || b.len() != expected {
        return Err(MetricError::Size { width, height, expected, a: a.len(), b: b.len() });
    }
    if width < WINDOW || height < WINDOW {
        return Err(MetricError::TooSmall { width, height });
    }
    Ok(())
}

fn window() -> [f64; WINDOW] {
    let c = (WINDOW / 2) as f64;
    let mut g = std::array::from_fn(|i| (-((i as f64 - c).powi(2)) / (2.0 * SIGMA * SIGMA)).exp());
    let s: f64 = g.iter().sum();
    for v in &mut g {
        *v /= s;
    }
    g
}

/// Valid separable Gaussian filtering: `(w - 10) x (h - 10)` output.
fn filter(img: &[f64], w: usize, h: usize, g: &[f64; WINDOW]) -> Vec<f64> {
    let (ow, oh) = (w - WINDOW + 1, h - WINDOW + 1);
    let mut rows = vec![0.0; ow * h];
    for y in 0..h {
        for x in 0..ow {
            rows[y * ow + x] = (0..WINDOW).map(|k| g[k] * img[y * w + x + k]).sum();
        }
    }
    let mut out = vec![0.0; ow * oh];
    for y in 0..oh {
        for x in 0..ow {
            out[y * ow + x] = (0..WINDOW).map(|k| g[k] * rows[(y + k) * ow + x]).sum();
        }
    }
    out
}

/// Mean SSIM and mean contrast-structure term of two `f64` images.
fn ssim_cs(a: &[f64], b: &[f64], w: usize, h: usize) -> (f64, f64) {
    let g = window();
    let (c1, c2) = (K1 * K1, K2 * K2);
    let prod = |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| f(*x, *y)).collect() };
    let (mu_a, mu_b) = (filter(a, w, h, &g), filter(b, w, h, &g));
    let (aa, bb, ab) = (
        filter(&prod(&|x, _| x * x), w, h, &g),
        filter(&prod(&|_, y| y * y), w, h, &g),
        filter(&prod(&|x, y| x * y), w, h, &g),
    );
    let n = mu_a.len() as f64;
    let (mut ssim, mut cs) = (0.0, 0.0);
    for i in 0..mu_a.len() {
        let (ma, mb) = (mu_a[i], mu_b[i]);
        let (saa, sbb, sab) = (aa[i] - ma * ma, bb[i] - mb * mb, ab[i] - ma * mb);
        let c = (2.0 * sab + c2) / (saa + sbb + c2);
        cs += c;
        ssim += (2.0 * ma * mb + c1) / (ma * ma + mb * mb + c1) * c;
    }
    (ssim / n, cs / n)
}

fn widen(v: &[f32]) -> Vec<f64> {
    v.iter().map(|&x| x as f64).collect()
}

/// SSIM of two `width x height` images.
pub fn ssim(a: &[f32], b: &[f32], width: usize, height: usize) -> Result<f64, MetricError> {
    check(a, b, width, height)?;
    Ok(ssim_cs(&widen(a), &widen(b), width, height).0)
}

/// 2x2 average pooling, zero-padding an odd last row or column.
fn pool(img: &[f64], w: usize, h: usize) -> (Vec<f64>, usize, usize) {
    let (ow, oh) = (w.div_ceil(2), h.div_ceil(2));
    let at = |x: usize, y: usize| if x < w && y < h { img[y * w + x] } else { 0.0 };
    let out = (0..ow * oh)
        .map(|k| {
            let (x, y) = (2 * (k % ow), 2 * (k / ow));
            0.25 * (at(x, y) + at(x + 1, y) + at(x, y + 1) + at(x + 1, y + 1))
        })
        .collect();
    (out, ow, oh)
}

/// MS-SSIM of two `width x height` images, and the number of scales used (at most 5; fewer
/// when the coarsest scale would be smaller than the window).
pub fn ms_ssim(a: &[f32], b: &[f32], width: usize, height: usize) -> Result<(f64, usize), MetricError> {
    check(a, b, width, height)?;
    let side = width.min(height);
    let mut levels = 1;
    while levels < MS_WEIGHTS.len() && side >> levels >= WINDOW {
        levels += 1;
    }
    let total: f64 = MS_WEIGHTS[..levels].iter().sum();
    let (mut a, mut b, mut w, mut h) = (widen(a), widen(b), width, height);
    let mut value = 1.0;
    for (level, weight) in MS_WEIGHTS[..levels].iter().enumerate() {
        let (s, cs) = ssim_cs(&a, &b, w, h);
        let term = if level + 1 < levels { cs } else { s };
        value *= term.max(0.0).powf(weight / total);
        if level + 1 < levels {
            let (pa, nw, nh) = pool(&a, w, h);
            let (pb, _, _) = pool(&b, w, h);
            (a, b, w, h) = (pa, pb, nw, nh);
        }
    }
    Ok((value, levels))
}

/// Mean squared error.
pub fn mse(a: &[f32], b: &[f32]) -> f64 {
    let n = a.len().min(b.len()).max(1) as f64;
    a.iter().zip(b).map(|(x, y)| (*x as f64 - *y as f64).powi(2)).sum::<f64>() / n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The images of `reference/ssim_reference.py`.
    fn image(kind: char, n: usize) -> Vec<f32> {
        (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64, (k / n) as f64);
                let a = 0.5 + 0.5 * (x / 7.0).sin() * (y / 11.0).cos();
                let v = if kind == 'a' { a } else { (a + 0.1 * ((x + 2.0 * y) / 5.0).sin()).clamp(0.0, 1.0) };
                v as f32
            })
            .collect()
    }

    #[test]
    fn ssim_and_ms_ssim_match_the_reference_values() {
        let text = include_str!("../reference/ssim_reference.json");
        let reference: serde_json::Value = serde_json::from_str(text).expect("reference JSON");
        for n in [256usize, 128, 64] {
            let r = &reference[n.to_string()];
            let (a, b) = (image('a', n), image('b', n));
            let s = ssim(&a, &b, n, n).expect("ssim");
            let (ms, levels) = ms_ssim(&a, &b, n, n).expect("ms-ssim");
            let (rs, rms) = (r["ssim_skimage"].as_f64().expect("f64"), r["ms_ssim"].as_f64().expect("f64"));
            // f32 images against the reference's f64 ones.
            assert!((s - rs).abs() < 2e-6, "{n}: SSIM {s} vs {rs}");
            assert!((ms - rms).abs() < 2e-6, "{n}: MS-SSIM {ms} vs {rms}");
            assert_eq!(levels as u64, r["ms_ssim_levels"].as_u64().expect("levels"), "{n}");
        }
    }

    #[test]
    fn identical_images_score_one_and_bad_sizes_are_errors() {
        let a = image('a', 64);
        assert!((ssim(&a, &a, 64, 64).expect("ssim") - 1.0).abs() < 1e-12);
        assert!((ms_ssim(&a, &a, 64, 64).expect("ms").0 - 1.0).abs() < 1e-12);
        assert_eq!(mse(&a, &a), 0.0);
        assert!(matches!(ssim(&a, &a[1..], 64, 64), Err(MetricError::Size { .. })));
        assert!(matches!(ssim(&a[..100], &a[..100], 10, 10), Err(MetricError::TooSmall { .. })));
    }
}
