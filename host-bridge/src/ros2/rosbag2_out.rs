//! ROS 2 output of `extract`, `scan` and `coprocessor`: an MCAP file
//! ([`super::mcap_out`]) or a rosbag2 folder, chosen by [`Format`].
//!
//! A rosbag2 folder is what `ros2 bag record -s mcap` leaves: `NAME_0.mcap`
//! (NAME the folder's name) and `metadata.yaml` beside it (rosbag2 format
//! version 5, read by ROS 2 Humble and later: storage `mcap`, the file,
//! duration, starting time, message counts per topic with each topic's
//! type, serialization format `cdr` and offered QoS, no compression; the
//! MCAP file's own chunks are zstd-compressed). The same YAML is also in
//! the MCAP file, as the metadata record `rosbag2` (key
//! `serialized_metadata`), as rosbag2's MCAP storage writes it.
//!
//! Stamps ([`stamp_for`]): a frame's header stamp is the input's own (a
//! ROS 2 bag's), else the capture's time (µs from its start), else the
//! frame's index times the LMS 2xx scan period of its variant
//! (13.3 ms at 1°, 26.7 ms at 0.5°, 53.3 ms at 0.25°: CARMEN logs, whose
//! time stamps are too coarse, and synthetic scenes), counted from 0.
//! The frame id is the input's, else [`messages::DEFAULT_FRAME_ID`].

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lms_core::Frame;

use super::mcap_out::{McapOut, Written, OFFERED_QOS};
use super::messages::{self, Stamp, CHANNELS};

/// The output format of `extract -o` (and `--format`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// JSON Lines, one object per frame (the default).
    Jsonl,
    /// An MCAP file of ROS 2 messages (the default for a name ending in `.mcap`).
    Mcap,
    /// A rosbag2 folder: metadata.yaml and one MCAP file.
    Rosbag2,
}

impl Format {
    /// The format asked for, else the one the output's name tells
    /// (`.mcap`: MCAP), else JSON Lines.
    pub fn choose(asked: Option<Format>, output: Option<&Path>) -> Format {
        match (asked, output) {
            (Some(f), _) => f,
            (None, Some(p))
                if p.extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("mcap")) =>
            {
                Format::Mcap
            }
            _ => Format::Jsonl,
        }
    }
}

/// The stamp of a frame (see the [module docs](self)): `stamp_ns` and
/// `frame_id` from a ROS 2 input, `time_us` from a capture, else
/// `index` scan periods.
pub fn stamp_for(
    index: usize,
    frame: &Frame,
    stamp_ns: Option<i64>,
    time_us: Option<u64>,
    frame_id: Option<&str>,
) -> Stamp {
    let ns = stamp_ns
        .or_else(|| time_us.map(|us| i64::try_from(us.saturating_mul(1000)).unwrap_or(i64::MAX)))
        .unwrap_or_else(|| {
            i64::try_from(index)
                .unwrap_or(i64::MAX)
                .saturating_mul(scan_period_ns(frame))
        });
    Stamp {
        ns,
        frame_id: frame_id.unwrap_or(messages::DEFAULT_FRAME_ID).to_string(),
    }
}

/// The scan period of an LMS 2xx sending frames like `frame` (ns).
fn scan_period_ns(frame: &Frame) -> i64 {
    let variant =
        lms_core::carmen::variant_for_beams(frame.len()).unwrap_or(lms_core::Variant::Fov180Res100);
    let us = lms_core::device::emulator::scan_period_us(variant);
    i64::try_from(us).unwrap_or(i64::MAX / 1000) * 1000
}

/// A rosbag2 folder being written (see the [module docs](self)).
#[derive(Debug)]
pub struct Rosbag2Out {
    dir: PathBuf,
    file_name: String,
    mcap: McapOut<BufWriter<File>>,
}

impl Rosbag2Out {
    /// Create the folder `dir` (it must not exist, or be empty) and its
    /// MCAP file; `live` as for [`McapOut::create`].
    pub fn create(dir: &Path, live: bool) -> Result<Self> {
        match std::fs::read_dir(dir) {
            Ok(mut entries) => {
                if entries.next().is_some() {
                    bail!(
                        "{} exists and is not empty: a rosbag2 output needs a new (or empty) folder",
                        dir.display()
                    );
                }
            }
            Err(e) if e.kind() == io::ErrorKind::NotFound => std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create the folder {}", dir.display()))?,
            Err(e) => {
                return Err(e).with_context(|| format!("{} is not a usable folder", dir.display()))
            }
        }
        let name = dir
            .canonicalize()
            .ok()
            .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "rosbag2".to_string());
        let file_name = format!("{name}_0.mcap");
        let mcap = McapOut::create(&dir.join(&file_name), live)?;
        Ok(Rosbag2Out {
            dir: dir.to_path_buf(),
            file_name,
            mcap,
        })
    }

    /// Finish the MCAP file and write `metadata.yaml`.
    pub fn finish(mut self) -> Result<Written> {
        let yaml = metadata_yaml(&self.file_name, self.mcap.written());
        let mut record = BTreeMap::new();
        record.insert("serialized_metadata".to_string(), yaml.clone());
        self.mcap.metadata("rosbag2", record)?;
        let written = self.mcap.finish()?;
        let path = self.dir.join("metadata.yaml");
        std::fs::write(&path, format!("rosbag2_bagfile_information:\n{yaml}"))
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(written)
    }
}

/// The body of `metadata.yaml` (under `rosbag2_bagfile_information:`),
/// indented by two spaces.
pub fn metadata_yaml(file_name: &str, w: &Written) -> String {
    let (start, end) = w.span.unwrap_or((0, 0));
    let duration = end - start;
    let total = w.total();
    let mut y = String::new();
    // Writing to a String cannot fail.
    let _ = write!(
        y,
        "  version: 5\n  storage_identifier: mcap\n  duration:\n    nanoseconds: {duration}\n  \
         starting_time:\n    nanoseconds_since_epoch: {start}\n  message_count: {total}\n  \
         topics_with_message_count:\n"
    );
    let qos = OFFERED_QOS.replace('\n', "\\n");
    for (c, count) in CHANNELS.iter().zip(w.messages) {
        let _ = write!(
            y,
            "    - topic_metadata:\n        name: {}\n        type: {}\n        \
             serialization_format: cdr\n        offered_qos_profiles: \"{qos}\"\n      \
             message_count: {count}\n",
            c.topic, c.type_name
        );
    }
    let _ = write!(
        y,
        "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    \
         - {file_name}\n  files:\n    - path: {file_name}\n      starting_time:\n        \
         nanoseconds_since_epoch: {start}\n      duration:\n        nanoseconds: {duration}\n      \
         message_count: {total}\n"
    );
    y
}

/// Where ROS 2 messages go: an MCAP file or a rosbag2 folder.
#[derive(Debug)]
pub enum RosOut {
    /// One MCAP file.
    Mcap(McapOut<BufWriter<File>>),
    /// A rosbag2 folder.
    Rosbag2(Rosbag2Out),
}

impl RosOut {
    /// Create the output at `path` in `format` (MCAP or rosbag2; `None`
    /// for JSON Lines); `live`: a recording (chunks closed every
    /// [`super::mcap_out::LIVE_CHUNK_PERIOD`]).
    pub fn create(format: Format, path: &Path, live: bool) -> Result<Option<Self>> {
        Ok(match format {
            Format::Jsonl => None,
            Format::Mcap => Some(RosOut::Mcap(McapOut::create(path, live)?)),
            Format::Rosbag2 => Some(RosOut::Rosbag2(Rosbag2Out::create(path, live)?)),
        })
    }

    /// Write one frame: scan, markers and features.
    pub fn write_frame(
        &mut self,
        stamp: &Stamp,
        frame: &Frame,
        features: &lms_core::Features,
    ) -> Result<()> {
        let mcap = match self {
            RosOut::Mcap(m) => m,
            RosOut::Rosbag2(b) => &mut b.mcap,
        };
        mcap.write_frame(stamp, frame, features)
    }

    /// Finish the file (summary, indexes; `metadata.yaml` for a folder).
    pub fn finish(self) -> Result<Written> {
        match self {
            RosOut::Mcap(m) => m.finish(),
            RosOut::Rosbag2(b) => b.finish(),
        }
    }
}
