//! Replay a CAN recording of a skin: candump log -> frames of the whole skin -> pressures.
//!
//! ```text
//! cargo run --release -p skin-examples --example replay_can_log
//! ```
//! Uses the fixture forearm's skin16 log (6.5 s, four touches) and its bus map. The first frames
//! (no contact yet) teach the baseline; every fifth later frame prints how many taxels are pressed.
//! A live robot does the same with `skin_can::live::Acquisition` in place of the log.

use skin_can::candump::CandumpLog;
use skin_can::{AssembledFrame, Assembler, BusMap, DEFAULT_WINDOW_US};
use skin_core::{Baseline, BaselineOptions};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm");
    let map = BusMap::read(&fixtures.join("busmap.toml"))?;
    let log = CandumpLog::read(&fixtures.join("touches.candump.log"))?;

    // One frame per sync cycle, values in bus-map order; partial frames come flagged.
    let mut frames: Vec<AssembledFrame> = Vec::new();
    let mut assembler = Assembler::for_map(&map, &log.interfaces, DEFAULT_WINDOW_US);
    for can_frame in &log.frames {
        assembler.push(can_frame, &mut |f| frames.push(f.clone()));
    }
    assembler.finish(&mut |f| frames.push(f.clone()));
    println!("{} CAN frames -> {} skin frames", log.frames.len(), frames.len());

    // Raw readings as f32; a missing value would be NaN, which Baseline refuses: this log is complete.
    let raw: Vec<Vec<f32>> = frames
        .iter()
        .map(|f| f.values.iter().map(|v| v.map_or(f32::NAN, f32::from)).collect())
        .collect();
    let idle = 10; // the 0.5 s before the first touch
    let (mut baseline, health) = Baseline::from_idle(
        raw[..idle].iter().map(Vec::as_slice),
        &BaselineOptions::default(),
        &fixtures.join("touches.candump.log"),
    )?;
    println!(
        "baseline from {idle} idle frames; dead taxels: {}",
        health.dead.len()
    );

    let mut pressures = vec![0.0f32; map.taxel_ids().len()];
    for (f, r) in frames.iter().zip(&raw).skip(idle).step_by(5) {
        baseline.apply(r, &mut pressures).map_err(anyhow::Error::msg)?;
        // Above the noise threshold is not yet a touch: 10 counts is this skin's active-set threshold.
        let pressed = pressures.iter().filter(|&&p| p > 10.0).count();
        let peak = pressures.iter().copied().fold(0.0f32, f32::max);
        println!(
            "cycle {:>3}: {pressed:>3} taxels pressed, peak {peak:>5.0} counts",
            f.cycle
        );
    }
    Ok(())
}
