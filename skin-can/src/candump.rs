//! candump logs: one CAN frame per line, as can-utils' `candump -l` and python-can's
//! `CanutilsLogWriter` write them.
//!
//! ```text
//! (1700000000.000150) can0 201#E803D007B80BA00F
//! (1700000000.000300) can1 12345678#0102 R
//! (1700000000.000450) can0 7FF#R
//! ```
//! A timestamp in seconds (microseconds after the point), the interface, the identifier in hex
//! (3 digits for an 11-bit standard id, 8 for a 29-bit extended id), `#`, then the data bytes in
//! hex (or `R` for a remote request), and optionally ` R` or ` T` (received / transmitted, as
//! python-can writes). Blank lines are skipped. CAN FD lines (`##`) are rejected with the line
//! number: skin traffic is classic CAN.
//!
//! [`CandumpReader`] reads a log of any length one frame at a time (gzip-compressed too: robots
//! keep their logs that way); [`CandumpLog`] holds a small one whole.

use crate::busmap::MAX_BUSES;
use crate::{Error, Result};
use skin_core::format::excerpt;
use skin_core::text::{Gzip, Input, Lines};
use std::fmt::Write as _;
use std::io::BufRead;
use std::path::Path;

/// Received or transmitted, when the log says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// ` R` at the end of the line.
    Received,
    /// ` T` at the end of the line.
    Transmitted,
}

/// One classic CAN frame from a log. Small and `Copy`, so replaying a log allocates nothing per
/// frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CanFrame {
    /// Timestamp, microseconds.
    pub time_us: u64,
    /// Index of the interface in [`CandumpLog::interfaces`].
    pub bus: u16,
    /// Identifier (11 or 29 bits).
    pub id: u32,
    /// 29-bit identifier.
    pub extended: bool,
    /// Remote transmission request (no data).
    pub remote: bool,
    /// Number of data bytes, 0..=8.
    pub len: u8,
    /// Data bytes; only the first `len` are meaningful.
    pub bytes: [u8; 8],
    /// ` R` / ` T` marker, when present.
    pub direction: Option<Direction>,
}

impl CanFrame {
    /// The data bytes.
    pub fn data(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len.min(8))]
    }
}

/// A parsed log: the interfaces in order of first appearance, and the frames in file order.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct CandumpLog {
    /// Interface names (`can0`, ...); a frame's `bus` indexes this list.
    pub interfaces: Vec<String>,
    /// The frames.
    pub frames: Vec<CanFrame>,
    /// Error frames (identifier with the CAN_ERR_FLAG bit 0x20000000, as SocketCAN's candump
    /// writes bus errors), counted and skipped: they carry no skin data.
    pub error_frames: usize,
}

impl CandumpLog {
    /// Reads a whole log file into memory (small logs and tests; [`CandumpReader`] reads one
    /// frame at a time). A gzip-compressed log is decompressed as it is read.
    pub fn read(path: &Path) -> Result<CandumpLog> {
        CandumpReader::open(path)?.into_log()
    }

    /// Parses log text; `path` is used in error messages.
    pub fn parse(text: &str, path: &Path) -> Result<CandumpLog> {
        CandumpReader::new(text.as_bytes(), path).into_log()
    }

    /// The log as text, one line per frame, in the form can-utils writes.
    pub fn to_text(&self) -> String {
        let mut s = String::with_capacity(self.frames.len() * 48);
        for f in &self.frames {
            let iface = self
                .interfaces
                .get(usize::from(f.bus))
                .map_or("?", String::as_str);
            write_line(&mut s, f, iface);
        }
        s
    }

    /// Writes the log to a file.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_text()).map_err(|source| Error::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// The index of interface `name`, added if new; `None` when the log already names
    /// [`MAX_BUSES`] interfaces.
    pub fn bus(&mut self, name: &str) -> Option<u16> {
        intern(&mut self.interfaces, name)
    }

    /// Its frames as a [`CanSource`], every interface known from the start.
    pub fn source(&self) -> LogFrames<'_> {
        LogFrames {
            log: self,
            next: 0,
            error_frames: 0,
        }
    }
}

/// CAN frames one at a time, with the interfaces their `bus` indexes: a [`CandumpReader`] on a
/// file or any text input, or [`CandumpLog::source`] on a log in memory. What `skin_learn`'s
/// session runs.
pub trait CanSource {
    /// The next frame; `None` at the end.
    fn next_frame(&mut self) -> Result<Option<CanFrame>>;
    /// The interfaces named so far, in order of first appearance: a frame's `bus` indexes this
    /// list, which grows as the frames come.
    fn interfaces(&self) -> &[String];
    /// Error frames (CAN_ERR_FLAG) met so far, skipped.
    fn error_frames(&self) -> usize;
    /// Bytes of text the frames so far took, when the source reads text (0 otherwise).
    fn bytes_read(&self) -> u64 {
        0
    }
    /// Whether frames arrive as they are made (a pipe another program writes as it goes): a
    /// reader then takes each as it comes instead of waiting to fill a batch, so that a frame
    /// is processed before its writer waits for the answer.
    fn streams(&self) -> bool {
        false
    }
}

impl<T: CanSource + ?Sized> CanSource for &mut T {
    fn next_frame(&mut self) -> Result<Option<CanFrame>> {
        (**self).next_frame()
    }

    fn interfaces(&self) -> &[String] {
        (**self).interfaces()
    }

    fn error_frames(&self) -> usize {
        (**self).error_frames()
    }

    fn streams(&self) -> bool {
        (**self).streams()
    }

    fn bytes_read(&self) -> u64 {
        (**self).bytes_read()
    }
}

/// What a [`CanSource`] can be made from: any source, or a whole [`CandumpLog`] by reference.
pub trait IntoCanSource {
    /// The source.
    type Source: CanSource;
    /// Makes it.
    fn into_can_source(self) -> Self::Source;
}

impl<S: CanSource> IntoCanSource for S {
    type Source = S;

    fn into_can_source(self) -> S {
        self
    }
}

impl<'a> IntoCanSource for &'a CandumpLog {
    type Source = LogFrames<'a>;

    fn into_can_source(self) -> LogFrames<'a> {
        self.source()
    }
}

/// The frames of a [`CandumpLog`] in memory, as a [`CanSource`].
#[derive(Debug, Clone)]
pub struct LogFrames<'a> {
    log: &'a CandumpLog,
    next: usize,
    error_frames: usize,
}

impl CanSource for LogFrames<'_> {
    fn next_frame(&mut self) -> Result<Option<CanFrame>> {
        let frame = self.log.frames.get(self.next).copied();
        self.next += usize::from(frame.is_some());
        if frame.is_none() {
            // The log's error frames were counted when it was read: all met by its end.
            self.error_frames = self.log.error_frames;
        }
        Ok(frame)
    }

    fn interfaces(&self) -> &[String] {
        &self.log.interfaces
    }

    fn error_frames(&self) -> usize {
        self.error_frames
    }
}

/// A candump log read one frame at a time, with memory for one line whatever the log's length
/// (gzip-compressed logs too, with [`CandumpReader::open`]).
///
/// ```
/// use skin_can::candump::CandumpReader;
///
/// let text = "(1700000000.000000) can0 080#05\n(1700000000.000150) can1 201#E803\n";
/// let mut log = CandumpReader::new(text.as_bytes(), "session.log".as_ref());
/// while let Some(frame) = log.next_frame()? {
///     println!("{} on {}", frame.id, log.interfaces()[usize::from(frame.bus)]);
/// }
/// assert_eq!(log.interfaces(), ["can0", "can1"]);
/// # Ok::<(), skin_can::Error>(())
/// ```
#[derive(Debug)]
pub struct CandumpReader<R = Input> {
    lines: Lines<R>,
    interfaces: Vec<String>,
    error_frames: usize,
    frames: u64,
    streams: bool,
}

impl CandumpReader<Input> {
    /// Opens the log at `path`, decompressed as it is read when gzip-compressed.
    pub fn open(path: &Path) -> Result<CandumpReader<Input>> {
        Ok(CandumpReader::new(Input::open(path, Gzip::Read)?, path))
    }
}

impl<R: BufRead> CandumpReader<R> {
    /// The log `reader` holds; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> CandumpReader<R> {
        CandumpReader {
            lines: Lines::new(reader, path),
            interfaces: Vec::new(),
            error_frames: 0,
            frames: 0,
            streams: false,
        }
    }

    /// Marks the log as written while it is read (a pipe: [`CanSource::streams`]).
    #[must_use]
    pub fn streaming(mut self, streams: bool) -> CandumpReader<R> {
        self.streams = streams;
        self
    }

    /// The next frame (blank lines and error frames skipped); `None` at the end of the log. An
    /// error names the file and the line.
    pub fn next_frame(&mut self) -> Result<Option<CanFrame>> {
        loop {
            let Some(line) = self.lines.next_line()? else {
                return Ok(None);
            };
            if line.trim().is_empty() {
                continue;
            }
            match parse_line(&line, &mut self.interfaces) {
                Ok(frame) => {
                    self.frames += 1;
                    return Ok(Some(frame));
                }
                Err(Bad::ErrorFrame) => self.error_frames += 1,
                Err(Bad::Line(message)) => {
                    return Err(Error::Line {
                        path: line.path().to_owned(),
                        line: line.number(),
                        message: line.explain(message),
                    });
                }
            }
        }
    }

    /// The interfaces named so far, in order of first appearance (a frame's `bus` indexes this).
    pub fn interfaces(&self) -> &[String] {
        &self.interfaces
    }

    /// Error frames met so far, skipped.
    pub fn error_frames(&self) -> usize {
        self.error_frames
    }

    /// Frames read so far.
    pub fn frames_read(&self) -> u64 {
        self.frames
    }

    /// The file, as errors name it.
    pub fn path(&self) -> &Path {
        self.lines.path()
    }

    /// The input being read.
    pub fn get_ref(&self) -> &R {
        self.lines.get_ref()
    }

    /// The rest of the log, read into memory.
    pub fn into_log(mut self) -> Result<CandumpLog> {
        let mut frames = Vec::new();
        while let Some(f) = self.next_frame()? {
            frames.push(f);
        }
        Ok(CandumpLog {
            interfaces: self.interfaces,
            frames,
            error_frames: self.error_frames,
        })
    }
}

impl<R: BufRead> CanSource for CandumpReader<R> {
    fn next_frame(&mut self) -> Result<Option<CanFrame>> {
        CandumpReader::next_frame(self)
    }

    fn interfaces(&self) -> &[String] {
        &self.interfaces
    }

    fn error_frames(&self) -> usize {
        self.error_frames
    }

    fn bytes_read(&self) -> u64 {
        self.lines.consumed()
    }

    fn streams(&self) -> bool {
        self.streams
    }
}

impl<R: BufRead> Iterator for CandumpReader<R> {
    type Item = Result<CanFrame>;

    fn next(&mut self) -> Option<Result<CanFrame>> {
        CandumpReader::next_frame(self).transpose()
    }
}

fn intern(interfaces: &mut Vec<String>, name: &str) -> Option<u16> {
    let k = match interfaces.iter().position(|i| i == name) {
        Some(k) => k,
        None if interfaces.len() < MAX_BUSES => {
            interfaces.push(name.to_string());
            interfaces.len() - 1
        }
        None => return None,
    };
    u16::try_from(k).ok()
}

/// Appends one frame as a log line (with a newline).
pub fn write_line(out: &mut String, f: &CanFrame, iface: &str) {
    let _ = write!(
        out,
        "({}.{:06}) {iface} ",
        f.time_us / 1_000_000,
        f.time_us % 1_000_000
    );
    if f.extended {
        let _ = write!(out, "{:08X}#", f.id);
    } else {
        let _ = write!(out, "{:03X}#", f.id);
    }
    if f.remote {
        out.push('R');
    } else {
        for b in f.data() {
            let _ = write!(out, "{b:02X}");
        }
    }
    match f.direction {
        Some(Direction::Received) => out.push_str(" R"),
        Some(Direction::Transmitted) => out.push_str(" T"),
        None => {}
    }
    out.push('\n');
}

/// Why a line gave no frame.
enum Bad {
    /// A SocketCAN error frame: counted, not an error of the log.
    ErrorFrame,
    /// What is wrong with the line.
    Line(String),
}

impl<T: Into<String>> From<T> for Bad {
    fn from(message: T) -> Bad {
        Bad::Line(message.into())
    }
}

/// The CAN_ERR_FLAG bit of a SocketCAN identifier.
const ERROR_FLAG: u32 = 0x2000_0000;

fn parse_line(line: &str, interfaces: &mut Vec<String>) -> std::result::Result<CanFrame, Bad> {
    let mut fields = line.split_ascii_whitespace();
    let stamp = fields.next().ok_or("empty line")?;
    let stamp = stamp
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .ok_or_else(|| {
            format!(
                "timestamp \"{}\" is not of the form (seconds.micros)",
                excerpt(stamp)
            )
        })?;
    let time_us = parse_time(stamp)
        .ok_or_else(|| format!("timestamp \"{}\" is not a number of seconds", excerpt(stamp)))?;
    let iface = fields.next().ok_or("no interface after the timestamp")?;
    let frame = fields.next().ok_or("no ID#DATA after the interface")?;
    let direction = match fields.next() {
        None => None,
        Some("R") => Some(Direction::Received),
        Some("T") => Some(Direction::Transmitted),
        Some(other) => {
            return Err(format!(
                "unexpected \"{}\" after the frame (only R or T may follow)",
                excerpt(other)
            )
            .into());
        }
    };
    if let Some(extra) = fields.next() {
        return Err(format!("unexpected \"{}\" at the end of the line", excerpt(extra)).into());
    }
    let (id_hex, data_hex) = frame.split_once('#').ok_or_else(|| {
        format!(
            "frame \"{}\" has no '#' between identifier and data",
            excerpt(frame)
        )
    })?;
    if data_hex.starts_with('#') {
        return Err("CAN FD frames (##) are not supported; skin traffic is classic CAN".into());
    }
    let (id, extended) = parse_identifier(id_hex)?;
    let mut f = CanFrame {
        time_us,
        bus: intern(interfaces, iface).ok_or_else(|| {
            format!(
                "interface \"{}\" is one more than the {MAX_BUSES} a log may name",
                excerpt(iface)
            )
        })?,
        id,
        extended,
        remote: false,
        len: 0,
        bytes: [0; 8],
        direction,
    };
    if data_hex.starts_with('R') {
        f.remote = true;
        return Ok(f);
    }
    parse_data(data_hex, &mut f)?;
    Ok(f)
}

/// A frame's identifier: 3 hex digits for a standard one, 8 for an extended one. An extended
/// identifier with SocketCAN's error flag is an error frame.
fn parse_identifier(id_hex: &str) -> std::result::Result<(u32, bool), Bad> {
    let extended = match id_hex.len() {
        3 => false,
        8 => true,
        n => {
            return Err(format!(
                "identifier \"{}\" has {n} hex digits (3 for standard, 8 for extended)",
                excerpt(id_hex)
            )
            .into());
        }
    };
    let id = u32::from_str_radix(id_hex, 16)
        .map_err(|_| format!("identifier \"{}\" is not hexadecimal", excerpt(id_hex)))?;
    if extended && id & ERROR_FLAG != 0 {
        return Err(Bad::ErrorFrame);
    }
    if (!extended && id > 0x7FF) || id > 0x1FFF_FFFF {
        return Err(format!("identifier {id_hex} is out of range").into());
    }
    Ok((id, extended))
}

/// A frame's data, 0 to 8 bytes in hex pairs, into `f`.
fn parse_data(data_hex: &str, f: &mut CanFrame) -> std::result::Result<(), Bad> {
    if !data_hex.len().is_multiple_of(2) || data_hex.len() > 16 {
        return Err(format!("data \"{}\" is not 0 to 8 bytes of hex", excerpt(data_hex)).into());
    }
    for (k, pair) in data_hex.as_bytes().chunks(2).enumerate() {
        let s = std::str::from_utf8(pair).map_err(|_| "data is not ASCII hex".to_string())?;
        f.bytes[k] =
            u8::from_str_radix(s, 16).map_err(|_| format!("data byte \"{s}\" is not hexadecimal"))?;
    }
    f.len = (data_hex.len() / 2) as u8;
    Ok(())
}

/// Seconds with up to six decimals, to whole microseconds.
fn parse_time(s: &str) -> Option<u64> {
    let (secs, frac) = s.split_once('.').unwrap_or((s, ""));
    if secs.is_empty()
        || frac.len() > 9
        || !secs.bytes().all(|b| b.is_ascii_digit())
        || !frac.bytes().all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let secs: u64 = secs.parse().ok()?;
    let mut micros = 0u64;
    for (k, b) in frac.bytes().take(6).enumerate() {
        micros += u64::from(b - b'0') * 10u64.pow(5 - k as u32);
    }
    secs.checked_mul(1_000_000)?.checked_add(micros)
}
