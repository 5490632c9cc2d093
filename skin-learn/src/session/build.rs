//! Building a session from its configuration: the files it names read, the models loaded (with
//! feature `onnx`, or brought by the caller), the links' maps made or read from the cache.

use super::{ConfigError, Session, SessionConfig, SessionError, SessionSettings, Stitching};
use crate::card::ModelCard;
use crate::model::{Classes, HandClassifier, ModelError, Models, PartSegmenter};
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

/// Models a caller brings in place of those a configuration names (a robot stack's own, a
/// binding's callables): each kind given replaces the configuration's, and the configuration's
/// files give the others ([`Session::from_config_with_own`]); or, with no configuration, the
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

impl Session {
    /// The session of a configuration: reads the layout, the bus map, the models, the script and
    /// the poses it names, and makes (or reads from the cache) the links' tactile maps. Models
    /// need feature `onnx`: without it a configuration that names one is an error
    /// ([`ConfigError::NoModelRuntime`]; see [`Session::from_config_with_models`]).
    pub fn from_config(config: &SessionConfig) -> Result<Session, SessionError> {
        build(config, || load_models(config, OwnModels::default()))
    }

    /// The session of a configuration with the caller's `models` ([`Models::none`]: touches are
    /// tracked, not decided); the configuration's `classifier` and `segmenter` are not read.
    /// The models must take images of the configuration's `image_size`.
    pub fn from_config_with_models(config: &SessionConfig, models: Models) -> Result<Session, SessionError> {
        build(config, || Ok(models))
    }

    /// The session of a configuration whose models the caller's `own` replace, each kind on its
    /// own: a classifier given replaces the configuration's (its classes named as
    /// [`OwnModels::classes`] says), a segmenter the configuration's; the configuration's files
    /// give the rest.
    pub fn from_config_with_own(config: &SessionConfig, own: OwnModels) -> Result<Session, SessionError> {
        build(config, || load_models(config, own))
    }

    /// A session over `links` and their tactile `maps` (layout order) with `models`, run as
    /// `settings` say: the one builder every session goes through (from a configuration too).
    /// The settings are checked ([`SessionSettings::check`]), the models must take images of
    /// `settings.image_size`, and the gate may name only the classifier's classes.
    ///
    /// ```
    /// # use skin_core::{LinkSkin, Taxel, TaxelId};
    /// # use nalgebra::{Point3, Unit, Vector3};
    /// use skin_learn::model::Models;
    /// use skin_learn::session::{Session, SessionSettings};
    /// # let taxels = (0..100u32).map(|i| Taxel {
    /// #     id: TaxelId(i),
    /// #     position: Point3::new(f64::from(i % 10) * 0.005, f64::from(i / 10) * 0.005, 0.0),
    /// #     normal: Unit::new_normalize(Vector3::z()),
    /// # }).collect();
    /// let patch = LinkSkin::new("patch", taxels);
    /// // run.toml's defaults, but a firmer press.
    /// let mut settings = SessionSettings::default();
    /// settings.touch.threshold = 20.0;
    /// let session = Session::from_links(vec![patch], Models::none(), &settings)?;
    /// assert_eq!(session.settings(), Some(&settings));
    /// assert_eq!(session.pipeline().options().threshold, 20.0);
    /// # Ok::<(), skin_learn::session::SessionError>(())
    /// ```
    pub fn with_settings(
        links: Vec<LinkSkin>,
        maps: Vec<TactileMap>,
        models: Models,
        settings: &SessionSettings,
    ) -> Result<Session, SessionError> {
        settings.check()?;
        let takes = models.input_size()?;
        if takes != settings.image_size && !models.is_none() {
            return Err(SessionError::ImageSize {
                takes,
                makes: settings.image_size,
            });
        }
        // Without a classifier the classes are hand / non_hand (what one brought later takes):
        // a gate naming others would never act.
        settings.check_gate(models.classes())?;
        let pipeline = TouchPipeline::new(maps, models, settings.touch_options())?;
        let mut session = Session::new(links, pipeline, settings.session_options())?;
        session.setup.settings = Some(settings.clone());
        Ok(session)
    }

    /// [`Session::with_settings`] over `links` flattened into tactile maps with the default
    /// options (as a configuration's are, without its cache).
    pub fn from_links(
        links: Vec<LinkSkin>,
        models: Models,
        settings: &SessionSettings,
    ) -> Result<Session, SessionError> {
        // Settings out of bounds cost no flattening.
        settings.check()?;
        let maps = links
            .iter()
            .map(|l| TactileMap::flatten(l, &skin_geom::FlattenOptions::default()))
            .collect::<Result<Vec<_>, _>>()?;
        Session::with_settings(links, maps, models, settings)
    }
}

/// The session of a configuration, its models given by `models` once the skin's files are read.
fn build(
    config: &SessionConfig,
    models: impl FnOnce() -> Result<Models, SessionError>,
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
    let settings = config.settings()?;
    let mut session = Session::with_settings(links, maps, models()?, &settings)
        .map_err(|e| in_config(config, e))?
        .with_source(&config.path);
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

/// A builder's error as the configuration's: a setting, or the models' image size, named with
/// the file.
fn in_config(config: &SessionConfig, e: SessionError) -> SessionError {
    match e {
        SessionError::Setting(source) => ConfigError::Setting {
            file: config.path.clone(),
            source,
        }
        .into(),
        SessionError::ImageSize { takes, makes } => ConfigError::ImageSize {
            model: PathBuf::from("the models"),
            takes,
            config: config.path.clone(),
            makes,
        }
        .into(),
        e => e,
    }
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

/// The configuration's models, loaded with tract where `own` brings none of the kind: the
/// classifier (its classes from its card) and the segmenter, each checked against the
/// configuration's image size.
#[cfg(feature = "onnx")]
fn load_models(config: &SessionConfig, own: OwnModels) -> Result<Models, SessionError> {
    use crate::classify::{Classifier, InputScale};
    use crate::segment::Segmenter;
    use skin_core::image::ImageSize;
    let at =
        |field: &'static str, p: &Option<PathBuf>| p.as_deref().map(|p| config.resolve(field, p)).transpose();
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
    let classifier = at("classifier", &config.classifier)?;
    let mut models = match (own.classifier.is_some(), classifier) {
        (true, replaced) => {
            let classes = own.classes(replaced.as_deref())?;
            Models {
                classifier: own.classifier,
                segmenter: None,
                classes,
            }
        }
        (false, Some(p)) => {
            let net = Classifier::load(&p, InputScale::for_model(&p)).map_err(ConfigError::Model)?;
            check_size(&p, net.input_size())?;
            let classes = card_classes(&p, net.classes())?;
            Models::new(net, classes)
        }
        (false, None) => Models::none(),
    };
    match (own.segmenter, at("segmenter", &config.segmenter)?) {
        (Some(own), _) => models.segmenter = Some(own),
        (None, Some(p)) => {
            let net = Segmenter::load(&p, InputScale::for_model(&p)).map_err(ConfigError::Model)?;
            check_size(&p, net.input_size())?;
            models = models.with_segmenter(net);
        }
        (None, None) => {}
    }
    Ok(models)
}

/// The classes of the classifier `model` of `outputs` outputs, from its card
/// ([`Classes::for_outputs`]); an error when they cannot be named.
#[cfg(feature = "onnx")]
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

/// Without a model runtime, a configuration that names a model `own` does not replace cannot
/// run.
#[cfg(not(feature = "onnx"))]
fn load_models(config: &SessionConfig, own: OwnModels) -> Result<Models, SessionError> {
    // Missing files are named first, as with the runtime.
    config.inputs()?;
    for (field, model, replaced) in [
        ("classifier", &config.classifier, own.classifier.is_some()),
        ("segmenter", &config.segmenter, own.segmenter.is_some()),
    ] {
        if let (Some(model), false) = (model, replaced) {
            return Err(ConfigError::NoModelRuntime {
                config: config.path.clone(),
                field,
                model: model.clone(),
            }
            .into());
        }
    }
    let replaced = config
        .classifier
        .as_deref()
        .map(|p| config.resolve("classifier", p))
        .transpose()?;
    let classes = match own.classifier {
        Some(_) => own.classes(replaced.as_deref())?,
        None => Classes::hand_or_not(),
    };
    Ok(Models {
        classifier: own.classifier,
        segmenter: own.segmenter,
        classes,
    })
}
