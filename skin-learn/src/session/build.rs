//! Building a session from its configuration: the files it names read, the models loaded (with
//! feature `onnx`, or brought by the caller), the links' maps made or read from the cache.

use super::{ConfigError, Session, SessionConfig, SessionError, SessionOptions, Stitching};
use crate::model::Models;
use crate::script::Script;
use crate::touch::TouchPipeline;
use skin_can::BusMap;
use skin_core::LinkSkin;
use skin_geom::TactileMap;
use std::path::{Path, PathBuf};

/// The files a configuration names, resolved against its folder.
struct Files {
    layout: PathBuf,
    busmap: Option<PathBuf>,
    truth: Option<PathBuf>,
    poses: Option<PathBuf>,
}

impl Session {
    /// The session of a configuration: reads the layout, the bus map, the models, the script and
    /// the poses it names, and makes (or reads from the cache) the links' tactile maps. Models
    /// need feature `onnx`: without it a configuration that names one is an error
    /// ([`ConfigError::NoModelRuntime`]; see [`Session::from_config_with_models`]).
    pub fn from_config(config: &SessionConfig) -> Result<Session, SessionError> {
        build(config, || load_models(config))
    }

    /// The session of a configuration with the caller's `models` ([`Models::none`]: touches are
    /// tracked, not decided); the configuration's `classifier` and `segmenter` are not read.
    /// The models must take images of the configuration's `image_size`.
    pub fn from_config_with_models(config: &SessionConfig, models: Models) -> Result<Session, SessionError> {
        build(config, || Ok(models))
    }
}

/// The session of a configuration, its models given by `models` once the skin's files are read.
fn build(
    config: &SessionConfig,
    models: impl FnOnce() -> Result<Models, ConfigError>,
) -> Result<Session, SessionError> {
    let files = resolve(config)?;
    let skin_core::format::Noted {
        value: links,
        notes: layout_notes,
    } = skin_geom::read_layout(&files.layout)?;
    let busmap = files.busmap.as_deref().map(BusMap::read).transpose()?;
    let maps = maps(config, &files.layout, &links)?;
    let stitching = match &files.poses {
        Some(p) => {
            let postures = skin_core::format::poses::Postures::read(p)?;
            Some(Stitching::new(&maps, postures, p)?)
        }
        None => None,
    };
    let models = models()?;
    let size = models.input_size()?;
    let (rows, cols) = config.image_size()?;
    if (size.rows, size.cols) != (rows, cols) && !models.is_none() {
        return Err(ConfigError::ImageSize {
            model: PathBuf::from("the models"),
            takes: (size.rows, size.cols),
            config: config.path.clone(),
            makes: (rows, cols),
        }
        .into());
    }
    let pipeline = TouchPipeline::new(maps, models, config.touch_options())?;
    let options = SessionOptions {
        baseline_frames: config.baseline.frames,
        polarity: config.baseline.polarity,
        gate: config.gate,
        frame_images: false,
    };
    let mut session = Session::new(links, pipeline, options)?.with_source(&config.path);
    if let Some(s) = stitching {
        session = session.with_stitching(s)?;
    }
    if let (Some(busmap), Some(busmap_path)) = (&busmap, &files.busmap) {
        session = session.with_can(busmap).map_err(|e| match e {
            SessionError::Can(skin_can::Error::NotInLayout { taxel }) => ConfigError::NotInLayout {
                busmap: busmap_path.clone(),
                layout: files.layout.clone(),
                taxel,
            }
            .into(),
            e => e,
        })?;
    }
    session.setup.layout_notes = layout_notes;
    if let Some(p) = &files.truth {
        session = session.with_script(Script::read(p)?);
    }
    Ok(session)
}

/// Every file the configuration names, resolved; an error for the first that does not exist.
fn resolve(config: &SessionConfig) -> Result<Files, ConfigError> {
    let files = config.inputs()?;
    let at =
        |field: &'static str, p: &Option<PathBuf>| p.as_deref().map(|p| config.resolve(field, p)).transpose();
    Ok(Files {
        layout: files[0].clone(),
        busmap: at("busmap", &config.busmap)?,
        truth: at("truth", &config.truth)?,
        poses: at("[stitch] poses", &config.stitch.as_ref().map(|s| s.poses.clone()))?,
    })
}

/// The links' tactile maps, from the cache or made (and cached), in layout order.
fn maps(config: &SessionConfig, layout: &Path, links: &[LinkSkin]) -> Result<Vec<TactileMap>, ConfigError> {
    let layout_bytes = std::fs::read(layout).map_err(|source| skin_core::Error::Io {
        path: layout.to_owned(),
        source,
    })?;
    let cache = skin_geom::MapCache::new(config.cache_dir());
    // Frames reach the pipeline in layout order: the cache gives maps that keep it.
    links
        .iter()
        .map(|l| {
            cache
                .map(&layout_bytes, l, &skin_geom::FlattenOptions::default())
                .map(|(map, _)| map)
                .map_err(|source| ConfigError::Map {
                    layout: layout.to_owned(),
                    link: l.name.clone(),
                    source,
                })
        })
        .collect()
}

/// The configuration's models, loaded with tract: the classifier (its classes from its card)
/// and the segmenter, each checked against the configuration's image size.
#[cfg(feature = "onnx")]
fn load_models(config: &SessionConfig) -> Result<Models, ConfigError> {
    use crate::card::ModelCard;
    use crate::classify::{Classifier, InputScale};
    use crate::model::Classes;
    use crate::segment::Segmenter;
    let at =
        |field: &'static str, p: &Option<PathBuf>| p.as_deref().map(|p| config.resolve(field, p)).transpose();
    let size = config.image_size()?;
    let check_size = |model: &Path, takes: (usize, usize)| {
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
    let Some(p) = at("classifier", &config.classifier)? else {
        let mut models = Models::none();
        if let Some(p) = at("segmenter", &config.segmenter)? {
            let net = Segmenter::load(&p, InputScale::for_model(&p))?;
            check_size(&p, net.input_size())?;
            models = models.with_segmenter(net);
        }
        return Ok(models);
    };
    let net = Classifier::load(&p, InputScale::for_model(&p))?;
    check_size(&p, net.input_size())?;
    let card = ModelCard::for_model(&p);
    let classes = Classes::for_outputs(card.as_ref(), net.classes()).map_err(|source| ConfigError::Card {
        card: ModelCard::path_for(&p),
        source,
    })?;
    let Some(classes) = classes else {
        return Err(ConfigError::UnnamedClasses {
            card: ModelCard::path_for(&p),
            model: p,
            classes: net.classes(),
        });
    };
    let mut models = Models::new(net, classes);
    if let Some(p) = at("segmenter", &config.segmenter)? {
        let net = Segmenter::load(&p, InputScale::for_model(&p))?;
        check_size(&p, net.input_size())?;
        models = models.with_segmenter(net);
    }
    Ok(models)
}

/// Without a model runtime, a configuration that names a model cannot run.
#[cfg(not(feature = "onnx"))]
fn load_models(config: &SessionConfig) -> Result<Models, ConfigError> {
    // Missing files are named first, as with the runtime.
    config.inputs()?;
    for (field, model) in [
        ("classifier", &config.classifier),
        ("segmenter", &config.segmenter),
    ] {
        if let Some(model) = model {
            return Err(ConfigError::NoModelRuntime {
                config: config.path.clone(),
                field,
                model: model.clone(),
            });
        }
    }
    Ok(Models::none())
}
