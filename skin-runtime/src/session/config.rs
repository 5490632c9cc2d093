//! A session's configuration: the TOML file `skin run` takes (`run.toml`), typed and checked.
//! Paths in it are relative to the file. [`SessionConfig::parse`] checks every value; the files
//! are read when a [`Session`](super::Session) is built from it
//! ([`Session::from_config_with_runtime`](super::Session::from_config_with_runtime)).
//! The settings that are not files (`image_size`, `[baseline]`, `[touch]`, `[gate]`) are a
//! [`SessionSettings`], whose defaults and bounds these are; the defaults below are theirs.
//!
//! ```toml
//! layout = "layout.json"          # the skin: every link of a skin-layout/1 file
//! busmap = "busmap.toml"          # which taxel each CAN slot carries (CAN input only)
//! classifier = "handsnet.onnx"    # optional; class names and input scale from its card
//! segmenter = "handseg.onnx"      # optional: hand parts of touches classified as hands
//! image_size = "68x100"           # the models' input; default 68x100
//! cache = ".skin-cache"           # tactile maps, made on first use; default as shown
//! truth = "session.tsv"           # optional: the scripted touches, to score the run
//! [baseline]
//! frames = 20                     # untouched frames at the start that learn offsets and
//!                                 # noise (a taxel reads pressure only beyond 6 standard
//!                                 # deviations of its idle readings, or of the link's
//!                                 # 90th-percentile taxel's when larger)
//! polarity = "rising"             # "falling" for iCub (255 = no load)
//! [touch]
//! threshold = 5.0                 # counts above the baseline (and the noise) that press
//! min_taxels = 2
//! decide_frames = 3               # frames of contact before the first decision
//! release_frames = 2              # frames without contact that end a touch
//! reclassify_growth = 1.25        # classify again when the touch grows by this factor
//! contacts = "peaks"              # a patch splits between pressure peaks (fingers side by
//!                                 # side); "connected": a patch is one contact (thesis 3.2)
//! [touch.split]                   # the peaks rule's parameters, defaults as shown:
//! min_dip = 0.5                   # the pressure falls by half between two peaks...
//! min_distance_mm = 12            # ...at least 12 mm apart (else one contact)
//! [gate]                          # optional: what the robot should do, per class of the
//! hand = "comply"                 # classifier (its model card's names): stop, comply,
//! non_hand = "stop"               # slow or resume
//! border = { within_mm = 15, hand_below = 0.95, action = "stop" }
//!                                 # optional: a hand less sure than hand_below whose taxels
//!                                 # come within within_mm of the skin's border gets action
//!                                 # (`border` is this rule's key, never a class's)
//! force_n = { hand = 140, non_hand = 65 }
//!                                 # optional, needs [force] on every link: a touch of the
//!                                 # class pressing harder (newtons, its contacts summed; a
//!                                 # reading past saturation counts as harder) stops the arm
//!                                 # until it is released, its force named in the gate event
//!                                 # (as ISO/TS 15066's quasi-static limits per body region);
//!                                 # no limit by default (`force_n` is never a class's)
//! [stitch]                        # optional: links stitched across joints (Ch. 6)
//! poses = "poses.json"            # skin-poses/1: every link's pose over time, and/or
//! urdf = "arm.urdf"               # the robot, for its joint states (skin run --joint-states)
//! base = "forearm"                # contacts across joints in this URDF link (default: the
//!                                 # first layout link)
//! max_age_s = 0.5                 # a joint state this old when a frame comes is stale
//! [force]                         # optional: newtons from counts (skin calibrate-force)
//! calibration = "force.json"      # skin-force/1: per link, the response curve and gains;
//!                                 # contacts then carry force_n and links a wrench
//! [sim]                           # optional: how a simulated skin answers (Python's
//!                                 # skin.sim, MuJoCo); defaults as shown, see SimConfig
//! frame_rate_hz = 20.0            # frames a second the skin delivers
//! cover_mm = 2.5                  # the elastic cover the load crosses to the taxels
//! half_scale_kpa = 150.0          # stress at which a taxel of gain 1 reads rest + half of
//! full_scale = 4095.0             # full scale, the counts it nears under a load it cannot take
//! gain_spread = 0.15              # each taxel's gain drawn in 1 +- this
//! rest = 200.0                    # counts at rest (pressure moves away from it)...
//! rest_spread = 20.0              # ...different per taxel by up to this
//! noise = 1.0                     # counts (standard deviation), every frame
//! dead = []                       # taxel ids that never answer (they read their rest)
//! missing_modules = []            # "can0:5": modules that stop delivering after the baseline
//! dropout = 0.0                   # chance a module's data is lost in a frame
//! seed = 1                        # gains, rests and noise are drawn from it
//! ```

use super::ConfigError;
use super::settings::{BaselineConfig, SessionSettings, TouchConfig};
use crate::touch::TouchOptions;
use serde::Deserialize;
use skin_control::hri::ClassGate;
use skin_core::image::ImageSize;
use std::path::{Path, PathBuf};

/// A session's configuration (see the `session::config` module for the file).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionConfig {
    /// The skin: a skin-layout/1 file (all its links), or one link's Cyskin or iCub file.
    pub layout: PathBuf,
    /// The bus map: which taxel each CAN slot carries (needed for CAN input only).
    pub busmap: Option<PathBuf>,
    /// The hand / non-hand classifier (ONNX); its card names the classes.
    pub classifier: Option<PathBuf>,
    /// The hand-part segmenter (ONNX), run on touches classified as hands.
    pub segmenter: Option<PathBuf>,
    /// The models' input, `ROWSxCOLS`; default `68x100`.
    pub image_size: Option<String>,
    /// Folder of cached tactile maps; default `.skin-cache`.
    pub cache: Option<PathBuf>,
    /// Scripted touches to score the session against.
    pub truth: Option<PathBuf>,
    /// How the baseline is learned.
    #[serde(default)]
    pub baseline: BaselineConfig,
    /// Touch tracking.
    #[serde(default)]
    pub touch: TouchConfig,
    /// What the robot does for each class of touch.
    pub gate: Option<ClassGate>,
    /// Links stitched across joints.
    pub stitch: Option<StitchConfig>,
    /// Force in newtons, for the links a calibration covers.
    pub force: Option<ForceConfig>,
    /// How a simulated skin answers (Python's `skin.sim`); the session itself does not read it.
    pub sim: Option<SimConfig>,
    /// The file this came from; paths are relative to its folder.
    #[serde(skip)]
    pub path: PathBuf,
}

/// `[stitch]`: the links' poses from a file over time, or from the robot's joint states
/// through its URDF (or both: the file's until the first joint state).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StitchConfig {
    /// Link poses over time (skin-poses/1), links in the layout's order.
    pub poses: Option<PathBuf>,
    /// The robot's URDF: its links named as the layout's, the chain from the first layout link
    /// (or `base`) to the last; joint states (`skin run --joint-states`) place the links.
    pub urdf: Option<PathBuf>,
    /// The URDF link contacts across joints are given in (default: the first layout link).
    pub base: Option<String>,
    /// A joint state older than this when a frame comes is stale (an event; its posture
    /// holds), seconds; default [`DEFAULT_MAX_AGE_S`].
    pub max_age_s: Option<f64>,
}

/// How old a joint state may be when a frame comes, by default, seconds.
pub const DEFAULT_MAX_AGE_S: f64 = 0.5;

/// `[force]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceConfig {
    /// A force calibration (skin-force/1, as `skin calibrate-force` writes it).
    pub calibration: PathBuf,
}

/// `[sim]`: the response model of a simulated skin, from the stress under each taxel to the
/// counts it reads (Python's `skin.sim` applies it to MuJoCo's contacts; see the module's table
/// for the defaults). The contact force is spread over the surface in proportion to how deep
/// each point is pressed (a Winkler bed) and carried down to the taxels by Boussinesq's
/// point-load stress through the cover's thickness; a taxel reads `rest + gain * full_scale * s / (s + half_scale)` of
/// stress `s` (a capacitive cell stiffens), plus noise, rounded, within 0 and full scale
/// (falling polarity: `rest` minus it).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// Frames a second the skin delivers (0.1 to 10,000).
    pub frame_rate_hz: f64,
    /// Thickness of the elastic cover over the taxels, millimetres (0.1 to 50).
    pub cover_mm: f64,
    /// Stress at which a taxel of gain 1 reads its rest plus half of full scale, kPa (0.01 to
    /// 1e6).
    pub half_scale_kpa: f64,
    /// The counts a taxel of gain 1 nears under a load it cannot take; readings stay within 0
    /// and this (1 to 65,535).
    pub full_scale: f64,
    /// Each taxel's gain is drawn uniformly in 1 +- this (0 to 0.9).
    pub gain_spread: f64,
    /// Counts at rest (0 to full scale).
    pub rest: f64,
    /// Rests differ from taxel to taxel by up to this many counts (0 to full scale).
    pub rest_spread: f64,
    /// Noise, counts (standard deviation, 0 to full scale).
    pub noise: f64,
    /// Taxel ids that never answer (they read their rest).
    pub dead: Vec<u32>,
    /// Modules that stop delivering once the session has its baseline, `INTERFACE:ADDRESS` as
    /// the bus map names them.
    pub missing_modules: Vec<String>,
    /// The chance that a module's data is lost in a frame (0 to 1).
    pub dropout: f64,
    /// Seed of the gains, rests, noise and dropouts.
    pub seed: u64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            frame_rate_hz: 20.0,
            cover_mm: 2.5,
            half_scale_kpa: 150.0,
            full_scale: 4095.0,
            gain_spread: 0.15,
            rest: 200.0,
            rest_spread: 20.0,
            noise: 1.0,
            dead: Vec::new(),
            missing_modules: Vec::new(),
            dropout: 0.0,
            seed: 1,
        }
    }
}

/// Each `[sim]` key: how errors name it and what it takes, in words (said once, by
/// [`SimConfig::check`] and [`SimConfig::set`] alike).
#[rustfmt::skip]
const SIM_KEYS: [(&str, &str); 12] = [
    ("[sim] frame_rate_hz", "frames a second from 0.1 to 10000"),
    ("[sim] cover_mm", "millimetres from 0.1 to 50"),
    ("[sim] half_scale_kpa", "kPa from 0.01 to 1e6"),
    ("[sim] full_scale", "counts from 1 to 65535"),
    ("[sim] gain_spread", "a fraction from 0 to 0.9"),
    ("[sim] rest", "counts from 0 to full_scale"),
    ("[sim] rest_spread", "counts from 0 to full_scale"),
    ("[sim] noise", "counts from 0 to full_scale"),
    ("[sim] dead", "a list of taxel ids, whole numbers from 0 to 4294967295"),
    ("[sim] missing_modules", "a list of modules, each INTERFACE:ADDRESS, e.g. [\"can0:5\"]"),
    ("[sim] dropout", "a probability from 0 to 1"),
    ("[sim] seed", "a whole number from 0 to 9223372036854775807"),
];

/// The `[sim]` keys, for an error about a key it does not have.
const SIM_KEY_NAMES: &str = "one of frame_rate_hz, cover_mm, half_scale_kpa, full_scale, gain_spread, \
     rest, rest_spread, noise, dead, missing_modules, dropout, seed";

impl SimConfig {
    /// Every number in its range, every module named `INTERFACE:ADDRESS`; `path` (or whatever
    /// gave the table) names it in errors.
    pub fn check(&self, path: &Path) -> Result<(), ConfigError> {
        let fs = self.full_scale.max(1.0);
        #[rustfmt::skip]
        let ranges = [
            ("frame_rate_hz", self.frame_rate_hz, 0.1, 10_000.0),
            ("cover_mm", self.cover_mm, 0.1, 50.0),
            ("half_scale_kpa", self.half_scale_kpa, 0.01, 1e6),
            ("full_scale", self.full_scale, 1.0, 65_535.0),
            ("gain_spread", self.gain_spread, 0.0, 0.9),
            ("rest", self.rest, 0.0, fs),
            ("rest_spread", self.rest_spread, 0.0, fs),
            ("noise", self.noise, 0.0, fs),
            ("dropout", self.dropout, 0.0, 1.0),
        ];
        for (key, v, lo, hi) in ranges {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(SimConfig::value_error(key, &v.to_string(), path));
            }
        }
        for m in &self.missing_modules {
            let ok = m
                .rsplit_once(':')
                .is_some_and(|(bus, address)| !bus.is_empty() && address.parse::<u32>().is_ok());
            if !ok {
                return Err(ConfigError::Value {
                    file: path.to_owned(),
                    field: "[sim] missing_modules",
                    value: m.chars().take(40).collect(),
                    expected: "INTERFACE:ADDRESS, e.g. \"can0:5\"",
                });
            }
        }
        Ok(())
    }

    /// Sets one key as a `[sim]` table in a file sets it (`key = value`; a binding converts its
    /// own values to TOML's). A key `[sim]` does not have, or a value of the wrong kind (text
    /// for a number, a number for a list), is an error that names the key and says what it
    /// takes; the value's range is [`SimConfig::check`]'s, left to it.
    pub fn set(&mut self, key: &str, value: toml::Value, origin: &Path) -> Result<(), ConfigError> {
        let shown = value.to_string();
        let mut table = toml::Table::new();
        table.insert(key.to_owned(), value);
        // Every other key takes its default: only `key` is copied over.
        let one: SimConfig = toml::Value::Table(table)
            .try_into()
            .map_err(|_| SimConfig::value_error(key, &shown, origin))?;
        match key {
            "frame_rate_hz" => self.frame_rate_hz = one.frame_rate_hz,
            "cover_mm" => self.cover_mm = one.cover_mm,
            "half_scale_kpa" => self.half_scale_kpa = one.half_scale_kpa,
            "full_scale" => self.full_scale = one.full_scale,
            "gain_spread" => self.gain_spread = one.gain_spread,
            "rest" => self.rest = one.rest,
            "rest_spread" => self.rest_spread = one.rest_spread,
            "noise" => self.noise = one.noise,
            "dead" => self.dead = one.dead,
            "missing_modules" => self.missing_modules = one.missing_modules,
            "dropout" => self.dropout = one.dropout,
            "seed" => self.seed = one.seed,
            _ => return Err(SimConfig::value_error(key, &shown, origin)),
        }
        Ok(())
    }

    /// The error for `key = shown` in a `[sim]` table from `origin`: what the key takes, or the
    /// keys there are when it is none of them. For a binding's values that have no TOML
    /// counterpart (Python's `None`), and [`SimConfig::set`]'s own.
    pub fn value_error(key: &str, shown: &str, origin: &Path) -> ConfigError {
        let clip = |text: &str| -> String { text.chars().take(40).collect() };
        match SIM_KEYS
            .iter()
            .find(|(field, _)| field.strip_prefix("[sim] ") == Some(key))
        {
            Some(&(field, expected)) => ConfigError::Value {
                file: origin.to_owned(),
                field,
                value: clip(shown),
                expected,
            },
            None => ConfigError::Value {
                file: origin.to_owned(),
                field: "[sim] key",
                value: clip(key),
                expected: SIM_KEY_NAMES,
            },
        }
    }
}

impl SessionConfig {
    /// Reads and checks a configuration file.
    pub fn read(path: &Path) -> Result<SessionConfig, ConfigError> {
        let text = skin_core::format::read_text(path)?;
        SessionConfig::parse(&text, path)
    }

    /// Parses and checks a configuration (not the files it names): every number in its range,
    /// every closed set one of its values. `path` names it in errors and anchors its paths.
    pub fn parse(text: &str, path: &Path) -> Result<SessionConfig, ConfigError> {
        // toml's own message quotes the whole line at fault, whatever its length: name the line
        // and say what is wrong instead.
        let mut config: SessionConfig = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text.get(..s.start).unwrap_or(text).matches('\n').count() + 1);
            // The message names the key and the allowed values; only a huge key makes it long.
            let message = e.message().trim_end();
            let mut short: String = message.chars().take(200).collect();
            if short.len() < message.len() {
                short.push_str("...");
            }
            ConfigError::Syntax {
                file: path.to_owned(),
                line,
                message: short,
            }
        })?;
        config.path = path.to_owned();
        config
            .settings()?
            .check()
            .map_err(|source| ConfigError::Setting {
                file: path.to_owned(),
                source,
            })?;
        if let Some(sim) = &config.sim {
            sim.check(path)?;
        }
        // A force limit with nothing to weigh a touch with would never stop the arm: refused
        // rather than trusted.
        if config.force.is_none()
            && let Some(class) = config.gate.as_ref().and_then(|g| g.force_n.keys().next())
        {
            return Err(ConfigError::Value {
                file: path.to_owned(),
                field: "[gate] force_n",
                value: format!("{{ {} = ... }}", class.chars().take(40).collect::<String>()),
                expected: "a force calibration to weigh touches with ([force] calibration = \"force.json\", \
                           made by skin calibrate-force): without one no touch has a force, and no limit could stop the arm",
            });
        }
        Ok(config)
    }

    /// The models' input size; [`ImageSize::MODEL_DEFAULT`] unless the file says.
    pub fn image_size(&self) -> Result<ImageSize, ConfigError> {
        let Some(s) = &self.image_size else {
            return Ok(ImageSize::MODEL_DEFAULT);
        };
        match s.parse::<ImageSize>() {
            Ok(size) => Ok(size),
            Err(_) => Err(ConfigError::Value {
                file: self.path.clone(),
                field: "image_size",
                value: s.chars().take(40).collect(),
                expected: super::settings::IMAGE_SIZE,
            }),
        }
    }

    /// Its settings: the image size, `[baseline]`, `[touch]` and `[gate]` as they are written,
    /// the defaults for the rest ([`SessionSettings::check`] checks them; [`SessionConfig::parse`]
    /// has).
    pub fn settings(&self) -> Result<SessionSettings, ConfigError> {
        Ok(SessionSettings {
            image_size: self.image_size()?,
            baseline: self.baseline,
            touch: self.touch,
            gate: self.gate.clone(),
        })
    }

    /// The touch options it gives ([`SessionSettings::touch_options`]).
    pub fn touch_options(&self) -> TouchOptions {
        SessionSettings {
            touch: self.touch,
            ..SessionSettings::default()
        }
        .touch_options()
    }

    /// A path of the configuration, resolved against its folder; `field` names it if the file
    /// is missing.
    pub fn resolve(&self, field: &'static str, p: &Path) -> Result<PathBuf, ConfigError> {
        let full = self.path.parent().unwrap_or(Path::new(".")).join(p);
        if full.is_dir() {
            return Err(ConfigError::Value {
                file: self.path.clone(),
                field,
                value: format!("\"{}\" ({})", p.display(), full.display()),
                expected: "a file, and this is a folder: name the file in it",
            });
        }
        if !full.is_file() {
            return Err(ConfigError::NoFile {
                config: self.path.clone(),
                field,
                path: p.to_owned(),
                resolved: full,
            });
        }
        Ok(full)
    }

    /// Every file the configuration names, resolved (no output may land on one); an error for
    /// the first that does not exist.
    pub fn inputs(&self) -> Result<Vec<PathBuf>, ConfigError> {
        let mut files = vec![self.resolve("layout", &self.layout)?];
        for (field, p) in [
            ("busmap", &self.busmap),
            ("classifier", &self.classifier),
            ("segmenter", &self.segmenter),
            ("truth", &self.truth),
            (
                "[stitch] poses",
                &self.stitch.as_ref().and_then(|s| s.poses.clone()),
            ),
            (
                "[stitch] urdf",
                &self.stitch.as_ref().and_then(|s| s.urdf.clone()),
            ),
            (
                "[force] calibration",
                &self.force.as_ref().map(|f| f.calibration.clone()),
            ),
        ] {
            if let Some(p) = p {
                files.push(self.resolve(field, p)?);
            }
        }
        Ok(files)
    }

    /// The map cache's folder, resolved.
    pub fn cache_dir(&self) -> PathBuf {
        self.path
            .parent()
            .unwrap_or(Path::new("."))
            .join(self.cache.clone().unwrap_or_else(|| PathBuf::from(".skin-cache")))
    }
}
