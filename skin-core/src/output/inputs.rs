//! The files a command reads, so that no output lands on one of them, and outputs that name
//! one file twice.

use super::error::{OutputError, Result};
use super::ids::{FileId, file_id};
use std::path::{Path, PathBuf};

/// The files a command reads, so that no output lands on one of them.
#[derive(Default, Debug, Clone)]
pub struct Inputs {
    files: Vec<Input>,
}

/// One input: the path as given, its canonical path, and its device and inode.
#[derive(Debug, Clone)]
struct Input {
    given: PathBuf,
    canonical: PathBuf,
    id: Option<FileId>,
}

impl Inputs {
    /// The inputs among `paths` that exist (a missing one is its reader's error to report).
    pub fn new<P: AsRef<Path>>(paths: impl IntoIterator<Item = P>) -> Inputs {
        let mut inputs = Inputs::default();
        for p in paths {
            inputs.add(p.as_ref());
        }
        inputs
    }

    /// Adds one input.
    pub fn add(&mut self, path: &Path) {
        let Ok(canonical) = std::fs::canonicalize(path) else {
            return;
        };
        let id = std::fs::metadata(&canonical).ok().map(|m| file_id(&m));
        self.files.push(Input {
            given: path.to_owned(),
            canonical,
            id,
        });
    }

    /// The input that `path` is, if any.
    pub(super) fn find(&self, path: &Path) -> Option<&Path> {
        let canonical = std::fs::canonicalize(path).ok();
        let id = std::fs::metadata(path).ok().map(|m| file_id(&m));
        self.files
            .iter()
            .find(|f| canonical.as_deref() == Some(f.canonical.as_path()) || (id.is_some() && f.id == id))
            .map(|f| f.given.as_path())
    }

    /// Refuses outputs that are inputs, or that name one file twice (`-o map.json --svg
    /// map.json`); each output is named as the user knows it (a flag) and may be absent.
    pub fn check_outputs(&self, outputs: &[(&str, Option<&Path>)]) -> Result<()> {
        distinct(outputs)?;
        outputs
            .iter()
            .filter_map(|(_, p)| *p)
            .try_for_each(|p| self.check(p))
    }

    /// Refuses `output` if it is one of the inputs.
    pub fn check(&self, output: &Path) -> Result<()> {
        match self.find(output) {
            Some(input) => Err(OutputError::IsInput {
                output: output.to_owned(),
                input: input.to_owned(),
            }),
            None => Ok(()),
        }
    }
}

/// Refuses two outputs that name the same file (`-o map.json --svg map.json`); each output is
/// named as the user knows it (a flag) and may be absent.
pub fn distinct(outputs: &[(&str, Option<&Path>)]) -> Result<()> {
    let key = |p: &Path| -> PathBuf {
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_owned());
        dir.join(p.file_name().unwrap_or_default())
    };
    let given: Vec<(&str, &Path)> = outputs.iter().filter_map(|(f, p)| p.map(|p| (*f, p))).collect();
    for (i, (first, a)) in given.iter().enumerate() {
        for (second, b) in &given[i + 1..] {
            if key(a) == key(b) {
                return Err(OutputError::SameFile {
                    first: (*first).to_owned(),
                    second: (*second).to_owned(),
                    path: a.to_path_buf(),
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::output::write_file;

    #[test]
    fn an_input_is_never_an_output_even_through_a_link() {
        let d = tempfile::tempdir().unwrap();
        let input = d.path().join("log.txt");
        std::fs::write(&input, "data").unwrap();
        let inputs = Inputs::new([&input]);
        assert!(write_file(&input, b"x", &inputs).is_err());
        let hard = d.path().join("hard.txt");
        std::fs::hard_link(&input, &hard).unwrap();
        assert!(write_file(&hard, b"x", &inputs).is_err());
        #[cfg(unix)]
        {
            let soft = d.path().join("soft.txt");
            std::os::unix::fs::symlink(&input, &soft).unwrap();
            assert!(write_file(&soft, b"x", &inputs).is_err());
        }
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "data");
    }

    #[test]
    fn two_outputs_on_one_file_are_refused() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("x")).unwrap();
        let a = d.path().join("x/map.json");
        let b = d.path().join("x/../x/map.json");
        let c = d.path().join("x/map.svg");
        assert!(distinct(&[("-o", Some(&a)), ("--svg", Some(&b))]).is_err());
        assert!(distinct(&[("-o", Some(&a)), ("--svg", Some(&c))]).is_ok());
        assert!(distinct(&[("-o", Some(&a)), ("--svg", None)]).is_ok());
    }
}
