//! Text input as editors and tools leave it, read by every reader of the workspace through one
//! opener.
//!
//! - A UTF-8 byte-order mark (what Windows editors put first) is skipped.
//! - Line ends may be LF, CRLF or CR alone (classic Mac OS), mixed too: each ends a line, as a
//!   text editor shows it, so a line number in an error is the line the user sees. A lone CR is
//!   read rather than refused because what it means is never in doubt, and every format read here
//!   either has no use for a CR inside a line (logs, recordings, tables) or treats it as a line
//!   end itself (JSON and TOML whitespace, XML's line-end normalisation).
//! - A gzip-compressed log or recording is decompressed as it is read ([`Gzip::Read`]); a file
//!   read whole (a layout, a map, a configuration) that is compressed is refused with the command
//!   that decompresses it, as are the other compressed formats (xz, zstd, bzip2, zip).
//! - UTF-16, binary data (NUL bytes), Latin-1 and other non-UTF-8 text are named as such, with
//!   the line and the command that converts the file.
//! - Memory is bounded: a line is at most [`MAX_LINE_BYTES`] long (a file with no line end, such
//!   as `/dev/zero`, fails after that many bytes), and a file read whole is refused past its limit
//!   ([`MAX_DOCUMENT_BYTES`]) before it is read, or after `limit + 1` bytes of a pipe or a device,
//!   which have no size.
//!
//! Line-based readers take any [`BufRead`] through [`Lines`]; [`Input::open`] opens a file for
//! them. Whole-file readers call [`read_document`] (or [`crate::format::read_text`]).
//!
//! ```
//! use skin_core::text::Lines;
//!
//! let mut lines = Lines::new("\u{feff}a b\r\nc\rd\n".as_bytes(), "t.txt".as_ref());
//! let mut seen = Vec::new();
//! while let Some(line) = lines.next_line()? {
//!     seen.push(line.text().to_owned());
//! }
//! assert_eq!(seen, ["a b", "c", "d"]);
//! # Ok::<(), skin_core::Error>(())
//! ```

use crate::{Error, Result};
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// The longest line a line-based reader takes, bytes (1 MiB: a recording line of some 150,000
/// taxels). A longer line is refused after this many bytes, so that a file without line ends
/// (`/dev/zero`, a binary file, a 2 GB single line) costs bounded memory.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// The largest file read whole into memory (JSON layouts, maps, Cyskin files, poses, scenes,
/// TOML configurations and bus maps, URDF, model cards), bytes: 64 MiB, some 400,000 taxels of
/// a JSON layout. Parsed, such a file takes several times its size in memory; a larger one is
/// refused before it is read.
pub const MAX_DOCUMENT_BYTES: u64 = 64 << 20;

/// How much of a file's start is looked at for a binary or UTF-16 signature.
const SNIFF_BYTES: usize = 8 << 10;

/// The UTF-8 byte-order mark.
const UTF8_BOM: &[u8] = b"\xef\xbb\xbf";

/// The buffer of a file being read line by line.
const BUFFER_BYTES: usize = 64 << 10;

/// What to do with a gzip-compressed file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gzip {
    /// Decompress it as it is read (logs and recordings, which are often kept compressed).
    Read,
    /// Refuse it, with the command that decompresses it.
    Refuse,
}

/// Compressed formats, by their first bytes, and the command that decompresses each.
const COMPRESSED: [(&[u8], &str, &str); 5] = [
    (&[0x1f, 0x8b], "gzip", "gunzip -k"),
    (&[0x28, 0xb5, 0x2f, 0xfd], "zstd", "zstd -d"),
    (&[0xfd, b'7', b'z', b'X', b'Z', 0x00], "xz", "xz -dk"),
    (b"BZh", "bzip2", "bunzip2 -k"),
    (b"PK\x03\x04", "zip", "unzip"),
];

/// The compressed format `head` starts with: its name and the command that decompresses it.
fn compressed(head: &[u8]) -> Option<(&'static str, &'static str)> {
    COMPRESSED
        .iter()
        .find(|(magic, _, _)| head.starts_with(magic))
        .map(|&(_, name, command)| (name, command))
}

/// How many bytes of a file have been read, shared with a progress display while the file is
/// read elsewhere ([`Input::meter`]).
#[derive(Debug, Clone)]
pub struct Meter {
    read: Arc<AtomicU64>,
    len: Option<u64>,
}

impl Meter {
    /// Bytes of the file read so far (of the compressed file, for a compressed one).
    pub fn read(&self) -> u64 {
        self.read.load(Ordering::Relaxed)
    }

    /// The file's length, when it has one (a regular file; not a pipe or a device).
    pub fn len(&self) -> Option<u64> {
        self.len
    }

    /// Whether the file is known to be empty.
    pub fn is_empty(&self) -> bool {
        self.len == Some(0)
    }
}

/// Counts the bytes read through it.
struct Counted<R> {
    inner: R,
    read: Arc<AtomicU64>,
}

impl<R: Read> Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.read.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

/// A file opened for reading line by line: buffered, decompressed when it is gzip-compressed
/// (with [`Gzip::Read`]), its bytes counted ([`Input::meter`]).
pub struct Input {
    inner: Box<dyn BufRead + Send>,
    meter: Meter,
    gzip: bool,
}

impl std::fmt::Debug for Input {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Input")
            .field("meter", &self.meter)
            .field("gzip", &self.gzip)
            .finish_non_exhaustive()
    }
}

impl Input {
    /// Opens `path`: a folder is refused by name; a gzip-compressed file is decompressed as it
    /// is read or refused, as `gzip` says.
    pub fn open(path: &Path, gzip: Gzip) -> Result<Input> {
        let file = open_file(path)?;
        let len = file
            .metadata()
            .ok()
            .filter(std::fs::Metadata::is_file)
            .map(|m| m.len());
        Input::from_reader(file, path, len, gzip)
    }

    /// An input over a reader the caller opened its own way (`path` names it in errors, `len`
    /// is its length when it has one): a pipe it waits on without blocking, a file whose reads
    /// it can interrupt. Decompressed or refused when gzip-compressed, as [`Input::open`] does;
    /// the first bytes are read now to tell.
    pub fn from_reader<R: Read + Send + 'static>(
        reader: R,
        path: &Path,
        len: Option<u64>,
        gzip: Gzip,
    ) -> Result<Input> {
        let read = Arc::new(AtomicU64::new(0));
        let mut raw = BufReader::with_capacity(
            BUFFER_BYTES,
            Counted {
                inner: reader,
                read: Arc::clone(&read),
            },
        );
        let head = raw.fill_buf().map_err(|e| Error::io(path, e))?;
        let is_gzip = matches!(compressed(head), Some(("gzip", _)));
        if is_gzip && gzip == Gzip::Refuse {
            return Err(refuse_compressed(path, "gzip", "gunzip -k"));
        }
        let inner: Box<dyn BufRead + Send> = if is_gzip {
            Box::new(BufReader::with_capacity(
                BUFFER_BYTES,
                flate2::bufread::MultiGzDecoder::new(raw),
            ))
        } else {
            Box::new(raw)
        };
        Ok(Input {
            inner,
            meter: Meter { read, len },
            gzip: is_gzip,
        })
    }

    /// The count of the file's bytes read so far, to show progress while the input is read
    /// elsewhere.
    pub fn meter(&self) -> Meter {
        self.meter.clone()
    }

    /// Whether the file is gzip-compressed (and decompressed as it is read).
    pub fn is_gzip(&self) -> bool {
        self.gzip
    }
}

impl Read for Input {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.inner.read(buf)
    }
}

impl BufRead for Input {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amount: usize) {
        self.inner.consume(amount);
    }
}

/// Opens `path` for reading as every reader here does, refusing a folder by name, and a pipe
/// this process read before ([`Input::open`] reads through it; a caller that opens its inputs
/// its own way, [`Input::from_reader`], starts from it for anything but a pipe).
pub fn open_file(path: &Path) -> Result<File> {
    once_per_pipe(path)?;
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err(Error::invalid(
            path,
            "file",
            "a folder, not a file: give a file in it",
        ));
    }
    Ok(file)
}

/// Refuses a named pipe (FIFO) this process has opened before. A command may read a file more
/// than once (a layout: once to tell its format, once to read it); a pipe's writer is gone after
/// the first read, and opening it again would wait for another writer forever. One clear line
/// instead, before the open that would hang.
#[cfg(unix)]
fn once_per_pipe(path: &Path) -> Result<()> {
    use std::os::unix::fs::{FileTypeExt, MetadataExt};
    static OPENED: std::sync::Mutex<Vec<(u64, u64)>> = std::sync::Mutex::new(Vec::new());
    let Ok(m) = std::fs::metadata(path) else {
        return Ok(());
    };
    if !m.file_type().is_fifo() {
        return Ok(());
    }
    let mut opened = OPENED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if opened.contains(&(m.dev(), m.ino())) {
        return Err(Error::invalid(
            path,
            "file",
            "a pipe, already read to its end: this file is read more than once, so give a regular file",
        ));
    }
    opened.push((m.dev(), m.ino()));
    Ok(())
}

#[cfg(not(unix))]
fn once_per_pipe(_: &Path) -> Result<()> {
    Ok(())
}

fn refuse_compressed(path: &Path, name: &str, command: &str) -> Error {
    Error::invalid(
        path,
        "start of file",
        format!(
            "{name}-compressed data, not text: decompress it first ({command} '{}') and give the result",
            path.display()
        ),
    )
}

/// The name `iconv` should write a converted copy of `path` to: `name.utf8.ext` beside it.
fn converted(path: &Path) -> PathBuf {
    converted_as(path, "utf8")
}

/// `name.TAG.ext` beside `path`: where a command that repairs it writes the repaired copy.
fn converted_as(path: &Path, tag: &str) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy()).unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}.{tag}.{}", ext.to_string_lossy()),
        None => format!("{stem}.{tag}"),
    };
    path.with_file_name(name)
}

/// The UTF-16 variant `head` (a file's first bytes) is written in, by its byte-order mark or by
/// its NUL bytes every other byte (ASCII text in UTF-16).
fn utf16(head: &[u8]) -> Option<&'static str> {
    if head.starts_with(&[0xff, 0xfe]) {
        return Some("UTF-16LE");
    }
    if head.starts_with(&[0xfe, 0xff]) {
        return Some("UTF-16BE");
    }
    let pairs = head.len().min(64) / 2;
    if pairs < 2 {
        return None;
    }
    let pair = |k: usize| (head[2 * k], head[2 * k + 1]);
    if (0..pairs).all(|k| pair(k).0 != 0 && pair(k).1 == 0) {
        return Some("UTF-16LE");
    }
    if (0..pairs).all(|k| pair(k).0 == 0 && pair(k).1 != 0) {
        return Some("UTF-16BE");
    }
    None
}

fn utf16_error(path: &Path, variant: &str) -> Error {
    Error::invalid(
        path,
        "line 1",
        format!(
            "{variant} text, not UTF-8: convert it first (iconv -f {variant} -t UTF-8 '{}' > '{}')",
            path.display(),
            converted(path).display()
        ),
    )
}

/// A NUL byte at `line`. One near the start of a file (`in_head`) makes it a binary file; one
/// after lines of text, a file cut short.
fn binary_error(path: &Path, line: usize, in_head: bool) -> Error {
    let message = if in_head || line <= 1 {
        "a NUL byte: binary data, not a text file (is it the file meant?)".to_string()
    } else {
        // Text, then NULs: how a file ends when the machine lost power or the disk filled
        // while it was written.
        format!(
            "a NUL byte: binary data after {} line(s) of text, as a file cut short by a crash or a full disk ends; keep the lines before it (head -n {} '{}' > '{}')",
            line - 1,
            line - 1,
            path.display(),
            converted_as(path, "head").display()
        )
    };
    Error::invalid(path, format!("line {line}"), message)
}

/// The error of a line that is not UTF-8 at `column` (1-based, bytes), whose first bad byte is
/// `byte`, with the command that converts the file (a Latin-1 or Windows-1252 file, as most
/// such files are).
fn not_utf8(path: &Path, line: usize, column: usize, byte: u8) -> Error {
    Error::invalid(
        path,
        format!("line {line}, column {column}"),
        format!(
            "byte 0x{byte:02X} is not UTF-8 (Latin-1 or Windows-1252 text?): convert the file first (iconv -f latin1 -t utf-8 '{}' > '{}')",
            path.display(),
            converted(path).display()
        ),
    )
}

/// Checks a file's first bytes: compressed (not decompressed here), UTF-16, binary. Returns how
/// many bytes of a UTF-8 byte-order mark to skip.
fn check_start(path: &Path, head: &[u8]) -> Result<usize> {
    if let Some((name, command)) = compressed(head) {
        return Err(refuse_compressed(path, name, command));
    }
    if let Some(variant) = utf16(head) {
        return Err(utf16_error(path, variant));
    }
    let sniff = &head[..head.len().min(SNIFF_BYTES)];
    if let Some(at) = memchr::memchr(0, sniff) {
        return Err(binary_error(path, line_at(sniff, at), true));
    }
    Ok(if head.starts_with(UTF8_BOM) {
        UTF8_BOM.len()
    } else {
        0
    })
}

/// The 1-based line (LF, CRLF or CR ends) that byte `at` of `text` is on.
fn line_at(text: &[u8], at: usize) -> usize {
    let before = &text[..at.min(text.len())];
    let lf = memchr::memchr_iter(b'\n', before).count();
    let lone_cr = memchr::memchr_iter(b'\r', before)
        .filter(|&i| text.get(i + 1) != Some(&b'\n'))
        .count();
    1 + lf + lone_cr
}

/// The lines of a text input, read one at a time with bounded memory (see the [module](self)):
/// the line ends (LF, CRLF, CR) are not part of a line; a UTF-8 byte-order mark is skipped.
pub struct Lines<R> {
    reader: R,
    path: PathBuf,
    /// The number of the line last returned (1-based; 0 before the first).
    number: usize,
    line: Vec<u8>,
    max: usize,
    started: bool,
    /// The last line ended with a CR: a LF right after it belongs to that line end.
    after_cr: bool,
    /// Bytes of the reader's buffer the line last returned (and its end) took, lent to the
    /// caller until the next call.
    lent: usize,
    done: bool,
    consumed: u64,
}

impl<R> std::fmt::Debug for Lines<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Lines")
            .field("path", &self.path)
            .field("number", &self.number)
            .finish_non_exhaustive()
    }
}

impl<R: BufRead> Lines<R> {
    /// The lines of `reader`; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Lines<R> {
        Lines {
            reader,
            path: path.to_owned(),
            number: 0,
            line: Vec::new(),
            max: MAX_LINE_BYTES,
            started: false,
            after_cr: false,
            lent: 0,
            done: false,
            consumed: 0,
        }
    }

    /// The same, with lines of at most `max` bytes instead of [`MAX_LINE_BYTES`].
    pub fn with_max_line(mut self, max: usize) -> Lines<R> {
        self.max = max.max(1);
        self
    }

    /// The file the lines are of, as errors name it.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The number of the line last returned (1-based; 0 before the first).
    pub fn number(&self) -> usize {
        self.number
    }

    /// Bytes taken from the reader so far (after decompression), the line last returned
    /// included.
    pub fn consumed(&self) -> u64 {
        self.consumed + self.lent as u64
    }

    /// The reader.
    pub fn get_ref(&self) -> &R {
        &self.reader
    }

    fn consume(&mut self, n: usize) {
        self.reader.consume(n);
        self.consumed += n as u64;
    }

    /// The next line, without its line end; `None` at the end of the input. An error names the
    /// file and the line: a line longer than the bound, binary data, UTF-16, text that is not
    /// UTF-8, a compressed file, a read that failed.
    pub fn next_line(&mut self) -> Result<Option<Line<'_>>> {
        // The line last returned was lent from the reader's buffer: it is taken now.
        if self.lent > 0 {
            let n = std::mem::take(&mut self.lent);
            self.consume(n);
        }
        if self.done {
            return Ok(None);
        }
        let number = self.number + 1;
        self.start_line(number)?;
        // Nearly every line lies whole in the reader's buffer: it is lent from there, not copied.
        let found = {
            let available = fill(&mut self.reader, &self.path, number)?;
            memchr::memchr3(b'\n', b'\r', 0, available)
                .filter(|&end| end <= self.max)
                .map(|end| (end, available[end]))
        };
        if let Some((end, terminator)) = found
            && terminator != 0
        {
            return self.lend(number, end, terminator);
        }
        // A line across the buffer's end (or a bad one): gathered in a copy.
        let Some(terminated) = self.gather(number)? else {
            return Ok(None);
        };
        self.number = number;
        if number == 1 && !self.strip_first_line_start(terminated)? {
            return Ok(None);
        }
        match std::str::from_utf8(&self.line) {
            Ok(text) => Ok(Some(Line {
                text,
                number,
                path: &self.path,
                unfinished: !terminated,
            })),
            Err(e) => {
                let at = e.valid_up_to();
                Err(not_utf8(&self.path, number, at + 1, self.line[at]))
            }
        }
    }

    /// Before line `number`: the checks of the file's start, and the `\n` of a `\r\n` that the
    /// line before ended on.
    fn start_line(&mut self, number: usize) -> Result<()> {
        if !self.started {
            self.started = true;
            // The first read is usually the buffer's size: enough to tell a compressed, UTF-16
            // or binary file. A byte-order mark is taken off the first line, which a short
            // first read (a pipe) may split.
            let head = fill(&mut self.reader, &self.path, number)?;
            check_start(&self.path, head)?;
        }
        if self.after_cr {
            self.after_cr = false;
            if fill(&mut self.reader, &self.path, number)?.first() == Some(&b'\n') {
                self.consume(1);
            }
        }
        Ok(())
    }

    /// Line `number`, whole in the reader's buffer up to `end` (its line end `terminator`): lent
    /// from the buffer, and taken from it at the next call.
    fn lend(&mut self, number: usize, end: usize, terminator: u8) -> Result<Option<Line<'_>>> {
        let available = fill(&mut self.reader, &self.path, number)?;
        let mut bytes = &available[..end];
        self.lent = end + 1;
        self.after_cr = terminator == b'\r';
        self.number = number;
        if number == 1 {
            if let Some(rest) = bytes.strip_prefix(UTF8_BOM) {
                bytes = rest;
            } else if let Some(variant) = utf16(bytes) {
                return Err(utf16_error(&self.path, variant));
            }
        }
        match std::str::from_utf8(bytes) {
            Ok(text) => Ok(Some(Line {
                text,
                number,
                path: &self.path,
                unfinished: false,
            })),
            Err(e) => {
                let at = e.valid_up_to();
                Err(not_utf8(&self.path, number, at + 1, bytes[at]))
            }
        }
    }

    /// Line `number` gathered into `self.line` across the reader's buffers (taken from the
    /// reader as it goes): whether it ended with a line end, or `None` at the end of the input.
    fn gather(&mut self, number: usize) -> Result<Option<bool>> {
        self.line.clear();
        loop {
            let available = fill(&mut self.reader, &self.path, number)?;
            if available.is_empty() {
                if self.line.is_empty() {
                    self.done = true;
                    return Ok(None);
                }
                return Ok(Some(false));
            }
            let end = memchr::memchr3(b'\n', b'\r', 0, available);
            let take = end.unwrap_or(available.len());
            if self.line.len() + take > self.max {
                return Err(Error::invalid(
                    &self.path,
                    format!("line {number}"),
                    format!(
                        "more than {} without a line end: not a text file of lines (a line this long is refused to bound memory)",
                        size(self.max as u64)
                    ),
                ));
            }
            let terminator = end.map(|i| available[i]);
            self.line.extend_from_slice(&available[..take]);
            match terminator {
                Some(0) => return Err(binary_error(&self.path, number, false)),
                Some(t) => {
                    self.consume(take + 1);
                    self.after_cr = t == b'\r';
                    return Ok(Some(true));
                }
                None => self.consume(take),
            }
        }
    }

    /// The copied first line without its byte-order mark, or UTF-16 refused. `false`: the file
    /// is a byte-order mark alone, which is an empty file.
    fn strip_first_line_start(&mut self, terminated: bool) -> Result<bool> {
        if self.line.starts_with(UTF8_BOM) {
            self.line.drain(..UTF8_BOM.len());
            if self.line.is_empty() && !terminated {
                self.done = true;
                return Ok(false);
            }
        } else if let Some(variant) = utf16(&self.line) {
            return Err(utf16_error(&self.path, variant));
        }
        Ok(true)
    }
}

/// One line of a [`Lines`], with its number and its file for error messages; it reads as the
/// `str` it holds.
#[derive(Debug)]
pub struct Line<'a> {
    text: &'a str,
    number: usize,
    path: &'a Path,
    unfinished: bool,
}

impl<'a> Line<'a> {
    /// The line's text, without its line end.
    pub fn text(&self) -> &'a str {
        self.text
    }

    /// Its number (1-based; CR, LF and CRLF each end a line).
    pub fn number(&self) -> usize {
        self.number
    }

    /// The file it is a line of.
    pub fn path(&self) -> &'a Path {
        self.path
    }

    /// Whether the input ends in this line without a line end. A last line without one reads
    /// as any other; but when it does not parse, the file was most likely cut short (copied
    /// while a logger was still writing it), which [`Line::explain`] says.
    pub fn unfinished(&self) -> bool {
        self.unfinished
    }

    /// `message` (why this line does not parse), with, for an [unfinished](Line::unfinished)
    /// last line, what that most likely means and the command that keeps the lines before it.
    pub fn explain(&self, message: String) -> String {
        match self.unfinished && self.number > 1 {
            false => message,
            true => format!(
                "{message}; the file ends in the middle of this line (no line end after it), as a file copied while it was still written does: keep the {} line(s) before it (head -n {} '{}' > '{}')",
                self.number - 1,
                self.number - 1,
                self.path.display(),
                converted_as(self.path, "head").display()
            ),
        }
    }
}

impl std::ops::Deref for Line<'_> {
    type Target = str;

    fn deref(&self) -> &str {
        self.text
    }
}

/// `reader`'s buffered bytes, read if there are none (empty at the end of the input). A
/// compressed stream that ends early or is damaged fails in the middle of a line: that is said
/// with the line, rather than an operating-system message without one.
fn fill<'a, R: BufRead>(reader: &'a mut R, path: &Path, line: usize) -> Result<&'a [u8]> {
    use std::io::ErrorKind;
    reader.fill_buf().map_err(|e| match e.kind() {
        ErrorKind::UnexpectedEof | ErrorKind::InvalidInput | ErrorKind::InvalidData => Error::invalid(
            path,
            format!("line {line}"),
            format!("the compressed data ends early or is damaged ({e}): is the file whole?"),
        ),
        _ => Error::io(path, e),
    })
}

/// Reads the whole file at `path` as text, refusing it past `limit` bytes before reading it (or
/// once `limit + 1` bytes of a pipe or a device are read): a UTF-8 byte-order mark is skipped,
/// lone CR line ends are read as LF; compressed, UTF-16, binary and non-UTF-8 files are refused
/// by name, with the line and the fix.
pub fn read_document(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_bytes(path, limit)?;
    let skip = check_start(path, &bytes)?;
    let mut bytes = bytes;
    bytes.drain(..skip);
    if let Some(at) = memchr::memchr(0, &bytes) {
        return Err(binary_error(path, line_at(&bytes, at), false));
    }
    let text = match String::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => {
            let bytes = e.as_bytes();
            let at = e.utf8_error().valid_up_to();
            let start = bytes[..at]
                .iter()
                .rposition(|&b| b == b'\n' || b == b'\r')
                .map_or(0, |i| i + 1);
            return Err(not_utf8(path, line_at(bytes, at), at - start + 1, bytes[at]));
        }
    };
    Ok(if memchr::memchr(b'\r', text.as_bytes()).is_some() {
        lone_cr_to_lf(&text)
    } else {
        text
    })
}

/// `text` with every CR that is not followed by a LF made a LF (CRLF kept).
fn lone_cr_to_lf(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut from = 0;
    for i in memchr::memchr_iter(b'\r', bytes) {
        if bytes.get(i + 1) != Some(&b'\n') {
            out.push_str(&text[from..i]);
            out.push('\n');
            from = i + 1;
        }
    }
    out.push_str(&text[from..]);
    out
}

/// Reads the whole file at `path` as bytes, refusing it past `limit` bytes: before reading it
/// when it is a regular file, after `limit + 1` bytes otherwise (a pipe or a device has no size).
pub fn read_bytes(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let file = open_file(path)?;
    let size = file
        .metadata()
        .ok()
        .filter(std::fs::Metadata::is_file)
        .map(|m| m.len());
    if let Some(size) = size
        && size > limit
    {
        return Err(too_large(path, Some(size), limit));
    }
    let mut bytes = Vec::with_capacity(size.map_or(0, |s| s as usize));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(path, None, limit));
    }
    Ok(bytes)
}

/// `n` bytes in the unit that reads best.
fn size(n: u64) -> String {
    match n {
        n if n >= 1 << 30 => format!("{:.1} GiB", n as f64 / f64::from(1u32 << 30)),
        n if n >= 1 << 20 => format!("{:.1} MiB", n as f64 / f64::from(1u32 << 20)),
        n if n >= 1 << 10 => format!("{:.1} KiB", n as f64 / f64::from(1u32 << 10)),
        n => format!("{n} bytes"),
    }
}

fn too_large(path: &Path, got: Option<u64>, limit: u64) -> Error {
    let limit = size(limit);
    let message = match got {
        Some(n) => format!(
            "{}, more than the {limit} a file of this kind may have (it is read whole into memory): is it the file meant?",
            size(n)
        ),
        None => format!(
            "more than the {limit} a file of this kind may have (it is read whole into memory; a device or a pipe has no size, so {limit} were read): is it the file meant?"
        ),
    };
    Error::invalid(path, "size", message)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test
    use super::*;

    fn all(text: &[u8]) -> Result<Vec<String>> {
        let mut lines = Lines::new(text, Path::new("t.txt"));
        let mut out = Vec::new();
        while let Some(l) = lines.next_line()? {
            out.push(l.text().to_owned());
        }
        Ok(out)
    }

    #[test]
    fn line_ends_of_every_kind() {
        assert_eq!(all(b"a\nb\r\nc\rd").unwrap(), ["a", "b", "c", "d"]);
        assert_eq!(all(b"a\n\nb\n").unwrap(), ["a", "", "b"]);
        assert_eq!(all(b"a\r\r\nb\r").unwrap(), ["a", "", "b"]);
        assert!(all(b"").unwrap().is_empty());
        assert_eq!(all(b"\xef\xbb\xbfa \t\n").unwrap(), ["a \t"]);
        assert!(all(b"\xef\xbb\xbf").unwrap().is_empty());
        assert_eq!(all(b"\xef\xbb\xbf\n").unwrap(), [""]);
    }

    #[test]
    fn a_crlf_split_across_reads_is_one_line_end() {
        // A reader that gives one byte at a time puts the CR and the LF in different reads.
        let text = b"ab\r\ncd\r\n";
        let mut lines = Lines::new(BufReader::with_capacity(1, &text[..]), Path::new("t"));
        let mut out = Vec::new();
        while let Some(l) = lines.next_line().unwrap() {
            out.push(l.text().to_owned());
        }
        assert_eq!(out, ["ab", "cd"]);
    }

    #[test]
    fn lone_crs_become_lfs_in_a_document() {
        assert_eq!(lone_cr_to_lf("a\rb\r\nc\r"), "a\nb\r\nc\n");
    }

    #[test]
    fn line_numbers_count_every_kind_of_line_end() {
        assert_eq!(line_at(b"a\nb\r\nc\rd", 7), 4);
        assert_eq!(line_at(b"abc", 2), 1);
    }
}
