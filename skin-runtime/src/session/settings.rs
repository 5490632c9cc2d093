//! How a session runs, apart from the files it reads: run.toml's `image_size`, `[baseline]`,
//! `[touch]` and `[gate]` as one value, [`SessionSettings`]. Its defaults and its bounds are
//! written here once; a session from a configuration file and one from code
//! ([`Session::with_settings`](super::Session::with_settings)) take them alike, and a binding
//! converts its own arguments into it ([`SessionSettings::set`]).

use crate::model::Classes;
use crate::touch::TouchOptions;
use serde::{Deserialize, Serialize};
use skin_control::hri::ClassGate;
use skin_core::image::ImageSize;
use skin_core::{Polarity, Separation};

/// A session's settings: run.toml's `image_size`, `[baseline]`, `[touch]` and `[gate]`, their defaults
/// and bounds written here once; [`Default`] is what a run.toml that sets
/// none of them gives.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct SessionSettings {
    /// The models' input (`image_size = "ROWSxCOLS"`); default [`ImageSize::MODEL_DEFAULT`].
    #[serde(serialize_with = "as_text")]
    pub image_size: ImageSize,
    /// `[baseline]`.
    pub baseline: BaselineConfig,
    /// `[touch]`.
    pub touch: TouchConfig,
    /// `[gate]`: what the robot does for each class of touch (none: no gate).
    pub gate: Option<ClassGate>,
}

/// `[baseline]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct BaselineConfig {
    /// Untouched complete frames at the start that learn the offsets (2 to 100,000; default 20).
    pub frames: usize,
    /// Which way pressure moves a reading (default rising).
    pub polarity: Polarity,
}

impl Default for BaselineConfig {
    /// 20 frames (a second at 20 Hz), rising: the one place these defaults are written.
    fn default() -> Self {
        BaselineConfig {
            frames: 20,
            polarity: Polarity::Rising,
        }
    }
}

/// `[touch]`: see [`TouchOptions`], whose defaults these are.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct TouchConfig {
    /// Counts above the baseline that press a taxel (0 to 1e9).
    pub threshold: f32,
    /// Patches of fewer taxels are noise.
    pub min_taxels: usize,
    /// Frames of contact before the first decision.
    pub decide_frames: usize,
    /// Frames without contact that end a touch.
    pub release_frames: usize,
    /// Classify again when the touch grows by this factor (1 to 1e6).
    pub reclassify_growth: f32,
    /// How a patch of pressed taxels becomes contacts; default [`ContactRule::Peaks`].
    pub contacts: ContactRule,
    /// `[touch.split]`: the parameters of [`ContactRule::Peaks`] (none: their defaults).
    pub split: Option<SplitConfig>,
}

impl Default for TouchConfig {
    fn default() -> Self {
        let d = TouchOptions::default();
        TouchConfig {
            threshold: d.threshold,
            min_taxels: d.min_taxels,
            decide_frames: d.decide_frames,
            release_frames: d.release_frames,
            reclassify_growth: d.reclassify_growth,
            contacts: ContactRule::default(),
            split: None,
        }
    }
}

/// `[touch] contacts`: how a connected patch of pressed taxels becomes contacts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactRule {
    /// `"peaks"`: split between prominent pressure peaks (`[touch.split]`), so fingers side by
    /// side are separate contacts.
    #[default]
    Peaks,
    /// `"connected"`: each connected patch is one contact (thesis Ch. 3.2).
    Connected,
}

/// `[touch.split]`: see [`Separation::Peaks`].
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SplitConfig {
    /// How far the pressure must fall between two peaks, as a fraction of the lower (0 to 1;
    /// default 0.5).
    pub min_dip: f32,
    /// How far apart two peaks must lie, millimetres (0 to 1000; default 12).
    pub min_distance_mm: f64,
}

impl Default for SplitConfig {
    /// [`Separation::FINGERS`], in the file's units.
    fn default() -> Self {
        match Separation::FINGERS {
            Separation::Peaks {
                min_dip,
                min_distance_m,
            } => SplitConfig {
                min_dip,
                min_distance_mm: min_distance_m * 1e3,
            },
            Separation::Connected => SplitConfig {
                min_dip: 0.0,
                min_distance_mm: 0.0,
            },
        }
    }
}

/// A setting out of its bounds, of the wrong kind, or naming what is not there; fields named as
/// run.toml spells them (a binding names its own argument instead).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingError {
    /// A value out of its range or of the wrong kind.
    #[error("{field} = {value}: expected {expected}")]
    Value {
        /// The key, as run.toml spells it (`"[touch] threshold"`).
        field: &'static str,
        /// Its value (the first 40 characters).
        value: String,
        /// What it takes, in words.
        expected: &'static str,
    },
    /// A force limit out of its range (`[gate] force_n`).
    #[error("[gate] force_n.{class} = {value}: expected {expected}")]
    ForceLimit {
        /// The class it limits.
        class: String,
        /// Its value.
        value: f64,
        /// What it takes, in words.
        expected: &'static str,
    },
    /// A `[gate]` key that names none of the classifier's classes: a misspelt class would
    /// never be gated.
    #[error("[gate] {class}: the classifier has no class {class:?} (its classes: {})", classes.join(", "))]
    GateClass {
        /// The class the gate names.
        class: String,
        /// The classifier's classes.
        classes: Vec<String>,
    },
}

/// A whole-number setting's key, bounds and what it takes (said in the words of its errors).
struct Whole {
    field: &'static str,
    min: usize,
    max: usize,
    expected: &'static str,
}

/// The whole-number settings, `[baseline] frames` first.
#[rustfmt::skip]
const WHOLE: [Whole; 4] = [
    Whole { field: "[baseline] frames", min: 2, max: 100_000,
        expected: "a whole number from 2 to 100000 (untouched frames the baseline learns from; 2 at least to measure noise)" },
    Whole { field: "[touch] min_taxels", min: 1, max: 1_000_000, expected: "a whole number from 1 to 1000000 (taxels)" },
    Whole { field: "[touch] decide_frames", min: 1, max: 1_000_000, expected: "a whole number from 1 to 1000000 (frames)" },
    Whole { field: "[touch] release_frames", min: 1, max: 1_000_000, expected: "a whole number from 1 to 1000000 (frames)" },
];

/// What `image_size` takes, in words (a configuration's error says it too).
pub(super) const IMAGE_SIZE: &str = "ROWSxCOLS, e.g. 68x100, each side 1 to 4096 pixels";

/// The other settings' keys and what they take (ranges checked in [`SessionSettings::check`]).
#[rustfmt::skip]
const OTHER: [(&str, &str); 7] = [
    ("image_size", IMAGE_SIZE),
    ("[baseline] polarity", "\"rising\" or \"falling\""),
    ("[touch] threshold", "counts from 0 to 1e9"),
    ("[touch] reclassify_growth", "a factor from 1 to 1e6"),
    ("[touch] contacts", "\"peaks\" or \"connected\""),
    ("[touch.split] min_dip", "a fraction from 0 to 1"),
    ("[touch.split] min_distance_mm", "millimetres from 0 to 1000"),
];

impl SettingError {
    /// The error for `field = value` (the value as shown, cut to 40 characters): what the key
    /// takes, or the keys there are when `field` is none of them.
    pub fn value(field: &str, value: &str) -> SettingError {
        let value: String = value.chars().take(40).collect();
        let known = WHOLE
            .iter()
            .map(|w| (w.field, w.expected))
            .chain(OTHER)
            .find(|(f, _)| *f == field);
        match known {
            Some((field, expected)) => SettingError::Value {
                field,
                value,
                expected,
            },
            None => SettingError::Value {
                field: "key",
                value: field.chars().take(40).collect(),
                expected: SETTING_KEYS,
            },
        }
    }
}

/// The keys [`SessionSettings::set`] takes, for an error about one it does not.
const SETTING_KEYS: &str = "one of image_size, [baseline] frames, [baseline] polarity, [touch] threshold, \
     [touch] min_taxels, [touch] decide_frames, [touch] release_frames, [touch] reclassify_growth, \
     [touch] contacts, [touch.split] min_dip, [touch.split] min_distance_mm";

impl SessionSettings {
    /// Every value in its bounds: the image size, `[baseline]`, `[touch]` (a `[touch.split]`
    /// only with the peaks rule) and the `[gate]` border rule. The one place they are checked.
    pub fn check(&self) -> Result<(), SettingError> {
        let size = self.image_size;
        if ImageSize::new(size.rows, size.cols).is_err() {
            return Err(SettingError::value("image_size", &size.to_string()));
        }
        let t = &self.touch;
        let wholes = [
            self.baseline.frames,
            t.min_taxels,
            t.decide_frames,
            t.release_frames,
        ];
        for (w, v) in WHOLE.iter().zip(wholes) {
            if !(w.min..=w.max).contains(&v) {
                return Err(SettingError::value(w.field, &v.to_string()));
            }
        }
        let numbers = [
            ("[touch] threshold", t.threshold, 0.0, 1e9),
            ("[touch] reclassify_growth", t.reclassify_growth, 1.0, 1e6),
        ];
        for (field, v, lo, hi) in numbers {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(SettingError::value(field, &v.to_string()));
            }
        }
        self.check_split()?;
        if let Some(Err((class, value, expected))) = self.gate.as_ref().map(|g| g.check_force()) {
            return Err(SettingError::ForceLimit {
                class: class.chars().take(40).collect(),
                value,
                expected,
            });
        }
        match self.gate.as_ref().and_then(|g| g.border).map(|b| b.check()) {
            Some(Err((field, value, expected))) => Err(SettingError::Value {
                field,
                value: value.to_string(),
                expected,
            }),
            _ => Ok(()),
        }
    }

    /// `[touch.split]`: only with the peaks rule, its numbers in their bounds.
    fn check_split(&self) -> Result<(), SettingError> {
        let t = &self.touch;
        if t.contacts == ContactRule::Connected && t.split.is_some() {
            return Err(SettingError::Value {
                field: "[touch.split]",
                value: "present".into(),
                expected: "no [touch.split] with contacts = \"connected\" (it sets the peaks rule)",
            });
        }
        if let Some(sp) = &t.split {
            if !(0.0..=1.0).contains(&sp.min_dip) {
                return Err(SettingError::value(
                    "[touch.split] min_dip",
                    &sp.min_dip.to_string(),
                ));
            }
            if !(0.0..=1000.0).contains(&sp.min_distance_mm) {
                return Err(SettingError::value(
                    "[touch.split] min_distance_mm",
                    &sp.min_distance_mm.to_string(),
                ));
            }
        }
        Ok(())
    }

    /// Every class the gate names is one of `classes` (the classifier's).
    pub fn check_gate(&self, classes: &Classes) -> Result<(), SettingError> {
        let Some(gate) = &self.gate else {
            return Ok(());
        };
        let named = |class: &str| classes.iter().any(|c| c.name() == class);
        match gate.actions.keys().chain(gate.force_n.keys()).find(|k| !named(k)) {
            Some(class) => Err(SettingError::GateClass {
                class: class.clone(),
                classes: classes.iter().map(|c| c.name().to_owned()).collect(),
            }),
            None => Ok(()),
        }
    }

    /// Sets one key as run.toml sets it (`field` spelt as there: `"[touch] threshold"`,
    /// `"image_size"`; `value` as TOML's, which a binding converts its own values to). A key
    /// it does not have, or a value of the wrong kind (text for a number, a fraction for a
    /// whole number), is an error that names the key and says what it takes; the value's range
    /// is [`SessionSettings::check`]'s, left to it.
    pub fn set(&mut self, field: &str, value: toml::Value) -> Result<(), SettingError> {
        let shown = value.to_string();
        let bad = || SettingError::value(field, &shown);
        let (table, key) = match field.split_once("] ") {
            Some((table, key)) => (table.trim_start_matches('['), key),
            None => ("", field),
        };
        // The key alone, in its table: every other key of the table takes its default.
        let mut doc = toml::Table::new();
        doc.insert(key.to_owned(), value);
        for part in table.rsplit('.').filter(|p| !p.is_empty()) {
            let mut outer = toml::Table::new();
            outer.insert(part.to_owned(), toml::Value::Table(doc));
            doc = outer;
        }
        let one: Sections = toml::Value::Table(doc).try_into().map_err(|_| bad())?;
        let (b, t) = (one.baseline, one.touch);
        match field {
            "image_size" => {
                let text = one.image_size.ok_or_else(bad)?;
                self.image_size = text.parse().map_err(|_| bad())?;
            }
            "[baseline] frames" => self.baseline.frames = b.frames,
            "[baseline] polarity" => self.baseline.polarity = b.polarity,
            "[touch] threshold" => self.touch.threshold = t.threshold,
            "[touch] min_taxels" => self.touch.min_taxels = t.min_taxels,
            "[touch] decide_frames" => self.touch.decide_frames = t.decide_frames,
            "[touch] release_frames" => self.touch.release_frames = t.release_frames,
            "[touch] reclassify_growth" => self.touch.reclassify_growth = t.reclassify_growth,
            "[touch] contacts" => self.touch.contacts = t.contacts,
            "[touch.split] min_dip" | "[touch.split] min_distance_mm" => {
                let given = t.split.ok_or_else(bad)?;
                let split = self.touch.split.get_or_insert_with(SplitConfig::default);
                if key == "min_dip" {
                    split.min_dip = given.min_dip;
                } else {
                    split.min_distance_mm = given.min_distance_mm;
                }
            }
            _ => return Err(bad()),
        }
        Ok(())
    }

    /// The same settings with every default written out as the session runs them: the peaks
    /// rule's `[touch.split]` parameters when the file leaves them out (what a binding shows).
    pub fn filled(&self) -> SessionSettings {
        let mut filled = self.clone();
        if filled.touch.contacts == ContactRule::Peaks && filled.touch.split.is_none() {
            filled.touch.split = Some(SplitConfig::default());
        }
        filled
    }

    /// The touch tracking they give.
    pub fn touch_options(&self) -> TouchOptions {
        let t = &self.touch;
        TouchOptions {
            threshold: t.threshold,
            min_taxels: t.min_taxels,
            decide_frames: t.decide_frames,
            release_frames: t.release_frames,
            reclassify_growth: t.reclassify_growth,
            separation: match t.contacts {
                ContactRule::Connected => Separation::Connected,
                ContactRule::Peaks => {
                    let s = t.split.unwrap_or_default();
                    Separation::Peaks {
                        min_dip: s.min_dip,
                        min_distance_m: s.min_distance_mm * 1e-3,
                    }
                }
            },
            ..TouchOptions::default()
        }
    }

    /// The session options they give (no frame images: a sink asks for those).
    pub fn session_options(&self) -> super::SessionOptions {
        super::SessionOptions {
            baseline_frames: self.baseline.frames,
            polarity: self.baseline.polarity,
            gate: self.gate.clone(),
            frame_images: false,
        }
    }
}

/// The settings' sections of a run.toml alone: what [`SessionSettings::set`] reads one key of.
#[derive(Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
struct Sections {
    image_size: Option<String>,
    baseline: BaselineConfig,
    touch: TouchConfig,
}

/// An image size written as run.toml writes it, `ROWSxCOLS`.
fn as_text<S: serde::Serializer>(size: &ImageSize, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(size)
}
