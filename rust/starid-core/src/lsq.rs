//! A small Levenberg–Marquardt solver for the pointing problems (a handful of parameters).
//!
//! The problem supplies residuals and their Jacobian at a state and how a parameter step moves
//! the state (states live on manifolds: unit vectors, rotations). Steps solve
//! `(JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr` (Marquardt's scaling, so parameters of any unit are treated
//! alike); λ shrinks after a successful step and grows after a failed one, so the iteration is
//! Gauss–Newton near the solution and gradient descent far from it.

use nalgebra::{DMatrix, DVector};

/// A nonlinear least-squares problem over states of type `S`.
pub trait Problem {
    /// The state: parameters plus whatever the residuals need.
    type State: Clone;

    /// Residuals and Jacobian (`rows × params`) at `state`; `None` where the model is undefined
    /// (a star behind the camera), which the solver treats as a failed step.
    fn evaluate(&self, state: &Self::State) -> Option<(DVector<f64>, DMatrix<f64>)>;

    /// The state moved by the parameter step `delta`.
    fn step(&self, state: &Self::State, delta: &DVector<f64>) -> Self::State;
}

/// Outcome of [`solve`].
#[derive(Debug, Clone)]
pub struct Solution<S> {
    /// Final state.
    pub state: S,
    /// Residuals at the final state.
    pub residuals: DVector<f64>,
    /// Jacobian at the final state.
    pub jacobian: DMatrix<f64>,
    /// Iterations taken (evaluations of a trial step).
    pub iterations: usize,
    /// Whether the step or the cost stopped changing (rather than the iteration limit).
    pub converged: bool,
}

impl<S> Solution<S> {
    /// Sum of squared residuals.
    pub fn cost(&self) -> f64 {
        self.residuals.norm_squared()
    }
}

/// Minimise the sum of squared residuals of `problem` from `start`; `None` when the model is
/// undefined at the start.
pub fn solve<P: Problem>(
    problem: &P,
    start: P::State,
    max_iterations: usize,
) -> Option<Solution<P::State>> {
    let (mut r, mut j) = problem.evaluate(&start)?;
    let mut state = start;
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut converged = false;
    let mut iterations = 0;
    while iterations < max_iterations {
        if cost == 0.0 {
            converged = true;
            break;
        }
        iterations += 1;
        let jtj = j.transpose() * &j;
        let g = j.transpose() * &r;
        let n = jtj.nrows();
        let max_diag = (0..n).map(|k| jtj[(k, k)]).fold(0.0f64, f64::max);
        if max_diag <= 0.0 || !max_diag.is_finite() {
            break;
        }
        let mut a = jtj.clone();
        for k in 0..n {
            a[(k, k)] += lambda * jtj[(k, k)].max(1e-12 * max_diag);
        }
        let delta = match a.clone().cholesky() {
            Some(ch) => -ch.solve(&g),
            None => match a.svd(true, true).solve(&(-&g), 1e-15) {
                Ok(d) => d,
                Err(_) => break,
            },
        };
        if !delta.iter().all(|d| d.is_finite()) {
            break;
        }
        let trial = problem.step(&state, &delta);
        match problem.evaluate(&trial) {
            Some((r2, j2)) if r2.norm_squared() <= cost => {
                let new_cost = r2.norm_squared();
                let improvement = cost - new_cost;
                state = trial;
                r = r2;
                j = j2;
                cost = new_cost;
                lambda = (lambda / 5.0).max(1e-15);
                // Stop when the scaled step is at rounding level or the cost no longer moves.
                let scaled: f64 = (0..n)
                    .map(|k| delta[k] * delta[k] * jtj[(k, k)])
                    .sum::<f64>()
                    .sqrt();
                if scaled <= 1e-12 * (1.0 + cost.sqrt()) || improvement <= 1e-15 * cost {
                    converged = true;
                    break;
                }
            }
            _ => {
                lambda *= 8.0;
                if lambda > 1e16 {
                    // No step lowers the cost: a minimum to working precision.
                    converged = true;
                    break;
                }
            }
        }
    }
    Some(Solution {
        state,
        residuals: r,
        jacobian: j,
        iterations,
        converged,
    })
}

/// `(JᵀJ)⁻¹`, or `None` when `J` is rank-deficient (reciprocal condition of `J` below `1e-10`).
pub fn inverse_normal_matrix(j: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if reciprocal_condition(j) < 1e-10 {
        return None;
    }
    (j.transpose() * j).try_inverse()
}

/// Smallest over largest singular value of `J` after scaling its columns to unit norm
/// (0 when a parameter is not determined at all).
pub fn reciprocal_condition(j: &DMatrix<f64>) -> f64 {
    let norms: Vec<f64> = j.column_iter().map(|c| c.norm()).collect();
    reciprocal_condition_scaled(j, &norms)
}

/// Smallest over largest singular value of `J` with column `k` divided by `scales[k]`, the
/// size that column would have in a well-posed problem: a column much smaller than its scale
/// (a parameter the data barely touch) shows as a small value.
pub fn reciprocal_condition_scaled(j: &DMatrix<f64>, scales: &[f64]) -> f64 {
    if j.ncols() == 0 || j.nrows() < j.ncols() || scales.len() != j.ncols() {
        return 0.0;
    }
    let mut scaled = j.clone();
    for (mut col, &n) in scaled.column_iter_mut().zip(scales) {
        if n.is_nan() || n <= 0.0 || !n.is_finite() {
            return 0.0;
        }
        col /= n;
    }
    let s = scaled.singular_values();
    let max = s.iter().copied().fold(0.0f64, f64::max);
    let min = s.iter().copied().fold(f64::INFINITY, f64::min);
    if max > 0.0 {
        min / max
    } else {
        0.0
    }
}
