//! Small nonlinear least squares: Levenberg-Marquardt with a forward-difference Jacobian.
//! For the handful-of-parameters fits of calibration (camera, ring placement, materials).

use nalgebra::{DMatrix, DVector};

/// Outcome of [`levenberg_marquardt`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitResult {
    /// Best parameters found.
    pub params: Vec<f64>,
    /// Root-mean-square residual at `params`.
    pub rms: f64,
    /// Iterations used.
    pub iterations: usize,
}

/// Minimises `sum residuals(p)^2` from `start`. `residuals` returns `None` where the model is
/// undefined (the step is then rejected as if it were worse). `scale` gives each parameter's
/// typical magnitude (finite-difference step = 1e-6 x scale).
pub fn levenberg_marquardt(
    start: &[f64],
    scale: &[f64],
    max_iterations: usize,
    mut residuals: impl FnMut(&[f64]) -> Option<Vec<f64>>,
) -> Option<FitResult> {
    let n = start.len();
    let mut p = start.to_vec();
    let mut r = DVector::from_vec(residuals(&p)?);
    let m = r.len();
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    for it in 0..max_iterations {
        iterations = it + 1;
        let mut jac = DMatrix::zeros(m, n);
        for j in 0..n {
            let h = 1e-6 * scale[j].abs().max(1e-12);
            let mut q = p.clone();
            q[j] += h;
            let rq = DVector::from_vec(residuals(&q)?);
            jac.set_column(j, &((rq - &r) / h));
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &r;
        let mut improved = false;
        for _ in 0..20 {
            let mut a = jtj.clone();
            for i in 0..n {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let q: Vec<f64> = p.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            match residuals(&q).map(DVector::from_vec) {
                Some(rq) if rq.norm_squared() < cost => {
                    let gain = cost - rq.norm_squared();
                    p = q;
                    r = rq;
                    cost = r.norm_squared();
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = gain > 1e-15 * cost.max(1e-300);
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    Some(FitResult { params: p, rms: (cost / m as f64).sqrt(), iterations })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential() {
        let xs: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 2.5 * (-1.3 * x).exp() + 0.2).collect();
        let fit = levenberg_marquardt(&[1.0, -0.5, 0.0], &[1.0, 1.0, 1.0], 200, |p| {
            Some(xs.iter().zip(&ys).map(|(x, y)| p[0] * (p[1] * x).exp() + p[2] - y).collect())
        })
        .expect("defined");
        assert!(fit.rms < 1e-8, "{fit:?}");
        assert!((fit.params[0] - 2.5).abs() < 1e-6 && (fit.params[1] + 1.3).abs() < 1e-6);
    }
}
