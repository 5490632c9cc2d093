//! The session: skin-runtime's ([`skin_runtime::session`], every item re-exported here), and
//! what skin-learn adds to it: [`FromConfig`], a session opened from `skin run`'s configuration
//! with the models it names run by tract ([`TractRuntime`], feature `onnx`).
//!
//! ```no_run
//! use skin_learn::session::{FromConfig, Session, SessionConfig};
//!
//! let config = SessionConfig::read("fixtures/session/run.toml".as_ref())?;
//! let session = Session::from_config(&config)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use skin_runtime::session::*;

/// A session opened from its configuration, the models it names run by skin-learn: with
/// feature `onnx`, by tract ([`TractRuntime`]); without it, a configuration that names a model
/// is refused ([`ConfigError::NoModelRuntime`]) unless the caller brings it.
pub trait FromConfig: Sized {
    /// The session of a configuration: reads the layout, the bus map, the models, the script and
    /// the poses it names, and makes (or reads from the cache) the links' tactile maps.
    fn from_config(config: &SessionConfig) -> Result<Self, SessionError> {
        Self::from_config_with_own(config, OwnModels::default())
    }

    /// The session of a configuration whose models the caller's `own` replace, each kind on its
    /// own ([`Session::from_config_with_runtime`]); the configuration's files give the rest.
    fn from_config_with_own(config: &SessionConfig, own: OwnModels) -> Result<Self, SessionError>;
}

impl FromConfig for Session {
    fn from_config_with_own(config: &SessionConfig, own: OwnModels) -> Result<Session, SessionError> {
        #[cfg(feature = "onnx")]
        let runtime: Option<&dyn ModelRuntime> = Some(&TractRuntime);
        #[cfg(not(feature = "onnx"))]
        let runtime: Option<&dyn ModelRuntime> = None;
        Session::from_config_with_runtime(config, own, runtime)
    }
}

/// ONNX classifiers and segmenters run by tract (feature `onnx`), scaled as their cards say
/// ([`crate::classify::InputScale::for_model`]).
#[cfg(feature = "onnx")]
#[derive(Debug, Clone, Copy, Default)]
pub struct TractRuntime;

#[cfg(feature = "onnx")]
impl ModelRuntime for TractRuntime {
    fn classifier(
        &self,
        path: &std::path::Path,
    ) -> Result<(Box<dyn crate::model::HandClassifier>, usize), crate::model::ModelError> {
        use crate::classify::{Classifier, InputScale};
        let net = Classifier::load(path, InputScale::for_model(path))?;
        let outputs = net.classes();
        Ok((Box::new(net), outputs))
    }

    fn segmenter(
        &self,
        path: &std::path::Path,
    ) -> Result<Box<dyn crate::model::PartSegmenter>, crate::model::ModelError> {
        use crate::classify::InputScale;
        use crate::segment::Segmenter;
        Ok(Box::new(Segmenter::load(path, InputScale::for_model(path))?))
    }
}
