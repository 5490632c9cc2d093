//! Classify touches: CAN log -> pressures -> touches -> hand or not, and which parts of the hand.
//!
//! ```text
//! cargo run --release -p skin-examples --example classify_touch
//! ```
//! Uses the fixture session (20 scripted touches of the forearm, hands and other contacts) and the
//! shipped models: HandsNet for hand / non-hand and the hand-part segmenter. This is the library
//! side of `skin run`: [`LayoutFrames`] puts each assembled frame in layout order,
//! [`BaselineLearner`] learns the baseline from the first complete frames, and a
//! [`TouchPipeline`] finds the contacts of every frame, follows each touch, and classifies it on
//! its fullest image after three frames of contact.

use skin_can::candump::CandumpLog;
use skin_can::{Assembler, BusMap, DEFAULT_WINDOW_US, LayoutFrames, Missing};
use skin_control::hri::TouchClass;
use skin_core::{Baseline, BaselineLearner, BaselineOptions};
use skin_geom::{FlattenOptions, TactileMap};
use skin_learn::classify::{Classifier, InputScale};
use skin_learn::segment::Segmenter;
use skin_learn::touch::{TouchEvent, TouchOptions, TouchPipeline};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let link = skin_core::format::load_link(&root.join("forearm/layout.json"))?;
    let map = TactileMap::flatten(&link, &FlattenOptions::default())?;
    let bus = BusMap::read(&root.join("forearm/busmap.toml"))?;
    let log = CandumpLog::read(&root.join("session/session.candump.log"))?;

    // The shipped models take pixels scaled to 0..1 (their cards say so).
    let (net, seg) = (
        root.join("models/handsnet.onnx"),
        root.join("models/handseg.onnx"),
    );
    let classifier = Classifier::load(&net, InputScale::Unit)?;
    let segmenter = Segmenter::load(&seg, InputScale::Unit)?;
    let options = TouchOptions {
        threshold: 5.0,
        ..TouchOptions::default()
    };
    let classes = options.classes.clone();
    let mut pipeline = TouchPipeline::new(
        vec![map],
        Some((classifier, net)),
        Some((segmenter, seg)),
        options,
    )?;

    // Every assembled frame of the log, flagged when a module was missing.
    let mut assembled = Vec::new();
    let mut assembler = Assembler::for_map(&bus, &log.interfaces, DEFAULT_WINDOW_US);
    for can_frame in &log.frames {
        assembler.push(can_frame, &mut |f| assembled.push(f.clone()));
    }
    assembler.finish(&mut |f| assembled.push(f.clone()));

    // Bus-map order to layout order, once; a lost module holds its last readings.
    let layout = LayoutFrames::new(&bus, &[link.ids()], Missing::HoldLast)?;
    let mut raw = layout.buffers();
    // The session's first second is untouched: its first 20 complete frames teach the baseline.
    let mut learner = BaselineLearner::new(layout.sizes(), 20, BaselineOptions::default())?;
    let mut baselines: Vec<Baseline> = Vec::new();
    let mut pressures = layout.buffers();
    let mut events = Vec::new();
    let t0 = assembled.first().map_or(0, |f| f.time_us);
    for frame in &assembled {
        let complete = layout.place(frame, &mut raw)?;
        if baselines.is_empty() {
            if complete {
                learner.push(&raw)?;
            }
            if learner.is_done() {
                let source = root.join("session/session.candump.log");
                baselines = learner.finish(&source)?.into_iter().map(|(b, _)| b).collect();
            }
            continue;
        }
        for ((b, r), p) in baselines.iter_mut().zip(&raw).zip(&mut pressures) {
            b.apply(r, p)?;
        }
        events.clear();
        let time = (frame.time_us - t0) as f64 * 1e-6;
        pipeline.process(time, &pressures, &mut events)?;
        for e in &events {
            if let TouchEvent::Classified {
                touch,
                time,
                decision,
                ..
            } = e
            {
                let class = match TouchClass::from_name(&classes[decision.class]) {
                    TouchClass::Hand => "hand",
                    TouchClass::NonHand => "not a hand",
                };
                let parts: Vec<String> = decision
                    .parts
                    .iter()
                    .map(|p| format!("{} ({} taxels)", p.part.name(), p.taxels))
                    .collect();
                println!(
                    "{time:6.2} s  touch {touch:2}: {class} (p = {:.2}) {}",
                    decision.probability,
                    parts.join(", ")
                );
            }
        }
    }
    Ok(())
}
