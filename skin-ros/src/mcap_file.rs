//! An MCAP file in the ros2 profile (feature `mcap`): what `ros2 bag play`, Foxglove, Lichtblick
//! and the `mcap` Python readers open. One schema per message type (`ros2msg`, nested types
//! included), one channel per topic (`cdr`, with rosbag2's `offered_qos_profiles` and
//! `topic_type_hash` metadata), uncompressed.
//!
//! The file follows the rules of [`skin_core::output`]: it is built aside and appears only when
//! [`McapOutlet::finish`] succeeds; an existing file at the path is replaced only if it is an
//! MCAP file; an input is never written.

use crate::RosError;
use crate::bridge::Outlet;
use crate::interfaces::Interfaces;
use crate::topics::{Topics, offered_qos_yaml};
use mcap::records::{MessageHeader, Metadata};
use mcap::write::NoSeek;
use skin_core::output::{Inputs, OutputFile};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The first bytes of every MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// Whether the file at `path` is an MCAP file (its first 8 bytes).
pub fn is_mcap(path: &Path) -> bool {
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| &head == MAGIC)
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
        why: e.to_string(),
    }
}

impl McapOutlet {
    /// Starts the file at `path` with a channel for each of `topics`.
    pub fn create(path: &Path, topics: &Topics, inputs: &Inputs) -> Result<McapOutlet, RosError> {
        inputs.check(path)?;
        skin_core::output::check_replaceable(path, "an MCAP file", is_mcap)?;
        let interfaces = Interfaces::skin()?;
        let file = OutputFile::create(path, inputs)?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("skin ", env!("CARGO_PKG_VERSION")))
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
        for topic in &topics.list {
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
                ("offered_qos_profiles".to_owned(), offered_qos_yaml()),
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
    pub fn finish(mut self) -> Result<u64, RosError> {
        let err = mcap_error(&self.path);
        self.writer.finish().map_err(&err)?;
        let file = self.writer.into_inner().into_inner();
        file.commit()?;
        Ok(self.messages)
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
            .map_err(|e| std::io::Error::other(format!("{}: {e}", self.path.display())))?;
        self.messages += 1;
        Ok(())
    }
}
