//! The whole per-frame pipeline of a skin as one value: frames in, typed [`Event`]s out (feature
//! `onnx`). What `skin run` does, for a robot stack to do in its own loop.
//!
//! ```text
//! CAN frames --Assembler--> assembled frame --LayoutFrames--> readings per link (layout order;
//!   a missing module holds its last readings and is reported: Event::Incomplete)
//!   --BaselineLearner (first N complete frames)--> Baseline --> pressures per link
//!   --TouchPipeline--> touches: Appeared, Classified (with the image decided on), Released
//!   --ClassGate--> Gate          --Stitching (per posture)--> AcrossJoint
//! ```
//!
//! A [`Session`] is built once, from a configuration file ([`Session::from_config`], the
//! `run.toml` of `skin run`) or from code ([`Session::new`] and the `with_` methods). Frames
//! reach it as assembled CAN frames ([`Session::push_can`]), as readings in layout order from
//! any other source ([`Session::push`]), or as a whole candump log ([`Session::run_log`]). Every
//! event goes to a [`Sink`] as it happens: [`JsonLines`] and [`PngImages`] are `skin run`'s
//! outputs, a `Vec<Event>` collects them, and a robot stack implements [`Sink`] to act on them.
//! [`Session::summary`] gives the run's summary (and its score against a [`Script`]).
//!
//! A robot stack's loop (frames in, events out) is the example on the [crate's first page](crate).
//!
//! The fixture session end to end (CAN log, HandsNet, segmenter): `examples/examples/classify_touch.rs`.

mod config;
mod event;
mod restart;
mod sink;
mod stitching;
mod summary;

pub use config::{
    BaselineConfig, ContactRule, MAX_IMAGE_SIDE, SessionConfig, SplitConfig, StitchConfig, TouchConfig,
};
pub use event::{Event, FrameView, GreyImage, MissingModule, ProcessedFrame};
pub use sink::{JsonLines, PngImages, Sink};
pub use stitching::{Spanning, Stitching};
pub use summary::{Summary, Timings};

use crate::card::ModelCard;
use crate::classify::{Classifier, InputScale, ModelError};
use crate::script::Script;
use crate::segment::Segmenter;
use crate::touch::{Decision, Footprint, TouchError, TouchEvent, TouchPipeline};
use skin_can::candump::{CanSource, IntoCanSource};
use skin_can::{AssembledFrame, Assembler, AssemblyStats, BusMap, CounterReset, LayoutFrames, Missing};
use skin_control::hri::{ClassGate, GateAction, TouchClass};
use skin_core::format::recording::{IntoRecordingSource, RecordingSource};
use skin_core::{
    Baseline, BaselineLearner, BaselineOptions, Columns, LinkSkin, Polarity, Recording, TaxelHealth,
};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What can go wrong building or running a [`Session`].
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The configuration is not valid TOML, or has a key it does not know.
    #[error("{}:{} {message}", file.display(), line.map_or(String::new(), |l| format!(" line {l}:")))]
    Syntax {
        /// The configuration.
        file: PathBuf,
        /// The line at fault, when known.
        line: Option<usize>,
        /// What is wrong (at most 200 characters).
        message: String,
    },
    /// A configuration value out of its range.
    #[error("{}: {field} = {value}: expected {expected}", file.display())]
    Value {
        /// The configuration.
        file: PathBuf,
        /// The key.
        field: &'static str,
        /// Its value (the first 40 characters).
        value: String,
        /// The range, in words.
        expected: &'static str,
    },
    /// A file the configuration names does not exist.
    #[error("{}: {field} = \"{}\": no such file ({})", config.display(), path.display(), resolved.display())]
    NoFile {
        /// The configuration.
        config: PathBuf,
        /// The key.
        field: &'static str,
        /// The path as written.
        path: PathBuf,
        /// The path resolved against the configuration's folder.
        resolved: PathBuf,
    },
    /// The bus map carries a taxel the layout lacks.
    #[error("{}: taxel {taxel} is not in the layout {}; is the bus map for this skin?", busmap.display(), layout.display())]
    NotInLayout {
        /// The bus map.
        busmap: PathBuf,
        /// The layout.
        layout: PathBuf,
        /// The taxel.
        taxel: skin_core::TaxelId,
    },
    /// A model takes images of another size than the configuration makes.
    #[error("{}: takes {} x {} images; {} makes {} x {} (image_size): a model for another image size",
        model.display(), takes.0, takes.1, config.display(), makes.0, makes.1)]
    ImageSize {
        /// The model.
        model: PathBuf,
        /// Its input (rows, cols).
        takes: (usize, usize),
        /// The configuration.
        config: PathBuf,
        /// The configuration's image size.
        makes: (usize, usize),
    },
    /// A classifier of more than two classes without a model card naming them.
    #[error("{}: {classes} classes and no model card naming them ({})", model.display(), card.display())]
    UnnamedClasses {
        /// The model.
        model: PathBuf,
        /// Its outputs.
        classes: usize,
        /// Where its card would be.
        card: PathBuf,
    },
    /// A link's map cannot be made.
    #[error("{}: link {link}: {source}", layout.display())]
    Map {
        /// The layout.
        layout: PathBuf,
        /// The link.
        link: String,
        /// Why.
        source: skin_geom::Error,
    },
    /// The poses name other links than the layout.
    #[error("{}: links {got:?}, but the layout has {layout:?} (same names, same order)", poses.display())]
    PoseLinks {
        /// The poses file.
        poses: PathBuf,
        /// Its links.
        got: Vec<String>,
        /// The layout's links.
        layout: Vec<String>,
    },
    /// The poses file has no posture.
    #[error("{}: no posture", poses.display())]
    NoPosture {
        /// The poses file.
        poses: PathBuf,
    },
    /// The links cannot be stitched at a posture.
    #[error("{}: posture \"{posture}\": {source}", poses.display())]
    Stitch {
        /// The poses file.
        poses: PathBuf,
        /// The posture.
        posture: String,
        /// Why.
        source: skin_geom::Error,
    },
    /// The pipeline and the links it was given do not match.
    #[error("the touch pipeline has links {pipeline:?}, the session's links are {links:?}")]
    Links {
        /// The pipeline's links.
        pipeline: Vec<String>,
        /// The session's.
        links: Vec<String>,
    },
    /// A frame of readings does not fit the skin.
    #[error("frame at {time:.3} s: {source}")]
    Frame {
        /// Frame time, s.
        time: f64,
        /// What does not fit.
        source: skin_core::Error,
    },
    /// None of the bus map's interfaces is in a log.
    #[error("{}: none of the bus map's interfaces ({}) is in the log (it has {}); is it a log of this skin?",
        log.display(), on_map.join(", "), in_log.join(", "))]
    OtherBuses {
        /// The log.
        log: PathBuf,
        /// The bus map's interfaces.
        on_map: Vec<String>,
        /// The log's.
        in_log: Vec<String>,
    },
    /// A log gave no skin frames, or mostly frames of modules the bus map lacks.
    #[error("{}: {frames} skin frames from {can_frames} CAN frames ({unknown} from modules the bus map lacks, {malformed} malformed for {format}, {ignored} not skin data); is it a log of this skin and bus map?", log.display())]
    NotThisSkin {
        /// The log.
        log: PathBuf,
        /// Skin frames assembled.
        frames: u64,
        /// CAN frames in the log.
        can_frames: usize,
        /// From modules the bus map lacks.
        unknown: u64,
        /// Malformed for the wire format.
        malformed: u64,
        /// The wire format.
        format: &'static str,
        /// Not skin traffic.
        ignored: u64,
    },
    /// CAN frames given to a session built without a bus map.
    #[error("CAN frames, but the session has no bus map (build it with Session::with_can)")]
    NoBusMap,
    /// The input ended before the baseline was learned.
    #[error(
        "the input ended after {frames} frame(s), before the {needed} complete untouched frames the baseline needs"
    )]
    TooShort {
        /// Frames seen.
        frames: u64,
        /// Complete untouched frames needed.
        needed: usize,
    },
    /// A recording has none of the layout's taxels among its columns.
    #[error("{}: none of the layout's {taxels} taxels is among the recording's {columns} columns; is it a recording of this skin?", recording.display())]
    NotRecorded {
        /// The recording.
        recording: PathBuf,
        /// Taxels of the layout.
        taxels: usize,
        /// Columns of the recording.
        columns: usize,
    },
    /// A sink failed to take an event or an image.
    #[error("cannot write the session's output: {0}")]
    Sink(#[source] std::io::Error),
    /// Reading or checking an input file.
    #[error(transparent)]
    Core(#[from] skin_core::Error),
    /// Maps, meshes and images.
    #[error(transparent)]
    Geom(#[from] skin_geom::Error),
    /// CAN traffic and bus maps.
    #[error(transparent)]
    Can(#[from] skin_can::Error),
    /// A model.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The touch pipeline.
    #[error(transparent)]
    Touch(#[from] TouchError),
}

/// How a session runs (the parts of [`SessionConfig`] that are not files).
#[derive(Debug, Clone, PartialEq)]
pub struct SessionOptions {
    /// Complete untouched frames at the start that learn the baseline (2 to 100,000).
    pub baseline_frames: usize,
    /// Which way pressure moves a reading.
    pub polarity: Polarity,
    /// What the robot does for each class of touch (a [`Event::Gate`] when it changes).
    pub gate: Option<ClassGate>,
    /// Make the tactile image of every frame with contact ([`Sink::frame_image`]).
    pub frame_images: bool,
}

impl Default for SessionOptions {
    fn default() -> Self {
        SessionOptions {
            baseline_frames: 20,
            polarity: Polarity::Rising,
            gate: None,
            frame_images: false,
        }
    }
}

/// A touch that ended.
#[derive(Debug, Clone, PartialEq)]
pub struct FinishedTouch {
    /// Link index (layout order).
    pub link: usize,
    /// Touch number.
    pub touch: u64,
    /// First frame of contact, s.
    pub start: f64,
    /// Last frame of contact, s.
    pub end: f64,
    /// The footprint at its largest total pressure.
    pub peak: Footprint,
    /// The final decision (none without a classifier).
    pub decision: Option<Decision>,
}

/// A link's baseline corrections: the one going on, and all so far.
#[derive(Debug, Default, Clone, Copy)]
struct Correcting {
    /// When the offsets being reset now began to be (none: no correction going on).
    since: Option<f64>,
    /// Frames since the last reset.
    quiet: u32,
    /// Corrections (events) and taxel resets so far.
    events: u64,
    taxels: u64,
}

/// Frames without a reset that end a baseline correction: a release takes a few frames, and its
/// taxels are reset as their readings come down, not all in one frame.
const CORRECTION_QUIET_FRAMES: u32 = 5;

/// Frames from CAN: the bus map's interfaces and the placement of its slots into links.
#[derive(Debug)]
struct CanInput {
    interfaces: Vec<String>,
    layout: LayoutFrames,
    busmap: BusMap,
}

#[derive(Debug, Default, Clone, Copy)]
struct Stages {
    assemble: Duration,
    baseline: Duration,
    output: Duration,
}

/// The per-frame pipeline of a whole skin, built once (see the [module](self)).
pub struct Session {
    links: Vec<LinkSkin>,
    pipeline: TouchPipeline,
    options: SessionOptions,
    /// Class names, and the gate's view of each.
    classes: Vec<String>,
    kinds: Vec<TouchClass>,
    can: Option<CanInput>,
    stitching: Option<Stitching>,
    script: Option<Script>,
    /// Names the input in errors (the configuration, or "frames").
    source: PathBuf,
    raw: Vec<Vec<f32>>,
    pressures: Vec<Vec<f32>>,
    learner: BaselineLearner,
    baselines: Vec<Baseline>,
    health: Vec<TaxelHealth>,
    /// Per link: offsets being reset now ([`Event::BaselineCorrected`]).
    correcting: Vec<Correcting>,
    /// The time the baseline was learned (its last frame), s.
    learned_at: f64,
    touch_events: Vec<TouchEvent>,
    /// Open touches' start times.
    open: std::collections::HashMap<u64, f64>,
    done: Vec<FinishedTouch>,
    t0_us: Option<u64>,
    last_time: f64,
    frames: u64,
    incomplete: u64,
    resets: u64,
    gate: Option<GateAction>,
    /// Contacts that spanned a joint (each counted once, when it began).
    across: u64,
    /// Lines for the summary about the traffic itself (skipped or odd CAN frames).
    notes: Vec<String>,
    /// What reading the layout file did ([`Session::from_config`]).
    layout_notes: Vec<skin_core::format::Note>,
    stage: Stages,
    image: GreyImage,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field("links", &self.links.iter().map(|l| &l.name).collect::<Vec<_>>())
            .field("options", &self.options)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

impl Session {
    /// A session over `links` (layout order) whose maps `pipeline` was built on.
    pub fn new(
        links: Vec<LinkSkin>,
        pipeline: TouchPipeline,
        options: SessionOptions,
    ) -> Result<Session, SessionError> {
        let names: Vec<String> = pipeline.link_names().map(str::to_owned).collect();
        let ours: Vec<String> = links.iter().map(|l| l.name.clone()).collect();
        if names != ours || (0..links.len()).any(|l| pipeline.taxels(l) != Some(links[l].taxels.len())) {
            return Err(SessionError::Links {
                pipeline: names,
                links: ours,
            });
        }
        let sizes: Vec<usize> = links.iter().map(|l| l.taxels.len()).collect();
        let baseline = BaselineOptions {
            polarity: options.polarity,
            ..BaselineOptions::default()
        };
        let classes = pipeline.classes().to_vec();
        Ok(Session {
            kinds: classes.iter().map(|c| TouchClass::from_name(c)).collect(),
            classes,
            learner: BaselineLearner::new(&sizes, options.baseline_frames, baseline)?,
            raw: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            pressures: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            links,
            pipeline,
            options,
            can: None,
            stitching: None,
            script: None,
            source: PathBuf::from("frames"),
            baselines: Vec::new(),
            health: Vec::new(),
            correcting: vec![Correcting::default(); sizes.len()],
            learned_at: 0.0,
            touch_events: Vec::new(),
            open: std::collections::HashMap::new(),
            done: Vec::new(),
            t0_us: None,
            last_time: 0.0,
            frames: 0,
            incomplete: 0,
            resets: 0,
            gate: None,
            across: 0,
            notes: Vec::new(),
            layout_notes: Vec::new(),
            stage: Stages::default(),
            image: GreyImage::default(),
        })
    }

    /// Takes assembled CAN frames of `busmap` ([`Session::push_can`]); a module missing from a
    /// frame holds its last readings. Fails for a taxel the links lack.
    pub fn with_can(mut self, busmap: &BusMap) -> Result<Session, SessionError> {
        let ids: Vec<Vec<_>> = self.links.iter().map(LinkSkin::ids).collect();
        let layout = LayoutFrames::new(busmap, &ids, Missing::HoldLast)?;
        // Taxels on no bus never read: bridged like a recording's missing columns.
        let mut deads = Vec::new();
        for k in 0..self.links.len() {
            let dead: Vec<usize> = layout
                .uncovered()
                .iter()
                .filter(|&&(l, _)| l == k)
                .map(|&(_, i)| i)
                .collect();
            self.pipeline.set_dead(k, &dead)?;
            deads.push(dead);
        }
        if let Some(st) = &mut self.stitching {
            st.set_dead(&deads)?;
        }
        self.can = Some(CanInput {
            interfaces: busmap.buses.iter().map(|b| b.interface.clone()).collect(),
            layout,
            busmap: busmap.clone(),
        });
        Ok(self)
    }

    /// Also searches contacts over the stitched chain ([`Event::AcrossJoint`]).
    pub fn with_stitching(mut self, stitching: Stitching) -> Session {
        self.stitching = Some(stitching);
        self
    }

    /// Scores the finished touches against a script ([`Session::summary`]).
    pub fn with_script(mut self, script: Script) -> Session {
        self.script = Some(script);
        self
    }

    /// Names the input in errors (default: "frames").
    pub fn with_source(mut self, source: &Path) -> Session {
        self.source = source.to_owned();
        self
    }

    /// The session of a configuration: reads the layout, the bus map, the models, the script and
    /// the poses it names, and makes (or reads from the cache) the links' tactile maps.
    pub fn from_config(config: &SessionConfig) -> Result<Session, SessionError> {
        let files = config.inputs()?;
        let layout_path = &files[0];
        let at = |field: &'static str, p: &Option<PathBuf>| {
            p.as_deref().map(|p| config.resolve(field, p)).transpose()
        };
        let busmap_path = at("busmap", &config.busmap)?;
        let classifier_path = at("classifier", &config.classifier)?;
        let segmenter_path = at("segmenter", &config.segmenter)?;
        let truth_path = at("truth", &config.truth)?;
        let poses_path = at("[stitch] poses", &config.stitch.as_ref().map(|s| s.poses.clone()))?;
        let size = config.image_size()?;

        let skin_core::format::Noted {
            value: links,
            notes: layout_notes,
        } = skin_geom::read_layout(layout_path)?;
        let busmap = busmap_path.as_deref().map(BusMap::read).transpose()?;
        let layout_bytes = std::fs::read(layout_path).map_err(|source| skin_core::Error::Io {
            path: layout_path.clone(),
            source,
        })?;
        let cache = skin_geom::MapCache::new(config.cache_dir());
        // Frames reach the pipeline in layout order: the cache gives maps that keep it.
        let maps = links
            .iter()
            .map(|l| {
                cache
                    .map(&layout_bytes, l, &skin_geom::FlattenOptions::default())
                    .map(|(map, _)| map)
                    .map_err(|source| SessionError::Map {
                        layout: layout_path.clone(),
                        link: l.name.clone(),
                        source,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let stitching = match &poses_path {
            Some(p) => Some(Stitching::new(
                &maps,
                skin_core::format::poses::Postures::read(p)?,
                p,
            )?),
            None => None,
        };
        let check_size = |model: &Path, takes: (usize, usize)| {
            if takes == size {
                Ok(())
            } else {
                Err(SessionError::ImageSize {
                    model: model.to_owned(),
                    takes,
                    config: config.path.clone(),
                    makes: size,
                })
            }
        };
        let mut classes = vec!["hand".to_string(), "non_hand".to_string()];
        let classifier = match classifier_path {
            Some(p) => {
                let net = Classifier::load(&p, InputScale::for_model(&p))?;
                check_size(&p, net.input_size())?;
                if let Some(card) = ModelCard::for_model(&p).filter(|c| c.classes.len() == net.classes()) {
                    classes = card.classes;
                } else if net.classes() != 2 {
                    return Err(SessionError::UnnamedClasses {
                        card: ModelCard::path_for(&p),
                        model: p,
                        classes: net.classes(),
                    });
                }
                Some((net, p))
            }
            None => None,
        };
        let segmenter = match segmenter_path {
            Some(p) => {
                let net = Segmenter::load(&p, InputScale::for_model(&p))?;
                check_size(&p, net.input_size())?;
                Some((net, p))
            }
            None => None,
        };
        let pipeline = TouchPipeline::new(maps, classifier, segmenter, config.touch_options(classes))?;
        let options = SessionOptions {
            baseline_frames: config.baseline.frames,
            polarity: config.baseline.polarity,
            gate: config.gate,
            frame_images: false,
        };
        let mut session = Session::new(links, pipeline, options)?.with_source(&config.path);
        if let Some(s) = stitching {
            session = session.with_stitching(s);
        }
        if let (Some(busmap), Some(busmap_path)) = (&busmap, &busmap_path) {
            session = session.with_can(busmap).map_err(|e| match e {
                SessionError::Can(skin_can::Error::NotInLayout { taxel }) => SessionError::NotInLayout {
                    busmap: busmap_path.clone(),
                    layout: layout_path.clone(),
                    taxel,
                },
                e => e,
            })?;
        }
        session.layout_notes = layout_notes;
        if let Some(p) = &truth_path {
            session = session.with_script(Script::read(p)?);
        }
        Ok(session)
    }

    /// Makes (or stops making) the tactile image of every frame with contact.
    pub fn set_frame_images(&mut self, on: bool) {
        self.options.frame_images = on;
    }

    /// The layout's taxels that no slot of the bus map covers, per link name, in layout
    /// order: they never get a reading (dead taxels). Empty without CAN input.
    pub fn uncovered(&self) -> Vec<(&str, skin_core::TaxelId)> {
        let Some(can) = &self.can else {
            return Vec::new();
        };
        can.layout
            .uncovered()
            .iter()
            .map(|&(l, i)| (self.links[l].name.as_str(), self.links[l].taxels[i].id))
            .collect()
    }

    /// What reading the configuration's layout file did to make it usable (dropped rows, merged
    /// taxels, ...): warnings to pass on. Empty for a session built from code.
    pub fn layout_notes(&self) -> &[skin_core::format::Note] {
        &self.layout_notes
    }

    /// The links, in layout order.
    pub fn links(&self) -> &[LinkSkin] {
        &self.links
    }

    /// The classifier's class names, in output order.
    pub fn classes(&self) -> &[String] {
        &self.classes
    }

    /// The touches that ended so far.
    pub fn touches(&self) -> &[FinishedTouch] {
        &self.done
    }

    /// The gate's current action (none before the first decision, or without a gate).
    pub fn gate(&self) -> Option<GateAction> {
        self.gate
    }

    /// The touch pipeline (its stage times, its last images).
    pub fn pipeline(&self) -> &TouchPipeline {
        &self.pipeline
    }

    /// The bus map frames are taken from, with [`Session::with_can`].
    pub fn busmap(&self) -> Option<&BusMap> {
        self.can.as_ref().map(|c| &c.busmap)
    }

    /// One assembled CAN frame (needs [`Session::with_can`]).
    pub fn push_can(&mut self, frame: &AssembledFrame, sink: &mut dyn Sink) -> Result<(), SessionError> {
        let time = self.time(frame.time_us, sink)?;
        let Some(can) = &self.can else {
            return Err(SessionError::NoBusMap);
        };
        can.layout.place(frame, &mut self.raw)?;
        if !frame.is_complete() {
            self.incomplete += 1;
            let missing = frame
                .missing
                .iter()
                .map(|m| MissingModule {
                    bus: can
                        .interfaces
                        .get(usize::from(m.bus))
                        .cloned()
                        .unwrap_or_default(),
                    address: m.address,
                })
                .collect();
            sink.event(&Event::Incomplete { time, missing })
                .map_err(SessionError::Sink)?;
        }
        self.step(frame.time_us, time, frame.cycle, frame.is_complete(), sink)
    }

    /// One frame from any source: `readings[link][taxel]` in layout order, at `time_us`
    /// (microseconds, any origin: times in events count from the first frame); `cycle` numbers
    /// the frame (image names). Every taxel must have a reading.
    pub fn push(
        &mut self,
        time_us: u64,
        cycle: u64,
        readings: &[impl AsRef<[f32]>],
        sink: &mut dyn Sink,
    ) -> Result<(), SessionError> {
        let time = self.time(time_us, sink)?;
        if readings.len() != self.raw.len() {
            return Err(SessionError::Frame {
                time,
                source: skin_core::Error::Length {
                    what: "links' readings",
                    got: readings.len(),
                    expected: self.raw.len(),
                },
            });
        }
        for (dst, src) in self.raw.iter_mut().zip(readings) {
            let src = src.as_ref();
            if src.len() != dst.len() {
                return Err(SessionError::Frame {
                    time,
                    source: skin_core::Error::Length {
                        what: "readings of a link",
                        got: src.len(),
                        expected: dst.len(),
                    },
                });
            }
            dst.copy_from_slice(src);
        }
        self.step(time_us, time, cycle, true, sink)
    }

    /// Reports the counter restarts `stats` has seen since the last call ([`Event::CounterReset`]);
    /// call it after pushing each CAN frame to the assembler.
    pub fn note_resets(&mut self, stats: &AssemblyStats, sink: &mut dyn Sink) -> Result<(), SessionError> {
        if stats.counter_resets > self.resets
            && let Some(r) = &stats.last_reset
        {
            self.resets = stats.counter_resets;
            self.counter_reset(r, sink)?;
        }
        Ok(())
    }

    fn counter_reset(&mut self, r: &CounterReset, sink: &mut dyn Sink) -> Result<(), SessionError> {
        let t0 = self.t0_us.unwrap_or(r.time_us);
        let bus = self
            .can
            .as_ref()
            .and_then(|c| c.interfaces.get(usize::from(r.bus)))
            .map_or("?", String::as_str);
        sink.event(&Event::CounterReset {
            time: r.time_us.saturating_sub(t0) as f64 * 1e-6,
            bus: bus.to_owned(),
            from: r.from,
            to: r.to,
            cycle: r.cycle,
        })
        .map_err(SessionError::Sink)
    }

    /// A raw recording (Cyskin's `ids / index time counts...` form; `path` names it in errors)
    /// through the session one frame at a time, then [`Session::finish`]: a
    /// [`RecordingReader`](skin_core::format::recording::RecordingReader) on a file of any
    /// length, or a whole [`Recording`] by reference. Each link reads its taxels' columns by id:
    /// a taxel the recording has no column for reads 0 and is dead (its count, with the columns
    /// that are no taxel of the layout, goes to the summary). Frame times are the recording's;
    /// frames are numbered by the recording's frame numbers. Events reach the sink as the frames
    /// are read: a fault further down the file fails the run after them. Returns the recording's
    /// span, seconds.
    pub fn run_recording(
        &mut self,
        rec: impl IntoRecordingSource,
        path: &Path,
        sink: &mut dyn Sink,
    ) -> Result<f64, SessionError> {
        let mut rec = rec.into_recording_source();
        // The header is all that matching columns to taxels needs.
        let header = Recording {
            taxel_ids: rec.taxel_ids().to_vec(),
            ..Recording::default()
        };
        let columns: Vec<Columns> = self.links.iter().map(|l| header.columns(&l.ids())).collect();
        // The whole skin at once: a column of one link is not "ignored" by another.
        let all: Vec<skin_core::TaxelId> = self.links.iter().flat_map(LinkSkin::ids).collect();
        let whole = header.columns(&all);
        if whole.missing.len() == all.len() {
            return Err(SessionError::NotRecorded {
                recording: path.to_owned(),
                taxels: all.len(),
                columns: header.taxel_ids.len(),
            });
        }
        self.notes.clear();
        if !whole.missing.is_empty() {
            let placeholders = whole.missing.iter().filter(|id| id.is_placeholder()).count();
            self.notes.push(format!(
                "{} taxel(s) of the layout have no column in the recording ({placeholders} of them placeholders): dead, contacts and images bridge them",
                whole.missing.len()
            ));
        }
        if whole.ignored > 0 {
            self.notes.push(format!(
                "{} column(s) of the recording are no taxel of the layout, ignored",
                whole.ignored
            ));
        }
        // Dead taxels are handled as Test B handles removed ones: each link's triangles are made
        // again without them (and made whole again for a recording that has them all).
        for (k, c) in columns.iter().enumerate() {
            self.pipeline.set_dead(k, &c.dead())?;
        }
        if let Some(st) = &mut self.stitching {
            st.set_dead(&columns.iter().map(Columns::dead).collect::<Vec<_>>())?;
        }
        let mut raw: Vec<Vec<f32>> = self.links.iter().map(|l| vec![0.0; l.taxels.len()]).collect();
        let (mut first, mut last) = (None, 0.0);
        while let Some(frame) = rec.next_frame()? {
            for (r, c) in raw.iter_mut().zip(&columns) {
                c.gather(frame.values, f32::NEG_INFINITY, r);
            }
            // Times count from the first frame; a recording's times only go forward.
            let t0 = *first.get_or_insert(frame.time);
            last = frame.time;
            let time_us = ((frame.time - t0).max(0.0) * 1e6).round() as u64;
            let cycle = frame.number;
            self.push(time_us, cycle, &raw, sink)?;
        }
        self.finish(sink)?;
        Ok(first.map_or(0.0, |t0| (last - t0).max(0.0)))
    }

    /// A candump log (`path` names it in errors) through the session one CAN frame at a time,
    /// then [`Session::finish`]: a [`CandumpReader`](skin_can::candump::CandumpReader) on a file
    /// of any length (memory does not grow with the log), a whole
    /// [`CandumpLog`](skin_can::candump::CandumpLog) by reference, or any other [`CanSource`].
    /// `progress(frames, bytes)` is called every 4,096 CAN frames with the frames read so far and
    /// the bytes of text they took ([`CanSource::bytes_read`]). Events reach the sink as the
    /// frames are read: a fault further down the log fails the run after them. A log that is
    /// empty, that has none of the bus map's interfaces or that gives no frame of this skin is
    /// an error naming it, found when the log ends. Returns the log's span, seconds.
    pub fn run_log<L: IntoCanSource>(
        &mut self,
        log: L,
        path: &Path,
        sink: &mut dyn Sink,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<f64, SessionError> {
        let mut log = log.into_can_source();
        let empty = |log: &<L as IntoCanSource>::Source| {
            let message = match log.error_frames() {
                0 => "no CAN frames in it (an empty log)".to_string(),
                n => {
                    format!("no CAN frames but {n} error frame(s): a log of bus errors, without skin traffic")
                }
            };
            SessionError::from(skin_can::Error::Invalid {
                path: path.to_owned(),
                message,
            })
        };
        let Some(can) = &self.can else {
            // An empty log is named as such, before the bus map's absence.
            if log.next_frame()?.is_none() {
                return Err(empty(&log));
            }
            let whose = if self.source == Path::new("frames") {
                "the session has none (Session::with_can)".to_string()
            } else {
                format!(
                    "{} names none: add busmap = \"FILE.toml\" to it",
                    self.source.display()
                )
            };
            return Err(skin_can::Error::Invalid {
                path: path.to_owned(),
                message: format!(
                    "a candump log needs a bus map (which taxel each CAN slot carries), and {whose}"
                ),
            }
            .into());
        };
        let busmap = can.busmap.clone();
        let on_map = can.interfaces.clone();
        // Interfaces are added to the assembler as the log names them.
        let mut assembler = Assembler::for_map(&busmap, &[], skin_can::DEFAULT_WINDOW_US);
        let mut error = None;
        let started = Instant::now();
        let mut inside = Duration::ZERO;
        let (mut count, mut first_us, mut last_us) = (0usize, 0u64, 0u64);
        // Frames are read a batch at a time, then assembled: reading and assembling each keep
        // their own code and data hot (bounded: BATCH frames).
        const BATCH: usize = 256;
        let mut batch: Vec<skin_can::candump::CanFrame> = Vec::with_capacity(BATCH);
        let mut ended = false;
        while !ended && error.is_none() {
            batch.clear();
            while batch.len() < BATCH {
                match log.next_frame() {
                    Ok(Some(frame)) => batch.push(frame),
                    Ok(None) => {
                        ended = true;
                        break;
                    }
                    Err(e) => {
                        error = Some(e.into());
                        ended = true;
                        break;
                    }
                }
            }
            let named = log.interfaces();
            if named.len() > assembler.interfaces() {
                for name in &named[assembler.interfaces()..] {
                    assembler.add_interface(name);
                }
            }
            let read_error = error.take();
            for frame in &batch {
                if count == 0 {
                    first_us = frame.time_us;
                }
                last_us = frame.time_us;
                assembler.push(frame, &mut |a| {
                    if error.is_none() {
                        let t = Instant::now();
                        error = self.push_can(a, sink).err();
                        inside += t.elapsed();
                    }
                });
                if error.is_none() {
                    error = self.note_resets(assembler.stats(), sink).err();
                }
                if error.is_some() {
                    break;
                }
                if count % 4096 == 0 {
                    progress(count as u64, log.bytes_read());
                }
                count += 1;
            }
            error = error.or(read_error);
        }
        if error.is_none() {
            assembler.finish(&mut |a| {
                if error.is_none() {
                    error = self.push_can(a, sink).err();
                }
            });
        }
        self.stage.assemble += started.elapsed().saturating_sub(inside);
        if let Some(e) = error {
            return Err(e);
        }
        if count == 0 {
            return Err(empty(&log));
        }
        let in_log = log.interfaces();
        if !on_map.iter().any(|i| in_log.contains(i)) {
            return Err(SessionError::OtherBuses {
                log: path.to_owned(),
                on_map,
                in_log: in_log.to_vec(),
            });
        }
        let s = assembler.stats();
        self.notes.clear();
        for (n, what) in [
            (log.error_frames() as u64, "CAN error frames in the log, skipped"),
            (s.remote, "remote requests, skipped"),
            (
                s.time_backwards,
                "CAN frames stamped earlier than the frame before them on their interface (kept in log order)",
            ),
        ] {
            if n > 0 {
                self.notes.push(format!("{n} {what}"));
            }
        }
        let data = s.frames * busmap.buses.iter().map(|b| b.modules.len() as u64).sum::<u64>();
        if s.frames == 0 || s.unknown_module > data.max(1) {
            return Err(SessionError::NotThisSkin {
                log: path.to_owned(),
                frames: s.frames,
                can_frames: count,
                unknown: s.unknown_module,
                malformed: s.malformed.iter().map(|(_, n)| n).sum(),
                format: busmap.format.name(),
                ignored: s.ignored,
            });
        }
        self.finish(sink)?;
        Ok(last_us.saturating_sub(first_us) as f64 * 1e-6)
    }

    /// Seconds from the first frame (whose stamp the sink is told).
    fn time(&mut self, time_us: u64, sink: &mut dyn Sink) -> Result<f64, SessionError> {
        let t0 = match self.t0_us {
            Some(t0) => t0,
            None => {
                self.t0_us = Some(time_us);
                sink.origin(time_us).map_err(SessionError::Sink)?;
                time_us
            }
        };
        Ok(time_us.saturating_sub(t0) as f64 * 1e-6)
    }

    /// The frame in `self.raw` through the whole path.
    fn step(
        &mut self,
        time_us: u64,
        time: f64,
        cycle: u64,
        complete: bool,
        sink: &mut dyn Sink,
    ) -> Result<(), SessionError> {
        let started = Instant::now();
        self.frames += 1;
        self.last_time = time;
        if self.baselines.is_empty() {
            if !complete {
                return Ok(());
            }
            self.learner.push(&self.raw)?;
            if self.learner.is_done() {
                for (b, health) in self.learner.finish(&self.source)? {
                    self.baselines.push(b);
                    self.health.push(health);
                }
                self.learned_at = time;
            }
            self.stage.baseline += started.elapsed();
            return Ok(());
        }
        for (l, ((b, raw), p)) in self
            .baselines
            .iter_mut()
            .zip(&self.raw)
            .zip(&mut self.pressures)
            .enumerate()
        {
            let reset = b
                .apply(raw, p)
                .map_err(|source| SessionError::Frame { time, source })?;
            let c = &mut self.correcting[l];
            if reset > 0 {
                c.since.get_or_insert(time);
                c.quiet = 0;
            } else if c.since.is_some() {
                c.quiet += 1;
            }
        }
        self.stage.baseline += started.elapsed();
        self.end_corrections(time, CORRECTION_QUIET_FRAMES, sink)?;
        self.touch_events.clear();
        self.pipeline
            .process(time, &self.pressures, &mut self.touch_events)?;
        let t = Instant::now();
        self.emit(sink)?;
        sink.frame(&ProcessedFrame {
            time_us,
            time,
            cycle,
            pressures: &self.pressures,
            pipeline: &self.pipeline,
        })
        .map_err(SessionError::Sink)?;
        if self.options.frame_images {
            for l in 0..self.links.len() {
                if self.pipeline.touching(l) {
                    let (grey, (rows, cols)) = self.pipeline.frame_image(l, &self.pressures[l])?;
                    fill(&mut self.image, grey, rows, cols);
                    sink.frame_image(FrameView::Link(&self.links[l].name), cycle, &self.image)
                        .map_err(SessionError::Sink)?;
                }
            }
        }
        self.across_joints(time, cycle, sink)?;
        self.stage.output += t.elapsed();
        Ok(())
    }

    /// Contacts across joints (an event when one begins and when none is left) and stitched
    /// images.
    fn across_joints(&mut self, time: f64, cycle: u64, sink: &mut dyn Sink) -> Result<(), SessionError> {
        let Some(st) = &mut self.stitching else {
            return Ok(());
        };
        let options = self.pipeline.options();
        let spans = st.spanning(&self.pressures, options.threshold, time, options.min_taxels)?;
        if !spans.is_empty() && !st.joined {
            self.across += 1;
            for s in &spans {
                let event = Event::AcrossJoint {
                    time,
                    links: s.links.iter().map(|&l| self.links[l].name.clone()).collect(),
                    taxels: s.taxels,
                    centroid: s.centroid,
                };
                sink.event(&event).map_err(SessionError::Sink)?;
            }
        } else if spans.is_empty() && st.joined {
            sink.event(&Event::AcrossJointEnd { time })
                .map_err(SessionError::Sink)?;
        }
        st.joined = !spans.is_empty();
        if self.options.frame_images && (0..self.links.len()).any(|l| self.pipeline.touching(l)) {
            let view = st.image()?;
            fill(&mut self.image, view.pixels(), view.size().rows, view.size().cols);
            sink.frame_image(FrameView::Stitched, cycle, &self.image)
                .map_err(SessionError::Sink)?;
        }
        Ok(())
    }

    /// Baseline corrections quiet for `quiet` frames are over: an event each.
    fn end_corrections(&mut self, time: f64, quiet: u32, sink: &mut dyn Sink) -> Result<(), SessionError> {
        for (l, (c, b)) in self.correcting.iter_mut().zip(&mut self.baselines).enumerate() {
            let Some(since) = c.since.filter(|_| c.quiet >= quiet) else {
                continue;
            };
            let taxels = b.take_corrected();
            c.since = None;
            c.events += 1;
            c.taxels += taxels as u64;
            let event = Event::BaselineCorrected {
                time,
                since,
                link: self.links[l].name.clone(),
                taxels,
            };
            sink.event(&event).map_err(SessionError::Sink)?;
        }
        Ok(())
    }

    /// The pipeline's events, typed, to the sink.
    fn emit(&mut self, sink: &mut dyn Sink) -> Result<(), SessionError> {
        let events = std::mem::take(&mut self.touch_events);
        let result = events.iter().try_for_each(|e| self.emit_one(e, sink));
        self.touch_events = events;
        result
    }

    fn class_name(&self, class: usize) -> String {
        self.classes.get(class).map_or("?", String::as_str).to_owned()
    }

    /// The gate's class of the model's class `class` (computed once, at build).
    fn kind(&self, class: usize) -> TouchClass {
        self.kinds.get(class).copied().unwrap_or(TouchClass::NonHand)
    }

    fn emit_one(&mut self, e: &TouchEvent, sink: &mut dyn Sink) -> Result<(), SessionError> {
        let link = |l: usize| self.links[l].name.clone();
        let event = match e {
            TouchEvent::Appeared {
                link: l,
                touch,
                time,
                footprint,
            } => {
                self.open.insert(*touch, *time);
                Event::Appeared {
                    time: *time,
                    link: link(*l),
                    touch: *touch,
                    footprint: *footprint,
                }
            }
            TouchEvent::Classified {
                link: l,
                touch,
                time,
                decision,
                revised,
            } => {
                let (pixels, (rows, cols)) = self.pipeline.last_image(*l).unwrap_or((&[], (0, 0)));
                Event::Classified {
                    time: *time,
                    link: link(*l),
                    touch: *touch,
                    revised: *revised,
                    class: self.class_name(decision.class),
                    kind: self.kind(decision.class),
                    probability: decision.probability,
                    parts: decision.parts.clone(),
                    image: GreyImage {
                        rows,
                        cols,
                        pixels: pixels.to_vec(),
                    },
                }
            }
            TouchEvent::Released {
                link: l,
                touch,
                time,
                duration,
                frames,
                peak,
                decision,
            } => {
                let start = self.open.remove(touch).unwrap_or(*time - *duration);
                self.done.push(FinishedTouch {
                    link: *l,
                    touch: *touch,
                    start,
                    end: *time,
                    peak: *peak,
                    decision: decision.clone(),
                });
                Event::Released {
                    time: *time,
                    link: link(*l),
                    touch: *touch,
                    duration: *duration,
                    frames: *frames,
                    peak: *peak,
                    class: decision.as_ref().map(|d| self.class_name(d.class)),
                    kind: decision.as_ref().map(|d| self.kind(d.class)),
                    probability: decision.as_ref().map(|d| d.probability),
                }
            }
        };
        sink.event(&event).map_err(SessionError::Sink)?;
        if let TouchEvent::Classified { time, .. } | TouchEvent::Released { time, .. } = e {
            self.update_gate(*time, sink)?;
        }
        Ok(())
    }

    /// The gate: the action of the most severe touch in progress.
    fn update_gate(&mut self, time: f64, sink: &mut dyn Sink) -> Result<(), SessionError> {
        let Some(gate) = &self.options.gate else {
            return Ok(());
        };
        let kinds = &self.kinds;
        let action = gate.decide(
            self.pipeline
                .open_classes()
                .map(|c| kinds.get(c).copied().unwrap_or(TouchClass::NonHand)),
        );
        if self.gate != Some(action) {
            self.gate = Some(action);
            sink.event(&Event::Gate { time, action })
                .map_err(SessionError::Sink)?;
        }
        Ok(())
    }

    /// The end of the input: touches still open are released. Fails if the baseline was never
    /// learned.
    pub fn finish(&mut self, sink: &mut dyn Sink) -> Result<(), SessionError> {
        if self.baselines.is_empty() {
            return Err(SessionError::TooShort {
                frames: self.frames,
                needed: self.options.baseline_frames,
            });
        }
        self.end_corrections(self.last_time, 0, sink)?;
        self.touch_events.clear();
        self.pipeline.finish(self.last_time, &mut self.touch_events)?;
        self.emit(sink)
    }

    /// The run's summary over `span` seconds of input: frames, untrusted taxels, the touches,
    /// and the score against the script (`Display` writes what `skin run` prints).
    pub fn summary(&self, span: f64) -> Summary<'_> {
        Summary { session: self, span }
    }

    /// Time per stage (`Display` writes `skin run --timings`).
    pub fn timings(&self, span: f64) -> Timings<'_> {
        Timings { session: self, span }
    }
}

/// Copies a borrowed image into the reused one.
fn fill(image: &mut GreyImage, grey: &[u8], rows: usize, cols: usize) {
    image.rows = rows;
    image.cols = cols;
    image.pixels.clear();
    image.pixels.extend_from_slice(grey);
}
