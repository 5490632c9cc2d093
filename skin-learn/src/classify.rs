//! Tactile image classification with an ONNX model run by tract (feature `onnx`; thesis Ch. 4.3):
//! "was that a human hand?" from one 8-bit grey tactile image.
//!
//! Any ONNX classifier whose input is one grey image batch, `[N, 1, H, W]` (N may be symbolic),
//! and whose output is `[N, classes]` loads. The model is planned once, for one image with a
//! concrete input shape, optimised by tract (and its 2 x 2 max-pools swapped for
//! [`crate::max_pool`]'s), and run through a reused state; a batch runs image by image through
//! that plan, which is 2.6 times faster than tract's batch plan. Pixels are scaled as the model
//! was trained ([`InputScale`]).

use crate::image_model::ImageModel;
pub use crate::image_model::{InputScale, ModelError};
use skin_core::image::{ImageSize, ImageView};
use std::path::Path;

/// A loaded classifier.
#[derive(Debug)]
pub struct Classifier {
    net: ImageModel,
    classes: usize,
}

impl Classifier {
    /// Loads `path` and plans it for one image at a time. The input must be `[N, 1, H, W]` with
    /// H and W fixed, the output `[N, classes]`; anything else is refused with the shape the
    /// file declares.
    pub fn load(path: &Path, scale: InputScale) -> Result<Classifier, ModelError> {
        let mut net = ImageModel::load(path, scale)?;
        let classes = match net.output_shape()?.as_slice() {
            [1, c] | [1, c, 1, 1] => *c,
            other => {
                return Err(ModelError::Shape {
                    path: path.into(),
                    why: format!("output {other:?}: expected [N, classes] class scores"),
                });
            }
        };
        Ok(Classifier { net, classes })
    }

    /// Runs the model on `threads` threads (1: on the caller's thread, the default). A batch
    /// is split between the threads image by image; a single image splits its matrix
    /// products, which gains less (see BENCHMARKS.md).
    pub fn with_threads(mut self, threads: usize) -> Result<Classifier, ModelError> {
        self.net.set_threads(threads)?;
        Ok(self)
    }

    /// Its input image's size (rows and columns, pixels).
    pub fn input_size(&self) -> ImageSize {
        ImageSize {
            rows: self.net.height,
            cols: self.net.width,
        }
    }

    /// Number of classes (the output's width).
    pub fn classes(&self) -> usize {
        self.classes
    }

    /// Class probabilities of one image (row-major grey levels, H x W).
    pub fn classify(&mut self, image: &[u8]) -> Result<Vec<f32>, ModelError> {
        Ok(self.classify_batch(&[image])?.remove(0))
    }

    /// Class probabilities of each image (each through the one-image plan).
    pub fn classify_batch(&mut self, images: &[&[u8]]) -> Result<Vec<Vec<f32>>, ModelError> {
        if images.is_empty() {
            return Ok(Vec::new());
        }
        let classes = self.classes;
        self.net
            .run(images, |flat| flat.chunks(classes).map(probabilities).collect())
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

impl crate::model::HandClassifier for Classifier {
    fn input_size(&self) -> ImageSize {
        ImageSize {
            rows: self.net.height,
            cols: self.net.width,
        }
    }

    fn classify(&mut self, image: ImageView<'_, u8>) -> Result<Vec<f32>, ModelError> {
        Classifier::classify(self, image.pixels())
    }
}
