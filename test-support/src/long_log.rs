//! A long candump log made as it is read: a log (the fixture session's) repeated with its
//! timestamps shifted, one copy after the other, never held whole. It counts the bytes it has
//! handed out, so a test can tell how much of the log a reader had taken when something happened.
//! `tools/long_log.py` writes the same log to a file for the benchmarks.

use std::io::Read;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Seconds between the end of one copy and the start of the next.
pub const GAP_US: u64 = 1_000_000;

/// The log `text` repeated `copies` times, each copy's stamps shifted by the span of the ones
/// before it plus [`GAP_US`].
pub struct RepeatedLog {
    /// Each line's stamp (µs) and what follows its closing parenthesis, line end included.
    lines: Vec<(u64, String)>,
    period_us: u64,
    copies: u64,
    copy: u64,
    next: usize,
    pending: Vec<u8>,
    at: usize,
    served: Arc<AtomicU64>,
}

impl RepeatedLog {
    /// `text` (a candump log whose every line starts `(seconds.micros)`) repeated `copies` times.
    pub fn new(text: &str, copies: u64) -> RepeatedLog {
        let lines: Vec<(u64, String)> = text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                let (stamp, rest) = l[1..].split_once(')').expect("a candump line");
                let (s, us) = stamp.split_once('.').expect("seconds.micros");
                let t = s.parse::<u64>().expect("seconds") * 1_000_000 + us.parse::<u64>().expect("micros");
                (t, format!("){rest}\n"))
            })
            .collect();
        let first = lines.first().map_or(0, |l| l.0);
        let last = lines.last().map_or(0, |l| l.0);
        RepeatedLog {
            period_us: last - first + GAP_US,
            lines,
            copies,
            copy: 0,
            next: 0,
            pending: Vec::new(),
            at: 0,
            served: Arc::new(AtomicU64::new(0)),
        }
    }

    /// The count of bytes read from it so far, to look at while another holds the log.
    pub fn served(&self) -> Arc<AtomicU64> {
        Arc::clone(&self.served)
    }

    /// Its whole length, bytes (what a whole-file reader would read before anything else).
    pub fn len(&self) -> u64 {
        // Every stamp of every copy has as many digits as the first one's (seconds of 10
        // digits, micros of 6), so each copy has the same length.
        let one: usize = self
            .lines
            .iter()
            .map(|(t, rest)| stamp(*t).len() + rest.len())
            .sum();
        one as u64 * self.copies
    }

    /// Whether it holds no byte at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// `(seconds.micros` of a time in µs.
fn stamp(t: u64) -> String {
    format!("({}.{:06}", t / 1_000_000, t % 1_000_000)
}

impl Read for RepeatedLog {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.at == self.pending.len() {
            if self.copy == self.copies || self.lines.is_empty() {
                return Ok(0);
            }
            let (t, rest) = &self.lines[self.next];
            self.pending.clear();
            self.at = 0;
            self.pending
                .extend_from_slice(stamp(t + self.copy * self.period_us).as_bytes());
            self.pending.extend_from_slice(rest.as_bytes());
            self.next += 1;
            if self.next == self.lines.len() {
                self.next = 0;
                self.copy += 1;
            }
        }
        let n = buf.len().min(self.pending.len() - self.at);
        buf[..n].copy_from_slice(&self.pending[self.at..self.at + n]);
        self.at += n;
        self.served.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
}
