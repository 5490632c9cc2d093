//! The models of a session built from a configuration: those the caller brings
//! ([`OwnModels`]) and those the configuration names, opened by a [`ModelRuntime`] (skin-learn's
//! tract runtime, or a robot stack's own), each checked against the configuration's image size
//! and its classes named by the model card.

use super::{ConfigError, SessionConfig, SessionError};
use crate::card::ModelCard;
use crate::model::{Classes, HandClassifier, ModelError, Models, PartSegmenter};
use skin_core::image::ImageSize;
use std::path::{Path, PathBuf};

/// What opens the model files a configuration names (`classifier`, `segmenter`): the session
/// asks of a model only the traits of [`crate::model`], so what runs it is the caller's choice.
/// skin-learn's `TractRuntime` (feature `onnx`) runs ONNX files with tract.
pub trait ModelRuntime {
    /// The classifier in `path`, and how many classes it outputs.
    fn classifier(&self, path: &Path) -> Result<(Box<dyn HandClassifier>, usize), ModelError>;
    /// The segmenter in `path`.
    fn segmenter(&self, path: &Path) -> Result<Box<dyn PartSegmenter>, ModelError>;
}

/// Models a caller brings in place of those a configuration names (a robot stack's own, a
/// binding's callables): each kind given replaces the configuration's, and the configuration's
/// files give the others ([`Session::from_config_with_runtime`](super::Session::from_config_with_runtime)); or, with no configuration, the
/// only models ([`OwnModels::into_models`]).
#[derive(Default)]
pub struct OwnModels {
    /// A classifier.
    pub classifier: Option<Box<dyn HandClassifier>>,
    /// The names of its outputs, in order (none: those of the model card of the configuration's
    /// classifier, which it replaces, or else [`Classes::hand_or_not`]).
    pub classes: Option<Vec<String>>,
    /// The name of the class that is the hand (none: the card's hand class, or the class named
    /// [`Classes::HAND`] among `classes`).
    pub hand: Option<String>,
    /// A segmenter.
    pub segmenter: Option<Box<dyn PartSegmenter>>,
}

impl std::fmt::Debug for OwnModels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OwnModels")
            .field("classifier", &self.classifier.as_ref().map(|c| c.input_size()))
            .field("classes", &self.classes)
            .field("hand", &self.hand)
            .field("segmenter", &self.segmenter.as_ref().map(|s| s.input_size()))
            .finish()
    }
}

impl OwnModels {
    /// The classes the classifier's outputs name: `classes` and `hand` as given, else those
    /// of the model card beside `replaced` (the configuration's classifier it replaces), else
    /// [`Classes::hand_or_not`], the hand renamed by `hand` if given. Names that do not fit are
    /// [`SessionError::Names`]; a card that does not, [`ConfigError::Card`].
    pub fn classes(&self, replaced: Option<&Path>) -> Result<Classes, SessionError> {
        let names = |field: &'static str| move |source| SessionError::Names { field, source };
        if let Some(given) = &self.classes {
            return Classes::for_names(given.clone(), self.hand.as_deref()).map_err(|e| match e {
                e @ ModelError::NotAClass { .. } => names("hand")(e),
                e => names("classes")(e),
            });
        }
        let mut classes = Classes::hand_or_not();
        if let Some(model) = replaced
            && let Some(card) = ModelCard::for_model(model)
        {
            let card_error = |source| ConfigError::Card {
                card: ModelCard::path_for(model),
                source,
            };
            if let Some(c) = Classes::from_card(&card).map_err(card_error)? {
                classes = c;
            }
        }
        match &self.hand {
            Some(hand) => classes.with_hand(hand).map_err(names("hand")),
            None => Ok(classes),
        }
    }

    /// The models alone, with no configuration behind them (no classifier: [`Models::none`]'s
    /// classes).
    pub fn into_models(self) -> Result<Models, SessionError> {
        let classes = match self.classifier {
            Some(_) => self.classes(None)?,
            None => Classes::hand_or_not(),
        };
        Ok(Models {
            classifier: self.classifier,
            segmenter: self.segmenter,
            classes,
        })
    }
}

/// The configuration's models, opened by `runtime` where `own` brings none of the kind: the
/// classifier (its classes from its card) and the segmenter, each checked against the
/// configuration's image size. Without a runtime, a model the configuration names and `own`
/// does not replace is [`ConfigError::NoModelRuntime`].
pub(super) fn load_models(
    config: &SessionConfig,
    own: OwnModels,
    runtime: Option<&dyn ModelRuntime>,
) -> Result<Models, SessionError> {
    let at =
        |field: &'static str, p: &Option<PathBuf>| p.as_deref().map(|p| config.resolve(field, p)).transpose();
    // The configuration's files were resolved (and a missing one named) before the models.
    let size = config.image_size()?;
    let check_size = |model: &Path, takes: ImageSize| {
        if takes == size {
            Ok(())
        } else {
            Err(ConfigError::ImageSize {
                model: model.to_owned(),
                takes,
                config: config.path.clone(),
                makes: size,
            })
        }
    };
    // Without a runtime, a model the configuration names and `own` does not replace cannot run:
    // said before anything else of the models is read, the classifier's first.
    let named = [
        ("classifier", &config.classifier, own.classifier.is_some()),
        ("segmenter", &config.segmenter, own.segmenter.is_some()),
    ];
    let unrunnable = named
        .iter()
        .find(|(_, model, replaced)| model.is_some() && !replaced);
    if let (None, Some(&(field, model, _))) = (runtime, unrunnable) {
        return Err(ConfigError::NoModelRuntime {
            config: config.path.clone(),
            field,
            model: model.clone().unwrap_or_default(),
        }
        .into());
    }
    // A model named and not replaced has a runtime from here on (checked above).
    let classifier = at("classifier", &config.classifier)?;
    let mut models = match (own.classifier.is_some(), classifier, runtime) {
        (true, replaced, _) => Models {
            classes: own.classes(replaced.as_deref())?,
            classifier: own.classifier,
            segmenter: None,
        },
        (false, Some(p), Some(runtime)) => {
            let (net, outputs) = runtime.classifier(&p).map_err(ConfigError::Model)?;
            check_size(&p, net.input_size())?;
            Models {
                classes: card_classes(&p, outputs)?,
                classifier: Some(net),
                segmenter: None,
            }
        }
        (false, _, _) => Models::none(),
    };
    match (own.segmenter, at("segmenter", &config.segmenter)?, runtime) {
        (Some(own), _, _) => models.segmenter = Some(own),
        (None, Some(p), Some(runtime)) => {
            let net = runtime.segmenter(&p).map_err(ConfigError::Model)?;
            check_size(&p, net.input_size())?;
            models.segmenter = Some(net);
        }
        (None, _, _) => {}
    }
    Ok(models)
}

/// The classes of the classifier `model` of `outputs` outputs, from its card
/// ([`Classes::for_outputs`]); an error when they cannot be named.
fn card_classes(model: &Path, outputs: usize) -> Result<Classes, ConfigError> {
    let card = ModelCard::for_model(model);
    let classes = Classes::for_outputs(card.as_ref(), outputs).map_err(|source| ConfigError::Card {
        card: ModelCard::path_for(model),
        source,
    })?;
    classes.ok_or_else(|| ConfigError::UnnamedClasses {
        card: ModelCard::path_for(model),
        model: model.to_owned(),
        classes: outputs,
    })
}
