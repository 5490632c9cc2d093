//! The task-priority solver (thesis App. D) against an independent reference, and the continuity
//! that makes activations usable.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_control::{Regularisation, StackError, Task, TaskStack};

const EXACT: Regularisation = Regularisation::Exact { tolerance: TOL };
/// Rank decisions: singular values under this are zero, in the solver and in the reference alike.
const TOL: f64 = 1e-6;

/// The reference's linear algebra: the eigen-decomposition of A^T A (n x n, whatever the shape
/// of A; the solver works with the smaller Gram matrix instead). nalgebra's SVD gave wrong
/// factors for some matrices with exactly zero singular values, so neither side relies on it.
fn gram(a: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let eig = (a.transpose() * a).symmetric_eigen();
    (eig.eigenvalues, eig.eigenvectors)
}

/// A^+ = sum over non-zero eigenpairs of A^T A of v v^T A^T / lambda.
fn svd_pinv(a: &DMatrix<f64>) -> DMatrix<f64> {
    let (vals, vecs) = gram(a);
    let mut out = DMatrix::zeros(a.ncols(), a.nrows());
    for i in 0..vals.len() {
        if vals[i] >= TOL * TOL {
            let v = vecs.column(i);
            out += v * (v.transpose() * a.transpose()) / vals[i];
        }
    }
    out
}

/// Orthonormal basis of the null space of `a` (columns): eigenvectors of A^T A with eigenvalue
/// under TOL^2.
fn null_basis(a: &DMatrix<f64>, n: usize) -> DMatrix<f64> {
    if a.nrows() == 0 {
        return DMatrix::identity(n, n);
    }
    let (vals, vecs) = gram(a);
    let cols: Vec<_> = (0..n)
        .filter(|&i| vals[i] < TOL * TOL)
        .map(|i| vecs.column(i).into_owned())
        .collect();
    if cols.is_empty() {
        DMatrix::zeros(n, 0)
    } else {
        DMatrix::from_columns(&cols)
    }
}

/// Nested least squares, level by level: q stays optimal for every higher level, moves only in
/// the null space left by them (explicit basis N), minimum norm at each level. Also returns the
/// smallest non-zero singular value met: exact solutions of near-singular levels are not
/// comparable (any method's rounding is amplified by its inverse).
fn reference(tasks: &[Task], n: usize) -> (DVector<f64>, f64) {
    let mut q = DVector::zeros(n);
    let mut basis = DMatrix::identity(n, n);
    let mut smallest = f64::INFINITY;
    for t in tasks {
        if basis.ncols() == 0 {
            break;
        }
        let jn = &t.jacobian * &basis;
        for &l in gram(&jn).0.iter() {
            if l >= TOL * TOL {
                smallest = smallest.min(l.sqrt());
            }
        }
        let z = svd_pinv(&jn) * (&t.reference - &t.jacobian * &q);
        q += &basis * z;
        let inner = null_basis(&jn, basis.ncols());
        basis = &basis * inner;
    }
    (q, smallest)
}

fn random_tasks(rng: &mut ChaCha8Rng, n: usize, count: usize) -> Vec<Task> {
    (0..count)
        .map(|k| {
            let m = rng.random_range(1..=6);
            let mut j = DMatrix::from_fn(m, n, |_, _| rng.random_range(-1.0..1.0));
            // Some tasks rank-deficient (a repeated row), some conflicting (a row of a higher task
            // with another reference).
            if m >= 2 && k % 3 == 1 {
                let row = j.row(0).into_owned();
                j.set_row(m - 1, &row);
            }
            Task {
                jacobian: j,
                reference: DVector::from_fn(m, |_, _| rng.random_range(-1.0..1.0)),
                activation: 1.0,
            }
        })
        .collect()
}

#[test]
fn exact_mode_matches_nested_least_squares_on_random_stacks() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut compared = 0;
    for trial in 0..200 {
        let n = rng.random_range(3..=9);
        let count = rng.random_range(1..=6);
        let mut tasks = random_tasks(&mut rng, n, count);
        if trial % 4 == 0 && tasks.len() >= 2 {
            // Conflict: task 1 asks for the opposite of task 0 along the same row.
            let row = tasks[0].jacobian.row(0).into_owned();
            tasks[1].jacobian.set_row(0, &row);
            tasks[1].reference[0] = -tasks[0].reference[0] - 1.0;
        }
        let (want, smallest) = reference(&tasks, n);
        if smallest < 1e-3 {
            continue;
        }
        compared += 1;
        let ours = TaskStack::new(n, EXACT).solve(&tasks).unwrap();
        assert!(
            (&ours - &want).norm() < 1e-7 * (1.0 + want.norm()),
            "trial {trial}: differ by {} (n {n}, {} tasks, smallest singular value {smallest})",
            (&ours - &want).norm(),
            tasks.len()
        );
    }
    assert!(compared >= 150, "only {compared} well-conditioned stacks");
}

#[test]
fn the_pseudo_inverse_meets_the_moore_penrose_conditions() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for _ in 0..300 {
        let (m, n, r) = (
            rng.random_range(1..8),
            rng.random_range(1..8),
            rng.random_range(1..4),
        );
        // Rank r (or less) by construction, zero singular values exactly.
        let x = DMatrix::from_fn(m, r, |_, _| rng.random_range(-1.0..1.0))
            * DMatrix::from_fn(r, n, |_, _| rng.random_range(-1.0..1.0));
        let p = skin_control::pseudo_inverse(&x, TOL);
        assert!((&x * &p * &x - &x).norm() < 1e-8, "X X+ X != X");
        assert!(
            (&p * &x * &p - &p).norm() < 1e-6 * (1.0 + p.norm().powi(2)),
            "X+ X X+ != X+"
        );
        assert!((&x * &p - (&x * &p).transpose()).norm() < 1e-8);
        assert!((&p * &x - (&p * &x).transpose()).norm() < 1e-8);
    }
}

#[test]
fn a_lower_task_never_disturbs_a_higher_one() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..100 {
        let tasks = random_tasks(&mut rng, 7, 4);
        let alone = TaskStack::new(7, EXACT).solve(&tasks[..1]).unwrap();
        let all = TaskStack::new(7, EXACT).solve(&tasks).unwrap();
        let j = &tasks[0].jacobian;
        assert!((j * &alone - j * &all).norm() < 1e-8);
    }
}

#[test]
fn activation_aware_is_exact_for_a_well_conditioned_active_task() {
    let j = DMatrix::from_row_slice(
        3,
        7,
        &[
            1.0, 0.2, 0.0, 0.3, 0.0, 0.1, 0.0, //
            0.0, 1.0, 0.4, 0.0, 0.2, 0.0, 0.1, //
            0.1, 0.0, 1.0, 0.0, 0.0, 0.5, 0.2,
        ],
    );
    let task = Task {
        jacobian: j.clone(),
        reference: DVector::from_vec(vec![0.3, -0.2, 0.1]),
        activation: 1.0,
    };
    let exact = TaskStack::new(7, EXACT)
        .solve(std::slice::from_ref(&task))
        .unwrap();
    let aware = TaskStack::new(7, Regularisation::default())
        .solve(std::slice::from_ref(&task))
        .unwrap();
    let damped = TaskStack::new(7, Regularisation::Damped { lambda: 0.05 })
        .solve(&[task])
        .unwrap();
    assert!(
        (&aware - &exact).norm() < 1e-9,
        "the activation-aware inverse damps nothing here"
    );
    assert!(
        (&damped - &exact).norm() > 1e-4,
        "damped least squares damps every direction"
    );
}

/// A contact task on top of a reaching task; the contact force ramps from 0 through the threshold
/// and beyond, activation (F / F_thresh)^4 saturating at 1 (Eq. 8.13-8.17).
fn ramp(reg: Regularisation) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let tasks = random_tasks(&mut rng, 7, 2);
    let mut stack = TaskStack::new(7, reg);
    let f_thresh = 15.0;
    let mut last: Option<DVector<f64>> = None;
    let mut worst: f64 = 0.0;
    for step in 0..=3000 {
        let f = 20.0 * f64::from(step) / 3000.0;
        let a = (f / f_thresh).powi(4).min(1.0);
        let stack_now = [
            Task {
                activation: a,
                ..tasks[0].clone()
            },
            tasks[1].clone(),
        ];
        let q = stack.solve(&stack_now).unwrap();
        if let Some(prev) = &last {
            worst = worst.max((&q - prev).norm());
        }
        last = Some(q);
    }
    worst
}

#[test]
fn joint_velocities_change_continuously_as_a_contact_task_activates() {
    // 3,000 steps over the ramp: a continuous solution moves by a small amount per step.
    let damped = ramp(Regularisation::Damped { lambda: 0.05 });
    let aware = ramp(Regularisation::default());
    let exact = ramp(EXACT);
    assert!(damped < 0.02, "damped: largest step change {damped}");
    assert!(aware < 0.02, "activation-aware: largest step change {aware}");
    // The plain pseudo-inverse switches the task on at once: the jump the regularisation removes.
    assert!(exact > 10.0 * aware.max(damped), "exact: {exact}");
}

#[test]
fn bad_stacks_are_errors_and_nan_gives_zero_velocity() {
    let mut stack = TaskStack::new(7, Regularisation::default());
    assert_eq!(stack.solve(&[]), Err(StackError::Empty));
    let wrong = Task {
        jacobian: DMatrix::zeros(6, 6),
        reference: DVector::zeros(6),
        activation: 1.0,
    };
    assert!(matches!(
        stack.solve(&[wrong]),
        Err(StackError::Size { task: 0, .. })
    ));
    let mismatched = Task {
        jacobian: DMatrix::zeros(6, 7),
        reference: DVector::zeros(5),
        activation: 1.0,
    };
    assert!(matches!(
        stack.solve(&[mismatched]),
        Err(StackError::Size { task: 0, .. })
    ));
    let nan = Task {
        jacobian: DMatrix::from_element(3, 7, 0.5),
        reference: DVector::from_element(3, f64::NAN),
        activation: 1.0,
    };
    assert_eq!(stack.solve(&[nan]).unwrap(), DVector::zeros(7));
}

proptest! {
    #[test]
    fn arbitrary_stacks_never_panic_and_give_finite_velocities(
        seed in any::<u64>(),
        n in 1usize..10,
        count in 1usize..8,
        activation in -1.0f64..2.0,
        scale in prop::sample::select(vec![0.0, 1e-12, 1.0, 1e6]),
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut tasks = random_tasks(&mut rng, n, count);
        for t in &mut tasks {
            t.jacobian *= scale;
            t.activation = activation;
        }
        for reg in [Regularisation::default(), Regularisation::Damped { lambda: 0.05 }, EXACT] {
            let q = TaskStack::new(n, reg).solve(&tasks).unwrap();
            prop_assert!(q.iter().all(|v| v.is_finite()));
        }
    }
}

/// The damped recursion written plainly with matrices (App. D with H = a J and damped least
/// squares), to check the solver's buffer-based path.
fn damped_reference(tasks: &[Task], n: usize, lambda: f64) -> DVector<f64> {
    let mut p = DMatrix::<f64>::identity(n, n);
    let mut r = DVector::<f64>::zeros(n);
    for t in tasks {
        let a = t.activation.clamp(0.0, 1.0);
        if a == 0.0 {
            continue;
        }
        let h = &t.jacobian * a;
        let x = &h * &p;
        let m = x.nrows();
        let g = &x * x.transpose() + DMatrix::identity(m, m) * (lambda * lambda);
        let pinv = x.transpose() * g.try_inverse().unwrap();
        // G_i r + P (H P)^# a rho
        r = &r - &p * (&pinv * (&h * &r)) + &p * (&pinv * (&t.reference * a));
        p = &p - &p * (&pinv * &x);
        p = (&p + p.transpose()) * 0.5;
    }
    r
}

#[test]
fn the_damped_path_is_the_damped_recursion() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for _ in 0..200 {
        let n = rng.random_range(2..=9);
        let count = rng.random_range(1..=6);
        let mut tasks = random_tasks(&mut rng, n, count);
        for t in &mut tasks {
            t.activation = rng.random_range(0.0..1.2);
        }
        let ours = TaskStack::new(n, Regularisation::Damped { lambda: 0.07 })
            .solve(&tasks)
            .unwrap();
        let want = damped_reference(&tasks, n, 0.07);
        assert!(
            (&ours - &want).norm() < 1e-9 * (1.0 + want.norm()),
            "{ours} vs {want}"
        );
    }
}
