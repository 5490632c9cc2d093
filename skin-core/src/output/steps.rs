//! The file operations of a commit. Every write, rename and removal a commit makes goes through
//! a [`Steps`] value that its caller passes in, so that a test can make any one of them fail as
//! a full disk (or a vanished folder) would.

use std::io;
use std::path::Path;

/// The writes, renames and removals of one commit, counted.
#[derive(Debug, Default)]
pub(super) struct Steps {
    /// Operations left before the one that fails (none: nothing fails).
    fail_after: Option<usize>,
}

impl Steps {
    /// Steps whose `k`-th (from 0) fails as on a full disk.
    #[cfg(test)]
    pub(super) fn failing_at(k: usize) -> Steps {
        Steps { fail_after: Some(k) }
    }

    /// Whether the step meant to fail was reached (and failed).
    #[cfg(test)]
    pub(super) fn failed(&self) -> bool {
        self.fail_after.is_none()
    }

    fn step(&mut self) -> io::Result<()> {
        match self.fail_after {
            Some(0) => {
                self.fail_after = None;
                Err(io::Error::from_raw_os_error(28)) // ENOSPC
            }
            Some(n) => {
                self.fail_after = Some(n - 1);
                Ok(())
            }
            None => Ok(()),
        }
    }

    /// A new file holding `bytes`, every write checked.
    pub(super) fn write(&mut self, path: &Path, bytes: &[u8]) -> io::Result<()> {
        self.step()?;
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)?;
        io::Write::write_all(&mut f, bytes)?;
        io::Write::flush(&mut f)
    }

    /// Renames `from` to `to`.
    pub(super) fn rename(&mut self, from: &Path, to: &Path) -> io::Result<()> {
        self.step()?;
        std::fs::rename(from, to)
    }

    /// Removes the file `path`.
    pub(super) fn remove_file(&mut self, path: &Path) -> io::Result<()> {
        self.step()?;
        std::fs::remove_file(path)
    }
}
