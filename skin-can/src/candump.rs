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

use crate::busmap::MAX_BUSES;
use crate::{Error, Result};
use skin_core::format::excerpt;
use std::fmt::Write as _;
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
    /// Reads a log file.
    pub fn read(path: &Path) -> Result<CandumpLog> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses log text; `path` is used in error messages.
    pub fn parse(text: &str, path: &Path) -> Result<CandumpLog> {
        let mut log = CandumpLog::default();
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            match parse_line(line, &mut log.interfaces) {
                Ok(frame) => log.frames.push(frame),
                Err(Bad::ErrorFrame) => log.error_frames += 1,
                Err(Bad::Line(message)) => {
                    return Err(Error::Line {
                        path: path.to_owned(),
                        line: i + 1,
                        message,
                    });
                }
            }
        }
        Ok(log)
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
    if data_hex.len() % 2 != 0 || data_hex.len() > 16 {
        return Err(format!("data \"{}\" is not 0 to 8 bytes of hex", excerpt(data_hex)).into());
    }
    for (k, pair) in data_hex.as_bytes().chunks(2).enumerate() {
        let s = std::str::from_utf8(pair).map_err(|_| "data is not ASCII hex".to_string())?;
        f.bytes[k] =
            u8::from_str_radix(s, 16).map_err(|_| format!("data byte \"{s}\" is not hexadecimal"))?;
    }
    f.len = (data_hex.len() / 2) as u8;
    Ok(f)
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
