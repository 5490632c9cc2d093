//! Synthetic labelled contacts straight to arrays (`synthesize`, what `skin synth` writes), and the
//! images of a `skin synth` dataset (`read_grey`, for `skin.SynthDataset`).

use crate::arrays;
use crate::errors::{self, Kind, arg};
use crate::geometry::TactileMap;
use crate::interrupt::{self, Watch};
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use skin_learn::synth::{DeadSpots, MaskLabels, Removal, SynthOptions, Synthesizer};
use std::path::PathBuf;
use std::sync::atomic::Ordering;

/// The most memory the arrays of one call may take, bytes (as `skin synth`).
const MAX_BYTES: usize = 8 << 30;

/// `count` labelled contacts on `map`, the samples `skin synth` makes with the same `seed` (1),
/// `subjects` (one per 40 samples; at most `count`) and `size` (68, 100) (sample i belongs to subject i * subjects / count): a dict of `images`
/// and part `masks` (S, rows, cols) uint8, `hand` (S,) bool, `kind` (names), `subject` (S,),
/// `partial` and `fingertips` (S,) bool, `pressures` (S, N) float32 and `taxel_parts` (S, N) uint8
/// in map order, and `removed` and `dead` (S,) float64: the fraction of the taxels removed from,
/// or dead in blind spots on, the map each image was made on (0 for the whole map). Made in
/// parallel with the GIL released; Ctrl-C stops it within a sample and raises
/// `KeyboardInterrupt`, nothing returned.
///
/// The options are those of `skin synth`: `mask_labels` ("pressing" or "as-imaged"),
/// `remove_up_to` with `thinned_share` (0.5), `blind_spots` with `blind_radius_mm` (40) and
/// `blind_share` (0.3), `small_objects` (0: the share of non-hand samples that are small rigid
/// prints, a knob or a rod); a share or radius given without the option it belongs to is refused.
///
/// `part=(start, stop)` makes only samples `start` to `stop - 1` of the `count`: the same arrays
/// as `synthesize(map, count)[start:stop]`, each sample a function of the seed, its subject and
/// its index alone, so that shards made anywhere, in any order, join into the whole set
/// (`skin.ray.synthesize`).
#[pyfunction]
#[pyo3(signature = (
    map, count, *, seed = None, subjects = None, size = None, hand_fraction = 0.5,
    mask_labels = "pressing", remove_up_to = None, thinned_share = None, blind_spots = None,
    blind_radius_mm = None, blind_share = None, small_objects = 0.0, part = None
))]
#[allow(clippy::too_many_arguments)] // keyword arguments, as `skin synth` has options
pub(crate) fn synthesize<'py>(
    py: Python<'py>,
    map: &TactileMap,
    count: &Bound<'py, PyAny>,
    seed: Option<&Bound<'py, PyAny>>,
    subjects: Option<&Bound<'py, PyAny>>,
    size: Option<&Bound<'py, PyAny>>,
    hand_fraction: f64,
    mask_labels: &str,
    remove_up_to: Option<f64>,
    thinned_share: Option<f64>,
    blind_spots: Option<&Bound<'py, PyAny>>,
    blind_radius_mm: Option<f64>,
    blind_share: Option<f64>,
    small_objects: f64,
    part: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let count = arrays::count("count", count)?;
    let (start, stop) = part.map_or(Ok((0, count)), |p| arrays::pair("part", p))?;
    if start >= stop || stop > count {
        return Err(arg(
            "part",
            format!("({start}, {stop}): expected start < stop <= count ({count})"),
        ));
    }
    let seed = seed.map_or(Ok(1), |s| arrays::count("seed", s))? as u64;
    let subjects = subjects.map(|s| arrays::count("subjects", s)).transpose()?;
    if subjects == Some(0) {
        return Err(arg("subjects", "0: at least one"));
    }
    let (rows, cols) = size.map_or(Ok((68, 100)), |s| arrays::pair("size", s))?;
    let image = skin_core::image::ImageSize::new(rows, cols).map_err(|e| arg("size", e))?;
    if count == 0 {
        return Err(arg("count", "0: at least one sample"));
    }
    let n = map.inner.ids.len();
    let bytes = (stop - start).saturating_mul(image.pixels() * 2 + n * 5);
    if bytes > MAX_BYTES {
        return Err(arg(
            "count",
            format!(
                "{} samples would take {:.1} GB; at most {} GB a call",
                stop - start,
                bytes as f64 / 1e9,
                MAX_BYTES >> 30
            ),
        ));
    }
    if !(0.0..=1.0).contains(&hand_fraction) {
        return Err(arg(
            "hand_fraction",
            format!("{}: expected 0 to 1", arrays::num(hand_fraction)),
        ));
    }
    if !(0.0..=1.0).contains(&small_objects) {
        return Err(arg("small_objects", format!("{small_objects}: expected 0 to 1")));
    }
    let subjects = subjects.unwrap_or(count.div_ceil(40)).clamp(1, count);
    let labels = match mask_labels {
        "pressing" => MaskLabels::Pressing,
        "as-imaged" => MaskLabels::AsImaged,
        other => {
            return Err(arg(
                "mask_labels",
                format!("{other:?}: expected \"pressing\" or \"as-imaged\""),
            ));
        }
    };
    let options = SynthOptions {
        image_size: image,
        hand_fraction,
        labels,
        small_objects,
        ..SynthOptions::default()
    };
    let blind_spots = blind_spots.map(|b| arrays::count("blind_spots", b)).transpose()?;
    let degrade = Degrade::new(
        remove_up_to,
        thinned_share,
        blind_spots,
        blind_radius_mm,
        blind_share,
    )?;
    let synth = degrade.on(
        Synthesizer::new(&map.inner, options).map_err(|e| errors::raise(Kind::Geometry, &e))?,
        &map.inner,
        seed,
    )?;
    let samples = sample_all(py, &synth, seed, subjects, count, start..stop)?;
    samples_dict(py, &samples, image, map.inner.ids.len())
}

/// Samples `part` of the `count` samples of `subjects` subjects, made in parallel with the GIL
/// released (sample i belongs to subject i * subjects / count); Ctrl-C stops it within a
/// sample.
fn sample_all(
    py: Python<'_>,
    synth: &Synthesizer,
    seed: u64,
    subjects: usize,
    count: usize,
    part: std::ops::Range<usize>,
) -> PyResult<Vec<skin_learn::synth::Sample>> {
    let watch = Watch::new();
    let samples: Option<Vec<_>> = py.detach(|| {
        interrupt::on_worker(&watch, |stop| {
            part.clone()
                .into_par_iter()
                .map_init(
                    || synth.clone(),
                    |s, i| {
                        if stop.load(Ordering::Relaxed) {
                            return None;
                        }
                        let subject = i * subjects / count;
                        let first = (subject * count).div_ceil(subjects);
                        Some(s.sample(seed, subject as u32, (i - first) as u32))
                    },
                )
                .collect()
        })
    });
    // Only a stop leaves a sample out.
    samples.ok_or_else(|| {
        watch
            .raised()
            .unwrap_or_else(|| errors::error(Kind::Other, "synthesize: stopped before every sample was made"))
    })
}

/// `synthesize`'s degraded maps: taxels removed (Test B) and blind spots (Test A), as `skin synth
/// --remove-up-to` and `--blind-spots` make them, with the same ranges.
struct Degrade {
    remove_up_to: Option<f64>,
    thinned_share: f64,
    blind_spots: Option<usize>,
    blind_radius_mm: f64,
    blind_share: f64,
}

impl Degrade {
    /// The options with their defaults, refusing a share or radius without its option (as `skin
    /// synth` refuses `--blind-share` without `--blind-spots`): it would be silently ignored.
    fn new(
        remove_up_to: Option<f64>,
        thinned_share: Option<f64>,
        blind_spots: Option<usize>,
        blind_radius_mm: Option<f64>,
        blind_share: Option<f64>,
    ) -> PyResult<Self> {
        let needs = |name: &str, given: bool, option: &str, set: bool| {
            if given && !set {
                Err(arg(name, format!("only with {option}")))
            } else {
                Ok(())
            }
        };
        needs(
            "thinned_share",
            thinned_share.is_some(),
            "remove_up_to",
            remove_up_to.is_some(),
        )?;
        needs(
            "blind_share",
            blind_share.is_some(),
            "blind_spots",
            blind_spots.is_some(),
        )?;
        needs(
            "blind_radius_mm",
            blind_radius_mm.is_some(),
            "blind_spots",
            blind_spots.is_some(),
        )?;
        Ok(Degrade {
            remove_up_to,
            thinned_share: thinned_share.unwrap_or(0.5),
            blind_spots,
            blind_radius_mm: blind_radius_mm.unwrap_or(40.0),
            blind_share: blind_share.unwrap_or(0.3),
        })
    }

    /// `synth` with the degraded maps asked for; an error naming the argument at fault.
    fn on(&self, mut synth: Synthesizer, map: &skin_geom::TactileMap, seed: u64) -> PyResult<Synthesizer> {
        let within = |name: &str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(arg(name, format!("{}: expected {lo} to {hi}", arrays::num(v))))
            }
        };
        within("thinned_share", self.thinned_share, 0.0, 1.0)?;
        within("blind_share", self.blind_share, 0.0, 1.0)?;
        if self.remove_up_to.is_some()
            && self.blind_spots.is_some()
            && self.thinned_share + self.blind_share > 1.0
        {
            return Err(arg(
                "blind_share",
                format!(
                    "{} with thinned_share {}: more than 1 together; a sample is imaged through one degraded map at most",
                    self.blind_share, self.thinned_share
                ),
            ));
        }
        let geometry = |e: skin_geom::Error| errors::raise(Kind::Geometry, &e);
        if let Some(up_to) = self.remove_up_to {
            within("remove_up_to", up_to, 0.01, 0.95)?;
            let removal = Removal {
                share: self.thinned_share,
                up_to,
                maps: Removal::MAPS,
            };
            synth = synth.with_removal(map, removal, seed).map_err(geometry)?;
        }
        if let Some(spots) = self.blind_spots {
            if !(1..=64).contains(&spots) {
                return Err(arg("blind_spots", format!("{spots}: expected 1 to 64")));
            }
            if !(self.blind_radius_mm.is_finite()
                && self.blind_radius_mm > 0.0
                && self.blind_radius_mm <= 1e3)
            {
                return Err(arg(
                    "blind_radius_mm",
                    format!(
                        "{}: expected above 0, at most 1000 mm",
                        arrays::num(self.blind_radius_mm)
                    ),
                ));
            }
            let dead = DeadSpots {
                share: self.blind_share,
                spots,
                radius_mm: self.blind_radius_mm,
                maps: DeadSpots::MAPS,
            };
            synth = synth.with_dead_spots(map, dead, seed).map_err(geometry)?;
        }
        Ok(synth)
    }
}

/// The samples as the arrays `synthesize` returns.
fn samples_dict<'py>(
    py: Python<'py>,
    samples: &[skin_learn::synth::Sample],
    image: skin_core::image::ImageSize,
    n: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let count = samples.len();
    let px = image.pixels();
    let shape = [count, image.rows, image.cols];
    let flat = |f: &dyn Fn(&skin_learn::synth::Sample) -> &[u8], len: usize| -> Vec<u8> {
        let mut v = Vec::with_capacity(count * len);
        for s in samples {
            v.extend_from_slice(f(s));
        }
        v
    };
    let d = PyDict::new(py);
    d.set_item("images", arrays::out(py, flat(&|s| &s.image, px), &shape)?)?;
    d.set_item("masks", arrays::out(py, flat(&|s| &s.mask, px), &shape)?)?;
    d.set_item(
        "taxel_parts",
        arrays::out(py, flat(&|s| &s.taxel_parts, n), &[count, n])?,
    )?;
    let mut pressures = Vec::with_capacity(count * n);
    for s in samples {
        pressures.extend_from_slice(&s.pressures);
    }
    d.set_item("pressures", arrays::out(py, pressures, &[count, n])?)?;
    let column =
        |f: &dyn Fn(&skin_learn::synth::Sample) -> bool| samples.iter().map(f).collect::<Vec<bool>>();
    d.set_item("hand", arrays::out(py, column(&|s| s.kind.is_hand()), &[count])?)?;
    d.set_item("partial", arrays::out(py, column(&|s| s.partial), &[count])?)?;
    d.set_item(
        "fingertips",
        arrays::out(py, column(&|s| s.fingertips_only), &[count])?,
    )?;
    d.set_item(
        "subject",
        arrays::out(
            py,
            samples.iter().map(|s| s.subject).collect::<Vec<u32>>(),
            &[count],
        )?,
    )?;
    d.set_item("kind", samples.iter().map(|s| s.kind.name()).collect::<Vec<_>>())?;
    let fraction =
        |f: &dyn Fn(&skin_learn::synth::Sample) -> f64| samples.iter().map(f).collect::<Vec<f64>>();
    d.set_item("removed", arrays::out(py, fraction(&|s| s.removed), &[count])?)?;
    d.set_item("dead", arrays::out(py, fraction(&|s| s.dead), &[count])?)?;
    Ok(d)
}

/// Reads an 8-bit grey PNG (a `skin synth` image or mask) as (rows, cols) uint8.
#[pyfunction]
pub(crate) fn read_grey<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
    let (pixels, rows, cols) =
        skin_learn::dataset::read_grey(&path).map_err(|e| errors::raise(Kind::Input, &e))?;
    arrays::out(py, pixels, &[rows, cols])
}

/// The samples of a dataset folder (`labels.csv`, `images/`, `masks/`: what `skin synth` writes),
/// read as `skin eval` reads them: what `skin.SynthDataset` stands on. A file name of
/// labels.csv that leaves the folder is refused with its line, when the folder is read; a file
/// that links out of it, when it is opened.
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct Dataset {
    inner: skin_learn::dataset::Dataset,
}

#[pymethods]
impl Dataset {
    /// Reads `root/labels.csv`.
    #[new]
    fn new(root: PathBuf) -> PyResult<Dataset> {
        let inner = skin_learn::dataset::Dataset::read(&root).map_err(|e| errors::raise(Kind::Input, &e))?;
        Ok(Dataset { inner })
    }

    /// Each sample as (file, hand, kind, subject, partial, fingertips), in row order.
    #[getter]
    fn entries(&self) -> Vec<(String, bool, String, u32, bool, bool)> {
        self.inner
            .entries
            .iter()
            .map(|e| {
                (
                    e.file.clone(),
                    e.hand,
                    e.kind.clone(),
                    e.subject,
                    e.partial,
                    e.fingertips,
                )
            })
            .collect()
    }

    /// Sample `i`'s image, (rows, cols) uint8.
    fn image<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        let (pixels, rows, cols) = self.inner.image(i).map_err(|e| errors::raise(Kind::Input, &e))?;
        arrays::out(py, pixels, &[rows, cols])
    }

    /// Sample `i`'s part mask, (rows, cols) uint8 (all background for a sample that is not a
    /// hand and has no mask file).
    fn mask<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
        let (pixels, rows, cols) = self.inner.mask(i).map_err(|e| errors::raise(Kind::Input, &e))?;
        arrays::out(py, pixels, &[rows, cols])
    }

    fn __len__(&self) -> usize {
        self.inner.entries.len()
    }
}
