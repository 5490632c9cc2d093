//! `skin run`'s sinks: events.jsonl and the PNG images of the folder being built (each file
//! made while an interrupt waits, errors naming the user's folder), standard output live, and
//! the ROS 2 outlets; and the checks, before any work, that outputs land where they may.

use crate::output::{Inputs, OutputDir};
use crate::ros_out::{Outlets, RosArgs};
use crate::view_cmd::View;
use anyhow::{Context, Result};
use skin_core::image::ImageView;
use skin_core::output::{Staged, writing};
use skin_learn::session::{
    Event, Flow, FrameView, JsonLines, PngImages, ProcessedFrame, SessionConfig, Sink, SinkError,
};
use skin_ros::RosSink;
use std::fs::File;
use std::io::{BufWriter, Stdout};
use std::path::{Path, PathBuf};

/// Where `skin run`'s events and images go: events.jsonl and the PNGs in the folder being
/// built, standard output when live, the ROS 2 outlets and the viewer; each optional. Every sink
/// gets everything, in this order; the first to fail stops the run with its own error (inside
/// a [`SinkError`]).
#[derive(Default)]
pub struct RunSinks {
    /// events.jsonl of the folder being built.
    pub events: Option<JsonLines<BufWriter<Named>>>,
    /// Events on standard output (live runs).
    pub stdout: Option<JsonLines<Stdout>>,
    /// The touches' (and with --frames, every frame's) PNG images.
    pub images: Option<Images>,
    /// The MCAP file and the Zenoh publisher.
    pub ros: Option<RosSink<Outlets>>,
    /// The live view.
    pub view: Option<View>,
}

impl RunSinks {
    /// The sinks of one recording of a batch: its events.jsonl and images in `dir` (in the
    /// folder being built, shown as `shown`), the ROS outlets and the viewer.
    pub fn recording(
        dir: &Path,
        shown: &Path,
        ros: Option<RosSink<Outlets>>,
        view: Option<View>,
    ) -> Result<RunSinks> {
        let file = Named::create(&dir.join("events.jsonl"), &shown.join("events.jsonl"))?;
        Ok(RunSinks {
            events: Some(JsonLines::new(BufWriter::new(file))),
            images: Some(Images::new(dir, shown)?),
            ros,
            view,
            ..RunSinks::default()
        })
    }

    /// Writes out what events.jsonl still buffers; its error names the file.
    pub fn close_events(&mut self) -> Result<()> {
        if let Some(events) = self.events.take() {
            events.into_inner()?;
        }
        Ok(())
    }

    /// The sinks as one, in order, without allocating (the per-frame path): skin-learn's pairs
    /// carry any error types.
    fn all(&mut self) -> impl Sink<Error = SinkError> + '_ {
        (
            &mut self.events,
            (
                &mut self.stdout,
                (&mut self.images, (&mut self.ros, &mut self.view)),
            ),
        )
    }
}

impl Sink for RunSinks {
    type Error = SinkError;

    fn event(&mut self, event: &Event) -> Result<Flow, SinkError> {
        self.all().event(event)
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> Result<Flow, SinkError> {
        self.all().frame_image(view, cycle, image)
    }

    fn origin(&mut self, origin_us: u64) -> Result<Flow, SinkError> {
        self.all().origin(origin_us)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, SinkError> {
        self.all().frame(frame)
    }
}

/// A file of the folder being built, whose errors name it as the user will know it (never the
/// staging folder).
pub struct Named {
    file: File,
    shown: PathBuf,
}

impl Named {
    /// Creates `path` (in the folder being built), shown as `shown`.
    pub fn create(path: &Path, shown: &Path) -> Result<Named> {
        let _creating = writing();
        let file = File::create(path).with_context(|| format!("cannot write {}", shown.display()))?;
        Ok(Named {
            file,
            shown: shown.to_owned(),
        })
    }

    fn named(&self, e: std::io::Error) -> std::io::Error {
        std::io::Error::new(e.kind(), format!("{}: {e}", self.shown.display()))
    }
}

impl std::io::Write for Named {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf).map_err(|e| self.named(e))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush().map_err(|e| self.named(e))
    }
}

/// The PNG images of the folder being built: each made while [`writing`] is held (an interrupt
/// waits for it, and none is made once the folder is abandoned), errors naming the user's
/// folder.
pub struct Images {
    png: PngImages,
    staging: String,
    shown: PathBuf,
}

impl Images {
    /// Images in `dir` (in the folder being built), shown as `shown`.
    pub fn new(dir: &Path, shown: &Path) -> Result<Images> {
        let _creating = writing();
        let png = PngImages::new(dir).with_context(|| format!("cannot write into {}", shown.display()))?;
        Ok(Images {
            png,
            staging: dir.display().to_string(),
            shown: shown.to_owned(),
        })
    }

    /// Each image is a new file: none is made once the folder is gone (its folders would be
    /// made again).
    fn check(&self) -> std::io::Result<()> {
        still_there(Path::new(&self.staging), &self.shown)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::NotFound, e))
    }

    fn named(&self, e: std::io::Error) -> std::io::Error {
        let shown = self.shown.display().to_string();
        let text = e.to_string().replace(&self.staging, &shown);
        let text = if text.contains(&shown) {
            text
        } else {
            format!("{shown}: {text}")
        };
        std::io::Error::new(e.kind(), text)
    }
}

impl Sink for Images {
    type Error = std::io::Error;

    fn event(&mut self, event: &Event) -> std::io::Result<Flow> {
        if !matches!(event, Event::Classified { .. }) {
            return Ok(Flow::Continue(()));
        }
        let _creating = writing();
        self.check()?;
        self.png.event(event).map_err(|e| self.named(e))
    }

    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: ImageView<'_, u8>,
    ) -> std::io::Result<Flow> {
        let _creating = writing();
        self.check()?;
        self.png
            .frame_image(view, cycle, image)
            .map_err(|e| self.named(e))
    }

    fn origin(&mut self, origin_us: u64) -> std::io::Result<Flow> {
        self.png.origin(origin_us)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> std::io::Result<Flow> {
        self.png.frame(frame)
    }
}

/// The sinks for an output folder (being built), live standard output, the ROS outputs and
/// the viewer.
pub fn sinks(
    out: Option<&OutputDir>,
    live: bool,
    ros: Option<RosSink<Outlets>>,
    view: Option<View>,
) -> Result<RunSinks> {
    let (events, images) = match out {
        Some(out) => {
            let file = Named::create(&out.path().join("events.jsonl"), &out.dir().join("events.jsonl"))?;
            let images = Images::new(out.path(), out.dir())?;
            (Some(JsonLines::new(BufWriter::new(file))), Some(images))
        }
        None => (None, None),
    };
    Ok(RunSinks {
        events,
        stdout: live.then(|| JsonLines::new(std::io::stdout())),
        images,
        ros,
        view,
    })
}

/// Refuses to write on once the folder being built (`staging`, shown as `shown`) is gone: the
/// user deleted or moved the output folder, and it must not come back half made.
pub fn still_there(staging: &Path, shown: &Path) -> Result<(), skin_core::output::OutputError> {
    match staging.is_dir() {
        true => Ok(()),
        false => Err(skin_core::output::OutputError::Vanished {
            dir: shown.to_owned(),
        }),
    }
}

/// Finishes the MCAP file of `outlets` (if any) without putting it in place; its messages.
pub fn stage_mcap(outlets: Option<&mut Outlets>) -> Result<Option<(Staged, u64)>> {
    #[cfg(feature = "mcap")]
    if let Some(o) = outlets {
        return o.stage_mcap();
    }
    let _ = outlets;
    Ok(None)
}

/// "wrote FILE.mcap (N ROS 2 messages)", once it is in place.
pub fn say_mcap(ros: &RosArgs, messages: Option<u64>) {
    if let (Some(p), Some(n)) = (ros.mcap_path(), messages) {
        crate::say!("wrote {} ({n} ROS 2 messages)", p.display());
    }
}

/// `path` made absolute, through the links of the part that exists, so that two names of one
/// place compare equal whether or not the place exists yet.
fn resolved(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
    let mut rest = Vec::new();
    let mut head = abs.as_path();
    loop {
        if let Ok(c) = head.canonicalize() {
            return rest.iter().rev().fold(c, |p: PathBuf, part| p.join(part));
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_owned());
                head = parent;
            }
            _ => return abs,
        }
    }
}

/// Refuses, before any work, an MCAP path that is an input, a user's other file, the output
/// folder itself, or inside it (whose next run would then find a file that is not its own).
pub fn precheck_mcap(ros: &RosArgs, output: Option<&Path>, inputs: &Inputs) -> Result<()> {
    if let (Some(file), Some(dir)) = (ros.mcap_path(), output) {
        let (f, d) = (resolved(file), resolved(dir));
        if f == d {
            let beside = match d.file_name() {
                Some(_) => dir.with_extension("mcap"),
                None => PathBuf::from("session.mcap"),
            };
            anyhow::bail!(
                "--mcap {} is the output folder: give the MCAP file a name beside it, e.g. --mcap {}",
                file.display(),
                beside.display()
            );
        }
        anyhow::ensure!(
            !f.starts_with(&d),
            "--mcap {} is inside the output folder {}: write it beside the folder",
            file.display(),
            dir.display()
        );
    }
    ros.precheck(inputs)
}

/// The map cache: refused inside the output folder (its next run would find files that are not
/// its own), and said once when it cannot be written (the maps are then made again each run).
pub fn check_cache(config: &SessionConfig, output: Option<&Path>, force: bool) -> Result<()> {
    let cache = config.cache_dir();
    if let Some(dir) = output
        && !force
        && resolved(&cache).starts_with(resolved(dir))
    {
        anyhow::bail!(
            "{}: the map cache {} is inside the output folder {}; set `cache =` to a folder outside it",
            config.path.display(),
            cache.display(),
            dir.display()
        );
    }
    if let Err(e) = skin_geom::MapCache::new(&cache).check_writable() {
        eprintln!(
            "warning: cannot keep tactile maps in {} ({e}): they are made again on every run; set `cache =` in {} to a folder skin can write",
            cache.display(),
            config.path.display()
        );
    }
    Ok(())
}
