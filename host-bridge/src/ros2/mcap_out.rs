//! Scans and features written to an MCAP file as ROS 2 messages: profile
//! `ros2`, the three channels of [`messages::CHANNELS`] (schema encoding
//! `ros2msg`, message encoding `cdr`), zstd-compressed chunks, with the
//! summary (statistics, chunk and message indexes) written on
//! [`McapOut::finish`].
//!
//! A chunk reaches the file whole (the writer does not seek back into it):
//! a recording cut short (a crash, `kill -9`) keeps every chunk written
//! before the cut, readable by a linear reader. A live recording
//! ([`McapOut::create`] with `live`) closes its chunk every
//! [`LIVE_CHUNK_PERIOD`], so a cut loses at most that much.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use lms_core::{Features, Frame};
use mcap::records::MessageHeader;

use super::messages::{self, Stamp, CHANNELS};

/// How often a live recording closes its chunk (at most this much is lost
/// when the recorder is killed).
pub const LIVE_CHUNK_PERIOD: Duration = Duration::from_secs(1);

/// The QoS a publisher of these topics offers (reliable, volatile, keep
/// last), in rosbag2's YAML form: channel metadata `offered_qos_profiles`
/// and the `metadata.yaml` of a rosbag2 folder.
pub const OFFERED_QOS: &str = "- history: 1\n  depth: 10\n  reliability: 1\n  durability: 2\n  \
deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    \
nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    \
nsec: 854775807\n  avoid_ros_namespace_conventions: false";

/// What an MCAP output holds, per channel and in time.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Written {
    /// Frames written (each is one message on every channel).
    pub frames: u64,
    /// Messages per channel, in [`CHANNELS`] order.
    pub messages: [u64; 3],
    /// Log time of the first and the last message (ns), if any.
    pub span: Option<(u64, u64)>,
}

impl Written {
    /// Messages on all channels.
    pub fn total(&self) -> u64 {
        self.messages.iter().sum()
    }
}

/// An MCAP file being written (see the [module docs](self)).
pub struct McapOut<W: Write + Seek> {
    writer: mcap::Writer<W>,
    channel_ids: [u16; 3],
    sequence: u32,
    written: Written,
    /// Live recordings: when the open chunk was started, closed after
    /// [`LIVE_CHUNK_PERIOD`].
    chunk_started: Option<Instant>,
}

impl<W: Write + Seek> std::fmt::Debug for McapOut<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapOut")
            .field("written", &self.written)
            .finish()
    }
}

impl McapOut<BufWriter<File>> {
    /// Create (or truncate) `path`; `live`: close a chunk every
    /// [`LIVE_CHUNK_PERIOD`].
    pub fn create(path: &Path, live: bool) -> Result<Self> {
        let file =
            File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        McapOut::new(BufWriter::new(file), live)
            .with_context(|| format!("cannot write {}", path.display()))
    }
}

impl<W: Write + Seek> McapOut<W> {
    /// Start an MCAP stream on `out`: header, schemas and channels.
    pub fn new(out: W, live: bool) -> Result<Self> {
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("host-bridge ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .compression_threads(0)
            .disable_seeking(true);
        let mut writer = options.create(out).context("cannot start the MCAP file")?;
        let mut metadata = BTreeMap::new();
        metadata.insert("offered_qos_profiles".to_string(), OFFERED_QOS.to_string());
        let mut channel_ids = [0u16; 3];
        for (id, c) in channel_ids.iter_mut().zip(CHANNELS) {
            let schema = writer
                .add_schema(c.type_name, "ros2msg", c.schema.as_bytes())
                .context("cannot write an MCAP schema")?;
            *id = writer
                .add_channel(schema, c.topic, "cdr", &metadata)
                .context("cannot write an MCAP channel")?;
        }
        Ok(McapOut {
            writer,
            channel_ids,
            sequence: 0,
            written: Written::default(),
            chunk_started: live.then(Instant::now),
        })
    }

    /// Write one frame: its scan, its markers and its features, all logged
    /// at the stamp's time (a stamp before the epoch is logged at 0).
    pub fn write_frame(&mut self, stamp: &Stamp, frame: &Frame, features: &Features) -> Result<()> {
        let time = u64::try_from(stamp.ns).unwrap_or(0);
        let bodies = [
            messages::scan_cdr(stamp, frame),
            messages::markers_cdr(stamp, frame, features),
            messages::features_cdr(stamp, features),
        ];
        for (k, body) in bodies.iter().enumerate() {
            let header = MessageHeader {
                channel_id: self.channel_ids[k],
                sequence: self.sequence,
                log_time: time,
                publish_time: time,
            };
            self.writer
                .write_to_known_channel(&header, body)
                .context("cannot write an MCAP message")?;
            self.written.messages[k] += 1;
        }
        self.sequence = self.sequence.wrapping_add(1);
        self.written.frames += 1;
        self.written.span = Some(match self.written.span {
            None => (time, time),
            Some((a, b)) => (a.min(time), b.max(time)),
        });
        if let Some(started) = self.chunk_started {
            if started.elapsed() >= LIVE_CHUNK_PERIOD {
                self.writer.flush().context("cannot write an MCAP chunk")?;
                self.chunk_started = Some(Instant::now());
            }
        }
        Ok(())
    }

    /// What has been written so far.
    pub fn written(&self) -> &Written {
        &self.written
    }

    /// Add a metadata record (`name` and its key-value pairs).
    pub fn metadata(&mut self, name: &str, pairs: BTreeMap<String, String>) -> Result<()> {
        self.writer
            .write_metadata(&mcap::records::Metadata {
                name: name.to_string(),
                metadata: pairs,
            })
            .context("cannot write an MCAP metadata record")
    }

    /// Close the last chunk, write the summary (statistics, indexes) and
    /// the footer, flush; hands back what was written.
    pub fn finish(mut self) -> Result<Written> {
        self.writer
            .finish()
            .context("cannot finish the MCAP file")?;
        let written = std::mem::take(&mut self.written);
        let mut out = self.writer.into_inner();
        out.flush().context("cannot flush the MCAP file")?;
        Ok(written)
    }
}

/// A live recording into an MCAP file (`scan -o x.mcap`, `coprocessor -o
/// x.mcap`): each scan stamped with the time it is complete (ns since the
/// Unix epoch), frame id [`messages::DEFAULT_FRAME_ID`], its features
/// computed here by the std pipeline with `params`; a chunk closed every
/// [`LIVE_CHUNK_PERIOD`]. [`Recording::finish`] writes the summary (a
/// recording dropped without it, on an error, is finished by the MCAP
/// writer all the same).
pub struct Recording {
    out: McapOut<BufWriter<File>>,
    path: std::path::PathBuf,
    ex: Box<lms_core::Extractor>,
    params: lms_core::ValidParams,
    /// Scans that gave no frame (counted, not recorded).
    pub skipped: u64,
}

impl std::fmt::Debug for Recording {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recording")
            .field("path", &self.path)
            .field("written", self.out.written())
            .field("skipped", &self.skipped)
            .finish()
    }
}

impl Recording {
    /// Start recording into `path` (created or truncated).
    pub fn create(path: &Path, params: lms_core::ValidParams) -> Result<Self> {
        Ok(Recording {
            out: McapOut::create(path, true)?,
            path: path.to_path_buf(),
            ex: Box::new(lms_core::Extractor::new()),
            params,
            skipped: 0,
        })
    }

    /// Record `frame`, stamped now.
    pub fn record(&mut self, frame: &Frame) -> Result<()> {
        let ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        let stamp = Stamp {
            ns,
            frame_id: messages::DEFAULT_FRAME_ID.to_string(),
        };
        let features = self.ex.run(frame, &self.params);
        self.out
            .write_frame(&stamp, frame, features)
            .with_context(|| format!("cannot record into {}", self.path.display()))
    }

    /// Frames recorded so far.
    pub fn frames(&self) -> u64 {
        self.out.written().frames
    }

    /// Write the summary and close the file; a line that says what it holds.
    pub fn finish(self) -> Result<String> {
        let path = self.path;
        let written = self
            .out
            .finish()
            .with_context(|| format!("cannot finish {}", path.display()))?;
        let bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
        let skipped = match self.skipped {
            0 => String::new(),
            n => format!(", {n} scans skipped (no frame)"),
        };
        Ok(format!(
            "recording: {} ({} scans as {} ROS 2 messages, {bytes} bytes{skipped})",
            path.display(),
            written.frames,
            written.total()
        ))
    }
}
