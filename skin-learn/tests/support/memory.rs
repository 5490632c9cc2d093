//! What the memory tests share: the process's resident memory, and a long session of varied
//! touches on the bundled forearm (synthetic hands and objects of every size, place and class,
//! each pressed over a few frames and released).

use skin_learn::session::{Event, Flow, FromConfig, Session, SessionConfig, Sink};
use skin_learn::synth::{SynthOptions, Synthesizer};
use std::path::Path;

/// The process's resident memory, kB (`VmRSS` of /proc/self/status).
pub fn resident_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// The forearm's session built from a run.toml in `dir`: the shipped HandsNet and segmenter
/// when `models`, else tracking alone.
pub fn forearm_session(dir: &Path, models: bool) -> Session {
    let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let mut text = format!("layout = {:?}\n", f.join("forearm/layout.json"));
    if models {
        text.push_str(&format!("classifier = {:?}\n", f.join("models/handsnet.onnx")));
        text.push_str(&format!("segmenter = {:?}\n", f.join("models/handseg.onnx")));
    }
    text.push_str("cache = \"cache\"\n[baseline]\nframes = 20\n[touch]\nthreshold = 5.0\n");
    let path = dir.join("run.toml");
    std::fs::write(&path, text).unwrap();
    Session::from_config(&SessionConfig::read(&path).unwrap()).unwrap()
}

/// Counts what a robot stack would act on and keeps nothing.
#[derive(Debug, Default)]
pub struct Count {
    /// Classified events (first decisions and revisions).
    pub classified: u64,
    /// Of them, of the hand class.
    pub hands: u64,
    /// Released events.
    pub released: u64,
}

impl Sink for Count {
    type Error = std::convert::Infallible;

    fn event(&mut self, e: &Event) -> Result<Flow, Self::Error> {
        match e {
            Event::Classified { touch, .. } => {
                self.classified += 1;
                self.hands += u64::from(touch.decision.class.is_hand());
            }
            Event::Released { .. } => self.released += 1,
            _ => {}
        }
        Ok(Flow::Continue(()))
    }
}

/// Frames of one touch: its pressure rises over three frames, is held, and goes.
const PRESS: [f32; 5] = [0.4, 0.75, 1.0, 1.0, 0.6];

/// A long run of varied touches on the forearm: `pool` synthetic samples (hands of every
/// interaction, objects and body parts, at random places, partly off the skin or not), each
/// touch one of them at its own strength. The frames between touches are at rest.
pub struct Presses {
    rest: Vec<f32>,
    samples: Vec<Vec<f32>>,
    frame: Vec<Vec<f32>>,
    time_us: u64,
    cycle: u64,
    touches: u64,
}

impl Presses {
    /// `pool` samples drawn on `session`'s one link (the forearm), seed fixed.
    pub fn new(session: &Session, pool: u32) -> Presses {
        let link = &session.links()[0];
        let map = session.pipeline().map(0).unwrap().clone();
        let mut synth = Synthesizer::new(&map, SynthOptions::default()).unwrap();
        let samples: Vec<Vec<f32>> = (0..pool)
            .map(|k| synth.sample(54, k % 12, k).pressures)
            .filter(|p| p.iter().filter(|&&v| v > 20.0).count() >= 3)
            .collect();
        assert!(
            samples.len() as u32 > pool / 2,
            "{} of {pool} samples press",
            samples.len()
        );
        let n = link.taxels.len();
        // A rest level with a fixed pattern, as real taxels have.
        let rest: Vec<f32> = (0..n).map(|i| 200.0 + (i % 7) as f32).collect();
        Presses {
            frame: vec![rest.clone()],
            rest,
            samples,
            time_us: 0,
            cycle: 0,
            touches: 0,
        }
    }

    /// Pushes `frames` frames at rest (20 Hz).
    pub fn rest<S: Sink>(&mut self, session: &mut Session, frames: usize, sink: &mut S) {
        self.frame[0].copy_from_slice(&self.rest);
        for _ in 0..frames {
            self.push(session, sink);
        }
    }

    /// Pushes one touch (five frames) and `quiet` frames at rest after it; the touch is
    /// released within them.
    pub fn touch<S: Sink>(&mut self, session: &mut Session, quiet: usize, sink: &mut S) {
        let k = self.touches as usize;
        self.touches += 1;
        let pool = self.samples.len();
        // Each pass over the pool presses at another strength.
        let strength = 0.6 + 0.1 * ((k / pool) % 8) as f32;
        for level in PRESS {
            let sample = &self.samples[k % pool];
            for ((dst, &r), &p) in self.frame[0].iter_mut().zip(&self.rest).zip(sample) {
                *dst = r + p * level * strength;
            }
            self.push(session, sink);
        }
        self.rest(session, quiet.max(2), sink);
    }

    fn push<S: Sink>(&mut self, session: &mut Session, sink: &mut S) {
        let flow = session.push(self.time_us, self.cycle, &self.frame, sink).unwrap();
        assert!(flow.is_continue());
        self.time_us += 50_000;
        self.cycle += 1;
    }
}
