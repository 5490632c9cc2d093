//! Writing a user's outputs without ever putting their files at risk (DESIGN.md, "Data safety").
//!
//! Every writer of the workspace (the `skin` commands, and a robot stack's own sinks) goes through
//! this module, so the rules hold everywhere:
//!
//! - An output that is one of the inputs is refused: the same canonical path, or the same device
//!   and inode (a hard link or a symbolic link to it). See [`Inputs`].
//! - A file ([`OutputFile`], [`write_file`]) is built aside as `.NAME.partial-PID-N` in its folder
//!   and renamed into place only when complete. A device, a FIFO or a socket is written through,
//!   never replaced; a symbolic link is followed and its target written (the link stays, and a
//!   dangling one gets its target created). A folder given as a file is refused. An existing
//!   file is replaced only if it is of the kind being written ([`check_replaceable`]): an
//!   earlier output, never a user's other file.
//! - A folder ([`OutputDir`]) is written into only if it is new, empty, or an earlier output of
//!   the same command (its hidden manifest `.skin-output` says so). Any other folder needs
//!   `force`, and even then only the files the command writes are replaced; nothing else there is
//!   touched. New files are built in `DIR/.skin-partial/` and moved into place by
//!   [`OutputDir::commit`]; files that the earlier output listed and this one does not write are
//!   removed (they were skin's). An advisory lock (`DIR/.skin-lock`) makes a second writer refuse
//!   at once.
//! - An output dropped without its commit removes what it built: the previous output stays as it
//!   was. An application that ends on a signal calls [`abandon_unfinished`] first; only a harder
//!   stop (SIGKILL, power loss) while files move into place can leave an `INCOMPLETE` file in the
//!   folder, listing what may be missing.
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
use std::sync::{Mutex, MutexGuard};

/// The manifest of a folder output: which command wrote it and which files are its.
const MANIFEST: &str = ".skin-output";
/// The lock that keeps two writers out of one folder.
const LOCK: &str = ".skin-lock";
/// Where a folder's new files are built.
const STAGING: &str = ".skin-partial";
/// Left in a folder only if a move into place was cut short.
const INCOMPLETE: &str = "INCOMPLETE";

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

// ---------------------------------------------------------------------------------------------
// Unfinished outputs, for an application's signal handler

/// What this process is building: removed by [`abandon_unfinished`].
enum Unfinished {
    /// A temporary file or folder of skin's own making: removed whole.
    Temporary(PathBuf),
    /// An output folder this process created: removed only if nothing else is in it.
    CreatedFolder(PathBuf),
}

/// Every unfinished output of the process. Held while files move into place, so that
/// [`abandon_unfinished`] waits for a move to end instead of cutting it short.
static UNFINISHED: Mutex<Vec<Unfinished>> = Mutex::new(Vec::new());

fn unfinished() -> MutexGuard<'static, Vec<Unfinished>> {
    UNFINISHED.lock().unwrap_or_else(|e| e.into_inner())
}

fn forget(list: &mut Vec<Unfinished>, path: &Path) {
    list.retain(|u| match u {
        Unfinished::Temporary(p) | Unfinished::CreatedFolder(p) => p != path,
    });
}

/// Removes what every unfinished [`OutputFile`] and [`OutputDir`] of this process has built, so
/// that the previous outputs stay as they were. For a signal handler that ends the process right
/// after (an output being moved into place finishes first). Returns how many were abandoned.
pub fn abandon_unfinished() -> usize {
    let mut list = unfinished();
    let n = list.len();
    for u in list.drain(..) {
        match u {
            Unfinished::Temporary(p) => remove_ours(&p),
            Unfinished::CreatedFolder(p) => {
                let _ = std::fs::remove_file(p.join(LOCK));
                let _ = std::fs::remove_dir(&p);
            }
        }
    }
    n
}

/// Removes a temporary file or folder of skin's own making.
fn remove_ours(path: &Path) {
    match std::fs::symlink_metadata(path) {
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
    id: Option<(u64, u64)>,
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
// One file

/// How a file output is written.
enum Target {
    /// Built aside as `tmp`, renamed to `path` when complete.
    Replace { path: PathBuf, tmp: PathBuf },
    /// A device, FIFO or socket: written in place.
    Through,
}

/// A file output being written: `write` to it, then [`OutputFile::commit`]. Dropped without a
/// commit, it leaves nothing behind (and the previous file as it was).
pub struct OutputFile {
    shown: PathBuf,
    file: std::io::BufWriter<File>,
    target: Target,
    committed: bool,
}

impl OutputFile {
    /// Opens `path` for writing under the rules of this module.
    pub fn create(path: &Path, inputs: &Inputs) -> Result<OutputFile> {
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
                file: std::io::BufWriter::new(file),
                target: Target::Through,
                committed: false,
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
        std::fs::create_dir_all(dir).map_err(io("create the folder of", path))?;
        // The process id and a count of this process's outputs: two threads writing one path
        // at once (two sessions filling one map cache) each build their own file.
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = dir.join(format!(".{name}.partial-{}-{n}", std::process::id()));
        unfinished().push(Unfinished::Temporary(tmp.clone()));
        let open = || OpenOptions::new().write(true).create_new(true).open(&tmp);
        let file = open().or_else(|_| {
            // A leftover of a killed run that had this same process id: it is ours.
            remove_ours(&tmp);
            open()
        });
        let file = match file {
            Ok(f) => f,
            Err(e) => {
                forget(&mut unfinished(), &tmp);
                return Err(io("write", path)(e));
            }
        };
        Ok(OutputFile {
            shown: path.to_owned(),
            file: std::io::BufWriter::new(file),
            target: Target::Replace {
                path: target_path,
                tmp,
            },
            committed: false,
        })
    }

    /// Finishes the file: flushed, then moved into place.
    pub fn commit(mut self) -> Result<()> {
        self.file.flush().map_err(io("write", &self.shown))?;
        if let Target::Replace { path, tmp } = &self.target {
            // Keep the permissions of the file being replaced (a shared log, a read-only copy).
            if let Ok(m) = std::fs::metadata(path) {
                let _ = std::fs::set_permissions(tmp, m.permissions());
            }
            let mut list = unfinished();
            std::fs::rename(tmp, path).map_err(io("write", &self.shown))?;
            forget(&mut list, tmp);
        }
        self.committed = true;
        Ok(())
    }

    /// The path the user gave.
    pub fn path(&self) -> &Path {
        &self.shown
    }
}

impl Write for OutputFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if let Target::Replace { tmp, .. } = &self.target
            && !self.committed
        {
            let mut list = unfinished();
            remove_ours(tmp);
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
    committed: bool,
    _lock: File,
}

impl OutputDir {
    /// Opens `dir` as the output folder of `command` (e.g. "skin run", or a robot stack's sink
    /// name); `force` allows writing its files into a folder that holds other files.
    pub fn create(dir: &Path, command: &str, force: bool, inputs: &Inputs) -> Result<OutputDir> {
        if dir.as_os_str().is_empty() {
            return Err(OutputError::NotAFolder { path: dir.to_owned() });
        }
        if std::fs::metadata(dir).is_ok_and(|m| !m.is_dir()) {
            return Err(OutputError::NotAFolder { path: dir.to_owned() });
        }
        // Refuse before touching anything (checked again once the lock is held).
        Self::precheck(dir, command, force)?;
        let created = match std::fs::create_dir(dir) {
            Ok(()) => true,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => false,
            Err(_) => {
                std::fs::create_dir_all(dir).map_err(io("create", dir))?;
                true
            }
        };
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
        remove_ours(&staging); // a killed run's leftovers
        {
            let mut list = unfinished();
            list.push(Unfinished::Temporary(staging.clone()));
            if created {
                list.push(Unfinished::CreatedFolder(dir.to_owned()));
            }
        }
        let out = OutputDir {
            dir: dir.to_owned(),
            staging,
            command: command.to_owned(),
            previous,
            inputs: inputs.clone(),
            created,
            lock_new,
            committed: false,
            _lock: lock,
        };
        // Dropped on failure: the registration and the lock go with it.
        std::fs::create_dir(&out.staging).map_err(io("write into", dir))?;
        Ok(out)
    }

    /// Refuses `dir` now, before any work, if [`OutputDir::create`] would (it checks again).
    pub fn precheck(dir: &Path, command: &str, force: bool) -> Result<()> {
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

    /// Checks that the folder may be written into; returns the files of its previous output.
    fn contents(dir: &Path, command: &str, force: bool) -> Result<BTreeSet<String>> {
        let manifest = std::fs::read_to_string(dir.join(MANIFEST))
            .ok()
            .and_then(|t| serde_json::from_str::<Manifest>(&t).ok());
        if let Some(m) = &manifest
            && m.command == command
        {
            return Ok(m.files.iter().filter(|f| is_relative_plain(f)).cloned().collect());
        }
        if force {
            return Ok(BTreeSet::new());
        }
        let mut foreign: Vec<String> = std::fs::read_dir(dir)
            .map_err(io("read", dir))?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|name| ![MANIFEST, LOCK, STAGING, INCOMPLETE].contains(&name.as_str()))
            .collect();
        if foreign.is_empty() {
            return Ok(BTreeSet::new());
        }
        foreign.sort();
        Err(OutputError::NotOurs {
            dir: dir.to_owned(),
            whose: match &manifest {
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
    pub fn commit(mut self) -> Result<()> {
        let mut files = Vec::new();
        walk(&self.staging, Path::new(""), &mut files).map_err(io("read", &self.dir))?;
        files.sort();
        // Check everything before anything moves.
        for rel in &files {
            let dest = self.dir.join(rel);
            self.inputs.check(&dest)?;
            if std::fs::symlink_metadata(&dest).is_ok_and(|m| m.is_dir() || m.file_type().is_symlink()) {
                return Err(OutputError::Blocked {
                    path: dest,
                    command: self.command.clone(),
                });
            }
        }
        let names: Vec<String> = files.iter().map(|p| slash(p)).collect();
        let mut list = unfinished();
        let marker = self.dir.join(INCOMPLETE);
        let _ = std::fs::write(
            &marker,
            format!(
                "{} was moving its files into this folder when it stopped: these may be missing or from an earlier run:\n{}\n",
                self.command,
                names.join("\n")
            ),
        );
        for rel in &files {
            let dest = self.dir.join(rel);
            if let Some(parent) = dest.parent() {
                std::fs::create_dir_all(parent).map_err(io("create", parent))?;
            }
            std::fs::rename(self.staging.join(rel), &dest).map_err(io("write", &dest))?;
        }
        let new: BTreeSet<&String> = names.iter().collect();
        for old in self.previous.iter().filter(|old| !new.contains(old)) {
            let path = self.dir.join(old);
            // An input that now sits where an old output was is the user's: never removed.
            if self.inputs.find(&path).is_none()
                && std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file())
            {
                let _ = std::fs::remove_file(&path);
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
        let manifest = Manifest {
            command: self.command.clone(),
            files: names,
        };
        let text = serde_json::to_string_pretty(&manifest).unwrap_or_default();
        std::fs::write(self.dir.join(MANIFEST), text).map_err(io("write into", &self.dir))?;
        let _ = std::fs::remove_file(&marker);
        let _ = std::fs::remove_dir_all(&self.staging);
        self.committed = true;
        forget(&mut list, &self.staging);
        forget(&mut list, &self.dir);
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
        remove_ours(&self.staging);
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
    #![allow(clippy::unwrap_used)]
    use super::*;

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
        let left: Vec<_> = std::fs::read_dir(d.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(left, ["notes.txt"]);
    }

    #[test]
    fn a_rerun_replaces_only_its_own_files() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("out");
        let o = OutputDir::create(&out, "skin image", false, &Inputs::default()).unwrap();
        std::fs::write(o.path().join("a.png"), "1").unwrap();
        std::fs::write(o.path().join("b.png"), "1").unwrap();
        o.commit().unwrap();
        let o = OutputDir::create(&out, "skin image", false, &Inputs::default()).unwrap();
        std::fs::write(o.path().join("a.png"), "2").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a.png")).unwrap(), "2");
        assert!(!out.join("b.png").exists());
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
        let left: Vec<_> = std::fs::read_dir(d.path().join("cache"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, ["map.json"], "no temporary file left");
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
}
