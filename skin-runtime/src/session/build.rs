//! Building a session from its configuration: the files it names read, the models opened
//! (`models.rs`), the links' maps made or read from the cache; and from code.

use super::models::load_models;
use super::{
    ConfigError, ModelRuntime, OwnModels, Session, SessionConfig, SessionError, SessionSettings, Stitching,
};
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
    urdf: Option<PathBuf>,
    force: Option<PathBuf>,
}

impl Session {
    /// The session of a configuration with the caller's `models` ([`Models::none`]: touches are
    /// tracked, not decided); the configuration's `classifier` and `segmenter` are not read.
    /// The models must take images of the configuration's `image_size`.
    pub fn from_config_with_models(config: &SessionConfig, models: Models) -> Result<Session, SessionError> {
        build(config, || Ok(models))
    }

    /// The session of a configuration: reads the layout, the bus map, the script and the poses
    /// it names, makes (or reads from the cache) the links' tactile maps, and opens the models it
    /// names with `runtime` where the caller's `own` brings none of the kind (a classifier given
    /// replaces the configuration's, its classes named as [`OwnModels::classes`] says; a
    /// segmenter the configuration's). Without a runtime, a configuration that names a model
    /// `own` does not replace is [`ConfigError::NoModelRuntime`]. skin-learn's `FromConfig`
    /// calls this with its tract runtime.
    pub fn from_config_with_runtime(
        config: &SessionConfig,
        own: OwnModels,
        runtime: Option<&dyn ModelRuntime>,
    ) -> Result<Session, SessionError> {
        build(config, || load_models(config, own, runtime))
    }

    /// A session over `links` and their tactile `maps` (layout order) with `models`, run as
    /// `settings` say: the one builder every session goes through (from a configuration too).
    /// The settings are checked ([`SessionSettings::check`]), the models must take images of
    /// `settings.image_size`, and the gate may name only the classifier's classes.
    ///
    /// ```
    /// # use skin_core::{LinkSkin, Taxel, TaxelId};
    /// # use nalgebra::{Point3, Unit, Vector3};
    /// use skin_runtime::model::Models;
    /// use skin_runtime::session::{Session, SessionSettings};
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
    /// # Ok::<(), skin_runtime::session::SessionError>(())
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
    let (stitching, kinematics) = stitching(config, &files, &maps, &links)?;
    let settings = config.settings()?;
    let mut session = Session::with_settings(links, maps, models()?, &settings)
        .map_err(|e| in_config(config, e))?
        .with_source(&config.path);
    if let Some(s) = stitching {
        session = session.with_stitching(s)?;
        // Stitched at the middle of the joints' limits for want of a poses file: a posture to
        // draw the maps at, not where the robot is.
        session.setup.posed_by_file = files.poses.is_some();
    }
    if let Some((chain, max_age)) = kinematics {
        session = session.with_kinematics(chain, max_age)?;
    }
    if let Some(p) = &files.force {
        let calibration = skin_core::format::force_file::ForceCalibration::read(p)?;
        session = session.with_force(&calibration, p)?;
    }
    // A force limit on a link that cannot be weighed would never stop the arm there.
    if settings.gate.as_ref().is_some_and(|g| !g.force_n.is_empty()) {
        let unweighed: Vec<&str> = (session.weighed().iter().zip(session.links()))
            .filter(|(w, _)| !**w)
            .map(|(_, l)| l.name.as_str())
            .collect();
        if !unweighed.is_empty() {
            return Err(ConfigError::Value {
                file: config.path.clone(),
                field: "[gate] force_n",
                value: format!("(links without a force calibration: {})", unweighed.join(", ")),
                expected: "a force calibration ([force]) of every link, so that a touch anywhere is weighed against its limit",
            }
            .into());
        }
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
    session.setup.simulated = config.sim.is_some();
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

/// The stitching a configuration's `[stitch]` asks for, at the poses file's postures or (with
/// only a URDF) at the middle of the joints' limits, and the chain's kinematics with a URDF.
type Kinematics = (skin_control::Chain, std::time::Duration);

fn stitching(
    config: &SessionConfig,
    files: &Files,
    maps: &[TactileMap],
    links: &[LinkSkin],
) -> Result<(Option<Stitching>, Option<Kinematics>), SessionError> {
    let kinematics = match (&files.urdf, &config.stitch) {
        (Some(urdf), Some(stitch)) => Some(kinematics(urdf, stitch, links)?),
        _ => None,
    };
    let stitching = match (&files.poses, &kinematics) {
        // One link has nothing to stitch: with a URDF, its joint states still place it (its
        // contacts are given in the base frame too).
        (None, Some(_)) if links.len() < 2 => None,
        (Some(p), _) => {
            let postures = skin_core::format::poses::Postures::read(p)?;
            Some(Stitching::new(maps, postures, p)?)
        }
        (None, Some((chain, _))) => {
            let urdf = files.urdf.as_deref().unwrap_or(Path::new("[stitch] urdf"));
            Some(Stitching::new(
                maps,
                reference_posture(chain, links, urdf)?,
                urdf,
            )?)
        }
        (None, None) if config.stitch.is_some() => {
            return Err(ConfigError::Value {
                file: config.path.clone(),
                field: "[stitch]",
                value: "(neither poses nor urdf)".into(),
                expected: "poses (a skin-poses/1 file) or urdf (the robot, for its joint states), or both",
            }
            .into());
        }
        (None, None) => None,
    };
    Ok((stitching, kinematics))
}

/// The chain of the stitched links in `urdf`, from `[stitch] base` (or the first layout link)
/// to the last layout link, and how old a posture may be.
fn kinematics(
    urdf: &Path,
    stitch: &super::StitchConfig,
    links: &[LinkSkin],
) -> Result<Kinematics, ConfigError> {
    let first = links.first().map_or("", |l| l.name.as_str());
    let last = links.last().map_or("", |l| l.name.as_str());
    let base = stitch.base.as_deref().unwrap_or(first);
    let chain = skin_control::Chain::from_urdf(urdf, base, last).map_err(|e| ConfigError::Kinematics {
        why: format!("{}: {e}", urdf.display()),
    })?;
    // A single link is its own base by default: no joint between, nothing a joint state moves.
    if chain.dof() == 0 {
        return Err(ConfigError::Kinematics {
            why: format!(
                "{}: no joint from {base:?} to {last:?}, so no joint state can place the skin: set [stitch] base to a link above it (the robot's base link)",
                urdf.display()
            ),
        });
    }
    let max_age = stitch.max_age_s.unwrap_or(super::config::DEFAULT_MAX_AGE_S);
    if !(max_age > 0.0 && max_age <= 3600.0) {
        return Err(ConfigError::Kinematics {
            why: format!("max_age_s = {max_age}: seconds above 0, at most 3600"),
        });
    }
    Ok((chain, std::time::Duration::from_secs_f64(max_age)))
}

/// The posture a chain is stitched at before its first joint state: every joint in the middle
/// of its limits (0 where unlimited), which also sets each joint's boundary taxels.
fn reference_posture(
    chain: &skin_control::Chain,
    links: &[LinkSkin],
    urdf: &Path,
) -> Result<skin_core::format::poses::Postures, ConfigError> {
    let q: Vec<f64> = chain
        .joints()
        .iter()
        .map(|j| match j.limits {
            (lo, hi) if lo.is_finite() && hi.is_finite() => 0.5 * (lo + hi),
            _ => 0.0,
        })
        .collect();
    let wrong = |e: skin_control::KinematicsError| ConfigError::Kinematics {
        why: format!("{}: {e}", urdf.display()),
    };
    let posture = chain.posture(&q).map_err(wrong)?;
    let poses = links
        .iter()
        .map(|l| posture.link_pose(&l.name))
        .collect::<Result<Vec<_>, _>>()
        .map_err(wrong)?;
    Ok(skin_core::format::poses::Postures {
        links: links.iter().map(|l| l.name.clone()).collect(),
        postures: vec![skin_core::format::poses::Posture {
            name: "the joint limits' middle".into(),
            time_s: 0.0,
            poses,
        }],
    })
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
        poses: at(
            "[stitch] poses",
            &config.stitch.as_ref().and_then(|s| s.poses.clone()),
        )?,
        urdf: at(
            "[stitch] urdf",
            &config.stitch.as_ref().and_then(|s| s.urdf.clone()),
        )?,
        force: at(
            "[force] calibration",
            &config.force.as_ref().map(|f| f.calibration.clone()),
        )?,
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
