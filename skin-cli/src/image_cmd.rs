//! `skin image`: recordings -> tactile images (PNG), one per frame.

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use skin_core::Recording;
use skin_core::format::recording;
use skin_geom::{Grid, Normalisation, Rasterizer, TactileImager, TactileMap};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Turn every frame of every recording into a tactile image (8-bit grey PNG).
///
/// MAP is a tactile map from `skin flatten` (or a Cyskin `tactile_maps` file); a layout file is
/// accepted too and flattened first. Each FRAMES file is a Cyskin raw recording (line 1: taxel
/// ids; then frame number, time in s, one reading per id).
/// Every taxel of the map must be in the recording; readings of ids the map does not know are
/// ignored and counted. Pressure is interpolated barycentrically on a grid laid on the map (thesis
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
    grid: Option<(usize, usize)>,
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
    size: Option<(usize, usize)>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Norm {
    FullScale,
    ContactMax,
}

/// One recording, with its readings reordered to map order.
pub(crate) struct Input {
    /// The recording.
    pub(crate) path: PathBuf,
    pub(crate) dir: PathBuf,
    pub(crate) rec: Recording,
    pub(crate) columns: Vec<usize>,
    /// Each frame's image file name: `frame_<number>.png`, and `frame_<number>_dup<k>.png` for
    /// the k-th repeat of a frame number (a recording joined from two, a counter reset).
    pub(crate) names: Vec<String>,
}

/// Image names for `frame_numbers`: repeats get a suffix instead of overwriting an image.
pub(crate) fn frame_names(frame_numbers: &[u64]) -> (Vec<String>, usize) {
    let mut seen: HashMap<u64, usize> = HashMap::new();
    let mut repeats = 0;
    let names = frame_numbers
        .iter()
        .map(|&n| {
            let k = seen.entry(n).or_default();
            *k += 1;
            if *k == 1 {
                format!("frame_{n:05}.png")
            } else {
                repeats += 1;
                format!("frame_{n:05}_dup{}.png", *k - 1)
            }
        })
        .collect();
    (names, repeats)
}

pub fn run(args: Args) -> Result<()> {
    let sources = crate::output::Inputs::new(std::iter::once(&args.map).chain(&args.frames));
    let out = crate::output::open_dir(&args.output, "skin image", args.force, &sources)?;
    let map = load_map(&args.map)?;
    let grid = match args.grid {
        Some((rows, cols)) => Grid::Size { rows, cols },
        None => Grid::StepMm(args.step_mm),
    };
    let norm = match (args.norm, args.full_scale) {
        (Norm::FullScale, Some(k)) => Normalisation::FullScale(k as f32),
        (Norm::FullScale, None) => {
            bail!("--norm full-scale needs --full-scale COUNTS (the sensor's full-scale reading)")
        }
        (Norm::ContactMax, _) => Normalisation::ContactMax,
    };
    let raster = Rasterizer::new(&map, grid).with_context(|| format!("{}", args.map.display()))?;
    let imager = TactileImager::new(raster, norm, args.morph, args.size)?;
    let (out_rows, out_cols) = imager.output_size();

    let threshold = args.threshold as f32;
    let inputs = load_inputs(&args.frames, &map, out.path())?;
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
        || (imager.clone(), vec![0.0f32; map.ids.len()]),
        |(imager, pressures), &(i, f)| -> Result<()> {
            let input = &inputs[i];
            let values = &input.rec.frames[f].values;
            for (p, &c) in pressures.iter_mut().zip(&input.columns) {
                let v = values[c];
                *p = if v > threshold { v } else { 0.0 };
            }
            let grey = imager.process(pressures)?;
            let path = input.dir.join(&input.names[f]);
            let png = skin_geom::encode_png(grey, out_rows, out_cols)
                .with_context(|| format!("cannot encode {}", input.names[f]))?;
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

/// Reads a tactile map, or flattens a layout given instead of one.
pub(crate) fn load_map(path: &Path) -> Result<TactileMap> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    if text.contains(skin_geom::MAP_FORMAT) || text.contains("\"tactile_maps\"") {
        return Ok(TactileMap::read(path)?);
    }
    let link = crate::flatten::load_input(path)?;
    let map = TactileMap::flatten(&link, &skin_geom::FlattenOptions::default())
        .with_context(|| format!("{}", path.display()))?;
    let (w, h) = map.extent();
    crate::say!(
        "{}: a layout, flattened to a {:.0} x {:.0} mm tactile map (mean angle error {:.3} deg); save it with `skin flatten` to skip this step",
        path.display(),
        w * 1e3,
        h * 1e3,
        map.report.distortion.angle_error_mean_deg
    );
    Ok(map)
}

/// Runs `each(input, frame, pressures, grey)` on every frame of `inputs` with a reading above
/// `threshold` (readings at or below it count as zero), imaged by `imager`; returns how many
/// frames had no contact.
pub(crate) fn each_touched_frame(
    inputs: &[Input],
    imager: &mut TactileImager,
    threshold: f32,
    mut each: impl FnMut(&Input, usize, &[f32], &[u8]) -> Result<()>,
) -> Result<usize> {
    let mut pressures = vec![0.0f32; imager.raster().taxel_count()];
    let mut quiet = 0usize;
    for input in inputs {
        for (f, frame) in input.rec.frames.iter().enumerate() {
            let mut any = false;
            for (p, &c) in pressures.iter_mut().zip(&input.columns) {
                let v = frame.values[c];
                *p = if v > threshold { v } else { 0.0 };
                any |= *p > 0.0;
            }
            if !any {
                quiet += 1;
                continue;
            }
            let grey = imager.process(&pressures)?;
            each(input, f, &pressures, grey)?;
        }
    }
    Ok(quiet)
}

/// One output name per input: its file stem, prefixed with its folder's name where two inputs
/// share a stem; an error where even that leaves two alike (nothing is written over another).
pub(crate) fn output_names(paths: &[PathBuf]) -> Result<Vec<String>> {
    let stem = |p: &Path| {
        p.file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("input")
            .to_string()
    };
    let mut count: HashMap<String, usize> = HashMap::new();
    for p in paths {
        *count.entry(stem(p)).or_default() += 1;
    }
    let mut used: HashMap<String, &Path> = HashMap::new();
    let mut names = Vec::with_capacity(paths.len());
    for p in paths {
        let mut name = stem(p);
        if count[&name] > 1 {
            let parent = p
                .parent()
                .and_then(|d| d.file_name())
                .and_then(|s| s.to_str())
                .unwrap_or("input");
            name = format!("{parent}_{name}");
        }
        if let Some(first) = used.insert(name.clone(), p) {
            bail!(
                "{} and {}: both would be written as {name}; give inputs distinct names (or list each once)",
                first.display(),
                p.display()
            );
        }
        names.push(name);
    }
    Ok(names)
}

/// Reads the recordings and maps their columns onto the map's taxels; names each output folder
/// after the recording (with its parent folder when two recordings share a name).
pub(crate) fn load_inputs(paths: &[PathBuf], map: &TactileMap, out: &Path) -> Result<Vec<Input>> {
    let names = output_names(paths)?;
    let mut inputs = Vec::with_capacity(paths.len());
    for p in paths {
        let rec = recording::read(p)?;
        let index: HashMap<_, _> = rec.taxel_ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
        let mut columns = Vec::with_capacity(map.ids.len());
        let mut missing = Vec::new();
        for id in &map.ids {
            match index.get(id) {
                Some(&c) => columns.push(c),
                None => missing.push(id.0),
            }
        }
        if !missing.is_empty() {
            bail!(
                "{}: {} taxel(s) of the map are not in the recording (first: {:?}); is it a recording of this link?",
                p.display(),
                missing.len(),
                &missing[..missing.len().min(5)]
            );
        }
        let extra = rec.taxel_ids.len() - map.ids.len().min(rec.taxel_ids.len());
        if extra > 0 {
            crate::say!(
                "{}: {extra} reading column(s) are not taxels of the map and are ignored",
                p.display()
            );
        }
        let name = names[inputs.len()].clone();
        let (files, repeats) = frame_names(&rec.frame_numbers);
        if repeats > 0 {
            crate::say!(
                "{}: {repeats} frame number(s) repeat an earlier frame's; their images are named frame_<number>_dup<k>.png",
                p.display()
            );
        }
        inputs.push(Input {
            path: p.clone(),
            dir: out.join(name),
            rec,
            columns,
            names: files,
        });
    }
    Ok(inputs)
}
