//! iCub skin taxel files (`icub-main/app/skinGui/conf/positions/*.txt`).
//!
//! A header of `key value` lines (`name`, `spatial_sampling`, `taxel2Repr (...)`), then a line
//! `[calibration]`, then one row per taxel slot: `x y z nx ny nz`, metres in the link frame. Slots
//! come 12 per triangular module. A row of zeros is an unused slot (a thermal pad or a missing
//! module) and is dropped. Taxel ids are the slot index (0-based row after `[calibration]`).
//!
//! Several slots can carry the same position (the files give some taxels their module's position).
//! [`Duplicates`] says what to do with them; either way the rows are reported.

use super::{make_taxel, read_text};
use crate::{Error, LinkSkin, Result, TaxelId};
use std::collections::HashMap;
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
            rows: self.skin.taxels.len() + self.zero_slots.len() + merged,
            unused: self.zero_slots.clone(),
        }];
        if !self.duplicates.is_empty() {
            notes.push(super::Note::MergedDuplicates {
                path: path.to_owned(),
                groups: self.duplicates.clone(),
            });
        }
        notes
    }
}

/// Reads an iCub taxel file.
pub fn read(path: &Path, duplicates: Duplicates) -> Result<IcubPositions> {
    parse(&read_text(path)?, path, duplicates)
}

/// Parses an iCub taxel file; `path` is used in error messages.
pub fn parse(text: &str, path: &Path, duplicates: Duplicates) -> Result<IcubPositions> {
    let mut name = String::new();
    let mut rows: Vec<(usize, [f64; 6])> = Vec::new();
    let mut in_calibration = false;
    for (i, line) in text.lines().enumerate() {
        let lineno = i + 1;
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') || trimmed.starts_with("//") {
            continue;
        }
        if !in_calibration {
            if trimmed == "[calibration]" {
                in_calibration = true;
            } else if let Some(rest) = trimmed.strip_prefix("name") {
                name = rest.trim().to_string();
            }
            continue;
        }
        if trimmed.starts_with('[') {
            break; // another section follows the taxel rows
        }
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
        rows.push((lineno, row));
    }
    if !in_calibration {
        return Err(Error::invalid(path, "header", "no [calibration] section"));
    }

    let mut taxels = Vec::new();
    let mut zero_slots = Vec::new();
    // Positions are written with a few decimals: group them on a 0.1 µm grid.
    let mut groups: HashMap<(i64, i64, i64), usize> = HashMap::new();
    let mut dup_groups: Vec<DuplicateGroup> = Vec::new();
    let mut group_of_first: HashMap<usize, usize> = HashMap::new();
    for (slot, (lineno, r)) in rows.iter().enumerate() {
        if r.iter().all(|&v| v == 0.0) {
            zero_slots.push(slot);
            continue;
        }
        let place = format!("line {lineno} (taxel {slot})");
        let taxel = make_taxel(
            path,
            &place,
            TaxelId(slot as u32),
            [r[0], r[1], r[2]],
            [r[3], r[4], r[5]],
        )?;
        let k = (
            (r[0] * 1e7).round() as i64,
            (r[1] * 1e7).round() as i64,
            (r[2] * 1e7).round() as i64,
        );
        match groups.get(&k) {
            None => {
                groups.insert(k, slot);
                taxels.push(taxel);
            }
            Some(&first) => {
                let g = *group_of_first.entry(first).or_insert_with(|| {
                    dup_groups.push(DuplicateGroup {
                        slots: vec![first],
                        lines: vec![rows[first].0],
                    });
                    dup_groups.len() - 1
                });
                dup_groups[g].slots.push(slot);
                dup_groups[g].lines.push(*lineno);
                if duplicates == Duplicates::Merge {
                    continue;
                }
                taxels.push(taxel);
            }
        }
    }
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
    Ok(IcubPositions {
        skin: LinkSkin::new(name, taxels),
        zero_slots,
        duplicates: dup_groups,
    })
}
