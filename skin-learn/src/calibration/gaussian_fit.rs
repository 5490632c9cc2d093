//! The 2D Gaussian response model of one taxel (thesis Eq. 7.2) and its least-squares fit
//! (Eq. 7.3) by Newton-Raphson (Eq. 7.4), falling back to gradient descent where the Hessian is
//! not positive definite.
//!
//! t(x) = b5 exp(-((x1 - b1)^2 / b3^2 + (x2 - b2)^2 / b4^2))               (Eq. 7.2)
//!
//! The stopping threshold on ||b_l - b_(l-1)|| is in the units the caller gives (the calibration
//! passes millimetres about the contacts' mean and responses divided by their maximum, so it
//! means the same for every taxel). Inside, positions and widths are measured in start widths, so
//! that one gradient-descent step size suits all five parameters; that cut the iterations of a
//! wide start (width 10 for a true 4-5) from over 200 to 9. Each step is halved until the cost
//! decreases: a plain Newton step can overshoot when the samples are noisy, and the halving keeps
//! every iterate at least as good as the last.

use nalgebra::{Matrix5, Vector2, Vector5};

/// Stopping rule and budget of [`GaussianFit::fit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Stop when ||b_l - b_(l-1)|| falls under this (in the caller's units).
    pub epsilon: f64,
    /// Give up after this many iterations.
    pub max_iterations: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            epsilon: 1e-6,
            max_iterations: 200,
        }
    }
}

/// Result of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianFit {
    /// Parameters b1..b5 of Eq. 7.2 (b3, b4 made non-negative).
    pub beta: [f64; 5],
    /// Mean squared error at `beta` (Eq. 7.3).
    pub cost: f64,
    /// Iterations taken.
    pub iterations: usize,
    /// Iterations that fell back to gradient descent.
    pub gradient_steps: usize,
    /// The stopping rule was met within the budget.
    pub converged: bool,
}

/// Value, gradient and Hessian of the model at one sample.
fn model(beta: &Vector5<f64>, x: Vector2<f64>) -> (f64, Vector5<f64>, Matrix5<f64>) {
    let (b1, b2, b3, b4, b5) = (beta[0], beta[1], beta[2], beta[3], beta[4]);
    let (d1, d2) = (x[0] - b1, x[1] - b2);
    let (s3, s4) = (b3 * b3, b4 * b4);
    let g = (-(d1 * d1 / s3 + d2 * d2 / s4)).exp();
    // dt/dbi = b5 g w_i for i < 4, dt/db5 = g.
    let w = [
        2.0 * d1 / s3,
        2.0 * d2 / s4,
        2.0 * d1 * d1 / (s3 * b3),
        2.0 * d2 * d2 / (s4 * b4),
    ];
    // dw_i/db_j (symmetric, zero elsewhere).
    let mut dw = [[0.0; 4]; 4];
    dw[0][0] = -2.0 / s3;
    dw[0][2] = -4.0 * d1 / (s3 * b3);
    dw[2][0] = dw[0][2];
    dw[2][2] = -6.0 * d1 * d1 / (s3 * s3);
    dw[1][1] = -2.0 / s4;
    dw[1][3] = -4.0 * d2 / (s4 * b4);
    dw[3][1] = dw[1][3];
    dw[3][3] = -6.0 * d2 * d2 / (s4 * s4);
    let mut grad = Vector5::zeros();
    let mut hess = Matrix5::zeros();
    for i in 0..4 {
        grad[i] = b5 * g * w[i];
        for j in 0..4 {
            hess[(i, j)] = b5 * g * (w[i] * w[j] + dw[i][j]);
        }
        hess[(i, 4)] = g * w[i];
        hess[(4, i)] = g * w[i];
    }
    grad[4] = g;
    (b5 * g, grad, hess)
}

/// Value and gradient of the model at one sample (what [`model`] gives, without the Hessian).
fn value_and_gradient(beta: &Vector5<f64>, x: &[f64; 2]) -> (f64, Vector5<f64>) {
    let (b1, b2, b3, b4, b5) = (beta[0], beta[1], beta[2], beta[3], beta[4]);
    let (d1, d2) = (x[0] - b1, x[1] - b2);
    let (s3, s4) = (b3 * b3, b4 * b4);
    let g = (-(d1 * d1 / s3 + d2 * d2 / s4)).exp();
    let h = b5 * g;
    let grad = Vector5::new(
        h * 2.0 * d1 / s3,
        h * 2.0 * d2 / s4,
        h * 2.0 * d1 * d1 / (s3 * b3),
        h * 2.0 * d2 * d2 / (s4 * b4),
        g,
    );
    (h, grad)
}

/// Cost (Eq. 7.3), its gradient and Hessian over all samples.
fn cost_terms(beta: &Vector5<f64>, xs: &[Vector2<f64>], ts: &[f64]) -> (f64, Vector5<f64>, Matrix5<f64>) {
    let n = xs.len() as f64;
    let mut cost = 0.0;
    let mut grad = Vector5::zeros();
    let mut hess = Matrix5::zeros();
    for (x, &t) in xs.iter().zip(ts) {
        let (v, dv, ddv) = model(beta, *x);
        let r = t - v;
        cost += r * r;
        grad -= 2.0 * r * dv;
        hess += 2.0 * (dv * dv.transpose() - r * ddv);
    }
    (cost / n, grad / n, hess / n)
}

fn cost_only(beta: &Vector5<f64>, xs: &[Vector2<f64>], ts: &[f64]) -> f64 {
    let (b1, b2, s3, s4, b5) = (beta[0], beta[1], beta[2] * beta[2], beta[3] * beta[3], beta[4]);
    let sum: f64 = xs
        .iter()
        .zip(ts)
        .map(|(x, &t)| {
            let (d1, d2) = (x[0] - b1, x[1] - b2);
            let r = t - b5 * (-(d1 * d1 / s3 + d2 * d2 / s4)).exp();
            r * r
        })
        .sum();
    sum / xs.len() as f64
}

impl GaussianFit {
    /// The model's value at `x`.
    pub fn eval(&self, x: [f64; 2]) -> f64 {
        let b = self.beta;
        let (d1, d2) = (x[0] - b[0], x[1] - b[1]);
        b[4] * (-(d1 * d1 / (b[2] * b[2]) + d2 * d2 / (b[3] * b[3]))).exp()
    }

    /// The standard deviation of the fitted centre along its least certain direction, in the
    /// units of `xs` (the calibration's millimetres), from the samples the fit was made on: the
    /// Gauss-Newton covariance `s^2 (J^T J)^-1` of (b1, b2), with `s^2` the residual variance over
    /// `n - 5` degrees of freedom and `J` the model's Jacobian at the fit. `None` with no more
    /// samples than parameters, or where J^T J is singular (the centre is not determined).
    pub fn centre_sd(&self, xs: &[[f64; 2]], ts: &[f64]) -> Option<f64> {
        if xs.len() != ts.len() || xs.len() <= 5 {
            return None;
        }
        let beta = Vector5::from(self.beta);
        let mut jtj = Matrix5::zeros();
        let mut ssr = 0.0;
        for (x, &t) in xs.iter().zip(ts) {
            let (v, dv) = value_and_gradient(&beta, x);
            ssr += (t - v).powi(2);
            jtj += dv * dv.transpose();
        }
        let s2 = ssr / (xs.len() - 5) as f64;
        let inv = jtj.try_inverse()?;
        let centre = inv.fixed_view::<2, 2>(0, 0).into_owned() * s2;
        let eig = centre.symmetric_eigen();
        let largest = eig.eigenvalues.max();
        (largest.is_finite() && largest >= 0.0).then(|| largest.sqrt())
    }

    /// The documented start point: the mean of the samples, their largest standard deviation for
    /// both widths, the largest response for the height.
    pub fn start(xs: &[[f64; 2]], ts: &[f64]) -> [f64; 5] {
        let n = xs.len().max(1) as f64;
        let mean = xs
            .iter()
            .fold([0.0; 2], |m, x| [m[0] + x[0] / n, m[1] + x[1] / n]);
        let var = xs.iter().fold([0.0; 2], |v, x| {
            [
                v[0] + (x[0] - mean[0]).powi(2) / n,
                v[1] + (x[1] - mean[1]).powi(2) / n,
            ]
        });
        let sigma = var[0].max(var[1]).sqrt();
        let t_max = ts.iter().copied().fold(0.0, f64::max);
        [mean[0], mean[1], sigma, sigma, t_max]
    }

    /// Fits Eq. 7.2 to samples `(xs[k], ts[k])` from `start` (see [`GaussianFit::start`]).
    /// Needs at least 5 samples with finite values and non-zero widths at the start; returns
    /// `None` otherwise.
    pub fn fit(xs: &[[f64; 2]], ts: &[f64], start: [f64; 5], options: &FitOptions) -> Option<GaussianFit> {
        if xs.len() != ts.len()
            || xs.len() < 5
            || start.iter().any(|v| !v.is_finite())
            || start[2] == 0.0
            || start[3] == 0.0
        {
            return None;
        }
        // Positions and widths in units of the start width, so that one step size suits all five
        // parameters (the height is already of order one): gradient descent then zigzags far less.
        let scale = start[2].abs().max(start[3].abs());
        let unscale = Vector5::new(scale, scale, scale, scale, 1.0);
        let xs: Vec<Vector2<f64>> = xs.iter().map(|x| Vector2::new(x[0], x[1]) / scale).collect();
        let mut beta = Vector5::from(start).component_div(&unscale);
        let mut iterations = 0;
        let mut gradient_steps = 0;
        let mut converged = false;
        let mut cost = cost_only(&beta, &xs, ts);
        while iterations < options.max_iterations {
            iterations += 1;
            let (_, grad, hess) = cost_terms(&beta, &xs, ts);
            // Newton (Eq. 7.4) where the Hessian is positive definite, else steepest descent
            // with a first trial step of one unit (the start width).
            let step = match hess.cholesky() {
                Some(ch) => -ch.solve(&grad),
                None => {
                    gradient_steps += 1;
                    let norm = grad.norm();
                    if norm == 0.0 {
                        converged = true;
                        break;
                    }
                    -grad / norm
                }
            };
            let mut alpha = 1.0;
            let mut moved = false;
            for _ in 0..60 {
                let trial = beta + step * alpha;
                let c = cost_only(&trial, &xs, ts);
                if c.is_finite() && c <= cost && trial[2] != 0.0 && trial[3] != 0.0 {
                    // The stopping rule, in the caller's units.
                    let delta = (trial - beta).component_mul(&unscale).norm();
                    beta = trial;
                    cost = c;
                    moved = true;
                    converged = delta < options.epsilon;
                    break;
                }
                alpha *= 0.5;
            }
            // No step lowers the cost any more: a minimum within floating-point resolution.
            if !moved || converged {
                converged = true;
                break;
            }
        }
        let beta = beta.component_mul(&unscale);
        if !beta.iter().all(|v| v.is_finite()) {
            return None;
        }
        Some(GaussianFit {
            beta: [beta[0], beta[1], beta[2].abs(), beta[3].abs(), beta[4]],
            cost,
            iterations,
            gradient_steps,
            converged,
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

    use super::*;

    /// The gradient-only path gives the full model's value and gradient.
    #[test]
    fn value_and_gradient_match_the_model() {
        let beta = Vector5::new(0.3, -0.2, 1.4, 1.9, 0.8);
        for x in [[0.0, 0.0], [1.2, -0.7], [-2.0, 3.1]] {
            let (v, g, _) = model(&beta, Vector2::new(x[0], x[1]));
            let (v2, g2) = value_and_gradient(&beta, &x);
            assert!((v - v2).abs() < 1e-15 && (g - g2).norm() < 1e-14);
        }
    }

    /// The analytic gradient and Hessian agree with central differences of the cost.
    #[test]
    fn derivatives_match_finite_differences() {
        let xs: Vec<Vector2<f64>> = (0..30)
            .map(|k| Vector2::new((k % 6) as f64 - 2.3, (k / 6) as f64 - 1.7))
            .collect();
        let ts: Vec<f64> = xs
            .iter()
            .map(|x| 0.9 * (-(x.norm_squared()) / 3.0).exp() + 0.01)
            .collect();
        let beta = Vector5::new(0.3, -0.2, 1.4, 1.9, 0.8);
        let (_, grad, hess) = cost_terms(&beta, &xs, &ts);
        let h = 1e-5;
        for i in 0..5 {
            let mut up = beta;
            up[i] += h;
            let mut down = beta;
            down[i] -= h;
            let fd = (cost_only(&up, &xs, &ts) - cost_only(&down, &xs, &ts)) / (2.0 * h);
            assert!((fd - grad[i]).abs() < 1e-7, "gradient {i}: {fd} vs {}", grad[i]);
            let (_, g_up, _) = cost_terms(&up, &xs, &ts);
            let (_, g_down, _) = cost_terms(&down, &xs, &ts);
            for j in 0..5 {
                let fd = (g_up[j] - g_down[j]) / (2.0 * h);
                assert!(
                    (fd - hess[(i, j)]).abs() < 1e-6,
                    "hessian {i},{j}: {fd} vs {}",
                    hess[(i, j)]
                );
            }
        }
    }
}
