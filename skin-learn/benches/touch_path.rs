//! The whole per-frame path of the thesis' full arm, through the `Session` that `skin run`
//! drives: 3,495 taxels on three links (half-cylinder covers, 8 mm pitch, 1,165 taxels each), 318
//! Cyskin modules on four skin16 buses, the links end to end and stitched at their joints
//! (thesis Ch. 6). One cycle = its CAN frames decoded and assembled, then `Session::push_can`:
//! the frame placed into links, the baseline applied, contacts searched on every link and over
//! the stitched chain, touches tracked, events typed and handed to a sink (one that keeps
//! nothing, as a robot stack acting on them would); a frame that decides a touch also images it
//! and runs the shipped HandsNet.
//!
//! - `no contact`: a cycle of an untouched arm (what offline replay mostly costs);
//! - `decision`: the cycle whose frame holds a hand on the middle link and decides it
//!   (decide_frames = 1): frame -> decision latency.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Translation3};
use skin_can::candump::CanFrame;
use skin_can::decode::skin16::{encode_module, encode_sync};
use skin_can::{Assembler, BusMap, WireFormat};
use skin_core::force::ResponseCurve;
use skin_core::format::force_file::{ForceCalibration, LinkForce};
use skin_core::format::poses::{Posture, Postures};
use skin_core::{LinkSkin, TaxelId};
use skin_geom::{FlattenOptions, StitchOptions, Stitcher, TactileMap};
use skin_learn::classify::{Classifier, InputScale};
use skin_learn::model::{Classes, Models};
use skin_learn::session::{Event, Flow, Session, SessionOptions, Sink, Stitching};
use skin_learn::touch::{TouchOptions, TouchPipeline};
use std::path::Path;
use std::time::{Duration, Instant};

use skin_learn::synth::arm::{hand_on_middle_link, link};

struct Arm {
    links: Vec<LinkSkin>,
    map: BusMap,
    interfaces: Vec<String>,
    /// Bus-map slot -> (link, taxel), to write the test traffic.
    slots: Vec<(usize, usize)>,
}

impl Arm {
    /// The CAN frames of cycle `n` carrying `raw[link][taxel]`.
    fn cycle(&self, n: u64, raw: &[Vec<u16>]) -> Vec<CanFrame> {
        let t0 = 1_000_000 + n * 50_000;
        let mut frames = Vec::new();
        let ids = self.map.taxel_ids();
        let mut slot = 0;
        for (b, bus) in self.map.buses.iter().enumerate() {
            frames.push(encode_sync(n as u8, t0, b as u16));
            for (m, module) in bus.modules.iter().enumerate() {
                let mut readings = [0u16; 12];
                for (c, &t) in module.taxels.iter().enumerate() {
                    if t >= 0 {
                        debug_assert_eq!(ids[slot].0 as i64, t);
                        let (l, i) = self.slots[slot];
                        readings[c] = raw[l][i];
                        slot += 1;
                    }
                }
                frames.extend(encode_module(
                    m as u32,
                    &readings,
                    t0 + 100 * (m as u64 + 1),
                    b as u16,
                ));
            }
        }
        frames
    }
}

/// Counts events and keeps nothing: the cost of the path, not of a writer.
struct Count(usize);

impl Sink for Count {
    type Error = std::convert::Infallible;

    fn event(&mut self, _: &Event) -> Result<Flow, Self::Error> {
        self.0 += 1;
        Ok(Flow::Continue(()))
    }
}

/// The full arm: three links of 1,165 taxels on four buses.
fn full_arm() -> Arm {
    let links: Vec<LinkSkin> = (0..3).map(link).collect();
    let ids: Vec<TaxelId> = links.iter().flat_map(|l| l.ids()).collect();
    assert_eq!(ids.len(), 3495);
    let map = BusMap::for_taxels(&ids, WireFormat::Skin16, 4).unwrap();
    let interfaces: Vec<String> = map.buses.iter().map(|b| b.interface.clone()).collect();
    let where_is: std::collections::HashMap<TaxelId, (usize, usize)> = links
        .iter()
        .enumerate()
        .flat_map(|(l, link)| link.taxels.iter().enumerate().map(move |(i, t)| (t.id, (l, i))))
        .collect();
    let slots = map.taxel_ids().iter().map(|id| where_is[id]).collect();
    Arm {
        links,
        map,
        interfaces,
        slots,
    }
}

/// The three links end to end along y, 6 mm apart, stitched once (a posture held, as in
/// `skin run`).
fn stitched_in_a_row(maps: &[TactileMap]) -> Stitching {
    let poses: Vec<Isometry3<f64>> = (0..3)
        .map(|k| Translation3::new(0.0, k as f64 * 0.2623, 0.0).into())
        .collect();
    let stitched = Stitcher::new(maps.to_vec(), &poses, StitchOptions::default())
        .unwrap()
        .reset(&poses)
        .unwrap();
    assert!(stitched.bridges.len() > 20, "{} bridges", stitched.bridges.len());
    let postures = Postures {
        links: maps.iter().map(|m| m.name.clone()).collect(),
        postures: vec![Posture {
            name: "held".into(),
            time_s: 0.0,
            poses,
        }],
    };
    Stitching::new(maps, postures, Path::new("poses")).unwrap()
}

/// A force calibration of every link of the arm: the `[sim]` response's curve, every gain 1.
fn every_link_calibrated(arm: &Arm) -> ForceCalibration {
    ForceCalibration::new(
        arm.links
            .iter()
            .map(|l| LinkForce {
                name: l.name.clone(),
                curve: ResponseCurve {
                    full_scale: 4095.0,
                    half_scale_kpa: 150.0,
                },
                ids: l.taxels.iter().map(|t| t.id.0).collect(),
                gains: vec![1.0; l.taxels.len()],
                fit: serde_json::Value::Null,
            })
            .collect(),
    )
}

/// The arm's session: HandsNet deciding on the first frame of a touch, over the stitched maps.
fn arm_session(arm: &Arm, maps: Vec<TactileMap>, stitching: Stitching) -> Session {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let model = root.join("fixtures/models/handsnet.onnx");
    let classifier = Classifier::load(&model, InputScale::Unit).unwrap();
    let options = TouchOptions {
        decide_frames: 1,
        release_frames: 1,
        threshold: 5.0,
        ..TouchOptions::default()
    };
    let models = Models::new(classifier, Classes::hand_or_not());
    let pipeline = TouchPipeline::new(maps, models, options).unwrap();
    Session::new(arm.links.clone(), pipeline, SessionOptions::default())
        .unwrap()
        .with_can(&arm.map)
        .unwrap()
        .with_stitching(stitching)
        .unwrap()
}

#[allow(clippy::too_many_lines)] // one arm's set-up, then its four cases, read top to bottom
fn bench(c: &mut Criterion) {
    let arm = full_arm();
    let ids = arm.map.taxel_ids();
    let maps: Vec<TactileMap> = arm
        .links
        .iter()
        .map(|l| TactileMap::flatten(l, &FlattenOptions::default()).unwrap())
        .collect();
    let stitching = stitched_in_a_row(&maps);
    // A whole hand on the middle link, from the synthetic-data generator.
    let hand = hand_on_middle_link(&arm.links, &maps[1]).unwrap();
    let offset = 300u16;
    let quiet: Vec<Vec<u16>> = arm.links.iter().map(|l| vec![offset; l.taxels.len()]).collect();
    let touched: Vec<Vec<u16>> = quiet
        .iter()
        .zip(&hand)
        .map(|(q, h)| q.iter().zip(h).map(|(o, p)| o + p.round() as u16).collect())
        .collect();

    // The same session, and one with a force model on every link (the [sim] response's curve,
    // every gain 1): what newtons add to a frame with a touch.
    let mut weighed = arm_session(&arm, maps.clone(), stitched_in_a_row(&maps))
        .with_force(&every_link_calibrated(&arm), Path::new("force.json"))
        .unwrap();
    let mut session = arm_session(&arm, maps, stitching);
    let mut sink = Count(0);
    let mut assembler = Assembler::for_map(&arm.map, &arm.interfaces, skin_can::DEFAULT_WINDOW_US);
    let mut n = 0u64;
    let mut push = |frames: &[CanFrame], session: &mut Session| {
        for f in frames {
            assembler.push(f, &mut |a| {
                let _ = session.push_can(a, &mut sink).unwrap();
            });
        }
    };
    // The CAN frames of 256 cycles (the sync counter's period), touched and quiet.
    let quiet_cycles: Vec<Vec<CanFrame>> = (0..256).map(|k| arm.cycle(k, &quiet)).collect();
    let touched_cycles: Vec<Vec<CanFrame>> = (0..256).map(|k| arm.cycle(k, &touched)).collect();
    let can_frames = quiet_cycles[0].len();
    // The session learns its baseline from the first untouched frames, as `skin run` does.
    while session.pipeline().times().frames == 0 {
        push(&quiet_cycles[(n % 256) as usize], &mut session);
        n += 1;
    }
    let mut m = 0u64;
    while weighed.pipeline().times().frames == 0 {
        push(&quiet_cycles[(m % 256) as usize], &mut weighed);
        m += 1;
    }

    let mut group = c.benchmark_group(format!(
        "full arm ({} taxels, 3 links, 4 buses, {can_frames} CAN frames a cycle)",
        ids.len()
    ));
    group.bench_function("no contact", |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                push(&quiet_cycles[(n % 256) as usize], &mut session);
                n += 1;
            }
            start.elapsed()
        })
    });
    group.bench_function("decision", |b| {
        b.iter_custom(|iters| {
            let mut spent = Duration::ZERO;
            for _ in 0..iters {
                // This cycle's frame is assembled when the next cycle's sync arrives: push the
                // touched cycle, then time the next one, whose first frame delivers the touch.
                push(&touched_cycles[(n % 256) as usize], &mut session);
                n += 1;
                let runs = session.pipeline().times().runs.0;
                let start = Instant::now();
                push(&quiet_cycles[(n % 256) as usize], &mut session);
                spent += start.elapsed();
                n += 1;
                assert_eq!(
                    session.pipeline().times().runs.0,
                    runs + 1,
                    "one decision per touched frame"
                );
            }
            spent
        })
    });
    // A touch held (decided at its first frame, then only followed): its contacts found, and
    // in newtons their forces and the link's wrench too; one after the other, in the same run.
    let mut held = |b: &mut criterion::Bencher<'_>, session: &mut Session, n: &mut u64| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                push(&touched_cycles[(*n % 256) as usize], session);
                *n += 1;
            }
            start.elapsed()
        })
    };
    group.bench_function("held touch", |b| held(b, &mut session, &mut n));
    group.bench_function("held touch, in newtons", |b| held(b, &mut weighed, &mut m));
    assert!(
        weighed.wrench(1).is_some_and(|(w, _)| w.magnitude > 0.0),
        "the held hand is weighed"
    );
    group.finish();
    // Where a decision's time goes, over every frame the session saw (quiet frames included in
    // the contact search): the model against the rest, measured in the same run.
    let t = session.pipeline().times();
    let runs = t.runs.0.max(1) as f64;
    eprintln!(
        "per decision: tactile image {:.0} us, classifier {:.2} ms; contact search {:.1} us a frame ({} frames, {} decisions)",
        t.image.as_secs_f64() * 1e6 / runs,
        t.classify.as_secs_f64() * 1e3 / runs,
        t.contacts.as_secs_f64() * 1e6 / t.frames.max(1) as f64,
        t.frames,
        t.runs.0
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = bench
}
criterion_main!(benches);
