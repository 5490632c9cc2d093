//! `skin classify`: hand or not, from tactile images, with an ONNX classifier (thesis Ch. 4.3).

use crate::shared::{ModelInputs, input_scale, read_model_image};
use anyhow::{Result, bail};
use skin_learn::card::ModelCard;
use skin_learn::classify::Classifier;

/// Classify tactile images as hand or not with an ONNX model (tract, on the CPU).
///
/// HandsNet is the shipped model.
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

pub fn run(args: Args) -> Result<()> {
    let scale = input_scale(&args.run.model, args.run.input_scale);
    let mut net = Classifier::load(&args.run.model, scale)?;
    let skin_core::image::ImageSize { rows: h, cols: w } = net.input_size();
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
            let map = crate::shared::load_map(map_path)?;
            let (inputs, maps) =
                crate::shared::load_inputs(&args.run.inputs, &map, std::path::Path::new("."))?;
            let mut imagers = crate::shared::model_imagers(&maps, net.input_size(), map_path)?;
            let quiet = crate::shared::each_touched_frame(
                &inputs,
                &mut imagers,
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
