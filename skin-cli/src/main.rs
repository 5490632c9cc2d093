//! `skin`: robot skin from the command line.
//!
//! `skin flatten` turns a link's taxel layout into a flat tactile map; `skin image` turns
//! recordings into tactile images through such a map; `skin replay` assembles skin frames from a
//! candump log of CAN traffic, `skin live` and `skin record` from SocketCAN interfaces;
//! `skin busmap` writes a bus map for a layout; `skin stitch` stitches the maps of a chain of
//! links into one image at every posture, `skin degrade` makes faulty maps for robustness
//! studies; `skin calibrate` fits taxel positions from probe
//! contacts, `skin probe-sim` simulates such contacts; `skin reach` and `skin phri` run the
//! control experiments in simulation; `skin synth` generates labelled hand and non-hand
//! contacts; `skin classify` tells hand touches from others with an ONNX model, `skin segment`
//! labels the hand parts, `skin eval` scores either on a dataset; `skin run` does it all at once,
//! from CAN traffic (a log or a live bus) to touch decisions, and `skin convert` turns a log or
//! a recording into a rosbag2 MCAP file without the models; `skin export` makes logs and
//! recordings into a dataset (LeRobot v3 layout, Parquet); `skin run --view` shows a session
//! live in a browser and `skin view` replays an MCAP file there. Run `skin help <command>` for details.

mod busmap_cmd;
mod calibrate_cmd;
#[cfg(feature = "onnx")]
mod classify_cmd;
mod convert_cmd;
mod degrade_cmd;
#[cfg(feature = "onnx")]
mod eval_cmd;
mod export_cmd;
mod flatten_cmd;
mod force_cmd;
mod image_cmd;
mod live_cmd;
mod numbers;
mod output;
mod phri_cmd;
mod reach_cmd;
mod replay_cmd;
mod ros_out;
mod run_cmd;
mod run_sinks;
#[cfg(feature = "onnx")]
mod segment_cmd;
mod shared;
mod stitch_cmd;
mod synth_cmd;
mod view_cmd;

/// `println!` for reports: a closed stdout (`skin ... | head`) ends the report, not the program.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}
pub(crate) use say;

use clap::{CommandFactory as _, FromArgMatches as _, Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "skin", version, about = "Large-area robot skin: from CAN traffic to tactile images, touch decisions and ROS 2", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Flatten(flatten_cmd::Args),
    Image(image_cmd::Args),
    Replay(replay_cmd::Args),
    Live(live_cmd::LiveArgs),
    Record(live_cmd::RecordArgs),
    Busmap(busmap_cmd::Args),
    Stitch(stitch_cmd::Args),
    Degrade(degrade_cmd::Args),
    Calibrate(calibrate_cmd::CalibrateArgs),
    ProbeSim(calibrate_cmd::ProbeSimArgs),
    CalibrateForce(force_cmd::Args),
    Reach(reach_cmd::Args),
    Phri(phri_cmd::Args),
    Synth(synth_cmd::Args),
    #[cfg(feature = "onnx")]
    Classify(classify_cmd::Args),
    #[cfg(feature = "onnx")]
    Segment(segment_cmd::Args),
    #[cfg(feature = "onnx")]
    Eval(eval_cmd::Args),
    Run(run_cmd::Args),
    Convert(convert_cmd::Args),
    Export(export_cmd::Args),
    #[cfg(feature = "mcap")]
    View(view_cmd::Args),
}

fn main() -> ExitCode {
    let mut command = one_line_summaries(Cli::command());
    let cli = command
        .try_get_matches_from_mut(std::env::args_os())
        .and_then(|mut matches| Cli::from_arg_matches_mut(&mut matches))
        .unwrap_or_else(|e| e.format(&mut command).exit());
    output::install_interrupt_handler();
    let result = match cli.command {
        Command::Flatten(args) => flatten_cmd::run(args),
        Command::Image(args) => image_cmd::run(args),
        Command::Replay(args) => replay_cmd::run(args),
        Command::Live(args) => live_cmd::live(args),
        Command::Record(args) => live_cmd::record(args),
        Command::Busmap(args) => busmap_cmd::run(args),
        Command::Stitch(args) => stitch_cmd::run(args),
        Command::Degrade(args) => degrade_cmd::run(args),
        Command::Calibrate(args) => calibrate_cmd::calibrate_cmd(args),
        Command::ProbeSim(args) => calibrate_cmd::probe_sim(args),
        Command::CalibrateForce(args) => force_cmd::run(args),
        Command::Reach(args) => reach_cmd::run(args),
        Command::Phri(args) => phri_cmd::run(args),
        Command::Synth(args) => synth_cmd::run(args),
        #[cfg(feature = "onnx")]
        Command::Classify(args) => classify_cmd::run(args),
        #[cfg(feature = "onnx")]
        Command::Segment(args) => segment_cmd::run(args),
        #[cfg(feature = "onnx")]
        Command::Eval(args) => eval_cmd::run(args),
        Command::Run(args) => run_cmd::run(args),
        Command::Convert(args) => convert_cmd::run(args),
        Command::Export(args) => export_cmd::run(args),
        #[cfg(feature = "mcap")]
        Command::View(args) => view_cmd::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", describe(&e));
            ExitCode::FAILURE
        }
    }
}

/// `skin --help` lists each command with the first paragraph of its description on one line
/// (a doc comment kept verbatim would break it where the source does); `skin help CMD` and
/// `skin CMD --help` show the whole description.
fn one_line_summaries(command: clap::Command) -> clap::Command {
    command.mut_subcommands(|sub| {
        let Some(about) = sub.get_about().map(ToString::to_string) else {
            return sub;
        };
        let long = sub
            .get_long_about()
            .map_or_else(|| about.clone(), ToString::to_string);
        let line = about.split_whitespace().collect::<Vec<_>>().join(" ");
        sub.about(line).long_about(long)
    })
}

/// An error and its causes, each said once: the library errors already end their message with
/// what the operating system said, and anyhow's `{:#}` would say it again.
fn describe(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}
