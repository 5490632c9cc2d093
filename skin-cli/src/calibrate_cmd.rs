//! `skin calibrate` and `skin probe-sim`: taxel positions from probe contacts, and simulated
//! probe datasets.

use anyhow::{Result, bail};
use skin_core::format::{cyskin, native};
use skin_core::{LinkSkin, SkinLayout};
use skin_learn::calibration::{
    CURVE_SAMPLES, CalibrationErrors, CalibrationOptions, ProbeDataset, ProbeSimulator, calibrate,
    convergence_curve, curve_svg, curve_table,
};
use std::path::PathBuf;

/// Fit every taxel's position and normal from probe contacts (thesis Ch. 7).
///
/// Per taxel a plane through the contacts that made it answer, then the 2D Gaussian of its responses fitted by
/// Newton-Raphson; the centre is the taxel's position, the plane's normal its normal.
///
/// PROBES.csv has the header `contact,x_m,y_m,z_m,taxel,response`: one row per (contact, taxel
/// that answered), contact centroids in metres, raw responses. Writes the fitted taxels as a
/// layout (metres); taxels that cannot be calibrated are listed with the reason and left out,
/// never guessed: among them a taxel whose contacts do not surround its fitted centre (the edge
/// of what was probed: probe past it). Each fitted centre's uncertainty (from the fit) is in
/// --report. With --truth (a layout: project JSON or Cyskin JSON, taxels matched by id),
/// prints the errors of Eq. 7.5-7.8 as in the thesis' Table 7.1, and with --plot draws the error
/// against samples per taxel (10 random subsets per point, as Fig. 7.9).
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct CalibrateArgs {
    /// Probe dataset (CSV).
    probes: PathBuf,
    /// Where to write the calibrated layout.
    #[arg(short, long, value_name = "LAYOUT.json")]
    output: PathBuf,
    /// `native`: the project's layout JSON; `cyskin`: Cyskin calibration JSON.
    #[arg(long, value_enum, default_value_t = LayoutFormat::Native)]
    format: LayoutFormat,
    /// The true layout, to measure the errors.
    #[arg(long, value_name = "LAYOUT.json")]
    truth: Option<PathBuf>,
    /// Draw the error against samples per taxel to this SVG (needs --truth).
    #[arg(long, value_name = "curve.svg")]
    plot: Option<PathBuf>,
    /// Taxels with fewer answered contacts are flagged.
    #[arg(long, default_value_t = 8, value_name = "N", value_parser = crate::numbers::count::<1, 1_000_000>)]
    min_responses: usize,
    /// A taxel whose contacts leave a wider angle than this (degrees) around its fitted centre
    /// is flagged: its contacts do not surround it (the edge of what was probed).
    #[arg(long, default_value_t = 170.0, value_name = "DEG")]
    max_open_angle: f64,
    /// Also write one line per taxel: status, samples, position, the centre's uncertainty (1
    /// standard deviation from the fit, mm) and the open angle around it (TSV).
    #[arg(long, value_name = "REPORT.tsv")]
    report: Option<PathBuf>,
    /// Name of the link in the written layout (default: the file name of PROBES).
    #[arg(long)]
    name: Option<String>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum LayoutFormat {
    Native,
    Cyskin,
}

/// Simulate a probe calibrating a skin: the dataset `skin calibrate` reads.
///
/// Random presses of about 5 N over the layout, each taxel answering gain * exp(-d^2 / (2
/// spread^2)) of 80 % of full scale, d its distance to the contact, plus noise; only answers
/// above 3 noise sigmas are kept. Deterministic for a given --seed.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct ProbeSimArgs {
    /// True layout (any file `skin flatten` reads).
    #[arg(long, value_name = "L.json")]
    layout: PathBuf,
    /// Number of probe contacts.
    #[arg(long, default_value_t = 350, value_parser = crate::numbers::count::<1, 1_000_000>)]
    contacts: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where to write the dataset (CSV).
    #[arg(short, long, value_name = "PROBES.csv")]
    output: PathBuf,
    /// Width (sigma) of a taxel's response around the contact, millimetres.
    #[arg(long, default_value_t = 4.0, value_name = "MM")]
    spread_mm: f64,
    /// Additive noise sigma, as a fraction of full scale.
    #[arg(long, default_value_t = 0.01)]
    noise: f64,
    /// Noise sigma of the contact centroid, per axis, millimetres.
    #[arg(long, default_value_t = 0.5, value_name = "MM")]
    centroid_noise_mm: f64,
    /// Per-taxel gains vary uniformly within 1 +- this.
    #[arg(long, default_value_t = 0.05)]
    gain_spread: f64,
    /// Mean probe force, newtons (it varies by --force-spread from contact to contact).
    #[arg(long, default_value_t = 5.0, value_name = "N")]
    force_n: f64,
    /// Relative standard deviation of the force.
    #[arg(long, default_value_t = 0.05)]
    force_spread: f64,
    /// Contacts land within this distance of some taxel, millimetres.
    #[arg(long, default_value_t = 8.0, value_name = "MM")]
    margin_mm: f64,
}

pub fn probe_sim(args: ProbeSimArgs) -> Result<()> {
    let inputs = crate::output::Inputs::new([&args.layout]);
    crate::output::replaceable(&inputs, Some(&args.output), crate::output::Kind::Probes)?;
    inputs.check_outputs(&[("-o", Some(&args.output))])?;
    let link = crate::shared::load_input(&args.layout)?;
    if link.taxels.is_empty() {
        bail!("{}: no taxels", args.layout.display());
    }
    for (name, v) in [
        ("--spread-mm", args.spread_mm),
        ("--noise", args.noise),
        ("--centroid-noise-mm", args.centroid_noise_mm),
        ("--gain-spread", args.gain_spread),
        ("--force-n", args.force_n),
        ("--force-spread", args.force_spread),
        ("--margin-mm", args.margin_mm),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            bail!("{name} must be a non-negative number, not {v}");
        }
    }
    if !(args.spread_mm > 0.0 && args.force_n > 0.0) {
        bail!("--spread-mm and --force-n must be positive");
    }
    let sim = ProbeSimulator {
        spread_mm: args.spread_mm,
        noise: args.noise,
        centroid_noise_mm: args.centroid_noise_mm,
        gain_spread: args.gain_spread,
        force_n: args.force_n,
        force_spread: args.force_spread,
        margin_mm: args.margin_mm,
        ..ProbeSimulator::default()
    };
    let dataset = sim.run(&link, args.contacts, args.seed);
    let rows: usize = dataset.contacts.iter().map(|c| c.responses.len()).sum();
    let silent = dataset.contacts.iter().filter(|c| c.responses.is_empty()).count();
    crate::output::write_file(&args.output, dataset.to_csv().as_bytes(), &inputs)?;
    crate::say!(
        "{} contacts on {} taxels: {rows} responses ({:.1} per taxel){}",
        args.contacts,
        link.taxels.len(),
        rows as f64 / link.taxels.len() as f64,
        if silent > 0 {
            format!(", {silent} contacts no taxel answered (not in the CSV)")
        } else {
            String::new()
        }
    );
    crate::say!("wrote {}", args.output.display());
    Ok(())
}

pub fn calibrate_cmd(args: CalibrateArgs) -> Result<()> {
    let inputs = crate::output::Inputs::new([Some(&args.probes), args.truth.as_ref()].into_iter().flatten());
    crate::output::replaceable(&inputs, Some(&args.output), crate::output::Kind::Layout)?;
    crate::output::replaceable(&inputs, args.plot.as_deref(), crate::output::Kind::Svg)?;
    crate::output::replaceable(
        &inputs,
        args.report.as_deref(),
        crate::output::Kind::Table(skin_learn::calibration::REPORT_HEADER),
    )?;
    inputs.check_outputs(&[
        ("-o", Some(&args.output)),
        ("--plot", args.plot.as_deref()),
        ("--report", args.report.as_deref()),
    ])?;
    if !(args.max_open_angle.is_finite() && (0.0..=360.0).contains(&args.max_open_angle)) {
        bail!(
            "--max-open-angle must be from 0 to 360 degrees, not {}",
            args.max_open_angle
        );
    }
    let dataset = ProbeDataset::read(&args.probes)?;
    if args.plot.is_some() && args.truth.is_none() {
        bail!("--plot draws the error against the truth: give --truth too");
    }
    let truth: Option<LinkSkin> = match &args.truth {
        Some(p) => Some(crate::shared::load_input(p)?),
        None => None,
    };
    let options = CalibrationOptions {
        min_responses: args.min_responses,
        max_open_angle_deg: args.max_open_angle,
        ..CalibrationOptions::default()
    };
    let report = calibrate(&dataset, &options);
    crate::say!("{}", report.summary(&args.probes, dataset.contacts.len()));
    if report.fitted() == 0 {
        bail!(
            "{}: no taxel could be calibrated; nothing written",
            args.probes.display()
        );
    }
    let name = args.name.clone().unwrap_or_else(|| {
        args.probes
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("calibrated")
            .to_string()
    });
    let mut link = report.to_link(&name);
    if let Some(t) = &truth {
        link.frame_to_parent = t.frame_to_parent;
    }
    let text = match args.format {
        LayoutFormat::Native => native::to_string(&SkinLayout { links: vec![link] }),
        LayoutFormat::Cyskin => cyskin::skin_to_string(&link),
    };
    crate::output::write_file(&args.output, text.as_bytes(), &inputs)?;
    crate::say!("wrote {}", args.output.display());
    if let Some(path) = &args.report {
        crate::output::write_file(path, report.to_tsv().as_bytes(), &inputs)?;
        crate::say!("wrote {}", path.display());
    }

    if let Some(truth) = &truth {
        crate::say!("{}", CalibrationErrors::compare(&report, truth).table());
        if let Some(plot) = &args.plot {
            let curve = convergence_curve(&dataset, truth, &CURVE_SAMPLES, 10, 1, &options);
            crate::say!("{}", curve_table(&curve, 10));
            let title = format!("Position error vs samples per taxel ({})", args.probes.display());
            crate::output::write_file(plot, curve_svg(&curve, &title).as_bytes(), &inputs)?;
            crate::say!("wrote {}", plot.display());
        }
    }
    Ok(())
}
