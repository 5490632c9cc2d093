//! Classification and segmentation scores (thesis Ch. 4.6): confusion matrices, accuracy, and
//! the four segmentation metrics of Long et al. (2015) used in Table 4.8.
//!
//! For segmentation, as in the thesis' six-by-six tables, the scores are taken over the pixels
//! whose ground truth is a hand part; a part pixel predicted as background is an error, and
//! background pixels are not scored. With n_ij the pixels of part i predicted as j, t_i the
//! pixels of part i, and p_i the pixels predicted as part i among the scored ones:
//!
//! - pixel accuracy = sum_i n_ii / sum_i t_i;
//! - mean accuracy = mean_i n_ii / t_i;
//! - mean IoU = mean_i n_ii / (t_i + p_i - n_ii);
//! - frequency-weighted IoU = sum_i t_i IoU_i / sum_i t_i;
//!
//! means over the parts present in the ground truth.

/// Counts of (true class, predicted class).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfusionMatrix {
    classes: usize,
    /// Row-major: counts[truth * classes + predicted].
    counts: Vec<u64>,
}

impl ConfusionMatrix {
    /// An empty matrix over `classes` classes.
    pub fn new(classes: usize) -> Self {
        ConfusionMatrix {
            classes,
            counts: vec![0; classes * classes],
        }
    }

    /// Number of classes.
    pub fn classes(&self) -> usize {
        self.classes
    }

    /// Adds one observation; classes out of range are ignored (and reported by `false`).
    pub fn add(&mut self, truth: usize, predicted: usize) -> bool {
        if truth < self.classes && predicted < self.classes {
            self.counts[truth * self.classes + predicted] += 1;
            true
        } else {
            false
        }
    }

    /// Adds every pixel of a label image against its ground truth.
    pub fn add_image(&mut self, truth: &[u8], predicted: &[u8]) {
        for (&t, &p) in truth.iter().zip(predicted) {
            self.add(usize::from(t), usize::from(p));
        }
    }

    /// Adds another matrix of the same size.
    pub fn merge(&mut self, other: &ConfusionMatrix) {
        if other.classes == self.classes {
            for (a, b) in self.counts.iter_mut().zip(&other.counts) {
                *a += b;
            }
        }
    }

    /// Count of class `truth` predicted as `predicted`.
    pub fn get(&self, truth: usize, predicted: usize) -> u64 {
        if truth < self.classes && predicted < self.classes {
            self.counts[truth * self.classes + predicted]
        } else {
            0
        }
    }

    /// Observations of class `truth`.
    pub fn truth_total(&self, truth: usize) -> u64 {
        (0..self.classes).map(|p| self.get(truth, p)).sum()
    }

    /// All observations.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// Fraction predicted right (0 when empty).
    pub fn accuracy(&self) -> f64 {
        let right: u64 = (0..self.classes).map(|c| self.get(c, c)).sum();
        ratio(right, self.total())
    }

    /// Fraction of class `c` predicted right (its recall; `None` if it never occurs).
    pub fn class_accuracy(&self, c: usize) -> Option<f64> {
        let t = self.truth_total(c);
        (t > 0).then(|| ratio(self.get(c, c), t))
    }

    /// Segmentation scores over the classes `first..classes` (the hand parts when class 0 is
    /// the background), scored on the pixels whose truth is one of them.
    pub fn segmentation_scores(&self, first: usize) -> SegmentationScores {
        let (mut right, mut total, mut acc, mut iou, mut fw, mut present) =
            (0u64, 0u64, 0.0, 0.0, 0.0, 0usize);
        let scored = first..self.classes;
        let mut per_class_iou = Vec::new();
        for i in scored.clone() {
            let t = self.truth_total(i);
            let n = self.get(i, i);
            let p: u64 = scored.clone().map(|j| self.get(j, i)).sum();
            if t == 0 {
                per_class_iou.push(None);
                continue;
            }
            let u = ratio(n, t + p - n);
            per_class_iou.push(Some(u));
            present += 1;
            right += n;
            total += t;
            acc += ratio(n, t);
            iou += u;
            fw += t as f64 * u;
        }
        let mean = |x: f64| if present > 0 { x / present as f64 } else { 0.0 };
        SegmentationScores {
            pixel_accuracy: ratio(right, total),
            mean_accuracy: mean(acc),
            mean_iou: mean(iou),
            frequency_weighted_iou: if total > 0 { fw / total as f64 } else { 0.0 },
            iou: per_class_iou,
        }
    }
}

/// The segmentation metrics of Table 4.8, fractions 0..1.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentationScores {
    /// Acc: scored pixels predicted right.
    pub pixel_accuracy: f64,
    /// mAcc: per-class accuracy, averaged.
    pub mean_accuracy: f64,
    /// mIoU: per-class intersection over union, averaged.
    pub mean_iou: f64,
    /// fwIoU: IoU weighted by each class's share of the pixels.
    pub frequency_weighted_iou: f64,
    /// IoU of each scored class (`None` when it never occurs in the truth).
    pub iou: Vec<Option<f64>>,
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn perfect_prediction_scores_one() {
        let mut cm = ConfusionMatrix::new(7);
        let truth = [0u8, 1, 2, 3, 4, 5, 6, 6, 6, 1];
        cm.add_image(&truth, &truth);
        let s = cm.segmentation_scores(1);
        assert_eq!(
            (
                s.pixel_accuracy,
                s.mean_accuracy,
                s.mean_iou,
                s.frequency_weighted_iou
            ),
            (1.0, 1.0, 1.0, 1.0)
        );
        assert_eq!(cm.accuracy(), 1.0);
    }

    #[test]
    fn scores_of_a_worked_example() {
        // Parts 1 and 2 (0 = background). Truth 1: 6 pixels, 4 right, 1 as 2, 1 as background.
        // Truth 2: 4 pixels, 3 right, 1 as 1. Background pixels (2 predicted as 1) not scored.
        let mut cm = ConfusionMatrix::new(3);
        for (t, p, n) in [
            (1, 1, 4),
            (1, 2, 1),
            (1, 0, 1),
            (2, 2, 3),
            (2, 1, 1),
            (0, 1, 2),
            (0, 0, 9),
        ] {
            for _ in 0..n {
                cm.add(t, p);
            }
        }
        let s = cm.segmentation_scores(1);
        assert!((s.pixel_accuracy - 7.0 / 10.0).abs() < 1e-12);
        assert!((s.mean_accuracy - (4.0 / 6.0 + 3.0 / 4.0) / 2.0).abs() < 1e-12);
        // IoU_1 = 4 / (6 + 5 - 4) (predicted as 1 among scored: 4 + 1), IoU_2 = 3 / (4 + 4 - 3).
        let (i1, i2) = (4.0 / 7.0, 3.0 / 5.0);
        assert!((s.mean_iou - (i1 + i2) / 2.0).abs() < 1e-12);
        assert!((s.frequency_weighted_iou - (6.0 * i1 + 4.0 * i2) / 10.0).abs() < 1e-12);
        assert!((cm.accuracy() - 16.0 / 21.0).abs() < 1e-12);
        assert_eq!(cm.class_accuracy(2), Some(0.75));
    }

    proptest! {
        #[test]
        fn scores_are_fractions_and_iou_never_beats_accuracy(
            pairs in proptest::collection::vec((0usize..5, 0usize..5), 0..300)
        ) {
            let mut cm = ConfusionMatrix::new(5);
            for (t, p) in pairs {
                cm.add(t, p);
            }
            let s = cm.segmentation_scores(1);
            for v in [s.pixel_accuracy, s.mean_accuracy, s.mean_iou, s.frequency_weighted_iou] {
                prop_assert!((0.0..=1.0).contains(&v));
            }
            prop_assert!(s.mean_iou <= s.mean_accuracy + 1e-12);
            prop_assert!(s.frequency_weighted_iou <= s.pixel_accuracy + 1e-12);
        }
    }
}
