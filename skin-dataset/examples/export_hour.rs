//! An hour of the thesis' full arm (3,495 taxels on three links, 50 Hz: 180,000 frames) through
//! a session into a dataset, timed; what BENCHMARKS.md's export rows measure. The frames are
//! made as they go (untouched readings with ±1 count of noise, and a hand held on the middle
//! link one second in four), so memory is the session's and the writer's alone:
//!
//!     cargo run --release -p skin-dataset --example export_hour -- OUT [MINUTES]
//!
//! prints the frames, the seconds, the dataset's bytes; `/usr/bin/time -v` gives the peak
//! memory (compare 10 and 60 minutes: it does not grow with the input).

use skin_dataset::{Dataset, DatasetOptions};
use skin_learn::synth::arm;
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().ok_or("usage: export_hour OUT [MINUTES]")?);
    let minutes: f64 = args.next().map_or(Ok(60.0), |m| m.parse())?;
    let frames = (minutes * 60.0 * 50.0).round() as u64;
    let (mut session, idle, held) = arm::tracking_session()?;
    let mut dataset = Dataset::create(
        &out,
        DatasetOptions::default(),
        &skin_core::output::Inputs::new::<&std::path::Path>([]),
    )?;
    let mut episode = dataset.episode(&session, "synthetic full arm".as_ref(), "-", "synthetic")?;
    let mut frame: Vec<Vec<f32>> = idle.clone();
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let started = Instant::now();
    for k in 0..frames {
        let source = if (k / 50) % 4 == 3 { &held } else { &idle };
        for (dst, src) in frame.iter_mut().zip(source) {
            for (d, s) in dst.iter_mut().zip(src) {
                // xorshift: noise of -1 to 1 count, under the session's threshold (5 counts).
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                *d = s + (state % 3) as f32 - 1.0;
            }
        }
        let _ = session.push(k * 20_000, k, &frame, &mut episode)?;
    }
    let _ = session.finish(&mut episode)?;
    let report = episode.finish(&session)?;
    let summary = dataset.finish()?;
    let seconds = started.elapsed().as_secs_f64();
    let bytes = std::fs::metadata(out.join(&report.data_file))?.len();
    println!(
        "{} frames ({minutes} min at {} Hz) of {} taxels in {seconds:.1} s ({:.1} µs a frame), {} events, data {:.1} MB ({:.0} bytes a frame)",
        summary.frames,
        summary.fps,
        idle.iter().map(Vec::len).sum::<usize>(),
        seconds * 1e6 / frames as f64,
        report.events,
        bytes as f64 / 1e6,
        bytes as f64 / frames as f64
    );
    Ok(())
}
