//! `skin image`: recordings -> tactile images (PNG), one per frame.

use crate::shared::{load_inputs, load_map};
use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use skin_core::image::{ImageSize, ImageView};
use skin_geom::{Grid, Normalisation, Rasterizer, TactileImager};
use std::path::PathBuf;

/// Turn every frame of every recording into a tactile image (8-bit grey PNG).
///
/// MAP is a tactile map from `skin flatten` (or a Cyskin `tactile_maps` file); a layout file is
/// accepted too and flattened first. Each FRAMES file is a Cyskin raw recording (line 1: taxel
/// ids; then frame number, time in s, one reading per id).
/// Taxels of the map the recording lacks are dead: reported, and the image interpolates across
/// them (as the thesis' Test B removes taxels); readings of ids the map does not know are ignored
/// and counted. Readings are raw: give --threshold above the idle noise (Cyskin: about 2000).
/// Pressure is interpolated barycentrically on a grid laid on the map (thesis
/// Ch. 3.3), then grey = floor(255 K / K_bar) (eq. 3.1).
///
/// Images go to OUT_DIR/<recording name>/frame_<number>.png; frames are processed in parallel.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Tactile map (JSON from `skin flatten`).
    #[arg(long, value_name = "MAP.json")]
    map: PathBuf,
    /// Recordings to convert.
    #[arg(required = true, value_name = "FRAMES")]
    frames: Vec<PathBuf>,
    /// Output folder: created if missing; an existing one is written into only if it holds an
    /// earlier output of `skin image` (or with --force).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Write into an output folder that holds other files: only the files this command writes
    /// are replaced, everything else stays.
    #[arg(long)]
    force: bool,
    /// Pixel side on the map, millimetres (0.01 to 1000).
    #[arg(long, default_value_t = 1.0, value_name = "MM", conflicts_with = "grid", value_parser = crate::numbers::within(0.01, 1000.0))]
    step_mm: f64,
    /// Lay a grid of exactly ROWSxCOLS pixels on the map instead of a fixed step (each side at
    /// most 4096).
    #[arg(long, value_name = "ROWSxCOLS", value_parser = crate::numbers::image_size)]
    grid: Option<ImageSize>,
    /// K_bar, the pressure shown as white: the sensor's full scale (needs --full-scale) or the
    /// largest pressure of each frame.
    #[arg(long, value_enum, default_value_t = Norm::ContactMax)]
    norm: Norm,
    /// Full-scale reading for --norm full-scale, in the recording's units (raw counts).
    #[arg(long, value_name = "COUNTS", value_parser = crate::numbers::above(0.0, f32::MAX as f64))]
    full_scale: Option<f64>,
    /// Readings at or below this are noise and count as no pressure (the active-set threshold
    /// eps, in the recording's units). With --norm contact-max and no threshold, a frame without
    /// contact shows its noise at full contrast.
    #[arg(long, default_value_t = 0.0, value_name = "COUNTS", value_parser = crate::numbers::within(-1e9, 1e9))]
    threshold: f64,
    /// Grey erosion with a disk of radius 2 px, then dilation with a disk of radius 4 px
    /// (thesis Ch. 4.5, the classifier's pre-processing).
    #[arg(long)]
    morph: bool,
    /// Resize the image to ROWSxCOLS (68x100 for the hand classifier; each side at most 4096).
    #[arg(long, value_name = "ROWSxCOLS", value_parser = crate::numbers::image_size)]
    size: Option<ImageSize>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Norm {
    FullScale,
    ContactMax,
}

pub fn run(args: Args) -> Result<()> {
    let sources = crate::output::Inputs::new(std::iter::once(&args.map).chain(&args.frames));
    let out = crate::output::open_dir(&args.output, "skin image", args.force, &sources)?;
    let map = load_map(&args.map)?;
    let grid = match args.grid {
        Some(ImageSize { rows, cols }) => Grid::Size { rows, cols },
        None => Grid::StepMm(args.step_mm),
    };
    let norm = match (args.norm, args.full_scale) {
        (Norm::FullScale, Some(k)) => Normalisation::FullScale(k as f32),
        (Norm::FullScale, None) => {
            bail!("--norm full-scale needs --full-scale COUNTS (the sensor's full-scale reading)")
        }
        (Norm::ContactMax, _) => Normalisation::ContactMax,
    };
    let threshold = args.threshold as f32;
    let (inputs, maps) = load_inputs(&args.frames, &map, out.path())?;
    let imagers = maps
        .iter()
        .map(|m| {
            let raster = Rasterizer::new(m, grid).with_context(|| format!("{}", args.map.display()))?;
            let size = args.size;
            Ok(TactileImager::new(raster, norm, args.morph, size)?)
        })
        .collect::<Result<Vec<_>>>()?;
    let ImageSize {
        rows: out_rows,
        cols: out_cols,
    } = imagers[0].output_size();
    let total: usize = inputs.iter().map(|i| i.rec.frames.len()).sum();
    for input in &inputs {
        std::fs::create_dir_all(&input.dir)
            .with_context(|| format!("cannot write into {}", args.output.display()))?;
    }
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total as u64).with_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames, {per_sec}, eta {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    };
    let jobs: Vec<(usize, usize)> = inputs
        .iter()
        .enumerate()
        .flat_map(|(i, input)| (0..input.rec.frames.len()).map(move |f| (i, f)))
        .collect();
    jobs.par_iter().try_for_each_init(
        || (imagers.clone(), vec![0.0f32; map.ids.len()]),
        |(imagers, pressures), &(i, f)| -> Result<()> {
            let input = &inputs[i];
            let imager = &mut imagers[input.map];
            let size = imager.output_size();
            let pressures = &mut pressures[..imager.raster().taxel_count()];
            let values = &input.rec.frames[f].values;
            input.columns.gather(values, threshold, pressures);
            let grey = imager.process(pressures)?;
            let path = input.dir.join(&input.names[f]);
            // The imager's output always fills its size.
            let png = skin_geom::encode_png(ImageView::new(grey, size)?)
                .with_context(|| format!("cannot encode {}", input.names[f]))?;
            // Held while the file is created: Ctrl-C's handler removes the staging folder only
            // once no file is being made in it.
            let _creating = skin_core::output::writing();
            std::fs::write(&path, &png)
                .with_context(|| format!("cannot write {} in {}", input.names[f], args.output.display()))?;
            bar.inc(1);
            Ok(())
        },
    )?;
    bar.finish_and_clear();
    out.commit()?;
    crate::say!(
        "{total} frames from {} recording(s) -> {out_rows} x {out_cols} px images in {}",
        inputs.len(),
        args.output.display()
    );
    Ok(())
}
