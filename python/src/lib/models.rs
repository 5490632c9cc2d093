//! Bring your own model: a Python callable as the session's classifier or segmenter, through
//! the model traits of `skin_learn::model`. The callable takes the tactile image, a (rows, cols)
//! uint8 numpy array, and returns class probabilities, 0 to 1 (anything `numpy.asarray` reads: an
//! array, a list, a tensor on the CPU; logits need a softmax first) or part labels (rows, cols), 0 background then thumb .. palm. An
//! exception it raises is kept and re-raised to the caller as itself, with the frame, link and
//! touch added as a note.

use pyo3::prelude::*;
use skin_core::image::{ImageSize, ImageView};
use skin_learn::model::{HandClassifier, ModelError, PartSegmenter};
use std::sync::{Arc, Mutex};

/// Where a callable's exception waits to be re-raised (shared by a session's models).
pub(crate) type Raised = Arc<Mutex<Option<PyErr>>>;

/// A Python callable run on a tactile image.
pub(crate) struct Callable {
    function: Py<PyAny>,
    size: ImageSize,
    raised: Raised,
    what: &'static str,
}

impl Callable {
    pub(crate) fn new(function: Py<PyAny>, size: ImageSize, raised: Raised, what: &'static str) -> Callable {
        Callable {
            function,
            size,
            raised,
            what,
        }
    }

    /// Calls the function on `image` and reads its answer as a flat array of `T` (numpy `dtype`).
    fn call<T: numpy::Element + Copy>(
        &self,
        image: ImageView<'_, u8>,
        dtype: &str,
    ) -> Result<Vec<T>, ModelError> {
        Python::attach(|py| {
            let answer = (|| -> PyResult<Vec<T>> {
                let pixels =
                    crate::arrays::out(py, image.pixels().to_vec(), &[self.size.rows, self.size.cols])?;
                let result = self.function.bind(py).call1((pixels,))?;
                if result.is_none() {
                    return Err(crate::errors::error(
                        crate::errors::Kind::Model,
                        format!("the Python {} returned None", self.what),
                    ));
                }
                // Any shape (a batch of one, an image of labels), read flat, through the
                // conversion arguments go through (no fraction read as a label, no text).
                let flat = py.import("numpy")?.call_method1("ravel", (result,))?;
                let what = format!("the Python {}'s answer", self.what);
                let array = crate::arrays::array::<T>(&what, &flat, dtype, 1)?;
                Ok(crate::arrays::slice(&what, &array)?.to_vec())
            })();
            answer.map_err(|e| {
                let text = format!("the Python {} raised {e}", self.what);
                let mut slot = self
                    .raised
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                slot.get_or_insert(e);
                ModelError::Run(text)
            })
        })
    }
}

impl HandClassifier for Callable {
    fn input_size(&self) -> ImageSize {
        self.size
    }

    fn classify(&mut self, image: ImageView<'_, u8>) -> Result<Vec<f32>, ModelError> {
        let scores: Vec<f32> = self.call(image, "float32")?;
        // The decision's probability is the largest score: scores must be probabilities (a
        // model's logits need a softmax first).
        if let Some(bad) = scores.iter().find(|s| !(0.0..=1.0).contains(*s)) {
            return Err(ModelError::Run(format!(
                "the Python classifier returned a score of {bad}: scores are probabilities, 0 to 1 (apply a softmax to logits)"
            )));
        }
        Ok(scores)
    }
}

impl PartSegmenter for Callable {
    fn input_size(&self) -> ImageSize {
        self.size
    }

    fn segment(&mut self, image: ImageView<'_, u8>) -> Result<Vec<u8>, ModelError> {
        let labels: Vec<i64> = self.call(image, "int64")?;
        labels
            .iter()
            .map(|&l| {
                u8::try_from(l).ok().filter(|&l| l <= 6).ok_or_else(|| {
                    ModelError::Run(format!(
                        "the Python segmenter returned label {l} (labels are 0 to 6)"
                    ))
                })
            })
            .collect()
    }
}

/// `err` with the exception a callable raised put back, if one did: that exception, noted with
/// `context` (which frame, link and touch); otherwise `err`.
pub(crate) fn reraise(raised: &Raised, err: PyErr, context: &str) -> PyErr {
    let kept = raised
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .take();
    let Some(original) = kept else {
        return err;
    };
    Python::attach(|py| {
        let value = original.value(py);
        let note = format!("in a skin session: {context}");
        if value.hasattr("add_note").unwrap_or(false) {
            let _ = value.call_method1("add_note", (note,));
        } else {
            // Before Python 3.11 notes are not printed, but kept where 3.11 keeps them.
            let _ = value.setattr("__notes__", vec![note]);
        }
    });
    original
}
