//! `skin eval`: scores of a classifier or segmenter on a dataset, and the robustness study of
//! thesis Ch. 5 (Test A: blind spots; Test B: removed taxels).

use anyhow::{Context as _, Result, bail};
use skin_learn::classify::{Classifier, ModelError};
use skin_learn::dataset::Dataset;
use skin_learn::evaluation::{Model, Robustness, robustness, score, taxel_truth, test_images};
use skin_learn::segment::Segmenter;
use std::path::PathBuf;

/// Score an ONNX classifier or hand-part segmenter on a dataset from `skin synth`.
///
/// The classifier: HandsNet or your own; the dataset: `skin synth`'s, or your own in the same
/// layout. The test set is the last --test-fraction of the subjects (unseen people, as in the thesis;
/// the training script splits the same way); 1 or 0 scores every sample. A classifier gets Tables
/// 4.3/4.4: accuracy, confusion matrix, accuracy per interaction or contact, and how the hard
/// cases (partly off the skin, fingertips only) fare. A segmenter (output [N, classes, H, W]) is
/// scored on the hand images, over the hand-part pixels, as Table 4.8 (Acc, mAcc, mIoU, fwIoU)
/// with the confusion matrix of Table 4.9.
///
/// --test-a regenerates the test images from the raw frames through maps with 1-4 blind spots of
/// 10-40 mm (Table 5.1/5.2); --test-b through maps with 10-70% of the taxels removed and
/// re-triangulated (Table 5.3/5.4). Each cell is the mean over --patterns random maps. The
/// segmentation ground truth of a degraded image is masked to what it still shows (Ch. 5.3).
/// The input scaling comes from the model card (MODEL.md beside MODEL.onnx) unless given.
///
/// A segmenter is also scored by case: whole hands on the skin, partly off it, fingertips only,
/// with or without the thumb or palm in view, with all six parts in view, and on the pixels off
/// the seams between parts; its pixels are counted by their distance to the nearest other part;
/// its wrong pixels are split between parts it named wrong as a whole (a true part region most
/// of whose pixels it gave another part's name) and the borders of parts it named right; and it
/// is scored as if each hand's side (left or right) were known, and as if every part region
/// were named right. Where the dataset has map.json, frames.txt and taxel_parts.txt, it is also
/// scored per taxel: each pressed taxel takes its pixel's part, as skin segment's per-part table
/// does, against the taxel's true part.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// The ONNX model.
    #[arg(long, value_name = "MODEL.onnx")]
    model: PathBuf,
    /// Dataset directory (labels.csv, images/, masks/, frames.txt, map.json).
    #[arg(long, value_name = "DIR")]
    dataset: PathBuf,
    /// Fraction of the subjects (the last ones) that form the test set; 1 (or 0) for all
    /// samples, as for a dataset the model never saw any of.
    #[arg(long, default_value_t = 0.3, value_parser = crate::numbers::within(0.0, 1.0))]
    test_fraction: f64,
    /// Test A: blind spots (1-4 spots of 10-40 mm).
    #[arg(long, conflicts_with = "test_b")]
    test_a: bool,
    /// Test B: 10-70% of the taxels removed.
    #[arg(long)]
    test_b: bool,
    /// Random degraded maps per cell of Test A / Test B (10 in the thesis).
    #[arg(long, default_value_t = 10, value_parser = crate::numbers::count::<1, 10_000>)]
    patterns: usize,
    /// Grey levels as the model expects them (default: from the model card, else 255).
    #[arg(long, value_enum)]
    input_scale: Option<crate::shared::Scale>,
    /// Threads for inference: each batch of 32 images is split between them.
    #[arg(long, default_value_t = 1, value_parser = crate::numbers::threads)]
    threads: usize,
    /// A segmenter averages the part scores of each image and of its three mirror images
    /// (left-right, up-down, both): four times the inference.
    #[arg(long)]
    mirrors: bool,
}

/// The test set's scores, through the maps the dataset was made on.
fn score_test_set(model: &mut Model, data: &Dataset, test: &[usize], segmenting: bool) -> Result<()> {
    let (images, truths) = test_images(model, data, test)?;
    let taxels = if segmenting {
        taxel_truth(data, test)?
    } else {
        None
    };
    let s = score(model, data, test, &images, &truths, taxels.as_ref())?;
    crate::say!("{}", s.to_string().trim_end());
    Ok(())
}

pub fn run(args: Args) -> Result<()> {
    let scale = crate::shared::input_scale(&args.model, args.input_scale);
    let model = match Classifier::load(&args.model, scale) {
        Ok(c) => Model::Classifier(c.with_threads(args.threads)?),
        Err(ModelError::Shape { .. }) => Model::Segmenter(
            Segmenter::load(&args.model, scale)
                .with_context(|| "neither a classifier ([N, classes]) nor a segmenter")?
                .with_mirror_averaging(args.mirrors)
                .with_threads(args.threads)?,
        ),
        Err(e) => return Err(e.into()),
    };
    if args.mirrors && matches!(model, Model::Classifier(_)) {
        bail!(
            "{}: --mirrors is for a segmenter, and this model is a classifier",
            args.model.display()
        );
    }
    let data = Dataset::read(&args.dataset)?;
    let segmenting = matches!(model, Model::Segmenter(_));
    let test = data.test_set(args.test_fraction, segmenting);
    if test.is_empty() {
        bail!("{}: no sample in the test set", args.dataset.display());
    }
    let hard_partial = test.iter().filter(|&&i| data.entries[i].partial).count();
    let hard_tips = test.iter().filter(|&&i| data.entries[i].fingertips).count();
    crate::say!(
        "{}: {} test images ({} hands; {hard_partial} partly off the skin, {hard_tips} fingertips only) of {} subjects",
        args.dataset.display(),
        test.len(),
        test.iter().filter(|&&i| data.entries[i].hand).count(),
        test.iter()
            .map(|&i| data.entries[i].subject)
            .collect::<std::collections::BTreeSet<_>>()
            .len()
    );
    let mut model = model;
    if !(args.test_a || args.test_b) {
        return score_test_set(&mut model, &data, &test, segmenting);
    }

    // Robustness (Ch. 5): regenerate the test images through degraded maps.
    crate::say!(
        "{} ({} maps per row; mean over them){}",
        if args.test_a {
            "Test A: blind spots"
        } else {
            "Test B: removed taxels"
        },
        args.patterns,
        if segmenting {
            "; p_d: share of hand pixels the masking discards"
        } else {
            ""
        }
    );
    crate::say!(
        "{}",
        match (args.test_a, segmenting) {
            (true, false) => "N_s  r(mm)  Accuracy",
            (false, false) => "    p  Accuracy",
            (true, true) => "N_s  r(mm)      Acc     mAcc     mIoU    fwIoU",
            (false, true) => "    p      Acc     mAcc     mIoU    fwIoU      p_d",
        }
    );
    let which = if args.test_a {
        Robustness::BlindSpots
    } else {
        Robustness::RemovedTaxels
    };
    let pct = |v: f64| format!("{:>7.2}%", 100.0 * v);
    robustness(&mut model, &data, &test, which, args.patterns, &mut |cell| {
        if segmenting {
            let mut row: Vec<String> = cell.segmentation.iter().map(|&v| pct(v)).collect();
            if !args.test_a {
                row.push(pct(cell.discarded));
            }
            crate::say!("{} {}", cell.name, row.join("  "));
        } else {
            crate::say!("{}  {}", cell.name, pct(cell.accuracy));
        }
    })?;
    Ok(())
}
