//! Classify touches: CAN log -> pressures -> touches -> hand or not, which parts of the hand,
//! and what the robot should do.
//!
//! ```text
//! cargo run --release -p skin-examples --example classify_touch
//! ```
//! Uses the fixture session (20 scripted touches of the forearm, hands and other contacts) and
//! its configuration, `fixtures/session/run.toml`: the shipped models (HandsNet for hand /
//! non-hand, the hand-part segmenter) and the gate (comply with a hand, stop for anything
//! else). This is the library side of `skin run`: a [`Session`] built from the configuration
//! takes every frame of the log and hands its events to a [`Sink`], here one that prints the
//! decisions and the gate as a robot stack would act on them.

use skin_can::candump::CandumpLog;
use skin_control::hri::GateAction;
use skin_learn::session::{Event, Flow, FromConfig, Session, SessionConfig, Sink};
use std::path::PathBuf;

/// Prints each decision and each change of the gate's action.
struct Robot {
    decisions: usize,
}

impl Sink for Robot {
    type Error = std::convert::Infallible;

    fn event(&mut self, event: &Event) -> Result<Flow, Self::Error> {
        match event {
            Event::Classified { touch, image, .. } => {
                self.decisions += 1;
                let decision = &touch.decision;
                let what = if decision.class.is_hand() {
                    "hand"
                } else {
                    "not a hand"
                };
                let parts: Vec<String> = decision
                    .parts
                    .iter()
                    .map(|p| format!("{} ({} taxels)", p.part.name(), p.taxels))
                    .collect();
                println!(
                    "{:6.2} s  touch {:2}: {what} (p = {:.2}, {} x {} image) {}",
                    touch.time,
                    touch.id,
                    decision.probability,
                    image.size().rows,
                    image.size().cols,
                    parts.join(", ")
                );
            }
            Event::Gate { time, action, .. } => {
                let say = match action {
                    GateAction::Stop => "stop the arm",
                    GateAction::Comply => "comply: follow the hand",
                    GateAction::Slow => "slow down",
                    GateAction::Resume => "resume",
                };
                println!("{time:6.2} s  gate: {say}");
            }
            _ => {}
        }
        Ok(Flow::Continue(()))
    }
}

fn main() -> anyhow::Result<()> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let config = SessionConfig::read(&root.join("run.toml"))?;
    // Reads the layout, bus map, models and script; the maps come from the cache after the
    // first run.
    let mut session = Session::from_config(&config)?;
    let log_path = root.join("session.candump.log");
    let log = CandumpLog::read(&log_path)?;
    let mut robot = Robot { decisions: 0 };
    let span = session.run_log(&log, &log_path, &mut robot, &mut |_, _| {})?;
    println!("\n{}", session.summary(span));
    anyhow::ensure!(robot.decisions >= 20, "{} decisions", robot.decisions);
    Ok(())
}
