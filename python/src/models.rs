//! Bring your own model: a Python callable as the session's classifier or segmenter, through
//! the model traits of `skin_learn::model`. The callable takes the tactile image, a (rows, cols)
//! uint8 numpy array, and returns class probabilities, 0 to 1 (anything `numpy.asarray` reads: an
//! array, a list, a tensor on the CPU; logits need a softmax first) or part labels (rows, cols), 0
//! background then thumb .. palm. An exception it raises travels inside the session's error as
//! the model's error source ([`Raised`]) and reaches the caller as itself, with the frame, link
//! and touch added as a note ([`reraised`]).

use pyo3::prelude::*;
use skin_core::image::{ImageSize, ImageView};
use skin_learn::model::{HandClassifier, ModelError, PartSegmenter};
use std::fmt;

/// The exception a Python model raised, as the source of the model's error
/// (`ModelError::Run`), so that the session's error brings it back to the binding unchanged.
#[derive(Debug)]
pub(crate) struct Raised {
    what: &'static str,
    exception: PyErr,
}

impl fmt::Display for Raised {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "the Python {} raised {}", self.what, self.exception)
    }
}

impl std::error::Error for Raised {}

/// A Python callable run on a tactile image.
pub(crate) struct Callable {
    function: Py<PyAny>,
    size: ImageSize,
    what: &'static str,
}

impl Callable {
    pub(crate) fn new(function: Py<PyAny>, size: ImageSize, what: &'static str) -> Callable {
        Callable { function, size, what }
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
            answer.map_err(|exception| {
                ModelError::Run(Box::new(Raised {
                    what: self.what,
                    exception,
                }))
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
            return Err(ModelError::Run(
                format!(
                    "the Python classifier returned a score of {bad}: scores are probabilities, 0 to 1 (apply a softmax to logits)"
                )
                .into(),
            ));
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
                    ModelError::Run(
                        format!("the Python segmenter returned label {l} (labels are 0 to 6)").into(),
                    )
                })
            })
            .collect()
    }
}

/// The exception a Python model raised, when one did among `error`'s causes: that exception
/// itself, noted with `context` (which frame, link and touch).
pub(crate) fn reraised(error: &(dyn std::error::Error + 'static), context: &str) -> Option<PyErr> {
    let mut cause = Some(error);
    while let Some(e) = cause {
        if let Some(raised) = e.downcast_ref::<Raised>() {
            return Some(Python::attach(|py| {
                let original = raised.exception.clone_ref(py);
                let value = original.value(py);
                let note = format!("in a skin session: {context}");
                if value.hasattr("add_note").unwrap_or(false) {
                    let _ = value.call_method1("add_note", (note,));
                } else {
                    // Before Python 3.11 notes are not printed, but kept where 3.11 keeps them.
                    let _ = value.setattr("__notes__", vec![note]);
                }
                original
            }));
        }
        cause = e.source();
    }
    None
}
