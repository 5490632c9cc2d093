//! `skin eval`: scores of a classifier or segmenter on a dataset, and the robustness study of
//! thesis Ch. 5 (Test A: blind spots; Test B: removed taxels).

use anyhow::{Context as _, Result, bail};
use skin_learn::classify::{Classifier, ModelError};
use skin_learn::dataset::Dataset;
use skin_learn::evaluation::{CASES, Model, Robustness, Scores, robustness, score, taxel_truth, test_images};
use skin_learn::parts::Part;
use skin_learn::segment::Segmenter;
use skin_learn::segmentation_diagnostics::SEAM_BINS;
use std::path::PathBuf;

/// Score an ONNX classifier (HandsNet) or hand-part segmenter on a dataset from `skin synth`
/// (or your own in the same layout).
///
/// The test set is the last --test-fraction of the subjects (unseen people, as in the thesis;
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
        let (images, truths) = test_images(&model, &data, &test)?;
        let taxels = if segmenting {
            taxel_truth(&data, &test)?
        } else {
            None
        };
        let s = score(&mut model, &data, &test, &images, &truths, taxels.as_ref())?;
        report(&s, segmenting);
        return Ok(());
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

fn report(s: &Scores, segmenting: bool) {
    let ms = 1e3 * s.seconds / s.images.max(1) as f64;
    if !segmenting {
        crate::say!(
            "accuracy {:.2}%  ({ms:.2} ms per image, batches of 32)",
            100.0 * s.cm.accuracy()
        );
        crate::say!("confusion (rows: true class, columns: predicted; % of the row)");
        crate::say!("{:>10} {:>9} {:>9}", "", "hand", "non_hand");
        for (t, name) in ["hand", "non_hand"].iter().enumerate() {
            let n = s.cm.truth_total(t).max(1) as f64;
            crate::say!(
                "{name:>10} {:>8.2}% {:>8.2}%",
                100.0 * s.cm.get(t, 0) as f64 / n,
                100.0 * s.cm.get(t, 1) as f64 / n
            );
        }
        crate::say!("by interaction / contact:");
        for (kind, (right, n)) in &s.by_kind {
            crate::say!(
                "  {kind:<11} {:>7.2}%  of {n}",
                100.0 * *right as f64 / (*n).max(1) as f64
            );
        }
        for ((right, n), name) in s.hard.iter().zip(["partly off the skin", "fingertips only"]) {
            crate::say!(
                "  {name}: {:.2}% of {n}",
                100.0 * *right as f64 / (*n).max(1) as f64
            );
        }
        return;
    }
    let g = s.cm.segmentation_scores(1);
    crate::say!("      Acc     mAcc     mIoU    fwIoU  Time (ms)");
    crate::say!(
        "{:>8.2}% {:>7.2}% {:>7.2}% {:>7.2}% {:>9.2}",
        100.0 * g.pixel_accuracy,
        100.0 * g.mean_accuracy,
        100.0 * g.mean_iou,
        100.0 * g.frequency_weighted_iou,
        ms
    );
    crate::say!("confusion over hand-part pixels (rows: true part, columns: predicted; % of the row)");
    let names: Vec<&str> = Part::ALL.iter().map(|p| p.name()).collect();
    crate::say!(
        "{:>8} {}",
        "",
        names.iter().map(|n| format!("{:>10}", n)).collect::<String>()
    );
    for (t, name) in names.iter().enumerate().take(s.cm.classes()).skip(1) {
        let n = s.cm.truth_total(t).max(1) as f64;
        let row: String = (0..s.cm.classes().min(7))
            .map(|p| format!("{:>9.2}%", 100.0 * s.cm.get(t, p) as f64 / n))
            .collect();
        crate::say!("{name:>8} {row}");
    }
    crate::say!("IoU per part: {}", {
        let v: Vec<String> = g
            .iou
            .iter()
            .zip(&names[1..])
            .map(|(u, n)| u.map_or(format!("{n} -"), |u| format!("{n} {:.2}%", 100.0 * u)))
            .collect();
        v.join(", ")
    });
    crate::say!("pixel accuracy by interaction:");
    for (kind, (right, n)) in &s.by_kind {
        crate::say!(
            "  {kind:<11} {:>7.2}%  of {n} px",
            100.0 * *right as f64 / (*n).max(1) as f64
        );
    }
    crate::say!("by case (an image can be in several):");
    crate::say!("  {:<24} {:>6}      Acc     mIoU", "", "images");
    for ((cm, n), name) in s.cases.iter().zip(CASES) {
        let g = cm.segmentation_scores(1);
        crate::say!(
            "  {name:<24} {n:>6} {:>7.2}% {:>7.2}%",
            100.0 * g.pixel_accuracy,
            100.0 * g.mean_iou
        );
    }
    let wrong: Vec<u64> = s.by_seam_distance.iter().map(|(right, n)| n - right).collect();
    let all_wrong = wrong.iter().sum::<u64>().max(1) as f64;
    let cells = |cell: &dyn Fn(usize) -> String| (0..SEAM_BINS.len()).map(cell).collect::<String>();
    let share = |a: u64, b: f64| format!("{:>8.2}%", 100.0 * a as f64 / b.max(1.0));
    crate::say!("hand-part pixels by distance to the nearest pixel of another part (px):");
    for (name, row) in [
        ("distance", cells(&|b| format!("{:>9}", SEAM_BINS[b].0))),
        ("pixels", cells(&|b| format!("{:>9}", s.by_seam_distance[b].1))),
        (
            "predicted right",
            cells(&|b| share(s.by_seam_distance[b].0, s.by_seam_distance[b].1 as f64)),
        ),
        ("share of the errors", cells(&|b| share(wrong[b], all_wrong))),
    ] {
        crate::say!("  {name:<22}{row}");
    }
    match &s.by_taxel {
        Some([model, masks]) => {
            // The masks follow the image, whose dilation spreads a brighter part over its
            // neighbour's taxels: read the same way, they are the most a segmenter that learned
            // them perfectly could score here.
            let (g, m) = (model.segmentation_scores(1), masks.segmentation_scores(1));
            crate::say!(
                "per taxel ({} pressed taxels with a true part from taxel_parts.txt, each taking its \
                 pixel's part as skin segment's per-part table does): Acc {:.2}%, mIoU {:.2}%; \
                 the true masks read the same way: Acc {:.2}%, mIoU {:.2}%",
                (1..model.classes()).map(|c| model.truth_total(c)).sum::<u64>(),
                100.0 * g.pixel_accuracy,
                100.0 * g.mean_iou,
                100.0 * m.pixel_accuracy,
                100.0 * m.mean_iou
            );
        }
        None => {
            crate::say!("per taxel: not scored (the dataset has no map.json, frames.txt and taxel_parts.txt)")
        }
    }
    let n = &s.naming;
    let named_right = s.named_right.segmentation_scores(1);
    crate::say!(
        "part regions (connected pixels of one true part): {} of {} named as another part by most of \
         their pixels; they hold {} of the wrong pixels, the regions named right the other {}; \
         with every region named right: Acc {:.2}%, mIoU {:.2}%",
        n.misnamed,
        n.regions,
        share(n.wrong_in_misnamed, n.wrong as f64).trim(),
        share(n.wrong - n.wrong_in_misnamed, n.wrong as f64).trim(),
        100.0 * named_right.pixel_accuracy,
        100.0 * named_right.mean_iou
    );
    // Taking a hand for the other side swaps its fingers' names; what this recovers is the
    // price of that mistake, the rest is where the parts meet.
    let g = s.side_known.0.segmentation_scores(1);
    crate::say!(
        "as if each hand's side were known (scored against the mirror hand's labels where those \
         fit better, {} of {} images): Acc {:.2}%, mIoU {:.2}%",
        s.side_known.1,
        // The last case, the pixels off the seams, takes every hand image.
        s.cases.last().map_or(0, |c| c.1),
        100.0 * g.pixel_accuracy,
        100.0 * g.mean_iou
    );
}
