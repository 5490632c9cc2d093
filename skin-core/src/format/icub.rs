//! iCub skin taxel files (`icub-main/app/skinGui/conf/positions/*.txt`).
//!
//! A header of `key value` lines (`name`, `spatial_sampling`, `taxel2Repr (...)`), then a line
//! `[calibration]`, then one row per taxel slot: `x y z nx ny nz`, metres in the link frame. Slots
//! come 12 per triangular module. A row of zeros is an unused slot (a thermal pad or a missing
//! module) and is dropped. Taxel ids are the slot index (0-based row after `[calibration]`).
//!
//! Several slots can carry the same position (the files give some taxels their module's position).
//! [`Duplicates`] says what to do with them; either way the rows are reported.

use super::make_taxel;
use crate::text::{Gzip, Input, Lines};
use crate::{Error, LinkSkin, Result, TaxelId};
use std::collections::HashMap;
use std::io::BufRead;
use std::path::Path;

/// What to do with taxels whose position repeats an earlier one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Duplicates {
    /// Keep the first taxel at each position and drop the others (listed in the report).
    Merge,
    /// Fail with an error naming the rows.
    Reject,
}

/// Taxels sharing one position: the first is kept when merging.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DuplicateGroup {
    /// Slot indices (taxel ids), first one kept.
    pub slots: Vec<usize>,
    /// 1-based line numbers in the file, same order.
    pub lines: Vec<usize>,
}

/// The result of reading an iCub taxel file.
#[derive(Debug, Clone, PartialEq)]
pub struct IcubPositions {
    /// The link's taxels (all-zero rows dropped, duplicates merged).
    pub skin: LinkSkin,
    /// Slots whose row was all zeros (unused), dropped.
    pub zero_slots: Vec<usize>,
    /// Groups of slots with the same position.
    pub duplicates: Vec<DuplicateGroup>,
    /// Slots with a position that the header's `taxel2Repr` says are not taxels (a negative
    /// entry: a thermal pad, an unused slot), dropped.
    pub not_taxels: Vec<usize>,
    /// Taxels (slots) whose row gives a position and an all-zero normal: their normals are
    /// estimated from the neighbouring taxels ([`crate::normals`]).
    pub estimated_normals: Vec<usize>,
}

impl IcubPositions {
    /// What reading `path` did: the rows it dropped, the taxels it merged.
    pub fn notes(&self, path: &Path) -> Vec<super::Note> {
        let merged: usize = self
            .duplicates
            .iter()
            .map(|g| g.slots.len().saturating_sub(1))
            .sum();
        let mut notes = vec![super::Note::IcubRows {
            path: path.to_owned(),
            rows: self.skin.taxels.len() + self.zero_slots.len() + merged + self.not_taxels.len(),
            unused: self.zero_slots.clone(),
        }];
        if !self.duplicates.is_empty() {
            notes.push(super::Note::MergedDuplicates {
                path: path.to_owned(),
                groups: self.duplicates.clone(),
            });
        }
        if !self.not_taxels.is_empty() {
            notes.push(super::Note::NotTaxels {
                path: path.to_owned(),
                slots: self.not_taxels.clone(),
            });
        }
        if !self.estimated_normals.is_empty() {
            notes.push(super::Note::EstimatedNormals {
                path: path.to_owned(),
                taxels: self.estimated_normals.len(),
            });
        }
        notes
    }
}

/// Reads an iCub taxel file, line by line (a compressed file is refused with the command that
/// decompresses it).
pub fn read(path: &Path, duplicates: Duplicates) -> Result<IcubPositions> {
    from_reader(Input::open(path, Gzip::Refuse)?, path, duplicates)
}

/// Parses an iCub taxel file; `path` is used in error messages.
pub fn parse(text: &str, path: &Path, duplicates: Duplicates) -> Result<IcubPositions> {
    from_reader(text.as_bytes(), path, duplicates)
}

/// Reads an iCub taxel file from any text input, line by line; `path` is used in error messages.
pub fn from_reader(reader: impl BufRead, path: &Path, duplicates: Duplicates) -> Result<IcubPositions> {
    let file = Sections::read(reader, path)?;
    let mut placed = Placed::default();
    for (slot, (lineno, r)) in file.rows.iter().enumerate() {
        placed.add(slot, *lineno, r, &file, path, duplicates)?;
    }
    let Placed {
        mut taxels,
        zero_slots,
        not_taxels,
        estimated_normals,
        dup_groups,
        ..
    } = placed;
    if duplicates == Duplicates::Reject
        && let Some(g) = dup_groups.first()
    {
        return Err(Error::invalid(
            path,
            format!("lines {:?}", g.lines),
            format!(
                "taxels {:?} share one position ({} such groups in the file)",
                g.slots,
                dup_groups.len()
            ),
        ));
    }
    if !estimated_normals.is_empty() {
        let positions: Vec<_> = taxels.iter().map(|t| t.position).collect();
        let mut given: Vec<_> = taxels.iter().map(|t| Some(t.normal)).collect();
        for &i in &estimated_normals {
            given[i] = None;
        }
        let normals = crate::normals::estimate_normals(&positions, &given);
        for &i in &estimated_normals {
            taxels[i].normal = normals[i];
        }
    }
    Ok(IcubPositions {
        estimated_normals: estimated_normals
            .iter()
            .map(|&i| taxels[i].id.0 as usize)
            .collect(),
        skin: LinkSkin::new(file.name, taxels),
        zero_slots,
        duplicates: dup_groups,
        not_taxels,
    })
}

/// What an iCub taxel file says: its name, the rows of its `[calibration]` section (with their
/// line numbers), and each slot's representative from `taxel2Repr`.
struct Sections {
    name: String,
    rows: Vec<(usize, [f64; 6])>,
    /// Negative for a slot that is no taxel (-1 unused, -2 a thermal pad); 0 where unsaid.
    repr: Vec<i64>,
}

impl Sections {
    fn read(reader: impl BufRead, path: &Path) -> Result<Sections> {
        let mut lines = Lines::new(reader, path);
        let mut name = String::new();
        let mut rows: Vec<(usize, [f64; 6])> = Vec::new();
        let mut in_calibration = false;
        // `taxel2Repr ( r0 r1 ... )`: each slot's representative taxel, negative for a slot that
        // is no taxel (-1 unused, -2 a thermal pad).
        let (mut in_repr, mut repr_text) = (false, String::new());
        while let Some(line) = lines.next_line()? {
            let lineno = line.number();
            let trimmed = line.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') || trimmed.starts_with("//") {
                continue;
            }
            if !in_calibration {
                if trimmed == "[calibration]" {
                    in_calibration = true;
                } else if let Some(rest) = trimmed.strip_prefix("taxel2Repr") {
                    in_repr = true;
                    repr_text.push_str(rest);
                } else if in_repr {
                    repr_text.push(' ');
                    repr_text.push_str(trimmed);
                } else if let Some(rest) = trimmed.strip_prefix("name") {
                    name = rest.trim().to_string();
                }
                if in_repr && repr_text.contains(')') {
                    in_repr = false;
                }
                continue;
            }
            if trimmed.starts_with('[') {
                break; // another section follows the taxel rows
            }
            rows.push((lineno, row(trimmed, lineno, path)?));
        }
        if !in_calibration {
            return Err(Error::invalid(path, "header", "no [calibration] section"));
        }
        let repr: Vec<i64> = repr_text
            .trim()
            .trim_start_matches('(')
            .split(')')
            .next()
            .unwrap_or_default()
            .split_whitespace()
            .map(|v| v.parse::<i64>().unwrap_or(0))
            .collect();
        Ok(Sections { name, rows, repr })
    }
}

/// One taxel row, `x y z nx ny nz`, of line `lineno`.
fn row(trimmed: &str, lineno: usize, path: &Path) -> Result<[f64; 6]> {
    let mut row = [0.0f64; 6];
    let mut count = 0;
    for (k, field) in trimmed.split_whitespace().enumerate() {
        if k >= 6 {
            count = 7;
            break;
        }
        row[k] = field.parse().map_err(|_| {
            Error::invalid(
                path,
                format!("line {lineno}"),
                format!("value {} (\"{}\") is not a number", k + 1, super::excerpt(field)),
            )
        })?;
        count = k + 1;
    }
    if count != 6 {
        return Err(Error::invalid(
            path,
            format!("line {lineno}"),
            format!(
                "expected 6 values (x y z nx ny nz), found {}",
                trimmed.split_whitespace().count()
            ),
        ));
    }
    Ok(row)
}

/// The file's slots sorted out: the taxels kept, the slots that are none, the taxels whose
/// normal is to be estimated, and the groups of slots at one position.
#[derive(Default)]
struct Placed {
    taxels: Vec<crate::Taxel>,
    zero_slots: Vec<usize>,
    not_taxels: Vec<usize>,
    estimated_normals: Vec<usize>,
    // Positions are written with a few decimals: grouped on a 0.1 µm grid.
    groups: HashMap<(i64, i64, i64), usize>,
    dup_groups: Vec<DuplicateGroup>,
    group_of_first: HashMap<usize, usize>,
}

impl Placed {
    /// Slot `slot`, row `r` of line `lineno`.
    fn add(
        &mut self,
        slot: usize,
        lineno: usize,
        r: &[f64; 6],
        file: &Sections,
        path: &Path,
        duplicates: Duplicates,
    ) -> Result<()> {
        if r.iter().all(|&v| v == 0.0) {
            self.zero_slots.push(slot);
            return Ok(());
        }
        if file.repr.get(slot).is_some_and(|&v| v < 0) {
            self.not_taxels.push(slot);
            return Ok(());
        }
        let place = format!("line {lineno} (taxel {slot})");
        // A position with an all-zero normal: the normal is estimated once all are read.
        let no_normal = r[3..].iter().all(|&v| v == 0.0);
        let normal = if no_normal {
            [0.0, 0.0, 1.0]
        } else {
            [r[3], r[4], r[5]]
        };
        let taxel = make_taxel(path, &place, TaxelId(slot as u32), [r[0], r[1], r[2]], normal)?;
        let k = (
            (r[0] * 1e7).round() as i64,
            (r[1] * 1e7).round() as i64,
            (r[2] * 1e7).round() as i64,
        );
        if let Some(&first) = self.groups.get(&k) {
            let dup_groups = &mut self.dup_groups;
            let g = *self.group_of_first.entry(first).or_insert_with(|| {
                dup_groups.push(DuplicateGroup {
                    slots: vec![first],
                    lines: vec![file.rows[first].0],
                });
                dup_groups.len() - 1
            });
            self.dup_groups[g].slots.push(slot);
            self.dup_groups[g].lines.push(lineno);
            if duplicates == Duplicates::Merge {
                return Ok(());
            }
        } else {
            self.groups.insert(k, slot);
        }
        if no_normal {
            self.estimated_normals.push(self.taxels.len());
        }
        self.taxels.push(taxel);
        Ok(())
    }
}
