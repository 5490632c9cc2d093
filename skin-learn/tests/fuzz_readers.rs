//! Fuzzing of skin-learn's reader of probe datasets (CSV): arbitrary text and hostile edits of a
//! valid file (see `skin_test_support::mutate`) give `Ok` or an error, never a panic; what is
//! accepted holds centroids within `MAX_POSITION_M`, finite bounded responses and no taxel
//! twice per contact, and calibrates (or flags its taxels) without a panic.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::Point3;
use proptest::prelude::*;
use skin_core::TaxelId;
use skin_core::format::MAX_POSITION_M;
use skin_core::format::recording::MAX_READING;
use skin_learn::calibration::{CalibrationOptions, ProbeContact, ProbeDataset, calibrate};
use std::collections::HashSet;
use std::path::Path;

use mutate::{arbitrary_text, config, mutated};
use skin_test_support::mutate;

/// Six presses around three taxels, each answered by all three.
fn csv() -> String {
    let contacts = (0..6)
        .map(|k| {
            let a = f64::from(k) * 1.05;
            let centroid = Point3::new(0.01 * a.cos(), 0.01 * a.sin(), 0.1);
            ProbeContact {
                centroid,
                force_n: None,
                responses: (0..3)
                    .map(|t| {
                        let taxel = Point3::new(0.004 * f64::from(t), 0.0, 0.1);
                        (
                            TaxelId(16 + t),
                            600.0 * (-(centroid - taxel).norm_squared() / 2e-4).exp(),
                        )
                    })
                    .collect(),
            }
        })
        .collect();
    ProbeDataset { contacts }.to_csv()
}

#[test]
fn the_valid_file_reads() {
    let d = ProbeDataset::parse(&csv(), Path::new("probes.csv")).unwrap();
    assert_eq!(d.contacts.len(), 6);
    assert!(d.contacts.iter().all(|c| c.responses.len() == 3));
}

#[test]
fn a_huge_cell_is_quoted_by_its_first_characters() {
    let long = "9".repeat(100_000);
    let text = format!("contact,x_m,y_m,z_m,taxel,response\n0,{long},0,0,16,1\n");
    let e = ProbeDataset::parse(&text, Path::new("probes.csv"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x_m") && e.contains("100000 bytes") && e.len() < 400,
        "{e}"
    );
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn probe_datasets(text in prop_oneof![mutated(&csv()), arbitrary_text()]) {
        let Ok(d) = ProbeDataset::parse(&text, Path::new("probes.csv")) else {
            return Ok(());
        };
        for c in &d.contacts {
            prop_assert!(c.centroid.coords.iter().all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M));
            prop_assert!(c.responses.iter().all(|(_, r)| r.is_finite() && r.abs() <= f64::from(MAX_READING)));
            prop_assert_eq!(c.responses.iter().map(|(t, _)| t).collect::<HashSet<_>>().len(), c.responses.len());
        }
        let report = calibrate(&d, &CalibrationOptions { min_responses: 3, ..CalibrationOptions::default() });
        for t in &report.taxels {
            if let Some(p) = t.position {
                prop_assert!(p.coords.iter().all(|v| v.is_finite()), "taxel {} at {p:?}", t.id);
            }
        }
    }
}

/// The session configuration (`run.toml`): hostile edits of the fixture's and arbitrary text
/// give values in their documented ranges or an error, never a panic, and never a message that
/// echoes a long line.
mod session_config {
    use super::*;
    use skin_core::image::ImageSize;
    use skin_learn::session::SessionConfig;

    const SESSION: &str = include_str!("../../fixtures/session/run.toml");

    #[test]
    fn the_fixture_configuration_parses() {
        let config = SessionConfig::parse(SESSION, Path::new("run.toml")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            (config.baseline.frames, config.image_size().unwrap()),
            (20, ImageSize { rows: 68, cols: 100 })
        );
        assert!(config.gate.is_some());
    }

    #[test]
    fn a_bad_line_is_named_not_echoed() {
        let text = format!("{SESSION}\ncolour = \"{}\"\n", "x".repeat(1_000_000));
        let e = SessionConfig::parse(&text, Path::new("run.toml"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        let line = SESSION.lines().count() + 2;
        assert!(
            e.contains(&format!("line {line}")) && e.contains("colour") && e.len() < 300,
            "{}",
            &e[..e.len().min(400)]
        );
    }

    #[test]
    fn each_range_is_checked_and_named() {
        for (edit, field) in [
            ("[baseline]\nframes = 1", "[baseline] frames = 1"),
            ("[touch]\nthreshold = nan", "[touch] threshold = NaN"),
            ("[touch]\nreclassify_growth = 0.5", "reclassify_growth = 0.5"),
            ("[touch]\nrelease_frames = 0", "release_frames = 0"),
            ("image_size = \"0x5\"", "image_size = 0x5"),
            ("image_size = \"5000x5\"", "image_size = 5000x5"),
            ("[sim]\nframe_rate_hz = 0", "[sim] frame_rate_hz = 0"),
            ("[sim]\ncover_mm = inf", "[sim] cover_mm = inf"),
            ("[sim]\nfull_scale = 70000", "[sim] full_scale = 70000"),
            ("[sim]\nrest = 5000", "[sim] rest = 5000"),
            ("[sim]\ndropout = 1.5", "[sim] dropout = 1.5"),
            (
                "[sim]\nmissing_modules = [\"can0\"]",
                "[sim] missing_modules = can0",
            ),
            ("[sim]\nmissing_modules = [\":5\"]", "[sim] missing_modules = :5"),
        ] {
            let text = format!("layout = \"l.json\"\nbusmap = \"b.toml\"\n{edit}\n");
            let e = SessionConfig::parse(&text, Path::new("run.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("run.toml: ") && e.contains(field), "{edit}: {e}");
        }
    }

    #[test]
    fn a_sim_table_is_read_with_its_defaults() {
        let text = "layout = \"l.json\"\n[sim]\nframe_rate_hz = 50\nmissing_modules = [\"can0:5\"]\n";
        let c = SessionConfig::parse(text, Path::new("run.toml")).unwrap();
        let sim = c.sim.unwrap();
        assert_eq!(sim.frame_rate_hz, 50.0);
        assert_eq!(sim.missing_modules, ["can0:5"]);
        assert_eq!(sim.cover_mm, skin_learn::session::SimConfig::default().cover_mm);
        let e = SessionConfig::parse("layout = \"l.json\"\n[sim]\ngain = 2\n", Path::new("run.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("gain"), "{e}");
        assert!(
            SessionConfig::parse(SESSION, Path::new("run.toml"))
                .unwrap()
                .sim
                .is_none()
        );
    }

    #[test]
    fn a_sim_key_set_as_a_binding_sets_it_names_the_key_and_what_it_takes() {
        use skin_learn::session::SimConfig;
        let origin = Path::new("[sim]");
        let mut sim = SimConfig::default();
        sim.set("noise", toml::Value::Integer(3), origin).unwrap();
        sim.set(
            "missing_modules",
            toml::Value::Array(vec!["can0:5".into()]),
            origin,
        )
        .unwrap();
        assert_eq!(
            (sim.noise, sim.missing_modules.as_slice()),
            (3.0, &["can0:5".to_owned()][..])
        );
        assert_eq!(sim.cover_mm, SimConfig::default().cover_mm);
        for (key, value, message) in [
            (
                "noise",
                toml::Value::from("x"),
                "[sim]: [sim] noise = \"x\": expected counts from 0 to full_scale",
            ),
            (
                "dead",
                toml::Value::Integer(5),
                "[sim] dead = 5: expected a list of taxel ids",
            ),
            (
                "dead",
                toml::Value::Array(vec![(-1).into()]),
                "[sim] dead = [-1]: expected a list of taxel ids",
            ),
            (
                "missing_modules",
                "can0:5".into(),
                "[sim] missing_modules = \"can0:5\": expected a list of modules",
            ),
            (
                "seed",
                toml::Value::Float(1.5),
                "[sim] seed = 1.5: expected a whole number",
            ),
            (
                "frame_rate_hz",
                "20".into(),
                "[sim] frame_rate_hz = \"20\": expected frames a second",
            ),
            (
                "noize",
                toml::Value::Integer(1),
                "[sim] key = noize: expected one of frame_rate_hz, cover_mm",
            ),
        ] {
            let e = sim.clone().set(key, value, origin).unwrap_err().to_string();
            assert!(e.contains(message) && !e.contains("column"), "{key}: {e}");
        }
        // A number of the right kind out of its range: named by the check that follows.
        sim.set("noise", toml::Value::Float(f64::NAN), origin).unwrap();
        let e = sim.check(origin).unwrap_err().to_string();
        assert_eq!(
            e,
            "[sim]: [sim] noise = NaN: expected counts from 0 to full_scale"
        );
        let e = SimConfig::value_error("rest", "None", origin).to_string();
        assert_eq!(
            e,
            "[sim]: [sim] rest = None: expected counts from 0 to full_scale"
        );
    }

    proptest! {
        #![proptest_config(config())]

        #[test]
        fn a_sim_key_is_set_or_refused_by_name(key in "[a-z_]{1,16}", n in any::<i64>(), x in any::<f64>(), text in ".{0,60}") {
            use skin_learn::session::SimConfig;
            for value in [toml::Value::Integer(n), toml::Value::Float(x), toml::Value::String(text.clone()), toml::Value::Array(vec![toml::Value::Integer(n)])] {
                let mut sim = SimConfig::default();
                if let Err(e) = sim.set(&key, value, Path::new("[sim]")) {
                    let e = e.to_string();
                    prop_assert!(e.contains(&format!("[sim] {key} = ")) || e.contains(&format!("[sim] key = {}", key.chars().take(40).collect::<String>())), "{}", e);
                    prop_assert!(e.len() < 300, "{}", e);
                }
            }
        }

        #[test]
        fn configurations_are_parsed_or_refused(text in prop_oneof![mutated(SESSION), arbitrary_text()]) {
            match SessionConfig::parse(&text, Path::new("run.toml")) {
                Ok(c) => {
                    prop_assert!((2..=100_000).contains(&c.baseline.frames));
                    prop_assert!(c.touch.threshold.is_finite() && c.touch.reclassify_growth >= 1.0);
                    let ImageSize { rows, cols } = c.image_size().unwrap();
                    let side = 1..=ImageSize::MAX_SIDE;
                    prop_assert!(side.contains(&rows) && side.contains(&cols));
                }
                Err(e) => prop_assert!(e.to_string().len() < 600, "{e}"),
            }
        }
    }
}
