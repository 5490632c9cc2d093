//! `skin eval` and `skin segment`: a model's scores on a dataset, and hand pixels coloured (Ch. 4, 5).

use super::*;

#[cfg(feature = "onnx")]
#[test]
fn eval_scores_the_matlab_handsnet_and_runs_test_a() {
    let model = root().join("../shared/data/cyskin/HandsNet_handles_finetuned.onnx");
    if !model.exists() {
        eprintln!(
            "skipped: {} is absent (../shared/data not beside the project)",
            model.display()
        );
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("d");
    synth(&data, "9");
    let m = model.to_str().unwrap();
    let d = data.to_str().unwrap();
    let o = skin(&["eval", "--model", m, "--dataset", d, "--test-fraction", "0"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("60 test images"), "{out}");
    assert!(
        out.contains("accuracy ") && out.contains("by interaction / contact:"),
        "{out}"
    );
    // All subjects as the test set, for a dataset the model saw none of: 1 says it too.
    let o = skin(&["eval", "--model", m, "--dataset", d, "--test-fraction", "1"]);
    let (all, err) = text(&o);
    assert!(o.status.success(), "{all}{err}");
    assert!(all.contains("60 test images"), "{all}");
    // The default holds out the last 30% of the subjects.
    let o = skin(&["eval", "--model", m, "--dataset", d]);
    let (held_out, err) = text(&o);
    assert!(o.status.success(), "{held_out}{err}");
    assert!(!held_out.contains("60 test images"), "{held_out}");
    let o = skin(&[
        "eval",
        "--model",
        m,
        "--dataset",
        d,
        "--test-a",
        "--patterns",
        "1",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    let rows = out.lines().filter(|l| l.trim_end().ends_with('%')).count();
    assert_eq!(rows, 16, "Test A has 4 x 4 cells:\n{out}");
    // A segmenter's wrong model: HandsNet has no per-pixel output.
    let o = skin(&[
        "segment",
        "--model",
        m,
        &root().join("fixtures/forearm/layout.json").display().to_string(),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(err.contains("per-pixel class scores"), "{err}");
}

/// The number that follows `key` in `line`.
#[cfg(feature = "onnx")]
fn number_after(line: &str, key: &str) -> f64 {
    line.split(key)
        .nth(1)
        .unwrap_or_else(|| panic!("no '{key}' in: {line}"))
        .trim_start()
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after '{key}' in: {line}"))
}

#[cfg(feature = "onnx")]
#[test]
fn eval_scores_a_segmenter_by_case_and_over_mirrors() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("d");
    synth(&data, "9");
    let hands = skin_learn::dataset::Dataset::read(&data)
        .unwrap()
        .entries
        .iter()
        .filter(|e| e.hand)
        .count();
    let model = root().join("fixtures/models/handseg.onnx");
    let (m, d) = (model.to_str().unwrap(), data.to_str().unwrap());
    let eval = |extra: &[&str]| {
        let mut a = vec!["eval", "--model", m, "--dataset", d, "--test-fraction", "1"];
        a.extend_from_slice(extra);
        let o = skin(&a);
        let (out, err) = text(&o);
        assert!(o.status.success(), "{out}{err}");
        out
    };
    let plain = eval(&[]);
    eval_case_rows(&plain, hands);
    let plain_acc = eval_side_known(&plain, hands);
    eval_part_naming(&plain, plain_acc);
    eval_error_bins(&plain);
    eval_per_taxel(&plain);
    let mirrors = eval(&["--mirrors"]);
    // Acc, mAcc, mIoU, fwIoU (the time is left out: it differs anyway).
    let scores = |out: &str| -> Vec<String> {
        let line = out.lines().nth(2).unwrap_or_default();
        line.split_whitespace().take(4).map(str::to_owned).collect()
    };
    assert_eq!(scores(&plain).len(), 4, "{plain}");
    assert_ne!(
        scores(&plain),
        scores(&mirrors),
        "--mirrors changed nothing:\n{mirrors}"
    );
    // A dataset of images and masks only is scored per pixel, and says why not per taxel.
    std::fs::remove_file(data.join("taxel_parts.txt")).unwrap();
    let without = eval(&[]);
    assert!(
        without.contains("per taxel: not scored") && scores(&without) == scores(&plain),
        "{without}"
    );
    segment_colours_hand_pixels(tmp.path(), &data, m);
    // A classifier has no pixels to mirror.
    let classifier = root().join("fixtures/models/handsnet.onnx");
    let o = skin(&[
        "eval",
        "--model",
        classifier.to_str().unwrap(),
        "--dataset",
        d,
        "--mirrors",
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(err.contains("--mirrors is for a segmenter"), "{err}");
}

/// The segmenter's rows by case: every hand image is in one of the view cases.
#[cfg(feature = "onnx")]
fn eval_case_rows(plain: &str, hands: usize) {
    // Each case row: its name, then images, Acc and mIoU.
    let images = |out: &str, case: &str| -> usize {
        let line = out
            .lines()
            .find(|l| l.trim_start().starts_with(case))
            .unwrap_or_else(|| panic!("no '{case}' row:\n{out}"));
        line[line.find(case).unwrap() + case.len()..]
            .split_whitespace()
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"))
    };
    assert_eq!(
        images(plain, "thumb or palm in view") + images(plain, "fingers only in view"),
        hands,
        "{plain}"
    );
    assert_eq!(images(plain, "pixels off part borders"), hands, "{plain}");
    assert!(images(plain, "whole hand on the skin") <= hands);
    assert!(images(plain, "all six parts in view") <= images(plain, "thumb or palm in view"));
}

/// The scores as if each hand's side were known: no fewer pixels right than against the masks
/// alone. Returns the plain pixel accuracy, %.
#[cfg(feature = "onnx")]
fn eval_side_known(plain: &str, hands: usize) -> f64 {
    // As if each hand's side were known: each image scored against the better fitting of its
    // mask and the mirror hand's, so no fewer pixels are right than against the masks alone.
    let side = plain
        .lines()
        .find(|l| l.starts_with("as if each hand's side were known"))
        .unwrap_or_else(|| panic!("no side-known line:\n{plain}"));
    let of = side.split(" images)").next().unwrap_or_default();
    let of: Vec<usize> = of
        .rsplit(", ")
        .next()
        .unwrap_or_default()
        .split(" of ")
        .map(|n| n.parse().unwrap())
        .collect();
    assert!(of[0] <= hands && of[1] == hands, "{side}");
    let side_acc: f64 = side
        .split("Acc ")
        .nth(1)
        .unwrap()
        .split('%')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let plain_acc: f64 = plain
        .lines()
        .nth(2)
        .unwrap()
        .split('%')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(side_acc >= plain_acc, "{side}\n{plain}");
    plain_acc
}

#[cfg(feature = "onnx")]
fn eval_part_naming(plain: &str, plain_acc: f64) {
    // Part regions named wrong: no more than there are regions, their share of the errors and
    // the rest's add up, and correcting their names loses no pixel.
    let naming = plain
        .lines()
        .find(|l| l.starts_with("part regions"))
        .unwrap_or_else(|| panic!("no part-regions line:\n{plain}"));
    let in_naming = |key: &str| number_after(naming, key);
    // "... part): M of N named as another part ..."
    let counts: Vec<f64> = naming
        .split("part):")
        .nth(1)
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .filter_map(|w| w.parse().ok())
        .collect();
    let [misnamed, regions] = counts[..] else {
        panic!("{naming}")
    };
    assert!(regions >= 1.0 && misnamed <= regions, "{naming}");
    let (in_misnamed, elsewhere) = (in_naming("they hold"), in_naming("the other"));
    assert!((in_misnamed + elsewhere - 100.0).abs() < 0.02, "{naming}");
    assert!(in_naming("named right: Acc") >= plain_acc, "{naming}\n{plain}");
}

#[cfg(feature = "onnx")]
fn eval_error_bins(plain: &str) {
    // Where the errors lie: every wrong pixel is in one distance bin.
    let row = |name: &str| -> Vec<f64> {
        let line = plain
            .lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("no '{name}' row:\n{plain}"));
        line.trim_start()[name.len()..]
            .split_whitespace()
            .map(|v| v.trim_end_matches('%').parse().unwrap())
            .collect()
    };
    let (pixels, right, share) = (
        row("pixels  "),
        row("predicted right"),
        row("share of the errors"),
    );
    assert!(
        pixels.len() == 6 && right.len() == 6 && share.len() == 6,
        "{plain}"
    );
    let wrong: f64 = pixels
        .iter()
        .zip(&right)
        .map(|(n, r)| n * (1.0 - r / 100.0))
        .sum();
    assert!(
        wrong > 0.0 && (share.iter().sum::<f64>() - 100.0).abs() < 0.1,
        "{plain}"
    );
}

#[cfg(feature = "onnx")]
fn eval_per_taxel(plain: &str) {
    // Per taxel: the segmentation read at each pressed taxel, against taxel_parts.txt; the
    // true masks read the same way give (almost) every taxel its own part.
    let per_taxel = plain
        .lines()
        .find(|l| l.starts_with("per taxel ("))
        .unwrap_or_else(|| panic!("no per-taxel line:\n{plain}"));
    let after = |key: &str| number_after(per_taxel, key);
    assert!(after("per taxel (") > 0.0, "{per_taxel}");
    assert!(after("the same way: Acc") >= 98.0, "{per_taxel}");
    assert!((0.0..=100.0).contains(&after("does): Acc")), "{per_taxel}");
}

#[cfg(feature = "onnx")]
fn segment_colours_hand_pixels(tmp: &Path, data: &Path, m: &str) {
    // skin segment: a coloured part image per input, black where nothing pressed.
    let entries = skin_learn::dataset::Dataset::read(data).unwrap().entries;
    let hand = entries.iter().find(|e| e.hand).unwrap();
    let input = data.join("images").join(&hand.file);
    let out = tmp.join("parts");
    for extra in [&[][..], &["--mirrors"][..]] {
        let mut a = vec![
            "segment",
            "--model",
            m,
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        let o = skin(&a);
        let (said, err) = text(&o);
        assert!(o.status.success(), "{said}{err}");
        let stem = hand.file.trim_end_matches(".png");
        let parts = image::open(out.join(format!("{stem}_parts.png")))
            .unwrap()
            .into_rgb8();
        assert_eq!(parts.dimensions(), (100, 68));
        // The hand's pixels in the true mask get a part: the model calls almost none of them
        // background (faint noise elsewhere in the image may stay black).
        let truth = grey(&data.join("masks").join(&hand.file));
        let (mut hand_px, mut coloured) = (0, 0);
        for ((px, &g), &t) in parts.pixels().zip(&grey(&input)).zip(&truth) {
            assert!(
                g > 0 || px.0 == [0, 0, 0],
                "{extra:?}: a part where nothing pressed"
            );
            hand_px += usize::from(t > 0);
            coloured += usize::from(t > 0 && px.0 != [0, 0, 0]);
        }
        assert!(
            coloured * 10 >= hand_px * 9,
            "{extra:?}: {coloured} of {hand_px} hand pixels coloured"
        );
    }
}

#[test]
fn a_broken_labels_file_names_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("d");
    synth(&data, "1");
    let csv = data.join("labels.csv");
    let mut text_csv = std::fs::read_to_string(&csv).unwrap();
    text_csv = text_csv.replacen(",hand,", ",hnad,", 1);
    std::fs::write(&csv, text_csv).unwrap();
    let err = skin_learn::dataset::Dataset::read(&data).unwrap_err().to_string();
    assert!(err.contains("labels.csv:") && err.contains("hnad"), "{err}");
}
