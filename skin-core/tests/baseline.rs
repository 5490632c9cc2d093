//! Baselines: offsets, noise thresholds, drift tracking, dead and stuck taxels.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_core::{Baseline, BaselineOptions, Polarity};
use std::path::Path;

/// Idle frames: taxel i sits at 1000 + 10 i with a +-2 count wobble; taxel 3 never moves, taxel 4
/// is pinned at 65535.
fn idle(frames: usize) -> Vec<Vec<f32>> {
    (0..frames)
        .map(|k| {
            (0..6)
                .map(|i| match i {
                    3 => 500.0,
                    4 => 65535.0,
                    _ => 1000.0 + 10.0 * i as f32 + [-2.0, 0.0, 2.0, 0.0][(k + i) % 4],
                })
                .collect()
        })
        .collect()
}

fn learn(frames: &[Vec<f32>], options: &BaselineOptions) -> (Baseline, skin_core::TaxelHealth) {
    Baseline::from_idle(frames.iter().map(Vec::as_slice), options, Path::new("idle")).unwrap()
}

#[test]
fn offsets_are_the_idle_means_and_noise_is_six_sigma_of_the_taxel_or_the_link() {
    let (b, health) = learn(&idle(40), &BaselineOptions::default());
    assert_eq!(b.len(), 6);
    assert!((b.offsets()[2] - 1020.0).abs() < 1e-3);
    // Readings -2, 0, 2, 0 repeating: sample sd = sqrt(2 * 40 / 39).
    let sd = (2.0f32 * 40.0 / 39.0).sqrt();
    assert!((b.noise()[0] - 6.0 * sd).abs() < 1e-3, "{}", b.noise()[0]);
    // A taxel that sat still gets the link's noise (its 90th-percentile taxel's), not zero.
    assert!((b.noise()[3] - 6.0 * sd).abs() < 1e-3, "{}", b.noise()[3]);
    assert_eq!(health.dead, vec![3]);
    assert_eq!(health.stuck, vec![4]);
    // Resting at 0, the rail pressure moves away from, is a stream that clips at rest: it can
    // still read pressure, so it is neither dead nor stuck. Pinned at 0 with falling readings,
    // it is stuck.
    let zeros: Vec<Vec<f32>> = (0..10).map(|_| vec![0.0, 2.0]).collect();
    let (_, rest) = learn(&zeros, &BaselineOptions::default());
    assert!(rest.stuck.is_empty() && rest.dead == vec![1], "{rest:?}");
    let falling = BaselineOptions {
        polarity: Polarity::Falling,
        ..BaselineOptions::default()
    };
    assert_eq!(learn(&zeros, &falling).1.stuck, vec![0]);
    // Without the link's floor, only the minimum is left for it.
    let own = BaselineOptions {
        noise_floor_quantile: 0.0,
        ..BaselineOptions::default()
    };
    assert_eq!(learn(&idle(40), &own).0.noise()[3], 1.0);
}

#[test]
fn a_few_noisy_taxels_do_not_set_the_links_floor() {
    // 20 taxels: 18 wobble by +-1, 2 by +-100. The floor is the 90th-percentile taxel's: +-1.
    let frames: Vec<Vec<f32>> = (0..10)
        .map(|k| {
            (0..20)
                .map(|i| {
                    let w = if k % 2 == 0 { 1.0 } else { -1.0 };
                    1000.0 + w * if i < 2 { 100.0 } else { 1.0 }
                })
                .collect()
        })
        .collect();
    let (b, _) = learn(&frames, &BaselineOptions::default());
    let sd = |a: f32| a * (10.0f32 / 9.0).sqrt();
    assert!((b.noise()[0] - 6.0 * sd(100.0)).abs() < 1e-2, "{}", b.noise()[0]);
    assert!((b.noise()[5] - 6.0 * sd(1.0)).abs() < 1e-3, "{}", b.noise()[5]);
}

#[test]
fn pressures_are_readings_above_the_offset_beyond_the_noise() {
    let (mut b, _) = learn(&idle(40), &BaselineOptions::default());
    let raw = [
        1000.0 + 3.0,
        1010.0 + 300.0,
        1020.0 + 10.0,
        500.0,
        65535.0,
        1050.0 - 40.0,
    ];
    let mut p = [9.0f32; 6];
    b.apply(&raw, &mut p).unwrap();
    assert_eq!(p[0], 0.0, "3 counts is within the noise");
    assert!((p[1] - 300.0).abs() < 1e-3);
    assert!((p[2] - 10.0).abs() < 1e-3, "10 counts is beyond 6 sigma (8.6)");
    assert_eq!(
        p[5], 0.0,
        "pressure does not lower a Cyskin reading: no negative pressures"
    );
    assert!(b.apply(&raw[..5], &mut p).is_err());
}

#[test]
fn drift_is_followed_only_while_there_is_no_contact() {
    let options = BaselineOptions {
        drift_per_frame: 0.05,
        ..BaselineOptions::default()
    };
    let (mut b, _) = learn(&idle(40), &options);
    let before = b.offsets().to_vec();
    let mut p = [0.0f32; 6];
    // The no-contact reading of taxel 0 creeps up by 20 counts over 400 frames...
    for k in 0..400 {
        let mut raw: Vec<f32> = idle(1)[0].clone();
        raw[0] = 1000.0 + 20.0 * k as f32 / 400.0;
        // ...while taxel 1 is pressed hard throughout.
        raw[1] = 1010.0 + 500.0;
        b.apply(&raw, &mut p).unwrap();
        assert_eq!(p[0], 0.0, "frame {k}: drift must not look like a touch");
    }
    // An exponential follower lags a ramp by slope / rate = (20 / 400) / 0.05 = 1 count.
    let last = 1000.0 + 20.0 * 399.0 / 400.0;
    assert!((b.offsets()[0] - (last - 1.0)).abs() < 0.05, "{}", b.offsets()[0]);
    // The pressed taxel follows what the others followed, on average (the link's common drift:
    // here a fifth of taxel 0's), not its own reading.
    let others = [0, 2, 3, 4, 5];
    let common = others.iter().map(|&i| b.offsets()[i] - before[i]).sum::<f32>() / others.len() as f32;
    assert!(common > 3.0 && common < 4.2, "{common}");
    assert!(
        (b.offsets()[1] - (before[1] + common)).abs() < 1e-2,
        "a pressed taxel follows the common drift: {} vs {}",
        b.offsets()[1],
        before[1] + common
    );
    assert!((p[1] - (1510.0 - b.offsets()[1])).abs() < 0.1);
}

#[test]
fn a_press_held_while_the_whole_link_drifts_keeps_its_pressure_and_leaves_nothing() {
    let (mut b, _) = learn(&idle(40), &BaselineOptions::default());
    let mut p = [0.0f32; 6];
    let mut first = None;
    // Every taxel's rest rises 40 counts over 1,200 frames (a minute at 20 Hz) while taxel 1
    // is pressed 500 counts above it.
    for k in 0..1200 {
        let mut raw: Vec<f32> = idle(1)[0].clone();
        let drift = 40.0 * k as f32 / 1200.0;
        raw.iter_mut().for_each(|r| *r += drift);
        raw[1] = 1010.0 + drift + 500.0;
        b.apply(&raw, &mut p).unwrap();
        first.get_or_insert(p[1]);
        assert!(
            p.iter().enumerate().all(|(i, &v)| i == 1 || v == 0.0),
            "frame {k}: {p:?}"
        );
    }
    let first = first.unwrap();
    assert!(
        (p[1] - first).abs() < 0.05 * first,
        "the held press keeps its pressure: {first} then {}",
        p[1]
    );
    // Released: it reads nothing, at once.
    let mut raw: Vec<f32> = idle(1)[0].clone();
    raw.iter_mut().for_each(|r| *r += 40.0);
    b.apply(&raw, &mut p).unwrap();
    assert_eq!(p, [0.0; 6], "no phantom touch where the press was");
}

#[test]
fn falling_readings_give_positive_pressures_for_icub_skin() {
    let frames: Vec<Vec<f32>> = (0..10).map(|k| vec![255.0 - (k % 2) as f32, 250.0]).collect();
    let options = BaselineOptions {
        polarity: Polarity::Falling,
        rails: (0.0, 255.0),
        ..BaselineOptions::default()
    };
    let (mut b, health) = learn(&frames, &options);
    assert!(
        health.stuck.is_empty(),
        "a taxel that only touches the rail is not stuck"
    );
    let mut p = [0.0f32; 2];
    b.apply(&[200.0, 250.0], &mut p).unwrap();
    assert!((p[0] - 54.5).abs() < 1e-3 && p[1] == 0.0, "{p:?}");
}

#[test]
fn too_few_or_ragged_idle_frames_are_errors() {
    let one = idle(1);
    let e = Baseline::from_idle(
        one.iter().map(Vec::as_slice),
        &BaselineOptions::default(),
        Path::new("idle.txt"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("at least 2"), "{e}");
    let mut ragged = idle(3);
    ragged[2].pop();
    let e = Baseline::from_idle(
        ragged.iter().map(Vec::as_slice),
        &BaselineOptions::default(),
        Path::new("idle.txt"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("idle frame 2"), "{e}");
}

#[test]
fn the_learner_gives_what_from_idle_gives_and_a_bad_frame_changes_nothing() {
    use skin_core::BaselineLearner;
    let frames = idle(30);
    let other: Vec<Vec<f32>> = frames
        .iter()
        .map(|f| f[..2].iter().map(|v| v + 7.0).collect())
        .collect();
    let mut learner = BaselineLearner::new(&[6, 2], 30, BaselineOptions::default()).unwrap();
    for (k, (a, b)) in frames.iter().zip(&other).enumerate() {
        assert!(!learner.is_done());
        if k == 10 {
            // A NaN in the second link, a short first link: refused, nothing taken.
            let mut bad = b.clone();
            bad[1] = f32::NAN;
            assert!(learner.push(&[a.clone(), bad]).is_err());
            assert!(learner.push(&[a[..5].to_vec(), b.clone()]).is_err());
            assert!(learner.push(std::slice::from_ref(a)).is_err());
            assert_eq!(learner.frames(), 10);
        }
        learner.push(&[a.clone(), b.clone()]).unwrap();
    }
    assert!(learner.is_done());
    let learned = learner.finish(Path::new("idle")).unwrap();
    assert_eq!(learned[0], learn(&frames, &BaselineOptions::default()));
    assert_eq!(learned[1], learn(&other, &BaselineOptions::default()));
    for frames in [0, 1, 100_001] {
        assert!(BaselineLearner::new(&[6], frames, BaselineOptions::default()).is_err());
    }
}

use skin_test_support::shared_data;

/// For each real Cyskin recording of `fingers` fingers: whether, with the baseline of its first
/// 5 frames (default options), any later frame presses 2 taxels or more.
fn pressed_recordings(fingers: usize) -> Option<Vec<bool>> {
    let dir = shared_data::shared(&format!("cyskin/recordings/{fingers}_finger"))?;
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    Some(
        files
            .iter()
            .map(|f| {
                let rec = skin_core::format::recording::read(f).unwrap();
                let idle = rec.frames[..5].iter().map(|fr| fr.values.as_slice());
                let (mut b, health) = Baseline::from_idle(idle, &BaselineOptions::default(), f).unwrap();
                // Cyskin rests at 0 on most taxels: that is no fault.
                assert!(
                    health.stuck.is_empty(),
                    "{}: stuck {:?}",
                    f.display(),
                    health.stuck
                );
                let mut p = vec![0.0f32; rec.taxel_ids.len()];
                rec.frames[5..].iter().any(|fr| {
                    b.apply(&fr.values, &mut p).unwrap();
                    p.iter().filter(|&&v| v > 0.0).count() >= 2
                })
            })
            .collect(),
    )
}

#[test]
fn on_the_real_recordings_nobody_touching_presses_nothing_and_a_finger_does() {
    let (Some(none), Some(one)) = (pressed_recordings(0), pressed_recordings(1)) else {
        return;
    };
    let share = |v: &[bool]| v.iter().filter(|&&p| p).count() as f64 / v.len() as f64;
    // Idle noise reaches 1,000 to 3,700 counts on these; presses 5,000 to 13,000.
    assert!(
        share(&none) <= 0.05,
        "{:.0}% of the 0-finger recordings press 2 taxels",
        100.0 * share(&none)
    );
    assert!(
        share(&one) >= 0.9,
        "{:.0}% of the 1-finger recordings press 2 taxels",
        100.0 * share(&one)
    );
}

/// `taxels` taxels resting at 1000 + i with a +-1 count wobble (uniform noise, as the fixture
/// skin's), one frame.
fn rest(taxels: usize, k: usize) -> Vec<f32> {
    (0..taxels)
        .map(|i| 1000.0 + i as f32 + [-1.0, 0.0, 1.0][(k * 7 + i * 3) % 3])
        .collect()
}

#[test]
fn a_touch_in_progress_while_the_baseline_is_learned_is_not_learned_as_noise() {
    // 100 taxels; while the 20 idle frames are taken, a touch on taxels 0..15 rises from
    // nothing to 400 counts.
    let frames: Vec<Vec<f32>> = (0..20)
        .map(|k| {
            let mut f = rest(100, k);
            for v in &mut f[..15] {
                *v += 20.0 * k as f32;
            }
            f
        })
        .collect();
    let (mut b, health) = learn(&frames, &BaselineOptions::default());
    assert_eq!(health.pressed, (0..15).collect::<Vec<_>>());
    // The other taxels keep the skin's noise: the touch did not set the link's floor (15% of the
    // taxels, past the 90th percentile it is taken at).
    let sd = b.noise()[50] / 6.0;
    assert!(sd < 1.0, "noise sd {sd}: the touch was learned as noise");
    // The pressed taxels rest at their least pressed reading, with the link's noise.
    assert!((b.offsets()[3] - frames[0][3]).abs() < 1e-3);
    assert_eq!(b.noise()[3], b.noise()[50]);
    // A light touch of 15 counts elsewhere reads as pressure.
    let mut raw = rest(100, 21);
    raw[60] += 15.0;
    raw[61] += 15.0;
    let mut p = vec![0.0; 100];
    b.apply(&raw, &mut p).unwrap();
    assert!(p[60] > 10.0 && p[61] > 10.0, "{} {}", p[60], p[61]);
}

#[test]
fn noise_is_not_taken_for_a_touch_however_large() {
    // Two taxels whose noise is 100 times the others' are noisy, not pressed: their readings
    // jump back and forth, a touch moves smoothly.
    let frames: Vec<Vec<f32>> = (0..20)
        .map(|k| {
            let mut f = rest(50, k);
            let w = if k % 2 == 0 { 100.0 } else { -100.0 };
            f[0] += w;
            f[1] -= w;
            f
        })
        .collect();
    let (b, health) = learn(&frames, &BaselineOptions::default());
    assert!(health.pressed.is_empty(), "{:?}", health.pressed);
    assert!(b.noise()[0] > 500.0, "{}", b.noise()[0]);
}

#[test]
fn a_baseline_learned_under_a_steady_press_is_corrected_when_the_press_goes() {
    // Someone leans on taxels 0..10 (+500 counts, steady) while the baseline is learned: the
    // readings do not move, so nothing tells the press from rest yet.
    let pressed = |k: usize, force: f32| {
        let mut f = rest(60, k);
        for v in &mut f[..10] {
            *v += force;
        }
        f
    };
    let frames: Vec<Vec<f32>> = (0..20).map(|k| pressed(k, 500.0)).collect();
    let (mut b, health) = learn(&frames, &BaselineOptions::default());
    assert!(health.pressed.is_empty());
    let mut p = vec![0.0; 60];
    // They let go: the readings fall 500 counts below the offsets. One frame could be a
    // glitch: nothing is reset yet; the second frame resets all ten.
    assert_eq!(b.apply(&pressed(20, 0.0), &mut p).unwrap(), 0);
    assert_eq!(b.apply(&pressed(21, 0.0), &mut p).unwrap(), 10);
    assert!(
        p.iter().all(|&v| v == 0.0),
        "no negative or phantom pressure: {p:?}"
    );
    assert_eq!(b.take_corrected(), 10);
    assert_eq!(b.take_corrected(), 0, "counted once");
    // From the next frame a press of 50 counts on those taxels reads 50 (the slow drift
    // tracking alone would take hundreds of frames to come down 500 counts).
    b.apply(&pressed(22, 50.0), &mut p).unwrap();
    for &v in &p[..10] {
        assert!((v - 50.0).abs() <= 2.0, "{v}");
    }
    assert!(p[10..].iter().all(|&v| v == 0.0));
}

#[test]
fn one_frame_below_the_baseline_is_a_glitch_not_a_correction() {
    let (mut b, _) = learn(
        &(0..20).map(|k| rest(10, k)).collect::<Vec<_>>(),
        &BaselineOptions::default(),
    );
    let offsets = b.offsets().to_vec();
    let mut p = vec![0.0; 10];
    for k in 0..200 {
        let mut raw = rest(10, k);
        if k % 3 == 0 {
            raw[4] -= 300.0; // a lone glitch every third frame
        }
        assert_eq!(b.apply(&raw, &mut p).unwrap(), 0, "frame {k}");
    }
    assert!(
        (b.offsets()[4] - offsets[4]).abs() < 1.0,
        "{} {}",
        b.offsets()[4],
        offsets[4]
    );
    assert_eq!(b.take_corrected(), 0);
}

#[test]
fn a_long_touch_does_not_fade_and_the_drift_under_it_is_corrected_at_release() {
    // Learned at rest. Then taxel 0 is pressed (+300 counts) for five minutes at 20 Hz while
    // its rest level drifts 60 counts down (the iCub skin's known failure: a baseline that
    // follows the reading under a long touch eats the touch, and reads negative after it).
    let (mut b, _) = learn(
        &(0..20).map(|k| rest(10, k)).collect::<Vec<_>>(),
        &BaselineOptions::default(),
    );
    let mut p = vec![0.0; 10];
    let frames = 6000;
    let drift = |k: usize| -60.0 * k as f32 / frames as f32;
    for k in 0..frames {
        let mut raw = rest(10, k);
        raw[0] += 300.0 + drift(k);
        b.apply(&raw, &mut p).unwrap();
        // The touch is still read at the end: its pressure is the press less the drift.
        assert!((p[0] - (300.0 + drift(k))).abs() <= 2.0, "frame {k}: {}", p[0]);
    }
    // Released: the rest level is 60 counts lower than the offset learned before the touch.
    let mut raw = rest(10, frames);
    raw[0] += drift(frames);
    b.apply(&raw, &mut p).unwrap();
    b.apply(&raw, &mut p).unwrap();
    assert_eq!(b.take_corrected(), 1);
    // A press of 40 counts right after reads 40, not 40 less the drift.
    raw[0] += 40.0;
    b.apply(&raw, &mut p).unwrap();
    assert!((p[0] - 40.0).abs() <= 2.0, "{}", p[0]);
}

#[test]
fn an_icub_baseline_learned_under_a_press_is_corrected_too() {
    // iCub: 255 at no load, pressure lowers the reading. Taxel 0 is pressed to 180 while the
    // baseline is learned; the press goes and it reads 250 again.
    let options = BaselineOptions {
        polarity: Polarity::Falling,
        rails: (0.0, 255.0),
        ..BaselineOptions::default()
    };
    let frames: Vec<Vec<f32>> = (0..10)
        .map(|k| vec![180.0 + (k % 2) as f32, 250.0 - (k % 2) as f32])
        .collect();
    let (mut b, _) = learn(&frames, &options);
    let mut p = [0.0f32; 2];
    assert_eq!(b.apply(&[250.0, 250.0], &mut p).unwrap(), 0);
    assert_eq!(b.apply(&[250.0, 250.0], &mut p).unwrap(), 1);
    assert_eq!(p, [0.0, 0.0]);
    b.apply(&[230.0, 250.0], &mut p).unwrap();
    assert!((p[0] - 20.0).abs() < 1e-3, "{p:?}");
}

#[test]
fn a_polarity_is_read_by_name_and_a_wrong_one_lists_the_names() {
    for p in [Polarity::Rising, Polarity::Falling] {
        assert_eq!(p.name().parse::<Polarity>(), Ok(p));
        assert_eq!(p.to_string(), p.name());
        // JSON writes it as configuration files do, and reads it back.
        let json = serde_json::to_string(&p).unwrap();
        assert_eq!(json, format!("\"{}\"", p.name()));
        assert_eq!(serde_json::from_str::<Polarity>(&json).unwrap(), p);
    }
    let e = "Rising".parse::<Polarity>().unwrap_err();
    assert_eq!(e.to_string(), "\"Rising\": expected \"rising\" or \"falling\"");
    let e = serde_json::from_str::<Polarity>("\"up\"")
        .unwrap_err()
        .to_string();
    assert!(e.contains("\"up\": expected \"rising\" or \"falling\""), "{e}");
}
