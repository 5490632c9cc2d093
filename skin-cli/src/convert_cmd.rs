//! `skin convert`: a recording into ROS 2 messages (an MCAP file), without the models.

use crate::output::Inputs;
use crate::ros_out::RosArgs;
use anyhow::{Context, Result};
use skin_can::Traffic;
use skin_learn::session::{FromConfig, Session, SessionConfig};
use std::path::PathBuf;

/// Convert a candump log or a raw recording into ROS 2 messages, without the models.
///
/// Offline: each link's pressures (PointCloud2, every frame after the baseline), the contacts
/// (skin_msgs/Contacts and RViz arrows) and the touch events (appeared, released, incomplete:
/// no decisions without a classifier). `skin run --mcap` gives the same with the decisions.
///
///     skin convert session.candump.log --config run.toml --mcap session.mcap
///     skin convert sample_19.txt --config real.toml --mcap sample_19.mcap
///
/// CONFIG is `skin run`'s (its models, gate and truth are not used): `layout`, `busmap` for a
/// candump log, [baseline] and [touch]. The MCAP file appears only when complete; an existing
/// file there is replaced only if it is an MCAP file. Topics and units: README, "Use it from
/// ROS 2".
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// A candump log of the skin's CAN traffic, or a raw recording (Cyskin's ids line, then
    /// index, time, counts); of any length, gzip-compressed or not, read as it goes.
    #[arg(value_name = "LOG|RECORDING")]
    input: PathBuf,
    /// The session's configuration (as for `skin run`).
    #[arg(long, value_name = "CONFIG.toml")]
    config: PathBuf,
    #[command(flatten)]
    ros: RosArgs,
}

pub fn run(args: Args) -> Result<()> {
    anyhow::ensure!(
        args.ros.any(),
        "nothing to write: give --mcap FILE (or --zenoh ENDPOINT to publish live)"
    );
    let mut config = SessionConfig::read(&args.config)?;
    let mut inputs = Inputs::new([&args.config, &args.input]);
    for p in config.inputs()? {
        inputs.add(&p);
    }
    args.ros.precheck(&inputs)?;
    config.classifier = None;
    config.segmenter = None;
    config.gate = None;
    config.truth = None;
    // One pass over the input, whatever its length: its first line tells a log from a
    // recording, then the same stream is read one frame at a time.
    let input = Traffic::open(&args.input)?;
    let mut session = Session::from_config(&config)?;
    for note in session.layout_notes() {
        crate::say!("{note}");
    }
    let mut ros = args
        .ros
        .open_session(&mut session, false, true, &inputs)?
        .context("no ROS output opened")?;
    let span = match input {
        Traffic::Log(log) => session.run_log(log, &args.input, &mut ros, &mut |_, _| {})?,
        Traffic::Recording(rec) => session.run_recording(rec, &args.input, &mut ros)?,
    };
    crate::say!("{}", session.summary(span));
    ros.into_outlet().finish(args.ros.mcap_path())
}
