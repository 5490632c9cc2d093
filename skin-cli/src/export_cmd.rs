//! `skin export`: sessions as a dataset (LeRobot v3 layout, Parquet): skin-dataset's
//! `export_files`, wired to the command line.

use anyhow::{Result, bail};
use skin_dataset::{DatasetOptions, export_files};
use skin_learn::session::{FromConfig, Session, SessionConfig};
use std::path::PathBuf;

/// Export candump logs or raw recordings as a dataset (LeRobot v3 layout, Parquet).
///
/// One episode per input, each through a session of its own (CONFIG, as for `skin run`: its
/// baseline learned from the input's first frames, its models deciding its touches):
///
///     skin export session.candump.log --config run.toml -o dataset
///     skin export day2/*.log.gz --config run.toml -o dataset --append
///
/// DATASET/data/chunk-000/file-NNN.parquet: a row per frame, `timestamp` (s from the episode's
/// first frame), `frame_index`, `episode_index`, `index`, `task_index`, `time_us` (the input's
/// stamp, µs), `cycle`, `complete`, and `observation.tactile.<link>`: the link's readings as
/// float32, counts as the skin sent them (no baseline subtracted), in the bus map's order (a
/// recording's: the layout's), one file per episode.
/// DATASET/events/...: a row per event (kind, link, touch, its JSON whole); DATASET/contacts/...:
/// a row per contact per frame (centroid in m, link frame; pressures in counts above the
/// baseline). DATASET/meta/info.json: features, fps (measured from the first input's stamps,
/// or --fps), and under "skin" every taxel's id, position and normal; meta/episodes/...: each
/// episode's source, SHA-256 and baseline (offsets, noise).
///
/// Read back with pyarrow, HF datasets (`load_dataset("parquet", data_files=
/// "DATASET/data/*/*.parquet")`), Ray (`ray.data.read_parquet("DATASET/data")`) or LeRobot.
/// The dataset appears whole or not at all; --append adds episodes to a dataset of the same
/// skin and frame rate. The inputs of one dataset are all logs or all recordings (their readings
/// come in different orders). An input that fails is named and left out, the others are
/// written, and the command exits with status 1.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Candump logs or raw recordings, gzip-compressed or not; an episode each, in this order.
    #[arg(value_name = "INPUT", required = true, num_args = 1..)]
    inputs: Vec<PathBuf>,
    /// The session's configuration (as for `skin run`).
    #[arg(long, value_name = "CONFIG.toml")]
    config: PathBuf,
    /// The dataset's folder: created; an existing dataset is refused unless --append.
    #[arg(short, long, value_name = "DATASET")]
    output: PathBuf,
    /// Add the episodes to the dataset at DATASET (same skin, same frame rate).
    #[arg(long)]
    append: bool,
    /// What was being done (LeRobot's task of each episode).
    #[arg(long, default_value = "skin session", value_name = "TEXT")]
    task: String,
    /// `robot_type` in meta/info.json.
    #[arg(long, value_name = "NAME")]
    robot_type: Option<String>,
    /// Frames per second (default: measured from the first input's stamps).
    #[arg(long, value_name = "HZ", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    fps: Option<u32>,
}

pub fn run(args: Args) -> Result<()> {
    let config = SessionConfig::read(&args.config)?;
    let options = DatasetOptions {
        task: args.task,
        robot_type: args.robot_type,
        fps: args.fps,
        append: args.append,
    };
    let export = export_files(
        &args.inputs,
        &mut || Session::from_config(&config),
        &args.output,
        options,
    )?;
    if let Some(s) = &export.summary {
        for e in &s.added {
            crate::say!(
                "episode {}: {}: {} frames ({} incomplete), {} events, {} contacts -> {}",
                e.episode,
                e.source.display(),
                e.frames,
                e.incomplete,
                e.events,
                e.contacts,
                e.data_file
            );
        }
        crate::say!(
            "{}: {} episode(s), {} frames at {} Hz",
            s.root.display(),
            s.episodes,
            s.frames,
            s.fps
        );
    }
    // Each error names its input.
    for (_, error) in &export.failed {
        eprintln!("error: left out: {error}");
    }
    if !export.failed.is_empty() {
        bail!(
            "{} of {} input(s) could not be exported{}",
            export.failed.len(),
            args.inputs.len(),
            if export.summary.is_some() {
                " (the others were)"
            } else {
                "; nothing was written"
            }
        );
    }
    Ok(())
}
