//! Small fits for calibration's handful of parameters: Levenberg-Marquardt with a
//! forward-difference Jacobian (smooth least squares: camera, ring placement), and
//! Nelder-Mead (derivative-free, for objectives with kinks: contact sets that change with the
//! parameters).

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

/// Outcome of [`nelder_mead`].
#[derive(Clone, Debug, PartialEq)]
pub struct Minimum {
    /// Best parameters found.
    pub params: Vec<f64>,
    /// Objective there.
    pub value: f64,
    /// Objective evaluations.
    pub evaluations: usize,
}

/// Minimises `f` from `start` with an initial simplex of steps `step` per parameter, until the
/// simplex's values span less than `tolerance` or `max_evaluations` is spent. `f` may return
/// `+inf` where the model is undefined (outside bounds).
pub fn nelder_mead(
    start: &[f64],
    step: &[f64],
    tolerance: f64,
    max_evaluations: usize,
    mut f: impl FnMut(&[f64]) -> f64,
) -> Minimum {
    let n = start.len();
    let mut evals = 0;
    let mut eval = |p: &[f64], evals: &mut usize| {
        *evals += 1;
        let v = f(p);
        if v.is_nan() { f64::INFINITY } else { v }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((start.to_vec(), eval(start, &mut evals)));
    for i in 0..n {
        let mut p = start.to_vec();
        p[i] += step[i];
        let v = eval(&p, &mut evals);
        simplex.push((p, v));
    }
    while evals < max_evaluations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        if (simplex[n].1 - simplex[0].1).abs() <= tolerance {
            break;
        }
        let centroid: Vec<f64> = (0..n).map(|k| simplex[..n].iter().map(|s| s.0[k]).sum::<f64>() / n as f64).collect();
        let along =
            |t: f64| -> Vec<f64> { (0..n).map(|k| centroid[k] + t * (simplex[n].0[k] - centroid[k])).collect() };
        let reflected = along(-1.0);
        let fr = eval(&reflected, &mut evals);
        if fr < simplex[0].1 {
            let expanded = along(-2.0);
            let fe = eval(&expanded, &mut evals);
            simplex[n] = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (reflected, fr);
        } else {
            let contracted = if fr < simplex[n].1 { along(-0.5) } else { along(0.5) };
            let fc = eval(&contracted, &mut evals);
            if fc < fr.min(simplex[n].1) {
                simplex[n] = (contracted, fc);
            } else {
                // Shrink towards the best.
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 = best.iter().zip(&s.0).map(|(b, x)| b + 0.5 * (x - b)).collect();
                    s.1 = eval(&s.0, &mut evals);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (params, value) = simplex.swap_remove(0);
    Minimum { params, value, evaluations: evals }
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

    #[test]
    fn nelder_mead_finds_the_rosenbrock_minimum_and_respects_infinite_walls() {
        let m = nelder_mead(&[-1.2, 1.0], &[0.5, 0.5], 1e-14, 2000, |p| {
            (1.0 - p[0]).powi(2) + 100.0 * (p[1] - p[0] * p[0]).powi(2)
        });
        assert!((m.params[0] - 1.0).abs() < 1e-4 && (m.params[1] - 1.0).abs() < 1e-4, "{m:?}");
        let walled =
            nelder_mead(&[2.0], &[1.0], 1e-12, 500, |p| if p[0] < 1.5 { f64::INFINITY } else { (p[0] - 1.0).powi(2) });
        assert!((walled.params[0] - 1.5).abs() < 1e-3, "{walled:?}");
    }
}
