//! What the touch path asks of its models, and nothing of how they run: a [`HandClassifier`]
//! (hand or not, from one tactile image) and a [`PartSegmenter`] (which part of the hand
//! pressed each pixel), with the [`Classes`] a classifier's outputs name, bundled as the
//! [`Models`] a [`TouchPipeline`](crate::touch::TouchPipeline) takes. Compiled always: tracking
//! needs no model, and a robot stack may bring its own. The shipped ONNX models implement the
//! traits with tract in skin-learn (feature `onnx`: `skin_learn::classify::Classifier`,
//! `skin_learn::segment::Segmenter`).
//!
//! Which class is the hand comes from the classifier's model card ([`Classes::from_card`]):
//! that class is segmented into parts and is what the gate treats as a hand.
//!
//! ```
//! use skin_core::image::{ImageSize, ImageView};
//! use skin_runtime::model::{Classes, HandClassifier, ModelError, Models};
//!
//! /// A hand presses a wide area; an object a small one.
//! struct ByArea;
//! impl HandClassifier for ByArea {
//!     fn input_size(&self) -> ImageSize {
//!         ImageSize::MODEL_DEFAULT
//!     }
//!     fn classify(&mut self, image: ImageView<'_, u8>) -> Result<Vec<f32>, ModelError> {
//!         let lit = image.pixels().iter().filter(|&&p| p > 0).count() as f32;
//!         let hand = (lit / 800.0).min(1.0);
//!         Ok(vec![hand, 1.0 - hand])
//!     }
//! }
//! let classes = Classes::new(["hand", "object"], Some(0));
//! let models = Models::new(ByArea, classes);
//! assert_eq!(models.input_size()?, ImageSize::MODEL_DEFAULT);
//! assert!(models.classes().get(0).is_some_and(|c| c.is_hand()));
//! # Ok::<(), skin_runtime::touch::TouchError>(())
//! ```

use crate::card::ModelCard;
use serde::{Serialize, Serializer};
use skin_control::hri::TouchClass;
use skin_core::image::{ImageSize, ImageView};
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// What can go wrong with a model or its input.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The file is not a model the runtime can load (corrupt, another format, an operator it
    /// lacks).
    #[error("{path}: not a usable model: {why}")]
    Load {
        /// The file.
        path: PathBuf,
        /// The runtime's explanation.
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
    /// The model failed while running: the runtime's own error, kept as the source (a Python
    /// model's exception reaches the binding as itself); a text says what went wrong otherwise.
    #[error("running the model: {0}")]
    Run(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// The classifier and the segmenter take images of different sizes.
    #[error("the classifier takes {classifier} images, the segmenter {segmenter}: they must agree")]
    Sizes {
        /// Classifier input.
        classifier: ImageSize,
        /// Segmenter input.
        segmenter: ImageSize,
    },
    /// A model card's `hand_class:` names none of its classes.
    #[error("hand_class {hand:?} is none of the classes ({})", classes.join(", "))]
    HandClass {
        /// The name given.
        hand: String,
        /// The classes the card lists.
        classes: Vec<String>,
    },
    /// A class name that is none of the classes (the hand a caller names among them).
    #[error("{name:?} is none of the classes ({})", classes.join(", "))]
    NotAClass {
        /// The name given.
        name: String,
        /// The classes there are.
        classes: Vec<String>,
    },
    /// A classifier's classes named with no name at all.
    #[error("no class")]
    NoClass,
    /// Two outputs named alike: their scores would read as one class.
    #[error("class {name:?} names outputs {first} and {again}: each output needs a name of its own")]
    DuplicateClass {
        /// The name given twice.
        name: String,
        /// The first output it names.
        first: usize,
        /// The next output it names.
        again: usize,
    },
}

/// Hand or not, from one tactile image (thesis Ch. 4.3).
pub trait HandClassifier: Send {
    /// The size of the images it takes.
    fn input_size(&self) -> ImageSize;

    /// One probability (or score) per class, in the order its [`Classes`] name them.
    fn classify(&mut self, image: ImageView<'_, u8>) -> Result<Vec<f32>, ModelError>;
}

/// Which part of the hand pressed each pixel of a tactile image (thesis Ch. 4.4).
pub trait PartSegmenter: Send {
    /// The size of the images it takes (and of the masks it gives).
    fn input_size(&self) -> ImageSize;

    /// One part label per pixel, row-major: 0 background, then thumb, index, middle, ring,
    /// pinkie, palm ([`crate::parts::Part`]).
    fn segment(&mut self, image: ImageView<'_, u8>) -> Result<Vec<u8>, ModelError>;
}

/// One class of a classifier's outputs: its index, its name, and whether it is the hand.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Class {
    index: usize,
    name: Arc<str>,
    hand: bool,
}

impl Class {
    /// Index in the classifier's outputs.
    pub fn index(&self) -> usize {
        self.index
    }

    /// Its name (the model card's).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// It is the hand class: segmented into parts, treated as a hand by the gate.
    pub fn is_hand(&self) -> bool {
        self.hand
    }

    /// The class as the gate sees it.
    pub fn kind(&self) -> TouchClass {
        if self.hand {
            TouchClass::Hand
        } else {
            TouchClass::NonHand
        }
    }
}

impl fmt::Display for Class {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name)
    }
}

/// A class is written as its name.
impl Serialize for Class {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name)
    }
}

/// The classes of a classifier's outputs, in order, built once (from its model card).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Classes {
    classes: Vec<Class>,
}

impl Classes {
    /// Classes named `names` in output order; `hand` is the index of the hand class, if any.
    pub fn new<S: Into<String>>(names: impl IntoIterator<Item = S>, hand: Option<usize>) -> Classes {
        let classes = names
            .into_iter()
            .enumerate()
            .map(|(index, name)| Class {
                index,
                name: Arc::from(name.into()),
                hand: Some(index) == hand,
            })
            .collect();
        Classes { classes }
    }

    /// [`Classes::new`], refusing a name given to two outputs: a decision of either would read
    /// as the same class, and a gate or a script could not tell them apart. What model cards
    /// and a user's own classifier are named through.
    pub fn named<S: Into<String>>(
        names: impl IntoIterator<Item = S>,
        hand: Option<usize>,
    ) -> Result<Classes, ModelError> {
        let names: Vec<String> = names.into_iter().map(Into::into).collect();
        let mut seen = std::collections::HashMap::new();
        for (again, name) in names.iter().enumerate() {
            if let Some(first) = seen.insert(name.as_str(), again) {
                return Err(ModelError::DuplicateClass {
                    name: name.clone(),
                    first,
                    again,
                });
            }
        }
        Ok(Classes::new(names, hand))
    }

    /// The name of the hand class when nothing else names it: the first of
    /// [`Classes::hand_or_not`], and the hand among names given without saying which is
    /// ([`Classes::for_names`]).
    pub const HAND: &'static str = "hand";

    /// A two-output classifier without a card, as HandsNet is: output 0 the hand, output 1
    /// anything else.
    pub fn hand_or_not() -> Classes {
        Classes::new([Classes::HAND, "non_hand"], Some(0))
    }

    /// The classes of a caller's classifier whose outputs it names `names`, in order: the hand
    /// is the class named `hand`, or without one the class named [`Classes::HAND`] if any. No
    /// name, a name given twice ([`Classes::named`]) or a `hand` that is none of them is an
    /// error.
    pub fn for_names(names: Vec<String>, hand: Option<&str>) -> Result<Classes, ModelError> {
        let at = match hand {
            Some(h) => Some(position(&names, h)?),
            None => names.iter().position(|n| n == Classes::HAND),
        };
        if names.is_empty() {
            return Err(ModelError::NoClass);
        }
        Classes::named(names, at)
    }

    /// The same classes with the one named `hand` as the hand; an error if none is.
    pub fn with_hand(&self, hand: &str) -> Result<Classes, ModelError> {
        let names: Vec<String> = self.iter().map(|c| c.name().to_owned()).collect();
        let at = position(&names, hand)?;
        Ok(Classes::new(names, Some(at)))
    }

    /// The classes a model card lists (none if it lists none). The hand class is the one its
    /// `hand_class:` field names, or else the first listed (as HandsNet's output 0 is the hand).
    /// A `hand_class:` that names none of them is an error: a misspelt name would otherwise
    /// leave the skin with no hand class, never segmenting and gating every touch as non-hand.
    /// So is a class listed twice ([`Classes::named`]).
    pub fn from_card(card: &ModelCard) -> Result<Option<Classes>, ModelError> {
        if card.classes.is_empty() {
            return Ok(None);
        }
        let hand = match &card.hand {
            Some(name) => match card.classes.iter().position(|c| c == name) {
                Some(k) => k,
                None => {
                    return Err(ModelError::HandClass {
                        hand: name.clone(),
                        classes: card.classes.clone(),
                    });
                }
            },
            None => 0,
        };
        Classes::named(card.classes.iter().cloned(), Some(hand)).map(Some)
    }

    /// The classes of a classifier of `outputs` outputs: its card's when they are as many,
    /// [`Classes::hand_or_not`] for two outputs without them, none otherwise (more classes
    /// than two need names).
    pub fn for_outputs(card: Option<&ModelCard>, outputs: usize) -> Result<Option<Classes>, ModelError> {
        let named = match card {
            Some(card) => Classes::from_card(card)?,
            None => None,
        };
        Ok(match named {
            Some(c) if c.len() == outputs => Some(c),
            _ if outputs == 2 => Some(Classes::hand_or_not()),
            _ => None,
        })
    }

    /// The class of output `index`.
    pub fn get(&self, index: usize) -> Option<&Class> {
        self.classes.get(index)
    }

    /// The hand class, if there is one.
    pub fn hand(&self) -> Option<&Class> {
        self.classes.iter().find(|c| c.hand)
    }

    /// Number of classes.
    pub fn len(&self) -> usize {
        self.classes.len()
    }

    /// No class at all.
    pub fn is_empty(&self) -> bool {
        self.classes.is_empty()
    }

    /// The classes in output order.
    pub fn iter(&self) -> std::slice::Iter<'_, Class> {
        self.classes.iter()
    }
}

/// Where `name` is among `names`; an error naming them if it is not.
fn position(names: &[String], name: &str) -> Result<usize, ModelError> {
    names
        .iter()
        .position(|n| n == name)
        .ok_or_else(|| ModelError::NotAClass {
            name: name.to_owned(),
            classes: names.to_vec(),
        })
}

/// The models of a touch pipeline: a classifier and the classes it names, and a segmenter for
/// the hand class. [`Models::none`] tracks touches without deciding them.
pub struct Models {
    pub(crate) classifier: Option<Box<dyn HandClassifier>>,
    pub(crate) segmenter: Option<Box<dyn PartSegmenter>>,
    pub(crate) classes: Classes,
}

impl fmt::Debug for Models {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Models")
            .field("classifier", &self.classifier.as_ref().map(|c| c.input_size()))
            .field("segmenter", &self.segmenter.as_ref().map(|s| s.input_size()))
            .field("classes", &self.classes)
            .finish()
    }
}

impl Default for Models {
    fn default() -> Self {
        Models::none()
    }
}

impl Models {
    /// No model: touches are tracked (appeared, released) and not classified.
    pub fn none() -> Models {
        Models {
            classifier: None,
            segmenter: None,
            classes: Classes::hand_or_not(),
        }
    }

    /// A classifier whose outputs are `classes`.
    pub fn new(classifier: impl HandClassifier + 'static, classes: Classes) -> Models {
        Models {
            classifier: Some(Box::new(classifier)),
            segmenter: None,
            classes,
        }
    }

    /// Also segments the touches classified as the hand class into parts.
    pub fn with_segmenter(mut self, segmenter: impl PartSegmenter + 'static) -> Models {
        self.segmenter = Some(Box::new(segmenter));
        self
    }

    /// The classifier's classes.
    pub fn classes(&self) -> &Classes {
        &self.classes
    }

    /// No model at all.
    pub fn is_none(&self) -> bool {
        self.classifier.is_none() && self.segmenter.is_none()
    }

    /// A classifier is there.
    pub fn classifies(&self) -> bool {
        self.classifier.is_some()
    }

    /// The image size the models take ([`ImageSize::MODEL_DEFAULT`] without a model); an
    /// error if the classifier and the segmenter take different sizes.
    pub fn input_size(&self) -> Result<ImageSize, ModelError> {
        let c = self.classifier.as_ref().map(|c| c.input_size());
        let s = self.segmenter.as_ref().map(|s| s.input_size());
        match (c, s) {
            (Some(classifier), Some(segmenter)) if classifier != segmenter => Err(ModelError::Sizes {
                classifier,
                segmenter,
            }),
            (Some(size), _) | (None, Some(size)) => Ok(size),
            (None, None) => Ok(ImageSize::MODEL_DEFAULT),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::path::PathBuf;

    fn card(front: &str) -> ModelCard {
        ModelCard::parse(&format!("---\n{front}---\n"), PathBuf::from("m.md"))
    }

    #[test]
    fn the_hand_class_comes_from_the_card() {
        let c = Classes::from_card(&card("classes: object, palm, hand\nhand_class: hand\n"))
            .unwrap()
            .unwrap();
        assert_eq!(c.hand().map(Class::index), Some(2));
        assert!(!c.get(0).unwrap().is_hand());
        // Without hand_class the first listed is the hand, as HandsNet's output 0 is.
        let c = Classes::from_card(&card("classes: hand, non_hand\n"))
            .unwrap()
            .unwrap();
        assert_eq!(c.hand().map(Class::name), Some("hand"));
        assert_eq!(Classes::from_card(&card("model: x\n")).unwrap(), None);
    }

    #[test]
    fn a_hand_class_that_is_no_class_is_refused() {
        let err = Classes::from_card(&card("classes: hand, non_hand\nhand_class: Hand\n")).unwrap_err();
        assert!(
            matches!(&err, ModelError::HandClass { hand, .. } if hand == "Hand"),
            "{err}"
        );
        assert!(err.to_string().contains("hand, non_hand"), "{err}");
    }

    #[test]
    fn a_class_named_twice_is_refused() {
        let err = Classes::from_card(&card(
            "classes: hand, object, hand
",
        ))
        .unwrap_err();
        assert!(
            matches!(&err, ModelError::DuplicateClass { name, first: 0, again: 2 } if name == "hand"),
            "{err}"
        );
        assert!(err.to_string().contains("outputs 0 and 2"), "{err}");
        let err = Classes::named(["a", "b", "b"], None).unwrap_err();
        assert!(err.to_string().contains("\"b\" names outputs 1 and 2"), "{err}");
        assert_eq!(
            Classes::named(["a", "b"], Some(1)).unwrap(),
            Classes::new(["a", "b"], Some(1))
        );
    }
}
