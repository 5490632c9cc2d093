//! How every `skin` command writes: the user's files are never at risk.
//!
//! The rules (DESIGN.md, "Data safety"), in one place so that every command follows them:
//! - An output that is one of the command's inputs is refused (same canonical path, or the same
//!   device and inode: a hard link or a symlink to it).
//! - A file output is built aside (`.NAME.partial-PID` in its folder) and renamed into place only
//!   when complete. A device, a FIFO or a socket is written through, never replaced; a symlink is
//!   followed and its target written (the link stays). A folder given as a file is refused.
//! - A folder output is written into only if it is new, empty, or a previous output of the same
//!   command (the hidden manifest `.skin-output` says so); any other folder needs `--force`, and
//!   even then only the files the command writes are replaced, everything else is left alone.
//!   Files are built in `DIR/.skin-partial/` and moved into place when the command has finished;
//!   files that the previous output of the same command listed and this one does not write are
//!   removed (they were skin's). An advisory lock (`DIR/.skin-lock`) makes a second writer refuse
//!   at once.
//! - Ctrl-C or SIGTERM removes what is half-built and exits with status 130: the previous output
//!   stays as it was. The move into place cannot be interrupted by them; only a harder stop
//!   (SIGKILL, power loss) during that moment can leave an `INCOMPLETE` file, which lists what
//!   may be missing.

use anyhow::{Context as _, Result, bail};
use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// The manifest of a folder output: which command wrote it and which files are its.
const MANIFEST: &str = ".skin-output";
/// The lock that keeps two writers out of one folder.
const LOCK: &str = ".skin-lock";
/// Where a folder's new files are built.
const STAGING: &str = ".skin-partial";
/// Left in a folder only if a move into place was cut short.
const INCOMPLETE: &str = "INCOMPLETE";

// ---------------------------------------------------------------------------------------------
// Interrupts

/// Temporary paths to remove if the command is interrupted, and the lock held while outputs move
/// into place (so that an interrupt waits for the move to finish).
static CLEANUP: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Set by Ctrl-C / SIGTERM for commands that stop by themselves (`live`, `record`, `run --can`).
static STOP: AtomicBool = AtomicBool::new(false);
/// Whether the running command stops by itself on an interrupt (else the handler ends it).
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// Catches Ctrl-C, SIGTERM and SIGHUP for the whole process: a command that stops by itself is
/// told so (see [`stop_requested`]); any other is ended at once, after its half-built outputs
/// are removed.
pub fn install_interrupt_handler() {
    let handled = ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) && !STOP.swap(true, Ordering::SeqCst) {
            return; // the command finishes its outputs and stops; a second interrupt ends it
        }
        let paths = CLEANUP.lock().unwrap_or_else(|e| e.into_inner());
        for p in paths.iter() {
            remove_ours(p);
        }
        eprintln!("interrupted: nothing was written");
        std::process::exit(130);
    });
    // Without a handler an interrupt still ends the program; temporary names then stay hidden.
    let _ = handled;
}

/// Marks the running command as one that stops by itself on Ctrl-C (it polls [`stop_requested`]).
pub fn stop_gracefully() {
    GRACEFUL.store(true, Ordering::SeqCst);
}

/// The flag itself, for loops that take an `&AtomicBool`.
pub fn stop_flag() -> &'static AtomicBool {
    &STOP
}

fn register(path: &Path) {
    CLEANUP
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(path.to_owned());
}

fn unregister(path: &Path) {
    CLEANUP
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .retain(|p| p != path);
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
    /// The inputs among `paths` that exist (a missing one is the reader's error to report).
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

    /// Refuses `output` if it is one of the inputs.
    pub fn check(&self, output: &Path) -> Result<()> {
        if let Some(input) = self.find(output) {
            if input == output {
                bail!(
                    "{}: the output is also an input; write it elsewhere",
                    output.display()
                );
            }
            bail!(
                "{}: the output is the input {} (the same file); write it elsewhere",
                output.display(),
                input.display()
            );
        }
        Ok(())
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

/// Refuses two output flags that name the same file (`-o map.json --svg map.json`).
pub fn distinct(outputs: &[(&str, Option<&PathBuf>)]) -> Result<()> {
    let key = |p: &Path| -> PathBuf {
        let dir = p
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_owned());
        dir.join(p.file_name().unwrap_or_default())
    };
    let given: Vec<(&str, &PathBuf)> = outputs.iter().filter_map(|(f, p)| p.map(|p| (*f, p))).collect();
    for (i, (fa, a)) in given.iter().enumerate() {
        for (fb, b) in &given[i + 1..] {
            if key(a) == key(b) {
                bail!(
                    "{fa} and {fb} name the same file {}; give each its own",
                    a.display()
                );
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
            bail!("the output path is empty");
        }
        inputs.check(path)?;
        // A symlink is followed: its target is what gets written, the link stays.
        let target_path = follow_links(path)?;
        let special = match std::fs::metadata(&target_path) {
            Ok(m) if m.is_dir() => bail!(
                "{}: a folder; give a file name (e.g. {})",
                path.display(),
                path.join("out").display()
            ),
            Ok(m) => !m.is_file(),
            Err(_) => false,
        };
        if special {
            let file = OpenOptions::new()
                .write(true)
                .open(&target_path)
                .with_context(|| format!("cannot write {}", path.display()))?;
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
            .with_context(|| format!("{}: not a file name", path.display()))?
            .to_string_lossy();
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the folder {}", dir.display()))?;
        let tmp = dir.join(format!(".{name}.partial-{}", std::process::id()));
        register(&tmp);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .or_else(|_| {
                // A leftover of a killed run of this same process id: it is ours.
                remove_ours(&tmp);
                OpenOptions::new().write(true).create_new(true).open(&tmp)
            });
        let file = match file {
            Ok(f) => f,
            Err(e) => {
                unregister(&tmp);
                return Err(e).with_context(|| format!("cannot write {}", path.display()));
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
        let shown = self.shown.clone();
        self.file
            .flush()
            .with_context(|| format!("cannot write {}", shown.display()))?;
        if let Target::Replace { path, tmp } = &self.target {
            // Keep the permissions of the file being replaced (a shared log, a read-only copy).
            if let Ok(m) = std::fs::metadata(path) {
                let _ = std::fs::set_permissions(tmp, m.permissions());
            }
            let _guard = CLEANUP.lock().unwrap_or_else(|e| e.into_inner());
            std::fs::rename(tmp, path).with_context(|| format!("cannot write {}", shown.display()))?;
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
        if let Target::Replace { tmp, .. } = &self.target {
            if !self.committed {
                remove_ours(tmp);
            }
            unregister(tmp);
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
                let to = std::fs::read_link(&p)
                    .with_context(|| format!("cannot read the link {}", path.display()))?;
                p = match p.parent() {
                    Some(dir) => dir.join(to),
                    None => to,
                };
            }
            _ => return Ok(p),
        }
    }
    bail!("{}: too many levels of symbolic links", path.display())
}

/// Writes `contents` to the file `path` under the rules of this module.
pub fn write_file(path: &Path, contents: &[u8], inputs: &Inputs) -> Result<()> {
    let mut out = OutputFile::create(path, inputs)?;
    out.write_all(contents)
        .with_context(|| format!("cannot write {}", path.display()))?;
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
    /// Opens `dir` as the output folder of `command` (e.g. "skin run"); `force` allows writing
    /// skin's files into a folder that holds other files.
    pub fn create(dir: &Path, command: &str, force: bool, inputs: &Inputs) -> Result<OutputDir> {
        if dir.as_os_str().is_empty() {
            bail!("the output folder's path is empty");
        }
        match std::fs::metadata(dir) {
            Ok(m) if !m.is_dir() => bail!("{}: exists and is not a folder", dir.display()),
            _ => {}
        }
        inputs.check(dir)?;
        // Refuse before touching anything (checked again once the lock is held).
        if dir.is_dir() {
            Self::check_contents(dir, command, force)?;
        }
        let created = match std::fs::create_dir(dir) {
            Ok(()) => true,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => false,
            Err(_) => {
                std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
                true
            }
        };
        let undo = |created: bool| {
            if created {
                let _ = std::fs::remove_dir(dir);
            }
        };
        let lock_new = !dir.join(LOCK).exists();
        let lock = match Self::lock(dir) {
            Ok(l) => l,
            Err(e) => {
                undo(created);
                return Err(e);
            }
        };
        let previous = match Self::check_contents(dir, command, force) {
            Ok(p) => p,
            Err(e) => {
                if lock_new {
                    let _ = std::fs::remove_file(dir.join(LOCK));
                }
                undo(created);
                return Err(e);
            }
        };
        let staging = dir.join(STAGING);
        remove_ours(&staging); // a killed run's leftovers
        register(&staging);
        if created {
            register(dir);
        }
        if let Err(e) = std::fs::create_dir(&staging) {
            unregister(&staging);
            return Err(e).with_context(|| format!("cannot write into {}", dir.display()));
        }
        Ok(OutputDir {
            dir: dir.to_owned(),
            staging,
            command: command.to_owned(),
            previous,
            inputs: inputs.clone(),
            created,
            lock_new,
            committed: false,
            _lock: lock,
        })
    }

    /// Refuses `dir` now, before any work, if [`OutputDir::create`] would (it checks again).
    pub fn precheck(dir: &Path, command: &str, force: bool) -> Result<()> {
        if dir.is_dir() {
            Self::check_contents(dir, command, force)?;
        }
        Ok(())
    }

    fn lock(dir: &Path) -> Result<File> {
        let path = dir.join(LOCK);
        let file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .with_context(|| format!("cannot write into {}", dir.display()))?;
        match file.try_lock() {
            Ok(()) => Ok(file),
            Err(std::fs::TryLockError::WouldBlock) => bail!(
                "{}: another skin command is writing this folder; wait for it to finish or choose another output folder",
                dir.display()
            ),
            Err(std::fs::TryLockError::Error(e)) => {
                Err(e).with_context(|| format!("cannot lock {}", dir.display()))
            }
        }
    }

    /// Checks that the folder may be written into; returns the files of its previous output.
    fn check_contents(dir: &Path, command: &str, force: bool) -> Result<BTreeSet<String>> {
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
        let mut foreign = Vec::new();
        let entries = std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))?;
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if [MANIFEST, LOCK, STAGING, INCOMPLETE].contains(&name.as_str()) {
                continue;
            }
            foreign.push(name);
        }
        if foreign.is_empty() {
            return Ok(BTreeSet::new());
        }
        foreign.sort();
        let shown: Vec<&str> = foreign.iter().take(3).map(String::as_str).collect();
        let more = if foreign.len() > 3 {
            format!(" and {} more", foreign.len() - 3)
        } else {
            String::new()
        };
        let whose = match &manifest {
            Some(m) => format!("the output of `{}`", m.command),
            None => "files that skin did not write".to_owned(),
        };
        bail!(
            "{}: holds {whose} ({}{more}); choose a new or empty folder, or pass --force to write {command}'s files into it (nothing else there is touched)",
            dir.display(),
            shown.join(", ")
        )
    }

    /// The folder to write the new files into (moved into place by [`OutputDir::commit`]).
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The folder the user named.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// `e` with the building folder's name replaced by the user's: a message never names a
    /// temporary path.
    pub fn user_error(&self, e: anyhow::Error) -> anyhow::Error {
        let text = format!("{e:#}");
        let staging = self.staging.display().to_string();
        anyhow::anyhow!("{}", text.replace(&staging, &self.dir.display().to_string()))
    }

    /// Moves the new files into place, removes files of the previous output that this one does
    /// not have, and records the new list in the manifest.
    pub fn commit(mut self) -> Result<()> {
        let mut files = Vec::new();
        walk(&self.staging, Path::new(""), &mut files)
            .with_context(|| format!("cannot read {}", self.staging.display()))?;
        files.sort();
        // Check everything before anything moves.
        for rel in &files {
            let dest = self.dir.join(rel);
            self.inputs.check(&dest)?;
            if let Ok(m) = std::fs::symlink_metadata(&dest)
                && (m.is_dir() || m.file_type().is_symlink())
            {
                bail!(
                    "{}: is a folder or a link, where {} writes a file; move it away or choose another output folder",
                    dest.display(),
                    self.command
                );
            }
        }
        let names: Vec<String> = files.iter().map(|p| slash(p)).collect();
        let guard = CLEANUP.lock().unwrap_or_else(|e| e.into_inner());
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
                std::fs::create_dir_all(parent)
                    .with_context(|| format!("cannot create {}", parent.display()))?;
            }
            std::fs::rename(self.staging.join(rel), &dest)
                .with_context(|| format!("cannot write {}", dest.display()))?;
        }
        let new: BTreeSet<&String> = names.iter().collect();
        for old in &self.previous {
            if !new.contains(old) {
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
        }
        let manifest = Manifest {
            command: self.command.clone(),
            files: names,
        };
        let text = serde_json::to_string_pretty(&manifest).context("cannot encode the manifest")?;
        std::fs::write(self.dir.join(MANIFEST), text)
            .with_context(|| format!("cannot write into {}", self.dir.display()))?;
        let _ = std::fs::remove_file(&marker);
        let _ = std::fs::remove_dir_all(&self.staging);
        self.committed = true;
        drop(guard);
        unregister(&self.staging);
        unregister(&self.dir);
        Ok(())
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        unregister(&self.staging);
        unregister(&self.dir);
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
        assert!(format!("{e:#}").contains("notes.txt"), "{e:#}");
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
    fn a_second_writer_is_refused_at_once() {
        let d = tempfile::tempdir().unwrap();
        let _a = OutputDir::create(d.path(), "skin run", false, &Inputs::default()).unwrap();
        let e = OutputDir::create(d.path(), "skin run", false, &Inputs::default())
            .err()
            .unwrap();
        assert!(format!("{e:#}").contains("another skin command"), "{e:#}");
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
}
