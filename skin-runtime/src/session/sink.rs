//! Where a session's events go: the [`Sink`] trait, and its two writers, [`JsonLines`] (one JSON
//! object a line: `events.jsonl`, or standard output live) and [`PngImages`] (the image of each
//! decision and, on request, of every touched frame).
//!
//! Each method says whether the run goes on ([`Flow::Continue`]) or stops ([`Flow::Break`]: the
//! session's run functions return after the frame at hand, and its `push` functions say
//! [`Flow::Break`] from then on), and fails with an error of the sink's own type.
//!
//! Sinks combine whatever their error types: a pair `(A, B)` is a sink, and so is a [`Sinks`]
//! list of any number; either fails with a [`SinkError`], the failing sink's own error inside.

use super::event::{Event, FrameView, ProcessedFrame, RawFrame};
use skin_core::image::ImageView;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

/// Whether a session's run goes on after a sink took something.
pub type Flow = ControlFlow<()>;

/// Go on.
const GO: Flow = ControlFlow::Continue(());

/// Both answers: stop if either says stop.
fn both(a: Flow, b: Flow) -> Flow {
    if a.is_break() || b.is_break() {
        ControlFlow::Break(())
    } else {
        GO
    }
}

/// Takes a session's events as they happen. A robot stack implements it to act on decisions
/// (and to stop the run: [`Flow::Break`]); `skin run` wires [`JsonLines`] and [`PngImages`].
pub trait Sink {
    /// Why the sink failed (the session's error carries it: [`SessionError::Sink`](super::SessionError::Sink)).
    type Error: std::error::Error + Send + Sync + 'static;

    /// One event.
    fn event(&mut self, event: &Event) -> Result<Flow, Self::Error>;

    /// The tactile image of one frame with contact (only with
    /// [`SessionOptions::frame_images`](super::SessionOptions)); `cycle` numbers the frame.
    /// Ignored unless implemented.
    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, Self::Error> {
        let _ = (view, cycle, image);
        Ok(GO)
    }

    /// The input's clock at the session's first frame, µs: event times count from it. Called
    /// once, before anything else. Ignored unless implemented.
    fn origin(&mut self, origin_us: u64) -> Result<Flow, Self::Error> {
        let _ = origin_us;
        Ok(GO)
    }

    /// Every frame as it came in (the frames that learn the baseline too), before its events:
    /// each link's readings as the skin sent them. Called on the frame path: keep it short.
    /// Ignored unless implemented.
    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> Result<Flow, Self::Error> {
        let _ = frame;
        Ok(GO)
    }

    /// Every frame after the baseline is learned, after the frame's events: pressures and
    /// contacts per link. Called on the frame path: keep it short. Ignored unless implemented.
    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, Self::Error> {
        let _ = frame;
        Ok(GO)
    }
}

/// Events as JSON lines (see [`Event`] for the fields and their units).
#[derive(Debug)]
pub struct JsonLines<W: Write> {
    out: W,
    line: Vec<u8>,
}

impl<W: Write> JsonLines<W> {
    /// Writes to `out` (buffer it: each event is one `write_all`).
    pub fn new(out: W) -> JsonLines<W> {
        JsonLines {
            out,
            line: Vec::with_capacity(256),
        }
    }

    /// The writer, flushed.
    pub fn into_inner(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

impl<W: Write> Sink for JsonLines<W> {
    type Error = std::io::Error;

    fn event(&mut self, event: &Event) -> std::io::Result<Flow> {
        self.line.clear();
        event.write_json(&mut self.line).map_err(std::io::Error::other)?;
        self.line.push(b'\n');
        self.out.write_all(&self.line)?;
        Ok(GO)
    }
}

/// Images as PNG files in a folder: `touches/touch_NNN_CLASS.png` for each decision (the image
/// it was made on), `frames/LINK/frame_NNNNN.png` and `frames/stitched/frame_NNNNN.png` for
/// touched frames.
#[derive(Debug)]
pub struct PngImages {
    dir: PathBuf,
}

impl PngImages {
    /// Writes into `dir` (which must exist; `touches/` is made now, so that it exists even
    /// when no touch is decided).
    pub fn new(dir: &Path) -> std::io::Result<PngImages> {
        std::fs::create_dir_all(dir.join("touches"))?;
        Ok(PngImages { dir: dir.to_owned() })
    }

    fn write(&self, relative: &str, image: ImageView<'_, u8>) -> std::io::Result<()> {
        let path = self.dir.join(relative);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        skin_geom::write_png(&path, image).map_err(|e| std::io::Error::other(format!("{relative}: {e}")))
    }
}

impl Sink for PngImages {
    type Error = std::io::Error;

    fn event(&mut self, event: &Event) -> std::io::Result<Flow> {
        if let Event::Classified { touch, image, .. } = event {
            let (id, class) = (touch.id, &touch.decision.class);
            self.write(&format!("touches/touch_{id:03}_{class}.png"), image.view())?;
        }
        Ok(GO)
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> std::io::Result<Flow> {
        let folder = match view {
            FrameView::Link(name) => name,
            FrameView::Stitched => "stitched",
        };
        self.write(&format!("frames/{folder}/frame_{cycle:05}.png"), image)?;
        Ok(GO)
    }
}

/// A sink's error, whatever the sink's error type: what sinks combined ([`Sinks`], a pair) fail
/// with. It reads as the error inside (the same text, the same sources); [`SinkError::get_ref`]
/// and [`SinkError::into_inner`] give that error, to downcast.
#[derive(Debug)]
pub struct SinkError(Box<dyn std::error::Error + Send + Sync>);

impl SinkError {
    /// Wraps a sink's error (a [`SinkError`] is kept as it is, not wrapped twice).
    pub fn new<E: std::error::Error + Send + Sync + 'static>(error: E) -> SinkError {
        let boxed: Box<dyn std::error::Error + Send + Sync> = Box::new(error);
        match boxed.downcast::<SinkError>() {
            Ok(already) => *already,
            Err(other) => SinkError(other),
        }
    }

    /// The sink's own error.
    pub fn get_ref(&self) -> &(dyn std::error::Error + Send + Sync + 'static) {
        &*self.0
    }

    /// The sink's own error, by value.
    pub fn into_inner(self) -> Box<dyn std::error::Error + Send + Sync> {
        self.0
    }
}

impl std::fmt::Display for SinkError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// Transparent: the error inside's sources are this one's (its own text is this one's text).
impl std::error::Error for SinkError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// A sink whose errors are [`SinkError`]s.
struct Boxed<S>(S);

impl<S: Sink> Sink for Boxed<S> {
    type Error = SinkError;

    fn event(&mut self, event: &Event) -> Result<Flow, SinkError> {
        self.0.event(event).map_err(SinkError::new)
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, SinkError> {
        self.0.frame_image(view, cycle, image).map_err(SinkError::new)
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, SinkError> {
        self.0.origin(origin_us).map_err(SinkError::new)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, SinkError> {
        self.0.frame(frame).map_err(SinkError::new)
    }

    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> Result<Flow, SinkError> {
        self.0.raw_frame(frame).map_err(SinkError::new)
    }
}

/// Any number of sinks, whatever their error types, as one: each gets everything, in the order
/// added; the run stops if any says stop; the first to fail stops the others taking that item
/// (its error, a [`SinkError`], is the run's). Sinks lent (`&mut sink`) are theirs again once
/// the list is dropped, to be finished or flushed.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use skin_runtime::session::{Event, JsonLines, Sink, Sinks};
///
/// let mut lines = JsonLines::new(Vec::new()); // fails with std::io::Error
/// let mut kept: Vec<Event> = Vec::new(); // cannot fail
/// let reset = Event::CounterReset { time: 1.5, bus: "can0".into(), from: 255, to: 0, cycle: 7 };
/// {
///     let mut both = Sinks::new().with(&mut lines).with(&mut kept);
///     both.event(&reset)?;
///     // A pair is a sink too.
///     (&mut both, Vec::new()).event(&reset)?;
/// }
/// assert_eq!(kept.len(), 2);
/// let text = String::from_utf8(lines.into_inner()?)?;
/// assert_eq!(text.lines().count(), 2);
/// assert!(text.lines().all(|l| l.contains(r#""event":"counter_reset""#)));
/// # Ok(()) }
/// ```
#[derive(Default)]
pub struct Sinks<'a> {
    list: Vec<Box<dyn Sink<Error = SinkError> + 'a>>,
}

impl std::fmt::Debug for Sinks<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sinks")
            .field("len", &self.list.len())
            .finish_non_exhaustive()
    }
}

impl<'a> Sinks<'a> {
    /// No sink yet.
    pub fn new() -> Sinks<'a> {
        Sinks::default()
    }

    /// The list with `sink` added last.
    #[must_use]
    pub fn with(mut self, sink: impl Sink + 'a) -> Sinks<'a> {
        self.push(sink);
        self
    }

    /// Adds `sink` last.
    pub fn push(&mut self, sink: impl Sink + 'a) {
        self.list.push(Box::new(Boxed(sink)));
    }

    /// How many sinks.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// No sink at all.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Hands something to every sink in order: stop if any says stop, the first error at once.
    fn each(
        &mut self,
        mut give: impl FnMut(&mut dyn Sink<Error = SinkError>) -> Result<Flow, SinkError>,
    ) -> Result<Flow, SinkError> {
        let mut flow = GO;
        for sink in &mut self.list {
            flow = both(flow, give(sink.as_mut())?);
        }
        Ok(flow)
    }
}

impl Sink for Sinks<'_> {
    type Error = SinkError;

    fn event(&mut self, event: &Event) -> Result<Flow, SinkError> {
        self.each(|s| s.event(event))
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, SinkError> {
        self.each(|s| s.frame_image(view, cycle, image))
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, SinkError> {
        self.each(|s| s.origin(origin_us))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, SinkError> {
        self.each(|s| s.frame(frame))
    }

    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> Result<Flow, SinkError> {
        self.each(|s| s.raw_frame(frame))
    }
}

/// Both sinks get everything, `.0` first, whatever their error types; the run stops if either
/// says stop, and `.1` is not given what `.0` failed on.
impl<A: Sink, B: Sink> Sink for (A, B) {
    type Error = SinkError;

    fn event(&mut self, event: &Event) -> Result<Flow, SinkError> {
        let a = self.0.event(event).map_err(SinkError::new)?;
        Ok(both(a, self.1.event(event).map_err(SinkError::new)?))
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, SinkError> {
        let a = self.0.frame_image(view, cycle, image).map_err(SinkError::new)?;
        let b = self.1.frame_image(view, cycle, image).map_err(SinkError::new)?;
        Ok(both(a, b))
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, SinkError> {
        let a = self.0.origin(origin_us).map_err(SinkError::new)?;
        Ok(both(a, self.1.origin(origin_us).map_err(SinkError::new)?))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, SinkError> {
        let a = self.0.frame(frame).map_err(SinkError::new)?;
        Ok(both(a, self.1.frame(frame).map_err(SinkError::new)?))
    }

    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> Result<Flow, SinkError> {
        let a = self.0.raw_frame(frame).map_err(SinkError::new)?;
        Ok(both(a, self.1.raw_frame(frame).map_err(SinkError::new)?))
    }
}

/// A sink that may be absent.
impl<S: Sink> Sink for Option<S> {
    type Error = S::Error;

    fn event(&mut self, event: &Event) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.event(event))
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, S::Error> {
        self.as_mut()
            .map_or(Ok(GO), |s| s.frame_image(view, cycle, image))
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.origin(origin_us))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.frame(frame))
    }

    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.raw_frame(frame))
    }
}

/// Collecting the events in memory (tests, examples, a stack that polls).
impl Sink for Vec<Event> {
    type Error = std::convert::Infallible;

    fn event(&mut self, event: &Event) -> Result<Flow, Self::Error> {
        self.push(event.clone());
        Ok(GO)
    }
}

impl<S: Sink + ?Sized> Sink for &mut S {
    type Error = S::Error;

    fn event(&mut self, event: &Event) -> Result<Flow, S::Error> {
        (**self).event(event)
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, S::Error> {
        (**self).frame_image(view, cycle, image)
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, S::Error> {
        (**self).origin(origin_us)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, S::Error> {
        (**self).frame(frame)
    }

    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> Result<Flow, S::Error> {
        (**self).raw_frame(frame)
    }
}
