//! `skin calibrate-force`: a link's force model fitted from presses with a known load.

use super::*;
use skin_core::force::ResponseCurve;
use skin_core::format::force_file::ForceCalibration;
use skin_core::{Frame, Recording};

/// The curve the simulated presses are read through.
const TRUE: ResponseCurve = ResponseCurve {
    full_scale: 4095.0,
    half_scale_kpa: 150.0,
};

/// A recording of the fixture forearm pressed by a 12 mm disc at `presses` places with the
/// forces given (each held 10 frames, 10 free frames between), its load-cell CSV, and a
/// run.toml naming the layout: written into `dir`. Taxel gains spread 1 +- 0.15.
fn pressed_forearm(dir: &Path, presses: &[(usize, f64)]) -> (PathBuf, PathBuf, PathBuf) {
    let layout_path = root().join("fixtures/forearm/layout.json");
    let link = skin_core::format::load_link(&layout_path).unwrap().value;
    let map = skin_geom::TactileMap::flatten(&link, &skin_geom::FlattenOptions::default()).unwrap();
    let areas = skin_core::force::taxel_areas(&map.positions, &map.faces).unwrap();
    let n = link.taxels.len();
    let gain = |i: usize| 0.85 + 0.3 * ((i * 7919) % 101) as f64 / 100.0;
    let rest = |i: usize| 200.0 + (i % 17) as f32;
    let (mut frames, mut load) = (Vec::new(), String::from("time_s,force_n\n"));
    let mut t = 0.0;
    let mut push = |values: Vec<f32>, force: f64, frames: &mut Vec<Frame>| {
        frames.push(Frame { time: t, values });
        load.push_str(&format!("{t:.3},{force}\n"));
        t += 0.05;
    };
    let idle: Vec<f32> = (0..n).map(rest).collect();
    for _ in 0..30 {
        push(idle.clone(), 0.0, &mut frames);
    }
    for &(centre, force) in presses {
        let c = map.positions[centre];
        let under: Vec<usize> = (0..n)
            .filter(|&i| (map.positions[i] - c).norm() <= 0.012)
            .collect();
        let area: f64 = under.iter().map(|&i| areas[i]).sum();
        let stress = force / area / 1e3;
        let mut pressed = idle.clone();
        for &i in &under {
            pressed[i] += TRUE.counts(stress, gain(i)).round() as f32;
        }
        for _ in 0..10 {
            push(pressed.clone(), force, &mut frames);
        }
        for _ in 0..10 {
            push(idle.clone(), 0.0, &mut frames);
        }
    }
    let rec = Recording {
        taxel_ids: link.taxels.iter().map(|t| t.id).collect(),
        frame_numbers: (0..frames.len() as u64).collect(),
        frames,
    };
    let (rec_path, load_path, config) = (
        dir.join("presses.txt"),
        dir.join("load.csv"),
        dir.join("run.toml"),
    );
    skin_core::format::recording::write(&rec_path, &rec).unwrap();
    std::fs::write(&load_path, load).unwrap();
    std::fs::write(
        &config,
        format!(
            "layout = {:?}\n[baseline]\nframes = 20\n",
            layout_path.display().to_string()
        ),
    )
    .unwrap();
    (config, rec_path, load_path)
}

fn calibrate(config: &Path, rec: &Path, load: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "calibrate-force",
        config.to_str().unwrap(),
        "--recording",
        rec.to_str().unwrap(),
        "--load",
        load.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    skin(&args)
}

#[test]
fn presses_of_known_force_give_back_the_curve() {
    let dir = tempfile::tempdir().unwrap();
    // 24 presses over the forearm, 2 to 30 N.
    let presses: Vec<(usize, f64)> = (0..24)
        .map(|k| ((k * 97 + 40) % 700, 2.0 + 28.0 * (k as f64 / 23.0)))
        .collect();
    let (config, rec, load) = pressed_forearm(dir.path(), &presses);
    let out = dir.path().join("force.json");
    // The configuration already names the calibration being made (a stale one, of another
    // link's taxels too): it is not read, and the other link's entry stays.
    let mut toml = std::fs::read_to_string(&config).unwrap();
    toml.push_str("[force]\ncalibration = \"force.json\"\n");
    std::fs::write(&config, toml).unwrap();
    let wrist = skin_core::format::force_file::LinkForce {
        name: "wrist".into(),
        curve: TRUE,
        ids: vec![1, 2],
        gains: vec![1.0, 1.0],
        fit: serde_json::Value::Null,
    };
    std::fs::write(&out, ForceCalibration::new(vec![wrist.clone()]).to_json()).unwrap();
    let o = calibrate(&config, &rec, &load, &out, &[]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{stdout}{err}");
    assert!(stdout.contains("press") && stdout.contains("wrote"), "{stdout}");
    let cal = ForceCalibration::read(&out).unwrap();
    assert_eq!(cal.links.len(), 2);
    assert_eq!(cal.links[0], wrist);
    let link = &cal.links[1];
    assert_eq!((link.name.as_str(), link.ids.len()), ("forearm", 715));
    // The shared curve within 10% (the gains absorb a common scale with the full scale).
    let h = link.curve.half_scale_kpa / TRUE.half_scale_kpa;
    assert!((h - 1.0).abs() < 0.1, "{:?}", link.curve);
    // Every press's residual within 5%.
    let fit = &link.fit;
    assert!(fit["r_squared"].as_f64().unwrap() > 0.99, "{fit}");
    for p in fit["presses"].as_array().unwrap() {
        let r = p["relative"].as_f64().unwrap();
        assert!(r.abs() < 0.05, "{p}");
    }
}

#[test]
fn bad_loads_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let (config, rec, load) = pressed_forearm(dir.path(), &[(100, 5.0), (300, 10.0), (500, 20.0)]);
    let out = dir.path().join("force.json");
    let cases: [(&str, &str); 5] = [
        ("time_s,force_n\n0,0\n2,1\n1,1\n", "line 4"),
        ("time_s,force_n\n0,0\n1,nan\n", "line 3"),
        ("time_s,force_n\n0,0\n1,-2\n", "never pull"),
        (
            "time_s,force_n\n1700000000,0\n1700000100,5\n",
            "seconds since the epoch",
        ),
        ("time_s,force_n\n500,0\n600,5\n", "no frame of the input"),
    ];
    for (text_, says) in cases {
        let bad = dir.path().join("bad.csv");
        std::fs::write(&bad, text_).unwrap();
        let o = calibrate(&config, &rec, &bad, &out, &[]);
        let (_, err) = text(&o);
        assert!(
            !o.status.success() && err.contains("bad.csv") && err.contains(says),
            "{text_}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!out.exists(), "{text_}: an output was written");
    }
    // The load file is an input: never the output.
    let o = calibrate(&config, &rec, &load, &load, &[]);
    assert!(!o.status.success() && text(&o).1.contains("also an input"));
    // Another file at the output is not replaced.
    std::fs::write(&out, "my notes").unwrap();
    let o = calibrate(&config, &rec, &load, &out, &[]);
    assert!(!o.status.success(), "{}", text(&o).0);
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "my notes");
}

/// The real Cyskin recordings: a stated load fits (nothing is claimed about their newtons), a
/// recording with nothing pressing is refused.
#[test]
fn real_recordings_fit_a_stated_load_and_a_press_free_one_is_refused() {
    let (Some(patch), Some(recordings)) = (
        shared("cyskin/curved_gesture_patch.json"),
        shared("cyskin/recordings"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("real.toml");
    std::fs::write(
        &config,
        format!(
            "layout = {:?}\n[baseline]\nframes = 5\n",
            patch.display().to_string()
        ),
    )
    .unwrap();
    // Each 1-finger recording presses from about 1.0 s to 2.0 s: say 5 N.
    let load = dir.path().join("load.csv");
    std::fs::write(&load, "start_s,end_s,force_n\n1.1,1.95,5.0\n").unwrap();
    let out = dir.path().join("force.json");
    let one = recordings.join("1_finger/sample_01.txt");
    let o = calibrate(&config, &one, &load, &out, &[]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("cannot be told apart"),
        "{err}"
    );
    let o = calibrate(&config, &one, &load, &out, &["--full-scale", "65535"]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{stdout}{err}");
    assert!(
        stdout.contains("(given)") && stdout.contains("got gain 1"),
        "{stdout}"
    );
    let cal = ForceCalibration::read(&out).unwrap();
    assert_eq!(cal.links[0].ids.len(), 642);
    assert_eq!(cal.links[0].curve.full_scale, 65535.0);
    std::fs::remove_file(&out).unwrap();
    let none = recordings.join("0_finger/sample_01.txt");
    let o = calibrate(&config, &none, &load, &out, &["--full-scale", "65535"]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("0 frame(s) under a load"),
        "{err}"
    );
    assert!(!out.exists());
}
