//! An MCAP file in the ros2 profile (feature `mcap`): what `ros2 bag play`, Foxglove, Lichtblick
//! and the `mcap` Python readers open. One schema per message type (`ros2msg`, nested types
//! included), one channel per topic (`cdr`, with rosbag2's `offered_qos_profiles` and
//! `topic_type_hash` metadata), uncompressed.
//!
//! The file follows the rules of [`skin_core::output`]: it is built aside and appears only when
//! [`McapOutlet::finish`] succeeds (or moves into place with an output folder, see
//! [`McapOutlet::stage`]); one process at a time writes a path (a second is refused at once);
//! an existing file at the path is replaced only if skin wrote it ([`written_by_skin`]); an
//! input is never written.

use crate::RosError;
use crate::bridge::Outlet;
use crate::interfaces::Interfaces;
use crate::topics::{Topics, offered_qos_yaml};
use mcap::records::{MessageHeader, Metadata};
use mcap::write::NoSeek;
use skin_core::output::{Inputs, OutputFile, Staged};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The first bytes of every MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// What [`McapOutlet`] writes in the header's `library` field, before its version.
const LIBRARY: &str = "skin ";

/// The longest header record read: a profile and a library name, a few dozen bytes in any
/// MCAP writer; a file that claims more is not read further.
const MAX_HEADER: u64 = 64 * 1024;

/// Whether the file at `path` is an MCAP file that skin wrote: its header record (read with
/// the `mcap` crate, at most 64 KiB of it) names skin as the library. A bag another tool
/// recorded is not, and is never replaced.
pub fn written_by_skin(path: &Path) -> bool {
    let read = || -> std::io::Result<bool> {
        let mut f = std::fs::File::open(path)?;
        let mut head = [0u8; 8 + 1 + 8];
        f.read_exact(&mut head)?;
        let len = u64::from_le_bytes(head[9..].try_into().unwrap_or_default());
        if &head[..8] != MAGIC || head[8] != mcap::records::op::HEADER || len > MAX_HEADER {
            return Ok(false);
        }
        let mut body = Vec::new();
        f.take(len).read_to_end(&mut body)?;
        Ok(matches!(
            mcap::parse_record(mcap::records::op::HEADER, &body),
            Ok(mcap::records::Record::Header(h)) if h.library.starts_with(LIBRARY)
        ))
    };
    read().unwrap_or(false)
}

/// An MCAP file being written; [`McapOutlet::finish`] puts it in place.
pub struct McapOutlet {
    writer: mcap::Writer<NoSeek<OutputFile>>,
    path: PathBuf,
    channels: Vec<u16>,
    sequence: u32,
    messages: u64,
}

impl std::fmt::Debug for McapOutlet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapOutlet")
            .field("path", &self.path)
            .field("messages", &self.messages)
            .finish_non_exhaustive()
    }
}

fn mcap_error(path: &Path) -> impl Fn(mcap::McapError) -> RosError + '_ {
    move |e| RosError::Mcap {
        path: path.to_owned(),
        why: why(&e),
    }
}

/// What went wrong, in the operating system's words when it was the operating system (the
/// crate's own text for I/O says only "I/O error from writing, or reading a compression
/// stream").
fn why(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => io.to_string(),
        e => e.to_string(),
    }
}

impl McapOutlet {
    /// Starts the file at `path` with a channel for each of `topics`.
    pub fn create(path: &Path, topics: &Topics, inputs: &Inputs) -> Result<McapOutlet, RosError> {
        inputs.check(path)?;
        skin_core::output::check_replaceable(path, "an MCAP file that skin wrote", written_by_skin)?;
        let interfaces = Interfaces::skin()?;
        let file = OutputFile::create_exclusive(path, inputs)?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("{LIBRARY}{}", env!("CARGO_PKG_VERSION")))
            .compression(None)
            .disable_seeking(true);
        let err = mcap_error(path);
        let mut writer = options.create(NoSeek::new(file)).map_err(&err)?;
        writer
            .write_metadata(&Metadata {
                name: "rosbag2".into(),
                metadata: BTreeMap::from([("ros_distro".into(), "jazzy".into())]),
            })
            .map_err(&err)?;
        let mut schemas: BTreeMap<&str, u16> = BTreeMap::new();
        let mut channels = Vec::with_capacity(topics.list.len());
        for (k, topic) in topics.list.iter().enumerate() {
            let ty = topic.type_name;
            let schema = match schemas.get(ty) {
                Some(&id) => id,
                None => {
                    let text = interfaces.schema(ty).ok_or(RosError::UnknownType(ty))?;
                    let id = writer.add_schema(ty, "ros2msg", text.as_bytes()).map_err(&err)?;
                    schemas.insert(ty, id);
                    id
                }
            };
            let hash = interfaces.type_hash(ty).ok_or(RosError::UnknownType(ty))?;
            let metadata = BTreeMap::from([
                ("offered_qos_profiles".to_owned(), offered_qos_yaml(topics.qos(k))),
                ("topic_type_hash".to_owned(), hash),
            ]);
            channels.push(
                writer
                    .add_channel(schema, &topic.name, "cdr", &metadata)
                    .map_err(&err)?,
            );
        }
        Ok(McapOutlet {
            writer,
            path: path.to_owned(),
            channels,
            sequence: 0,
            messages: 0,
        })
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// Writes the summary and puts the file in place.
    pub fn finish(self) -> Result<u64, RosError> {
        let (file, messages) = self.stage()?;
        file.commit()?;
        Ok(messages)
    }

    /// Writes the summary, every byte checked, and leaves the file to be moved into place
    /// (with an output folder: [`skin_core::output::OutputDir::commit_with`]). Also says how
    /// many messages it holds.
    pub fn stage(mut self) -> Result<(Staged, u64), RosError> {
        let err = mcap_error(&self.path);
        self.writer.finish().map_err(&err)?;
        let file = self.writer.into_inner().into_inner();
        Ok((file.stage()?, self.messages))
    }
}

impl Outlet for McapOutlet {
    fn publish(&mut self, topic: usize, stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        let Some(&channel_id) = self.channels.get(topic) else {
            return Err(std::io::Error::other(format!("no topic {topic}")));
        };
        self.sequence = self.sequence.wrapping_add(1);
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: stamp_ns,
            publish_time: stamp_ns,
        };
        self.writer
            .write_to_known_channel(&header, cdr)
            .map_err(|e| std::io::Error::other(format!("{}: {}", self.path.display(), why(&e))))?;
        self.messages += 1;
        Ok(())
    }
}
