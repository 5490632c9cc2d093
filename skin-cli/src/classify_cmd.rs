//! `skin classify`: hand or not, from tactile images, with an ONNX classifier (thesis Ch. 4.3).

use anyhow::{Context, Result, bail};
use skin_geom::{Grid, Normalisation, Rasterizer, TactileImager};
use skin_learn::classify::{Classifier, InputScale};
use std::path::PathBuf;

/// Classify tactile images with an ONNX model (HandsNet: hand or not), run by tract on the CPU.
///
/// INPUTS are 8-bit grey PNG images of the model's input size (68 x 100 for HandsNet: make
/// them with `skin image --size 68x100`), or, with --map, recordings whose every frame is
/// turned into such an image by the real pipeline first (contact-max normalisation, erosion and
/// dilation, resizing to the model's input); frames with no reading above --threshold are
/// reported as "no contact" and not classified.
///
/// One line per image: its name (or frame number and time), the probability of each class and
/// the most likely one. The model must take [N, 1, H, W] grey images; --input-scale says how it
/// expects grey levels (255: 0..255 as floats, as the MATLAB-exported HandsNet; 1: 0..1).
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// The ONNX model.
    #[arg(long, value_name = "MODEL.onnx")]
    model: PathBuf,
    /// PNG images, or recordings with --map.
    #[arg(required = true, value_name = "INPUTS")]
    inputs: Vec<PathBuf>,
    /// Tactile map (or layout) of the recordings: classify their frames.
    #[arg(long, value_name = "MAP.json")]
    map: Option<PathBuf>,
    /// With --map: readings at or below this count as no contact.
    #[arg(long, default_value_t = 10.0)]
    threshold: f32,
    /// Grey levels as the model expects them: 255 (0..255) or 1 (0..1).
    #[arg(long, value_enum, default_value = "255")]
    input_scale: Scale,
    /// Class names, in the model's output order, comma separated (default: class0, class1, ...).
    #[arg(long, value_delimiter = ',')]
    labels: Vec<String>,
}

/// How the model expects grey levels.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Scale {
    /// 0..255 as floats.
    #[value(name = "255")]
    Bytes,
    /// 0..1.
    #[value(name = "1")]
    Unit,
}

pub fn run(args: Args) -> Result<()> {
    let scale = match args.input_scale {
        Scale::Unit => InputScale::Unit,
        Scale::Bytes => InputScale::Bytes,
    };
    let mut net = Classifier::load(&args.model, scale)?;
    let (h, w) = net.input_size();
    let classes = net.classes();
    let labels: Vec<String> = if args.labels.is_empty() {
        (0..classes).map(|k| format!("class{k}")).collect()
    } else if args.labels.len() == classes {
        args.labels.clone()
    } else {
        bail!(
            "--labels names {} classes, {} gives {classes}",
            args.labels.len(),
            args.model.display()
        );
    };
    crate::say!(
        "{}: [N, 1, {h}, {w}] -> {classes} classes ({})",
        args.model.display(),
        labels.join(", ")
    );
    let mut counts = vec![0usize; classes];
    let report = |name: &str, p: &[f32], counts: &mut Vec<usize>| {
        let best = p
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(k, _)| k);
        counts[best] += 1;
        let probs: Vec<String> = labels.iter().zip(p).map(|(l, v)| format!("{l} {v:.3}")).collect();
        crate::say!("{name}: {}  -> {}", probs.join("  "), labels[best]);
    };
    match &args.map {
        None => {
            for path in &args.inputs {
                let img = image::open(path)
                    .with_context(|| format!("cannot read {} as an image", path.display()))?
                    .into_luma8();
                let (iw, ih) = img.dimensions();
                if (ih as usize, iw as usize) != (h, w) {
                    bail!(
                        "{}: {ih} x {iw} px, the model takes {h} x {w} (make images of that size with `skin image --size {h}x{w}`)",
                        path.display()
                    );
                }
                let p = net.classify(img.as_raw())?;
                report(&path.display().to_string(), &p, &mut counts);
            }
        }
        Some(map_path) => {
            let map = crate::image_cmd::load_map(map_path)?;
            let raster = Rasterizer::new(&map, Grid::StepMm(1.0))
                .with_context(|| format!("{}", map_path.display()))?;
            let mut imager = TactileImager::new(raster, Normalisation::ContactMax, true, Some((h, w)))?;
            let inputs = crate::image_cmd::load_inputs(&args.inputs, &map, std::path::Path::new("."))?;
            let mut pressures = vec![0.0f32; map.ids.len()];
            let mut quiet = 0usize;
            for (input, path) in inputs.iter().zip(&args.inputs) {
                for (f, frame) in input.rec.frames.iter().enumerate() {
                    let mut any = false;
                    for (p, &c) in pressures.iter_mut().zip(&input.columns) {
                        let v = frame.values[c];
                        *p = if v > args.threshold { v } else { 0.0 };
                        any |= *p > 0.0;
                    }
                    let name = format!(
                        "{} frame {} ({:.2} s)",
                        path.display(),
                        input.rec.frame_numbers[f],
                        frame.time
                    );
                    if !any {
                        quiet += 1;
                        continue;
                    }
                    let grey = imager.process(&pressures)?;
                    let p = net.classify(grey)?;
                    report(&name, &p, &mut counts);
                }
            }
            crate::say!("{quiet} frame(s) with no contact above {}", args.threshold);
        }
    }
    let summary: Vec<String> = labels
        .iter()
        .zip(&counts)
        .map(|(l, n)| format!("{n} {l}"))
        .collect();
    crate::say!("{}", summary.join(", "));
    Ok(())
}
