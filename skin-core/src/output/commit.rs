//! The commit of a folder output. Everything a commit writes (the manifest, the `INCOMPLETE`
//! marker) is written aside before the first file moves, so a full disk stops a commit before
//! it changes anything; then only renames follow, while a signal handler waits.

use super::error::{Action, OutputError, Result, io};
use super::file::Staged;
use super::folder::OutputDir;
use super::ids::{folder_id, id_of};
use super::records::{INCOMPLETE, MANIFEST, Manifest, is_record, slash, walk};
use super::steps::Steps;
use super::unfinished::{forget, unfinished};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// A move of a commit: a file, or a whole folder the output folder lacks.
struct Move {
    from: PathBuf,
    to: PathBuf,
}

/// Where a commit wrote the folder's records aside, in its staging folder, before moving them in.
struct Aside {
    /// The new manifest.
    manifest: PathBuf,
    /// The `INCOMPLETE` marker.
    marker: PathBuf,
}

impl OutputDir {
    /// Moves the new files into place, removes files of the previous output that this one does
    /// not have, and records the new list in the manifest.
    pub fn commit(self) -> Result<()> {
        self.commit_with(Vec::new())
    }

    /// As [`OutputDir::commit`], and moves `files` (finished beside the folder, e.g. a
    /// recording of the same run) into place with it: if the folder's commit fails before its
    /// files move, none of `files` moves either; they move after the folder's files and before
    /// its manifest, so a failure between leaves the folder marked `INCOMPLETE`.
    pub fn commit_with(self, files: Vec<Staged>) -> Result<()> {
        self.commit_steps(files, &mut Steps::default())
    }

    /// [`OutputDir::commit_with`], its writes, renames and removals made as `steps`.
    pub(super) fn commit_steps(mut self, mut files: Vec<Staged>, steps: &mut Steps) -> Result<()> {
        if folder_id(&self.dir) != self.ids.0 || id_of(&self.staging) != self.ids.1 {
            return Err(OutputError::Vanished {
                dir: self.dir.clone(),
            });
        }
        let (moves, names) = self.plan()?;
        let old = self.stale(&names);
        let aside = self.records_aside(&names, &old, steps)?;
        // From here only renames, while a signal handler waits.
        let mut list = unfinished();
        let marker_path = self.dir.join(INCOMPLETE);
        let mut done = 0;
        let result = (|| {
            steps
                .rename(&aside.marker, &marker_path)
                .map_err(io(Action::WriteInto, &self.dir))?;
            for m in &moves {
                steps.rename(&m.from, &m.to).map_err(io(Action::Write, &m.to))?;
                done += 1;
            }
            self.remove_stale(&old, steps);
            steps
                .rename(&aside.manifest, &self.dir.join(MANIFEST))
                .map_err(io(Action::WriteInto, &self.dir))?;
            for f in &mut files {
                f.put_in_place(&mut list, steps)?;
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                // A marker that cannot be removed only says "incomplete" of a complete folder.
                let _ = steps.remove_file(&marker_path);
                let _ = std::fs::remove_dir_all(&self.staging);
                self.committed = true;
                forget(&mut list, &self.staging);
                forget(&mut list, &self.dir);
                Ok(())
            }
            Err(e) => {
                if self.created {
                    self.undo(&moves[..done], &aside);
                }
                // Otherwise the marker stays (if it got there): the folder says it is unfinished
                // and lists what may be missing; the next run accepts it.
                Err(e)
            }
        }
    }

    /// Files of the earlier output that this one (`names`) does not have: removed once the new
    /// files are in. The manifest lists them too, so one that cannot be removed stays skin's.
    fn stale(&self, names: &[String]) -> Vec<String> {
        if self.keep {
            return Vec::new();
        }
        let new: BTreeSet<&String> = names.iter().collect();
        self.previous
            .iter()
            .filter(|old| !new.contains(old))
            .filter(|old| std::fs::symlink_metadata(self.dir.join(old)).is_ok_and(|m| m.is_file()))
            .cloned()
            .collect()
    }

    /// Writes the manifest (the new files and the stale ones) and the `INCOMPLETE` marker (the
    /// new files) aside, in the staging folder. Everything that takes space is written now, each
    /// write checked: a full disk stops the commit here, with nothing moved.
    fn records_aside(&self, names: &[String], old: &[String], steps: &mut Steps) -> Result<Aside> {
        let mut listed = names.to_vec();
        listed.extend(old.iter().cloned());
        if self.keep {
            let here = |f: &&String| std::fs::symlink_metadata(self.dir.join(f)).is_ok_and(|m| m.is_file());
            listed.extend(self.previous.iter().filter(here).cloned());
        }
        listed.sort();
        listed.dedup();
        let manifest = Manifest {
            command: self.command.clone(),
            files: listed,
        };
        let marker = Manifest {
            command: self.command.clone(),
            files: names.to_vec(),
        };
        let aside = Aside {
            manifest: self.staging.join(MANIFEST),
            marker: self.staging.join(INCOMPLETE),
        };
        let text = serde_json::to_string_pretty(&manifest)
            .map_err(|e| io(Action::WriteInto, &self.dir)(std::io::Error::other(e)))?;
        steps
            .write(&aside.manifest, text.as_bytes())
            .map_err(io(Action::WriteInto, &self.dir))?;
        steps
            .write(&aside.marker, marker.marker_text().as_bytes())
            .map_err(io(Action::WriteInto, &self.dir))?;
        Ok(aside)
    }

    /// Removes the earlier output's files that this one does not have, and the folders they
    /// leave empty. One that cannot be removed stays (the manifest still lists it).
    fn remove_stale(&self, old: &[String], steps: &mut Steps) {
        for o in old {
            let path = self.dir.join(o);
            // An input that now sits where an old output was is the user's: never removed.
            if self.inputs.find(&path).is_none() && steps.remove_file(&path).is_ok() {
                // Folders of the old output that are now empty go too.
                let mut up = path.parent();
                while let Some(p) = up.filter(|p| *p != self.dir) {
                    if std::fs::remove_dir(p).is_err() {
                        break;
                    }
                    up = p.parent();
                }
            }
        }
    }

    /// Takes a new folder back to absent after a failed commit: every move in `done` undone
    /// (renames back need no space), the manifest and marker out of the folder, which then goes
    /// with this output.
    fn undo(&self, done: &[Move], aside: &Aside) {
        for m in done.iter().rev() {
            let _ = std::fs::rename(&m.to, &m.from);
        }
        let manifest_path = self.dir.join(MANIFEST);
        if std::fs::symlink_metadata(&manifest_path).is_ok() {
            let _ = std::fs::rename(&manifest_path, &aside.manifest);
        }
        let _ = std::fs::remove_file(self.dir.join(INCOMPLETE));
    }

    /// The moves of a commit and the new output's files (relative, `/`-separated, sorted);
    /// everything checked before anything moves.
    fn plan(&self) -> Result<(Vec<Move>, Vec<String>)> {
        let mut files = Vec::new();
        walk(&self.staging, Path::new(""), &mut files).map_err(io(Action::Read, &self.dir))?;
        files.sort();
        for rel in &files {
            let dest = self.dir.join(rel);
            let top = rel.components().count() == 1;
            let name = rel.to_string_lossy();
            if top && is_record(&name) {
                return Err(io(Action::Write, &dest)(std::io::Error::other(
                    "a name skin keeps for the folder's own records",
                )));
            }
            self.inputs.check(&dest)?;
        }
        let mut moves = Vec::new();
        self.plan_folder(Path::new(""), &mut moves)?;
        Ok((moves, files.iter().map(|p| slash(p)).collect()))
    }

    /// The moves for the staging folder's `rel`: a file or a folder the output folder lacks
    /// moves whole; a folder it has is gone into.
    fn plan_folder(&self, rel: &Path, moves: &mut Vec<Move>) -> Result<()> {
        let from_dir = self.staging.join(rel);
        let mut entries: Vec<_> = std::fs::read_dir(&from_dir)
            .map_err(io(Action::Read, &self.dir))?
            .collect::<std::io::Result<_>>()
            .map_err(io(Action::Read, &self.dir))?;
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let r = rel.join(e.file_name());
            let to = self.dir.join(&r);
            let is_dir = e.file_type().map_err(io(Action::Read, &self.dir))?.is_dir();
            let blocked = || OutputError::Blocked {
                path: to.clone(),
                command: self.command.clone(),
            };
            match std::fs::symlink_metadata(&to) {
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => moves.push(Move {
                    from: self.staging.join(&r),
                    to: to.clone(),
                }),
                Err(e) => return Err(io(Action::Read, &to)(e)),
                Ok(m) if m.file_type().is_symlink() => return Err(blocked()),
                Ok(m) if is_dir && m.is_dir() => self.plan_folder(&r, moves)?,
                Ok(m) if !is_dir && !m.is_dir() => moves.push(Move {
                    from: self.staging.join(&r),
                    to: to.clone(),
                }),
                Ok(_) => return Err(blocked()),
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::panic)]
    use super::*;
    use crate::output::test_util::{names, snapshot};
    use crate::output::{Inputs, OutputFile};
    use std::io::Write as _;

    /// One commit of a folder (and of a file beside it) over an earlier one, with the `k`-th
    /// write, rename or removal of the commit failing as on a full disk; and whether that
    /// failure happened (the commit has fewer steps).
    fn commit_failing_at(k: usize, out: &Path, beside: &Path, run: &str) -> (Result<()>, bool) {
        let inputs = Inputs::default();
        let o = OutputDir::create(out, "skin run", false, &inputs).unwrap();
        std::fs::write(o.path().join("events.jsonl"), run).unwrap();
        std::fs::create_dir(o.path().join("touches")).unwrap();
        std::fs::write(o.path().join("touches/touch_000.png"), run).unwrap();
        let mut f = OutputFile::create_exclusive(beside, &inputs).unwrap();
        f.write_all(run.as_bytes()).unwrap();
        let staged = f.stage().unwrap();
        let mut steps = Steps::failing_at(k);
        let r = o.commit_steps(vec![staged], &mut steps);
        (r, steps.failed())
    }

    fn commit(out: &Path, beside: &Path, run: &str) {
        commit_failing_at(usize::MAX, out, beside, run).0.unwrap();
    }

    #[test]
    fn a_full_disk_at_any_step_of_a_commit_leaves_a_new_folder_absent() {
        for k in 0.. {
            let d = tempfile::tempdir().unwrap();
            let (out, beside) = (d.path().join("out"), d.path().join("run.mcap"));
            match commit_failing_at(k, &out, &beside, "new") {
                (Ok(()), failed) => {
                    let mut want = vec![".skin-lock", ".skin-output", "events.jsonl", "touches"];
                    // The marker could not be removed: it stays, and says "incomplete" of a
                    // complete folder (the safe side).
                    if failed {
                        want.insert(2, "INCOMPLETE");
                    }
                    assert_eq!(names(&out), want);
                    assert_eq!(
                        std::fs::read_to_string(out.join("touches/touch_000.png")).unwrap(),
                        "new"
                    );
                    assert_eq!(std::fs::read_to_string(&beside).unwrap(), "new");
                    assert_eq!(names(d.path()), ["out", "run.mcap"]);
                    if !failed {
                        assert!(k > 5, "the commit has several steps");
                        break;
                    }
                }
                (Err(e), _) => {
                    assert!(e.to_string().contains(&d.path().display().to_string()), "{e}");
                    assert!(!e.to_string().contains(".partial"), "{e}");
                    // Nothing at all: no folder, no file beside it, no temporary file.
                    assert_eq!(names(d.path()), Vec::<String>::new(), "step {k}: {e}");
                }
            }
        }
    }

    #[test]
    fn a_full_disk_at_any_step_of_a_commit_keeps_the_earlier_output_or_marks_it() {
        for k in 0.. {
            let d = tempfile::tempdir().unwrap();
            let (out, beside) = (d.path().join("out"), d.path().join("run.mcap"));
            commit(&out, &beside, "old");
            let before = snapshot(&out);
            match commit_failing_at(k, &out, &beside, "new") {
                (Ok(()), failed) => {
                    assert_eq!(std::fs::read_to_string(out.join("events.jsonl")).unwrap(), "new");
                    assert_eq!(
                        std::fs::read_to_string(out.join("touches/touch_000.png")).unwrap(),
                        "new"
                    );
                    assert_eq!(std::fs::read_to_string(&beside).unwrap(), "new");
                    assert_eq!(out.join(INCOMPLETE).exists(), failed);
                    if !failed {
                        break;
                    }
                }
                (Err(e), _) => {
                    assert!(!e.to_string().contains(".partial"), "{e}");
                    assert_eq!(names(d.path()), ["out", "run.mcap"], "step {k}: {e}");
                    match Manifest::read_marker(&out) {
                        // Stopped before anything moved: the earlier output as it was.
                        None => {
                            assert_eq!(snapshot(&out), before, "step {k}: {e}");
                            assert_eq!(std::fs::read_to_string(&beside).unwrap(), "old");
                        }
                        // Stopped while moving: a readable marker, and the next run goes on.
                        Some(m) => {
                            assert_eq!(m.command, "skin run");
                            assert_eq!(m.files, ["events.jsonl", "touches/touch_000.png"]);
                            commit(&out, &beside, "again");
                            assert!(!out.join(INCOMPLETE).exists());
                            assert_eq!(
                                std::fs::read_to_string(out.join("events.jsonl")).unwrap(),
                                "again"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn an_unfinished_commit_into_an_empty_folder_is_taken_up_by_the_next_run() {
        let d = tempfile::tempdir().unwrap();
        let (out, beside) = (d.path().join("out"), d.path().join("run.mcap"));
        std::fs::create_dir(&out).unwrap(); // the user's empty folder: not removed on failure
        // Fail step after step until the rename of the file beside fails: the folder's files
        // and manifest are in, its marker too.
        let mut k = 0;
        loop {
            let _ = std::fs::remove_file(&beside);
            match commit_failing_at(k, &out, &beside, "first") {
                (Err(_), _) if !beside.exists() && out.join(MANIFEST).exists() => break,
                (Err(_), _) => k += 1,
                (Ok(()), _) => panic!("no step left the folder marked"),
            }
        }
        let text = std::fs::read_to_string(out.join(INCOMPLETE)).unwrap();
        assert!(text.starts_with("skin run was moving its files"), "{text}");
        // A folder holding only the marked files is skin's: the next run takes it.
        std::fs::remove_file(out.join(MANIFEST)).unwrap();
        OutputDir::precheck(&out, "skin run", false).unwrap();
        commit(&out, &beside, "second");
        assert!(!out.join(INCOMPLETE).exists());
        // But a file the marker does not list is still the user's.
        std::fs::write(out.join("touches/mine.txt"), "x").unwrap();
        std::fs::remove_file(out.join(MANIFEST)).unwrap();
        std::fs::write(out.join(INCOMPLETE), text).unwrap();
        assert!(matches!(
            OutputDir::precheck(&out, "skin run", false),
            Err(OutputError::NotOurs { .. })
        ));
    }

    #[test]
    fn a_blocked_folder_commit_puts_nothing_in_place() {
        let d = tempfile::tempdir().unwrap();
        let (out, beside) = (d.path().join("out"), d.path().join("run.mcap"));
        commit(&out, &beside, "old");
        std::fs::remove_file(out.join("events.jsonl")).unwrap();
        std::fs::create_dir(out.join("events.jsonl")).unwrap();
        let before = snapshot(&out);
        let e = commit_failing_at(usize::MAX, &out, &beside, "new").0.unwrap_err();
        assert!(matches!(e, OutputError::Blocked { .. }), "{e}");
        assert_eq!(snapshot(&out), before);
        assert_eq!(std::fs::read_to_string(&beside).unwrap(), "old");
        assert_eq!(names(d.path()), ["out", "run.mcap"]);
    }
}
