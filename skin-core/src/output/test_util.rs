//! What the output tests share: the names in a folder, and every file under it with its bytes.

#![allow(clippy::unwrap_used)]

use super::records::{slash, walk};
use std::path::Path;

/// The names in `dir`, sorted.
pub(super) fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Every file under `dir` with its bytes.
pub(super) fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    walk(dir, Path::new(""), &mut files).unwrap();
    let mut v: Vec<_> = files
        .iter()
        .map(|f| (slash(f), std::fs::read(dir.join(f)).unwrap()))
        .collect();
    v.sort();
    v
}
