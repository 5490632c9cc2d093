//! Writing a user's outputs without ever putting their files at risk (the rules a user reads in
//! the README's "Your files are safe").
//!
//! Every writer of the workspace (the `skin` commands, and a robot stack's own sinks) goes through
//! this module, so the rules hold everywhere:
//!
//! - An output that is one of the inputs is refused: the same canonical path, or the same device
//!   and inode (a hard link or a symbolic link to it). See [`Inputs`].
//! - A file ([`OutputFile`], [`write_file`]) is built aside as `.NAME.partial-PID-N` in its folder
//!   (NAME shortened so that the whole stays a legal file name) and renamed into place only when
//!   complete. The partial file is locked while it is written: the next writer of NAME removes
//!   the partial files whose lock nobody holds (a killed run's), never a live writer's. A file
//!   that one process at a time may write ([`OutputFile::create_exclusive`], an MCAP recording)
//!   is built as `.NAME.partial`, whose lock makes a second writer refuse at once.
//! - A device, a FIFO or a socket is written through, never replaced; a symbolic link is
//!   followed and its target written (the link stays, and a dangling one gets its target
//!   created). A folder given as a file is refused. An existing file is replaced only if it is
//!   of the kind being written ([`check_replaceable`]): an earlier output, never a user's other
//!   file.
//! - A folder ([`OutputDir`]) is written into only if it is new, empty, or an earlier output of
//!   the same command (its hidden manifest `.skin-output` says so). Any other folder needs
//!   `force`, and even then only the files the command writes are replaced; nothing else there is
//!   touched. New files are built in `DIR/.skin-partial/` and moved into place by
//!   [`OutputDir::commit`]; files that the earlier output listed and this one does not write are
//!   removed (they were skin's). An advisory lock (`DIR/.skin-lock`) makes a second writer refuse
//!   at once.
//! - Everything a commit writes (the manifest, the `INCOMPLETE` marker) is written aside before
//!   the first file moves, so a full disk stops a commit before it changes anything; then only
//!   renames follow. A new folder whose commit fails is removed; a folder that held an earlier
//!   output and whose commit fails half-way keeps a readable `INCOMPLETE` that lists the files
//!   that may be missing or old, and the next run of the command accepts and replaces it. Files
//!   finished beside the folder ([`Staged`], an MCAP file) move into place with it
//!   ([`OutputDir::commit_with`]), after its files and before its marker goes.
//! - An output dropped without its commit removes what it built: the previous output stays as it
//!   was. An application that ends on a signal calls [`abandon_unfinished`] first; it waits for
//!   writes under [`writing`] and for a commit under way, and no such write starts after it.
//!
//! The rules by concern, one file each: the inputs an output must not be (`inputs`); the
//! partial files a file is built in (`partial`); a file output (`file`); a folder output and its
//! lock (`folder`); the records that say which files of a folder are skin's, its manifest and
//! `INCOMPLETE` marker (`records`); the moves of a folder's commit (`commit`) and the file
//! operations they are made of (`steps`); the list of unfinished outputs that a signal handler
//! removes (`unfinished`); per-input output names (`names`); a file's identity (`ids`); and the
//! errors (`error`).
//!
//! ```
//! use skin_core::output::{Inputs, OutputDir, write_file};
//!
//! let tmp = std::env::temp_dir().join(format!("skin-output-doc-{}", std::process::id()));
//! let layout = tmp.join("layout.json");
//! std::fs::create_dir_all(&tmp)?;
//! std::fs::write(&layout, "{}")?;
//! let inputs = Inputs::new([&layout]);
//!
//! // An output that is an input is refused, and the input kept.
//! assert!(write_file(&layout, b"map", &inputs).is_err());
//!
//! // A folder output: files are written into `out.path()`, then moved into place at once.
//! let out = OutputDir::create(&tmp.join("images"), "my-sink", false, &inputs)?;
//! std::fs::write(out.path().join("frame_00001.png"), b"...")?;
//! out.commit()?;
//! assert!(tmp.join("images/frame_00001.png").is_file());
//! # std::fs::remove_dir_all(&tmp)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod commit;
mod error;
mod file;
mod folder;
mod ids;
mod inputs;
mod names;
mod partial;
mod records;
mod steps;
mod unfinished;

pub use error::{Action, OutputError, Whose};
pub use file::{OutputFile, Staged, check_free, check_replaceable, write_file};
pub use folder::OutputDir;
pub use inputs::{Inputs, distinct};
pub use names::output_names;
pub use unfinished::{Writing, abandon_unfinished, writing};

#[cfg(test)]
mod test_util;
