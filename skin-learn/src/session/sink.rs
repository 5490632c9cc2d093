//! Where a session's events go: the [`Sink`] trait, and its two writers, [`JsonLines`] (one JSON
//! object a line: `events.jsonl`, or standard output live) and [`PngImages`] (the image of each
//! decision and, on request, of every touched frame).
//!
//! Each method says whether the run goes on ([`Flow::Continue`]) or stops ([`Flow::Break`]: the
//! session's run functions return after the frame at hand, and its `push` functions say
//! [`Flow::Break`] from then on), and fails with an error of the sink's own type.

use super::event::{Event, FrameView, GreyImage, ProcessedFrame};
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
        image: &GreyImage,
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

    fn write(&self, relative: &str, image: &GreyImage) -> std::io::Result<()> {
        let path = self.dir.join(relative);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        let Some(view) = image.view() else {
            return Err(std::io::Error::other(format!(
                "{relative}: {} pixels do not fill a {}x{} image",
                image.pixels.len(),
                image.rows,
                image.cols
            )));
        };
        skin_geom::write_png(&path, view).map_err(|e| std::io::Error::other(format!("{relative}: {e}")))
    }
}

impl Sink for PngImages {
    type Error = std::io::Error;

    fn event(&mut self, event: &Event) -> std::io::Result<Flow> {
        if let Event::Classified { touch, image, .. } = event {
            let (id, class) = (touch.id, &touch.decision.class);
            self.write(&format!("touches/touch_{id:03}_{class}.png"), image)?;
        }
        Ok(GO)
    }

    fn frame_image(&mut self, view: FrameView<'_>, cycle: u64, image: &GreyImage) -> std::io::Result<Flow> {
        let folder = match view {
            FrameView::Link(name) => name,
            FrameView::Stitched => "stitched",
        };
        self.write(&format!("frames/{folder}/frame_{cycle:05}.png"), image)?;
        Ok(GO)
    }
}

/// Both sinks get everything, `.0` first; the run stops if either says stop.
impl<E, A, B> Sink for (A, B)
where
    E: std::error::Error + Send + Sync + 'static,
    A: Sink<Error = E>,
    B: Sink<Error = E>,
{
    type Error = E;

    fn event(&mut self, event: &Event) -> Result<Flow, E> {
        Ok(both(self.0.event(event)?, self.1.event(event)?))
    }

    fn frame_image(&mut self, view: FrameView<'_>, cycle: u64, image: &GreyImage) -> Result<Flow, E> {
        Ok(both(
            self.0.frame_image(view, cycle, image)?,
            self.1.frame_image(view, cycle, image)?,
        ))
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, E> {
        Ok(both(self.0.origin(origin_us)?, self.1.origin(origin_us)?))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, E> {
        Ok(both(self.0.frame(frame)?, self.1.frame(frame)?))
    }
}

/// A sink that may be absent.
impl<S: Sink> Sink for Option<S> {
    type Error = S::Error;

    fn event(&mut self, event: &Event) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.event(event))
    }

    fn frame_image(&mut self, view: FrameView<'_>, cycle: u64, image: &GreyImage) -> Result<Flow, S::Error> {
        self.as_mut()
            .map_or(Ok(GO), |s| s.frame_image(view, cycle, image))
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.origin(origin_us))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, S::Error> {
        self.as_mut().map_or(Ok(GO), |s| s.frame(frame))
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

    fn frame_image(&mut self, view: FrameView<'_>, cycle: u64, image: &GreyImage) -> Result<Flow, S::Error> {
        (**self).frame_image(view, cycle, image)
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, S::Error> {
        (**self).origin(origin_us)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, S::Error> {
        (**self).frame(frame)
    }
}
