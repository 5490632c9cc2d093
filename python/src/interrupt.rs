//! Ctrl-C in long calls. Python runs its signal handlers (the one that raises
//! `KeyboardInterrupt` on SIGINT) only when the interpreter runs in the main thread; a call that
//! works for seconds with the GIL released would hold Ctrl-C until it returns, and a pipe's
//! `open(2)` waiting for a writer would hold it forever. So long calls check between frames, at
//! most every [`PERIOD`]: they attach for a moment and let Python run its handlers
//! ([`Watch::stop`]). An exception a handler raises ends the call, its work dropped (a half-run
//! result is never returned as if complete), and reaches the caller as itself. Named pipes are
//! opened without blocking and waited on in slices ([`open`]).

use pyo3::prelude::*;
use skin_core::text::{Gzip, Input};
use std::io::Read;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often a long call lets Python run its signal handlers: well under the half second in
/// which Ctrl-C should take effect, and rare enough that taking the GIL for it costs nothing
/// measurable.
pub(crate) const PERIOD: Duration = Duration::from_millis(20);

/// Whether a long call should stop because a signal handler raised: checked cheaply as often as
/// the work likes, it runs Python's handlers at most every [`PERIOD`]. Shared by the threads and
/// readers of one call.
pub(crate) struct Watch {
    start: Instant,
    /// When the next check is due, µs after `start`.
    due_us: AtomicU64,
    tripped: AtomicBool,
    /// What a signal handler raised, until the call reports it.
    raised: Mutex<Option<PyErr>>,
}

impl Watch {
    /// A watch whose first [`Watch::stop`] checks at once (a Ctrl-C that came just before the
    /// call stops it before it starts).
    pub(crate) fn new() -> Watch {
        Watch {
            start: Instant::now(),
            due_us: AtomicU64::new(0),
            tripped: AtomicBool::new(false),
            raised: Mutex::new(None),
        }
    }

    /// Whether to stop: a signal handler raised, now or at an earlier check. Called without the
    /// GIL; it attaches only when a check is due. In a thread other than the main one Python
    /// runs no handler, and this says go on.
    pub(crate) fn stop(&self) -> bool {
        if self.tripped.load(Ordering::Acquire) {
            return true;
        }
        let now = u64::try_from(self.start.elapsed().as_micros()).unwrap_or(u64::MAX);
        if now < self.due_us.load(Ordering::Relaxed) {
            return false;
        }
        let period = u64::try_from(PERIOD.as_micros()).unwrap_or(u64::MAX);
        self.due_us.store(now.saturating_add(period), Ordering::Relaxed);
        if let Err(e) = Python::attach(|py| py.check_signals()) {
            lock(&self.raised).get_or_insert(e);
            self.tripped.store(true, Ordering::Release);
        }
        self.tripped.load(Ordering::Acquire)
    }

    /// Whether the call was stopped by a signal handler.
    pub(crate) fn tripped(&self) -> bool {
        self.tripped.load(Ordering::Acquire)
    }

    /// The exception a signal handler raised, to report once (the watch stays tripped).
    pub(crate) fn raised(&self) -> Option<PyErr> {
        lock(&self.raised).take()
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The error a watched reader gives once the call is to stop; the caller reports the handler's
/// exception instead. Not `ErrorKind::Interrupted`, which readers retry.
fn interrupted() -> std::io::Error {
    std::io::Error::other("interrupted by a signal")
}

/// Runs `work` on a thread of its own while this thread watches for Ctrl-C: for work spread over
/// a thread pool, whose threads cannot run Python's handlers and would hold this one until the
/// whole batch is done. `work` gets the flag that says stop (set when a handler raised); it
/// should look at it between items. Call it without the GIL.
pub(crate) fn on_worker<T: Send>(watch: &Watch, work: impl FnOnce(&AtomicBool) -> T + Send) -> T {
    let stop = AtomicBool::new(false);
    let flag = &stop;
    let caller = std::thread::current();
    std::thread::scope(|s| {
        let handle = s.spawn(move || {
            let out = work(flag);
            caller.unpark();
            out
        });
        while !handle.is_finished() {
            if watch.stop() {
                flag.store(true, Ordering::Relaxed);
            }
            std::thread::park_timeout(PERIOD);
        }
        handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// Opens `path` for one of the crates' line readers (as [`Input::open`] does, gzip decompressed
/// as `gzip` says), its reads watched: once `watch` says stop a read fails, and the caller
/// reports the handler's exception. A named pipe is opened without waiting for its writer and
/// waited on in slices, so that Ctrl-C ends the wait and the GIL is not needed meanwhile. Unlike
/// [`Input::open`], a pipe read before may be opened again: the wait for another writer can be
/// interrupted, so it is no hang. Call it without the GIL: it may wait.
pub(crate) fn open(path: &Path, gzip: Gzip, watch: &Arc<Watch>) -> skin_core::Result<Input> {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    if let Some(pipe) = pipe::Pipe::open(path, watch)? {
        return Input::from_reader(pipe, path, None, gzip);
    }
    let file = skin_core::text::open_file(path)?;
    let len = file
        .metadata()
        .ok()
        .filter(std::fs::Metadata::is_file)
        .map(|m| m.len());
    let reader = Checked {
        inner: file,
        watch: Arc::clone(watch),
    };
    Input::from_reader(reader, path, len, gzip)
}

/// A file (or device) whose reads stop once the watch says so.
struct Checked<R> {
    inner: R,
    watch: Arc<Watch>,
}

impl<R: Read> Read for Checked<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.watch.stop() {
            return Err(interrupted());
        }
        self.inner.read(buf)
    }
}

#[cfg(any(target_os = "linux", target_os = "android"))]
mod pipe {
    use super::{PERIOD, Watch, interrupted};
    use nix::errno::Errno;
    use nix::poll::{PollFd, PollFlags, PollTimeout, poll};
    use std::fs::File;
    use std::io::{ErrorKind, Read};
    use std::os::fd::AsFd;
    use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
    use std::path::Path;
    use std::sync::Arc;

    /// A named pipe opened without blocking: each read waits for data (or the writer's end) a
    /// slice at a time, looking at the watch between slices.
    pub(super) struct Pipe {
        file: File,
        watch: Arc<Watch>,
    }

    impl Pipe {
        /// `path` opened so if it is a named pipe; None for anything else.
        pub(super) fn open(path: &Path, watch: &Arc<Watch>) -> skin_core::Result<Option<Pipe>> {
            let is_fifo = std::fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo());
            if !is_fifo {
                return Ok(None);
            }
            // O_NONBLOCK: open(2) of a pipe's read end returns at once instead of waiting, in
            // the kernel, for a writer (a wait no signal handler of Python's can end).
            let file = std::fs::OpenOptions::new()
                .read(true)
                .custom_flags(nix::libc::O_NONBLOCK)
                .open(path)
                .map_err(|source| skin_core::Error::Io {
                    path: path.to_owned(),
                    source,
                })?;
            Ok(Some(Pipe {
                file,
                watch: Arc::clone(watch),
            }))
        }
    }

    impl Read for Pipe {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let slice = PollTimeout::try_from(PERIOD).unwrap_or(PollTimeout::MAX);
            loop {
                if self.watch.stop() {
                    return Err(interrupted());
                }
                // Never read before poll(2) says so: until a writer has come, a pipe opened
                // without blocking reads as ended. poll reports a writer's data, or its end
                // (POLLHUP) only once a writer has been and gone.
                let mut fds = [PollFd::new(self.file.as_fd(), PollFlags::POLLIN)];
                match poll(&mut fds, slice) {
                    Ok(0) | Err(Errno::EINTR) => continue,
                    Ok(_) => {}
                    Err(e) => return Err(e.into()),
                }
                match self.file.read(buf) {
                    Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => {}
                    result => return result,
                }
            }
        }
    }
}
