//! Classify touches: CAN log -> pressures -> touches -> hand or not, and which parts of the hand.
//!
//! ```text
//! cargo run --release -p skin-examples --example classify_touch
//! ```
//! Uses the fixture session (20 scripted touches of the forearm, hands and other contacts) and the
//! shipped models: HandsNet for hand / non-hand and the hand-part segmenter. This is the library
//! side of `skin run`: a [`TouchPipeline`] finds the contacts of every frame, follows each touch,
//! and classifies it on its fullest image after three frames of contact.

use skin_can::candump::CandumpLog;
use skin_can::{Assembler, BusMap, DEFAULT_WINDOW_US};
use skin_core::{Baseline, BaselineOptions};
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
    let mut pipeline = TouchPipeline::new(
        vec![map],
        Some((classifier, net)),
        Some((segmenter, seg)),
        options,
    )?;

    // The bus map lists taxels in its own order; the pipeline wants layout order.
    let ids = bus.taxel_ids();
    let column: Vec<usize> = link
        .taxels
        .iter()
        .map(|t| {
            ids.iter()
                .position(|id| *id == t.id)
                .ok_or(anyhow::anyhow!("taxel {} not on the bus", t.id))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut frames: Vec<(f64, Vec<f32>)> = Vec::new();
    let mut assembler = Assembler::for_map(&bus, &log.interfaces, DEFAULT_WINDOW_US);
    let mut keep = |f: &skin_can::AssembledFrame| {
        let raw = column
            .iter()
            .map(|&c| f.values[c].map_or(f32::NAN, f32::from))
            .collect();
        frames.push((f.time_us as f64 * 1e-6, raw));
    };
    for can_frame in &log.frames {
        assembler.push(can_frame, &mut keep);
    }
    assembler.finish(&mut keep);

    // The session's first second is untouched: it teaches the baseline.
    let idle = 20;
    let path = root.join("session/session.candump.log");
    let (mut baseline, _) = Baseline::from_idle(
        frames[..idle].iter().map(|f| f.1.as_slice()),
        &BaselineOptions::default(),
        &path,
    )?;
    let t0 = frames[0].0;
    let mut pressures = vec![0.0f32; link.taxels.len()];
    let mut events = Vec::new();
    for (time, raw) in &frames[idle..] {
        baseline.apply(raw, &mut pressures)?;
        events.clear();
        pipeline.process(time - t0, &[&pressures], &mut events)?;
        for e in &events {
            if let TouchEvent::Classified {
                touch,
                time,
                decision,
                ..
            } = e
            {
                let class = if decision.class == 0 { "hand" } else { "not a hand" };
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
