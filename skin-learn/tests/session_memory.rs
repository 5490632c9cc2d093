//! A session's memory does not grow with its length: a million frames with 25,000 touches
//! through a session that tracks touches (no models), resident memory measured in this
//! process, which runs nothing else (this file holds one test, so its binary runs only it).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

mod support;

use skin_learn::session::TOUCH_HISTORY;
use support::memory::{Count, Presses, forearm_session, resident_kb};

/// Frames per touch: five pressed, the rest at rest (two of them release it).
const FRAMES_PER_TOUCH: usize = 40;

#[test]
fn a_million_frames_with_25000_touches_keep_resident_memory_flat() {
    let dir = tempfile::tempdir().unwrap();
    let mut session = forearm_session(dir.path(), false);
    let mut presses = Presses::new(&session, 200);
    let mut sink = Count::default();
    presses.rest(&mut session, 40, &mut sink);
    let touches = 25_000;
    // Past the touches a session keeps, with every buffer grown.
    let warm = 2 * TOUCH_HISTORY;
    let mut at_warm = 0;
    let mut highest = 0;
    for k in 0..touches {
        presses.touch(&mut session, FRAMES_PER_TOUCH - 5, &mut sink);
        if k + 1 == warm {
            at_warm = resident_kb();
        }
        if k + 1 > warm && (k + 1) % 500 == 0 {
            highest = highest.max(resident_kb());
        }
    }
    let stats = session.stats();
    assert_eq!(stats.touches, touches);
    assert_eq!(sink.released, touches as u64);
    assert!(
        stats.frames >= (touches * FRAMES_PER_TOUCH) as u64,
        "{}",
        stats.frames
    );
    let grown = highest.saturating_sub(at_warm);
    eprintln!(
        "{} frames, {touches} touches: resident {at_warm} kB after {warm} touches, at most {highest} kB after",
        stats.frames
    );
    assert!(
        grown <= 1024,
        "resident memory grew by {grown} kB after warm-up ({at_warm} -> {highest} kB)"
    );
    assert_eq!(session.touches().len(), TOUCH_HISTORY);
}
