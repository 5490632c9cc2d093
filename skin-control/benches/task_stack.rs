//! One TaskStack solve for a 7-joint arm with 2, 5 and 8 six-row tasks (activations between 0.3
//! and 1), in each regularisation mode. Writes the problems to target/bench-data for
//! bench/task_stack_numpy.py, which runs the same recursion with numpy in the same run.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_control::{Regularisation, Task, TaskStack};
use std::fmt::Write as _;
use std::hint::black_box;
use std::path::Path;

fn tasks(count: usize) -> Vec<Task> {
    let mut rng = ChaCha8Rng::seed_from_u64(count as u64);
    (0..count)
        .map(|_| Task {
            jacobian: DMatrix::from_fn(6, 7, |_, _| rng.random_range(-1.0..1.0)),
            reference: DVector::from_fn(6, |_, _| rng.random_range(-0.1..0.1)),
            activation: rng.random_range(0.3..1.0),
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/bench-data");
    std::fs::create_dir_all(&out).unwrap();
    let mut group = c.benchmark_group("task_stack");
    for count in [2usize, 5, 8] {
        let stack_tasks = tasks(count);
        // The problem and the damped solution, for the numpy reference to check and time.
        let mut damped = TaskStack::new(7, Regularisation::Damped { lambda: 0.05 });
        let q = damped.solve(&stack_tasks).unwrap();
        let mut json = String::from("{\"tasks\": [");
        for (k, t) in stack_tasks.iter().enumerate() {
            let rows: Vec<String> = (0..6)
                .map(|r| {
                    format!(
                        "[{}]",
                        (0..7)
                            .map(|c| format!("{:e}", t.jacobian[(r, c)]))
                            .collect::<Vec<_>>()
                            .join(",")
                    )
                })
                .collect();
            let _ = write!(
                json,
                "{}{{\"J\": [{}], \"rho\": [{}], \"a\": {:e}}}",
                if k > 0 { "," } else { "" },
                rows.join(","),
                t.reference
                    .iter()
                    .map(|v| format!("{v:e}"))
                    .collect::<Vec<_>>()
                    .join(","),
                t.activation
            );
        }
        let _ = write!(
            json,
            "], \"lambda\": 0.05, \"qdot\": [{}]}}",
            q.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(",")
        );
        std::fs::write(out.join(format!("task_stack_{count}.json")), json).unwrap();
        for (name, reg) in [
            ("damped", Regularisation::Damped { lambda: 0.05 }),
            ("activation-aware", Regularisation::default()),
        ] {
            let mut stack = TaskStack::new(7, reg);
            group.bench_function(format!("{count} tasks, 7 joints, {name}"), |b| {
                b.iter(|| black_box(stack.solve(black_box(&stack_tasks)).unwrap()))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
