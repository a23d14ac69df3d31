//! Two-dimensional real FFTs of fixed size for the zero-padded (DC-FFT) operator products.

use std::sync::Arc;

use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

/// Forward and inverse transforms of an `m x n` real array stored row by row (`m` along `x`).
/// Spectra hold `(m/2 + 1) * n` values, column by column (`kx * n + ky`).
#[derive(Clone)]
pub struct Fft2 {
    m: usize,
    n: usize,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
}

impl std::fmt::Debug for Fft2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Fft2({}x{})", self.m, self.n)
    }
}

impl Fft2 {
    /// Plans for an `m x n` array (`m` even).
    pub fn new(m: usize, n: usize) -> Self {
        let mut real = RealFftPlanner::<f64>::new();
        let mut complex = FftPlanner::<f64>::new();
        Self {
            m,
            n,
            r2c: real.plan_fft_forward(m),
            c2r: real.plan_fft_inverse(m),
            forward: complex.plan_fft_forward(n),
            inverse: complex.plan_fft_inverse(n),
        }
    }

    /// Number of spectrum values.
    pub fn spectrum_len(&self) -> usize {
        (self.m / 2 + 1) * self.n
    }

    /// Forward transform of the `m x n` array whose first `input.len() / m` rows are `input`
    /// (row by row; all `n` at most) and whose other rows are zero, into a new spectrum. The
    /// zero rows' row transforms are zero and are skipped: a zero-padded operator product's
    /// input has nonzero rows in its first half only, so its row transforms halve (issue 31).
    pub fn forward(&self, input: &[f64]) -> Vec<Complex64> {
        assert!(
            input.len().is_multiple_of(self.m) && input.len() <= self.m * self.n,
            "rows of a {}-wide FFT input",
            self.m
        );
        let half = self.m / 2 + 1;
        let mut spectrum = vec![Complex64::new(0.0, 0.0); half * self.n];
        let mut row = vec![0.0; self.m];
        let mut row_out = vec![Complex64::new(0.0, 0.0); half];
        let mut scratch = self.r2c.make_scratch_vec();
        for (y, values) in input.chunks_exact(self.m).enumerate() {
            row.copy_from_slice(values);
            // Lengths are right by construction; realfft only fails on wrong lengths.
            let _ = self.r2c.process_with_scratch(&mut row, &mut row_out, &mut scratch);
            for (kx, v) in row_out.iter().enumerate() {
                spectrum[kx * self.n + y] = *v;
            }
        }
        self.forward.process(&mut spectrum);
        spectrum
    }

    /// The first `out.len() / m` rows (all `n` at most) of the inverse transform of `spectrum`
    /// (consumed), row by row into `out`, normalised so that `inverse(forward(a)) == a`. The
    /// other rows' row transforms are skipped: a zero-padded product reads its first half only.
    pub fn inverse(&self, mut spectrum: Vec<Complex64>, out: &mut [f64]) {
        assert!(
            out.len().is_multiple_of(self.m) && out.len() <= self.m * self.n,
            "rows of a {}-wide FFT output",
            self.m
        );
        let half = self.m / 2 + 1;
        self.inverse.process(&mut spectrum);
        let scale = 1.0 / (self.m * self.n) as f64;
        let mut row_in = vec![Complex64::new(0.0, 0.0); half];
        let mut row = vec![0.0; self.m];
        let mut scratch = self.c2r.make_scratch_vec();
        for (y, values) in out.chunks_exact_mut(self.m).enumerate() {
            for (kx, v) in row_in.iter_mut().enumerate() {
                *v = spectrum[kx * self.n + y] * scale;
            }
            // The input is the spectrum of a real array: the DC and Nyquist bins are real up to
            // rounding, which realfft would reject.
            row_in[0].im = 0.0;
            row_in[half - 1].im = 0.0;
            let _ = self.c2r.process_with_scratch(&mut row_in, &mut row, &mut scratch);
            values.copy_from_slice(&row);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_by_rows_equal_the_whole_ones() {
        let (m, n) = (8, 6);
        let f = Fft2::new(m, n);
        let rows: Vec<f64> = (0..m * 3).map(|k| ((k * 29 % 13) as f64) - 6.0).collect();
        let mut whole = rows.clone();
        whole.resize(m * n, 0.0);
        let (a, b) = (f.forward(&rows), f.forward(&whole));
        assert_eq!(a, b, "the zero rows' transforms are zero");
        let mut all = vec![0.0; m * n];
        f.inverse(b.clone(), &mut all);
        let mut first = vec![0.0; m * 3];
        f.inverse(b, &mut first);
        assert_eq!(first[..], all[..m * 3]);
    }

    #[test]
    fn round_trip_and_circular_convolution() {
        let (m, n) = (8, 6);
        let a: Vec<f64> = (0..m * n).map(|k| ((k * 37 % 11) as f64) - 5.0).collect();
        let b: Vec<f64> = (0..m * n).map(|k| ((k * 13 % 7) as f64) * 0.5).collect();
        let f = Fft2::new(m, n);
        let mut back = vec![0.0; m * n];
        f.inverse(f.forward(&a), &mut back);
        for (x, y) in a.iter().zip(&back) {
            assert!((x - y).abs() < 1e-12);
        }
        let (fa, fb) = (f.forward(&a), f.forward(&b));
        let mut conv = vec![0.0; m * n];
        f.inverse(fa.iter().zip(&fb).map(|(x, y)| x * y).collect(), &mut conv);
        for y in 0..n {
            for x in 0..m {
                let mut s = 0.0;
                for v in 0..n {
                    for u in 0..m {
                        s += a[v * m + u] * b[((n + y - v) % n) * m + (m + x - u) % m];
                    }
                }
                assert!((conv[y * m + x] - s).abs() < 1e-9);
            }
        }
    }
}
