//! The per-frame touch path (`skin_learn::touch`): when touches appear, get decided and end, on
//! the bundled forearm with rule-based test models (no model runtime needed), and once with the
//! shipped models (feature `onnx`).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

mod support;
use support::{forearm, rule_models};

use skin_geom::TactileMap;
use skin_learn::model::Models;
use skin_learn::synth::{Kind, SynthOptions, Synthesizer};
use skin_learn::touch::{Released, TouchEvent, TouchOptions, TouchPipeline};

/// A whole-hand grasp wholly on the skin, in map order.
fn hand(map: &TactileMap) -> Vec<f32> {
    let mut synth = Synthesizer::new(map, SynthOptions::default()).unwrap();
    (0..)
        .map(|i| synth.sample(11, 500 + i, i))
        .find(|s| matches!(s.kind, Kind::Hand(_)) && !s.partial && !s.fingertips_only)
        .unwrap()
        .pressures
}

/// Runs `frames` (None: untouched) at 20 Hz; returns the events with their frame index.
fn run(pipeline: &mut TouchPipeline, frames: &[Option<&[f32]>], n: usize) -> Vec<(usize, TouchEvent)> {
    let quiet = vec![0.0f32; n];
    let mut all = Vec::new();
    let mut events = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        events.clear();
        pipeline
            .process(k as f64 * 0.05, &[f.unwrap_or(&quiet)], &mut events)
            .unwrap();
        all.extend(events.drain(..).map(|e| (k, e)));
    }
    events.clear();
    pipeline.finish(frames.len() as f64 * 0.05, &mut events).unwrap();
    all.extend(events.drain(..).map(|e| (frames.len(), e)));
    all
}

/// The default options at a threshold of 10 counts, which these tests' pressures were made for.
fn at_10_counts() -> TouchOptions {
    TouchOptions {
        threshold: 10.0,
        ..TouchOptions::default()
    }
}

/// The shipped models: HandsNet and the hand-part segmenter.
#[cfg(feature = "onnx")]
fn shipped_models() -> Models {
    use skin_learn::classify::{Classifier, InputScale};
    use skin_learn::model::Classes;
    use skin_learn::segment::Segmenter;
    use support::model;
    let classifier = Classifier::load(&model("handsnet.onnx"), InputScale::Unit).unwrap();
    let segmenter = Segmenter::load(&model("handseg.onnx"), InputScale::Unit).unwrap();
    let card = skin_learn::card::ModelCard::for_model(&model("handsnet.onnx")).unwrap();
    Models::new(classifier, Classes::from_card(&card).unwrap().unwrap()).with_segmenter(segmenter)
}

#[test]
fn a_touch_appears_is_decided_after_decide_frames_and_ends_after_release_frames() {
    decided_then_released(rule_models());
}

#[cfg(feature = "onnx")]
#[test]
fn the_shipped_models_decide_a_whole_hand_and_find_its_parts() {
    decided_then_released(shipped_models());
}

fn decided_then_released(models: Models) {
    let map = forearm();
    let press = hand(&map);
    let n = press.len();
    let mut pipeline = TouchPipeline::new(vec![map], models, at_10_counts()).unwrap();
    // 2 quiet, 6 pressed, 1 quiet (a dropped frame: not a release), 2 pressed, 4 quiet.
    let p = Some(press.as_slice());
    let frames = [None, None, p, p, p, p, p, p, None, p, p, None, None, None, None];
    let events = run(&mut pipeline, &frames, n);
    let kinds: Vec<(usize, &str)> = events
        .iter()
        .map(|(k, e)| {
            (
                *k,
                match e {
                    TouchEvent::Appeared(_) => "appeared",
                    TouchEvent::Classified(_) => "classified",
                    TouchEvent::Released(_) => "released",
                },
            )
        })
        .collect();
    // Decided on the 3rd frame of contact; released on the 2nd quiet frame after the last.
    assert_eq!(kinds, [(2, "appeared"), (4, "classified"), (12, "released")]);
    let TouchEvent::Released(Released {
        time,
        duration,
        frames,
        decision,
        peak,
        ..
    }) = &events[2].1
    else {
        unreachable!()
    };
    assert!((time - 0.5).abs() < 1e-9, "the last frame of contact: {time}");
    assert!((duration - 0.4).abs() < 1e-9, "frames 2 to 10: {duration}");
    assert_eq!(*frames, 8);
    let decision = decision.as_ref().unwrap();
    assert_eq!(decision.class.index(), 0, "a whole hand is a hand");
    assert!(decision.class.is_hand());
    assert!(!decision.parts.is_empty(), "and its parts are found");
    let pressed = press.iter().filter(|&&v| v > 10.0).count();
    assert!(
        peak.taxels <= pressed && peak.taxels + 5 >= pressed,
        "{} of {pressed}",
        peak.taxels
    );
    assert_eq!(
        pipeline.times().runs,
        (1, 1),
        "one decision, the touch did not grow"
    );
}

#[test]
fn a_touch_too_short_to_decide_is_decided_at_release_and_growth_reclassifies() {
    let map = forearm();
    let press = hand(&map);
    let n = press.len();
    let classes = skin_learn::model::Classes::hand_or_not();
    let models = Models::new(support::ByArea { hand_pixels: 50 }, classes);
    let mut pipeline = TouchPipeline::new(vec![map], models, at_10_counts()).unwrap();
    let weak: Vec<f32> = press.iter().map(|v| v * 0.5).collect();
    let frames = [
        Some(press.as_slice()),
        None,
        None,
        // Weak for 3 frames (decided), then twice as strong: classified again.
        Some(weak.as_slice()),
        Some(&weak),
        Some(&weak),
        Some(&press),
        None,
        None,
    ];
    let events = run(&mut pipeline, &frames, n);
    let released: Vec<_> = events
        .iter()
        .filter_map(|(_, e)| match e {
            TouchEvent::Released(r) => Some((r.decision.is_some(), r.frames)),
            _ => None,
        })
        .collect();
    assert_eq!(released, [(true, 1), (true, 4)]);
    assert_eq!(
        pipeline.times().runs.0,
        3,
        "1 at the short touch's release, 2 for the growing one"
    );
}

#[test]
fn without_models_touches_are_tracked_and_left_undecided() {
    let map = forearm();
    let press = hand(&map);
    let n = press.len();
    let mut pipeline = TouchPipeline::new(vec![map.clone(), map], Models::none(), at_10_counts()).unwrap();
    let quiet = vec![0.0f32; n];
    let mut events = Vec::new();
    // Link 1 touched, link 0 not.
    pipeline.process(0.0, &[&quiet, &press], &mut events).unwrap();
    assert!(matches!(events[..], [TouchEvent::Appeared(ref a)] if a.link == 1));
    // A frame with one link's pressures missing is an error, not a panic.
    let e = pipeline
        .process(0.05, &[&quiet], &mut events)
        .unwrap_err()
        .to_string();
    assert!(e.contains("1 links") && e.contains("2 links"), "{e}");
    let e = pipeline
        .process(0.05, &[&quiet, &quiet[..10]], &mut events)
        .unwrap_err()
        .to_string();
    assert!(e.contains("10 readings"), "{e}");
    events.clear();
    pipeline.finish(0.1, &mut events).unwrap();
    assert!(matches!(
        events[..],
        [TouchEvent::Released(Released {
            link: 1,
            decision: None,
            ..
        })]
    ));
}
