//! Tactile image datasets on disk: what `skin synth` writes and `skin eval` reads. A user's own
//! dataset in the same layout works the same way.
//!
//! ```text
//! DIR/labels.csv        file,class,kind,subject,partial,fingertips   (one row per sample)
//! DIR/images/NAME.png   8-bit grey tactile image (68 x 100 by default)
//! DIR/masks/NAME.png    8-bit part labels, 0 background, 1 thumb ... 6 palm (hands only)
//! DIR/frames.txt        the raw readings, one frame per sample in row order (recording format)
//! DIR/taxel_parts.txt   the part pressing each taxel, same layout as frames.txt
//! DIR/map.json          the tactile map the images were made on
//! ```
//!
//! `class` is `hand` or `non_hand`; `kind` the interaction (`grasp`, `pull`, ...) or contact
//! (`ball`, `torso`, ...); `subject` the subject number (split train and test on it);
//! `partial` 1 when less than 85% of the contact lies on the skin; `fingertips` 1 for a hand
//! touching with its fingertips only.
//!
//! `file` names a file in `images/` (and `masks/`), subfolders allowed; a name that leaves the
//! folder (absolute, or through `..`) is refused as labels.csv is read, and a file that is a
//! symbolic link out of the dataset's folder when it is opened: a dataset from elsewhere cannot
//! make its reader open any file of the machine.

use crate::synth::Sample;
use skin_core::image::{ImageSize, ImageView};
use skin_core::text::{Gzip, Input, Lines};
use skin_core::{Frame, Recording, TaxelId};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A dataset error, naming the file (and line) at fault.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The dataset's files disagree (frame counts, taxels, image sizes).
    #[error("{path}: {message}")]
    Inconsistent {
        /// The file at fault.
        path: PathBuf,
        /// How it disagrees.
        message: String,
    },
    /// A line of labels.csv is malformed.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// One row of labels.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// File name under images/ (and masks/), inside them.
    pub file: String,
    /// The line of labels.csv it was read from (1-based).
    pub line: usize,
    /// A hand.
    pub hand: bool,
    /// Interaction or contact name.
    pub kind: String,
    /// Subject number.
    pub subject: u32,
    /// Less than 85% of the contact on the skin.
    pub partial: bool,
    /// A hand touching with its fingertips only.
    pub fingertips: bool,
}

/// A dataset directory and its labels.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// The directory.
    pub dir: PathBuf,
    /// Its samples, in row order.
    pub entries: Vec<Entry>,
}

const HEADER: &str = "file,class,kind,subject,partial,fingertips";

impl Dataset {
    /// The test set: indices of the samples of the last `fraction` of the subjects (by subject
    /// number; the whole dataset when `fraction` is 0 or there is one subject), hands only if
    /// `hands_only`. The same cut as `skin-learn/training/train.py`, so a model is scored on
    /// subjects it was not trained on.
    pub fn test_set(&self, fraction: f64, hands_only: bool) -> Vec<usize> {
        let keep = |i: &usize| !hands_only || self.entries[*i].hand;
        let mut subjects: Vec<u32> = self.entries.iter().map(|e| e.subject).collect();
        subjects.sort_unstable();
        subjects.dedup();
        if !(fraction > 0.0) || subjects.len() < 2 {
            return (0..self.entries.len()).filter(keep).collect();
        }
        // subjects[round(n * (1 - fraction))] on.
        let k =
            ((subjects.len() as f64 * (1.0 - fraction.min(1.0))).round() as usize).min(subjects.len() - 1);
        let cut = subjects[k];
        (0..self.entries.len())
            .filter(|&i| self.entries[i].subject >= cut)
            .filter(keep)
            .collect()
    }

    /// Reads `DIR/labels.csv`.
    pub fn read(dir: &Path) -> Result<Dataset, DatasetError> {
        let path = dir.join("labels.csv");
        let input = Input::open(&path, Gzip::Read).map_err(|e| text_error(&path, e))?;
        let mut lines = Lines::new(input, &path);
        match lines.next_line().map_err(|e| text_error(&path, e))? {
            Some(h) if h.trim() == HEADER => {}
            other => {
                let found = skin_core::format::excerpt(other.as_ref().map_or("", |h| h.text()));
                return Err(DatasetError::Parse {
                    path: path.clone(),
                    line: 1,
                    message: format!("expected the header `{HEADER}`, found `{found}`"),
                });
            }
        }
        let mut entries = Vec::new();
        while let Some(line) = lines.next_line().map_err(|e| text_error(&path, e))? {
            if line.trim().is_empty() {
                continue;
            }
            let bad = |message: String| DatasetError::Parse {
                path: path.clone(),
                line: line.number(),
                message,
            };
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            if f.len() != 6 {
                return Err(bad(format!("{} fields, expected 6 ({HEADER})", f.len())));
            }
            let flag = |s: &str, name: &str| match s {
                "0" => Ok(false),
                "1" => Ok(true),
                _ => Err(bad(format!("{name} must be 0 or 1, not `{s}`"))),
            };
            if let Some(why) = leaves_folder(f[0]) {
                return Err(bad(format!(
                    "file `{}` {why}: name a file in images/",
                    skin_core::format::excerpt(f[0])
                )));
            }
            entries.push(Entry {
                file: f[0].to_string(),
                line: line.number(),
                hand: match f[1] {
                    "hand" => true,
                    "non_hand" => false,
                    c => return Err(bad(format!("class must be hand or non_hand, not `{c}`"))),
                },
                kind: f[2].to_string(),
                subject: f[3]
                    .parse()
                    .map_err(|_| bad(format!("subject must be a whole number, not `{}`", f[3])))?,
                partial: flag(f[4], "partial")?,
                fingertips: flag(f[5], "fingertips")?,
            });
        }
        Ok(Dataset {
            dir: dir.to_path_buf(),
            entries,
        })
    }

    /// The grey image of entry `i`: (pixels row-major, rows, cols).
    pub fn image(&self, i: usize) -> Result<(Vec<u8>, usize, usize), DatasetError> {
        read_grey(&self.inside("images", self.entry(i)?)?)
    }

    /// The part mask of entry `i` (all background for a contact that is not a hand when the
    /// dataset has no mask for it).
    pub fn mask(&self, i: usize) -> Result<(Vec<u8>, usize, usize), DatasetError> {
        let e = self.entry(i)?;
        let path = self.inside("masks", e)?;
        if !e.hand && !path.exists() {
            let (img, r, c) = self.image(i)?;
            return Ok((vec![0; img.len()], r, c));
        }
        read_grey(&path)
    }

    /// `DIR/folder/FILE` of `entry`, refused if it resolves, through symbolic links, outside
    /// the dataset's folder (a file that does not exist is left for the reader to name).
    fn inside(&self, folder: &str, entry: &Entry) -> Result<PathBuf, DatasetError> {
        let path = self.dir.join(folder).join(&entry.file);
        if let (Ok(real), Ok(root)) = (path.canonicalize(), self.dir.canonicalize())
            && !real.starts_with(&root)
        {
            return Err(DatasetError::Parse {
                path: self.dir.join("labels.csv"),
                line: entry.line,
                message: format!(
                    "file `{}`: {} is a link to {}, outside the dataset's folder: refused",
                    skin_core::format::excerpt(&entry.file),
                    path.display(),
                    real.display()
                ),
            });
        }
        Ok(path)
    }

    fn entry(&self, i: usize) -> Result<&Entry, DatasetError> {
        self.entries.get(i).ok_or_else(|| DatasetError::Io {
            path: self.dir.join("labels.csv"),
            message: format!("no sample {i} (the dataset has {})", self.entries.len()),
        })
    }
}

/// Why a file name of labels.csv leaves the dataset's folder, if it does: empty, absolute, or
/// through `..` (a name joined to images/ must stay in it).
fn leaves_folder(name: &str) -> Option<&'static str> {
    use std::path::Component;
    if name.is_empty() {
        return Some("is empty");
    }
    let path = Path::new(name);
    // A backslash is a separator on Windows: `..\x` would leave the folder there.
    if path.is_absolute() || name.starts_with(['/', '\\']) {
        return Some("is an absolute path, outside the dataset's folder");
    }
    let up = path.components().any(|c| {
        matches!(
            c,
            Component::ParentDir | Component::RootDir | Component::Prefix(_)
        )
    }) || name.split(['/', '\\']).any(|part| part == "..");
    up.then_some("leaves the dataset's folder (..)")
}

/// A text input's error (it names its file and line) as a dataset error.
fn text_error(file: &Path, e: skin_core::Error) -> DatasetError {
    match e {
        skin_core::Error::Invalid { path, place, message } => DatasetError::Io {
            path,
            message: format!("{place}: {message}"),
        },
        skin_core::Error::Io { path, source } => DatasetError::Io {
            path,
            message: source.to_string(),
        },
        e => DatasetError::Io {
            path: file.to_owned(),
            message: e.to_string(),
        },
    }
}

/// Reads an 8-bit grey PNG: (pixels, rows, cols).
pub fn read_grey(path: &Path) -> Result<(Vec<u8>, usize, usize), DatasetError> {
    let img = image::open(path).map_err(|e| DatasetError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    if img.color() != image::ColorType::L8 {
        return Err(DatasetError::Io {
            path: path.to_path_buf(),
            message: format!("expected an 8-bit grey image, found {:?}", img.color()),
        });
    }
    let grey = img.into_luma8();
    let (w, h) = grey.dimensions();
    Ok((grey.into_raw(), h as usize, w as usize))
}

/// Writes a dataset directory sample by sample.
#[derive(Debug)]
pub struct DatasetWriter {
    dir: PathBuf,
    csv: String,
    frames: Recording,
    parts: Recording,
    size: ImageSize,
}

impl DatasetWriter {
    /// Creates `dir` (and images/, masks/) for images of `size` (rows, cols) over the taxels
    /// `ids`, and writes the map as `map_json`.
    pub fn create(
        dir: &Path,
        ids: &[TaxelId],
        map_json: &str,
        size: ImageSize,
    ) -> Result<DatasetWriter, DatasetError> {
        for sub in ["images", "masks"] {
            let d = dir.join(sub);
            std::fs::create_dir_all(&d).map_err(|e| io(&d, e))?;
        }
        let map = dir.join("map.json");
        std::fs::write(&map, map_json).map_err(|e| io(&map, e))?;
        let empty = Recording {
            taxel_ids: ids.to_vec(),
            ..Default::default()
        };
        Ok(DatasetWriter {
            dir: dir.to_path_buf(),
            csv: format!("{HEADER}\n"),
            frames: empty.clone(),
            parts: empty,
            size,
        })
    }

    /// Adds one sample, named by `index`.
    pub fn add(&mut self, index: usize, s: &Sample) -> Result<(), DatasetError> {
        let file = format!("{index:06}.png");
        let ImageSize { rows, cols } = self.size;
        let png = |name: &str, pixels: &[u8]| {
            let path = self.dir.join(name).join(&file);
            let io = |message: String| DatasetError::Io {
                path: path.clone(),
                message,
            };
            let image = ImageView::new(pixels, ImageSize { rows, cols }).map_err(|e| io(e.to_string()))?;
            skin_geom::write_png(&path, image).map_err(|e| io(e.to_string()))
        };
        png("images", &s.image)?;
        if s.kind.is_hand() {
            png("masks", &s.mask)?;
        }
        let _ = writeln!(
            self.csv,
            "{file},{},{},{},{},{}",
            if s.kind.is_hand() { "hand" } else { "non_hand" },
            s.kind.name(),
            s.subject,
            u8::from(s.partial),
            u8::from(s.fingertips_only)
        );
        let number = index as u64;
        self.frames.frame_numbers.push(number);
        self.frames.frames.push(Frame {
            time: 0.0,
            values: s.pressures.clone(),
        });
        self.parts.frame_numbers.push(number);
        self.parts.frames.push(Frame {
            time: 0.0,
            values: s.taxel_parts.iter().map(|&p| f32::from(p)).collect(),
        });
        Ok(())
    }

    /// Writes labels.csv, frames.txt and taxel_parts.txt.
    pub fn finish(self) -> Result<(), DatasetError> {
        let csv = self.dir.join("labels.csv");
        std::fs::write(&csv, &self.csv).map_err(|e| io(&csv, e))?;
        for (name, rec) in [("frames.txt", &self.frames), ("taxel_parts.txt", &self.parts)] {
            let path = self.dir.join(name);
            skin_core::format::recording::write(&path, rec).map_err(|e| DatasetError::Io {
                path: path.clone(),
                message: e.to_string(),
            })?;
        }
        Ok(())
    }
}

fn io(path: &Path, e: std::io::Error) -> DatasetError {
    DatasetError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_test_set_is_the_last_subjects_samples() {
        // Subjects 1..=4, two samples each, the second of each a hand.
        let entries = (0..8)
            .map(|k| Entry {
                file: format!("{k}.png"),
                line: 2 + k as usize,
                hand: k % 2 == 1,
                kind: String::new(),
                subject: 1 + k / 2,
                partial: false,
                fingertips: false,
            })
            .collect();
        let data = Dataset {
            dir: PathBuf::from("d"),
            entries,
        };
        // A quarter of 4 subjects: the last one.
        assert_eq!(data.test_set(0.25, false), [6, 7]);
        assert_eq!(data.test_set(0.5, true), [5, 7]);
        // Nothing held out: everything; NaN and more than all are clamped, never a panic.
        assert_eq!(data.test_set(0.0, false).len(), 8);
        assert_eq!(data.test_set(f64::NAN, true), [1, 3, 5, 7]);
        assert_eq!(data.test_set(1.0, false).len(), 8);
    }

    #[test]
    fn a_file_name_that_leaves_the_folder_is_refused() {
        for name in ["../x.png", "a/../../x.png", "/etc/passwd", "..\\x.png", ""] {
            assert!(leaves_folder(name).is_some(), "{name:?}");
        }
        for name in ["x.png", "sub/x.png", "x..png", "..x.png"] {
            assert_eq!(leaves_folder(name), None, "{name:?}");
        }
    }
}
