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
        let mut aware = TaskStack::new(7, Regularisation::default());
        let q_aware = aware.solve(&stack_tasks).unwrap();
        let Regularisation::ActivationAware {
            lambda: aware_lambda,
            threshold,
            eta,
        } = Regularisation::default()
        else {
            unreachable!("the default regularisation is the activation-aware one")
        };
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
            "], \"lambda\": 0.05, \"qdot\": [{}], \"aware\": {{\"lambda\": {aware_lambda:e}, \"threshold\": {threshold:e}, \"eta\": {eta:e}, \"qdot\": [{}]}}}}",
            q.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(","),
            q_aware
                .iter()
                .map(|v| format!("{v:e}"))
                .collect::<Vec<_>>()
                .join(",")
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

/// One whole control cycle of the 7-DOF fixture arm: forward kinematics, contact tasks on three
/// links (two grouped contacts each), the reaching task, joint-limit tasks, the solve.
fn control_cycle(c: &mut Criterion) {
    use nalgebra::{Point3, Unit, Vector3};
    use skin_control::contact_tasks::{Contact, Gains};
    use skin_control::{Chain, LinkContacts, ReachGoal, SkinController};
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf");
    let chain = Chain::from_urdf(&urdf, "base", "tool").unwrap();
    let q = [0.2, 0.6, -0.1, 1.2, 0.1, 0.5, 0.0];
    let mut contacts = Vec::new();
    for (k, link) in ["link3", "link5", "tool"].iter().enumerate() {
        let pose = chain.link_pose(link, &q).unwrap();
        let contact = |y: f64, force: f64| Contact {
            point: pose * Point3::new(0.0, 0.04, y),
            normal: Unit::new_normalize(pose.rotation * Vector3::y()),
            force,
            stiffness: 1000.0,
        };
        contacts.push(LinkContacts {
            link: link.to_string(),
            contacts: vec![contact(0.03, 4.0 + k as f64), contact(0.09, 2.0)],
        });
    }
    let goal = ReachGoal {
        goal: Point3::new(0.45, 0.1, 0.35),
        hand: Point3::origin(),
        tool_axis: Vector3::z_axis(),
    };
    let mut group = c.benchmark_group("control_cycle");
    for (name, reg) in [
        ("damped", Regularisation::Damped { lambda: 0.05 }),
        ("activation-aware", Regularisation::default()),
    ] {
        let mut ctl = SkinController::new(chain.clone(), "tool", reg, Gains::default(), 15.0).unwrap();
        group.bench_function(format!("3 touched links + reach, {name}"), |b| {
            b.iter(|| {
                black_box(
                    ctl.step(black_box(&q), black_box(&contacts), Some(&goal))
                        .unwrap(),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench, control_cycle);
criterion_main!(benches);
