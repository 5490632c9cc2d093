//! A session with the shipped models keeps its memory through a long run: varied touches on
//! the forearm (synthetic hands of every interaction, objects and body parts, at every place
//! and strength), each decided by HandsNet and every hand segmented, with resident memory
//! measured in this process (this file holds one test, so its binary runs only it).
//!
//! `SKIN_MEMORY_DECISIONS` sets the number of classifier runs (default 8,000; BENCHMARKS.md
//! gives the figures of 50,000). Resident memory is compared from the 5,000th on (a tenth of
//! the run, if longer): by then the allocator holds what the models' runs need between them.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

mod support;

use support::memory::{Count, Presses, forearm_session, resident_kb};

#[test]
fn a_long_session_with_the_shipped_models_keeps_resident_memory_within_10_percent() {
    let decisions: u64 = std::env::var("SKIN_MEMORY_DECISIONS")
        .ok()
        .map_or(8_000, |v| v.parse().unwrap());
    let warm = (decisions / 10).max(5_000);
    assert!(
        decisions > warm,
        "SKIN_MEMORY_DECISIONS={decisions}: more than 5,000"
    );
    let dir = tempfile::tempdir().unwrap();
    let mut session = forearm_session(dir.path(), true);
    let mut presses = Presses::new(&session, 400);
    let mut sink = Count::default();
    presses.rest(&mut session, 40, &mut sink);
    let mut at_warm = None;
    let mut highest = 0;
    let mut next = 1_000;
    let runs = |s: &skin_learn::session::Session| s.stats().pipeline.runs;
    while runs(&session).0 < decisions {
        presses.touch(&mut session, 4, &mut sink);
        let (classified, segmented) = runs(&session);
        if at_warm.is_none() && classified >= warm {
            at_warm = Some(resident_kb());
        }
        if classified >= next {
            let now = resident_kb();
            eprintln!("{classified:>6} decisions ({segmented} segmentations): resident {now} kB");
            if at_warm.is_some() {
                highest = highest.max(now);
            }
            next += 1_000;
        }
    }
    let (classified, segmented) = runs(&session);
    // Varied: both classes decided, about half the touches segmented as hands.
    assert!(
        sink.hands > classified / 5 && sink.hands < classified * 4 / 5,
        "{} of {classified} decisions were hands",
        sink.hands
    );
    assert!(segmented > classified / 5, "{segmented} segmentations");
    let at_warm = at_warm.unwrap();
    highest = highest.max(resident_kb());
    eprintln!("resident {at_warm} kB at {warm} decisions, at most {highest} kB after, over {classified}");
    assert!(
        highest * 10 <= at_warm * 11,
        "resident memory grew from {at_warm} kB at {warm} decisions to {highest} kB"
    );
}
