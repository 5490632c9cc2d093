//! Tactile image classification with an ONNX model run by tract (feature `onnx`; thesis Ch. 4.3):
//! "was that a human hand?" from one 8-bit grey tactile image.
//!
//! Any ONNX classifier whose input is one grey image batch, `[N, 1, H, W]` (N may be symbolic),
//! and whose output is `[N, classes]` loads. The model is planned once per batch size with a
//! concrete input shape, optimised by tract, and run through a reused state, so a call allocates
//! only its input tensor and its result. Pixels are scaled as the model was trained: the
//! MATLAB-exported HandsNet takes grey levels 0..255 as floats ([`InputScale::Bytes`]), models
//! trained on normalised images take 0..1 ([`InputScale::Unit`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use tract_linalg::multithread::{Executor, multithread_tract_scope};
use tract_onnx::prelude::*;
use tract_onnx::tract_hir::infer::Factoid;

/// How grey levels are handed to the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputScale {
    /// 0..255, as floats (the MATLAB-exported HandsNet).
    Bytes,
    /// 0..1.
    Unit,
}

/// What can go wrong with a model or its input.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The file is not a model tract can load (corrupt, not ONNX, unsupported operator).
    #[error("{path}: not a usable ONNX model: {why}")]
    Load {
        /// The file.
        path: PathBuf,
        /// tract's explanation.
        why: String,
    },
    /// The model's input or output is not what a tactile image classifier has.
    #[error("{path}: {why}")]
    Shape {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// An image of the wrong size.
    #[error("image {index}: {got} pixels, the model takes {height} x {width} = {want}")]
    Image {
        /// Index in the batch.
        index: usize,
        /// Pixels given.
        got: usize,
        /// Pixels expected.
        want: usize,
        /// Model input height.
        height: usize,
        /// Model input width.
        width: usize,
    },
    /// tract failed while running.
    #[error("running the model: {0}")]
    Run(String),
}

/// A loaded classifier.
#[derive(Debug)]
pub struct Classifier {
    path: PathBuf,
    model: InferenceModel,
    height: usize,
    width: usize,
    scale: InputScale,
    /// A plan and a reused state per batch size.
    plans: HashMap<usize, TypedSimpleState>,
    classes: Option<usize>,
    executor: Executor,
}

impl Classifier {
    /// Loads `path` and plans it for one image at a time. The input must be `[N, 1, H, W]` with
    /// H and W fixed; anything else is refused with the shape the file declares.
    pub fn load(path: &Path, scale: InputScale) -> Result<Classifier, ModelError> {
        let load = |why: String| ModelError::Load {
            path: path.into(),
            why,
        };
        let model = tract_onnx::onnx()
            .model_for_path(path)
            .map_err(|e| load(format!("{e:#}")))?;
        let shape_err = |why: String| ModelError::Shape {
            path: path.into(),
            why,
        };
        if model.inputs.len() != 1 {
            return Err(shape_err(format!(
                "{} inputs; a tactile image classifier has one ([N, 1, H, W])",
                model.inputs.len()
            )));
        }
        let fact = model.input_fact(0).map_err(|e| load(format!("{e:#}")))?.clone();
        // Each declared dimension, None where it is symbolic or unknown.
        let dims: Vec<Option<usize>> = fact
            .shape
            .dims()
            .map(|d| {
                d.concretize()
                    .and_then(|t| t.to_i64().ok())
                    .and_then(|v| usize::try_from(v).ok())
            })
            .collect();
        let declared = format!("{:?}", fact.shape);
        let (height, width) = match (fact.shape.is_open(), dims.as_slice()) {
            (false, [_, Some(1), Some(h), Some(w)]) => (*h, *w),
            _ => {
                return Err(shape_err(format!(
                    "input {declared}: expected [N, 1, H, W], one grey channel with fixed H and W"
                )));
            }
        };
        let mut classifier = Classifier {
            path: path.into(),
            model,
            height,
            width,
            scale,
            plans: HashMap::new(),
            classes: None,
            executor: Executor::SingleThread,
        };
        classifier.plan(1)?;
        Ok(classifier)
    }

    /// Runs the model's matrix products on `threads` threads (1: on the caller's thread, the
    /// default). Worth it for large batches; a single 68 x 100 image gains little.
    pub fn with_threads(mut self, threads: usize) -> Result<Classifier, ModelError> {
        self.executor = if threads <= 1 {
            Executor::SingleThread
        } else {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .thread_name(|k| format!("skin-classify-{k}"))
                .build()
                .map_err(|e| ModelError::Run(format!("cannot start {threads} threads: {e}")))?;
            Executor::MultiThread(std::sync::Arc::new(pool))
        };
        Ok(self)
    }

    /// Input height and width, pixels.
    pub fn input_size(&self) -> (usize, usize) {
        (self.height, self.width)
    }

    /// Number of classes (the output's width).
    pub fn classes(&self) -> usize {
        self.classes.unwrap_or(0)
    }

    fn plan(&mut self, batch: usize) -> Result<&mut TypedSimpleState, ModelError> {
        if !self.plans.contains_key(&batch) {
            let shape_err = |why: String| ModelError::Shape {
                path: self.path.clone(),
                why,
            };
            let typed = self
                .model
                .clone()
                .with_input_fact(0, f32::fact([batch, 1, self.height, self.width]).into())
                .and_then(|m| m.into_optimized())
                .map_err(|e| shape_err(format!("planning for batch {batch}: {e:#}")))?;
            let out = typed
                .output_fact(0)
                .map_err(|e| shape_err(format!("{e:#}")))?
                .shape
                .as_concrete()
                .map(|s| s.to_vec());
            let classes = match out.as_deref() {
                Some([n, c]) if *n == batch => *c,
                Some([n, c, 1, 1]) if *n == batch => *c,
                other => {
                    return Err(shape_err(format!(
                        "output {other:?}: expected [N, classes] class scores"
                    )));
                }
            };
            self.classes = Some(classes);
            let plan = typed.into_runnable().map_err(|e| shape_err(format!("{e:#}")))?;
            let state = TypedSimpleState::new(&plan).map_err(|e| shape_err(format!("{e:#}")))?;
            self.plans.insert(batch, state);
        }
        self.plans
            .get_mut(&batch)
            .ok_or_else(|| ModelError::Run("plan cache".into()))
    }

    /// Class probabilities of one image (row-major grey levels, H x W).
    pub fn classify(&mut self, image: &[u8]) -> Result<Vec<f32>, ModelError> {
        Ok(self.classify_batch(&[image])?.remove(0))
    }

    /// Class probabilities of each image, run as one batch.
    pub fn classify_batch(&mut self, images: &[&[u8]]) -> Result<Vec<Vec<f32>>, ModelError> {
        let (h, w) = (self.height, self.width);
        for (index, im) in images.iter().enumerate() {
            if im.len() != h * w {
                return Err(ModelError::Image {
                    index,
                    got: im.len(),
                    want: h * w,
                    height: h,
                    width: w,
                });
            }
        }
        if images.is_empty() {
            return Ok(Vec::new());
        }
        let k = match self.scale {
            InputScale::Bytes => 1.0,
            InputScale::Unit => 1.0 / 255.0,
        };
        let n = images.len();
        let input: Tensor = tract_ndarray::Array4::from_shape_fn((n, 1, h, w), |(b, _, r, c)| {
            f32::from(images[b][r * w + c]) * k
        })
        .into();
        let executor = self.executor.clone();
        let state = self.plan(n)?;
        let out = multithread_tract_scope(executor, || state.run(tvec!(input.into())))
            .map_err(|e| ModelError::Run(format!("{e:#}")))?;
        let scores = out[0]
            .to_plain_array_view::<f32>()
            .map_err(|e| ModelError::Run(format!("{e:#}")))?;
        let classes = scores.len() / n;
        let flat = scores
            .as_slice()
            .ok_or_else(|| ModelError::Run("the output is not contiguous".into()))?;
        Ok(flat.chunks(classes).map(probabilities).collect())
    }
}

/// The model's scores as probabilities: kept if they already are (a softmax layer at the end,
/// as in HandsNet), otherwise passed through a softmax.
fn probabilities(scores: &[f32]) -> Vec<f32> {
    let sum: f32 = scores.iter().sum();
    if scores.iter().all(|s| (0.0..=1.0).contains(s)) && (sum - 1.0).abs() < 1e-3 {
        return scores.to_vec();
    }
    let top = scores.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f32> = scores.iter().map(|s| (s - top).exp()).collect();
    let total: f32 = e.iter().sum();
    e.iter().map(|v| v / total).collect()
}
