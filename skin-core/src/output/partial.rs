//! The partial files a file output is built in: `.NAME.partial-PID-N` beside it, locked while
//! written, so that the next writer of NAME removes a killed run's leftovers and never a live
//! writer's; and the one `.NAME.partial` of a file that one process at a time writes.

use super::ids::file_id;
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

/// The longest file name Linux, macOS and Windows take, bytes.
const NAME_MAX: usize = 255;
/// What a partial name adds after its stem: `-PID-N`, two numbers of up to 10 and 20 digits.
const PARTIAL_NUMBERS: usize = 1 + 10 + 1 + 20;

/// `.NAME.partial`: the stem of the partial files of `name`, NAME cut (at a character) so that
/// `.NAME.partial-PID-N` fits in a file name. The same for every writer of `name`, so the next
/// one finds a killed one's leftovers.
pub(super) fn partial_stem(name: &str) -> String {
    let room = NAME_MAX - ".".len() - ".partial".len() - PARTIAL_NUMBERS;
    let mut end = name.len().min(room);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    format!(".{}.partial", &name[..end])
}

/// Whether `file` (open) is the file at `path` (not one that replaced it).
pub(super) fn is_open_at(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => file_id(&a) == file_id(&b),
        _ => false,
    }
}

/// Removes the partial files `STEM-PID-N` in `dir` that no process is writing (their lock is
/// free): a killed run's leftovers. A live writer holds its lock from the moment its file
/// exists (see [`new_partial`]), so its file is never taken for a dead one, whatever the PIDs.
pub(super) fn remove_dead_partials(dir: &Path, stem: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(rest) = name
            .to_str()
            .and_then(|n| n.strip_prefix(stem))
            .and_then(|r| r.strip_prefix('-'))
        else {
            continue;
        };
        if !rest.split_once('-').is_some_and(|(a, b)| digits(a) && digits(b))
            || !e.file_type().is_ok_and(|t| t.is_file())
        {
            continue;
        }
        let path = e.path();
        let Ok(f) = File::open(&path) else {
            continue;
        };
        // Ours now: no writer holds it, and it is still the file we opened.
        if f.try_lock().is_ok() && is_open_at(&f, &path) {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// A new partial file `STEM-PID-N` in `dir`, locked while it exists. A file that another
/// process's clean-up took between its creation and its lock is left to it: another name.
pub(super) fn new_partial(dir: &Path, stem: &str) -> std::io::Result<(File, PathBuf)> {
    // Process-wide, as the names it tells apart are: every thread's partial files of one path
    // share the folder, whichever output value made them.
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let mut last = None;
    for _ in 0..100 {
        // The process id and a count of this process's outputs: two threads writing one path
        // at once (two sessions filling one map cache) each build their own file.
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = dir.join(format!("{stem}-{}-{n}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(f) => match f.try_lock() {
                Ok(()) if is_open_at(&f, &tmp) => return Ok((f, tmp)),
                // A file system without locks: written unprotected, as it has to be.
                Err(std::fs::TryLockError::Error(_)) => return Ok((f, tmp)),
                Ok(()) | Err(std::fs::TryLockError::WouldBlock) => {}
            },
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(e),
        }
        last = Some(tmp);
    }
    Err(std::io::Error::other(format!(
        "no free temporary name (last tried {})",
        last.unwrap_or_default().display()
    )))
}

/// The one partial file `STEM` of an exclusive output, locked; a killed writer's leftover is
/// emptied and reused. `Ok(None)`: another process holds it.
pub(super) fn exclusive_partial(dir: &Path, stem: &str) -> std::io::Result<Option<(File, PathBuf)>> {
    let tmp = dir.join(stem);
    for _ in 0..100 {
        // Never through a link or into a folder that stands at the name.
        if std::fs::symlink_metadata(&tmp).is_ok_and(|m| !m.is_file()) {
            return Err(std::io::Error::other(format!(
                "{} is in the way (not a file)",
                tmp.display()
            )));
        }
        let f = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(false)
            .open(&tmp)?;
        match f.try_lock() {
            Ok(()) | Err(std::fs::TryLockError::Error(_)) => {}
            Err(std::fs::TryLockError::WouldBlock) => return Ok(None),
        }
        // Locked, and still the file at that name (not one a finished writer renamed into
        // place after we opened it): ours.
        if is_open_at(&f, &tmp) {
            f.set_len(0)?;
            return Ok(Some((f, tmp)));
        }
    }
    Err(std::io::Error::other("the temporary file keeps being replaced"))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use crate::output::test_util::names;
    use crate::output::{Inputs, OutputError, OutputFile, check_free, write_file};
    use std::io::Write as _;

    #[test]
    fn a_dead_writers_partial_file_is_removed_and_a_live_ones_kept() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("session.mcap");
        // A killed run's leftover (its process id long reused), and one of an older skin.
        std::fs::write(d.path().join(".session.mcap.partial-4242-0"), "dead").unwrap();
        std::fs::write(d.path().join(".session.mcap.partial-1-17"), "dead").unwrap();
        // Not skin's partial files: kept.
        std::fs::write(d.path().join(".session.mcap.partial-notes"), "mine").unwrap();
        std::fs::write(d.path().join(".other.mcap.partial-1-1"), "another output's").unwrap();
        let live = OutputFile::create(&path, &Inputs::default()).unwrap();
        let mut live_names = names(d.path());
        live_names.retain(|n| n.starts_with(".session.mcap.partial-") && n != ".session.mcap.partial-notes");
        assert_eq!(live_names.len(), 1, "{live_names:?}");
        // Another writer of the same file meanwhile: the live partial file stays.
        write_file(&path, b"second", &Inputs::default()).unwrap();
        assert!(d.path().join(&live_names[0]).exists());
        live.commit().unwrap();
        assert_eq!(
            names(d.path()),
            [
                ".other.mcap.partial-1-1",
                ".session.mcap.partial-notes",
                "session.mcap"
            ]
        );
    }

    #[test]
    fn a_second_exclusive_writer_is_refused_at_once() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("run.mcap");
        // A killed writer's partial file: taken over, emptied.
        std::fs::write(d.path().join(".run.mcap.partial"), "a killed run's bytes").unwrap();
        let mut first = OutputFile::create_exclusive(&path, &Inputs::default()).unwrap();
        let e = OutputFile::create_exclusive(&path, &Inputs::default())
            .err()
            .unwrap();
        assert!(matches!(e, OutputError::FileBusy { .. }), "{e}");
        assert!(
            e.to_string()
                .contains("run.mcap: another skin command is writing this file")
        );
        assert!(matches!(check_free(&path), Err(OutputError::FileBusy { .. })));
        first.write_all(b"whole").unwrap();
        first.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "whole");
        assert_eq!(names(d.path()), ["run.mcap"]);
        check_free(&path).unwrap();
        // Given up: the next writer goes on.
        drop(OutputFile::create_exclusive(&path, &Inputs::default()).unwrap());
        assert_eq!(names(d.path()), ["run.mcap"]);
        check_free(&path).unwrap();
    }

    #[test]
    fn the_longest_legal_name_can_be_written() {
        let d = tempfile::tempdir().unwrap();
        for n in [200, 236, 237, 255] {
            let name = format!("{}.json", "é".repeat((n - 5) / 2)) + &"x".repeat((n - 5) % 2);
            assert_eq!(name.len(), n);
            let path = d.path().join(&name);
            write_file(&path, b"{}", &Inputs::default()).unwrap();
            OutputFile::create_exclusive(&path, &Inputs::default())
                .unwrap()
                .commit()
                .unwrap();
            assert!(path.is_file());
        }
        assert_eq!(names(d.path()).len(), 4, "no temporary file left");
    }
}
