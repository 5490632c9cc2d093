//! Hand-part segmentation of tactile images with an ONNX model run by tract (feature `onnx`;
//! thesis Ch. 4.4): which part of the hand (thumb, index, middle, ring, pinkie, palm) pressed
//! each pixel.
//!
//! Any ONNX segmenter whose input is `[N, 1, H, W]` grey and whose output is per-pixel class
//! scores `[N, classes, H, W]` loads; the class of a pixel is the one with the highest score
//! (what a softmax would pick). Planning and input scaling are as for
//! [`crate::classify::Classifier`].
//!
//! With [`Segmenter::with_mirror_averaging`], each image also goes through the model mirrored
//! left-right, up-down and both, and a pixel's class is the best of its four scores summed
//! (test-time augmentation). It suits models trained with flip augmentation, as train.py's
//! are: the shipped `handseg_wide.onnx` gains 2.65 points of mIoU (70.65% to 73.30% on the
//! forearm12k test hands) for four times the inference.

use crate::image_model::ImageModel;
pub use crate::image_model::{InputScale, ModelError};
use skin_core::image::{ImageSize, ImageView};
use std::path::Path;

/// A loaded segmenter.
#[derive(Debug)]
pub struct Segmenter {
    net: ImageModel,
    classes: usize,
    mirrors: bool,
    /// Each image of the last batch and its three mirror images, when averaging over mirrors.
    views: Vec<u8>,
}

impl Segmenter {
    /// Loads `path` and plans it for one image. The input must be `[N, 1, H, W]` with H and W
    /// fixed, the output `[N, classes, H, W]`.
    pub fn load(path: &Path, scale: InputScale) -> Result<Segmenter, ModelError> {
        let mut net = ImageModel::load(path, scale)?;
        let (h, w) = (net.height, net.width);
        let classes = match net.output_shape()?.as_slice() {
            [1, c, oh, ow] if (*oh, *ow) == (h, w) && *c >= 2 && *c <= 256 => *c,
            other => {
                return Err(ModelError::Shape {
                    path: path.into(),
                    why: format!(
                        "output {other:?}: expected [N, classes, {h}, {w}] per-pixel class scores (2 to 256 classes)"
                    ),
                });
            }
        };
        Ok(Segmenter {
            net,
            classes,
            mirrors: false,
            views: Vec::new(),
        })
    }

    /// Averages the scores of each image and its three mirror images (left-right, up-down,
    /// both) before picking a pixel's class: steadier labels at four times the inference. Off
    /// by default. Only for a model trained on mirrored images too; a left and a right hand
    /// are mirror images, so a hand-part model has no preferred side to lose.
    pub fn with_mirror_averaging(mut self, on: bool) -> Segmenter {
        self.mirrors = on;
        self
    }

    /// Runs the model on `threads` threads (1: on the caller's thread, the default). A batch
    /// is split between the threads image by image; a single image splits its matrix
    /// products, which gains less (see BENCHMARKS.md).
    pub fn with_threads(mut self, threads: usize) -> Result<Segmenter, ModelError> {
        self.net.set_threads(threads)?;
        Ok(self)
    }

    /// Its input (and output) image's size (rows and columns, pixels).
    pub fn input_size(&self) -> ImageSize {
        ImageSize {
            rows: self.net.height,
            cols: self.net.width,
        }
    }

    /// Number of classes, background included.
    pub fn classes(&self) -> usize {
        self.classes
    }

    /// The class of each pixel of one image (row-major grey levels, H x W).
    pub fn segment(&mut self, image: &[u8]) -> Result<Vec<u8>, ModelError> {
        Ok(self.segment_batch(&[image])?.remove(0))
    }

    /// The class of each pixel of each image (each through the one-image plan). Pixels that are
    /// black in the input are background (class 0) whatever the model says: nothing pressed
    /// there.
    pub fn segment_batch(&mut self, images: &[&[u8]]) -> Result<Vec<Vec<u8>>, ModelError> {
        if images.is_empty() {
            return Ok(Vec::new());
        }
        let (classes, ImageSize { rows: h, cols: w }) = (self.classes, self.input_size());
        let pixels = h * w;
        let label = |image: &[u8], score: &dyn Fn(usize, usize) -> f32| -> Vec<u8> {
            (0..pixels)
                .map(|p| {
                    if image[p] == 0 {
                        return 0;
                    }
                    let mut best = (f32::NEG_INFINITY, 0u8);
                    for c in 0..classes {
                        let s = score(c, p);
                        if s > best.0 {
                            best = (s, c as u8);
                        }
                    }
                    best.1
                })
                .collect()
        };
        if !self.mirrors {
            return self.net.run(images, |flat| {
                images
                    .iter()
                    .zip(flat.chunks(classes * pixels))
                    .map(|(image, scores)| label(image, &|c, p| scores[c * pixels + p]))
                    .collect()
            });
        }
        // Pixel p = (r, x) of view v (bit 0: left-right, bit 1: up-down) shows pixel
        // mirror(v, p) of the image; the same map takes it back.
        let mirror = move |v: usize, p: usize| {
            let (r, x) = (p / w, p % w);
            let r = if v & 2 != 0 { h - 1 - r } else { r };
            let x = if v & 1 != 0 { w - 1 - x } else { x };
            r * w + x
        };
        // Checked before the views are cut, which index every image at H x W.
        self.net.check_sizes(images)?;
        self.views.clear();
        for image in images {
            for v in 0..4 {
                self.views.extend((0..pixels).map(|p| image[mirror(v, p)]));
            }
        }
        let views: Vec<&[u8]> = self.views.chunks(pixels).collect();
        self.net.run(&views, |flat| {
            images
                .iter()
                .zip(flat.chunks(4 * classes * pixels))
                .map(|(image, scores)| {
                    label(image, &|c, p| {
                        (0..4)
                            .map(|v| scores[(v * classes + c) * pixels + mirror(v, p)])
                            .sum()
                    })
                })
                .collect()
        })
    }
}

impl crate::model::PartSegmenter for Segmenter {
    fn input_size(&self) -> ImageSize {
        ImageSize {
            rows: self.net.height,
            cols: self.net.width,
        }
    }

    fn segment(&mut self, image: ImageView<'_, u8>) -> Result<Vec<u8>, ModelError> {
        Segmenter::segment(self, image.pixels())
    }
}
