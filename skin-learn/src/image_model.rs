//! The ONNX side shared by [`crate::classify::Classifier`] and [`crate::segment::Segmenter`]
//! (feature `onnx`): load a model of grey tactile images with tract, check its declared input,
//! plan it once per batch size with a concrete input shape, and run it through a reused state.
//!
//! Any model whose input is one grey image batch, `[N, 1, H, W]` (N may be symbolic), loads.
//! Pixels are scaled as the model was trained: the MATLAB-exported HandsNet takes grey levels
//! 0..255 as floats ([`InputScale::Bytes`]), models trained on normalised images 0..1
//! ([`InputScale::Unit`]); a model card beside the model says which ([`crate::card`]).

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

/// A planned ONNX model of grey images, with one plan and reused state per batch size.
#[derive(Debug)]
pub(crate) struct ImageModel {
    pub(crate) path: PathBuf,
    model: InferenceModel,
    pub(crate) height: usize,
    pub(crate) width: usize,
    scale: InputScale,
    /// Per batch size: the reused state and the output's concrete shape.
    plans: HashMap<usize, (TypedSimpleState, Vec<usize>)>,
    executor: Executor,
}

impl ImageModel {
    /// Loads `path` and checks that its input is `[N, 1, H, W]` with H and W fixed.
    pub(crate) fn load(path: &Path, scale: InputScale) -> Result<ImageModel, ModelError> {
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
                "{} inputs; a tactile image model has one ([N, 1, H, W])",
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
        Ok(ImageModel {
            path: path.into(),
            model,
            height,
            width,
            scale,
            plans: HashMap::new(),
            executor: Executor::SingleThread,
        })
    }

    /// Runs the matrix products on `threads` threads (1: on the caller's thread).
    pub(crate) fn set_threads(&mut self, threads: usize) -> Result<(), ModelError> {
        self.executor = if threads <= 1 {
            Executor::SingleThread
        } else {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .thread_name(|k| format!("skin-onnx-{k}"))
                .build()
                .map_err(|e| ModelError::Run(format!("cannot start {threads} threads: {e}")))?;
            Executor::MultiThread(std::sync::Arc::new(pool))
        };
        Ok(())
    }

    /// The output shape for a batch of `batch` images (planning the model for it if needed).
    pub(crate) fn output_shape(&mut self, batch: usize) -> Result<Vec<usize>, ModelError> {
        Ok(self.plan(batch)?.1.clone())
    }

    fn plan(&mut self, batch: usize) -> Result<&mut (TypedSimpleState, Vec<usize>), ModelError> {
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
                .and_then(|mut m| crate::max_pool::swap_max_pools(&mut m).map(|_| m))
                .map_err(|e| shape_err(format!("planning for batch {batch}: {e:#}")))?;
            let out = typed
                .output_fact(0)
                .map_err(|e| shape_err(format!("{e:#}")))?
                .shape
                .as_concrete()
                .map(|s| s.to_vec())
                .ok_or_else(|| shape_err("the output's shape is not fixed for a fixed input".into()))?;
            let plan = typed.into_runnable().map_err(|e| shape_err(format!("{e:#}")))?;
            let state = TypedSimpleState::new(&plan).map_err(|e| shape_err(format!("{e:#}")))?;
            self.plans.insert(batch, (state, out));
        }
        self.plans
            .get_mut(&batch)
            .ok_or_else(|| ModelError::Run("plan cache".into()))
    }

    /// Runs a batch of images (row-major grey levels, H x W each) and hands the flat output
    /// (in the shape given by [`Self::output_shape`]) to `read`.
    pub(crate) fn run<T>(
        &mut self,
        images: &[&[u8]],
        read: impl FnOnce(&[f32]) -> T,
    ) -> Result<T, ModelError> {
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
        let (state, _) = self.plan(n)?;
        let out = multithread_tract_scope(executor, || state.run(tvec!(input.into())))
            .map_err(|e| ModelError::Run(format!("{e:#}")))?;
        let view = out[0]
            .to_plain_array_view::<f32>()
            .map_err(|e| ModelError::Run(format!("{e:#}")))?;
        let flat = view
            .as_slice()
            .ok_or_else(|| ModelError::Run("the output is not contiguous".into()))?;
        Ok(read(flat))
    }
}
