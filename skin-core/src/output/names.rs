//! The names of per-input outputs (a folder or a file for each recording, image or log).

use super::error::{OutputError, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// One output name per input: its file stem, prefixed with its folder's name (`rig1_sample`)
/// where two inputs share a stem; [`OutputError::SameName`] where even that leaves two alike,
/// so that no output is written over another.
pub fn output_names(paths: &[PathBuf]) -> Result<Vec<String>> {
    // A gzip-compressed input is named as the file inside it: `sample_19.txt.gz` -> `sample_19`.
    let stem = |p: &Path| {
        let inner = match p.extension() {
            Some(e) if e.eq_ignore_ascii_case("gz") => p.file_stem().map(Path::new).unwrap_or(p),
            _ => p,
        };
        inner
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("input")
            .to_string()
    };
    let mut count: HashMap<String, usize> = HashMap::new();
    for p in paths {
        *count.entry(stem(p)).or_default() += 1;
    }
    let mut used: HashMap<String, &Path> = HashMap::new();
    let mut names = Vec::with_capacity(paths.len());
    for p in paths {
        let mut name = stem(p);
        if count.get(&name).is_some_and(|&n| n > 1) {
            let parent = p
                .parent()
                .and_then(|d| d.file_name())
                .and_then(|s| s.to_str())
                .unwrap_or("input");
            name = format!("{parent}_{name}");
        }
        if let Some(first) = used.insert(name.clone(), p) {
            return Err(OutputError::SameName {
                first: first.to_owned(),
                second: p.clone(),
                name,
            });
        }
        names.push(name);
    }
    Ok(names)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_shared_stem_takes_its_folder_and_a_full_clash_is_refused() {
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(output_names(&[p("a/x.txt"), p("b/y.txt")]).unwrap(), ["x", "y"]);
        assert_eq!(
            output_names(&[p("a/x.txt"), p("b/x.txt")]).unwrap(),
            ["a_x", "b_x"]
        );
        assert_eq!(
            output_names(&[p("a/x.txt.gz"), p("b/y.log.GZ"), p("c/z.gz")]).unwrap(),
            ["x", "y", "z"]
        );
        // A file and its compressed copy would share a name: told apart by folder, or refused.
        let e = output_names(&[p("a/x.txt"), p("a/x.txt.gz")]).unwrap_err();
        assert!(e.to_string().contains("both would be written as a_x"), "{e}");
        let e = output_names(&[p("a/x.txt"), p("a/x.txt")]).unwrap_err();
        assert!(e.to_string().contains("both would be written as a_x"), "{e}");
    }
}
