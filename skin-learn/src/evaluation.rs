//! Scoring a classifier or a segmenter on a dataset (thesis Tables 4.3, 4.4, 4.8, 4.9), and the
//! robustness study of Ch. 5 (feature `onnx`): the test images regenerated through maps with
//! blind spots (Test A) or taxels removed (Test B), scored per cell over random maps. What
//! `skin eval` prints.

use crate::classify::Classifier;
use crate::dataset::{Dataset, DatasetError};
use crate::metrics::ConfusionMatrix;
use crate::parts::{Part, taxel_labels};
use crate::segment::Segmenter;
use crate::segmentation_diagnostics::{
    Naming, SEAM_BINS, mirror_hand, name_regions, off_borders, seam_distance,
};
use crate::{Error, Result};
use skin_core::format::recording;
use skin_core::image::ImageSize;
use skin_core::{Recording, TaxelId};
use skin_geom::{BlindSpots, Decimation, Grid, Rasterizer, TactileImager, TactileMap};
use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

/// A degraded map of one cell of Test A / Test B, by pattern seed.
type Degrade = Box<dyn Fn(u64) -> skin_geom::Result<TactileMap>>;

/// The model scored.
#[derive(Debug)]
pub enum Model {
    /// Hand / non-hand (or any classes of grey images).
    Classifier(Classifier),
    /// Hand parts.
    Segmenter(Segmenter),
}

impl Model {
    /// Its input image's size.
    pub fn input_size(&self) -> ImageSize {
        match self {
            Model::Classifier(c) => c.input_size(),
            Model::Segmenter(s) => s.input_size(),
        }
    }
}

/// Scores of one pass over the test set ([`score`]).
#[derive(Debug)]
pub struct Scores {
    /// The confusion matrix: images (classifier) or pixels (segmenter).
    pub cm: ConfusionMatrix,
    /// Per interaction or contact kind: (right, all), images or hand-part pixels.
    pub by_kind: BTreeMap<String, (usize, usize)>,
    /// A classifier on the hard cases, partly off the skin and fingertips only: (right, all).
    pub hard: [(usize, usize); 2],
    /// A segmenter's confusion per case of [`CASES`], with the number of images in each.
    pub cases: Vec<(ConfusionMatrix, usize)>,
    /// A segmenter's confusion with each image scored against its mask or the mirror hand's,
    /// whichever fits better, and the number of images the mirror hand's fit better.
    pub side_known: (ConfusionMatrix, usize),
    /// A segmenter's hand-part pixels by [`SEAM_BINS`]: (predicted right, all).
    pub by_seam_distance: [(u64, u64); SEAM_BINS.len()],
    /// A segmenter's part regions summed over the images (see [`Naming`]).
    pub naming: Naming,
    /// A segmenter's confusion with the name of each region named wrong corrected.
    pub named_right: ConfusionMatrix,
    /// Over the pressed taxels with a true part, each taking the part of its pixel (when the
    /// dataset has per-taxel truth): the segmenter's confusion, and the true masks' own.
    pub by_taxel: Option<[ConfusionMatrix; 2]>,
    /// Time spent in the model alone; the scoring around it (seam distances, per-taxel
    /// reading, region naming) is not inference and would inflate the per-image figure.
    pub seconds: f64,
    /// Images scored.
    pub images: usize,
    /// Whether the model is a segmenter (scores per pixel) rather than a classifier.
    pub segmenting: bool,
}

/// The cases a segmenter is also scored on, to show where its errors lie. The first three come
/// from labels.csv; the others from the true mask: without the thumb or the palm in view, a row
/// of fingers reads the same for a left hand as for a mirrored right one; with all six parts in
/// view, nothing is hidden.
pub const CASES: [&str; 7] = [
    "whole hand on the skin",
    "partly off the skin",
    "fingertips only",
    "thumb or palm in view",
    "fingers only in view",
    "all six parts in view",
    BORDERS_AWAY,
];

/// The case scored on every image but only on pixels whose 8 neighbours share their true label:
/// how much of the error sits on the one-pixel seams between parts (PASCAL VOC likewise leaves a
/// band along object borders unscored).
pub const BORDERS_AWAY: &str = "pixels off part borders";

/// Which of [`CASES`] a hand image with `truth` as its part mask belongs to.
fn cases_of(e: &crate::dataset::Entry, truth: &[u8]) -> [bool; 7] {
    let anchored = truth
        .iter()
        .any(|&l| l == Part::Thumb as u8 || l == Part::Palm as u8);
    // Nothing hidden: the thumb gives the hand's side and no finger is missing from the row.
    let whole = Part::ALL[1..].iter().all(|&p| truth.contains(&(p as u8)));
    [
        !e.partial && !e.fingertips,
        e.partial,
        e.fingertips,
        anchored,
        !anchored,
        whole,
        true,
    ]
}

/// The column of `rec` (read from `file`) that holds each of `ids` (the taxels of `whose` map).
fn columns_of(rec: &Recording, ids: &[TaxelId], file: &Path, whose: &str) -> Result<Vec<usize>> {
    let columns = rec.columns(ids);
    match columns.missing.first() {
        Some(id) => Err(inconsistent(file, format!("no column for taxel {id} of {whose}"))),
        None => Ok(columns.of_taxel.into_iter().flatten().collect()),
    }
}

/// A dataset whose files disagree.
fn inconsistent(path: &Path, message: String) -> Error {
    DatasetError::Inconsistent {
        path: path.to_owned(),
        message,
    }
    .into()
}

/// The per-taxel truth of a dataset's test images: the map, the raster its images were made on
/// (1 mm grid, as `skin synth` draws them), and per test image its readings and each taxel's
/// true part, in map order.
/// (Opaque: read with [`taxel_truth`], used by [`score`].)
#[allow(missing_debug_implementations)]
pub struct TaxelTruth {
    map: TactileMap,
    raster: Rasterizer,
    pressures: Vec<Vec<f32>>,
    parts: Vec<Vec<u8>>,
}

/// Reads [`TaxelTruth`] for `test`, or `None` if the dataset lacks any of map.json, frames.txt
/// and taxel_parts.txt (a dataset of images and masks only).
pub fn taxel_truth(data: &Dataset, test: &[usize]) -> Result<Option<TaxelTruth>> {
    let [map, frames, parts] = ["map.json", "frames.txt", "taxel_parts.txt"].map(|f| data.dir.join(f));
    if !(map.exists() && frames.exists() && parts.exists()) {
        return Ok(None);
    }
    let map = TactileMap::read(&map)?;
    let raster = Rasterizer::new(&map, Grid::StepMm(1.0))?;
    let in_map_order = |path: &std::path::Path| -> Result<Vec<Vec<f32>>> {
        let rec = recording::read(path)?;
        if rec.frames.len() != data.entries.len() {
            let message = format!(
                "{} frames for {} rows of labels.csv",
                rec.frames.len(),
                data.entries.len()
            );
            return Err(inconsistent(path, message));
        }
        let cols = columns_of(&rec, &map.ids, path, "map.json")?;
        Ok(test
            .iter()
            .map(|&i| cols.iter().map(|&c| rec.frames[i].values[c]).collect())
            .collect())
    };
    let pressures = in_map_order(&frames)?;
    let parts = in_map_order(&parts)?
        .into_iter()
        .map(|row| row.into_iter().map(|v| v.clamp(0.0, 255.0) as u8).collect())
        .collect();
    Ok(Some(TaxelTruth {
        map,
        raster,
        pressures,
        parts,
    }))
}

/// Scores `model` on the `test` samples of `data`, given their `images` (and for a segmenter
/// their part masks, `truths`; with `taxels`, also per taxel).
pub fn score(
    model: &mut Model,
    data: &Dataset,
    test: &[usize],
    images: &[Vec<u8>],
    truths: &[Vec<u8>],
    taxels: Option<&TaxelTruth>,
) -> Result<Scores> {
    let mut s = Scores::empty(model, images.len(), taxels.is_some());
    let mut inference = Duration::ZERO;
    for (n, (chunk, idx)) in images.chunks(32).zip(test.chunks(32)).enumerate() {
        let refs: Vec<&[u8]> = chunk.iter().map(|v| v.as_slice()).collect();
        match model {
            Model::Classifier(c) => {
                let start = Instant::now();
                let probabilities = c.classify_batch(&refs)?;
                inference += start.elapsed();
                for (p, &i) in probabilities.iter().zip(idx) {
                    s.add_classified(&data.entries[i], p);
                }
            }
            Model::Segmenter(g) => {
                let start = Instant::now();
                let segmented = g.segment_batch(&refs)?;
                inference += start.elapsed();
                for (k, labels) in segmented.iter().enumerate() {
                    let taxel = taxels.map(|t| (t, n * 32 + k));
                    s.add_segmented(
                        &data.entries[idx[k]],
                        &truths[n * 32 + k],
                        labels,
                        g.input_size(),
                        taxel,
                    );
                }
            }
        }
    }
    s.seconds = inference.as_secs_f64();
    Ok(s)
}

impl Scores {
    /// Nothing scored yet, for `model` on `images` images (`by_taxel`: also per taxel).
    fn empty(model: &Model, images: usize, by_taxel: bool) -> Scores {
        let mut s = Scores {
            cm: ConfusionMatrix::new(match model {
                Model::Classifier(c) => c.classes(),
                Model::Segmenter(g) => g.classes(),
            }),
            by_kind: BTreeMap::new(),
            hard: [(0, 0); 2],
            cases: Vec::new(),
            side_known: (ConfusionMatrix::new(0), 0),
            by_seam_distance: [(0, 0); SEAM_BINS.len()],
            naming: Naming::default(),
            named_right: ConfusionMatrix::new(0),
            by_taxel: None,
            seconds: 0.0,
            images,
            segmenting: matches!(model, Model::Segmenter(_)),
        };
        if let Model::Segmenter(g) = model {
            s.cases = CASES
                .iter()
                .map(|_| (ConfusionMatrix::new(g.classes()), 0))
                .collect();
            s.side_known.0 = ConfusionMatrix::new(g.classes());
            s.named_right = ConfusionMatrix::new(g.classes());
            s.by_taxel = by_taxel.then(|| [(); 2].map(|_| ConfusionMatrix::new(g.classes())));
        }
        s
    }

    /// One sample `e` a classifier gave the class `probabilities`.
    fn add_classified(&mut self, e: &crate::dataset::Entry, probabilities: &[f32]) {
        let truth = usize::from(!e.hand); // class 0 hand, 1 non-hand
        let best = probabilities
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(k, _)| k);
        self.cm.add(truth, best);
        let right = usize::from(best == truth);
        let slot = self.by_kind.entry(e.kind.clone()).or_default();
        *slot = (slot.0 + right, slot.1 + 1);
        for (h, flag) in self.hard.iter_mut().zip([e.partial, e.fingertips]) {
            if flag {
                *h = (h.0 + right, h.1 + 1);
            }
        }
    }

    /// One sample `e` a segmenter labelled `labels` (an image of `rows` x `cols`) against its
    /// part mask `truth`; `taxel`: the taxels' truth and the sample's index in it.
    fn add_segmented(
        &mut self,
        e: &crate::dataset::Entry,
        truth: &[u8],
        labels: &[u8],
        ImageSize { rows, cols }: ImageSize,
        taxel: Option<(&TaxelTruth, usize)>,
    ) {
        let mut one = ConfusionMatrix::new(self.cm.classes());
        one.add_image(truth, labels);
        let slot = self.by_kind.entry(e.kind.clone()).or_default();
        // Per interaction: pixels right / hand pixels.
        let parts: u64 = (1..one.classes()).map(|c| one.truth_total(c)).sum();
        let right: u64 = (1..one.classes()).map(|c| one.get(c, c)).sum();
        *slot = (slot.0 + right as usize, slot.1 + parts as usize);
        for ((case, yes), name) in self.cases.iter_mut().zip(cases_of(e, truth)).zip(CASES) {
            if !yes {
                continue;
            }
            if name == BORDERS_AWAY {
                case.0.add_image(&off_borders(truth, rows, cols), labels);
            } else {
                case.0.merge(&one);
            }
            case.1 += 1;
        }
        for ((&t, &p), d) in truth.iter().zip(labels).zip(seam_distance(truth, rows, cols)) {
            if t != 0 {
                let bin = SEAM_BINS.iter().position(|&(_, last)| d <= last).unwrap_or(0);
                let slot = &mut self.by_seam_distance[bin];
                *slot = (slot.0 + u64::from(p == t), slot.1 + 1);
            }
        }
        if let (Some((t, at)), Some(cms)) = (taxel, self.by_taxel.as_mut()) {
            let (pressures, parts) = (&t.pressures[at], &t.parts[at]);
            for (cm, image) in cms.iter_mut().zip([labels, truth]) {
                for (i, label) in taxel_labels(&t.map, &t.raster, ImageSize { rows, cols }, image, pressures)
                {
                    if parts[i] > 0 {
                        cm.add(usize::from(parts[i]), usize::from(label));
                    }
                }
            }
        }
        let (naming, renamed) = name_regions(truth, labels, rows, cols);
        self.naming.add(&naming);
        self.named_right.add_image(truth, &renamed);
        let mut mirror = ConfusionMatrix::new(self.cm.classes());
        mirror.add_image(&mirror_hand(truth), labels);
        let mirror_right: u64 = (1..mirror.classes()).map(|c| mirror.get(c, c)).sum();
        if mirror_right > right {
            self.side_known.0.merge(&mirror);
            self.side_known.1 += 1;
        } else {
            self.side_known.0.merge(&one);
        }
        self.cm.merge(&one);
    }
}

/// Grey images (row-major), or part masks.
pub type Images = Vec<Vec<u8>>;

/// The test images of `data` (and, for a segmenter, their part masks), checked against the
/// model's input size.
pub fn test_images(model: &Model, data: &Dataset, test: &[usize]) -> Result<(Images, Images)> {
    let segmenting = matches!(model, Model::Segmenter(_));
    let mut images = Vec::with_capacity(test.len());
    let mut truths = Vec::with_capacity(test.len());
    for &i in test {
        let (img, r, c) = data.image(i)?;
        let takes = model.input_size();
        if (r, c) != (takes.rows, takes.cols) {
            let (mr, mc) = (takes.rows, takes.cols);
            let message = format!(
                "image {} is {r} x {c}, the model takes {mr} x {mc}",
                data.entries[i].file
            );
            return Err(inconsistent(&data.dir, message));
        }
        images.push(img);
        truths.push(if segmenting { data.mask(i)?.0 } else { Vec::new() });
    }
    Ok((images, truths))
}

/// A robustness test of Ch. 5.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Robustness {
    /// Test A: 1-4 blind spots of 10-40 mm radius (Tables 5.1, 5.2).
    BlindSpots,
    /// Test B: 10-70% of the taxels removed and the rest re-triangulated (Tables 5.3, 5.4).
    RemovedTaxels,
}

/// One cell (row) of a robustness table: the means over its random maps.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// The cell's parameters as the table prints them (`N_s r(mm)` or `p`).
    pub name: String,
    /// A classifier's accuracy, 0 to 1.
    pub accuracy: f64,
    /// A segmenter's Acc, mAcc, mIoU and fwIoU over hand-part pixels, 0 to 1.
    pub segmentation: [f64; 4],
    /// A segmenter's share of hand pixels the masking discards (Ch. 5.3), 0 to 1.
    pub discarded: f64,
}

/// Test A or B: the `test` images of `data` regenerated from its raw frames (frames.txt, in
/// map.json's taxels) through `patterns` random degraded maps per cell, and scored; a
/// segmenter's truth is masked to what a degraded image still shows. `each` gets every cell as it
/// is done.
pub fn robustness(
    model: &mut Model,
    data: &Dataset,
    test: &[usize],
    which: Robustness,
    patterns: usize,
    each: &mut dyn FnMut(&Cell),
) -> Result<Vec<Cell>> {
    let segmenting = matches!(model, Model::Segmenter(_));
    let map = TactileMap::read(&data.dir.join("map.json"))?;
    let frames_path = data.dir.join("frames.txt");
    let frames = recording::read(&frames_path)?;
    let parts = recording::read(&data.dir.join("taxel_parts.txt"))?;
    if frames.frames.len() != data.entries.len() || parts.frames.len() != data.entries.len() {
        let message = format!(
            "{} frames, taxel_parts.txt {}, labels.csv {} rows",
            frames.frames.len(),
            parts.frames.len(),
            data.entries.len()
        );
        return Err(inconsistent(&frames_path, message));
    }
    let size = model.input_size();
    let mut truths_full = Vec::new();
    for &i in test {
        truths_full.push(if segmenting { data.mask(i)?.0 } else { Vec::new() });
    }
    let cells = degradations(which, &map);
    let mut table = Vec::with_capacity(cells.len());
    for (name, make) in &cells {
        let mut sums = [0.0f64; 5];
        for seed in 0..patterns as u64 {
            let degraded = make(seed)?;
            let mut imager = TactileImager::for_model(&degraded, 1.0, size)?;
            let cols = columns_of(&frames, &degraded.ids, &frames_path, "a degraded map")?;
            let masks = segmenting.then_some(truths_full.as_slice());
            let (images, truths, kept, before) = degraded_images(&mut imager, &frames, &cols, test, masks)?;
            let s = score(model, data, test, &images, &truths, None)?;
            if segmenting {
                let g = s.cm.segmentation_scores(1);
                for (sum, v) in sums.iter_mut().zip([
                    g.pixel_accuracy,
                    g.mean_accuracy,
                    g.mean_iou,
                    g.frequency_weighted_iou,
                    1.0 - kept as f64 / before.max(1) as f64,
                ]) {
                    *sum += v;
                }
            } else {
                sums[0] += s.cm.accuracy();
            }
        }
        let n = patterns.max(1) as f64;
        let cell = Cell {
            name: name.clone(),
            accuracy: if segmenting { 0.0 } else { sums[0] / n },
            segmentation: if segmenting {
                [sums[0] / n, sums[1] / n, sums[2] / n, sums[3] / n]
            } else {
                [0.0; 4]
            },
            discarded: if segmenting { sums[4] / n } else { 0.0 },
        };
        each(&cell);
        table.push(cell);
    }
    Ok(table)
}

/// The cells of a robustness table: each one's name as the table prints it, and how to make one
/// of its degraded maps of `map` from a seed.
fn degradations(which: Robustness, map: &TactileMap) -> Vec<(String, Degrade)> {
    match which {
        Robustness::BlindSpots => (1..=4)
            .flat_map(|spots| (1..=4).map(move |r| (spots, 10.0 * r as f64)))
            .map(|(spots, radius_mm)| {
                let m = map.clone();
                let f: Degrade = Box::new(move |seed| {
                    BlindSpots {
                        spots,
                        radius_mm,
                        seed,
                    }
                    .apply(&m)
                });
                (format!("{spots:>3} {radius_mm:>5.0}"), f)
            })
            .collect(),
        Robustness::RemovedTaxels => (1..=7)
            .map(|k| {
                let m = map.clone();
                let fraction = k as f64 / 10.0;
                let f: Degrade = Box::new(move |seed| Decimation { fraction, seed }.apply(&m));
                (format!("{:>4.0}%", 100.0 * fraction), f)
            })
            .collect(),
    }
}

/// The `test` samples' images through a degraded map's `imager` (`cols`: each of its taxels'
/// column in `frames`). For a segmenter (`truths_full`: the samples' whole part masks) also the
/// masks cut to what the degraded image still shows, and the hand pixels kept and before.
fn degraded_images(
    imager: &mut TactileImager,
    frames: &Recording,
    cols: &[usize],
    test: &[usize],
    truths_full: Option<&[Vec<u8>]>,
) -> Result<(Images, Images, usize, usize)> {
    let mut pressures = vec![0.0f32; cols.len()];
    let (mut images, mut truths) = (Vec::with_capacity(test.len()), Vec::with_capacity(test.len()));
    let (mut kept, mut before) = (0usize, 0usize);
    for (k, &i) in test.iter().enumerate() {
        let values = &frames.frames[i].values;
        for (p, &c) in pressures.iter_mut().zip(cols) {
            *p = values[c];
        }
        let img = imager.process(&pressures)?.to_vec();
        if let Some(truths_full) = truths_full {
            let (img, truth) = skin_geom::masked_ground_truth(&img, &truths_full[k], 0)?;
            before += truths_full[k].iter().filter(|&&l| l > 0).count();
            kept += truth.iter().filter(|&&l| l > 0).count();
            images.push(img);
            truths.push(truth);
        } else {
            images.push(img);
            truths.push(Vec::new());
        }
    }
    Ok((images, truths, kept, before))
}

/// The tables `skin eval` prints: a classifier's accuracy and confusion by kind and hard case;
/// a segmenter's Acc / mAcc / mIoU / fwIoU, part confusion, and where its errors lie (by case,
/// by distance to a part seam, per taxel, by region naming, with the hand's side known).
impl std::fmt::Display for Scores {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let ms = 1e3 * self.seconds / self.images.max(1) as f64;
        if !self.segmenting {
            return self.write_classifier(f, ms);
        }
        self.write_segmenter(f, ms)?;
        self.write_seams(f)?;
        self.write_where_errors_lie(f)
    }
}

impl Scores {
    /// A classifier's accuracy, confusion, and accuracy by kind and hard case.
    fn write_classifier(&self, f: &mut std::fmt::Formatter<'_>, ms: f64) -> std::fmt::Result {
        let s = self;
        writeln!(
            f,
            "accuracy {:.2}%  ({ms:.2} ms per image, batches of 32)",
            100.0 * s.cm.accuracy()
        )?;
        writeln!(
            f,
            "confusion (rows: true class, columns: predicted; % of the row)"
        )?;
        writeln!(f, "{:>10} {:>9} {:>9}", "", "hand", "non_hand")?;
        for (t, name) in ["hand", "non_hand"].iter().enumerate() {
            let n = s.cm.truth_total(t).max(1) as f64;
            writeln!(
                f,
                "{name:>10} {:>8.2}% {:>8.2}%",
                100.0 * s.cm.get(t, 0) as f64 / n,
                100.0 * s.cm.get(t, 1) as f64 / n
            )?;
        }
        writeln!(f, "by interaction / contact:")?;
        for (kind, (right, n)) in &s.by_kind {
            writeln!(
                f,
                "  {kind:<11} {:>7.2}%  of {n}",
                100.0 * *right as f64 / (*n).max(1) as f64
            )?;
        }
        for ((right, n), name) in s.hard.iter().zip(["partly off the skin", "fingertips only"]) {
            writeln!(
                f,
                "  {name}: {:.2}% of {n}",
                100.0 * *right as f64 / (*n).max(1) as f64
            )?;
        }
        Ok(())
    }

    /// A segmenter's scores, part confusion, IoU per part, and accuracy by interaction and case.
    fn write_segmenter(&self, f: &mut std::fmt::Formatter<'_>, ms: f64) -> std::fmt::Result {
        let s = self;
        let g = s.cm.segmentation_scores(1);
        writeln!(f, "      Acc     mAcc     mIoU    fwIoU  Time (ms)")?;
        writeln!(
            f,
            "{:>8.2}% {:>7.2}% {:>7.2}% {:>7.2}% {:>9.2}",
            100.0 * g.pixel_accuracy,
            100.0 * g.mean_accuracy,
            100.0 * g.mean_iou,
            100.0 * g.frequency_weighted_iou,
            ms
        )?;
        writeln!(
            f,
            "confusion over hand-part pixels (rows: true part, columns: predicted; % of the row)"
        )?;
        let names: Vec<&str> = Part::ALL.iter().map(|p| p.name()).collect();
        writeln!(
            f,
            "{:>8} {}",
            "",
            names.iter().map(|n| format!("{:>10}", n)).collect::<String>()
        )?;
        for (t, name) in names.iter().enumerate().take(s.cm.classes()).skip(1) {
            let n = s.cm.truth_total(t).max(1) as f64;
            let row: String = (0..s.cm.classes().min(7))
                .map(|p| format!("{:>9.2}%", 100.0 * s.cm.get(t, p) as f64 / n))
                .collect();
            writeln!(f, "{name:>8} {row}")?;
        }
        writeln!(f, "IoU per part: {}", {
            let v: Vec<String> = g
                .iou
                .iter()
                .zip(&names[1..])
                .map(|(u, n)| u.map_or(format!("{n} -"), |u| format!("{n} {:.2}%", 100.0 * u)))
                .collect();
            v.join(", ")
        })?;
        writeln!(f, "pixel accuracy by interaction:")?;
        for (kind, (right, n)) in &s.by_kind {
            writeln!(
                f,
                "  {kind:<11} {:>7.2}%  of {n} px",
                100.0 * *right as f64 / (*n).max(1) as f64
            )?;
        }
        writeln!(f, "by case (an image can be in several):")?;
        writeln!(f, "  {:<24} {:>6}      Acc     mIoU", "", "images")?;
        for ((cm, n), name) in s.cases.iter().zip(CASES) {
            let g = cm.segmentation_scores(1);
            writeln!(
                f,
                "  {name:<24} {n:>6} {:>7.2}% {:>7.2}%",
                100.0 * g.pixel_accuracy,
                100.0 * g.mean_iou
            )?;
        }
        Ok(())
    }

    /// Hand-part pixels by their distance to another part: where the errors lie.
    fn write_seams(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self;
        let wrong: Vec<u64> = s.by_seam_distance.iter().map(|(right, n)| n - right).collect();
        let all_wrong = wrong.iter().sum::<u64>().max(1) as f64;
        let cells = |cell: &dyn Fn(usize) -> String| (0..SEAM_BINS.len()).map(cell).collect::<String>();
        let share = |a: u64, b: f64| format!("{:>8.2}%", 100.0 * a as f64 / b.max(1.0));
        writeln!(
            f,
            "hand-part pixels by distance to the nearest pixel of another part (px):"
        )?;
        for (name, row) in [
            ("distance", cells(&|b| format!("{:>9}", SEAM_BINS[b].0))),
            ("pixels", cells(&|b| format!("{:>9}", s.by_seam_distance[b].1))),
            (
                "predicted right",
                cells(&|b| share(s.by_seam_distance[b].0, s.by_seam_distance[b].1 as f64)),
            ),
            ("share of the errors", cells(&|b| share(wrong[b], all_wrong))),
        ] {
            writeln!(f, "  {name:<22}{row}")?;
        }
        Ok(())
    }

    /// Per taxel, by region naming, and with the hand's side known.
    fn write_where_errors_lie(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self;
        let share = |a: u64, b: f64| format!("{:>8.2}%", 100.0 * a as f64 / b.max(1.0));
        match &s.by_taxel {
            Some([model, masks]) => {
                // The masks follow the image, whose dilation spreads a brighter part over its
                // neighbour's taxels: read the same way, they are the most a segmenter that learned
                // them perfectly could score here.
                let (g, m) = (model.segmentation_scores(1), masks.segmentation_scores(1));
                writeln!(
                    f,
                    "per taxel ({} pressed taxels with a true part from taxel_parts.txt, each taking its \
                 pixel's part as skin segment's per-part table does): Acc {:.2}%, mIoU {:.2}%; \
                 the true masks read the same way: Acc {:.2}%, mIoU {:.2}%",
                    (1..model.classes()).map(|c| model.truth_total(c)).sum::<u64>(),
                    100.0 * g.pixel_accuracy,
                    100.0 * g.mean_iou,
                    100.0 * m.pixel_accuracy,
                    100.0 * m.mean_iou
                )?;
            }
            None => writeln!(
                f,
                "per taxel: not scored (the dataset has no map.json, frames.txt and taxel_parts.txt)"
            )?,
        }
        let n = &s.naming;
        let named_right = s.named_right.segmentation_scores(1);
        writeln!(
            f,
            "part regions (connected pixels of one true part): {} of {} named as another part by most of \
         their pixels; they hold {} of the wrong pixels, the regions named right the other {}; \
         with every region named right: Acc {:.2}%, mIoU {:.2}%",
            n.misnamed,
            n.regions,
            share(n.wrong_in_misnamed, n.wrong as f64).trim(),
            share(n.wrong - n.wrong_in_misnamed, n.wrong as f64).trim(),
            100.0 * named_right.pixel_accuracy,
            100.0 * named_right.mean_iou
        )?;
        // Taking a hand for the other side swaps its fingers' names; what this recovers is the
        // price of that mistake, the rest is where the parts meet.
        let g = s.side_known.0.segmentation_scores(1);
        writeln!(
            f,
            "as if each hand's side were known (scored against the mirror hand's labels where those \
         fit better, {} of {} images): Acc {:.2}%, mIoU {:.2}%",
            s.side_known.1,
            // The last case, the pixels off the seams, takes every hand image.
            s.cases.last().map_or(0, |c| c.1),
            100.0 * g.pixel_accuracy,
            100.0 * g.mean_iou
        )?;
        Ok(())
    }
}
