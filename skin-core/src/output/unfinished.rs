//! Unfinished outputs, for an application's signal handler.
//!
//! This is the one process-wide state of the output rules, and it has to be: a signal handler
//! (Ctrl-C, SIGTERM) runs outside every call that holds an output, so the outputs under way
//! must be findable from nowhere else than the process itself. The list holds what this process
//! is building, and a gate keeps files from being created once the handler has removed them.
//! Everything else of an output is a value its writer holds.

use super::ids::{FileId, file_id, is_same};
use super::records::LOCK;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, RwLock, RwLockReadGuard};

/// What this process is building: removed by [`abandon_unfinished`]. Each is removed only if it
/// is still the file or folder this process made (device and inode), never one that took its
/// place.
pub(super) enum Unfinished {
    /// A temporary file or folder of skin's own making: removed whole.
    Temporary(PathBuf, Option<FileId>),
    /// An output folder this process created: removed only if nothing else is in it.
    CreatedFolder(PathBuf, Option<FileId>),
}

/// Every unfinished output of the process. Held while files move into place, so that
/// [`abandon_unfinished`] waits for a move to end instead of cutting it short. Process-wide
/// because a signal handler reaches nothing else (see the module's note).
static UNFINISHED: Mutex<Vec<Unfinished>> = Mutex::new(Vec::new());

/// Held (shared) while files are created in an unfinished output; [`abandon_unfinished`] takes
/// it for good, so that no file appears in a folder after it was removed. Process-wide with
/// [`UNFINISHED`], for the same signal handler.
static GATE: RwLock<()> = RwLock::new(());

/// The list of unfinished outputs, locked (a writer that panicked left it usable).
pub(super) fn unfinished() -> MutexGuard<'static, Vec<Unfinished>> {
    UNFINISHED.lock().unwrap_or_else(|e| e.into_inner())
}

/// Takes `path` off the list: it is in place, or removed.
pub(super) fn forget(list: &mut Vec<Unfinished>, path: &Path) {
    list.retain(|u| match u {
        Unfinished::Temporary(p, _) | Unfinished::CreatedFolder(p, _) => p != path,
    });
}

thread_local! {
    /// How many [`Writing`] guards this thread holds (the gate is taken by the first): a
    /// thread that took the shared gate must not wait on it again behind the handler's
    /// exclusive claim.
    static WRITING: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Held while files are created in an unfinished output ([`writing`]).
pub struct Writing {
    _gate: Option<RwLockReadGuard<'static, ()>>,
}

impl Drop for Writing {
    fn drop(&mut self) {
        WRITING.set(WRITING.get().saturating_sub(1));
    }
}

/// A guard to hold while creating files in an unfinished output (a sink's image in
/// [`OutputDir::path`](super::OutputDir::path), a summary): [`abandon_unfinished`] waits until
/// it is dropped, and once that has run, taking this guard blocks for good (the process is
/// ending). A thread may hold several (creating an [`OutputFile`](super::OutputFile) takes one
/// too).
pub fn writing() -> Writing {
    let gate = (WRITING.get() == 0).then(|| GATE.read().unwrap_or_else(|e| e.into_inner()));
    WRITING.set(WRITING.get() + 1);
    Writing { _gate: gate }
}

/// Removes what every unfinished [`OutputFile`](super::OutputFile) and
/// [`OutputDir`](super::OutputDir) of this process has built, so that the previous outputs stay
/// as they were. For a signal handler that ends the process right after: it waits for the files
/// being created under [`writing`] and for an output being moved into place, and from then on
/// nothing more is created there (writers block). Returns how many were abandoned.
pub fn abandon_unfinished() -> usize {
    let gate = GATE.write().unwrap_or_else(|e| e.into_inner());
    // Held until the process ends: a writer that comes after would recreate what goes now.
    std::mem::forget(gate);
    let mut list = unfinished();
    let n = list.len();
    for u in list.drain(..) {
        match u {
            Unfinished::Temporary(p, id) => remove_ours(&p, id),
            Unfinished::CreatedFolder(p, id) => {
                if is_same(&p, id) {
                    let _ = std::fs::remove_file(p.join(LOCK));
                    let _ = std::fs::remove_dir(&p);
                }
            }
        }
    }
    n
}

/// Removes a temporary file or folder of skin's own making (if it is still that one).
pub(super) fn remove_ours(path: &Path, id: Option<FileId>) {
    match std::fs::symlink_metadata(path) {
        Ok(m) if id.is_some_and(|id| file_id(&m) != id) => {}
        Ok(m) if m.is_dir() => {
            let _ = std::fs::remove_dir_all(path);
        }
        Ok(_) => {
            let _ = std::fs::remove_file(path);
        }
        Err(_) => {}
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::output::{Inputs, write_file};

    #[test]
    fn the_writing_guard_nests_on_one_thread() {
        let d = tempfile::tempdir().unwrap();
        let _a = writing();
        let _b = writing();
        write_file(&d.path().join("x"), b"x", &Inputs::default()).unwrap();
    }
}
