//! The project's shipped models (fixtures/models, trained by skin-learn/training/train.py on
//! `skin synth` data) run by tract: their cards are read, the segmenter's per-pixel output is
//! laid out right (it agrees with fresh ground truth far above chance), and a classifier is
//! refused as a segmenter.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

mod support;
use support::{forearm, model};

use skin_core::image::ImageSize;
use skin_learn::card::ModelCard;
use skin_learn::classify::{Classifier, InputScale, ModelError};
use skin_learn::metrics::ConfusionMatrix;
use skin_learn::segment::Segmenter;
use skin_learn::synth::{Sample, SynthOptions, Synthesizer};

#[test]
fn cards_say_how_to_feed_the_models() {
    for name in ["handsnet.onnx", "handseg.onnx", "handseg_wide.onnx"] {
        let card = ModelCard::for_model(&model(name)).expect("a card beside every shipped model");
        assert_eq!(card.unit_scale, Some(true), "{name}");
    }
    assert_eq!(
        ModelCard::for_model(&model("handsnet.onnx")).unwrap().classes,
        ["hand", "non_hand"]
    );
    for name in ["handseg.onnx", "handseg_wide.onnx"] {
        let card = ModelCard::for_model(&model(name)).unwrap();
        assert_eq!(card.classes.len(), 7, "{name}");
    }
}

#[test]
fn the_segmenters_label_fresh_hands_far_above_chance() {
    for name in ["handseg.onnx", "handseg_wide.onnx"] {
        labels_fresh_hands_far_above_chance(name);
    }
}

/// `count` hands of subjects no model saw (the training sets used other seeds), four each.
fn fresh_hands(seed: u64, count: u32) -> Vec<Sample> {
    let map = forearm();
    let mut synth = Synthesizer::new(
        &map,
        SynthOptions {
            hand_fraction: 1.0,
            ..SynthOptions::default()
        },
    )
    .unwrap();
    (0..count).map(|k| synth.sample(seed, k / 4, k % 4)).collect()
}

fn labels_fresh_hands_far_above_chance(name: &str) {
    let mut net = Segmenter::load(&model(name), InputScale::Unit).unwrap();
    assert_eq!(
        (net.input_size(), net.classes()),
        (ImageSize { rows: 68, cols: 100 }, 7)
    );
    let samples = fresh_hands(77, 24);
    let images: Vec<&[u8]> = samples.iter().map(|s| s.image.as_slice()).collect();
    let batch = net.segment_batch(&images).unwrap();
    let mut cm = ConfusionMatrix::new(7);
    for (s, labels) in samples.iter().zip(&batch) {
        assert_eq!(
            labels,
            &net.segment(&s.image).unwrap(),
            "batch and single runs differ"
        );
        assert!(labels.iter().zip(&s.image).all(|(&l, &g)| l == 0 || g > 0));
        cm.add_image(&s.mask, labels);
    }
    let scores = cm.segmentation_scores(1);
    // Six parts: chance is about 1/6; a transposed or misread output scores near it.
    assert!(scores.pixel_accuracy > 0.45, "{name}: {scores:?}");
}

/// `labels` (H x W, row-major) mirrored left-right.
fn mirrored(labels: &[u8], w: usize) -> Vec<u8> {
    labels
        .chunks(w)
        .flat_map(|row| row.iter().rev().copied())
        .collect()
}

#[test]
fn mirror_averaging_labels_a_mirrored_hand_as_the_mirror_of_its_labels() {
    let mut plain = Segmenter::load(&model("handseg_wide.onnx"), InputScale::Unit).unwrap();
    let mut averaged = Segmenter::load(&model("handseg_wide.onnx"), InputScale::Unit)
        .unwrap()
        .with_mirror_averaging(true);
    let w = averaged.input_size().cols;
    let samples = fresh_hands(79, 16);
    let (mut plain_cm, mut averaged_cm) = (ConfusionMatrix::new(7), ConfusionMatrix::new(7));
    let mut plain_breaks_symmetry = false;
    for s in &samples {
        let labels = averaged.segment(&s.image).unwrap();
        // The four views of a mirrored image are the four views of the image: its labels must
        // be the mirror of the image's, pixel for pixel. Scores read back from the wrong
        // pixel, or a view left out, break this.
        let flipped = averaged.segment(&mirrored(&s.image, w)).unwrap();
        assert_eq!(flipped, mirrored(&labels, w));
        let one = plain.segment(&s.image).unwrap();
        plain_breaks_symmetry |= plain.segment(&mirrored(&s.image, w)).unwrap() != mirrored(&one, w);
        plain_cm.add_image(&s.mask, &one);
        averaged_cm.add_image(&s.mask, &labels);
    }
    // The model alone is not mirror-symmetric, so the assertion above has something to catch.
    assert!(plain_breaks_symmetry);
    let images: Vec<&[u8]> = samples.iter().map(|s| s.image.as_slice()).collect();
    let mut two = Segmenter::load(&model("handseg_wide.onnx"), InputScale::Unit)
        .unwrap()
        .with_mirror_averaging(true)
        .with_threads(2)
        .unwrap();
    let batch = two.segment_batch(&images).unwrap();
    for (s, labels) in samples.iter().zip(&batch) {
        assert_eq!(
            labels,
            &averaged.segment(&s.image).unwrap(),
            "batch and single runs differ"
        );
    }
    let (p, a) = (
        plain_cm.segmentation_scores(1).mean_iou,
        averaged_cm.segmentation_scores(1).mean_iou,
    );
    assert!(
        a > p - 0.01,
        "averaging over mirrors: mIoU {a:.4}, the model alone {p:.4}"
    );
}

#[test]
fn a_segmenter_refuses_an_image_of_the_wrong_size_with_or_without_mirrors() {
    let good = vec![0u8; 68 * 100];
    for mirrors in [false, true] {
        let mut net = Segmenter::load(&model("handseg.onnx"), InputScale::Unit)
            .unwrap()
            .with_mirror_averaging(mirrors);
        let err = net.segment_batch(&[&good, &[0u8; 100]]).unwrap_err();
        assert!(
            matches!(
                err,
                ModelError::Image {
                    index: 1,
                    got: 100,
                    want: 6800,
                    ..
                }
            ),
            "mirrors {mirrors}: {err}"
        );
    }
}

#[test]
fn the_classifier_tells_fresh_hands_from_other_contacts_above_chance() {
    let map = forearm();
    let mut synth = Synthesizer::new(&map, SynthOptions::default()).unwrap();
    let mut net = Classifier::load(&model("handsnet.onnx"), InputScale::Unit).unwrap();
    let samples: Vec<_> = (0..120).map(|k| synth.sample(78, k / 10, k % 10)).collect();
    let images: Vec<&[u8]> = samples.iter().map(|s| s.image.as_slice()).collect();
    let probs = net.classify_batch(&images).unwrap();
    let right = samples
        .iter()
        .zip(&probs)
        .filter(|(s, p)| (p[0] > p[1]) == s.kind.is_hand())
        .count();
    assert!(right >= 72, "{right} of 120 right");
}

#[test]
fn a_classifier_is_not_a_segmenter_and_vice_versa() {
    let err = Segmenter::load(&model("handsnet.onnx"), InputScale::Unit).unwrap_err();
    assert!(matches!(err, ModelError::Shape { .. }), "{err}");
    assert!(err.to_string().contains("per-pixel class scores"), "{err}");
    let err = Classifier::load(&model("handseg.onnx"), InputScale::Unit).unwrap_err();
    assert!(matches!(err, ModelError::Shape { .. }), "{err}");
}

/// skin-learn swaps tract's 2 x 2 max-pools for its own vectorised one, which takes in the ReLU
/// before it: the shipped models must give exactly what tract's own plan gives (a max is exact,
/// the rest of the plan is the same).
#[test]
fn the_swapped_max_pools_change_no_output() {
    use tract_onnx::prelude::*;
    let map = forearm();
    let mut synth = Synthesizer::new(&map, SynthOptions::default()).unwrap();
    let images: Vec<Vec<u8>> = (0..6).map(|k| synth.sample(79, k, k).image).collect();
    // HandsNet's ReLUs feed their pools alone; the segmenter's first two also feed its skip
    // connections, so they stay.
    for (name, pools, relus_taken_in) in [("handsnet.onnx", 4, 4), ("handseg.onnx", 2, 0)] {
        let optimised = tract_onnx::onnx()
            .model_for_path(model(name))
            .and_then(|m| m.with_input_fact(0, f32::fact([1, 1, 68, 100]).into()))
            .and_then(|m| m.into_optimized())
            .unwrap();
        let mut swapped = optimised.clone();
        assert_eq!(
            skin_learn::max_pool::swap_max_pools(&mut swapped).unwrap(),
            pools,
            "{name}"
        );
        let taken_in = swapped
            .nodes
            .iter()
            .filter(|n| n.op.name() == "ReluMaxPool2x2")
            .count();
        assert_eq!(taken_in, relus_taken_in, "{name}");
        // What feeds each of those pools is the convolution, no longer a ReLU.
        for pool in swapped.nodes.iter().filter(|n| n.op.name() == "ReluMaxPool2x2") {
            let before = swapped.nodes[pool.inputs[0].node].op.name();
            assert_ne!(
                before, "OptMaxByScalar",
                "{name}: {} still follows a ReLU",
                pool.name
            );
        }
        let plain = optimised.into_runnable().unwrap();
        let swapped = swapped.into_runnable().unwrap();
        for image in &images {
            let input: Tensor = tract_ndarray::Array4::from_shape_fn((1, 1, 68, 100), |(_, _, r, c)| {
                f32::from(image[r * 100 + c]) / 255.0
            })
            .into();
            let a = plain.run(tvec!(input.clone().into())).unwrap();
            let b = swapped.run(tvec!(input.into())).unwrap();
            let a = a[0].to_plain_array_view::<f32>().unwrap();
            let b = b[0].to_plain_array_view::<f32>().unwrap();
            assert_eq!(a.shape(), b.shape(), "{name}");
            assert!(
                a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{name}"
            );
        }
    }
}

/// On two threads a batch is split between them, each thread running its images through its own
/// state of the one plan: every image must come out exactly as on one thread, in its place,
/// whatever the split (7 images: shares of 4 and 3; 1 image: no split).
#[test]
fn a_batch_split_between_threads_gives_what_one_thread_gives() {
    let map = forearm();
    let mut synth = Synthesizer::new(&map, SynthOptions::default()).unwrap();
    let samples: Vec<Vec<u8>> = (0..7).map(|k| synth.sample(80, k, k).image).collect();
    let images: Vec<&[u8]> = samples.iter().map(|s| s.as_slice()).collect();

    let mut one = Classifier::load(&model("handsnet.onnx"), InputScale::Unit).unwrap();
    let mut two = Classifier::load(&model("handsnet.onnx"), InputScale::Unit)
        .unwrap()
        .with_threads(2)
        .unwrap();
    let expected = one.classify_batch(&images).unwrap();
    assert_eq!(two.classify_batch(&images).unwrap(), expected);
    // Twice, so that the second run reuses the states the first made.
    assert_eq!(two.classify_batch(&images[2..]).unwrap(), expected[2..]);
    let single = two.classify(images[3]).unwrap();
    assert!(single.iter().zip(&expected[3]).all(|(a, b)| (a - b).abs() < 1e-5));

    let mut one = Segmenter::load(&model("handseg.onnx"), InputScale::Unit).unwrap();
    let mut two = Segmenter::load(&model("handseg.onnx"), InputScale::Unit)
        .unwrap()
        .with_threads(2)
        .unwrap();
    assert_eq!(
        two.segment_batch(&images).unwrap(),
        one.segment_batch(&images).unwrap()
    );
}
