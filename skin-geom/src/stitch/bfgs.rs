//! The per-joint solve of Eq. 6.6: argmin's BFGS from the warm start, anytime.

use super::cost::Eq66;
use super::{Deadline, JointSolve, Stitcher};
use crate::{Error, Result};
use argmin::core::{Executor, State, TerminationReason, TerminationStatus};
use argmin::solver::linesearch::BacktrackingLineSearch;
use argmin::solver::linesearch::condition::ArmijoCondition;
use argmin::solver::quasinewton::BFGS;
use nalgebra::Isometry3;

impl Stitcher {
    pub(super) fn solve_joint(
        &mut self,
        j: usize,
        to_parent: &Isometry3<f64>,
        deadline: Deadline,
    ) -> Result<JointSolve> {
        let edges = self.edges(j, to_parent)?;
        let joint = &self.joints[j];
        let last = joint.placement;
        let kept = |edges: usize, cost: f64| JointSolve {
            placement: last,
            cost,
            start_cost: cost,
            iterations: 0,
            converged: false,
            edges,
            kept_last: true,
        };
        if edges.is_empty() {
            return Ok(kept(0, f64::NAN));
        }
        let problem = Eq66::new(&self.maps[j], &self.maps[j + 1], joint, &edges);
        let start = problem.param_of(&last);
        let start_cost = problem.cost_m2(&start);
        let budget_is_zero = match deadline {
            Deadline::Iterations(n) => n == 0,
            Deadline::Time(t) => t.is_zero(),
        };
        if budget_is_zero {
            return Ok(JointSolve {
                kept_last: false,
                ..kept(edges.len(), start_cost)
            });
        }
        // Already at a minimum: nothing to do (a line search from a stationary point cannot make
        // progress and is not asked to).
        let g0 = problem.gradient_mm(&start);
        if g0.iter().map(|g| g * g).sum::<f64>().sqrt() < self.options.tolerance {
            return Ok(JointSolve {
                converged: true,
                kept_last: false,
                ..kept(edges.len(), start_cost)
            });
        }
        let (iterations, converged) = run_bfgs(&problem, &start, deadline, self.options.tolerance)?;
        let best = problem.best.borrow().1.clone();
        let best = if best.len() == start.len() {
            best
        } else {
            start.clone()
        };
        let cost = problem.cost_m2(&best);
        let (best, cost) = if cost <= start_cost {
            (best, cost)
        } else {
            (start, start_cost)
        };
        let placement = problem.placement_of(&best);
        self.joints[j].placement = placement;
        Ok(JointSolve {
            placement,
            cost,
            start_cost,
            iterations,
            converged,
            edges: edges.len(),
            kept_last: false,
        })
    }
}

/// Runs BFGS on `problem` from `start` within `deadline`: (iterations, converged). The best point
/// evaluated is left in `problem.best`, whatever stopped the solver.
fn run_bfgs(problem: &Eq66, start: &[f64], deadline: Deadline, tolerance: f64) -> Result<(u64, bool)> {
    let start = start.to_vec();
    let inv_hessian = problem.gauss_newton_inverse(&start);
    // Backtracking (Armijo) rather than More-Thuente: it always ends, which a control loop
    // needs; the Gauss-Newton scaling makes the first trial step usually the right one.
    let condition = ArmijoCondition::new(1e-4).map_err(|e| Error::Solve(format!("solver set-up: {e}")))?;
    let solver = BFGS::new(BacktrackingLineSearch::new(condition))
        .with_tolerance_grad(tolerance)
        .map_err(|e| Error::Solve(format!("solver set-up: {e}")))?
        .with_tolerance_cost(0.0)
        .map_err(|e| Error::Solve(format!("solver set-up: {e}")))?;
    let (max_iters, timeout) = match deadline {
        Deadline::Iterations(n) => (n, None),
        Deadline::Time(t) => (1_000, Some(t)),
    };
    *problem.best.borrow_mut() = (problem.cost_mm2(&start), start.clone());
    let mut executor = Executor::new(problem.clone(), solver).configure(|state| {
        state
            .param(start.clone())
            .inv_hessian(inv_hessian)
            .max_iters(max_iters)
    });
    if let Some(t) = timeout {
        executor = executor.timeout(t);
    }
    let (iterations, converged) = match executor.run() {
        Ok(result) => {
            let state = result.state();
            let converged = matches!(
                state.get_termination_status(),
                TerminationStatus::Terminated(TerminationReason::SolverConverged)
            );
            (state.get_iter(), converged)
        }
        // A degenerate step stopped the solver: the best point it evaluated is kept, and
        // reported as not converged.
        Err(_) => (0, false),
    };
    Ok((iterations, converged))
}
