//! The ONNX side shared by [`crate::classify::Classifier`] and [`crate::segment::Segmenter`]
//! (feature `onnx`): load a model of grey tactile images with tract, check its declared input,
//! plan it for one image with a concrete input shape, and run it through a reused state.
//!
//! Any model whose input is one grey image batch, `[N, 1, H, W]` (N may be symbolic), loads.
//! Pixels are scaled as the model was trained: the MATLAB-exported HandsNet takes grey levels
//! 0..255 as floats ([`InputScale::Bytes`]), models trained on normalised images 0..1
//! ([`InputScale::Unit`]); a model card beside the model says which ([`crate::card`]).

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

impl InputScale {
    /// The scale a model's card states ([`crate::card::ModelCard`]), `Bytes` without one.
    pub fn for_model(model: &std::path::Path) -> InputScale {
        match crate::card::ModelCard::for_model(model).and_then(|c| c.unit_scale) {
            Some(true) => InputScale::Unit,
            _ => InputScale::Bytes,
        }
    }
}

pub use crate::model::ModelError;

/// A planned ONNX model of grey images: one plan for one image, and its reused state.
#[derive(Debug)]
pub(crate) struct ImageModel {
    pub(crate) path: PathBuf,
    model: InferenceModel,
    pub(crate) height: usize,
    pub(crate) width: usize,
    scale: InputScale,
    /// The plan for one image, made on first use.
    plan: Option<Plan>,
    executor: Executor,
}

impl ImageModel {
    /// Loads `path` and checks that its input is `[N, 1, H, W]` with H and W fixed.
    pub(crate) fn load(path: &Path, scale: InputScale) -> Result<ImageModel, ModelError> {
        let load = |why: String| ModelError::Load {
            path: path.into(),
            why,
        };
        // Say what the path is before tract does ("No such device" for a folder).
        match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => return Err(load("a folder, not an ONNX model file".into())),
            Err(e) => return Err(load(format!("cannot read it: {e}"))),
            Ok(_) => {}
        }
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
            plan: None,
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
                .map_err(|e| ModelError::Run(format!("cannot start {threads} threads: {e}").into()))?;
            Executor::MultiThread(std::sync::Arc::new(pool))
        };
        Ok(())
    }

    /// The output shape for one image, `[1, ...]` (planning the model if needed).
    pub(crate) fn output_shape(&mut self) -> Result<Vec<usize>, ModelError> {
        Ok(self.plan()?.output_shape.clone())
    }

    /// The plan for one image, made on first use: a concrete `[1, 1, H, W]` input, tract's
    /// optimisations with the project's own operators ([`crate::tract_plan`]), and a state
    /// reused from run to run.
    fn plan(&mut self) -> Result<&mut Plan, ModelError> {
        if self.plan.is_none() {
            let shape_err = |why: String| ModelError::Shape {
                path: self.path.clone(),
                why,
            };
            let typed = self
                .model
                .clone()
                .with_input_fact(0, f32::fact([1, 1, self.height, self.width]).into())
                .and_then(|m| m.into_typed())
                .and_then(crate::tract_plan::optimise)
                .map_err(|e| shape_err(format!("planning for one image: {e:#}")))?;
            let output_shape = typed
                .output_fact(0)
                .map_err(|e| shape_err(format!("{e:#}")))?
                .shape
                .as_concrete()
                .map(|s| s.to_vec())
                .ok_or_else(|| shape_err("the output's shape is not fixed for a fixed input".into()))?;
            let plan = typed.into_runnable().map_err(|e| shape_err(format!("{e:#}")))?;
            let state = TypedSimpleState::new(&plan).map_err(|e| shape_err(format!("{e:#}")))?;
            let per_image: usize = output_shape.iter().product();
            if per_image == 0 {
                return Err(shape_err(format!(
                    "output {output_shape:?} for one image is empty: no class or pixel scores"
                )));
            }
            self.plan = Some(Plan {
                states: vec![state],
                output_shape,
                outputs: Vec::new(),
                per_image,
            });
        }
        self.plan
            .as_mut()
            .ok_or_else(|| ModelError::Run("plan cache".into()))
    }

    /// Checks that each image of a batch has the model's H x W pixels.
    pub(crate) fn check_sizes(&self, images: &[&[u8]]) -> Result<(), ModelError> {
        let (h, w) = (self.height, self.width);
        match images.iter().position(|im| im.len() != h * w) {
            None => Ok(()),
            Some(index) => Err(ModelError::Image {
                index,
                got: images[index].len(),
                want: h * w,
                height: h,
                width: w,
            }),
        }
    }

    /// Runs a batch of images (row-major grey levels, H x W each) and hands the flat output
    /// (the outputs of [`Self::output_shape`] one image after the other) to `read`.
    ///
    /// A batch runs image by image through the one-image plan. tract plans a batch's
    /// convolutions with the im2col matrix of the whole batch (174 MB for HandsNet's second
    /// convolution at 32 images): 8.7 ms an image, against 3.4 ms one at a time. On more than
    /// one thread, a batch is split between the threads, each running its share of images
    /// through its own state of the plan: images are independent, so that parallelism is
    /// free, where splitting one image's small matrix products between threads is not. A
    /// single image splits its products instead.
    pub(crate) fn run<T>(
        &mut self,
        images: &[&[u8]],
        read: impl FnOnce(&[f32]) -> T,
    ) -> Result<T, ModelError> {
        self.check_sizes(images)?;
        let (h, w) = (self.height, self.width);
        let input = Input {
            height: h,
            width: w,
            gain: match self.scale {
                InputScale::Bytes => 1.0,
                InputScale::Unit => 1.0 / 255.0,
            },
        };
        let executor = self.executor.clone();
        let plan = self.plan()?;
        let per_image = plan.per_image;
        plan.outputs.clear();
        plan.outputs.resize(images.len() * per_image, 0.0);
        let pool = match &executor {
            Executor::MultiThread(pool) if images.len() > 1 => Some(pool),
            _ => None,
        };
        match pool {
            None => {
                let state = plan
                    .states
                    .first_mut()
                    .ok_or_else(|| ModelError::Run("the plan has no state".into()))?;
                input.run_share(state, images, &mut plan.outputs, per_image, &executor)?;
            }
            Some(pool) => {
                let workers = pool.current_num_threads().clamp(1, images.len());
                while plan.states.len() < workers {
                    // A clone is a session of its own over the same plan.
                    let state = plan
                        .states
                        .first()
                        .cloned()
                        .ok_or_else(|| ModelError::Run("the plan has no state".into()))?;
                    plan.states.push(state);
                }
                let share = images.len().div_ceil(workers);
                let mut results: Vec<Result<(), ModelError>> = (0..workers).map(|_| Ok(())).collect();
                pool.scope(|scope| {
                    for (((chunk, outs), state), result) in images
                        .chunks(share)
                        .zip(plan.outputs.chunks_mut(share * per_image))
                        .zip(plan.states.iter_mut())
                        .zip(results.iter_mut())
                    {
                        let input = &input;
                        scope.spawn(move |_| {
                            *result = input.run_share(state, chunk, outs, per_image, &Executor::SingleThread);
                        });
                    }
                });
                results.into_iter().collect::<Result<(), ModelError>>()?;
            }
        }
        Ok(read(&plan.outputs))
    }
}

/// How an image becomes the model's input tensor.
struct Input {
    height: usize,
    width: usize,
    /// Grey level to input value.
    gain: f32,
}

impl Input {
    /// Runs `images` one after the other through `state`, each into its `per_image` values of
    /// `outs`; stops at the first failure.
    fn run_share(
        &self,
        state: &mut TypedSimpleState,
        images: &[&[u8]],
        outs: &mut [f32],
        per_image: usize,
        executor: &Executor,
    ) -> Result<(), ModelError> {
        for (image, out) in images.iter().zip(outs.chunks_exact_mut(per_image)) {
            self.run(state, image, executor, out)?;
        }
        Ok(())
    }

    /// Runs one image (its size already checked) through `state` and writes its outputs to
    /// `out`, which has the plan's size for one image.
    fn run(
        &self,
        state: &mut TypedSimpleState,
        image: &[u8],
        executor: &Executor,
        out: &mut [f32],
    ) -> Result<(), ModelError> {
        let run_err = |e: TractError| ModelError::Run(format!("{e:#}").into());
        // tract takes the input tensor by value: one H x W tensor an image (27 kB for
        // 68 x 100), next to the output tensors tract allocates for each node of the plan.
        let mut input = Tensor::zero::<f32>(&[1, 1, self.height, self.width]).map_err(run_err)?;
        {
            let mut ram = input.try_as_plain_ram_mut().map_err(run_err)?;
            let pixels = ram.as_slice_mut::<f32>().map_err(run_err)?;
            for (p, &g) in pixels.iter_mut().zip(image) {
                *p = f32::from(g) * self.gain;
            }
        }
        let result =
            multithread_tract_scope(executor.clone(), || state.run(tvec!(input.into()))).map_err(run_err)?;
        let view = result[0].to_plain_array_view::<f32>().map_err(run_err)?;
        let flat = view
            .as_slice()
            .ok_or_else(|| ModelError::Run("the output is not contiguous".into()))?;
        if flat.len() != out.len() {
            return Err(ModelError::Run(
                format!(
                    "{} output values for one image, the plan said {}",
                    flat.len(),
                    out.len()
                )
                .into(),
            ));
        }
        out.copy_from_slice(flat);
        Ok(())
    }
}

/// A model planned for one image.
#[derive(Debug)]
struct Plan {
    /// One state per thread that runs images of a batch (the first made with the plan).
    states: Vec<TypedSimpleState>,
    /// The output's shape for one image.
    output_shape: Vec<usize>,
    /// The outputs of the last batch, one image after the other.
    outputs: Vec<f32>,
    per_image: usize,
}
