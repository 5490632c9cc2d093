//! The crate's error: every error of skin-learn's modules, so that a robot stack can `?` any of
//! them into one type. Each module keeps its own precise error ([`crate::dataset::DatasetError`],
//! the model, touch and session errors); this wraps them.

/// Any error of skin-learn.
///
/// ```
/// use std::path::Path;
///
/// // Two readers with their own errors, one `?` each.
/// fn samples(dir: &Path) -> skin_learn::Result<usize> {
///     let probes = skin_learn::calibration::ProbeDataset::read(&dir.join("probes.csv"))?;
///     let images = skin_learn::dataset::Dataset::read(dir)?;
///     Ok(probes.contacts.len() + images.entries.len())
/// }
/// let e = samples(Path::new("no-such-folder")).unwrap_err();
/// assert!(matches!(e, skin_learn::Error::Core(_)) && e.to_string().contains("probes.csv"));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or checking an input file (layouts, recordings, probe datasets).
    #[error(transparent)]
    Core(#[from] skin_core::Error),
    /// Maps, meshes and images.
    #[error(transparent)]
    Geom(#[from] skin_geom::Error),
    /// Datasets on disk.
    #[error(transparent)]
    Dataset(#[from] crate::dataset::DatasetError),
    /// Models and their inputs.
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    /// The per-frame touch pipeline.
    #[error(transparent)]
    Touch(#[from] crate::touch::TouchError),
    /// The synthetic full arm (`synth::arm`).
    #[error(transparent)]
    Arm(#[from] crate::synth::arm::ArmError),
    /// A session: its configuration, its inputs, its frames (boxed: it is the largest).
    #[error(transparent)]
    Session(Box<crate::session::SessionError>),
}

/// `Result` with skin-learn's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<crate::session::SessionError> for Error {
    fn from(e: crate::session::SessionError) -> Self {
        Error::Session(Box::new(e))
    }
}
