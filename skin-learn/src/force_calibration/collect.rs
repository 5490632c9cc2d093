//! The frames of a session run under a known load: what [`fit_force`](super::fit_force) fits.

use super::LoadedFrame;
use skin_core::format::load::LoadFile;
use skin_runtime::session::{Event, Flow, ProcessedFrame, Sink};

/// A [`Sink`] keeping one link's frames that fall within a load file's span, with the load at
/// each and the taxels of the frame's contacts (layout indices): the taxels a calibrated
/// session weighs.
#[derive(Debug)]
pub struct LoadedFrames<'a> {
    loads: &'a LoadFile,
    link: usize,
    offset_s: f64,
    frames: Vec<LoadedFrame>,
    /// The first and last frame's times on the load's clock, seconds.
    seen: Option<(f64, f64)>,
}

/// Why the frames of a run do not go with the load file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CollectError {
    /// No frame within the load file's span.
    #[error(
        "{}: no frame of the input falls within the loads' times ({:.3} to {:.3} s); the input's frames run {:.3} to {:.3} s{}",
        path.display(), span.0, span.1, input.0, input.1, hint
    )]
    NoOverlap {
        /// The load file.
        path: std::path::PathBuf,
        /// The load file's span, seconds.
        span: (f64, f64),
        /// The input's span on the same clock, seconds.
        input: (f64, f64),
        /// What the mismatch most likely is, and the fix.
        hint: String,
    },
    /// The input had no frame after its baseline.
    #[error("the input has no frame after its baseline frames: nothing to calibrate with")]
    NoFrames,
}

impl<'a> LoadedFrames<'a> {
    /// Frames of link `link` (layout index) under `loads`; a frame's time on the load's clock
    /// is its stamp (`time_us`) plus `offset_s` (a recording's stamps count from its first
    /// frame: its first time column's value).
    pub fn new(loads: &'a LoadFile, link: usize, offset_s: f64) -> LoadedFrames<'a> {
        LoadedFrames {
            loads,
            link,
            offset_s,
            frames: Vec::new(),
            seen: None,
        }
    }

    /// The frames kept, or why none go with the load file.
    pub fn finish(self) -> Result<Vec<LoadedFrame>, CollectError> {
        let Some(input) = self.seen else {
            return Err(CollectError::NoFrames);
        };
        if !self.frames.is_empty() {
            return Ok(self.frames);
        }
        let span = self.loads.span();
        Err(CollectError::NoOverlap {
            path: self.loads.path.clone(),
            span,
            input,
            hint: clock_hint(span, input),
        })
    }
}

/// What a load file's times most likely are, when they miss the input's.
fn clock_hint(span: (f64, f64), input: (f64, f64)) -> String {
    let epoch = |t: f64| t > 1e8; // later than 1973 as seconds since the epoch
    let fix = "give the load's times in seconds on the input's clock";
    if epoch(input.0) && !epoch(span.1) {
        format!(
            ": the input's stamps are seconds since the epoch (a candump log's) and the loads' are not; {fix}, e.g. add {:.3} to each",
            input.0
        )
    } else if !epoch(input.0) && epoch(span.0) {
        format!(": the loads' times are seconds since the epoch and the input's count from its start; {fix}")
    } else if span.1 / 1000.0 >= input.0 && span.0 / 1000.0 <= input.1 {
        format!(": are the loads' times milliseconds? {fix}")
    } else {
        format!("; {fix}")
    }
}

impl Sink for LoadedFrames<'_> {
    type Error = std::convert::Infallible;

    fn event(&mut self, _: &Event) -> Result<Flow, Self::Error> {
        Ok(Flow::Continue(()))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, Self::Error> {
        let t = frame.time_us as f64 * 1e-6 + self.offset_s;
        self.seen = Some(self.seen.map_or((t, t), |(a, _)| (a, t)));
        let (Some(force_n), Some(pressures)) = (self.loads.force_at(t), frame.pressures.get(self.link))
        else {
            return Ok(Flow::Continue(()));
        };
        let readings = frame
            .contacts(self.link)
            .iter()
            .flat_map(|c| c.taxels.iter())
            .filter_map(|&i| Some((i, *pressures.get(i)?)))
            .collect();
        self.frames.push(LoadedFrame {
            time_s: t,
            force_n,
            readings,
        });
        Ok(Flow::Continue(()))
    }
}
