//! `skin calibrate-force`: a link's force model (counts to newtons) fitted from presses with a
//! known load.

use anyhow::{Context as _, Result, bail};
use skin_core::format::force_file::ForceCalibration;
use skin_core::format::load::LoadFile;
use skin_core::format::recording::RecordingReader;
use skin_core::output::Inputs;
use skin_core::text::{Gzip, Input};
use skin_learn::force_calibration::{ForceFitOptions, LoadedFrames, fit_force, link_areas};
use skin_learn::session::{FromConfig as _, Session, SessionConfig};
use std::path::PathBuf;

/// Fit a link's force model from presses with a known load: counts to newtons.
///
/// Runs CONFIG's session over the input (a candump log, --log, or a raw recording,
/// --recording; its first frames learn the baseline, unloaded), keeps the frames within
/// LOAD.csv's times, and fits the response every taxel shares (full scale, half-scale stress)
/// and each pressed taxel's gain, so that the taxels' forces (stress times the area each
/// stands for) add up to the load. Writes the calibration (skin-force/1) that run.toml's
/// [force] table names, with the fit's report (another link's entry in an existing file
/// stays); prints the fit: R², each press's residual, the taxels loaded in too few frames
/// (they get gain 1, the skin's typical taxel, and are named). CONFIG's own [force] is not
/// read: the run is in counts.
///
/// LOAD.csv is a load cell's samples, `time_s,force_n` (optionally `,x_m,y_m,z_m`, where it
/// pressed: read, not used by the fit), or the loads held over spans, `start_s,end_s,mass_kg` (or `force_n`). Times are
/// seconds on the input's clock: a candump log's stamps (seconds since the epoch), a
/// recording's time column.
///
/// Loads that never bend the response curve (readings well below full scale) determine only
/// the ratio of full scale to half-scale stress: the fit refuses them unless --full-scale
/// gives the sensor's full scale in counts.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Configuration (TOML): the layout (and, for --log, the bus map) and the baseline.
    #[arg(value_name = "CONFIG.toml")]
    config: PathBuf,
    /// A candump log of the presses.
    #[arg(
        long,
        value_name = "LOG",
        conflicts_with = "recording",
        required_unless_present = "recording"
    )]
    log: Option<PathBuf>,
    /// A raw recording of the presses (Cyskin's ids line, then index, time, counts).
    #[arg(long, value_name = "FILE")]
    recording: Option<PathBuf>,
    /// The known loads (CSV; see above).
    #[arg(long, value_name = "LOAD.csv")]
    load: PathBuf,
    /// The link pressed (default: the layout's only link).
    #[arg(long, value_name = "NAME")]
    link: Option<String>,
    /// The sensor's full scale, counts, when known: fixed instead of fitted.
    #[arg(long, value_name = "COUNTS", value_parser = crate::numbers::above(0.0, 1e9))]
    full_scale: Option<f64>,
    /// Standard deviation of the prior holding each gain towards 1.
    #[arg(long, value_name = "SD", default_value_t = 0.2, value_parser = crate::numbers::above(0.0, 10.0))]
    gain_sd: f64,
    /// Frames a taxel must be loaded in to get a gain of its own.
    #[arg(long, value_name = "N", default_value_t = 3, value_parser = crate::numbers::count::<1, 1_000_000>)]
    min_frames: usize,
    /// Where to write the calibration (JSON). An existing force calibration there is replaced;
    /// any other file is refused.
    #[arg(short, long, value_name = "FORCE.json")]
    output: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let input = args
        .log
        .as_ref()
        .or(args.recording.as_ref())
        .context("give --log or --recording")?;
    let mut config = SessionConfig::read(&args.config)?;
    // The calibration being made is not read: the run is in counts (a stale one, of another
    // layout, would refuse the session), and its file may be the output.
    config.force = None;
    let mut inputs = Inputs::new([&args.config, input, &args.load]);
    for p in config.inputs()? {
        inputs.add(&p);
    }
    crate::output::replaceable(&inputs, Some(&args.output), crate::output::Kind::ForceCalibration)?;
    let loads = LoadFile::read(&args.load)?;
    let mut session = Session::from_config(&config)?;
    let link = pick_link(&session, args.link.as_deref())?;
    let frames = match (&args.log, &args.recording) {
        (Some(log), _) => {
            let mut sink = LoadedFrames::new(&loads, link, 0.0);
            let reader = skin_can::candump::CandumpReader::new(Input::open(log, Gzip::Read)?, log);
            session.run_log(reader, log, &mut sink, &mut |_, _| {})?;
            sink.finish()?
        }
        (None, Some(rec)) => {
            // The session's stamps count from the recording's first frame; the loads' are on
            // its time column.
            let first = RecordingReader::open(rec)?.next_frame()?.map_or(0.0, |f| f.time);
            let mut sink = LoadedFrames::new(&loads, link, first);
            session.run_recording(RecordingReader::open(rec)?, rec, &mut sink)?;
            sink.finish()?
        }
        (None, None) => bail!("give --log or --recording"),
    };
    let map = session
        .pipeline()
        .map(link)
        .context("the session has no map of the link")?;
    let areas = link_areas(map).with_context(|| format!("the mesh of link \"{}\"", map.name))?;
    let options = ForceFitOptions {
        full_scale: args.full_scale,
        gain_sd: args.gain_sd,
        min_frames: args.min_frames,
        ..ForceFitOptions::default()
    };
    let fit = fit_force(&frames, &areas, &options).with_context(|| {
        format!(
            "{} with {}: cannot calibrate link \"{}\"",
            input.display(),
            args.load.display(),
            map.name
        )
    })?;
    // Another link's calibration in the file stays: a skin is calibrated a link at a time.
    let mut calibration = match args.output.exists() {
        true => ForceCalibration::read(&args.output)?,
        false => ForceCalibration::new(Vec::new()),
    };
    let entry = fit.link_force(&map.name, &map.ids);
    match calibration.links.iter_mut().find(|l| l.name == map.name) {
        Some(l) => *l = entry,
        None => calibration.links.push(entry),
    }
    crate::output::write_file(&args.output, calibration.to_json().as_bytes(), &inputs)?;
    say_fit(&fit, &map.name, &map.ids);
    crate::say!("wrote {}", args.output.display());
    Ok(())
}

/// The layout index of the link named `name`, or of the only link.
fn pick_link(session: &Session, name: Option<&str>) -> Result<usize> {
    let names: Vec<&str> = session.links().iter().map(|l| l.name.as_str()).collect();
    match name {
        Some(n) => names
            .iter()
            .position(|&m| m == n)
            .with_context(|| format!("--link {n}: the layout's links are {}", names.join(", "))),
        None if names.len() == 1 => Ok(0),
        None => bail!(
            "the layout has {} links ({}): name the one pressed with --link",
            names.len(),
            names.join(", ")
        ),
    }
}

fn say_fit(fit: &skin_learn::force_calibration::ForceFit, link: &str, ids: &[skin_core::TaxelId]) {
    let r = &fit.report;
    let curve = fit.model.curve();
    crate::say!(
        "link \"{link}\": full scale {:.0} counts{}, half-scale stress {:.1} kPa; R² {}, rms {:.3} N over {} frames",
        curve.full_scale,
        if r.full_scale_given { " (given)" } else { "" },
        curve.half_scale_kpa,
        r.r_squared
            .map_or("n/a (one load)".to_owned(), |v| format!("{v:.4}")),
        r.rms_n,
        r.frames
    );
    crate::say!("press   from (s)   to (s)  frames   load (N)  fitted (N)  residual");
    for (k, p) in r.presses.iter().enumerate() {
        crate::say!(
            "{:5}  {:9.3}  {:7.3}  {:6}  {:9.3}  {:10.3}  {:+7.1}%",
            k + 1,
            p.start_s,
            p.end_s,
            p.frames,
            p.load_n,
            p.fitted_n,
            100.0 * p.relative
        );
    }
    const SHOWN: usize = 12;
    let unloaded: Vec<String> = r
        .unloaded_taxels
        .iter()
        .take(SHOWN)
        .filter_map(|&i| ids.get(i))
        .map(|id| id.0.to_string())
        .collect();
    let more = r.unloaded_taxels.len().saturating_sub(SHOWN);
    crate::say!(
        "{} taxels have gains of their own; {} were loaded in too few frames and got gain 1{}{}",
        r.fitted_taxels,
        r.unloaded_taxels.len(),
        match unloaded.is_empty() {
            true => String::new(),
            false => format!(
                " (taxels {}{})",
                unloaded.join(", "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            ),
        },
        if r.saturated_readings > 0 {
            format!(
                "; {} readings were past saturation (lower bounds)",
                r.saturated_readings
            )
        } else {
            String::new()
        }
    );
}
