//! `skin classify`: hand or not, from tactile images, with an ONNX classifier (thesis Ch. 4.3).

use anyhow::{Context, Result, bail};
use skin_geom::{Grid, Normalisation, Rasterizer, TactileImager};
use skin_learn::card::ModelCard;
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
/// expects grey levels (255: 0..255 as floats, as the MATLAB-exported HandsNet; 1: 0..1), or
/// the model card beside it does (`input_scale: unit`, as for fixtures/models/handsnet.onnx).
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    run: ModelInputs,
    /// Class names, in the model's output order, comma separated (default: from the model card,
    /// else class0, class1, ...).
    #[arg(long, value_delimiter = ',')]
    labels: Vec<String>,
}

/// The model and what it runs on, for `skin classify` and `skin segment`.
#[derive(clap::Args)]
pub(crate) struct ModelInputs {
    /// The ONNX model.
    #[arg(long, value_name = "MODEL.onnx")]
    pub(crate) model: PathBuf,
    /// PNG images, or recordings with --map.
    #[arg(required = true, value_name = "INPUTS")]
    pub(crate) inputs: Vec<PathBuf>,
    /// Tactile map (or layout) of the recordings: run the model on their touched frames.
    #[arg(long, value_name = "MAP.json")]
    pub(crate) map: Option<PathBuf>,
    /// With --map: readings at or below this count as no contact (the recording's units).
    #[arg(long, default_value_t = 10.0, value_parser = crate::numbers::within(-1e9, 1e9))]
    pub(crate) threshold: f64,
    /// Grey levels as the model expects them: 255 (0..255) or 1 (0..1). Default: what the
    /// model card (MODEL.md beside MODEL.onnx) says, else 255.
    #[arg(long, value_enum)]
    pub(crate) input_scale: Option<Scale>,
}

/// How the model expects grey levels.
#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum Scale {
    /// 0..255 as floats.
    #[value(name = "255")]
    Bytes,
    /// 0..1.
    #[value(name = "1")]
    Unit,
}

/// A grey PNG of the model's input size (rows, cols), as row-major pixels.
pub(crate) fn read_model_image(path: &std::path::Path, (h, w): (usize, usize)) -> Result<Vec<u8>> {
    let img = image::open(path).with_context(|| format!("cannot read {} as an image", path.display()))?;
    // A colour or 16-bit image is not a tactile image: converting it would hide the mistake.
    if img.color() != image::ColorType::L8 {
        bail!(
            "{}: a {:?} image; the model takes 8-bit grey tactile images (make them with `skin image`)",
            path.display(),
            img.color()
        );
    }
    let img = img.into_luma8();
    let (iw, ih) = img.dimensions();
    if (ih as usize, iw as usize) != (h, w) {
        bail!(
            "{}: {ih} x {iw} px, the model takes {h} x {w} (make images of that size with `skin image --size {h}x{w}`)",
            path.display()
        );
    }
    Ok(img.into_raw())
}

/// The input scaling: as given, else as the model card says, else 0..255 (the MATLAB HandsNet).
pub(crate) fn input_scale(model: &std::path::Path, given: Option<Scale>) -> InputScale {
    match given {
        Some(Scale::Unit) => InputScale::Unit,
        Some(Scale::Bytes) => InputScale::Bytes,
        None => match ModelCard::for_model(model).and_then(|c| c.unit_scale) {
            Some(true) => InputScale::Unit,
            _ => InputScale::Bytes,
        },
    }
}

pub fn run(args: Args) -> Result<()> {
    let scale = input_scale(&args.run.model, args.run.input_scale);
    let mut net = Classifier::load(&args.run.model, scale)?;
    let (h, w) = net.input_size();
    let classes = net.classes();
    let card = ModelCard::for_model(&args.run.model)
        .map(|c| c.classes)
        .unwrap_or_default();
    let labels: Vec<String> = if args.labels.is_empty() && card.len() == classes {
        card
    } else if args.labels.is_empty() {
        (0..classes).map(|k| format!("class{k}")).collect()
    } else if args.labels.len() == classes {
        args.labels.clone()
    } else {
        bail!(
            "--labels names {} classes, {} gives {classes}",
            args.labels.len(),
            args.run.model.display()
        );
    };
    crate::say!(
        "{}: [N, 1, {h}, {w}] -> {classes} classes ({})",
        args.run.model.display(),
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
    match &args.run.map {
        None => {
            for path in &args.run.inputs {
                let img = read_model_image(path, (h, w))?;
                let p = net.classify(&img)?;
                report(&path.display().to_string(), &p, &mut counts);
            }
        }
        Some(map_path) => {
            let map = crate::image_cmd::load_map(map_path)?;
            let raster = Rasterizer::new(&map, Grid::StepMm(1.0))
                .with_context(|| format!("{}", map_path.display()))?;
            let mut imager = TactileImager::new(raster, Normalisation::ContactMax, true, Some((h, w)))?;
            let inputs = crate::image_cmd::load_inputs(&args.run.inputs, &map, std::path::Path::new("."))?;
            let quiet = crate::image_cmd::each_touched_frame(
                &inputs,
                &mut imager,
                args.run.threshold as f32,
                |input, f, _, grey| {
                    let name = format!(
                        "{} frame {} ({:.2} s)",
                        input.path.display(),
                        input.rec.frame_numbers[f],
                        input.rec.frames[f].time
                    );
                    let p = net.classify(grey)?;
                    report(&name, &p, &mut counts);
                    Ok(())
                },
            )?;
            crate::say!("{quiet} frame(s) with no contact above {}", args.run.threshold);
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
