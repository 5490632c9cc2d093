//! One builder for a session: from run.toml and from code, the same settings, defaults and
//! bounds; the gate by the classifier's class names.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

mod support;

use skin_control::hri::{BorderRule, ClassGate, GateAction};
use skin_core::LinkSkin;
use skin_core::image::{ImageSize, ImageView};
use skin_learn::model::{Classes, HandClassifier, ModelError, Models};
use skin_learn::session::{
    BaselineConfig, ConfigError, Event, FromConfig, OwnModels, Session, SessionConfig, SessionError,
    SessionOptions, SessionSettings, SettingError, SplitConfig, TouchConfig,
};
use skin_learn::touch::TouchOptions;
use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

/// The small hex patch: quick to flatten.
fn patch() -> Vec<LinkSkin> {
    skin_geom::read_layout(&fixtures().join("hex_patch/layout.json"))
        .unwrap()
        .value
}

/// A run.toml in `dir` naming the hex patch, its map cache beside it, and `more`.
fn run_toml(dir: &Path, more: &str) -> PathBuf {
    let path = dir.join("run.toml");
    let layout = fixtures().join("hex_patch/layout.json");
    std::fs::write(
        &path,
        format!(
            "layout = {:?}\ncache = \"cache\"\n{more}",
            layout.display().to_string()
        ),
    )
    .unwrap();
    path
}

#[test]
fn a_session_from_run_toml_and_one_from_code_run_with_the_same_options() {
    let dir = tempfile::tempdir().unwrap();
    // A run.toml that sets nothing but its layout, and code that sets nothing.
    let config = SessionConfig::read(&run_toml(dir.path(), "")).unwrap();
    let from_file = Session::from_config(&config).unwrap();
    let defaults = SessionSettings::default();
    let from_code = Session::from_links(patch(), Models::none(), &defaults).unwrap();
    assert_eq!(from_file.settings(), Some(&defaults));
    assert_eq!(from_code.settings(), Some(&defaults));
    // Every option they run with, not only the settings they were given.
    assert_eq!(from_file.pipeline().options(), from_code.pipeline().options());
    assert_eq!(from_file.options(), from_code.options());
    assert_eq!(from_file.classes(), from_code.classes());
    // The parts a session can be put together from take the same defaults.
    assert_eq!(from_code.pipeline().options(), &TouchOptions::default());
    assert_eq!(from_code.options(), &SessionOptions::default());
    // A run.toml that writes run.toml's documented defaults out runs as one that leaves them.
    let written = "image_size = \"68x100\"\n[baseline]\nframes = 20\npolarity = \"rising\"\n\
        [touch]\nthreshold = 5.0\nmin_taxels = 2\ndecide_frames = 3\nrelease_frames = 2\n\
        reclassify_growth = 1.25\ncontacts = \"peaks\"\n";
    let config = SessionConfig::read(&run_toml(dir.path(), written)).unwrap();
    assert_eq!(config.settings().unwrap(), defaults);
    // As a binding sees them: run.toml's sections and keys.
    assert_eq!(
        serde_json::to_value(&defaults).unwrap(),
        serde_json::json!({
            "image_size": "68x100",
            "baseline": {"frames": 20, "polarity": "rising"},
            "touch": {"threshold": 5.0, "min_taxels": 2, "decide_frames": 3, "release_frames": 2,
                      "reclassify_growth": 1.25, "contacts": "peaks", "split": null},
            "gate": null,
        })
    );
}

#[test]
fn the_defaults_are_the_fixture_sessions_and_agree_everywhere() {
    // The shipped session writes its touch settings out; they are the defaults (a threshold
    // of 5 counts, not the 10 touch tracking once took alone).
    let config = SessionConfig::read(&fixtures().join("session/run.toml")).unwrap();
    let settings = config.settings().unwrap();
    assert_eq!(settings.touch, TouchConfig::default());
    assert_eq!(settings.baseline, BaselineConfig::default());
    assert_eq!(TouchOptions::default().threshold, 5.0);
    assert_eq!(
        SessionSettings::default().touch_options(),
        TouchOptions::default()
    );
    assert_eq!(
        SessionOptions::default().baseline_frames,
        BaselineConfig::default().frames
    );
    // The peaks rule's defaults in the file's units are the touch tracking's.
    let split = SessionSettings {
        touch: TouchConfig {
            split: Some(SplitConfig::default()),
            ..TouchConfig::default()
        },
        ..SessionSettings::default()
    };
    assert_eq!(split.touch_options(), TouchOptions::default());
}

/// A setting out of its bounds: as run.toml writes it, and as code sets it.
type Case = (&'static str, &'static str, fn(&mut SessionSettings));

#[test]
fn bounds_are_checked_in_one_place_for_a_file_and_for_code() {
    let cases: [Case; 9] = [
        ("[baseline]\nframes = 1\n", "[baseline] frames", |s| {
            s.baseline.frames = 1
        }),
        ("[touch]\nthreshold = -1.0\n", "[touch] threshold", |s| {
            s.touch.threshold = -1.0
        }),
        ("[touch]\nthreshold = nan\n", "[touch] threshold", |s| {
            s.touch.threshold = f32::NAN
        }),
        ("[touch]\nmin_taxels = 0\n", "[touch] min_taxels", |s| {
            s.touch.min_taxels = 0
        }),
        ("[touch]\nrelease_frames = 0\n", "[touch] release_frames", |s| {
            s.touch.release_frames = 0
        }),
        (
            "[touch]\nreclassify_growth = 0.5\n",
            "[touch] reclassify_growth",
            |s| {
                s.touch.reclassify_growth = 0.5;
            },
        ),
        ("[touch.split]\nmin_dip = 2.0\n", "[touch.split] min_dip", |s| {
            s.touch.split = Some(SplitConfig {
                min_dip: 2.0,
                ..SplitConfig::default()
            });
        }),
        (
            "[touch]\ncontacts = \"connected\"\n[touch.split]\nmin_dip = 0.5\n",
            "[touch.split]",
            |s| {
                s.touch.contacts = skin_learn::session::ContactRule::Connected;
                s.touch.split = Some(SplitConfig::default());
            },
        ),
        (
            "[gate]\nborder = { within_mm = -1 }\n",
            "[gate] border.within_mm",
            |s| {
                s.gate = Some(ClassGate {
                    border: Some(BorderRule {
                        within_mm: -1.0,
                        ..BorderRule::default()
                    }),
                    ..ClassGate::default()
                });
            },
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (text, field, set) in cases {
        let path = run_toml(dir.path(), text);
        let file_error = match SessionConfig::read(&path) {
            Err(ConfigError::Setting { source, .. }) => source,
            other => panic!("{text}: {other:?}"),
        };
        let mut settings = SessionSettings::default();
        set(&mut settings);
        let code_error = match Session::from_links(patch(), Models::none(), &settings) {
            Err(SessionError::Setting(e)) => e,
            other => panic!("{text}: {other:?}"),
        };
        assert!(
            matches!(&code_error, SettingError::Value { field: f, .. } if *f == field),
            "{text}: {code_error}"
        );
        assert_eq!(file_error, code_error, "{text}");
        assert_eq!(settings.check(), Err(code_error.clone()));
        // The file's error names the file, then says what code's does.
        let message = SessionConfig::read(&path).unwrap_err().to_string();
        assert_eq!(message, format!("{}: {code_error}", path.display()), "{text}");
    }
}

#[test]
fn a_binding_sets_keys_as_run_toml_writes_them_and_a_wrong_kind_is_named() {
    use toml::Value;
    let mut s = SessionSettings::default();
    s.set("[baseline] frames", Value::Integer(30)).unwrap();
    s.set("[baseline] polarity", Value::String("falling".into()))
        .unwrap();
    s.set("[touch] threshold", Value::Integer(7)).unwrap();
    s.set("[touch] decide_frames", Value::Integer(4)).unwrap();
    s.set("[touch.split] min_dip", Value::Float(0.25)).unwrap();
    s.set("image_size", Value::String("34x50".into())).unwrap();
    assert_eq!(s.baseline.frames, 30);
    assert_eq!(s.baseline.polarity, skin_core::Polarity::Falling);
    assert_eq!(s.touch.threshold, 7.0);
    assert_eq!(s.touch.decide_frames, 4);
    assert_eq!(
        s.touch.split,
        Some(SplitConfig {
            min_dip: 0.25,
            ..SplitConfig::default()
        })
    );
    assert_eq!(s.image_size, ImageSize::new(34, 50).unwrap());
    // Every other setting kept its default.
    assert_eq!(s.touch.min_taxels, TouchConfig::default().min_taxels);
    s.check().unwrap();
    // A value of the wrong kind names the key and what it takes, whatever the value.
    for value in [Value::Float(2.5), Value::Integer(-1), Value::String("20".into())] {
        let e = s.set("[baseline] frames", value.clone()).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "[baseline] frames = {value}: expected a whole number from 2 to 100000 (untouched frames the baseline learns from; 2 at least to measure noise)"
            )
        );
    }
    let e = s
        .set("[baseline] polarity", Value::String("up".into()))
        .unwrap_err();
    assert!(e.to_string().starts_with("[baseline] polarity = \"up\""), "{e}");
    // A key it does not have lists those it has.
    let e = s.set("[touch] treshold", Value::Float(5.0)).unwrap_err();
    assert!(
        e.to_string().contains("[touch] treshold") && e.to_string().contains("[touch] threshold"),
        "{e}"
    );
    // The range is the check's, one place for a file and a binding.
    s.set("[baseline] frames", Value::Integer(0)).unwrap();
    assert!(matches!(
        s.check(),
        Err(SettingError::Value {
            field: "[baseline] frames",
            ..
        })
    ));
}

/// A classifier of three classes, none named "hand": "palm" (the hand), "object", "elbow". Its
/// answers are given in turn, one per decision.
struct InTurn(Vec<[f32; 3]>);

impl HandClassifier for InTurn {
    fn input_size(&self) -> ImageSize {
        ImageSize::MODEL_DEFAULT
    }

    fn classify(&mut self, _: ImageView<'_, u8>) -> Result<Vec<f32>, ModelError> {
        if self.0.is_empty() {
            return Err(ModelError::Run(
                "asked for more decisions than the test gave".into(),
            ));
        }
        Ok(self.0.remove(0).to_vec())
    }
}

fn three_classes() -> Classes {
    Classes::new(["object", "palm", "elbow"], Some(1))
}

#[test]
fn the_gate_maps_the_classifiers_classes_by_name() {
    let palm = [0.1, 0.8, 0.1];
    let object = [0.8, 0.1, 0.1];
    let models = Models::new(InTurn(vec![palm, object]), three_classes());
    let settings = SessionSettings {
        gate: Some(ClassGate::new([
            ("palm", GateAction::Comply),
            ("object", GateAction::Stop),
        ])),
        ..SessionSettings::default()
    };
    let links = patch();
    // A dome over the patch: one peak, one contact.
    let taxels = &links[0].taxels;
    let centre = taxels
        .iter()
        .map(|t| t.position.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / taxels.len() as f64;
    let far = taxels
        .iter()
        .map(|t| (t.position.coords - centre).norm())
        .fold(0.0, f64::max);
    let dome: Vec<f32> = taxels
        .iter()
        .map(|t| 100.0 + (300.0 * (1.0 - (t.position.coords - centre).norm() / far)) as f32)
        .collect();
    let idle = vec![100.0f32; taxels.len()];
    let mut session = Session::from_links(links, models, &settings).unwrap();
    let mut events: Vec<Event> = Vec::new();
    // 20 idle frames, then two presses, each held 6 frames.
    for k in 0..50u64 {
        let pressed = (25..31).contains(&k) || (38..44).contains(&k);
        let frame = if pressed { dome.clone() } else { idle.clone() };
        let _ = session.push(k * 50_000, k, &[frame], &mut events).unwrap();
    }
    let _ = session.finish(&mut events).unwrap();
    let gates: Vec<GateAction> = events
        .iter()
        .filter_map(|e| match e {
            Event::Gate { action, .. } => Some(*action),
            _ => None,
        })
        .collect();
    assert_eq!(
        gates,
        [
            GateAction::Comply,
            GateAction::Resume,
            GateAction::Stop,
            GateAction::Resume
        ]
    );
}

#[test]
fn a_gate_class_the_classifier_lacks_is_refused_from_code_and_from_run_toml() {
    let settings = SessionSettings {
        gate: Some(ClassGate::new([
            ("palm", GateAction::Comply),
            ("hand", GateAction::Comply),
        ])),
        ..SessionSettings::default()
    };
    let models = || Models::new(InTurn(Vec::new()), three_classes());
    let e = Session::from_links(patch(), models(), &settings).unwrap_err();
    let want = SettingError::GateClass {
        class: "hand".into(),
        classes: vec!["object".into(), "palm".into(), "elbow".into()],
    };
    assert!(matches!(&e, SessionError::Setting(s) if *s == want), "{e}");
    assert_eq!(
        e.to_string(),
        "[gate] hand: the classifier has no class \"hand\" (its classes: object, palm, elbow)"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = run_toml(dir.path(), "[gate]\npalm = \"comply\"\nhand = \"comply\"\n");
    let config = SessionConfig::read(&path).unwrap();
    let e = Session::from_config_with_models(&config, models()).unwrap_err();
    assert_eq!(e.to_string(), format!("{}: {want}", path.display()));
    // Without a classifier the classes are hand and non_hand: a gate naming others (a misspelt
    // class) would never act, so it is refused too.
    let e = Session::from_links(patch(), Models::none(), &settings).unwrap_err();
    let want = SettingError::GateClass {
        class: "palm".into(),
        classes: vec!["hand".into(), "non_hand".into()],
    };
    assert!(matches!(&e, SessionError::Setting(s) if *s == want), "{e}");
    let plain = SessionSettings {
        gate: Some(ClassGate::new([("non_hand", GateAction::Stop)])),
        ..SessionSettings::default()
    };
    assert!(Session::from_links(patch(), Models::none(), &plain).is_ok());
}

#[test]
fn run_tomls_gate_names_any_classes_and_their_actions_by_name() {
    let text = "layout = \"l.json\"\n[gate]\npalm = \"comply\"\nobject = \"stop\"\n\
                border = { within_mm = 10 }\n";
    let config = SessionConfig::parse(text, Path::new("run.toml")).unwrap();
    let gate = config.gate.unwrap();
    assert_eq!(
        gate.actions.into_iter().collect::<Vec<_>>(),
        [
            ("object".to_owned(), GateAction::Stop),
            ("palm".to_owned(), GateAction::Comply)
        ]
    );
    assert_eq!(
        gate.border,
        Some(BorderRule {
            within_mm: 10.0,
            ..BorderRule::default()
        })
    );
    // A wrong action is named with the line and the actions there are.
    let e = SessionConfig::parse(
        "layout = \"l.json\"\n[gate]\npalm = \"explode\"\n",
        Path::new("run.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("line 3") && e.contains("\"explode\": expected stop, comply, slow or resume"),
        "{e}"
    );
    let e = SessionConfig::parse(
        "layout = \"l.json\"\n[baseline]\npolarity = \"up\"\n",
        Path::new("run.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("\"up\": expected \"rising\" or \"falling\""), "{e}");
}

#[test]
fn a_callers_classifier_is_named_by_skin_learns_rules() {
    let own = |classes: Option<&[&str]>, hand: Option<&str>| OwnModels {
        classifier: Some(Box::new(support::ByArea { hand_pixels: 50 })),
        classes: classes.map(|c| c.iter().map(|s| (*s).to_owned()).collect()),
        hand: hand.map(str::to_owned),
        segmenter: None,
    };
    let names = |c: &Classes| -> (Vec<String>, Option<String>) {
        (
            c.iter().map(|c| c.name().to_owned()).collect(),
            c.hand().map(|h| h.name().to_owned()),
        )
    };
    // Names given: the hand is the one named, or the class called "hand".
    let c = own(Some(&["object", "hand"]), None).classes(None).unwrap();
    assert_eq!(
        names(&c),
        (vec!["object".into(), "hand".into()], Some("hand".into()))
    );
    let c = own(Some(&["object", "palm"]), Some("palm"))
        .classes(None)
        .unwrap();
    assert_eq!(c.hand().map(|h| h.index()), Some(1));
    let c = own(Some(&["object", "palm"]), None).classes(None).unwrap();
    assert_eq!(c.hand(), None);
    // Names that do not fit name the argument at fault.
    for (classes, hand, field, message) in [
        (
            Some(&["a", "b"][..]),
            Some("c"),
            "hand",
            "hand: \"c\" is none of the classes (a, b)",
        ),
        (Some(&[][..]), None, "classes", "classes: no class"),
        (
            Some(&["a", "a"][..]),
            None,
            "classes",
            "classes: class \"a\" names outputs 0 and 1: each output needs a name of its own",
        ),
        (
            None,
            Some("nope"),
            "hand",
            "hand: \"nope\" is none of the classes (hand, non_hand)",
        ),
    ] {
        let e = own(classes, hand).classes(None).unwrap_err();
        assert!(
            matches!(&e, SessionError::Names { field: f, .. } if *f == field),
            "{e}"
        );
        assert_eq!(e.to_string(), message);
    }
    // No names: those of the card of the model it replaces, the hand renamed if asked.
    let handsnet = support::model("handsnet.onnx");
    let c = own(None, Some("non_hand")).classes(Some(&handsnet)).unwrap();
    assert_eq!(
        names(&c),
        (vec!["hand".into(), "non_hand".into()], Some("non_hand".into()))
    );
    // Alone, without a classifier: no names to give.
    let models = OwnModels::default().into_models().unwrap();
    assert!(!models.classifies());
    assert_eq!(models.classes(), &Classes::hand_or_not());
}

#[test]
fn without_a_model_runtime_a_named_model_is_refused_before_anything_else_of_the_models() {
    let dir = tempfile::tempdir().unwrap();
    let models = fixtures().join("models");
    let more = format!(
        "classifier = {:?}\nsegmenter = {:?}\n",
        models.join("handsnet.onnx").display().to_string(),
        models.join("handseg.onnx").display().to_string()
    );
    let config = SessionConfig::read(&run_toml(dir.path(), &more)).unwrap();
    // The caller's classifier names a hand that is none of its classes (an error of its own),
    // and nothing replaces the configuration's segmenter: without a runtime, that segmenter is
    // what is said, as it was before the runtime had a crate of its own.
    let own = || OwnModels {
        classifier: Some(Box::new(InTurn(Vec::new()))),
        classes: Some(vec!["object".into(), "palm".into()]),
        hand: Some("thumb".into()),
        segmenter: None,
    };
    let refused = |e: &SessionError| match e {
        SessionError::Config(c) => match **c {
            ConfigError::NoModelRuntime { field, .. } => Some(field),
            _ => None,
        },
        _ => None,
    };
    let e = Session::from_config_with_runtime(&config, own(), None).unwrap_err();
    assert_eq!(refused(&e), Some("segmenter"), "{e}");
    // Nothing named is left unreplaced: the classifier's own fault is said.
    let none = SessionConfig::read(&run_toml(dir.path(), "")).unwrap();
    let e = Session::from_config_with_runtime(&none, own(), None).unwrap_err();
    assert!(matches!(&e, SessionError::Names { field: "hand", .. }), "{e}");
    // Neither model brought: the classifier, named first, is what is said.
    let e = Session::from_config_with_runtime(&config, OwnModels::default(), None).unwrap_err();
    assert_eq!(refused(&e), Some("classifier"), "{e}");
}
