//! The thesis' full arm (3,495 taxels on three links) at 50 frames/s through a session, served
//! to a browser: a hand presses the middle link for a second, lets go for half a second, and
//! presses again. What `skin-view/bench/latency.py` measures the page's latency on; also a way to
//! see the view without a skin:
//!
//! ```sh
//! cargo run --release -p skin-view --example full_arm_live -- 8080 60
//! ```
//!
//! Arguments: the port (default 8080, 0 for any free one), seconds to run (default 60), frames
//! per second (default 50).

#![allow(clippy::unwrap_used, clippy::expect_used)] // an example: a failed set-up should stop it

use skin_learn::synth::arm::tracking_session;
use skin_view::{Scene, Viewer};
use std::io::Write as _;
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: usize, default: f64| args.get(k).map_or(default, |a| a.parse().expect("a number"));
    let (port, seconds, rate) = (arg(0, 8080.0) as u16, arg(1, 60.0), arg(2, 50.0));

    // Tracking only (no model): the decisions' cost is not the view's.
    let (mut session, idle, held) = tracking_session().expect("the synthetic arm");
    let viewer = Viewer::bind(
        std::net::SocketAddr::from(([127, 0, 0, 1], port)),
        Scene::of_session(&session, "full arm (synthetic)"),
    )
    .unwrap();
    eprintln!("view the skin at {}", viewer.url());
    let _ = std::io::stderr().flush();
    let mut sink = viewer.sink();
    let step = Duration::from_secs_f64(1.0 / rate);
    let frames = (seconds * rate) as u64;
    let start = Instant::now();
    let mut frame = idle.clone();
    for k in 0..frames {
        let t = k as f64 / rate;
        // 1 s pressed, 0.5 s not, the press growing and easing within each second.
        let phase = t % 1.5;
        let squeeze = if phase < 1.0 {
            (std::f64::consts::PI * phase).sin() as f32
        } else {
            0.0
        };
        for ((f, i), h) in frame.iter_mut().zip(&idle).zip(&held) {
            for ((f, i), h) in f.iter_mut().zip(i).zip(h) {
                *f = i + squeeze * (h - i);
            }
        }
        // After the baseline's 20 frames (0 to 0.38 s).
        let _ = session
            .push(1_000_000 + (t * 1e6) as u64, 100 + k, &frame, &mut sink)
            .unwrap();
        let due = start + step * (k as u32 + 1);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
    }
    let s = viewer.stats();
    println!(
        "{frames} frames in {:.1} s; sent {} frames to browsers, {} skipped",
        start.elapsed().as_secs_f64(),
        s.frames_sent,
        s.frames_skipped
    );
}
