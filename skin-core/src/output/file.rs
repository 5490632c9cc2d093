//! A file output: built aside in a partial file and renamed into place when complete; a device,
//! FIFO or socket written through; a symbolic link followed.

use super::error::{Action, OutputError, Result, io};
use super::ids::{FileId, id_of};
use super::inputs::Inputs;
use super::partial::{exclusive_partial, new_partial, partial_stem, remove_dead_partials};
use super::steps::Steps;
use super::unfinished::{Unfinished, forget, remove_ours, unfinished, writing};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How a file output is written.
enum Target {
    /// Built aside as `tmp` (device and inode `id`), renamed to `path` when complete.
    Replace {
        path: PathBuf,
        tmp: PathBuf,
        id: Option<FileId>,
    },
    /// A device, FIFO or socket: written in place.
    Through,
}

/// A file output being written: `write` to it, then [`OutputFile::commit`] (or
/// [`OutputFile::stage`], to move it into place with an output folder). Dropped without a
/// commit, it leaves nothing behind (and the previous file as it was).
pub struct OutputFile {
    shown: PathBuf,
    /// Taken by [`OutputFile::stage`].
    file: Option<std::io::BufWriter<File>>,
    target: Target,
}

impl OutputFile {
    /// Opens `path` for writing under the rules of this module. Several writers of one path
    /// (threads filling one cache) each build their own file; the last one moved into place
    /// stays.
    pub fn create(path: &Path, inputs: &Inputs) -> Result<OutputFile> {
        Self::open(path, inputs, false)
    }

    /// As [`OutputFile::create`], for a file that one process at a time writes (a recording):
    /// a second writer of `path` is refused at once ([`OutputError::FileBusy`]) until the first
    /// has finished or given up.
    pub fn create_exclusive(path: &Path, inputs: &Inputs) -> Result<OutputFile> {
        Self::open(path, inputs, true)
    }

    fn open(path: &Path, inputs: &Inputs, exclusive: bool) -> Result<OutputFile> {
        if path.as_os_str().is_empty() {
            return Err(io(Action::Write, path)(std::io::ErrorKind::InvalidInput.into()));
        }
        inputs.check(path)?;
        let target_path = follow_links(path)?;
        let special = match std::fs::metadata(&target_path) {
            Ok(m) if m.is_dir() => {
                return Err(OutputError::IsFolder {
                    path: path.to_owned(),
                });
            }
            Ok(m) => !m.is_file(),
            Err(_) => false,
        };
        if special {
            let file = OpenOptions::new()
                .write(true)
                .open(&target_path)
                .map_err(io(Action::Write, path))?;
            return Ok(OutputFile {
                shown: path.to_owned(),
                file: Some(std::io::BufWriter::new(file)),
                target: Target::Through,
            });
        }
        let dir = target_path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = target_path
            .file_name()
            .ok_or_else(|| OutputError::IsFolder {
                path: path.to_owned(),
            })?
            .to_string_lossy();
        let stem = partial_stem(&name);
        // No file appears once an interrupted process has abandoned its outputs.
        let _gate = writing();
        std::fs::create_dir_all(dir).map_err(io(Action::CreateFolderOf, path))?;
        remove_dead_partials(dir, &stem);
        let made = if exclusive {
            exclusive_partial(dir, &stem).map_err(io(Action::Write, path))?
        } else {
            Some(new_partial(dir, &stem).map_err(io(Action::Write, path))?)
        };
        let Some((file, tmp)) = made else {
            return Err(OutputError::FileBusy {
                path: path.to_owned(),
            });
        };
        let id = id_of(&tmp);
        unfinished().push(Unfinished::Temporary(tmp.clone(), id));
        Ok(OutputFile {
            shown: path.to_owned(),
            file: Some(std::io::BufWriter::new(file)),
            target: Target::Replace {
                path: target_path,
                tmp,
                id,
            },
        })
    }

    /// Finishes the file: flushed, then moved into place.
    pub fn commit(self) -> Result<()> {
        self.stage()?.commit()
    }

    /// Finishes writing the file, every byte checked, without moving it into place yet: the
    /// [`Staged`] file moves with [`Staged::commit`] or with a folder ([`OutputDir::commit_with`](super::OutputDir::commit_with)).
    pub fn stage(mut self) -> Result<Staged> {
        let target = std::mem::replace(&mut self.target, Target::Through);
        let shown = self.shown.clone();
        // From here the staged file owns the temporary file: dropped, it removes it.
        let mut staged = Staged {
            shown,
            target,
            file: None,
            done: false,
        };
        if let Some(w) = self.file.take() {
            staged.file = Some(
                w.into_inner()
                    .map_err(|e| io(Action::Write, &self.shown)(e.into_error()))?,
            );
        }
        Ok(staged)
    }

    /// The path the user gave.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    fn writer(&mut self) -> std::io::Result<&mut std::io::BufWriter<File>> {
        self.file
            .as_mut()
            .ok_or_else(|| std::io::Error::other("the file was finished"))
    }
}

impl Write for OutputFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer()?.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.writer()?.flush()
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if let Target::Replace { tmp, id, .. } = &self.target {
            let mut list = unfinished();
            remove_ours(tmp, *id);
            forget(&mut list, tmp);
        }
    }
}

/// A file written whole and waiting to be moved into place ([`OutputFile::stage`]): by
/// [`Staged::commit`], or with an output folder by [`OutputDir::commit_with`](super::OutputDir::commit_with). Dropped without
/// that, it leaves nothing behind.
pub struct Staged {
    shown: PathBuf,
    target: Target,
    /// Kept open (and locked) until the file is in place.
    file: Option<File>,
    done: bool,
}

impl Staged {
    /// Moves the file into place.
    pub fn commit(mut self) -> Result<()> {
        let mut list = unfinished();
        self.put_in_place(&mut list, &mut Steps::default())
    }

    /// The path the user gave.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    /// The rename, with the list of unfinished outputs held, as one of `steps`.
    pub(super) fn put_in_place(&mut self, list: &mut Vec<Unfinished>, steps: &mut Steps) -> Result<()> {
        if let Target::Replace { path, tmp, .. } = &self.target {
            // Keep the permissions of the file being replaced (a shared log, a read-only copy).
            if let Ok(m) = std::fs::metadata(path) {
                let _ = std::fs::set_permissions(tmp, m.permissions());
            }
            steps.rename(tmp, path).map_err(io(Action::Write, &self.shown))?;
            forget(list, tmp);
        }
        self.done = true;
        self.file = None;
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Target::Replace { tmp, id, .. } = &self.target
            && !self.done
        {
            let mut list = unfinished();
            remove_ours(tmp, *id);
            forget(&mut list, tmp);
        }
    }
}

/// Where writing `path` lands: the file itself, or the end of its chain of symbolic links (which
/// may not exist yet, as when a shell writes through a dangling link).
fn follow_links(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_owned();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let to = std::fs::read_link(&p).map_err(io(Action::ReadLink, path))?;
                p = match p.parent() {
                    Some(dir) => dir.join(to),
                    None => to,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(OutputError::LinkLoop {
        path: path.to_owned(),
    })
}

/// Refuses to replace an existing regular file at `path` unless `same_kind` recognises it as a
/// file of the `kind` about to be written (an earlier output, so that running a command again
/// works); a user's other file is never lost. A new path, an empty file, a device or a FIFO is
/// fine. Call it before the work, as a command checks its folder first.
///
/// ```
/// use skin_core::output::check_replaceable;
///
/// let notes = std::env::temp_dir().join(format!("skin-replace-doc-{}.txt", std::process::id()));
/// std::fs::write(&notes, "my notes")?;
/// let is_map = |p: &std::path::Path| std::fs::read_to_string(p).is_ok_and(|t| t.contains("skin-tactile-map/1"));
/// assert!(check_replaceable(&notes, "a tactile map", is_map).is_err());
/// # std::fs::remove_file(&notes)?;
/// # Ok::<(), std::io::Error>(())
/// ```
pub fn check_replaceable(path: &Path, kind: &str, same_kind: impl FnOnce(&Path) -> bool) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() && m.len() > 0 && !same_kind(path) => Err(OutputError::Foreign {
            path: path.to_owned(),
            kind: kind.to_owned(),
        }),
        _ => Ok(()),
    }
}

/// Writes `contents` to the file `path` under the rules of this module.
pub fn write_file(path: &Path, contents: &[u8], inputs: &Inputs) -> Result<()> {
    let mut out = OutputFile::create(path, inputs)?;
    out.write_all(contents).map_err(io(Action::Write, path))?;
    out.commit()
}

/// Refuses `path` now, before any work, if another process is writing it with
/// [`OutputFile::create_exclusive`] (that function checks again, and holds the lock).
pub fn check_free(path: &Path) -> Result<()> {
    let Ok(target) = follow_links(path) else {
        return Ok(());
    };
    let (Some(dir), Some(name)) = (target.parent(), target.file_name()) else {
        return Ok(());
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let tmp = dir.join(partial_stem(&name.to_string_lossy()));
    match File::open(&tmp).map(|f| f.try_lock()) {
        Ok(Err(std::fs::TryLockError::WouldBlock)) => Err(OutputError::FileBusy {
            path: path.to_owned(),
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::output::test_util::names;

    #[test]
    fn threads_writing_one_file_at_once_each_finish_whole() {
        // Two sessions of one process filling one map cache: each file is built aside on its
        // own, so the last one moved into place is whole and neither writer fails.
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("cache").join("map.json");
        let texts: Vec<String> = (0..8).map(|k| format!("{k}").repeat(100_000)).collect();
        std::thread::scope(|s| {
            for t in &texts {
                let path = &path;
                s.spawn(move || write_file(path, t.as_bytes(), &Inputs::default()).unwrap());
            }
        });
        let got = std::fs::read_to_string(&path).unwrap();
        assert!(texts.contains(&got), "a whole file, not a mix");
        assert_eq!(
            names(&d.path().join("cache")),
            ["map.json"],
            "no temporary file left"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_is_written_through() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("real.json");
        std::fs::write(&target, "old").unwrap();
        let link = d.path().join("link.json");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_file(&link, b"new", &Inputs::default()).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
    }
}
