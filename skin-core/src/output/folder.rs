//! A folder output: written into only if it is new, empty, or an earlier output of the same
//! command (or with `force`); locked against a second writer; its new files built in a staging
//! folder inside it and moved into place by its commit (`commit`).

use super::error::{Action, OutputError, Result, Whose, io};
use super::ids::{FileId, folder_id, id_of};
use super::inputs::Inputs;
use super::records::{LOCK, Manifest, STAGING, is_record, is_relative_plain, slash, walk};
use super::unfinished::{Unfinished, forget, remove_ours, unfinished, writing};
use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

/// A folder output being built: write into [`OutputDir::path`], then [`OutputDir::commit`].
/// Dropped without a commit, it removes what it built and leaves the folder as it was.
pub struct OutputDir {
    pub(super) dir: PathBuf,
    pub(super) staging: PathBuf,
    pub(super) command: String,
    pub(super) previous: BTreeSet<String>,
    pub(super) inputs: Inputs,
    pub(super) created: bool,
    /// Whether this process made the lock file (removed again if nothing is committed).
    pub(super) lock_new: bool,
    /// The folder's and the staging folder's device and inode: a folder deleted or replaced
    /// while the command ran is not written into (nor removed).
    pub(super) ids: (Option<FileId>, Option<FileId>),
    pub(super) committed: bool,
    /// The previous output's files stay part of this one ([`OutputDir::keep_previous`]).
    pub(super) keep: bool,
    _lock: File,
}

impl OutputDir {
    /// Opens `dir` as the output folder of `command` (e.g. "skin run", or a robot stack's sink
    /// name); `force` allows writing its files into a folder that holds other files.
    pub fn create(dir: &Path, command: &str, force: bool, inputs: &Inputs) -> Result<OutputDir> {
        // Refuse before touching anything (checked again once the lock is held).
        Self::precheck(dir, command, force)?;
        // No folder appears once an interrupted process has abandoned its outputs.
        let _gate = writing();
        let created = match std::fs::create_dir(dir) {
            Ok(()) => true,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => false,
            Err(_) => {
                std::fs::create_dir_all(dir).map_err(io(Action::Create, dir))?;
                true
            }
        };
        let dir_id = folder_id(dir);
        let undo = |lock_new: bool| {
            if lock_new {
                let _ = std::fs::remove_file(dir.join(LOCK));
            }
            if created {
                let _ = std::fs::remove_dir(dir);
            }
        };
        let lock_new = !dir.join(LOCK).exists();
        let lock = match Self::lock(dir) {
            Ok(l) => l,
            Err(e) => {
                undo(false);
                return Err(e);
            }
        };
        let previous = match Self::contents(dir, command, force) {
            Ok(p) => p,
            Err(e) => {
                undo(lock_new);
                return Err(e);
            }
        };
        let staging = dir.join(STAGING);
        remove_ours(&staging, None); // a killed run's leftovers (the lock is ours)
        if let Err(e) = std::fs::create_dir(&staging) {
            undo(lock_new);
            return Err(io(Action::WriteInto, dir)(e));
        }
        let staging_id = id_of(&staging);
        {
            let mut list = unfinished();
            list.push(Unfinished::Temporary(staging.clone(), staging_id));
            if created {
                list.push(Unfinished::CreatedFolder(dir.to_owned(), dir_id));
            }
        }
        Ok(OutputDir {
            dir: dir.to_owned(),
            staging,
            command: command.to_owned(),
            previous,
            inputs: inputs.clone(),
            created,
            lock_new,
            ids: (dir_id, staging_id),
            committed: false,
            keep: false,
            _lock: lock,
        })
    }

    /// Refuses `dir` now, before any work, if [`OutputDir::create`] would (it checks again).
    pub fn precheck(dir: &Path, command: &str, force: bool) -> Result<()> {
        if dir.as_os_str().is_empty() || std::fs::metadata(dir).is_ok_and(|m| !m.is_dir()) {
            return Err(OutputError::NotAFolder { path: dir.to_owned() });
        }
        if dir.is_dir() {
            Self::contents(dir, command, force)?;
        }
        Ok(())
    }

    fn lock(dir: &Path) -> Result<File> {
        let file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(dir.join(LOCK))
            .map_err(io(Action::WriteInto, dir))?;
        match file.try_lock() {
            Ok(()) => Ok(file),
            Err(std::fs::TryLockError::WouldBlock) => Err(OutputError::Busy { dir: dir.to_owned() }),
            Err(std::fs::TryLockError::Error(e)) => Err(io(Action::Lock, dir)(e)),
        }
    }

    /// Checks that the folder may be written into; returns the files of its previous output
    /// (those its manifest lists, and those an unfinished commit's marker lists).
    fn contents(dir: &Path, command: &str, force: bool) -> Result<BTreeSet<String>> {
        let manifest = Manifest::read(dir);
        let marker = Manifest::read_marker(dir);
        let mut ours = BTreeSet::new();
        for m in manifest.iter().chain(&marker).filter(|m| m.command == command) {
            ours.extend(m.files.iter().filter(|f| is_relative_plain(f)).cloned());
        }
        if force || manifest.as_ref().is_some_and(|m| m.command == command) {
            return Ok(ours);
        }
        // Without a manifest of this command, every file there must be skin's: an unfinished
        // commit's, listed in its marker.
        let mut foreign = Vec::new();
        for e in std::fs::read_dir(dir).map_err(io(Action::Read, dir))?.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if is_record(&name) {
                continue;
            }
            let mut files = Vec::new();
            let listed = if e.file_type().is_ok_and(|t| t.is_dir()) {
                walk(dir, Path::new(&name), &mut files).is_ok()
                    && files.iter().all(|f| ours.contains(&slash(f)))
            } else {
                ours.contains(&name)
            };
            if !listed {
                foreign.push(name);
            }
        }
        if foreign.is_empty() {
            return Ok(ours);
        }
        foreign.sort();
        let other = manifest.or(marker).filter(|m| m.command != command);
        Err(OutputError::NotOurs {
            dir: dir.to_owned(),
            whose: match other {
                Some(m) => Whose::Command(m.command),
                None => Whose::NotSkins,
            },
            files: foreign,
            command: command.to_owned(),
        })
    }

    /// Keeps the previous output's files as part of this one (an output that grows, as a
    /// dataset appended to does): the commit removes none of them, and the manifest lists them
    /// with the new files. A new file of the same name still replaces one of them.
    pub fn keep_previous(&mut self) {
        self.keep = true;
    }

    /// The folder to write the new files into (moved into place by [`OutputDir::commit`]).
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The folder the user named.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        let mut list = unfinished();
        forget(&mut list, &self.staging);
        forget(&mut list, &self.dir);
        if self.committed {
            return;
        }
        remove_ours(&self.staging, self.ids.1);
        if folder_id(&self.dir) != self.ids.0 {
            return; // not the folder we opened any more: nothing of ours to remove there
        }
        if self.created || self.lock_new {
            let _ = std::fs::remove_file(self.dir.join(LOCK));
        }
        if self.created {
            let _ = std::fs::remove_dir(&self.dir);
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::output::records::MANIFEST;
    use crate::output::test_util::names;

    #[test]
    fn a_folder_of_other_files_is_refused_and_left_alone() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("notes.txt"), "mine").unwrap();
        let e = OutputDir::create(d.path(), "skin image", false, &Inputs::default())
            .err()
            .unwrap();
        assert!(
            matches!(&e, OutputError::NotOurs { files, .. } if files == &["notes.txt"]),
            "{e}"
        );
        assert_eq!(names(d.path()), ["notes.txt"]);
    }

    #[test]
    fn a_rerun_replaces_only_its_own_files() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out");
        let o = OutputDir::create(&out, "skin image", false, &Inputs::default()).unwrap();
        std::fs::write(o.path().join("a.png"), "1").unwrap();
        std::fs::create_dir(o.path().join("sub")).unwrap();
        std::fs::write(o.path().join("sub/b.png"), "1").unwrap();
        o.commit().unwrap();
        let o = OutputDir::create(&out, "skin image", false, &Inputs::default()).unwrap();
        std::fs::write(o.path().join("a.png"), "2").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a.png")).unwrap(), "2");
        assert!(
            !out.join("sub").exists(),
            "the old output's folder went with its file"
        );
        assert_eq!(names(&out), [".skin-lock", ".skin-output", "a.png"]);
        // Another command's output is not this one's.
        assert!(OutputDir::create(&out, "skin stitch", false, &Inputs::default()).is_err());
    }

    #[test]
    fn an_abandoned_folder_leaves_the_previous_output() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out");
        let o = OutputDir::create(&out, "skin image", false, &Inputs::default()).unwrap();
        std::fs::write(o.path().join("a.png"), "1").unwrap();
        o.commit().unwrap();
        let o = OutputDir::create(&out, "skin image", false, &Inputs::default()).unwrap();
        std::fs::write(o.path().join("a.png"), "2").unwrap();
        drop(o);
        assert_eq!(std::fs::read_to_string(out.join("a.png")).unwrap(), "1");
        assert!(!out.join(STAGING).exists());
        // And a new folder that was abandoned is gone.
        let fresh = d.path().join("fresh");
        drop(OutputDir::create(&fresh, "skin image", false, &Inputs::default()).unwrap());
        assert!(!fresh.exists());
    }

    /// One commit of a folder (and of a file beside it) over an earlier one, with the `k`-th
    #[test]
    fn a_file_or_no_path_is_refused_before_any_work() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("afile");
        std::fs::write(&file, "the user's").unwrap();
        for dir in [file.as_path(), Path::new("")] {
            assert!(matches!(
                OutputDir::precheck(dir, "skin run", true),
                Err(OutputError::NotAFolder { .. })
            ));
        }
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "the user's");
        OutputDir::precheck(&d.path().join("new"), "skin run", false).unwrap();
    }

    #[test]
    fn a_folder_deleted_while_it_is_written_is_not_committed() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out");
        let o = OutputDir::create(&out, "skin run", false, &Inputs::default()).unwrap();
        std::fs::remove_dir_all(&out).unwrap();
        // A writer that makes its folders as it goes brings the staging folder back.
        std::fs::create_dir_all(o.path().join("touches")).unwrap();
        std::fs::write(o.path().join("touches/a.png"), "x").unwrap();
        let e = o.commit().unwrap_err();
        assert!(matches!(e, OutputError::Vanished { .. }), "{e}");
        assert!(!out.join(MANIFEST).exists() && !out.join("touches").exists());
    }

    #[cfg(unix)]
    #[test]
    fn a_folder_given_as_a_link_is_written_through_it() {
        let d = tempfile::tempdir().unwrap();
        let (real, link) = (d.path().join("real"), d.path().join("link"));
        std::fs::create_dir(&real).unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        for run in ["1", "2"] {
            let o = OutputDir::create(&link, "skin run", false, &Inputs::default()).unwrap();
            std::fs::write(o.path().join("a.png"), run).unwrap();
            o.commit().unwrap();
        }
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(real.join("a.png")).unwrap(), "2");
        // Abandoned: the link and the earlier output stay, the lock it found too.
        drop(OutputDir::create(&link, "skin run", false, &Inputs::default()).unwrap());
        assert_eq!(names(&real), [".skin-lock", ".skin-output", "a.png"]);
    }

    #[test]
    fn a_second_writer_is_refused_at_once() {
        let d = tempfile::tempdir().unwrap();
        let _a = OutputDir::create(d.path(), "skin run", false, &Inputs::default()).unwrap();
        let e = OutputDir::create(d.path(), "skin run", false, &Inputs::default())
            .err()
            .unwrap();
        assert!(matches!(e, OutputError::Busy { .. }), "{e}");
    }
}
