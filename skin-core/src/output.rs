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

use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::{Mutex, MutexGuard, RwLock, RwLockReadGuard};

/// The manifest of a folder output: which command wrote it and which files are its.
const MANIFEST: &str = ".skin-output";
/// The lock that keeps two writers out of one folder.
const LOCK: &str = ".skin-lock";
/// Where a folder's new files are built.
const STAGING: &str = ".skin-partial";
/// Left in a folder while files move into place (and after, if the move was cut short).
const INCOMPLETE: &str = "INCOMPLETE";
/// The first line of an `INCOMPLETE` marker, after the command's name.
const INCOMPLETE_SAYS: &str =
    " was moving its files into this folder when it stopped: these may be missing or from an earlier run:";

/// Why an output cannot be written. Each variant names the path the user gave.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output is one of the inputs (`input` as the user named it).
    #[error("{}: the output is {}; write it elsewhere", output.display(), same_as(output, input))]
    IsInput {
        /// The output.
        output: PathBuf,
        /// The input it would overwrite.
        input: PathBuf,
    },
    /// Two outputs name the same file.
    #[error("{first} and {second} name the same file {}; give each its own", path.display())]
    SameFile {
        /// How the first is named (a flag, e.g. `-o`).
        first: String,
        /// How the second is named.
        second: String,
        /// The file.
        path: PathBuf,
    },
    /// A folder where a file is expected.
    #[error("{}: a folder; give a file name (e.g. {})", path.display(), path.join("out").display())]
    IsFolder {
        /// The path given.
        path: PathBuf,
    },
    /// Something other than a folder where a folder is expected.
    #[error("{}: exists and is not a folder", path.display())]
    NotAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// A folder that holds files this command did not write.
    #[error(
        "{}: holds {whose} ({}); choose a new or empty folder, or force writing {command}'s files into it (nothing else there is touched)",
        dir.display(),
        listing(files)
    )]
    NotOurs {
        /// The folder.
        dir: PathBuf,
        /// "files that skin did not write", or "the output of `skin image`".
        whose: String,
        /// Some of those files, sorted.
        files: Vec<String>,
        /// The command that wanted to write.
        command: String,
    },
    /// Another process holds the folder's lock.
    #[error(
        "{}: another skin command is writing this folder; wait for it to finish or choose another output folder",
        dir.display()
    )]
    Busy {
        /// The folder.
        dir: PathBuf,
    },
    /// Another process is writing the file ([`OutputFile::create_exclusive`]).
    #[error(
        "{}: another skin command is writing this file; wait for it to finish or choose another name",
        path.display()
    )]
    FileBusy {
        /// The file.
        path: PathBuf,
    },
    /// The output folder was deleted, moved or replaced while the command wrote it.
    #[error(
        "{}: the output folder was moved or deleted while skin wrote it; nothing was put there: run again",
        dir.display()
    )]
    Vanished {
        /// The folder.
        dir: PathBuf,
    },
    /// A folder or a link stands where the command writes a file.
    #[error(
        "{}: is a folder or a link, where {command} writes a file; move it away or choose another output folder",
        path.display()
    )]
    Blocked {
        /// The path in the output folder.
        path: PathBuf,
        /// The command.
        command: String,
    },
    /// A chain of symbolic links that does not end.
    #[error("{}: too many levels of symbolic links", path.display())]
    LinkLoop {
        /// The path given.
        path: PathBuf,
    },
    /// An existing file that is not of the kind being written (a user's file, not an earlier
    /// output): replacing it would lose it.
    #[error(
        "{}: exists and is not {kind}; skin replaces only a file of the kind it writes there: move it or choose another name",
        path.display()
    )]
    Foreign {
        /// The file.
        path: PathBuf,
        /// What is written there, e.g. "a tactile map".
        kind: String,
    },
    /// Two inputs whose outputs would have the same name ([`output_names`]).
    #[error(
        "{} and {}: both would be written as {name}; give inputs distinct names (or list each once)",
        first.display(),
        second.display()
    )]
    SameName {
        /// The first input.
        first: PathBuf,
        /// The second.
        second: PathBuf,
        /// The name both would have.
        name: String,
    },
    /// The operating system refused (a full disk, no permission, ...).
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// What was being done: "write", "create", "read", "lock".
        action: &'static str,
        /// The path the user gave (never a temporary name).
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
}

fn same_as(output: &Path, input: &Path) -> String {
    if output == input {
        "also an input".to_owned()
    } else {
        format!("the input {} (the same file)", input.display())
    }
}

fn listing(files: &[String]) -> String {
    let shown: Vec<&str> = files.iter().take(3).map(String::as_str).collect();
    match files.len() {
        n if n > 3 => format!("{} and {} more", shown.join(", "), n - 3),
        _ => shown.join(", "),
    }
}

fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> OutputError + 'a {
    move |source| OutputError::Io {
        action,
        path: path.to_owned(),
        source,
    }
}

type Result<T, E = OutputError> = std::result::Result<T, E>;

mod names;
pub use names::output_names;

/// A file's device and inode: what it is, whatever its name.
type FileId = (u64, u64);

// ---------------------------------------------------------------------------------------------
// The file operations of a commit

/// Every write, rename and removal a commit makes goes through here, so that a test can make
/// any one of them fail as a full disk (or a vanished folder) would.
mod fsop {
    use std::io;
    use std::path::Path;

    #[cfg(test)]
    thread_local! {
        /// Operations left before the one that fails (none: nothing fails).
        pub(super) static FAIL_AFTER: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
    }

    fn step() -> io::Result<()> {
        #[cfg(test)]
        match FAIL_AFTER.get() {
            Some(0) => {
                FAIL_AFTER.set(None);
                return Err(io::Error::from_raw_os_error(28)); // ENOSPC
            }
            Some(n) => FAIL_AFTER.set(Some(n - 1)),
            None => {}
        }
        Ok(())
    }

    /// A new file holding `bytes`, every write checked.
    pub(super) fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
        step()?;
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)?;
        io::Write::write_all(&mut f, bytes)?;
        io::Write::flush(&mut f)
    }

    pub(super) fn rename(from: &Path, to: &Path) -> io::Result<()> {
        step()?;
        std::fs::rename(from, to)
    }

    pub(super) fn remove_file(path: &Path) -> io::Result<()> {
        step()?;
        std::fs::remove_file(path)
    }
}

// ---------------------------------------------------------------------------------------------
// Unfinished outputs, for an application's signal handler

/// What this process is building: removed by [`abandon_unfinished`]. Each is removed only if it
/// is still the file or folder this process made (device and inode), never one that took its
/// place.
enum Unfinished {
    /// A temporary file or folder of skin's own making: removed whole.
    Temporary(PathBuf, Option<FileId>),
    /// An output folder this process created: removed only if nothing else is in it.
    CreatedFolder(PathBuf, Option<FileId>),
}

/// Every unfinished output of the process. Held while files move into place, so that
/// [`abandon_unfinished`] waits for a move to end instead of cutting it short.
static UNFINISHED: Mutex<Vec<Unfinished>> = Mutex::new(Vec::new());

/// Held (shared) while files are created in an unfinished output; [`abandon_unfinished`] takes
/// it for good, so that no file appears in a folder after it was removed.
static GATE: RwLock<()> = RwLock::new(());

fn unfinished() -> MutexGuard<'static, Vec<Unfinished>> {
    UNFINISHED.lock().unwrap_or_else(|e| e.into_inner())
}

fn forget(list: &mut Vec<Unfinished>, path: &Path) {
    list.retain(|u| match u {
        Unfinished::Temporary(p, _) | Unfinished::CreatedFolder(p, _) => p != path,
    });
}

thread_local! {
    /// How many [`Writing`] guards this thread holds (the gate is taken by the first).
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
/// [`OutputDir::path`], a summary): [`abandon_unfinished`] waits until it is dropped, and once
/// that has run, taking this guard blocks for good (the process is ending). A thread may hold
/// several (creating an [`OutputFile`] takes one too).
pub fn writing() -> Writing {
    let gate = (WRITING.get() == 0).then(|| GATE.read().unwrap_or_else(|e| e.into_inner()));
    WRITING.set(WRITING.get() + 1);
    Writing { _gate: gate }
}

/// Removes what every unfinished [`OutputFile`] and [`OutputDir`] of this process has built, so
/// that the previous outputs stay as they were. For a signal handler that ends the process right
/// after: it waits for the files being created under [`writing`] and for an output being moved
/// into place, and from then on nothing more is created there (writers block). Returns how many
/// were abandoned.
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

/// Whether `path` is still the file or folder `id` (unknown ids match).
fn is_same(path: &Path, id: Option<FileId>) -> bool {
    match id {
        Some(id) => std::fs::symlink_metadata(path).is_ok_and(|m| file_id(&m) == id),
        None => true,
    }
}

/// The device and inode of the folder a user named: through a symbolic link (an output folder
/// given as a link is written through it).
fn folder_id(path: &Path) -> Option<FileId> {
    std::fs::metadata(path).ok().map(|m| file_id(&m))
}

fn id_of(path: &Path) -> Option<FileId> {
    std::fs::symlink_metadata(path).ok().map(|m| file_id(&m))
}

/// Removes a temporary file or folder of skin's own making (if it is still that one).
fn remove_ours(path: &Path, id: Option<FileId>) {
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

// ---------------------------------------------------------------------------------------------
// Inputs

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
    fn find(&self, path: &Path) -> Option<&Path> {
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

#[cfg(unix)]
fn file_id(m: &std::fs::Metadata) -> (u64, u64) {
    use std::os::unix::fs::MetadataExt as _;
    (m.dev(), m.ino())
}

#[cfg(not(unix))]
fn file_id(_: &std::fs::Metadata) -> (u64, u64) {
    (0, 0)
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

// ---------------------------------------------------------------------------------------------
// Partial files

/// The longest file name Linux, macOS and Windows take, bytes.
const NAME_MAX: usize = 255;
/// What a partial name adds after its stem: `-PID-N`, two numbers of up to 10 and 20 digits.
const PARTIAL_NUMBERS: usize = 1 + 10 + 1 + 20;

/// `.NAME.partial`: the stem of the partial files of `name`, NAME cut (at a character) so that
/// `.NAME.partial-PID-N` fits in a file name. The same for every writer of `name`, so the next
/// one finds a killed one's leftovers.
fn partial_stem(name: &str) -> String {
    let room = NAME_MAX - ".".len() - ".partial".len() - PARTIAL_NUMBERS;
    let mut end = name.len().min(room);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    format!(".{}.partial", &name[..end])
}

/// Whether `file` (open) is the file at `path` (not one that replaced it).
fn is_open_at(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => file_id(&a) == file_id(&b),
        _ => false,
    }
}

/// Removes the partial files `STEM-PID-N` in `dir` that no process is writing (their lock is
/// free): a killed run's leftovers. A live writer holds its lock from the moment its file
/// exists (see [`new_partial`]), so its file is never taken for a dead one, whatever the PIDs.
fn remove_dead_partials(dir: &Path, stem: &str) {
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
fn new_partial(dir: &Path, stem: &str) -> std::io::Result<(File, PathBuf)> {
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
fn exclusive_partial(dir: &Path, stem: &str) -> std::io::Result<Option<(File, PathBuf)>> {
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

// ---------------------------------------------------------------------------------------------
// One file

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
            return Err(io("write", path)(std::io::ErrorKind::InvalidInput.into()));
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
                .map_err(io("write", path))?;
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
        std::fs::create_dir_all(dir).map_err(io("create the folder of", path))?;
        remove_dead_partials(dir, &stem);
        let made = if exclusive {
            exclusive_partial(dir, &stem).map_err(io("write", path))?
        } else {
            Some(new_partial(dir, &stem).map_err(io("write", path))?)
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
    /// [`Staged`] file moves with [`Staged::commit`] or with a folder ([`OutputDir::commit_with`]).
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
                    .map_err(|e| io("write", &self.shown)(e.into_error()))?,
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
/// [`Staged::commit`], or with an output folder by [`OutputDir::commit_with`]. Dropped without
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
        self.put_in_place(&mut list)
    }

    /// The path the user gave.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    /// The rename, with the list of unfinished outputs held.
    fn put_in_place(&mut self, list: &mut Vec<Unfinished>) -> Result<()> {
        if let Target::Replace { path, tmp, .. } = &self.target {
            // Keep the permissions of the file being replaced (a shared log, a read-only copy).
            if let Ok(m) = std::fs::metadata(path) {
                let _ = std::fs::set_permissions(tmp, m.permissions());
            }
            fsop::rename(tmp, path).map_err(io("write", &self.shown))?;
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
                let to = std::fs::read_link(&p).map_err(io("read the link", path))?;
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
    out.write_all(contents).map_err(io("write", path))?;
    out.commit()
}

// ---------------------------------------------------------------------------------------------
// A folder

/// What `.skin-output` records.
#[derive(serde::Serialize, serde::Deserialize)]
struct Manifest {
    /// The command that wrote the folder, e.g. "skin run".
    command: String,
    /// The files it wrote, relative to the folder.
    files: Vec<String>,
}

impl Manifest {
    fn read(dir: &Path) -> Option<Manifest> {
        let text = std::fs::read_to_string(dir.join(MANIFEST)).ok()?;
        serde_json::from_str(&text).ok()
    }

    /// An `INCOMPLETE` marker: the command's line, then a file a line.
    fn read_marker(dir: &Path) -> Option<Manifest> {
        let text = std::fs::read_to_string(dir.join(INCOMPLETE)).ok()?;
        let mut lines = text.lines();
        let command = lines.next()?.strip_suffix(INCOMPLETE_SAYS)?.to_owned();
        Some(Manifest {
            command,
            files: lines.filter(|l| !l.is_empty()).map(str::to_owned).collect(),
        })
    }

    fn marker_text(&self) -> String {
        format!("{}{INCOMPLETE_SAYS}\n{}\n", self.command, self.files.join("\n"))
    }
}

/// A folder output being built: write into [`OutputDir::path`], then [`OutputDir::commit`].
/// Dropped without a commit, it removes what it built and leaves the folder as it was.
pub struct OutputDir {
    dir: PathBuf,
    staging: PathBuf,
    command: String,
    previous: BTreeSet<String>,
    inputs: Inputs,
    created: bool,
    /// Whether this process made the lock file (removed again if nothing is committed).
    lock_new: bool,
    /// The folder's and the staging folder's device and inode: a folder deleted or replaced
    /// while the command ran is not written into (nor removed).
    ids: (Option<FileId>, Option<FileId>),
    committed: bool,
    _lock: File,
}

/// A move of a commit: a file, or a whole folder the output folder lacks.
struct Move {
    from: PathBuf,
    to: PathBuf,
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
                std::fs::create_dir_all(dir).map_err(io("create", dir))?;
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
            return Err(io("write into", dir)(e));
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
            .map_err(io("write into", dir))?;
        match file.try_lock() {
            Ok(()) => Ok(file),
            Err(std::fs::TryLockError::WouldBlock) => Err(OutputError::Busy { dir: dir.to_owned() }),
            Err(std::fs::TryLockError::Error(e)) => Err(io("lock", dir)(e)),
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
        for e in std::fs::read_dir(dir).map_err(io("read", dir))?.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if [MANIFEST, LOCK, STAGING, INCOMPLETE].contains(&name.as_str()) {
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
                Some(m) => format!("the output of `{}`", m.command),
                None => "files that skin did not write".to_owned(),
            },
            files: foreign,
            command: command.to_owned(),
        })
    }

    /// The folder to write the new files into (moved into place by [`OutputDir::commit`]).
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The folder the user named.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Moves the new files into place, removes files of the previous output that this one does
    /// not have, and records the new list in the manifest.
    pub fn commit(self) -> Result<()> {
        self.commit_with(Vec::new())
    }

    /// As [`OutputDir::commit`], and moves `files` (finished beside the folder, e.g. a
    /// recording of the same run) into place with it: if the folder's commit fails before its
    /// files move, none of `files` moves either; they move after the folder's files and before
    /// its manifest, so a failure between leaves the folder marked `INCOMPLETE`.
    pub fn commit_with(mut self, mut files: Vec<Staged>) -> Result<()> {
        if folder_id(&self.dir) != self.ids.0 || id_of(&self.staging) != self.ids.1 {
            return Err(OutputError::Vanished {
                dir: self.dir.clone(),
            });
        }
        let (moves, names) = self.plan()?;
        let new: BTreeSet<&String> = names.iter().collect();
        // Files of the earlier output that this one does not have: removed once the new files
        // are in. The manifest lists them too, so one that cannot be removed stays skin's.
        let old: Vec<&String> = self
            .previous
            .iter()
            .filter(|old| !new.contains(old))
            .filter(|old| std::fs::symlink_metadata(self.dir.join(old)).is_ok_and(|m| m.is_file()))
            .collect();
        let mut listed = names.clone();
        listed.extend(old.iter().map(|s| (*s).clone()));
        listed.sort();
        let manifest = Manifest {
            command: self.command.clone(),
            files: listed,
        };
        let marker = Manifest {
            command: self.command.clone(),
            files: names.clone(),
        };
        // Everything that takes space is written now, aside, each write checked: a full disk
        // stops the commit here, with nothing moved.
        let manifest_aside = self.staging.join(MANIFEST);
        let marker_aside = self.staging.join(INCOMPLETE);
        let text = serde_json::to_string_pretty(&manifest)
            .map_err(|e| io("write into", &self.dir)(std::io::Error::other(e)))?;
        fsop::write(&manifest_aside, text.as_bytes()).map_err(io("write into", &self.dir))?;
        fsop::write(&marker_aside, marker.marker_text().as_bytes()).map_err(io("write into", &self.dir))?;
        // From here only renames, while a signal handler waits.
        let mut list = unfinished();
        let marker_path = self.dir.join(INCOMPLETE);
        let mut done: Vec<&Move> = Vec::new();
        let result = (|| {
            fsop::rename(&marker_aside, &marker_path).map_err(io("write into", &self.dir))?;
            for m in &moves {
                fsop::rename(&m.from, &m.to).map_err(io("write", &m.to))?;
                done.push(m);
            }
            for o in &old {
                let path = self.dir.join(o);
                // An input that now sits where an old output was is the user's: never removed.
                if self.inputs.find(&path).is_none() && fsop::remove_file(&path).is_ok() {
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
            fsop::rename(&manifest_aside, &self.dir.join(MANIFEST)).map_err(io("write into", &self.dir))?;
            for f in &mut files {
                f.put_in_place(&mut list)?;
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                // A marker that cannot be removed only says "incomplete" of a complete folder.
                let _ = fsop::remove_file(&marker_path);
                let _ = std::fs::remove_dir_all(&self.staging);
                self.committed = true;
                forget(&mut list, &self.staging);
                forget(&mut list, &self.dir);
                Ok(())
            }
            Err(e) => {
                if self.created {
                    // A new folder goes back to absent: every move undone (renames back need no
                    // space), then the folder itself goes with this output.
                    for m in done.iter().rev() {
                        let _ = std::fs::rename(&m.to, &m.from);
                    }
                    let manifest_path = self.dir.join(MANIFEST);
                    if std::fs::symlink_metadata(&manifest_path).is_ok() {
                        let _ = std::fs::rename(&manifest_path, &manifest_aside);
                    }
                    let _ = std::fs::remove_file(&marker_path);
                }
                // Otherwise the marker stays (if it got there): the folder says it is unfinished
                // and lists what may be missing; the next run accepts it.
                Err(e)
            }
        }
    }

    /// The moves of a commit and the new output's files (relative, `/`-separated, sorted);
    /// everything checked before anything moves.
    fn plan(&self) -> Result<(Vec<Move>, Vec<String>)> {
        let mut files = Vec::new();
        walk(&self.staging, Path::new(""), &mut files).map_err(io("read", &self.dir))?;
        files.sort();
        for rel in &files {
            let dest = self.dir.join(rel);
            let top = rel.components().count() == 1;
            let name = rel.to_string_lossy();
            if top && [MANIFEST, LOCK, STAGING, INCOMPLETE].contains(&name.as_ref()) {
                return Err(io("write", &dest)(std::io::Error::other(
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
            .map_err(io("read", &self.dir))?
            .collect::<std::io::Result<_>>()
            .map_err(io("read", &self.dir))?;
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let r = rel.join(e.file_name());
            let to = self.dir.join(&r);
            let is_dir = e.file_type().map_err(io("read", &self.dir))?.is_dir();
            let blocked = || OutputError::Blocked {
                path: to.clone(),
                command: self.command.clone(),
            };
            match std::fs::symlink_metadata(&to) {
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => moves.push(Move {
                    from: self.staging.join(&r),
                    to: to.clone(),
                }),
                Err(e) => return Err(io("read", &to)(e)),
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

/// Lists the files under `dir` (relative to it).
fn walk(dir: &Path, rel: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
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

fn slash(p: &Path) -> String {
    p.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

/// A manifest entry is only trusted if it stays inside the folder.
fn is_relative_plain(name: &str) -> bool {
    !name.is_empty()
        && Path::new(name)
            .components()
            .all(|c| matches!(c, Component::Normal(_)))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::panic)]
    use super::*;

    /// The names in `dir`, sorted.
    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// Every file under `dir` with its bytes.
    fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut files = Vec::new();
        walk(dir, Path::new(""), &mut files).unwrap();
        let mut v: Vec<_> = files
            .iter()
            .map(|f| (slash(f), std::fs::read(dir.join(f)).unwrap()))
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_manifest_cannot_point_outside_its_folder() {
        assert!(is_relative_plain("touches/touch_000.png"));
        assert!(!is_relative_plain("../notes.txt"));
        assert!(!is_relative_plain("/etc/passwd"));
        assert!(!is_relative_plain(""));
    }

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
        fsop::FAIL_AFTER.set(Some(k));
        let r = o.commit_with(vec![staged]);
        let failed = fsop::FAIL_AFTER.get().is_none();
        fsop::FAIL_AFTER.set(None);
        (r, failed)
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

    #[test]
    fn a_second_writer_is_refused_at_once() {
        let d = tempfile::tempdir().unwrap();
        let _a = OutputDir::create(d.path(), "skin run", false, &Inputs::default()).unwrap();
        let e = OutputDir::create(d.path(), "skin run", false, &Inputs::default())
            .err()
            .unwrap();
        assert!(matches!(e, OutputError::Busy { .. }), "{e}");
    }

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

    #[test]
    fn the_writing_guard_nests_on_one_thread() {
        let d = tempfile::tempdir().unwrap();
        let _a = writing();
        let _b = writing();
        write_file(&d.path().join("x"), b"x", &Inputs::default()).unwrap();
    }
}
