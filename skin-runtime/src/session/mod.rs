//! The whole per-frame pipeline of a skin as one value: frames in, typed [`Event`]s out. What
//! `skin run` does, for a robot stack to do in its own loop.
//!
//! ```text
//! CAN frames --Assembler--> assembled frame --LayoutFrames--> readings per link (layout order;
//!   a missing module holds its last readings and is reported: Event::Incomplete)
//!   --BaselineLearner (first N complete frames)--> Baseline --> pressures per link
//!   --TouchPipeline--> touches: Appeared, Classified (with the image decided on), Released
//!   --ClassGate--> Gate          --Stitching (per posture)--> AcrossJoint
//! ```
//!
//! A [`Session`] is built once, from a configuration file (the `run.toml` of `skin run`:
//! [`Session::from_config_with_runtime`], its models opened by a [`ModelRuntime`] such as
//! skin-learn's tract one, which skin-learn's `FromConfig::from_config` uses; or
//! [`Session::from_config_with_models`] with models you bring) or from code
//! ([`Session::with_settings`], [`Session::new`] and the `with_` methods). Frames
//! reach it as assembled CAN frames ([`Session::push_can`]), as readings in layout order from
//! any other source ([`Session::push`]), or as a whole candump log ([`Session::run_log`]). Every
//! event goes to a [`Sink`] as it happens: [`JsonLines`] and [`PngImages`] are `skin run`'s
//! outputs, a `Vec<Event>` collects them, and a robot stack implements [`Sink`] to act on them.
//! A sink may stop the run ([`Flow::Break`]). [`Session::stats`] counts frames, touches and
//! time per stage; [`Session::summary`] gives the run's summary (and its score against a
//! [`Script`]).
//!
//! The code is split by concern: `config` (the run.toml file), `settings` (its settings with
//! their defaults and bounds), `build` (from a configuration: files, map cache; from code),
//! `models` (the models a configuration names, opened by a [`ModelRuntime`], or the caller's
//! [`OwnModels`]), `input` (CAN frames, candump logs, recordings; a bus map's
//! uncovered taxels are declared dead in [`Session::with_can`]), `restart` (sync-counter
//! restarts), `frame` (one frame through the path), `emit` (touch events, the gate), `stitching`
//! (contacts across joints), `event` (what a sink receives), `sink` (the [`Sink`] trait and
//! `skin run`'s writers), `stats`, `error`, `summary`.
//!
//! A robot stack's loop (frames in, events out) is the example on the [crate's first page](crate).
//!
//! The fixture session end to end (CAN log, HandsNet, segmenter): `examples/examples/classify_touch.rs`.

mod build;
mod config;
mod describe;
mod emit;
mod error;
mod event;
mod frame;
mod input;
mod joint_states;
mod models;
mod restart;
mod settings;
mod sink;
mod stats;
mod stitching;
mod summary;
mod tare;

pub use config::{ForceConfig, SessionConfig, SimConfig, StitchConfig};
pub use describe::{Description, LinkDescription, Readings, Units};
pub use error::{ConfigError, InputError, SessionError};
pub use event::{Event, FrameView, MissingModule, OverForce, ProcessedFrame, RawFrame};
pub use joint_states::{FEED_CAPACITY, FeedCounts, JointFault, JointProblem, PostureFeed};
pub use models::{ModelRuntime, OwnModels};
pub use settings::{BaselineConfig, ContactRule, SessionSettings, SettingError, SplitConfig, TouchConfig};
pub use sink::{Flow, JsonLines, PngImages, Sink, SinkError, Sinks};
pub use stats::SessionStats;
pub use stitching::{Spanning, Stitching};
pub use summary::{ScriptScore, Summary, Timings};
pub use tare::{TareHandle, TareRefused, TareStarted};

use crate::model::Classes;
use crate::script::{Found, Script, Tally};
use crate::touch::{Released, TouchEvent, TouchPipeline};
use skin_can::{BusMap, LayoutFrames, Missing};
use skin_control::hri::{ClassGate, GateAction};
use skin_core::{Baseline, BaselineLearner, BaselineOptions, LinkSkin, Polarity, TaxelHealth};
use std::collections::VecDeque;
use std::path::{Path, PathBuf};

/// The touches that ended a session keeps ([`Session::touches`], the table of its
/// [`Session::summary`]): the last this many. A session runs for as long as a robot does, so
/// it keeps no memory per touch beyond these; every touch reaches the sinks as it ends
/// ([`Event::Released`]), and the counts and the score against a script take every one.
pub const TOUCH_HISTORY: usize = 1_000;

/// How a session runs (the parts of [`SessionConfig`] that are not files).
#[derive(Debug, Clone, PartialEq)]
pub struct SessionOptions {
    /// Complete untouched frames at the start that learn the baseline (2 to 100,000; default
    /// [`BaselineConfig::default`]'s).
    pub baseline_frames: usize,
    /// Which way pressure moves a reading.
    pub polarity: Polarity,
    /// What the robot does for each class of touch (a [`Event::Gate`] when it changes).
    pub gate: Option<ClassGate>,
    /// Make the tactile image of every frame with contact ([`Sink::frame_image`]).
    pub frame_images: bool,
}

impl Default for SessionOptions {
    /// [`SessionSettings::default`]'s: run.toml's defaults.
    fn default() -> Self {
        SessionSettings::default().session_options()
    }
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

/// The baseline: learned from the first complete frames, then applied and corrected.
struct BaselineState {
    learner: BaselineLearner,
    baselines: Vec<Baseline>,
    health: Vec<TaxelHealth>,
    /// Per link: offsets being reset now ([`Event::BaselineCorrected`]).
    correcting: Vec<Correcting>,
}

/// What the session is given to work on: the skin and what comes with it, fixed once built.
struct Setup {
    links: Vec<LinkSkin>,
    options: SessionOptions,
    can: Option<CanInput>,
    stitching: Option<Stitching>,
    /// Names the input in errors (the configuration, or "frames").
    source: PathBuf,
    /// What reading the layout file did (a session from a configuration).
    layout_notes: Vec<skin_core::format::Note>,
    /// Each link's dead taxels (no reading: on no bus, or no column of a recording), kept so a
    /// stitching added later bridges them too.
    dead: Vec<Vec<usize>>,
    /// The settings it was built with ([`Session::with_settings`]).
    settings: Option<SessionSettings>,
    /// The skin is simulated ([`Session::describe`]).
    simulated: bool,
    /// Per link, the force calibration its newtons come from (empty: none).
    calibration_ids: Vec<String>,
    /// The stitching's postures are the robot's (a poses file, or [`Session::with_stitching`]),
    /// not a posture made up to draw the maps at: they place the links' contacts in the base
    /// frame.
    posed_by_file: bool,
    /// The stitched chain's kinematics (`[stitch] urdf`) and how old a posture may be.
    kinematics: Option<(skin_control::Chain, std::time::Duration)>,
    /// The robot's joint states, when a feed was asked for ([`Session::joint_state_feed`]),
    /// and whether frames are stamped from 0 at the first (else on the input's clock).
    feed: Option<(PostureFeed, bool)>,
}

/// The per-frame pipeline of a whole skin, built once (see the [module](self)).
pub struct Session {
    setup: Setup,
    pipeline: TouchPipeline,
    base: BaselineState,
    raw: Vec<Vec<f32>>,
    pressures: Vec<Vec<f32>>,
    touch_events: Vec<TouchEvent>,
    /// The last [`TOUCH_HISTORY`] touches that ended, oldest first.
    done: VecDeque<Released>,
    /// The score against the script so far ([`Session::with_script`]).
    tally: Option<Tally>,
    t0_us: Option<u64>,
    last_time: f64,
    stats: SessionStats,
    gate: Option<GateAction>,
    /// Per link, the touch that pressed past its class's force limit (`[gate] force_n`): the
    /// gate stays at `stop` until it is released.
    over_force: Vec<Option<u64>>,
    /// Lines for the summary about the traffic itself (skipped or odd CAN frames).
    notes: Vec<String>,
    /// A sink said stop: nothing more reaches the sinks, frames are refused.
    stopped: bool,
    /// The posture a frame got from the joint states (kept to copy into).
    live_poses: Vec<nalgebra::Isometry3<f64>>,
    /// The joint states gave a posture at some frame: from then on, the poses file's postures
    /// no longer say where the robot is.
    live_placed: bool,
    /// The touch pipeline holds the links' poses (else it holds none).
    placed: bool,
    /// Faults of the joint states taken at a frame (kept to copy into).
    joint_faults: Vec<JointFault>,
    /// Tares asked for ([`Session::tare`], [`TareHandle`]).
    tares: tare::Tares,
    /// The baseline was learned once: a tare learning it again does not make the input too
    /// short.
    learned: bool,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field(
                "links",
                &self.setup.links.iter().map(|l| &l.name).collect::<Vec<_>>(),
            )
            .field("options", &self.setup.options)
            .field("frames", &self.stats.frames)
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
        let baseline_frames = options.baseline_frames;
        let baseline = BaselineOptions {
            polarity: options.polarity,
            ..BaselineOptions::default()
        };
        Ok(Session {
            base: BaselineState {
                learner: BaselineLearner::new(&sizes, options.baseline_frames, baseline)?,
                baselines: Vec::new(),
                health: Vec::new(),
                correcting: vec![Correcting::default(); sizes.len()],
            },
            raw: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            pressures: sizes.iter().map(|&n| vec![0.0; n]).collect(),
            setup: Setup {
                links,
                options,
                can: None,
                stitching: None,
                source: PathBuf::from("frames"),
                layout_notes: Vec::new(),
                dead: Vec::new(),
                settings: None,
                simulated: false,
                calibration_ids: vec![String::new(); sizes.len()],
                posed_by_file: false,
                kinematics: None,
                feed: None,
            },
            pipeline,
            touch_events: Vec::new(),
            done: VecDeque::new(),
            tally: None,
            t0_us: None,
            last_time: 0.0,
            stats: SessionStats::default(),
            gate: None,
            over_force: vec![None; sizes.len()],
            notes: Vec::new(),
            stopped: false,
            live_poses: Vec::new(),
            live_placed: false,
            placed: false,
            joint_faults: Vec::new(),
            tares: tare::Tares::new(baseline_frames),
            learned: false,
        })
    }

    /// Takes assembled CAN frames of `busmap` ([`Session::push_can`]); a module missing from a
    /// frame holds its last readings. Fails for a taxel the links lack.
    pub fn with_can(mut self, busmap: &BusMap) -> Result<Session, SessionError> {
        let ids: Vec<Vec<_>> = self.setup.links.iter().map(LinkSkin::ids).collect();
        let layout = LayoutFrames::new(busmap, &ids, Missing::HoldLast)?;
        // Taxels on no bus never read: bridged like a recording's missing columns.
        let dead = (0..self.setup.links.len())
            .map(|k| {
                layout
                    .uncovered()
                    .iter()
                    .filter(|&&(l, _)| l == k)
                    .map(|&(_, i)| i)
                    .collect()
            })
            .collect();
        self.set_dead(dead)?;
        self.setup.can = Some(CanInput {
            interfaces: busmap.buses.iter().map(|b| b.interface.clone()).collect(),
            layout,
            busmap: busmap.clone(),
        });
        Ok(self)
    }

    /// Also searches contacts over the stitched chain ([`Event::AcrossJoint`]), bridging the
    /// dead taxels already known (a bus map's, [`Session::with_can`]) whichever comes first.
    /// Fails if the chain's maps do not fit the links' taxels.
    pub fn with_stitching(mut self, mut stitching: Stitching) -> Result<Session, SessionError> {
        if !self.setup.dead.is_empty() {
            stitching.set_dead(&self.setup.dead)?;
        }
        self.setup.stitching = Some(stitching);
        self.setup.posed_by_file = true;
        Ok(self)
    }

    /// Declares each link's dead taxels (indices into its taxels; no reading, so contacts and
    /// images bridge them as Test B bridges removed taxels): on every link's touch tracking and
    /// on the stitched chain, now and when one is added.
    fn set_dead(&mut self, dead: Vec<Vec<usize>>) -> Result<(), SessionError> {
        for (k, d) in dead.iter().enumerate() {
            self.pipeline.set_dead(k, d)?;
        }
        if let Some(st) = &mut self.setup.stitching {
            st.set_dead(&dead)?;
        }
        self.setup.dead = dead;
        Ok(())
    }

    /// Reports force for the links `calibration` covers (read from `path`, which names it in
    /// errors): their contacts carry `force_n` ([`skin_core::Contact::force_n`], the events'
    /// footprints) and each a [`wrench`](Session::wrench). A calibration of a link the layout
    /// does not have, or of other taxels, is refused by name.
    pub fn with_force(
        mut self,
        calibration: &skin_core::format::force_file::ForceCalibration,
        path: &Path,
    ) -> Result<Session, SessionError> {
        for (k, lf) in calibration.links.iter().enumerate() {
            let Some(l) = self.setup.links.iter().position(|l| l.name == lf.name) else {
                let names: Vec<&str> = self.setup.links.iter().map(|l| l.name.as_str()).collect();
                return Err(skin_core::Error::invalid(
                    path,
                    format!("links[{k}].name"),
                    format!(
                        "link \"{}\" is not in the layout (its links: {})",
                        lf.name,
                        names.join(", ")
                    ),
                )
                .into());
            };
            let map = self.pipeline.map(l).ok_or(crate::touch::TouchError::NoLink {
                link: l,
                links: self.setup.links.len(),
            })?;
            let areas = skin_core::force::taxel_areas(&map.positions, &map.faces).map_err(|source| {
                skin_core::Error::Force {
                    path: path.to_owned(),
                    place: format!("links[{k}]"),
                    source: Box::new(source),
                }
            })?;
            let link = &self.setup.links[l];
            let model = lf.model(link, areas, path)?;
            self.setup.calibration_ids[l] = calibration_id(path, lf);
            let normals = link.taxels.iter().map(|t| t.normal.into_inner()).collect();
            self.pipeline.set_force(l, model, normals)?;
        }
        Ok(self)
    }

    /// What the contacts of the last frame press `link` with (layout index), in its frame:
    /// force (N), torque about its origin (N m) and centre of pressure, and how many of their
    /// taxels read past saturation (then a lower bound); none for a link without a force
    /// calibration ([`Session::with_force`]).
    pub fn wrench(&self, link: usize) -> Option<(skin_core::force::Wrench, usize)> {
        self.pipeline.wrench(link)
    }

    /// Scores the finished touches against a script ([`Session::summary`]).
    pub fn with_script(mut self, script: Script) -> Session {
        self.tally = Some(Tally::new(script));
        self
    }

    /// Names the input in errors (default: "frames").
    pub fn with_source(mut self, source: &Path) -> Session {
        self.setup.source = source.to_owned();
        self
    }

    /// Makes (or stops making) the tactile image of every frame with contact.
    pub fn set_frame_images(&mut self, on: bool) {
        self.setup.options.frame_images = on;
    }

    /// Whether links are stitched across joints (a `[stitch]` section): frames then carry the
    /// maps' placements ([`ProcessedFrame::stitched_placements`]).
    pub fn stitched(&self) -> bool {
        self.setup.stitching.is_some()
    }

    /// The layout's taxels that no slot of the bus map covers, per link name, in layout
    /// order: they never get a reading (dead taxels). Empty without CAN input.
    pub fn uncovered(&self) -> Vec<(&str, skin_core::TaxelId)> {
        let Some(can) = &self.setup.can else {
            return Vec::new();
        };
        let links = &self.setup.links;
        can.layout
            .uncovered()
            .iter()
            .map(|&(l, i)| (links[l].name.as_str(), links[l].taxels[i].id))
            .collect()
    }

    /// What reading the configuration's layout file did to make it usable (dropped rows, merged
    /// taxels, ...): warnings to pass on. Empty for a session built from code.
    pub fn layout_notes(&self) -> &[skin_core::format::Note] {
        &self.setup.layout_notes
    }

    /// The settings it was built with, as run.toml would write them: those of its
    /// configuration, or those given to [`Session::with_settings`]; none for a session put
    /// together from a touch pipeline with [`Session::new`] (its options are
    /// [`Session::options`] and the pipeline's).
    pub fn settings(&self) -> Option<&SessionSettings> {
        self.setup.settings.as_ref()
    }

    /// How it runs: the baseline, the gate.
    pub fn options(&self) -> &SessionOptions {
        &self.setup.options
    }

    /// The links, in layout order.
    pub fn links(&self) -> &[LinkSkin] {
        &self.setup.links
    }

    /// The classifier's classes, in output order.
    pub fn classes(&self) -> &Classes {
        self.pipeline.classes()
    }

    /// The touches that ended, oldest first: the last [`TOUCH_HISTORY`] of them
    /// ([`SessionStats::touches`] counts them all).
    pub fn touches(&self) -> impl ExactSizeIterator<Item = &Released> + DoubleEndedIterator + '_ {
        self.done.iter()
    }

    /// Takes a touch that ended: counts it, scores it against the script, and keeps it among
    /// the last [`TOUCH_HISTORY`] (room for all of them made once, so a long session's
    /// touches move no memory).
    fn ended(&mut self, touch: &Released) {
        self.stats.touches += 1;
        self.stats.most_contacts = self.stats.most_contacts.max(touch.peak.contacts);
        if let Some(tally) = &mut self.tally {
            tally.add(&Found {
                start_s: touch.start,
                end_s: touch.time,
                class: touch.decision.as_ref().map(|d| d.class.name()),
            });
        }
        if self.done.len() >= TOUCH_HISTORY {
            self.done.pop_front();
        }
        if self.done.capacity() < TOUCH_HISTORY {
            self.done.reserve_exact(TOUCH_HISTORY - self.done.len());
        }
        self.done.push_back(touch.clone());
    }

    /// The gate's current action (none before the first decision, or without a gate).
    pub fn gate(&self) -> Option<GateAction> {
        self.gate
    }

    /// The touch pipeline (its stage times, its last images).
    pub fn pipeline(&self) -> &TouchPipeline {
        &self.pipeline
    }

    /// Per link (layout order), whether it has a force model: its contacts carry newtons and it
    /// has a wrench.
    pub fn weighed(&self) -> Vec<bool> {
        (0..self.setup.links.len())
            .map(|l| self.pipeline.force_model(l).is_some())
            .collect()
    }

    /// The bus map frames are taken from, with [`Session::with_can`].
    pub fn busmap(&self) -> Option<&BusMap> {
        self.setup.can.as_ref().map(|c| &c.busmap)
    }

    /// Per link, its taxels (layout indices) in the order the input carries them: the bus
    /// map's (bus, module, slot), then the taxels no bus carries in layout order; layout order
    /// for a session without a bus map. The order `skin replay -o` writes a log's columns in.
    pub fn wire_order(&self) -> Vec<Vec<usize>> {
        let links = &self.setup.links;
        let Some(can) = &self.setup.can else {
            return links.iter().map(|l| (0..l.taxels.len()).collect()).collect();
        };
        let mut seen: Vec<Vec<bool>> = links.iter().map(|l| vec![false; l.taxels.len()]).collect();
        let mut order: Vec<Vec<usize>> = vec![Vec::new(); links.len()];
        for &(l, i) in can.layout.slots() {
            if !std::mem::replace(&mut seen[l][i], true) {
                order[l].push(i);
            }
        }
        for (l, s) in seen.iter().enumerate() {
            order[l].extend(s.iter().enumerate().filter(|(_, s)| !**s).map(|(i, _)| i));
        }
        order
    }

    /// The baselines in use, one per link (layout order): each taxel's offset and noise, in the
    /// input's units; empty until the first frames have learned them.
    pub fn baselines(&self) -> &[Baseline] {
        &self.base.baselines
    }

    /// A sink said stop ([`Flow::Break`]): the session takes no more frames.
    pub fn stopped(&self) -> bool {
        self.stopped
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

/// What names a link's force calibration in a [`Description`]: the file's name, the link and
/// the first 16 hex digits of a SHA-256 over the link's calibration (its curve, ids and gains).
fn calibration_id(path: &Path, link: &skin_core::format::force_file::LinkForce) -> String {
    use sha2::Digest;
    let bytes = serde_json::to_vec(&(&link.curve, &link.ids, &link.gains)).unwrap_or_default();
    let digest = sha2::Sha256::digest(&bytes);
    let hex: String = digest.iter().take(8).map(|b| format!("{b:02x}")).collect();
    let file = path.file_name().map_or_else(
        || path.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    format!("{file}#{} sha256:{hex}", link.name)
}

/// Hands something to the sink, unless a sink has said stop; remembers a stop.
fn send<S: Sink + ?Sized>(
    stopped: &mut bool,
    sink: &mut S,
    give: impl FnOnce(&mut S) -> Result<Flow, S::Error>,
) -> Result<(), SessionError> {
    if *stopped {
        return Ok(());
    }
    let flow = give(sink).map_err(|e| SessionError::Sink(Box::new(e)))?;
    *stopped = flow.is_break();
    Ok(())
}

/// What the session's push functions answer: go on, or stop (a sink said so).
fn flow(stopped: bool) -> Flow {
    if stopped {
        Flow::Break(())
    } else {
        Flow::Continue(())
    }
}
