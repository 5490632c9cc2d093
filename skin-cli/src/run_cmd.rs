//! `skin run`: the whole pipeline, from CAN traffic to touch decisions, offline or live. The
//! pipeline is skin-learn's `Session`; this wires its input and its sinks.

use crate::output::Inputs;
use crate::ros_out::RosArgs;
use crate::run_sinks::{RunSinks, check_cache, precheck_mcap, say_mcap, sinks, stage_mcap, still_there};
use crate::shared::LiveStep;
use crate::view_cmd::{View, ViewArgs};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use skin_can::candump::CandumpReader;
use skin_can::live::Live;
use skin_core::output::{Staged, writing};
use skin_core::text::{Gzip, Input};
use skin_learn::session::{Flow, FromConfig, Session, SessionConfig, SessionError};
use skin_ros::RosSink;
use std::fmt::Write as _;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Run the whole pipeline on a log, recording or live bus: touches and decisions.
///
/// Frames, contacts, tactile images, hand / non-hand decisions and hand parts, per link.
///
/// CONFIG is a TOML file naming the skin and the models (paths relative to it):
///
///     layout = "layout.json"          # the skin (all links of a skin-layout/1 file)
///     busmap = "busmap.toml"          # which taxel each CAN slot carries (CAN input only)
///     classifier = "handsnet.onnx"    # optional; class names and input scale from its card
///     segmenter = "handseg.onnx"      # optional: hand parts of touches classified as hands
///     image_size = "68x100"           # the models' input; default 68x100
///     cache = ".skin-cache"           # tactile maps, made on first use; default as shown
///     truth = "session.tsv"           # optional: the scripted touches, to score the run
///     [baseline]
///     frames = 20                     # untouched frames at the start that learn offsets
///                                     # and noise: a taxel reads pressure only beyond 6
///                                     # standard deviations of its idle readings (or of the
///                                     # link's 90th-percentile taxel's, when larger)
///     polarity = "rising"             # "falling" for iCub (255 = no load)
///     [touch]
///     threshold = 5.0                 # counts above the baseline (and the noise) that press
///     min_taxels = 2
///     decide_frames = 3               # frames of contact before the first decision
///     release_frames = 2              # frames without contact that end a touch
///     reclassify_growth = 1.25        # classify again when the touch grows by this factor
///     contacts = "peaks"              # split between pressure peaks; "connected": thesis 3.2
///     [touch.split]                   # the peaks rule (defaults as shown):
///     min_dip = 0.5                   # the pressure falls by half between two peaks...
///     min_distance_mm = 12            # ...at least 12 mm apart
///     [gate]                          # optional: what the robot should do
///     hand = "comply"                 # stop, comply, slow or resume
///     non_hand = "stop"
///     [stitch]                        # optional: links stitched across joints (Ch. 6)
///     poses = "poses.json"            # skin-poses/1: every link's pose over time, and/or
///     urdf = "arm.urdf"               # the robot: its joint states place the links
///                                     # (--joint-states; max_age_s = 0.5, base = link)
///
/// Per frame: CAN frames -> assembled frame (bus map) -> baseline -> contacts (connected
/// pressed taxels, split between separate pressure peaks) -> touches -> tactile image of the
/// touch at its fullest -> classifier (and segmenter for hands). A module missing from a frame
/// keeps its last readings and is reported.
///
/// With [stitch], the maps are stitched at each posture and contacts are also searched over the
/// whole chain: a contact crossing a joint gives an across_joint event, and --frames writes
/// stitched images too.
///
/// For raw recordings (--recording), CONFIG needs only `layout` (and [baseline] frames: the
/// untouched frames each recording starts with); every other key has a default.
///
/// Offline (--log): writes OUT/events.jsonl (one JSON object a line: appeared, classified,
/// released, across_joint, gate, incomplete; times in s, centroids in m in the link frame,
/// and with joint states or poses also in the chain's base frame (centroid_base), areas in
/// cm², pressures in counts; a named pipe is read as it is written), OUT/touches/*.png (the image each decision was made
/// on), with --frames OUT/frames/<link>/*.png, and OUT/summary.txt; prints the summary.
/// The output folder appears whole or not at all. Live (--can): events go to standard
/// output as they happen; Ctrl-C or --duration ends the run and prints the summary.
///
/// ROS 2 (no ROS needed): --mcap FILE also records the session as ROS 2 messages (pressure
/// clouds, decision images, contacts, events, RViz markers) in an MCAP file that `ros2 bag
/// play` and Foxglove open; --zenoh ENDPOINT publishes them live as an rmw_zenoh node does.
/// The topics and their units are in the README, "Use it from ROS 2".
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
        conflicts_with_all = ["can", "recording"],
        required_unless_present_any = ["can", "recording"]
    )]
    log: Option<PathBuf>,
    /// Offline: raw recordings (Cyskin's ids line, then index, time, counts), each through a
    /// session of its own (its first frames learn the baseline): OUT/<recording>/ holds its
    /// events.jsonl, touches/ and summary.txt, and OUT/recordings.tsv a line per recording.
    /// Needs no bus map in CONFIG.
    #[arg(long, value_name = "FILE", num_args = 1.., conflicts_with = "can")]
    recording: Vec<PathBuf>,
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
    /// Print the time spent per stage (with --view, a log's pacing counts as output).
    #[arg(long)]
    timings: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    ros: RosArgs,
    #[command(flatten)]
    view: ViewArgs,
}

pub fn run(args: Args) -> Result<()> {
    // Before the maps are built and cached: a refused folder costs nothing and writes nothing.
    if let Some(dir) = &args.output {
        crate::output::precheck_dir(dir, "skin run", args.force)?;
    }
    check_inputs(args.log.iter().chain(&args.recording))?;
    let config = SessionConfig::read(&args.config)?;
    let mut inputs = Inputs::new(
        std::iter::once(&args.config)
            .chain(&args.log)
            .chain(&args.recording),
    );
    for p in config.inputs()? {
        inputs.add(&p);
    }
    precheck_mcap(&args.ros, args.output.as_deref(), &inputs)?;
    check_cache(&config, args.output.as_deref(), args.force)?;
    if !args.recording.is_empty() {
        return recordings(&args, &config, &inputs);
    }
    let mut viewer = crate::view_cmd::bind(&args.view, &args.config)?;
    let mut session = Session::from_config(&config)?;
    for note in session.layout_notes() {
        crate::say!("{note}");
    }
    let uncovered = session.uncovered();
    if let Some((link, id)) = uncovered.first() {
        crate::say!(
            "{} layout taxel(s) are on no bus of the bus map (first: taxel {id} of link \"{link}\"): dead, they never read",
            uncovered.len()
        );
    }
    session.set_frame_images(args.frames);
    crate::view_cmd::show(viewer.as_mut(), &session, &args.config);
    let view = viewer
        .as_ref()
        .map(|v| View::new(v, args.log.is_some().then_some(args.view.speed)));
    let mut out = match &args.output {
        Some(d) => Some(crate::output::open_dir(d, "skin run", args.force, &inputs)?),
        None => None,
    };
    let ros = args
        .ros
        .open_session(&mut session, true, args.log.is_some(), &inputs)?;
    let result = sinks(out.as_ref(), args.log.is_none(), ros, view).and_then(|mut sinks| {
        let span = match &args.log {
            Some(log) => offline(&mut session, log, &mut sinks, args.quiet)?,
            None => live(&mut session, &args, &mut sinks)?,
        };
        // Every frame is processed: an interrupt from here on waits until the outputs are in
        // place, and keeps them.
        let finishing = writing();
        sinks.close_events()?;
        let mut outlets = sinks.ros.take().map(RosSink::into_outlet);
        let mcap = stage_mcap(outlets.as_mut())?;
        let summary = session.summary(span).to_string();
        crate::say!("{summary}");
        if args.timings {
            crate::say!("{}", session.timings(span));
        }
        // The folder moves into place whole (only skin run's own files are replaced), and the
        // MCAP file with it.
        let (staged, messages) = mcap.unzip();
        match out.take() {
            Some(dir) => {
                let path = dir.dir().to_owned();
                still_there(dir.path(), &path)?;
                std::fs::write(dir.path().join("summary.txt"), summary)
                    .with_context(|| format!("cannot write summary.txt in {}", path.display()))?;
                dir.commit_with(staged.into_iter().collect())?;
                crate::say!("wrote {}", path.display());
            }
            None => staged.map(Staged::commit).transpose().map(drop)?,
        }
        say_mcap(&args.ros, messages);
        crate::output::outputs_written();
        drop(finishing);
        // The network last: its drain may take seconds, and an interrupt during it loses no file.
        if let Some(rest) = outlets {
            rest.finish(args.ros.mcap_path())?;
        }
        Ok(())
    });
    // A failed run leaves the previous output as it was: the half-built folder goes with `out`.
    drop(out);
    result?;
    // Live, Ctrl-C ended the run: it ends the page too.
    crate::view_cmd::hold(viewer.as_ref().filter(|_| args.log.is_some()));
    Ok(())
}

/// Refuses, before any work, every input that cannot be read (missing, a folder, no
/// permission), all of them in one line.
fn check_inputs<'a>(paths: impl IntoIterator<Item = &'a PathBuf>) -> Result<()> {
    let paths: Vec<&PathBuf> = paths.into_iter().collect();
    let bad: Vec<String> = paths
        .iter()
        .filter_map(|p| unreadable(p).map(|why| format!("{} ({why})", p.display())))
        .collect();
    const SHOWN: usize = 10;
    let mut list = bad.iter().take(SHOWN).cloned().collect::<Vec<_>>().join(", ");
    if bad.len() > SHOWN {
        let _ = write!(list, " and {} more", bad.len() - SHOWN);
    }
    match bad.len() {
        0 => Ok(()),
        1 if paths.len() == 1 => anyhow::bail!("cannot read {list}"),
        n => anyhow::bail!(
            "cannot read {n} of the {} inputs: {list}; nothing was run",
            paths.len()
        ),
    }
}

/// Why `path` cannot be read as an input, if it cannot. A FIFO or a device is read as it comes.
fn unreadable(path: &Path) -> Option<String> {
    match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Some("no such file".into()),
        Err(e) => Some(e.to_string()),
        Ok(m) if m.is_dir() => Some("a folder, not a file".into()),
        Ok(m) if m.is_file() => File::open(path).err().map(|e| e.to_string()),
        Ok(_) => None,
    }
}

/// Offline: the log through the session, read one frame at a time (gzip-compressed logs too);
/// the progress bar follows the bytes of the file read. Returns the log's span, seconds.
fn offline(session: &mut Session, log_path: &Path, sinks: &mut RunSinks, quiet: bool) -> Result<f64> {
    let input = Input::open(log_path, Gzip::Read)?;
    let meter = input.meter();
    let style = |template: &str| {
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar())
    };
    let bar = match meter.len() {
        _ if quiet => ProgressBar::hidden(),
        Some(len) => ProgressBar::new(len).with_style(style("{bar:40} {percent}% of the log, eta {eta}")),
        // A pipe or a device: no length to go by.
        None => ProgressBar::new_spinner().with_style(style("{spinner} {bytes} of the log read")),
    };
    // A pipe (no length) is read as it is written: each frame goes through as it comes.
    let log = CandumpReader::new(input, log_path).streaming(meter.len().is_none());
    let span = session.run_log(log, log_path, sinks, &mut |_, _| bar.set_position(meter.read()));
    bar.finish_and_clear();
    Ok(span?)
}

/// Live: SocketCAN through the same session until Ctrl-C or --duration. Returns the seconds
/// it ran.
fn live(session: &mut Session, args: &Args, sinks: &mut RunSinks) -> Result<f64> {
    let started = Instant::now();
    let mut error = None;
    let busmap = session.busmap().cloned().context("the session has no bus map")?;
    crate::shared::each_live(&busmap, &args.can, args.master, args.duration, &mut |step| {
        // Interface outages go to standard error: standard output carries the events.
        match step {
            LiveStep::Item(Live::Frame(a)) => return go_on(session.push_can(a, sinks), &mut error),
            LiveStep::Item(Live::Down { interface, error }) => eprintln!("{interface}: {error}; reopening"),
            LiveStep::Item(Live::Reopened { interface }) => eprintln!("{interface}: open again"),
            LiveStep::Item(Live::Can(_)) => {}
            LiveStep::Polled(stats) => return go_on(session.note_resets(stats, sinks), &mut error),
        }
        true
    })?;
    if let Some(e) = error {
        return Err(e.into());
    }
    // The run ends here whether or not a sink asked to stop.
    let _ = session.finish(sinks)?;
    Ok(started.elapsed().as_secs_f64())
}

/// Whether the live loop goes on after a step: not when a sink asked to stop or failed (kept
/// in `error` for the caller).
fn go_on(step: Result<Flow, SessionError>, error: &mut Option<SessionError>) -> bool {
    match step {
        Ok(flow) => flow.is_continue(),
        Err(e) => {
            *error = Some(e);
            false
        }
    }
}

/// Offline, raw recordings: one session, built once (the layout, maps and models read once for
/// the whole batch) and started again for each recording, into OUT/<recording>/, and a line
/// each in OUT/recordings.tsv (frames, touches, the most separate contacts a touch had at its
/// fullest).
fn recordings(args: &Args, config: &SessionConfig, inputs: &Inputs) -> Result<()> {
    let names = crate::shared::output_names(&args.recording)?;
    let dir = args.output.as_deref().context("--recording needs -o DIR")?;
    anyhow::ensure!(
        !args.ros.any() || args.recording.len() == 1,
        "--mcap and --zenoh take one recording at a time ({} given): a session each would restart the stamps",
        args.recording.len()
    );
    let mut viewer = crate::view_cmd::bind(&args.view, &args.config)?;
    let mut session = Session::from_config(config)?;
    session.set_frame_images(args.frames);
    crate::view_cmd::show(viewer.as_mut(), &session, &args.config);
    let mut view = viewer.as_ref().map(|v| View::new(v, Some(args.view.speed)));
    let out = crate::output::open_dir(dir, "skin run", args.force, inputs)?;
    let cannot = || format!("cannot write into {}", dir.display());
    for note in session.layout_notes() {
        crate::say!("{note}");
    }
    let mut table = String::from("recording\tframes\ttouches\tmost_contacts\n");
    crate::say!("recording                       frames  touches  most contacts in a touch");
    let (mut staged, mut rest) = (None, None);
    for (k, (path, name)) in args.recording.iter().zip(&names).enumerate() {
        let mut rec = skin_core::format::recording::RecordingReader::open(path)?;
        if k > 0 {
            session = session.restarted()?;
        }
        if let Some(v) = view.as_mut() {
            v.restart();
        }
        let here = out.path().join(name);
        let shown = dir.join(name);
        {
            let _creating = writing();
            still_there(out.path(), dir)?;
            std::fs::create_dir_all(&here).with_context(cannot)?;
        }
        let ros = args.ros.open_session(&mut session, true, true, inputs)?;
        let mut sinks = RunSinks::recording(&here, &shown, ros, view.take())?;
        let span = session.run_recording(&mut rec, path, &mut sinks);
        view = sinks.view.take();
        let span = span?;
        sinks.close_events()?;
        if let Some(ros) = sinks.ros.take() {
            let mut outlets = ros.into_outlet();
            staged = stage_mcap(Some(&mut outlets))?;
            rest = Some(outlets);
        }
        let summary = session.summary(span).to_string();
        {
            let _creating = writing();
            still_there(out.path(), dir)?;
            std::fs::write(here.join("summary.txt"), &summary).with_context(cannot)?;
        }
        if !args.quiet {
            crate::say!("{summary}");
        }
        let stats = session.stats();
        let row = [rec.frames_read() as usize, stats.touches, stats.most_contacts];
        let _ = writeln!(table, "{name}\t{}\t{}\t{}", row[0], row[1], row[2]);
        crate::say!("{name:<30} {:>7}  {:>7}  {:>7}", row[0], row[1], row[2]);
    }
    // Every recording is processed: an interrupt from here on keeps the outputs.
    let finishing = writing();
    std::fs::write(out.path().join("recordings.tsv"), table).with_context(cannot)?;
    let (staged, messages) = staged.unzip();
    out.commit_with(staged.into_iter().collect())?;
    crate::say!("wrote {}", dir.display());
    say_mcap(&args.ros, messages);
    crate::output::outputs_written();
    drop(finishing);
    if let Some(rest) = rest {
        rest.finish(args.ros.mcap_path())?;
    }
    crate::view_cmd::hold(viewer.as_ref());
    Ok(())
}
