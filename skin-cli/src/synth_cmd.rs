//! `skin synth`: a labelled dataset of synthetic contacts on a layout (thesis Ch. 4.5).

use anyhow::{Context as _, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use skin_core::image::ImageSize;
use skin_learn::dataset::DatasetWriter;
use skin_learn::synth::{DeadSpots, MaskLabels, Removal, SynthOptions, Synthesizer};
use std::collections::BTreeMap;
use std::io::IsTerminal as _;
use std::path::PathBuf;

/// Generate a labelled dataset of hand and non-hand contacts on a skin layout.
///
/// Hands of simulated subjects (hand length 15-22 cm, their own finger spread, bending and
/// load) grasp, twist, push and pull the link as in the thesis' data collection (Ch. 4.5),
/// with the variability of Ch. 4.2: cut at the edge of the skin, fingertips only, fingers bent
/// or lifted, uneven pressure, any rotation and position. Other contacts are objects (balls,
/// edges, bars, plates, corners, tools) and body parts (forearm, arm, shoulder, torso, back).
/// Readings get sensor noise, spikes and a dead band, then go through the real image pipeline:
/// map, 1 mm grid, contact-max grey (eq. 3.1), erosion r=2 and dilation r=4, resize.
///
/// --small-objects S makes a share S of the non-hand samples small rigid prints, as a rigid
/// object prints on a curved, soft link: a knob or ball (a dome 0.8-2.8 cm across) or a bar
/// pressed across the link (a stroke 2-7 cm long), anywhere on the skin and over its edge,
/// where the edge cuts them smaller still. Without it (the default) none are drawn and a seed
/// gives the dataset it always gave.
///
/// Writes DIR/images/*.png (grey, 68 x 100 by default), DIR/masks/*.png (hand parts: 0
/// background, 1 thumb, 2 index, 3 middle, 4 ring, 5 pinkie, 6 palm), DIR/labels.csv (file,
/// class, kind, subject, partial, fingertips), DIR/frames.txt (raw readings, one frame per
/// sample), DIR/taxel_parts.txt and DIR/map.json. Samples are numbered subject by subject; the
/// same --seed gives the same dataset, whatever the number of threads. Split train and test by
/// subject, as the thesis does.
///
/// Masks label each lit pixel with the part that pressed the taxels behind it (--mask-labels
/// pressing, the truth per taxel), or with each part's region as it shows on the image, where a
/// brighter finger's blob spreads over a dimmer neighbour (--mask-labels as-imaged, as the thesis'
/// annotators drew them for Table 4.8). The images are the same either way.
///
/// --remove-up-to F images --thinned-share of the samples (half by default) through maps with
/// taxels removed as Test B removes them (Ch. 5), 16 maps with fractions spread evenly up to F:
/// training data for models that must hold up on a skin with dead or missing taxels.
/// --blind-spots N images --blind-share of the samples (30% by default) through maps whose
/// taxels read zero within 1 to N blind spots of a quarter of --blind-radius-mm to all of it, as
/// Test A blinds them (Table 5.1: 1-4 spots of 10-40 mm is --blind-spots 4 --blind-radius-mm 40),
/// 64 maps. A sample is imaged through at most one degraded map, so the two shares add up to at
/// most 1. Readings in frames.txt keep every taxel; the same --seed without either option gives
/// the same contacts, imaged whole, and adding --blind-spots leaves the thinned samples as they
/// were.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Skin layout (JSON, Cyskin, iCub) or tactile map (JSON from `skin flatten`).
    #[arg(long, value_name = "LAYOUT.json")]
    layout: PathBuf,
    /// Number of samples (1 to 1,000,000; they are held in memory until written).
    #[arg(long, value_name = "N", value_parser = crate::numbers::count::<1, 1_000_000>)]
    count: usize,
    /// Number of subjects the samples are shared among (default: one per 40 samples, as the
    /// thesis' 90 subjects for 3,530 images).
    #[arg(long, value_name = "K", value_parser = crate::numbers::count::<1, 1_000_000>)]
    subjects: Option<usize>,
    /// Fraction of hand samples, 0 to 1.
    #[arg(long, default_value_t = 0.5, value_parser = crate::numbers::within(0.0, 1.0))]
    hand_fraction: f64,
    /// Seed of the whole dataset.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output image size ROWSxCOLS.
    #[arg(long, value_name = "ROWSxCOLS", default_value = "68x100", value_parser = crate::numbers::image_size)]
    size: ImageSize,
    /// Output folder: created if missing; an existing one is written into only if it holds an
    /// earlier output of `skin synth` (whose files this one replaces, stale ones removed), or
    /// with --force.
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Write into an output folder that holds other files: only the files this command writes
    /// are replaced, everything else stays.
    #[arg(long)]
    force: bool,
    /// Image some samples through maps with up to this fraction of the taxels removed (0.01 to
    /// 0.95; Table 5.3 goes to 0.7).
    #[arg(long, value_name = "F", value_parser = crate::numbers::within(0.01, 0.95))]
    remove_up_to: Option<f64>,
    /// With --remove-up-to: the share of samples imaged through a thinned map, 0 to 1.
    #[arg(long, value_name = "S", default_value_t = 0.5, requires = "remove_up_to", value_parser = crate::numbers::within(0.0, 1.0))]
    thinned_share: f64,
    /// Image some samples through maps with 1 to N blind spots (1 to 64; Table 5.1 goes to 4).
    #[arg(long, value_name = "N", value_parser = crate::numbers::count::<1, 64>)]
    blind_spots: Option<usize>,
    /// With --blind-spots: the largest spot radius, millimetres (radii are drawn from a quarter
    /// of it to all of it).
    #[arg(long, value_name = "R", default_value_t = 40.0, requires = "blind_spots", value_parser = crate::numbers::above(0.0, 1e3))]
    blind_radius_mm: f64,
    /// With --blind-spots: the share of samples imaged through a map with blind spots, 0 to 1.
    #[arg(long, value_name = "S", default_value_t = 0.3, requires = "blind_spots", value_parser = crate::numbers::within(0.0, 1.0))]
    blind_share: f64,
    /// Share of the non-hand samples that are small rigid prints (a knob or a rod), 0 to 1.
    #[arg(long, value_name = "S", default_value_t = 0.0, value_parser = crate::numbers::within(0.0, 1.0))]
    small_objects: f64,
    /// Hand-part masks: `pressing` (the part that pressed each pixel's taxels) or `as-imaged`
    /// (each part's region as it shows on the image, as the thesis labelled by hand).
    #[arg(long, value_enum, default_value_t = Labels::Pressing)]
    mask_labels: Labels,
}

/// `--mask-labels`: see [`MaskLabels`].
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum Labels {
    Pressing,
    AsImaged,
}

/// The generator the arguments ask for, on `map`.
fn synthesizer(args: &Args, map: &skin_geom::TactileMap) -> Result<Synthesizer> {
    let options = SynthOptions {
        image_size: args.size,
        hand_fraction: args.hand_fraction,
        small_objects: args.small_objects,
        labels: match args.mask_labels {
            Labels::Pressing => MaskLabels::Pressing,
            Labels::AsImaged => MaskLabels::AsImaged,
        },
        ..SynthOptions::default()
    };
    let mut synth = Synthesizer::new(map, options).with_context(|| format!("{}", args.layout.display()))?;
    if args.remove_up_to.is_some()
        && args.blind_spots.is_some()
        && args.thinned_share + args.blind_share > 1.0
    {
        bail!(
            "--thinned-share {} and --blind-share {} add up to more than 1: a sample is imaged through one degraded map at most",
            args.thinned_share,
            args.blind_share
        );
    }
    if let Some(up_to) = args.remove_up_to {
        let removal = Removal {
            share: args.thinned_share,
            up_to,
            maps: Removal::MAPS,
        };
        synth = synth
            .with_removal(map, removal, args.seed)
            .with_context(|| format!("{}: --remove-up-to {up_to}", args.layout.display()))?;
    }
    if let Some(spots) = args.blind_spots {
        let dead = DeadSpots {
            share: args.blind_share,
            spots,
            radius_mm: args.blind_radius_mm,
            maps: DeadSpots::MAPS,
        };
        synth = synth
            .with_dead_spots(map, dead, args.seed)
            .with_context(|| format!("{}: --blind-spots {spots}", args.layout.display()))?;
    }
    Ok(synth)
}

/// The most memory the samples may take before they are written, bytes.
const MAX_SAMPLE_BYTES: usize = 8 << 30;

pub fn run(args: Args) -> Result<()> {
    // Each sample holds its image and its mask until the dataset is written.
    let bytes = args.count.saturating_mul(args.size.pixels() * 2);
    if bytes > MAX_SAMPLE_BYTES {
        bail!(
            "--count {} of {}x{} images would hold {:.1} GB in memory; at most {} GB: make fewer or smaller samples, or several datasets",
            args.count,
            args.size.rows,
            args.size.cols,
            bytes as f64 / 1e9,
            MAX_SAMPLE_BYTES >> 30
        );
    }
    let sources = crate::output::Inputs::new([&args.layout]);
    let out = crate::output::open_dir(&args.output, "skin synth", args.force, &sources)?;
    let subjects = args
        .subjects
        .unwrap_or(args.count.div_ceil(40))
        .clamp(1, args.count);
    let map = crate::shared::load_map(&args.layout)?;
    let synth = synthesizer(&args, &map)?;
    // Sample i belongs to subject i * subjects / count: consecutive, nearly equal shares.
    let jobs: Vec<(usize, u32, u32)> = (0..args.count)
        .map(|i| {
            let s = i * subjects / args.count;
            let first = (s * args.count).div_ceil(subjects);
            (i, s as u32, (i - first) as u32)
        })
        .collect();
    let bar = if std::io::stderr().is_terminal() {
        ProgressBar::new(args.count as u64).with_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} samples, {eta} left")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    } else {
        ProgressBar::hidden()
    };
    let samples: Vec<_> = jobs
        .par_iter()
        .map_init(
            || synth.clone(),
            |s, &(i, subject, k)| {
                bar.inc(1);
                (i, s.sample(args.seed, subject, k))
            },
        )
        .collect();
    bar.finish_and_clear();

    let mut writer = DatasetWriter::create(out.path(), &map.ids, &map.to_json(), args.size)
        .map_err(|e| crate::output::user_error(&out, e.into()))?;
    let mut kinds: BTreeMap<(bool, &str), usize> = BTreeMap::new();
    let (mut partial, mut tips, mut hands, mut thinned, mut blinded) = (0, 0, 0, 0, 0);
    for (i, s) in &samples {
        writer
            .add(*i, s)
            .map_err(|e| crate::output::user_error(&out, e.into()))?;
        *kinds.entry((!s.kind.is_hand(), s.kind.name())).or_default() += 1;
        hands += usize::from(s.kind.is_hand());
        partial += usize::from(s.partial);
        tips += usize::from(s.fingertips_only);
        thinned += usize::from(s.removed > 0.0);
        blinded += usize::from(s.dead > 0.0);
    }
    writer
        .finish()
        .map_err(|e| crate::output::user_error(&out, e.into()))?;
    out.commit()?;
    crate::say!(
        "{}: {} samples of {subjects} subjects on {} ({} taxels): {hands} hands, {} other contacts; {partial} partly off the skin, {tips} fingertips only",
        args.output.display(),
        args.count,
        map.name,
        map.ids.len(),
        args.count - hands
    );
    let list: Vec<String> = kinds.iter().map(|((_, k), n)| format!("{k} {n}")).collect();
    crate::say!("  {}", list.join(", "));
    say_options(&args, thinned, blinded);
    Ok(())
}

/// The report's lines on what the options changed: `thinned` samples imaged through thinned
/// maps, `blinded` through maps with blind spots.
fn say_options(args: &Args, thinned: usize, blinded: usize) {
    if let Some(up_to) = args.remove_up_to {
        crate::say!(
            "  {thinned} imaged through maps with up to {:.0}% of the taxels removed",
            100.0 * up_to
        );
    }
    if let Some(spots) = args.blind_spots {
        crate::say!(
            "  {blinded} imaged through maps with 1 to {spots} blind spots of up to {} mm",
            args.blind_radius_mm
        );
    }
    if let Labels::AsImaged = args.mask_labels {
        crate::say!(
            "  hand-part masks: each part's region as it shows on the image (--mask-labels as-imaged)"
        );
    }
}
