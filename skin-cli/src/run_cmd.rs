//! `skin run`: the whole pipeline, from CAN traffic to touch decisions, offline or live.

use crate::output::{Inputs, OutputDir};
use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Deserialize;
use serde_json::json;
use skin_can::candump::CandumpLog;
use skin_can::{AssembledFrame, Assembler, BusMap, LayoutFrames, Missing};
use skin_control::hri::{ClassGate, GateAction, TouchClass};
use skin_core::{Baseline, BaselineLearner, BaselineOptions, LinkSkin, Polarity, TaxelHealth};
use skin_learn::card::ModelCard;
use skin_learn::classify::Classifier;
use skin_learn::script::{Found, Script};
use skin_learn::segment::Segmenter;
use skin_learn::touch::{Decision, Footprint, TouchEvent, TouchOptions, TouchPipeline};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Run the whole pipeline on a recording or a live bus: frames, contacts, tactile images,
/// hand / non-hand decisions and hand parts, per link.
///
/// CONFIG is a TOML file naming the skin and the models (paths relative to it):
///
///     layout = "layout.json"          # the skin (all links of a skin-layout/1 file)
///     busmap = "busmap.toml"          # which taxel each CAN slot carries
///     classifier = "handsnet.onnx"    # optional; class names and input scale from its card
///     segmenter = "handseg.onnx"      # optional: hand parts of touches classified as hands
///     image_size = "68x100"           # the models' input; default 68x100
///     cache = ".skin-cache"           # tactile maps, made on first use; default as shown
///     truth = "session.tsv"           # optional: the scripted touches, to score the run
///     [baseline]
///     frames = 20                     # untouched frames at the start that learn offsets
///     polarity = "rising"             # "falling" for iCub (255 = no load)
///     [touch]
///     threshold = 5.0                 # counts above the baseline that press a taxel
///     min_taxels = 2
///     decide_frames = 3               # frames of contact before the first decision
///     release_frames = 2              # frames without contact that end a touch
///     reclassify_growth = 1.25        # classify again when the touch grows by this factor
///     [gate]                          # optional: what the robot should do
///     hand = "comply"                 # stop, comply, slow or resume
///     non_hand = "stop"
///     [stitch]                        # optional: links stitched across joints (Ch. 6)
///     poses = "poses.json"            # skin-poses/1: every link's pose over time
///
/// Per frame: CAN frames -> assembled frame (bus map) -> baseline -> contacts (connected
/// pressed taxels) -> touches -> tactile image of the touch at its fullest -> classifier (and
/// segmenter for hands). A module missing from a frame keeps its last readings and is reported.
///
/// With [stitch], the maps are stitched at each posture and contacts are also searched over the
/// whole chain: a contact crossing a joint gives an across_joint event, and --frames writes
/// stitched images too.
///
/// Offline (--log): writes OUT/events.jsonl (one JSON object a line: appeared, classified,
/// released, across_joint, gate, incomplete; times in s, centroids in m in the link frame,
/// areas in cm², pressures in counts), OUT/touches/*.png (the image each decision was made
/// on), with --frames OUT/frames/<link>/*.png, and OUT/summary.txt; prints the summary.
/// The output folder appears whole or not at all. Live (--can): events go to standard
/// output as they happen; Ctrl-C or --duration ends the run and prints the summary.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Configuration (TOML).
    #[arg(value_name = "CONFIG.toml")]
    config: PathBuf,
    /// Offline: a candump log of the skin's CAN traffic.
    #[arg(
        long,
        value_name = "LOG",
        conflicts_with = "can",
        required_unless_present = "can"
    )]
    log: Option<PathBuf>,
    /// Live: SocketCAN interfaces, comma-separated (Linux).
    #[arg(long, value_delimiter = ',', value_name = "can0,can1")]
    can: Vec<String>,
    /// Live: send the skin16 sync every 50 ms (when no other node is bus master).
    #[arg(long, requires = "can")]
    master: bool,
    /// Live: stop after this many seconds (default: at Ctrl-C).
    #[arg(long, value_name = "S", requires = "can", value_parser = crate::numbers::above(0.0, 1e7))]
    duration: Option<f64>,
    /// Output folder (offline: required; live: optional): created if missing; an existing one
    /// is written into only if it holds an earlier output of `skin run` (or with --force).
    #[arg(short, long, value_name = "DIR", required_unless_present = "can")]
    output: Option<PathBuf>,
    /// Write into an output folder that holds other files: only the files this command writes
    /// are replaced, everything else stays.
    #[arg(long)]
    force: bool,
    /// Also write the tactile image of every frame with contact.
    #[arg(long)]
    frames: bool,
    /// Print the time spent per stage.
    #[arg(long)]
    timings: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Config {
    layout: PathBuf,
    busmap: PathBuf,
    classifier: Option<PathBuf>,
    segmenter: Option<PathBuf>,
    image_size: Option<String>,
    cache: Option<PathBuf>,
    truth: Option<PathBuf>,
    #[serde(default)]
    baseline: BaselineConfig,
    #[serde(default)]
    touch: TouchConfig,
    gate: Option<ClassGate>,
    stitch: Option<StitchConfig>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StitchConfig {
    /// Link poses over time (skin-poses/1), links in the layout's order.
    poses: PathBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct BaselineConfig {
    frames: usize,
    polarity: Polarity,
}

impl Default for BaselineConfig {
    fn default() -> Self {
        BaselineConfig {
            frames: 20,
            polarity: Polarity::Rising,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct TouchConfig {
    threshold: f32,
    min_taxels: usize,
    decide_frames: usize,
    release_frames: usize,
    reclassify_growth: f32,
}

impl Default for TouchConfig {
    fn default() -> Self {
        let d = TouchOptions::default();
        TouchConfig {
            threshold: 5.0,
            min_taxels: d.min_taxels,
            decide_frames: d.decide_frames,
            release_frames: d.release_frames,
            reclassify_growth: d.reclassify_growth,
        }
    }
}

/// Everything the per-frame path needs, built once.
struct Setup {
    /// Every file the configuration names (no output may land on one).
    inputs: Vec<PathBuf>,
    config_path: PathBuf,
    links: Vec<LinkSkin>,
    busmap: BusMap,
    /// Bus-map slot -> (link, taxel index in the link).
    slots: LayoutFrames,
    pipeline: TouchPipeline,
    classes: Vec<String>,
    truth: Option<Script>,
    baseline: BaselineConfig,
    gate: Option<ClassGate>,
    /// Contacts across joints and stitched images, when the config has `[stitch]`.
    stitching: Option<crate::run_stitch::Stitching>,
    threshold: f32,
    min_taxels: usize,
}

/// A finished touch, for the summary.
struct Done {
    link: usize,
    touch: u64,
    start: f64,
    end: f64,
    peak: Footprint,
    decision: Option<Decision>,
}

/// Per-frame state: baselines, last readings, outputs.
struct Session {
    raw: Vec<Vec<f32>>,
    pressures: Vec<Vec<f32>>,
    learner: BaselineLearner,
    baselines: Vec<Baseline>,
    health: Vec<TaxelHealth>,
    events: Vec<TouchEvent>,
    open: std::collections::HashMap<u64, f64>,
    done: Vec<Done>,
    out: Output,
    t0_us: Option<u64>,
    /// Sync counter restarts reported so far.
    resets: u64,
    /// Lines for the summary about the traffic itself (skipped or odd CAN frames).
    notes: Vec<String>,
    /// Time of the latest frame, seconds from the first.
    last_time: f64,
    frames: u64,
    incomplete: u64,
    gate: Option<GateAction>,
    /// Contacts that spanned a joint (each counted once, when it began).
    across: u64,
    stage: Stages,
}

#[derive(Default)]
struct Stages {
    assemble: Duration,
    baseline: Duration,
    output: Duration,
}

/// Where events and images go.
struct Output {
    /// The output folder being built.
    dir: Option<OutputDir>,
    events: Option<std::io::BufWriter<std::fs::File>>,
    stdout: bool,
    frames: bool,
    line: String,
}

pub fn run(args: Args) -> Result<()> {
    // Before the maps are built and cached: a refused folder costs nothing and writes nothing.
    if let Some(dir) = &args.output {
        crate::output::precheck_dir(dir, "skin run", args.force)?;
    }
    let mut setup = load(&args.config)?;
    let mut inputs = Inputs::new(std::iter::once(&args.config).chain(&args.log));
    for p in &setup.inputs {
        inputs.add(p);
    }
    let output = Output::new(
        args.output.as_deref(),
        args.force,
        &inputs,
        args.log.is_none(),
        args.frames,
    )?;
    let mut session = Session::new(&setup, output)?;
    let result = match &args.log {
        Some(log) => offline(&mut setup, &mut session, log, args.quiet),
        None => live(&mut setup, &mut session, &args),
    };
    let result = result.and_then(|span| {
        let summary = summary(&setup, &session, span);
        crate::say!("{summary}");
        if args.timings {
            crate::say!("{}", timings(&setup, &session, span));
        }
        session.out.finish(&summary)
    });
    if result.is_err() {
        session.out.abandon();
    }
    result
}

/// Parses a configuration and checks its values (not the files it names): every number in its
/// range, every closed set one of its values. `config_path` names it in messages.
fn parse_config(text: &str, config_path: &Path) -> Result<(Config, (usize, usize))> {
    // toml's own message quotes the whole line at fault, whatever its length: name the line and
    // say what is wrong instead.
    let config: Config = toml::from_str(text).map_err(|e| {
        let place = e.span().map_or(String::new(), |s| {
            format!(
                " line {}:",
                text.get(..s.start).unwrap_or(text).matches('\n').count() + 1
            )
        });
        // The message names the key and the allowed values; only a huge key makes it long.
        let message = e.message().trim_end();
        let short: String = message.chars().take(200).collect();
        let cut = if short.len() < message.len() { "..." } else { "" };
        anyhow::anyhow!("{}:{place} {short}{cut}", config_path.display())
    })?;
    if !(2..=100_000).contains(&config.baseline.frames) {
        bail!(
            "{}: [baseline] frames = {}: expected 2 to 100000 untouched frames (2 at least to measure noise)",
            config_path.display(),
            config.baseline.frames
        );
    }
    let t = &config.touch;
    if !(t.threshold.is_finite() && (0.0..=1e9).contains(&t.threshold)) {
        bail!(
            "{}: [touch] threshold = {}: expected counts from 0 to 1e9",
            config_path.display(),
            t.threshold
        );
    }
    if !(t.reclassify_growth.is_finite() && (1.0..=1e6).contains(&t.reclassify_growth)) {
        bail!(
            "{}: [touch] reclassify_growth = {}: expected a factor from 1 to 1e6",
            config_path.display(),
            t.reclassify_growth
        );
    }
    for (field, v, lo) in [
        ("min_taxels", t.min_taxels, 1),
        ("decide_frames", t.decide_frames, 1),
        ("release_frames", t.release_frames, 1),
    ] {
        if !(lo..=1_000_000).contains(&v) {
            bail!(
                "{}: [touch] {field} = {v}: expected {lo} to 1000000",
                config_path.display()
            );
        }
    }
    let size = match &config.image_size {
        Some(s) => crate::numbers::image_size(s)
            .map_err(|e| anyhow::anyhow!("{}: image_size: {e}", config_path.display()))?,
        None => (68, 100),
    };

    Ok((config, size))
}

/// Reads and checks the configuration and everything it names; builds the maps and models.
fn load(config_path: &Path) -> Result<Setup> {
    let text = std::fs::read_to_string(config_path)
        .with_context(|| format!("cannot read {}", config_path.display()))?;
    let (config, size) = parse_config(&text, config_path)?;
    let t = &config.touch;
    let base = config_path.parent().unwrap_or(Path::new("."));
    let resolve = |field: &str, p: &Path| -> Result<PathBuf> {
        let full = base.join(p);
        if !full.is_file() {
            bail!(
                "{}: {field} = \"{}\": no such file ({})",
                config_path.display(),
                p.display(),
                full.display()
            );
        }
        Ok(full)
    };
    let layout_path = resolve("layout", &config.layout)?;
    let busmap_path = resolve("busmap", &config.busmap)?;
    let classifier_path = config
        .classifier
        .as_deref()
        .map(|p| resolve("classifier", p))
        .transpose()?;
    let segmenter_path = config
        .segmenter
        .as_deref()
        .map(|p| resolve("segmenter", p))
        .transpose()?;
    let truth_path = config.truth.as_deref().map(|p| resolve("truth", p)).transpose()?;
    let poses_path = config
        .stitch
        .as_ref()
        .map(|s| resolve("[stitch] poses", &s.poses))
        .transpose()?;
    let links = crate::shared::load_links(&layout_path)?;
    let busmap = BusMap::read(&busmap_path)?;
    let ids: Vec<Vec<_>> = links.iter().map(LinkSkin::ids).collect();
    let slots = LayoutFrames::new(&busmap, &ids, Missing::HoldLast).map_err(|e| match e {
        skin_can::Error::NotInLayout { taxel } => anyhow::anyhow!(
            "{}: taxel {taxel} is not in the layout {}; is the bus map for this skin?",
            busmap_path.display(),
            layout_path.display()
        ),
        e => e.into(),
    })?;

    let layout_bytes =
        std::fs::read(&layout_path).with_context(|| format!("cannot read {}", layout_path.display()))?;
    let cache = skin_geom::MapCache::new(
        base.join(
            config
                .cache
                .clone()
                .unwrap_or_else(|| PathBuf::from(".skin-cache")),
        ),
    );
    // Frames reach the pipeline in layout order: the cache gives maps that keep it.
    let maps = links
        .iter()
        .map(|l| {
            cache
                .map(&layout_bytes, l, &skin_geom::FlattenOptions::default())
                .map(|(map, _)| map)
                .with_context(|| format!("{}: link {}", layout_path.display(), l.name))
        })
        .collect::<Result<Vec<_>>>()?;
    let stitching = match &poses_path {
        Some(p) => Some(crate::run_stitch::Stitching::new(p, &layout_path, &maps)?),
        None => None,
    };

    let mut classes = vec!["hand".to_string(), "non_hand".to_string()];
    let classifier = match &classifier_path {
        Some(p) => {
            let net = Classifier::load(p, crate::shared::input_scale(p, None))?;
            check_size(p, net.input_size(), size, config_path)?;
            if let Some(card) = ModelCard::for_model(p).filter(|c| c.classes.len() == net.classes()) {
                classes = card.classes;
            } else if net.classes() != 2 {
                bail!(
                    "{}: {} classes and no model card naming them ({})",
                    p.display(),
                    net.classes(),
                    ModelCard::path_for(p).display()
                );
            }
            Some((net, p.clone()))
        }
        None => None,
    };
    let segmenter = match &segmenter_path {
        Some(p) => {
            let net = Segmenter::load(p, crate::shared::input_scale(p, None))?;
            check_size(p, net.input_size(), size, config_path)?;
            Some((net, p.clone()))
        }
        None => None,
    };
    let options = TouchOptions {
        threshold: t.threshold,
        min_taxels: t.min_taxels,
        decide_frames: t.decide_frames,
        release_frames: t.release_frames,
        reclassify_growth: t.reclassify_growth,
        classes: classes.clone(),
        ..TouchOptions::default()
    };
    let pipeline = TouchPipeline::new(maps, classifier, segmenter, options)?;
    let truth = truth_path.as_deref().map(Script::read).transpose()?;
    let inputs = [Some(&layout_path), Some(&busmap_path)]
        .into_iter()
        .chain([&classifier_path, &segmenter_path, &truth_path, &poses_path].map(Option::as_ref))
        .flatten()
        .cloned()
        .collect();
    Ok(Setup {
        inputs,
        config_path: config_path.to_owned(),
        links,
        busmap,
        slots,
        pipeline,
        classes,
        truth,
        baseline: BaselineConfig {
            frames: config.baseline.frames,
            polarity: config.baseline.polarity,
        },
        gate: config.gate,
        stitching,
        threshold: t.threshold,
        min_taxels: t.min_taxels,
    })
}

fn check_size(model: &Path, got: (usize, usize), want: (usize, usize), config: &Path) -> Result<()> {
    if got != want {
        bail!(
            "{}: takes {} x {} images; {} makes {} x {} (image_size): a model for another image size",
            model.display(),
            got.0,
            got.1,
            config.display(),
            want.0,
            want.1
        );
    }
    Ok(())
}

/// Offline: the log through the assembler and the pipeline. Returns the log's span, seconds.
fn offline(setup: &mut Setup, session: &mut Session, log_path: &Path, quiet: bool) -> Result<f64> {
    let log = CandumpLog::read(log_path)?;
    let on_map: Vec<&str> = setup.busmap.buses.iter().map(|b| b.interface.as_str()).collect();
    if !on_map.iter().any(|i| log.interfaces.iter().any(|l| l == i)) {
        bail!(
            "{}: none of the bus map's interfaces ({}) is in the log (it has {}); is it a log of this skin?",
            log_path.display(),
            on_map.join(", "),
            log.interfaces.join(", ")
        );
    }
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(log.frames.len() as u64).with_style(
            ProgressStyle::with_template("{bar:40} {percent}% of the CAN frames, eta {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    };
    let mut assembler = Assembler::for_map(&setup.busmap, &log.interfaces, skin_can::DEFAULT_WINDOW_US);
    let mut error: Option<anyhow::Error> = None;
    let started = Instant::now();
    let mut inside = Duration::ZERO;
    for (k, frame) in log.frames.iter().enumerate() {
        assembler.push(frame, &mut |a| {
            if error.is_none() {
                let t = Instant::now();
                if let Err(e) = session.frame(setup, a) {
                    error = Some(e);
                }
                inside += t.elapsed();
            }
        });
        if error.is_none()
            && assembler.stats().counter_resets > session.resets
            && let Some(reset) = assembler.stats().last_reset
            && let Err(e) = session.counter_reset(setup, &reset)
        {
            error = Some(e);
        }
        if error.is_some() {
            break;
        }
        if k % 4096 == 0 {
            bar.set_position(k as u64);
        }
    }
    assembler.finish(&mut |a| {
        if error.is_none()
            && let Err(e) = session.frame(setup, a)
        {
            error = Some(e);
        }
    });
    bar.finish_and_clear();
    session.stage.assemble += started.elapsed().saturating_sub(inside);
    if let Some(e) = error {
        return Err(e);
    }
    let s = assembler.stats();
    session.notes.clear();
    for (n, what) in [
        (log.error_frames as u64, "CAN error frames in the log, skipped"),
        (s.remote, "remote requests, skipped"),
        (
            s.time_backwards,
            "CAN frames stamped earlier than the frame before them on their interface (kept in log order)",
        ),
    ] {
        if n > 0 {
            session.notes.push(format!("{n} {what}"));
        }
    }
    let data = s.frames
        * setup
            .busmap
            .buses
            .iter()
            .map(|b| b.modules.len() as u64)
            .sum::<u64>();
    if s.frames == 0 || s.unknown_module > data.max(1) {
        let malformed: u64 = s.malformed.iter().map(|(_, n)| n).sum();
        bail!(
            "{}: {} skin frames from {} CAN frames ({} from modules the bus map lacks, {malformed} malformed for {}, {} not skin data); is it a log of this skin and bus map?",
            log_path.display(),
            s.frames,
            log.frames.len(),
            s.unknown_module,
            setup.busmap.format.name(),
            s.ignored
        );
    }
    session.end(setup)?;
    let span = match (log.frames.first(), log.frames.last()) {
        (Some(a), Some(b)) => b.time_us.saturating_sub(a.time_us) as f64 * 1e-6,
        _ => 0.0,
    };
    Ok(span)
}

/// Live: SocketCAN through the same per-frame path until Ctrl-C or --duration.
fn live(setup: &mut Setup, session: &mut Session, args: &Args) -> Result<f64> {
    let started = Instant::now();
    let mut error: Option<anyhow::Error> = None;
    let busmap = setup.busmap.clone();
    crate::live_cmd::run_frames(&busmap, &args.can, args.master, args.duration, &mut |a| {
        if error.is_none()
            && let Err(e) = session.frame(setup, a)
        {
            error = Some(e);
        }
        error.is_none()
    })?;
    if let Some(e) = error {
        return Err(e);
    }
    session.end(setup)?;
    Ok(started.elapsed().as_secs_f64())
}

impl Output {
    fn new(dir: Option<&Path>, force: bool, inputs: &Inputs, live: bool, frames: bool) -> Result<Output> {
        let dir = match dir {
            Some(d) => {
                let out = crate::output::open_dir(d, "skin run", force, inputs)?;
                std::fs::create_dir(out.path().join("touches"))
                    .with_context(|| format!("cannot write into {}", d.display()))?;
                Some(out)
            }
            None => None,
        };
        let events = match &dir {
            Some(out) => {
                let file = std::fs::File::create(out.path().join("events.jsonl"))
                    .with_context(|| format!("cannot write events.jsonl in {}", out.dir().display()))?;
                Some(std::io::BufWriter::new(file))
            }
            None => None,
        };
        Ok(Output {
            dir,
            events,
            stdout: live,
            frames,
            line: String::with_capacity(256),
        })
    }

    fn event(&mut self, value: &serde_json::Value) -> Result<()> {
        self.line.clear();
        let _ = write!(self.line, "{value}");
        self.line.push('\n');
        if let Some(out) = &mut self.events {
            out.write_all(self.line.as_bytes())
                .context("cannot write events.jsonl")?;
        }
        if self.stdout {
            let _ = std::io::stdout().write_all(self.line.as_bytes());
        }
        Ok(())
    }

    fn png(&self, relative: &str, grey: &[u8], (rows, cols): (usize, usize)) -> Result<()> {
        let Some(out) = &self.dir else {
            return Ok(());
        };
        let path = out.path().join(relative);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("cannot write into {}", out.dir().display()))?;
        }
        skin_geom::write_png(&path, grey, rows, cols)
            .with_context(|| format!("cannot write {relative} in {}", out.dir().display()))
    }

    /// Moves the finished folder into place (only skin run's own files are replaced).
    fn finish(&mut self, summary: &str) -> Result<()> {
        if let Some(mut events) = self.events.take() {
            events.flush().context("cannot write events.jsonl")?;
        }
        if let Some(out) = self.dir.take() {
            let dir = out.dir().to_owned();
            std::fs::write(out.path().join("summary.txt"), summary)
                .with_context(|| format!("cannot write summary.txt in {}", dir.display()))?;
            out.commit()?;
            crate::say!("wrote {}", dir.display());
        }
        Ok(())
    }

    /// Removes the half-written output of a failed run (the previous output stays).
    fn abandon(&mut self) {
        self.events = None;
        self.dir = None;
    }
}

impl Session {
    fn new(setup: &Setup, out: Output) -> Result<Session> {
        let n = |l: &LinkSkin| l.taxels.len();
        let sizes: Vec<usize> = setup.links.iter().map(n).collect();
        let options = BaselineOptions {
            polarity: setup.baseline.polarity,
            ..BaselineOptions::default()
        };
        Ok(Session {
            raw: setup.links.iter().map(|l| vec![0.0; n(l)]).collect(),
            pressures: setup.links.iter().map(|l| vec![0.0; n(l)]).collect(),
            learner: BaselineLearner::new(&sizes, setup.baseline.frames, options)?,
            baselines: Vec::new(),
            health: Vec::new(),
            events: Vec::new(),
            open: std::collections::HashMap::new(),
            done: Vec::new(),
            out,
            t0_us: None,
            resets: 0,
            notes: Vec::new(),
            last_time: 0.0,
            frames: 0,
            incomplete: 0,
            gate: None,
            across: 0,
            stage: Stages::default(),
        })
    }

    /// One assembled frame through the whole path.
    fn frame(&mut self, setup: &mut Setup, a: &AssembledFrame) -> Result<()> {
        let t0 = *self.t0_us.get_or_insert(a.time_us);
        let time = a.time_us.saturating_sub(t0) as f64 * 1e-6;
        let started = Instant::now();
        self.frames += 1;
        self.last_time = time;
        // A missing module keeps its last readings (reported below), so a lost CAN frame does
        // not look like a release.
        setup.slots.place(a, &mut self.raw)?;
        if !a.is_complete() {
            self.incomplete += 1;
            let missing: Vec<_> = a
                .missing
                .iter()
                .map(|m| json!({"bus": setup.busmap.buses[usize::from(m.bus)].interface, "address": m.address}))
                .collect();
            self.out
                .event(&json!({"event": "incomplete", "time": round(time, 3), "missing": missing}))?;
        }
        if self.baselines.is_empty() {
            if !a.is_complete() {
                return Ok(());
            }
            self.learner.push(&self.raw)?;
            if self.learner.is_done() {
                for (b, health) in self.learner.finish(&setup.config_path)? {
                    self.baselines.push(b);
                    self.health.push(health);
                }
            }
            self.stage.baseline += started.elapsed();
            return Ok(());
        }
        for ((b, raw), p) in self.baselines.iter_mut().zip(&self.raw).zip(&mut self.pressures) {
            b.apply(raw, p)
                .map_err(|e| anyhow::anyhow!("frame at {time:.3} s: {e}"))?;
        }
        self.stage.baseline += started.elapsed();
        self.events.clear();
        setup.pipeline.process(time, &self.pressures, &mut self.events)?;
        let t = Instant::now();
        self.emit(setup)?;
        if self.out.frames {
            for (l, p) in self.pressures.iter().enumerate() {
                if setup.pipeline.touching(l) {
                    let name = &setup.links[l].name;
                    let (grey, size) = setup.pipeline.frame_image(l, p)?;
                    self.out
                        .png(&format!("frames/{name}/frame_{:05}.png", a.cycle), grey, size)?;
                }
            }
        }
        self.across_joints(setup, time, a.cycle)?;
        self.stage.output += t.elapsed();
        Ok(())
    }

    /// Contacts across joints (an event when one begins and when none is left) and stitched
    /// images, when the config stitches the links.
    fn across_joints(&mut self, setup: &mut Setup, time: f64, cycle: u64) -> Result<()> {
        let Some(st) = &mut setup.stitching else {
            return Ok(());
        };
        let spans = st.spanning(&self.pressures, setup.threshold, time, setup.min_taxels)?;
        if !spans.is_empty() && !st.joined {
            self.across += 1;
            for s in &spans {
                let links: Vec<&str> = s.links.iter().map(|&l| setup.links[l].name.as_str()).collect();
                self.out.event(&json!({
                    "event": "across_joint",
                    "time": round(time, 3),
                    "links": links,
                    "taxels": s.taxels,
                    "centroid": s.centroid.map(|x| round(x, 4)),
                }))?;
            }
        } else if spans.is_empty() && st.joined {
            self.out
                .event(&json!({"event": "across_joint_end", "time": round(time, 3)}))?;
        }
        st.joined = !spans.is_empty();
        if self.out.frames && (0..setup.links.len()).any(|l| setup.pipeline.touching(l)) {
            let (grey, size) = st.image()?;
            self.out
                .png(&format!("frames/stitched/frame_{cycle:05}.png"), grey, size)?;
        }
        Ok(())
    }

    /// Reports a sync counter that restarted: an event, and a line in the summary.
    fn counter_reset(&mut self, setup: &Setup, r: &skin_can::CounterReset) -> Result<()> {
        self.resets += 1;
        let t0 = self.t0_us.unwrap_or(r.time_us);
        let time = r.time_us.saturating_sub(t0) as f64 * 1e-6;
        let bus = setup
            .busmap
            .buses
            .get(usize::from(r.bus))
            .map_or("?", |b| b.interface.as_str());
        self.out.event(&json!({
            "event": "counter_reset",
            "time": round(time, 3),
            "bus": bus,
            "from": r.from,
            "to": r.to,
            "cycle": r.cycle,
        }))
    }

    /// Writes the pipeline's events.
    fn emit(&mut self, setup: &Setup) -> Result<()> {
        let events = std::mem::take(&mut self.events);
        for e in &events {
            let link_name = |l: usize| setup.links[l].name.as_str();
            match e {
                TouchEvent::Appeared {
                    link,
                    touch,
                    time,
                    footprint,
                } => {
                    self.open.insert(*touch, *time);
                    let mut v = footprint_json(footprint);
                    v["event"] = json!("appeared");
                    v["time"] = json!(round(*time, 3));
                    v["link"] = json!(link_name(*link));
                    v["touch"] = json!(touch);
                    self.out.event(&v)?;
                }
                TouchEvent::Classified {
                    link,
                    touch,
                    time,
                    decision,
                    revised,
                } => {
                    let mut v = decision_json(decision, &setup.classes);
                    v["event"] = json!("classified");
                    v["time"] = json!(round(*time, 3));
                    v["link"] = json!(link_name(*link));
                    v["touch"] = json!(touch);
                    v["revised"] = json!(revised);
                    if let Some((grey, size)) = setup.pipeline.last_image(*link) {
                        self.out.png(
                            &format!(
                                "touches/touch_{touch:03}_{}.png",
                                class_name(&setup.classes, decision.class)
                            ),
                            grey,
                            size,
                        )?;
                    }
                    self.out.event(&v)?;
                }
                TouchEvent::Released {
                    link,
                    touch,
                    time,
                    duration,
                    frames,
                    peak,
                    decision,
                } => {
                    let start = self.open.remove(touch).unwrap_or(*time - *duration);
                    let mut v = json!({
                        "event": "released",
                        "time": round(*time, 3),
                        "link": link_name(*link),
                        "touch": touch,
                        "duration": round(*duration, 3),
                        "frames": frames,
                        "peak": footprint_json(peak),
                    });
                    if let Some(d) = decision {
                        v["class"] = json!(class_name(&setup.classes, d.class));
                        v["probability"] = json!(round(f64::from(d.probability), 4));
                    }
                    self.out.event(&v)?;
                    self.done.push(Done {
                        link: *link,
                        touch: *touch,
                        start,
                        end: *time,
                        peak: *peak,
                        decision: decision.clone(),
                    });
                }
            }
            if let TouchEvent::Classified { time, .. } | TouchEvent::Released { time, .. } = e {
                self.update_gate(setup, *time)?;
            }
        }
        self.events = events;
        Ok(())
    }

    /// The gate: the action of the most severe touch in progress ("stop" before anything).
    fn update_gate(&mut self, setup: &Setup, time: f64) -> Result<()> {
        let Some(gate) = &setup.gate else {
            return Ok(());
        };
        let action = gate.decide(
            setup
                .pipeline
                .open_classes()
                .map(|class| TouchClass::from_name(class_name(&setup.classes, class))),
        );
        if self.gate != Some(action) {
            self.out
                .event(&json!({"event": "gate", "time": round(time, 3), "action": action.name()}))?;
            self.gate = Some(action);
        }
        Ok(())
    }

    /// The end of the input: open touches are released.
    fn end(&mut self, setup: &mut Setup) -> Result<()> {
        if self.baselines.is_empty() {
            bail!(
                "the input ended after {} frame(s), before the {} complete untouched frames the baseline needs",
                self.frames,
                setup.baseline.frames
            );
        }
        self.events.clear();
        setup.pipeline.finish(self.last_time, &mut self.events)?;
        self.emit(setup)
    }
}

fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

fn class_name(classes: &[String], k: usize) -> &str {
    classes.get(k).map_or("?", String::as_str)
}

fn footprint_json(f: &Footprint) -> serde_json::Value {
    json!({
        "contacts": f.contacts,
        "taxels": f.taxels,
        "area_cm2": round(f.area_cm2, 2),
        "mean_pressure": round(f64::from(f.mean_pressure), 1),
        "centroid": [round(f.centroid.x, 4), round(f.centroid.y, 4), round(f.centroid.z, 4)],
    })
}

fn decision_json(d: &Decision, classes: &[String]) -> serde_json::Value {
    let mut v = json!({
        "class": class_name(classes, d.class),
        "probability": round(f64::from(d.probability), 4),
    });
    if !d.parts.is_empty() {
        v["parts"] = d
            .parts
            .iter()
            .map(|p| {
                let mut o = json!({
                    "part": p.part.name(),
                    "taxels": p.taxels,
                    "mean_pressure": round(f64::from(p.mean_pressure), 1),
                });
                if let Some(c) = p.centroid {
                    o["centroid"] = json!([round(c.x, 4), round(c.y, 4), round(c.z, 4)]);
                }
                o
            })
            .collect();
    }
    v
}

/// The summary: the run, the touches, and the score against the script.
fn summary(setup: &Setup, s: &Session, span: f64) -> String {
    let mut out = String::new();
    let taxels: usize = setup.links.iter().map(|l| l.taxels.len()).sum();
    let _ = writeln!(
        out,
        "{} frames ({} incomplete) of {} taxels on {} link(s) over {:.2} s; baseline from the first {} frames",
        s.frames,
        s.incomplete,
        taxels,
        setup.links.len(),
        span,
        setup.baseline.frames
    );
    if s.resets > 0 {
        let _ = writeln!(
            out,
            "sync counter restarted {} time(s) (recordings joined or a hub reset): the frames after it are kept, numbered on by time (\"counter_reset\" events)",
            s.resets
        );
    }
    for note in &s.notes {
        let _ = writeln!(out, "{note}");
    }
    for (l, h) in s.health.iter().enumerate() {
        if !h.dead.is_empty() || !h.stuck.is_empty() {
            let ids = |v: &[usize]| {
                v.iter()
                    .map(|&i| setup.links[l].taxels[i].id.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let _ = writeln!(
                out,
                "link {}: taxels that cannot be trusted: dead [{}], stuck [{}]",
                setup.links[l].name,
                ids(&h.dead),
                ids(&h.stuck)
            );
        }
    }
    if setup.stitching.is_some() {
        let _ = writeln!(out, "contacts across joints (stitched maps): {}", s.across);
    }
    // Each scripted touch's detected touch: the one overlapping it the longest.
    let found: Vec<Found> = s
        .done
        .iter()
        .map(|d| Found {
            start_s: d.start,
            end_s: d.end,
            class: d
                .decision
                .as_ref()
                .map(|dec| class_name(&setup.classes, dec.class)),
        })
        .collect();
    let score = setup.truth.as_ref().map(|script| script.score(&found));
    let scripted: Vec<String> = (0..s.done.len())
        .map(|j| match (&setup.truth, &score) {
            (Some(script), Some(score)) => score.scripted_of(j).map_or(String::new(), |k| {
                let t = &script.touches[k];
                format!("{} {}", t.class, t.kind)
            }),
            _ => String::new(),
        })
        .collect();
    let _ = writeln!(out, "{} touch(es):", s.done.len());
    let _ = writeln!(
        out,
        "  touch  link        start s   end s  class        prob  taxels  area cm2  mean  {}parts",
        if setup.truth.is_some() {
            "script               "
        } else {
            ""
        }
    );
    for (d, script) in s.done.iter().zip(&scripted) {
        let (class, prob, parts) = match &d.decision {
            Some(dec) => (
                class_name(&setup.classes, dec.class).to_string(),
                format!("{:.3}", dec.probability),
                dec.parts
                    .iter()
                    .map(|p| format!("{} {}", p.part.name(), p.taxels))
                    .collect::<Vec<_>>()
                    .join(", "),
            ),
            None => ("-".into(), "-".into(), String::new()),
        };
        let script = if setup.truth.is_some() {
            format!(
                "{:<21}",
                if script.is_empty() {
                    "(not scripted)"
                } else {
                    script
                }
            )
        } else {
            String::new()
        };
        let row = format!(
            "  {:>5}  {:<10} {:>7.2} {:>7.2}  {:<10} {:>6}  {:>6}  {:>8.1}  {:>4.0}  {script}{parts}",
            d.touch,
            setup.links[d.link].name,
            d.start,
            d.end,
            class,
            prob,
            d.peak.taxels,
            d.peak.area_cm2,
            d.peak.mean_pressure,
        );
        let _ = writeln!(out, "{}", row.trim_end());
    }
    if let (Some(script), Some(score)) = (&setup.truth, &score) {
        let _ = writeln!(
            out,
            "script: {} of {} scripted touches found, {} with the right class ({:.1}%); {} touch(es) not in the script",
            score.found(),
            script.touches.len(),
            score.right(),
            100.0 * score.right() as f64 / script.touches.len().max(1) as f64,
            score.extra(&found)
        );
        for (k, (t, m)) in script.touches.iter().zip(&score.matches).enumerate() {
            match m {
                Some(j) if !score.correct[k] => {
                    let got = found[*j].class.unwrap_or("-");
                    let _ = writeln!(
                        out,
                        "  scripted touch {k} ({} {}) taken for {got}",
                        t.class, t.kind
                    );
                }
                Some(_) => {}
                None => {
                    let _ = writeln!(out, "  scripted touch {k} ({} {}) not found", t.class, t.kind);
                }
            }
        }
    }
    out.trim_end().to_string()
}

/// The per-stage timing report.
fn timings(setup: &Setup, s: &Session, span: f64) -> String {
    let t = setup.pipeline.times();
    let frames = t.frames.max(1) as f64;
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    let wall = s.stage.assemble + s.stage.baseline + t.total + s.stage.output;
    let mut out = String::from("time per frame (mean over all frames), stage by stage:\n");
    let rows = [
        ("CAN decode + assembly", s.stage.assemble),
        ("baseline", s.stage.baseline),
        ("contacts", t.contacts),
        ("tactile images", t.image),
        ("classifier", t.classify),
        ("segmenter + parts", t.segment),
        ("events and images out", s.stage.output),
    ];
    for (name, d) in rows {
        let _ = writeln!(out, "  {name:<24} {:>9.1} us", us(d) / frames);
    }
    let _ = writeln!(
        out,
        "  {:<24} {:>9.1} us  (slowest frame of the pipeline: {:.2} ms; {} classifier and {} segmenter runs)",
        "all",
        us(wall) / frames,
        t.worst_frame.as_secs_f64() * 1e3,
        t.runs.0,
        t.runs.1
    );
    if span > 0.0 && wall > Duration::ZERO {
        let _ = write!(
            out,
            "  {:.0}x real time ({span:.2} s of input in {:.3} s)",
            span / wall.as_secs_f64(),
            wall.as_secs_f64()
        );
    }
    out.trim_end().to_string()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::panic)]
    use super::*;
    use crate::mutate::{arbitrary_text, config, mutated};
    use proptest::prelude::*;

    const SESSION: &str = include_str!("../../fixtures/session/run.toml");

    #[test]
    fn the_fixture_configuration_parses() {
        let (config, size) = parse_config(SESSION, Path::new("run.toml")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((config.baseline.frames, size), (20, (68, 100)));
    }

    #[test]
    fn a_bad_line_is_named_not_echoed() {
        let text = format!("{SESSION}\ncolour = \"{}\"\n", "x".repeat(1_000_000));
        let e = parse_config(&text, Path::new("run.toml"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            e.contains("line 24") && e.contains("colour") && e.len() < 300,
            "{}",
            &e[..e.len().min(400)]
        );
    }

    proptest! {
        #![proptest_config(config())]

        /// Hostile edits of the fixture configuration and arbitrary text: an error or values in
        /// their documented ranges, never a panic, and never a message that echoes a long line.
        #[test]
        fn configurations_are_parsed_or_refused(text in prop_oneof![mutated(SESSION), arbitrary_text()]) {
            match parse_config(&text, Path::new("run.toml")) {
                Ok((c, (rows, cols))) => {
                    prop_assert!((2..=100_000).contains(&c.baseline.frames));
                    prop_assert!(c.touch.threshold.is_finite() && c.touch.reclassify_growth >= 1.0);
                    let side = 1..=crate::numbers::MAX_SIDE as usize;
                    prop_assert!(side.contains(&rows) && side.contains(&cols));
                }
                Err(e) => prop_assert!(e.to_string().len() < 600, "{e}"),
            }
        }
    }
}
