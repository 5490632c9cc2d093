//! Where tract spends a batch-1 run of the project's models: the optimised plan node by node,
//! the time of each (mean over 100 runs after 20 warm-up runs), largest first. Not a criterion
//! bench: it prints a profile, the "what limits tract" part of BENCHMARKS.md.
//!
//! ```text
//! cargo bench -p skin-learn --features onnx --bench model_profile [-- MODEL.onnx ...]
//! (relative paths from the workspace root)
//! ```
//!
//! A model whose input shape is fixed runs at that shape (the single layers of
//! `bench/conv_layers.py`). `BATCH=32` profiles a batch; `PLAIN_TRACT=1` leaves tract's own convolutions and max-pools in the plan;
//! `FULL=1` prints each node's whole description (the matrix kernel it picked).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)] // a profiling tool

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tract_onnx::prelude::*;
use tract_onnx::tract_hir::infer::Factoid;

const WARM_UP: usize = 20;
const RUNS: usize = 100;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let args: Vec<PathBuf> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        // cargo runs a bench in its crate's folder: a relative path is the workspace root's.
        .map(|a| root.join(a))
        .collect();
    let models = if args.is_empty() {
        vec![
            root.join("fixtures/models/handsnet.onnx"),
            root.join("fixtures/models/handseg.onnx"),
        ]
    } else {
        args
    };
    for path in models {
        profile(&path);
    }
}

fn profile(path: &Path) {
    let batch: usize = std::env::var("BATCH")
        .ok()
        .and_then(|b| b.parse().ok())
        .unwrap_or(1);
    let (plan, input) = plan_and_input(path, batch);
    let mut state = TypedSimpleState::new(&plan).unwrap();
    for _ in 0..WARM_UP {
        state.run(tvec!(input.clone().into())).unwrap();
    }
    let mut per_node: HashMap<usize, Duration> = HashMap::new();
    let whole = Instant::now();
    for _ in 0..RUNS {
        state
            .run_plan_with_eval(tvec!(input.clone().into()), |ctx, op_state, node, inputs| {
                let t = Instant::now();
                let out = tract_onnx::tract_core::plan::eval(ctx, op_state, node, inputs);
                *per_node.entry(node.id).or_default() += t.elapsed();
                out
            })
            .unwrap();
    }
    let whole = whole.elapsed().as_secs_f64() * 1e3 / RUNS as f64;
    let model = plan.model();
    let mut rows: Vec<(usize, f64)> = per_node
        .iter()
        .map(|(&id, d)| (id, d.as_secs_f64() * 1e3 / RUNS as f64))
        .collect();
    rows.sort_by(|a, b| b.1.total_cmp(&a.1));
    let total: f64 = rows.iter().map(|r| r.1).sum();
    println!(
        "\n{}: {} nodes, {whole:.3} ms a run ({total:.3} ms in the nodes)",
        path.display(),
        model.nodes.len()
    );
    for (id, ms) in rows {
        let node = &model.nodes[id];
        let shape = format!("{:?}", node.outputs[0].fact.shape);
        let op = format!("{:?}", node.op);
        let op: String = if std::env::var("FULL").is_ok() {
            op
        } else {
            op.chars().take(150).collect()
        };
        println!(
            "{ms:8.3} ms {:5.1}%  #{id:<3} {:<28} [{shape}] {op}",
            100.0 * ms / total,
            node.name.chars().take(28).collect::<String>()
        );
    }
}

/// The model's optimised plan (as skin-learn plans it, unless PLAIN_TRACT is set) and an input
/// for it.
fn plan_and_input(path: &Path, batch: usize) -> (std::sync::Arc<TypedRunnableModel>, Tensor) {
    let model = tract_onnx::onnx().model_for_path(path).unwrap();
    // A model whose input shape is fixed (a single layer of bench/conv_layers.py) runs at it;
    // a tactile image model at [batch, 1, 68, 100].
    let fixed: Option<Vec<usize>> = model.input_fact(0).ok().and_then(|f| {
        f.shape
            .dims()
            .map(|d| {
                d.concretize()
                    .and_then(|t| t.to_i64().ok())
                    .and_then(|v| usize::try_from(v).ok())
            })
            .collect::<Option<Vec<usize>>>()
            .filter(|_| !f.shape.is_open())
    });
    let shape = fixed.unwrap_or_else(|| vec![batch, 1, 68, 100]);
    let plan = model
        .with_input_fact(0, f32::fact(&shape).into())
        .and_then(|m| m.into_typed())
        .and_then(|m| {
            // As skin-learn plans it, unless PLAIN_TRACT is set.
            if std::env::var("PLAIN_TRACT").is_err() {
                skin_learn::tract_plan::optimise(m)
            } else {
                m.into_optimized()
            }
        })
        .and_then(|m| m.into_runnable())
        .unwrap();
    let input: Tensor = if shape[..] == [batch, 1, 68, 100] {
        tract_ndarray::Array4::from_shape_fn((batch, 1, 68, 100), |(_, _, r, c)| {
            if (r as f32 - 34.0).hypot(c as f32 - 50.0) < 18.0 {
                0.8f32
            } else {
                0.0
            }
        })
        .into()
    } else {
        let n: usize = shape.iter().product();
        Tensor::from_shape(
            &shape,
            &(0..n).map(|i| (i % 101) as f32 / 101.0).collect::<Vec<_>>(),
        )
        .unwrap()
    };
    (plan, input)
}
