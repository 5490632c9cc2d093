//! Scoring a run against a script of touches: which scripted touch each found touch is, and
//! whether its class was right (how `skin run` reports a recorded session with known touches).
//!
//! A script is a text file, one touch per line, fields separated by tabs:
//!
//! ```text
//! # touch  start s  end s  class     kind       (more fields are ignored)
//! 0        1.00     2.00   hand      grasp      1003
//! 1        2.50     3.50   non_hand  bar        1008
//! ```
//! Blank lines and lines starting with `#` are skipped. A scripted touch is matched with the
//! found touch that overlaps it the longest (touching ends count as overlapping); a found touch
//! that no scripted touch took is extra.
//!
//! ```
//! use skin_runtime::script::{Found, Script};
//!
//! let script = Script::parse("0\t1.0\t2.0\thand\tgrasp\n1\t3.0\t4.0\tnon_hand\tball\n", "s.tsv".as_ref())?;
//! let found = [
//!     Found { start_s: 1.05, end_s: 2.1, class: Some("hand") },
//!     Found { start_s: 3.1, end_s: 3.9, class: Some("hand") },
//!     Found { start_s: 6.0, end_s: 6.5, class: None },
//! ];
//! let score = script.score(&found);
//! assert_eq!((score.found(), score.right(), score.extra(&found)), (2, 1, 1));
//! # Ok::<(), skin_core::Error>(())
//! ```

use skin_core::format::excerpt;
use skin_core::text::{Gzip, Input, Lines};
use skin_core::{Error, Result};
use std::io::BufRead;
use std::path::Path;

/// One touch of the script.
#[derive(Debug, Clone, PartialEq)]
pub struct Scripted {
    /// When it starts and ends, seconds on the recording's clock.
    pub start_s: f64,
    /// See `start_s`.
    pub end_s: f64,
    /// The class it should get (`hand`, `non_hand`, or a model card's class).
    pub class: String,
    /// What it was (`grasp`, `ball`, ...), for reports.
    pub kind: String,
}

/// The touches a run should find.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Script {
    /// In file order.
    pub touches: Vec<Scripted>,
}

/// A touch a run found: its span and the class it was given (`None`: never decided).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Found<'a> {
    /// When it appeared and was released, seconds.
    pub start_s: f64,
    /// See `start_s`.
    pub end_s: f64,
    /// Its decided class.
    pub class: Option<&'a str>,
}

/// How a run did against a script.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Score {
    /// For each scripted touch, the index of the found touch matched with it.
    pub matches: Vec<Option<usize>>,
    /// For each scripted touch, whether its match got the scripted class.
    pub correct: Vec<bool>,
}

impl Script {
    /// Reads a script file, line by line (gzip-compressed too).
    pub fn read(path: &Path) -> Result<Script> {
        Script::from_reader(Input::open(path, Gzip::Read)?, path)
    }

    /// Parses a script; `path` names it in errors. Times must be finite, and no touch may end
    /// before it starts.
    pub fn parse(text: &str, path: &Path) -> Result<Script> {
        Script::from_reader(text.as_bytes(), path)
    }

    /// Reads a script from any text input, line by line; `path` names it in errors.
    pub fn from_reader(reader: impl BufRead, path: &Path) -> Result<Script> {
        let mut touches = Vec::new();
        let mut lines = Lines::new(reader, path);
        while let Some(line) = lines.next_line()? {
            if line.trim().is_empty() || line.starts_with('#') {
                continue;
            }
            let n = line.number() - 1;
            let f: Vec<&str> = line.split('\t').map(str::trim).collect();
            let place = |field: usize| format!("line {} field {}", n + 1, field + 1);
            let time = |i: usize, what: &str| -> Result<f64> {
                let field = f.get(i).copied().unwrap_or_default();
                field
                    .parse::<f64>()
                    .ok()
                    .filter(|t| t.is_finite())
                    .ok_or_else(|| {
                        Error::invalid(
                            path,
                            place(i),
                            format!("{what} \"{}\" is not a finite number of seconds", excerpt(field)),
                        )
                    })
            };
            let (start_s, end_s) = (time(1, "start")?, time(2, "end")?);
            if end_s < start_s {
                return Err(Error::invalid(
                    path,
                    place(2),
                    format!("the touch ends at {end_s} s, before it starts ({start_s} s)"),
                ));
            }
            let class = match f.get(3) {
                Some(c) if !c.is_empty() => c.to_string(),
                _ => return Err(Error::invalid(path, place(3), "no class (the 4th field)")),
            };
            touches.push(Scripted {
                start_s,
                end_s,
                class,
                kind: f.get(4).map_or(String::new(), |s| s.to_string()),
            });
        }
        Ok(Script { touches })
    }

    /// Matches each scripted touch with the found touch overlapping it the longest.
    pub fn score(&self, found: &[Found<'_>]) -> Score {
        let mut tally = Tally::new(self.clone());
        for f in found {
            tally.add(f);
        }
        tally.score()
    }
}

/// The found touch a scripted touch is matched with so far.
#[derive(Debug, Clone, PartialEq)]
struct Best {
    /// Seconds of overlap (0 where their ends touch).
    overlap: f64,
    /// Its index among the touches found.
    index: usize,
    /// The class it was given.
    class: Option<Box<str>>,
}

/// A score kept as found touches come, one at a time: memory per scripted touch, whatever the
/// number of touches found, so a session of any length scores itself without keeping its
/// touches. [`Script::score`] is this over a list.
///
/// ```
/// use skin_runtime::script::{Found, Script, Tally};
///
/// let script = Script::parse("0\t1.0\t2.0\thand\tgrasp\n", "s.tsv".as_ref())?;
/// let mut tally = Tally::new(script);
/// tally.add(&Found { start_s: 1.05, end_s: 2.1, class: Some("hand") });
/// tally.add(&Found { start_s: 6.0, end_s: 6.5, class: None });
/// let score = tally.score();
/// assert_eq!((score.found(), score.right(), score.extra_among(tally.found())), (1, 1, 1));
/// # Ok::<(), skin_core::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Tally {
    script: Script,
    /// For each scripted touch, its match so far.
    best: Vec<Option<Best>>,
    /// Found touches taken.
    found: usize,
}

impl Tally {
    /// A tally of `script` with no touch found yet.
    pub fn new(script: Script) -> Tally {
        Tally {
            best: vec![None; script.touches.len()],
            script,
            found: 0,
        }
    }

    /// The script it scores against.
    pub fn script(&self) -> &Script {
        &self.script
    }

    /// The script, for a tally started again.
    pub fn into_script(self) -> Script {
        self.script
    }

    /// Takes the next found touch (its index is the number taken before it). A scripted touch
    /// it overlaps at least as long as its match so far takes it instead: of equal overlaps,
    /// the later touch.
    pub fn add(&mut self, found: &Found<'_>) {
        let index = self.found;
        self.found += 1;
        for (t, best) in self.script.touches.iter().zip(&mut self.best) {
            let overlap = found.end_s.min(t.end_s) - found.start_s.max(t.start_s);
            if !(overlap >= 0.0)
                || best
                    .as_ref()
                    .is_some_and(|b| overlap.total_cmp(&b.overlap).is_lt())
            {
                continue;
            }
            *best = Some(Best {
                overlap,
                index,
                class: found.class.map(Box::from),
            });
        }
    }

    /// Found touches taken so far.
    pub fn found(&self) -> usize {
        self.found
    }

    /// The class given to the found touch matched with scripted touch `scripted` (none if
    /// none matched, or it was never decided).
    pub fn class_of(&self, scripted: usize) -> Option<&str> {
        self.best.get(scripted)?.as_ref()?.class.as_deref()
    }

    /// The score of the touches taken so far.
    pub fn score(&self) -> Score {
        let matches = self.best.iter().map(|b| b.as_ref().map(|b| b.index)).collect();
        let correct = self
            .script
            .touches
            .iter()
            .zip(&self.best)
            .map(|(t, b)| {
                b.as_ref()
                    .is_some_and(|b| b.class.as_deref() == Some(t.class.as_str()))
            })
            .collect();
        Score { matches, correct }
    }
}

impl Score {
    /// Scripted touches that were found.
    pub fn found(&self) -> usize {
        self.matches.iter().flatten().count()
    }

    /// Scripted touches found with the right class.
    pub fn right(&self) -> usize {
        self.correct.iter().filter(|&&c| c).count()
    }

    /// Found touches that no scripted touch took.
    pub fn extra(&self, found: &[Found<'_>]) -> usize {
        self.extra_among(found.len())
    }

    /// Of `found` touches found (numbered from 0), those that no scripted touch took.
    pub fn extra_among(&self, found: usize) -> usize {
        let mut taken: Vec<usize> = self
            .matches
            .iter()
            .flatten()
            .copied()
            .filter(|&j| j < found)
            .collect();
        taken.sort_unstable();
        taken.dedup();
        found - taken.len()
    }

    /// For each found touch, the scripted touch matched with it.
    pub fn scripted_of(&self, found: usize) -> Option<usize> {
        // The last one, if several scripted touches took it.
        self.matches.iter().rposition(|&m| m == Some(found))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn each_scripted_touch_takes_the_found_touch_overlapping_it_the_longest() {
        let script = Script::parse(
            "# header\n0\t1.0\t2.0\thand\tgrasp\n\n1\t3.0\t4.0\tnon_hand\tball\n2\t5.0\t6.0\thand\tpoke\n",
            Path::new("s.tsv"),
        )
        .unwrap();
        assert_eq!(script.touches.len(), 3);
        let found = [
            Found {
                start_s: 0.5,
                end_s: 1.2,
                class: Some("non_hand"),
            }, // overlaps touch 0 by 0.2 s
            Found {
                start_s: 1.3,
                end_s: 2.5,
                class: Some("hand"),
            }, // ...and this one by 0.7 s
            Found {
                start_s: 4.0,
                end_s: 4.5,
                class: None,
            }, // touches touch 1's end
            Found {
                start_s: 8.0,
                end_s: 9.0,
                class: Some("hand"),
            }, // not scripted
        ];
        let score = script.score(&found);
        assert_eq!(score.matches, [Some(1), Some(2), None]);
        assert_eq!(score.correct, [true, false, false]);
        assert_eq!((score.found(), score.right(), score.extra(&found)), (2, 1, 2));
        assert_eq!(score.scripted_of(1), Some(0));
        assert_eq!(score.scripted_of(0), None);
    }

    /// The match of each scripted touch as a list scores it all at once: the found touch of
    /// longest overlap, the last of equals.
    fn longest_overlaps(script: &Script, found: &[Found<'_>]) -> Vec<Option<usize>> {
        let overlap = |t: &Scripted, d: &Found<'_>| d.end_s.min(t.end_s) - d.start_s.max(t.start_s);
        script
            .touches
            .iter()
            .map(|t| {
                (0..found.len())
                    .filter(|&j| overlap(t, &found[j]) >= 0.0)
                    .max_by(|&a, &b| overlap(t, &found[a]).total_cmp(&overlap(t, &found[b])))
            })
            .collect()
    }

    proptest::proptest! {
        /// Touches taken one at a time score as the whole list does: matches, classes, extras.
        #[test]
        fn a_tally_scores_as_the_whole_list(
            scripted in proptest::collection::vec((0u8..20, 0u8..4, proptest::bool::ANY), 0..6),
            found in proptest::collection::vec((0u8..20, 0u8..4, 0u8..3), 0..12),
        ) {
            let classes = ["hand", "non_hand"];
            let script = Script {
                touches: scripted
                    .iter()
                    .map(|&(start, len, hand)| Scripted {
                        start_s: f64::from(start) * 0.5,
                        end_s: f64::from(start + len) * 0.5,
                        class: classes[usize::from(!hand)].into(),
                        kind: String::new(),
                    })
                    .collect(),
            };
            let found: Vec<Found<'_>> = found
                .iter()
                .map(|&(start, len, class)| Found {
                    start_s: f64::from(start) * 0.5,
                    end_s: f64::from(start + len) * 0.5,
                    class: classes.get(usize::from(class)).copied(),
                })
                .collect();
            let mut tally = Tally::new(script.clone());
            for f in &found {
                tally.add(f);
            }
            let score = tally.score();
            let matches = longest_overlaps(&script, &found);
            proptest::prop_assert_eq!(&score.matches, &matches);
            for (k, m) in matches.iter().enumerate() {
                let class = m.and_then(|j| found[j].class);
                proptest::prop_assert_eq!(tally.class_of(k), class);
                proptest::prop_assert_eq!(score.correct[k], class == Some(script.touches[k].class.as_str()));
            }
            let extra = (0..found.len()).filter(|j| !matches.contains(&Some(*j))).count();
            proptest::prop_assert_eq!(score.extra(&found), extra);
            proptest::prop_assert_eq!(score.extra_among(tally.found()), extra);
            proptest::prop_assert_eq!(script.score(&found), score);
        }
    }

    #[test]
    fn bad_lines_are_named() {
        for (text, want) in [
            ("0\t1.0\tsoon\thand\n", "line 1 field 3"),
            ("0\t1.0\tNaN\thand\n", "finite"),
            ("0\t2.0\t1.0\thand\n", "before it starts"),
            ("0\t1.0\t2.0\n", "no class"),
        ] {
            let e = Script::parse(text, Path::new("s.tsv")).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("s.tsv"), "{text:?}: {e}");
        }
    }
}
