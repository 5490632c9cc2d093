//! What can go wrong, by concern: building a session from its configuration ([`ConfigError`]),
//! feeding it an input that does not fit ([`InputError`]), and anything while it runs
//! ([`SessionError`], which carries the other two).

use super::settings::SettingError;
use crate::model::ModelError;
use crate::touch::TouchError;
use skin_core::image::ImageSize;
use std::path::PathBuf;

/// A configuration that cannot be used: its text, its values, the files it names, the models.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The configuration is not valid TOML, or has a key it does not know.
    #[error("{}:{} {message}", file.display(), line.map_or(String::new(), |l| format!(" line {l}:")))]
    Syntax {
        /// The configuration.
        file: PathBuf,
        /// The line at fault, when known.
        line: Option<usize>,
        /// What is wrong (at most 200 characters).
        message: String,
    },
    /// A configuration value out of its range.
    #[error("{}: {field} = {value}: expected {expected}", file.display())]
    Value {
        /// The configuration.
        file: PathBuf,
        /// The key.
        field: &'static str,
        /// Its value (the first 40 characters).
        value: String,
        /// The range, in words.
        expected: &'static str,
    },
    /// A setting (`image_size`, `[baseline]`, `[touch]`, `[gate]`) out of its bounds, or a
    /// `[gate]` class the classifier does not have.
    #[error("{}: {source}", file.display())]
    Setting {
        /// The configuration.
        file: PathBuf,
        /// The setting and what it takes.
        #[source]
        source: SettingError,
    },
    /// A file the configuration names does not exist.
    #[error("{}: {field} = \"{}\": no such file ({})", config.display(), path.display(), resolved.display())]
    NoFile {
        /// The configuration.
        config: PathBuf,
        /// The key.
        field: &'static str,
        /// The path as written.
        path: PathBuf,
        /// The path resolved against the configuration's folder.
        resolved: PathBuf,
    },
    /// The bus map carries a taxel the layout lacks.
    #[error("{}: taxel {taxel} is not in the layout {}; is the bus map for this skin?", busmap.display(), layout.display())]
    NotInLayout {
        /// The bus map.
        busmap: PathBuf,
        /// The layout.
        layout: PathBuf,
        /// The taxel.
        taxel: skin_core::TaxelId,
    },
    /// A model takes images of another size than the configuration makes.
    #[error("{}: takes {} x {} images; {} makes {} x {} (image_size): a model for another image size",
        model.display(), takes.rows, takes.cols, config.display(), makes.rows, makes.cols)]
    ImageSize {
        /// The model.
        model: PathBuf,
        /// Its input.
        takes: ImageSize,
        /// The configuration.
        config: PathBuf,
        /// The configuration's image size.
        makes: ImageSize,
    },
    /// A classifier of more than two classes without a model card naming them.
    #[error("{}: {classes} classes and no model card naming them ({})", model.display(), card.display())]
    UnnamedClasses {
        /// The model.
        model: PathBuf,
        /// Its outputs.
        classes: usize,
        /// Where its card would be.
        card: PathBuf,
    },
    /// A classifier's model card is inconsistent.
    #[error("{}: {source}", card.display())]
    Card {
        /// The card.
        card: PathBuf,
        /// What is wrong.
        source: ModelError,
    },
    /// A link's map cannot be made.
    #[error("{}: link {link}: {source}", layout.display())]
    Map {
        /// The layout.
        layout: PathBuf,
        /// The link.
        link: String,
        /// Why.
        source: skin_geom::Error,
    },
    /// The poses name other links than the layout.
    #[error("{}: links {got:?}, but the layout has {layout:?} (same names, same order)", poses.display())]
    PoseLinks {
        /// The poses file.
        poses: PathBuf,
        /// Its links.
        got: Vec<String>,
        /// The layout's links.
        layout: Vec<String>,
    },
    /// Joint states asked for without the chain's kinematics.
    #[error(
        "joint states need the chain's kinematics: give [stitch] urdf (a URDF whose links are the layout's) in the configuration"
    )]
    NoKinematics,
    /// The URDF does not give the stitched links' poses.
    #[error("[stitch] urdf: {why}")]
    Kinematics {
        /// What is wrong.
        why: String,
    },
    /// The poses file has no posture.
    #[error("{}: no posture", poses.display())]
    NoPosture {
        /// The poses file.
        poses: PathBuf,
    },
    /// The links cannot be stitched at a posture.
    #[error("{}: posture \"{posture}\": {source}", poses.display())]
    Stitch {
        /// The poses file.
        poses: PathBuf,
        /// The posture.
        posture: String,
        /// Why.
        source: skin_geom::Error,
    },
    /// The configuration names a model, and the session was built without a model runtime
    /// (skin-learn's feature `onnx` off, or none given to
    /// [`Session::from_config_with_runtime`](super::Session::from_config_with_runtime)): give
    /// one, or bring the models ([`Session::from_config_with_models`](super::Session::from_config_with_models)).
    #[error("{}: {field} = \"{}\": this build has no model runtime (feature onnx); remove the line, or build with it", config.display(), model.display())]
    NoModelRuntime {
        /// The configuration.
        config: PathBuf,
        /// The key.
        field: &'static str,
        /// The model as written.
        model: PathBuf,
    },
    /// Reading a file the configuration names.
    #[error(transparent)]
    Read(#[from] skin_core::Error),
    /// Maps and stitching of the configuration's skin.
    #[error(transparent)]
    Geom(#[from] skin_geom::Error),
    /// A model it names cannot be used.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// An input that does not fit the session: another skin's log, too short, no bus map.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// None of the bus map's interfaces is in a log.
    #[error("{}: none of the bus map's interfaces ({}) is in the log (it has {}); is it a log of this skin?",
        log.display(), on_map.join(", "), in_log.join(", "))]
    OtherBuses {
        /// The log.
        log: PathBuf,
        /// The bus map's interfaces.
        on_map: Vec<String>,
        /// The log's.
        in_log: Vec<String>,
    },
    /// A log gave no skin frames, or mostly frames of modules the bus map lacks.
    #[error("{}: {frames} skin frames from {can_frames} CAN frames ({unknown} from modules the bus map lacks, {malformed} malformed for {format}, {ignored} not skin data); is it a log of this skin and bus map?", log.display())]
    NotThisSkin {
        /// The log.
        log: PathBuf,
        /// Skin frames assembled.
        frames: u64,
        /// CAN frames in the log.
        can_frames: usize,
        /// From modules the bus map lacks.
        unknown: u64,
        /// Malformed for the wire format.
        malformed: u64,
        /// The wire format.
        format: &'static str,
        /// Not skin traffic.
        ignored: u64,
    },
    /// CAN frames given to a session built without a bus map.
    #[error("CAN frames, but the session has no bus map (build it with Session::with_can)")]
    NoBusMap,
    /// The input ended before the baseline was learned.
    #[error(
        "the input ended after {frames} frame(s), before the {needed} complete untouched frames the baseline needs"
    )]
    TooShort {
        /// Frames seen.
        frames: u64,
        /// Complete untouched frames needed.
        needed: usize,
    },
    /// A recording has none of the layout's taxels among its columns.
    #[error("{}: none of the layout's {taxels} taxels is among the recording's {columns} columns; is it a recording of this skin?", recording.display())]
    NotRecorded {
        /// The recording.
        recording: PathBuf,
        /// Taxels of the layout.
        taxels: usize,
        /// Columns of the recording.
        columns: usize,
    },
}

/// What can go wrong building or running a [`Session`](crate::session::Session).
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The pipeline and the links it was given do not match.
    #[error("the touch pipeline has links {pipeline:?}, the session's links are {links:?}")]
    Links {
        /// The pipeline's links.
        pipeline: Vec<String>,
        /// The session's.
        links: Vec<String>,
    },
    /// A setting of a session built from code out of its bounds (named as run.toml spells it),
    /// or a gate class the classifier does not have.
    #[error(transparent)]
    Setting(#[from] SettingError),
    /// The names a caller gave the scores of its own classifier do not fit (`field`: `"classes"`
    /// or `"hand"`, the names given).
    #[error("{field}: {source}")]
    Names {
        /// Which names: `"classes"` or `"hand"`.
        field: &'static str,
        /// What is wrong with them.
        #[source]
        source: ModelError,
    },
    /// The models take images of another size than the settings make.
    #[error(
        "the models take {takes} images; the session makes {makes} (image_size): models for another image size"
    )]
    ImageSize {
        /// The models' input.
        takes: ImageSize,
        /// The settings' image size.
        makes: ImageSize,
    },
    /// A frame of readings does not fit the skin.
    #[error("frame at {time:.3} s: {source}")]
    Frame {
        /// Frame time, s.
        time: f64,
        /// What does not fit.
        source: skin_core::Error,
    },
    /// The configuration, or a file it names (boxed: the largest).
    #[error(transparent)]
    Config(Box<ConfigError>),
    /// An input (a candump log, a recording, frames) that does not fit the session (boxed).
    #[error(transparent)]
    Input(Box<InputError>),
    /// A sink failed to take an event or an image (the sink's own error inside).
    #[error("cannot write the session's output: {0}")]
    Sink(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// Reading or checking an input file.
    #[error(transparent)]
    Core(#[from] skin_core::Error),
    /// Maps, meshes and images.
    #[error(transparent)]
    Geom(#[from] skin_geom::Error),
    /// CAN traffic and bus maps.
    #[error(transparent)]
    Can(#[from] skin_can::Error),
    /// A model.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The touch pipeline.
    #[error(transparent)]
    Touch(#[from] TouchError),
}

impl From<ConfigError> for SessionError {
    fn from(e: ConfigError) -> Self {
        SessionError::Config(Box::new(e))
    }
}

impl From<InputError> for SessionError {
    fn from(e: InputError) -> Self {
        SessionError::Input(Box::new(e))
    }
}
