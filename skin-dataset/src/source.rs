//! What an episode is made from: a candump log or a raw recording, as a file or as bytes (a Ray
//! worker's `read_binary_files` row), gzip-compressed or not; which one it is, is read from its
//! first line, not from its name (skin-can's [`Traffic`]).

use sha2::{Digest, Sha256};
use skin_can::{Traffic, TrafficError};
use skin_core::text::{Gzip, Input};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The kind of input, told from its first line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// A candump log (`(time) can0 ID#DATA` lines): run through the bus map.
    Candump,
    /// A raw recording (a line of taxel ids, then index, time and one value a taxel).
    Recording,
}

impl InputKind {
    /// The name the episodes table gives it.
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Candump => "candump",
            InputKind::Recording => "recording",
        }
    }
}

/// An input, opened: its reader (which form it is, told as `skin convert` tells it), and the
/// SHA-256 of its bytes as stored (the content hash a rerun skips finished inputs by).
#[derive(Debug)]
pub struct Source {
    /// Names it in errors and in the episodes table.
    pub path: PathBuf,
    /// SHA-256 of its bytes as stored (compressed, if it is), hex.
    pub sha256: String,
    pub(crate) traffic: Traffic,
}

/// SHA-256 of everything `reader` gives, hex.
pub fn sha256_of(mut reader: impl Read) -> std::io::Result<String> {
    let mut hash = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = reader.read(&mut buf)?;
        if n == 0 {
            break;
        }
        hash.update(&buf[..n]);
    }
    Ok(hex(&hash.finalize()))
}

/// SHA-256 of `bytes`, hex.
pub fn sha256_bytes(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

impl Source {
    /// Opens the file at `path` (hashed first, in one pass of its own).
    pub fn open(path: &Path) -> Result<Source, TrafficError> {
        let file = skin_core::text::open_file(path)?;
        let sha256 = sha256_of(file).map_err(|source| TrafficError::Read {
            path: path.to_owned(),
            source,
        })?;
        Ok(Source {
            path: path.to_owned(),
            sha256,
            traffic: Traffic::open(path)?,
        })
    }

    /// An input held in memory (`path` names it).
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Source, TrafficError> {
        let sha256 = sha256_bytes(&bytes);
        let len = bytes.len() as u64;
        let input = Input::from_reader(std::io::Cursor::new(bytes), path, Some(len), Gzip::Read)?;
        Ok(Source {
            path: path.to_owned(),
            sha256,
            traffic: Traffic::from_input(input, path)?,
        })
    }

    /// What it is.
    pub fn kind(&self) -> InputKind {
        match self.traffic {
            Traffic::Log(_) => InputKind::Candump,
            Traffic::Recording(_) => InputKind::Recording,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_log_and_a_recording_are_told_apart_by_their_first_line() {
        let log = Source::from_bytes(Path::new("a.log"), b"(1.000000) can0 101#00\n".to_vec()).unwrap();
        assert_eq!(log.kind(), InputKind::Candump);
        let rec = Source::from_bytes(Path::new("b.txt"), b"17 18\n0 0.0 1 2\n".to_vec()).unwrap();
        assert_eq!(rec.kind(), InputKind::Recording);
        let e = Source::from_bytes(Path::new("c.bin"), b"\x00\x01 not text".to_vec()).unwrap_err();
        assert!(e.to_string().contains("c.bin"), "{e}");
    }

    #[test]
    fn gzip_is_read_through_and_hashed_as_stored() {
        use std::io::Write as _;
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        gz.write_all(b"(1.000000) can0 101#00\n").unwrap();
        let bytes = gz.finish().unwrap();
        let s = Source::from_bytes(Path::new("a.log.gz"), bytes.clone()).unwrap();
        assert_eq!(s.kind(), InputKind::Candump);
        assert_eq!(s.sha256, sha256_bytes(&bytes));
        // The hash of an empty input is SHA-256's own.
        assert_eq!(
            sha256_bytes(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }
}
