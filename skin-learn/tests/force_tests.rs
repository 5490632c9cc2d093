//! Force end to end on the fixture forearm: presses of known force through a simulated response
//! (a gain spread, the saturating curve), the force model fitted from a session's frames, and a
//! session with that calibration reporting newtons per contact and a wrench per link.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed set-up should stop the test

use nalgebra::{Point3, Vector3};
use skin_core::LinkSkin;
use skin_core::force::ResponseCurve;
use skin_core::format::force_file::ForceCalibration;
use skin_core::format::load::LoadFile;
use skin_learn::force_calibration::{ForceFitOptions, LoadedFrames, fit_force, link_areas};
use skin_learn::model::Models;
use skin_learn::session::{Event, Session, SessionSettings, Sink};
use std::path::Path;

const TRUE: ResponseCurve = ResponseCurve {
    full_scale: 4095.0,
    half_scale_kpa: 150.0,
};

fn forearm() -> LinkSkin {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm/layout.json");
    skin_core::format::load_link(&path).unwrap().value
}

/// Frame `k` (50 ms apart) of `readings` into the session.
fn step<S: Sink>(s: &mut Session, k: u64, readings: &[f32], sink: &mut S) {
    assert!(s.push(k * 50_000, k, &[readings], sink).unwrap().is_continue());
}

fn gain(i: usize) -> f64 {
    0.85 + 0.3 * ((i * 7919) % 101) as f64 / 100.0
}

/// A session over the forearm, baseline learned on 20 idle frames; the idle readings.
fn session(link: &LinkSkin) -> (Session, Vec<f32>) {
    let mut settings = SessionSettings::default();
    settings.baseline.frames = 20;
    let mut s = Session::from_links(vec![link.clone()], Models::none(), &settings).unwrap();
    let idle: Vec<f32> = (0..link.taxels.len()).map(|i| 200.0 + (i % 17) as f32).collect();
    let mut sink: Vec<Event> = Vec::new();
    for k in 0..20 {
        step(&mut s, k, &idle, &mut sink);
    }
    (s, idle)
}

/// The readings of `force` newtons spread evenly over the taxels within `radius` of taxel
/// `centre` (on the session's map), and those taxels.
fn press(s: &Session, idle: &[f32], centre: usize, radius: f64, force: f64) -> (Vec<f32>, Vec<usize>) {
    let map = s.pipeline().map(0).unwrap();
    let areas = link_areas(map).unwrap();
    let c = map.positions[centre];
    let under: Vec<usize> = (0..idle.len())
        .filter(|&i| (map.positions[i] - c).norm() <= radius)
        .collect();
    let stress = force / under.iter().map(|&i| areas[i]).sum::<f64>() / 1e3;
    let mut readings = idle.to_vec();
    for &i in &under {
        readings[i] += TRUE.counts(stress, gain(i)).round() as f32;
    }
    (readings, under)
}

/// The forearm's force calibration, fitted from a session's frames of 150 presses of 1 to 30 N
/// over the whole skin (each 3 frames) and their load cell's CSV.
fn calibrate(link: &LinkSkin) -> ForceCalibration {
    let (mut s, idle) = session(link);
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("time_s,force_n\n");
    let mut frames = Vec::new();
    let mut t = 20u64;
    for k in 0..150usize {
        let force = 1.0 + 29.0 * ((k * 37) % 150) as f64 / 149.0;
        let (readings, _) = press(&s, &idle, (k * 131 + 17) % 715, 0.012, force);
        for _ in 0..3 {
            frames.push((t, readings.clone()));
            csv.push_str(&format!("{},{force}\n", t as f64 * 0.05));
            t += 1;
        }
        frames.push((t, idle.clone()));
        csv.push_str(&format!("{},0\n", t as f64 * 0.05));
        t += 1;
    }
    let load_path = dir.path().join("load.csv");
    std::fs::write(&load_path, csv).unwrap();
    let loads = LoadFile::read(&load_path).unwrap();
    let mut sink = LoadedFrames::new(&loads, 0, 0.0);
    for (k, r) in &frames {
        step(&mut s, *k, r, &mut sink);
    }
    let loaded = sink.finish().unwrap();
    let map = s.pipeline().map(0).unwrap();
    let fit = fit_force(&loaded, &link_areas(map).unwrap(), &ForceFitOptions::default()).unwrap();
    ForceCalibration::new(vec![fit.link_force(&map.name, &map.ids)])
}

/// Checks the link's wrench after a press of `under` (an even stress) weighing `total`
/// newtons over its contacts.
fn check_wrench(s: &Session, under: &[usize], total: f64) {
    let (w, saturated) = s.wrench(0).unwrap();
    assert_eq!(saturated, 0);
    // The wrench's magnitude is the contacts' force; its torque is r x F of its taxels, about
    // the link's origin: about cop x F when the normals under the press agree.
    assert!((w.magnitude - total).abs() < 1e-9 * total.max(1.0));
    let cop = w.cop.unwrap();
    let lever = cop.coords.cross(&w.force);
    assert!(
        (w.torque - lever).norm() <= 0.1 * w.torque.norm().max(1e-3),
        "torque {:?} against cop x F {lever:?}",
        w.torque
    );
    // The centre of pressure is that of the load: an even stress over the pressed taxels'
    // areas puts it at their area-weighted centroid (off the centre taxel at the border).
    let map = s.pipeline().map(0).unwrap();
    let areas = link_areas(map).unwrap();
    let area: f64 = under.iter().map(|&i| areas[i]).sum();
    let truth = under
        .iter()
        .fold(Vector3::zeros(), |m, &i| m + map.positions[i].coords * areas[i])
        / area;
    let truth = Point3::from(truth);
    assert!(
        (cop - truth).norm() < 0.001,
        "cop {cop:?} against the load's {truth:?}"
    );
}

#[test]
fn a_calibrated_session_reports_the_force_it_was_pressed_with() {
    let link = forearm();
    let calibration = calibrate(&link);

    // Held out: other places, other forces, through a fresh session with the calibration.
    let (s, idle) = session(&link);
    let mut s = s.with_force(&calibration, Path::new("force.json")).unwrap();
    let (mut errors, mut floor) = (Vec::new(), Vec::new());
    let mut events: Vec<Event> = Vec::new();
    for k in 0..30usize {
        let force = 2.0 + 18.0 * k as f64 / 29.0;
        let centre = (k * 211 + 5) % 715;
        let (readings, under) = press(&s, &idle, centre, 0.010, force);
        step(&mut s, 200 + 10 * k as u64, &readings, &mut events);
        let readings_now: Vec<f32> = readings.iter().zip(&idle).map(|(r, i)| r - i).collect();
        let areas_now = link_areas(s.pipeline().map(0).unwrap()).unwrap();
        let contacts = s.pipeline().contacts(0);
        let total: f64 = contacts.iter().map(|c| c.force_n.unwrap()).sum();
        errors.push((total / force - 1.0).abs());
        // What the true curve with every gain 1 would read: the floor a calibration that
        // cannot tell the taxels apart reaches.
        let unit: f64 = contacts
            .iter()
            .flat_map(|c| c.taxels.iter())
            .map(|&i| TRUE.stress_kpa(f64::from(readings_now[i]), 1.0).0 * 1e3 * areas_now[i])
            .sum();
        floor.push((unit / force - 1.0).abs());
        check_wrench(&s, &under, total);
        assert!(
            under
                .iter()
                .all(|&i| contacts.iter().any(|c| c.taxels.contains(&i)))
        );
        for gap in 1..4 {
            step(&mut s, 200 + 10 * k as u64 + gap, &idle, &mut events);
        }
    }
    // Within the bounds force control needs (10% median, 20% at the 95th percentile), and no
    // worse than the true curve with the gains unknown: 150 presses of total force alone
    // cannot single out 715 gains (each frame is one sum), so gains are held near 1 where
    // the presses leave them open.
    let stats = |e: &mut Vec<f64>| {
        e.sort_by(f64::total_cmp);
        (e[e.len() / 2], e[e.len() * 95 / 100])
    };
    let ((median, p95), (floor_median, floor_p95)) = (stats(&mut errors), stats(&mut floor));
    assert!(
        median < 0.10 && p95 < 0.20 && median <= floor_median * 1.1 && p95 <= floor_p95 * 1.1,
        "relative errors: median {median}, 95th {p95}; with the true curve and gains 1: {floor_median}, {floor_p95}"
    );
    // The events carry the force where the session knows it.
    let appeared = events
        .iter()
        .find_map(|e| match e {
            Event::Appeared { touch, .. } => Some(touch.footprint.force_n),
            _ => None,
        })
        .expect("a touch appeared");
    assert!(appeared.is_some_and(|f| f > 1.0), "{appeared:?}");
    let mut line = Vec::new();
    events[0].write_json(&mut line).unwrap();
    assert!(String::from_utf8(line).unwrap().contains("\"force_n\":"));
    // A zero wrench between presses, not a stale one.
    let (w, _) = s.wrench(0).unwrap();
    assert_eq!((w.force, w.cop), (Vector3::zeros(), None));
}

#[test]
fn an_uncalibrated_session_says_nothing_of_newtons() {
    let link = forearm();
    let (mut s, idle) = session(&link);
    let (readings, _) = press(&s, &idle, 300, 0.012, 10.0);
    let mut events: Vec<Event> = Vec::new();
    step(&mut s, 20, &readings, &mut events);
    assert!(s.wrench(0).is_none());
    assert!(s.pipeline().contacts(0).iter().all(|c| c.force_n.is_none()));
    let mut line = Vec::new();
    events[0].write_json(&mut line).unwrap();
    assert!(!String::from_utf8(line).unwrap().contains("force_n"));
}

#[test]
fn a_calibration_of_another_link_or_layout_is_refused_by_name() {
    let link = forearm();
    let (s, _) = session(&link);
    let map = s.pipeline().map(0).unwrap();
    let mut lf = skin_core::format::force_file::LinkForce {
        name: "wrist".into(),
        curve: TRUE,
        ids: map.ids.iter().map(|id| id.0).collect(),
        gains: vec![1.0; map.ids.len()],
        fit: serde_json::Value::Null,
    };
    let e = s
        .with_force(&ForceCalibration::new(vec![lf.clone()]), Path::new("f.json"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("f.json") && e.contains("\"wrist\" is not in the layout") && e.contains("forearm"),
        "{e}"
    );
    let (s, _) = session(&link);
    lf.name = "forearm".into();
    lf.ids.swap(0, 1);
    let e = s
        .with_force(&ForceCalibration::new(vec![lf]), Path::new("f.json"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("f.json") && e.contains("ids[0]") && e.contains("another layout"),
        "{e}"
    );
}

#[test]
fn a_restarted_session_keeps_its_calibration_and_forgets_the_last_wrench() {
    let link = forearm();
    let (s, idle) = session(&link);
    let map = s.pipeline().map(0).unwrap();
    let calibration = ForceCalibration::new(vec![skin_core::format::force_file::LinkForce {
        name: "forearm".into(),
        curve: TRUE,
        ids: map.ids.iter().map(|id| id.0).collect(),
        gains: (0..map.ids.len()).map(gain).collect(),
        fit: serde_json::Value::Null,
    }]);
    let mut s = s.with_force(&calibration, Path::new("f.json")).unwrap();
    let (readings, _) = press(&s, &idle, 300, 0.012, 8.0);
    let mut events: Vec<Event> = Vec::new();
    step(&mut s, 20, &readings, &mut events);
    let (w, _) = s.wrench(0).unwrap();
    // The true curve and gains: the press's 8 N back to rounding of the counts.
    assert!((w.magnitude - 8.0).abs() < 0.01 * 8.0, "{}", w.magnitude);
    let s = s.restarted().unwrap();
    let (w, saturated) = s.wrench(0).expect("the calibration stays");
    assert_eq!((w.magnitude, w.cop, saturated), (0.0, None, 0));
}

#[test]
fn a_press_over_a_dead_taxel_keeps_its_force() {
    use skin_learn::touch::{TouchOptions, TouchPipeline};
    let link = forearm();
    let map = skin_geom::TactileMap::flatten(&link, &skin_geom::FlattenOptions::default()).unwrap();
    let areas = link_areas(&map).unwrap();
    let n = areas.len();
    let model = skin_core::force::ForceModel::new(TRUE, (0..n).map(gain).collect(), areas.clone()).unwrap();
    let normals = link.taxels.iter().map(|t| t.normal.into_inner()).collect();
    let mut pipeline =
        TouchPipeline::new(vec![map.clone()], Models::none(), TouchOptions::default()).unwrap();
    pipeline.set_force(0, model, normals).unwrap();
    // 10 N spread evenly over the taxels within 12 mm of taxel 300, the middle one dead.
    let c = map.positions[300];
    let under: Vec<usize> = (0..n)
        .filter(|&i| (map.positions[i] - c).norm() <= 0.012)
        .collect();
    let stress = 10.0 / under.iter().map(|&i| areas[i]).sum::<f64>() / 1e3;
    let dead = 300;
    let share = areas[dead] / under.iter().map(|&i| areas[i]).sum::<f64>();
    let mut pressures = vec![0.0f32; n];
    for &i in under.iter().filter(|&&i| i != dead) {
        pressures[i] = TRUE.counts(stress, gain(i)).round() as f32;
    }
    pipeline.set_dead(0, &[dead]).unwrap();
    let mut events = Vec::new();
    pipeline.process(1.0, &[pressures], &mut events).unwrap();
    let (w, _) = pipeline.wrench(0).unwrap();
    // Without the bridged areas the press would read short by the dead taxel's share.
    assert!(share > 0.04, "the dead taxel's share {share}");
    assert!(
        (w.magnitude / 10.0 - 1.0).abs() < share / 2.0,
        "{} N of 10 (share {share})",
        w.magnitude
    );
}
