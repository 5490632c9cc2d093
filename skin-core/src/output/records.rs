//! What skin keeps in an output folder besides the output: the manifest `.skin-output` (which
//! command wrote the folder and which files are its), the `INCOMPLETE` marker of a commit under
//! way, the lock `.skin-lock` and the staging folder `.skin-partial`.

use std::path::{Component, Path, PathBuf};

/// The manifest of a folder output: which command wrote it and which files are its.
pub(super) const MANIFEST: &str = ".skin-output";
/// The lock that keeps two writers out of one folder.
pub(super) const LOCK: &str = ".skin-lock";
/// Where a folder's new files are built.
pub(super) const STAGING: &str = ".skin-partial";
/// Left in a folder while files move into place (and after, if the move was cut short).
pub(super) const INCOMPLETE: &str = "INCOMPLETE";
/// The first line of an `INCOMPLETE` marker, after the command's name.
const INCOMPLETE_SAYS: &str =
    " was moving its files into this folder when it stopped: these may be missing or from an earlier run:";

/// Whether `name`, at the top of an output folder, is one of skin's records (never an output
/// file, never a user's).
pub(super) fn is_record(name: &str) -> bool {
    [MANIFEST, LOCK, STAGING, INCOMPLETE].contains(&name)
}

/// What `.skin-output` records.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct Manifest {
    /// The command that wrote the folder, e.g. "skin run".
    pub(super) command: String,
    /// The files it wrote, relative to the folder.
    pub(super) files: Vec<String>,
}

impl Manifest {
    /// The manifest of `dir`, if it has one that reads.
    pub(super) fn read(dir: &Path) -> Option<Manifest> {
        let text = std::fs::read_to_string(dir.join(MANIFEST)).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// An `INCOMPLETE` marker: the command's line, then a file a line.
    pub(super) fn read_marker(dir: &Path) -> Option<Manifest> {
        let text = std::fs::read_to_string(dir.join(INCOMPLETE)).ok()?;
        let mut lines = text.lines();
        let command = lines.next()?.strip_suffix(INCOMPLETE_SAYS)?.to_owned();
        Some(Manifest {
            command,
            files: lines.filter(|l| !l.is_empty()).map(str::to_owned).collect(),
        })
    }

    /// The text of the `INCOMPLETE` marker that lists these files.
    pub(super) fn marker_text(&self) -> String {
        format!("{}{INCOMPLETE_SAYS}\n{}\n", self.command, self.files.join("\n"))
    }
}

/// Lists the files under `dir` (relative to it).
pub(super) fn walk(dir: &Path, rel: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for e in std::fs::read_dir(dir.join(rel))? {
        let e = e?;
        let r = rel.join(e.file_name());
        if e.file_type()?.is_dir() {
            walk(dir, &r, out)?;
        } else {
            out.push(r);
        }
    }
    Ok(())
}

/// A relative path as a manifest lists it: `/`-separated on every system.
pub(super) fn slash(p: &Path) -> String {
    p.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// A manifest entry is only trusted if it stays inside the folder.
pub(super) fn is_relative_plain(name: &str) -> bool {
    !name.is_empty()
        && Path::new(name)
            .components()
            .all(|c| matches!(c, Component::Normal(_)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_manifest_cannot_point_outside_its_folder() {
        assert!(is_relative_plain("touches/touch_000.png"));
        assert!(!is_relative_plain("../notes.txt"));
        assert!(!is_relative_plain("/etc/passwd"));
        assert!(!is_relative_plain(""));
    }
}
