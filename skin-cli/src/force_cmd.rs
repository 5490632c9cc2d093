//! `skin calibrate-force`: a link's force model (counts to newtons) fitted from presses with a
//! known load.

use anyhow::{Result, bail};
use skin_core::format::force_file::ForceCalibration;
use skin_core::format::load::LoadFile;
use skin_core::format::recording::MAX_READING;
use skin_core::output::Inputs;
use skin_learn::force_calibration::{
    CalibrateForceError, ForceFitOptions, MAX_GAIN_SD, Presses, calibrate_link,
};
use skin_learn::session::SessionConfig;
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
    #[arg(long, value_name = "COUNTS", value_parser = crate::numbers::above(0.0, f64::from(MAX_READING)))]
    full_scale: Option<f64>,
    /// Standard deviation of the prior holding each gain towards 1.
    #[arg(long, value_name = "SD", default_value_t = ForceFitOptions::default().gain_sd, value_parser = crate::numbers::above(0.0, MAX_GAIN_SD))]
    gain_sd: f64,
    /// Frames a taxel must be loaded in to get a gain of its own.
    #[arg(long, value_name = "N", default_value_t = ForceFitOptions::default().min_frames, value_parser = crate::numbers::count::<1, 1_000_000>)]
    min_frames: usize,
    /// Where to write the calibration (JSON). An existing force calibration there is replaced;
    /// any other file is refused.
    #[arg(short, long, value_name = "FORCE.json")]
    output: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let presses = match (&args.log, &args.recording) {
        (Some(log), _) => Presses::Log(log),
        (None, Some(rec)) => Presses::Recording(rec),
        (None, None) => bail!("give --log or --recording"),
    };
    let mut config = SessionConfig::read(&args.config)?;
    // The calibration being made is not read (calibrate_link runs in counts): its file may be
    // the output, and is no input.
    config.force = None;
    let mut inputs = Inputs::new([&args.config, presses.path(), &args.load]);
    for p in config.inputs()? {
        inputs.add(&p);
    }
    crate::output::replaceable(&inputs, Some(&args.output), crate::output::Kind::ForceCalibration)?;
    let loads = LoadFile::read(&args.load)?;
    let options = ForceFitOptions {
        full_scale: args.full_scale,
        gain_sd: args.gain_sd,
        min_frames: args.min_frames,
        ..ForceFitOptions::default()
    };
    let calibrated = calibrate_link(
        &config,
        presses,
        &loads,
        &args.load,
        args.link.as_deref(),
        &options,
    )
    .map_err(|e| match e {
        // The command's flag, where the library says "name the one pressed".
        CalibrateForceError::WhichLink { known } => anyhow::anyhow!(
            "the layout has {} links ({}): name the one pressed with --link",
            known.len(),
            known.join(", ")
        ),
        CalibrateForceError::UnknownLink { name, known } => {
            anyhow::anyhow!("--link {name}: the layout's links are {}", known.join(", "))
        }
        e => e.into(),
    })?;
    // Another link's calibration in the file stays: a skin is calibrated a link at a time.
    let mut calibration = match args.output.exists() {
        true => ForceCalibration::read(&args.output)?,
        false => ForceCalibration::new(Vec::new()),
    };
    calibration.set_link(calibrated.entry());
    crate::output::write_file(&args.output, calibration.to_json().as_bytes(), &inputs)?;
    say_fit(&calibrated.fit, &calibrated.link, &calibrated.ids);
    crate::say!("wrote {}", args.output.display());
    Ok(())
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
