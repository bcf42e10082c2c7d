//! ROS 2 bags as scan input: a rosbag2 folder with MCAP storage (its
//! `metadata.yaml` beside the `.mcap` files it names), or one `.mcap`
//! file, holding `sensor_msgs/msg/LaserScan` messages in CDR
//! ([`crate::ros2::laser_scan`]). [`BagScans`] streams the scans of one
//! topic as [`BagScan`]s, which `crate::input` hands out like the scans
//! of a CARMEN log.
//!
//! # Topic
//!
//! `--topic NAME` chooses it; without it, the bag's only LaserScan topic.
//! The topics come from each file's summary section (read from its end);
//! a file without one (a cut recording) is read once more to list them.
//!
//! # Geometry
//!
//! `angle_min`, `angle_increment` and the number of ranges must be those
//! of an LMS 2xx variant ([`scan_frame::variant_of`]): 180° from −90° or
//! 100° from −50°, at 1°, 0.5° or 0.25° (181, 361, 101, 201 or 401
//! ranges; 180 and 360 as in CARMEN logs); any other scan is an error
//! that names its angles (in degrees) and its count.
//!
//! # Ranges: quantised as the sensor sends them
//!
//! Each range becomes the integer code the LMS would send in the bag's
//! unit, `round(range / unit)`, and is then read exactly as the CARMEN
//! reader reads a range of a log: a code at or above the unit's first
//! error code is an invalid beam with that code's reason, 0 is a zero
//! range, any other code is the `f32` nearest `code × unit` (the `f32`
//! its decimal text parses to). So a bag written from a log's ranges
//! gives frames, and features, bit-identical to the log's. The unit is
//! `--unit`, or with `auto` decided on the first scan
//! ([`scan_frame::unit_for`]): mm when `range_max` is below 32.759 m (the
//! first mm error code), or when a quarter of the valid ranges are not
//! whole centimetres and none reaches 32.759 m; else cm.
//!
//! Ranges that are not finite, below `range_min` or above `range_max` are
//! invalid beams; the reasons are counted ([`scan_frame::InvalidCounts`])
//! and reported on stderr once the scans are read ([`BagScans::report`]).
//!
//! # Stamps, cut files, memory
//!
//! Each scan keeps its header's stamp (ns) and frame id. A file that
//! ends inside a record (a cut recording) keeps every scan read before
//! the cut and says where it is cut ([`BagScans::cut`]). The files are
//! streamed through `mcap`'s message reader over a buffered file: memory
//! holds one chunk at a time, whatever the bag's length.

pub mod files;
pub mod scan_frame;

use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use lms_core::Unit;
use mcap::sans_io::{SummaryReadEvent, SummaryReader};

use crate::ros2::laser_scan::{self, LaserScan, MESSAGE_ENCODING, SCHEMA_NAME};
use files::BagFiles;
use lms_core::Frame;
use scan_frame::InvalidCounts;

/// The magic bytes an MCAP file starts with.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// Bytes read from a bag file at a time.
const READ_BUFFER: usize = 256 * 1024;

/// `true` if `path` is a bag: a rosbag2 folder (or its `metadata.yaml`),
/// or a file whose first bytes `head` are the MCAP magic.
pub fn is_bag(path: &Path, head: &[u8]) -> bool {
    head.starts_with(MAGIC) || files::is_folder(path)
}

/// `true` if `path` is a bag: a rosbag2 folder (or its `metadata.yaml`),
/// or a file that starts with the MCAP magic.
pub fn is_bag_path(path: &Path) -> bool {
    if files::is_folder(path) {
        return true;
    }
    let mut head = [0u8; 8];
    File::open(path).is_ok_and(|mut f| f.read_exact(&mut head).is_ok() && head == *MAGIC)
}

/// A topic of a bag: its name, schema name and message encoding.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Topic {
    /// The topic, e.g. `/scan`.
    pub name: String,
    /// The schema (message type) name, e.g. `sensor_msgs/msg/LaserScan`.
    pub schema: String,
    /// The message encoding, e.g. `cdr`.
    pub encoding: String,
}

impl Topic {
    fn of(channel: &mcap::Channel<'_>) -> Topic {
        Topic {
            name: channel.topic.clone(),
            schema: channel
                .schema
                .as_ref()
                .map_or_else(String::new, |s| s.name.clone()),
            encoding: channel.message_encoding.clone(),
        }
    }
}

/// The topics of the MCAP file at `path` from its summary section, or
/// `None` if it has none (or it cannot be read: a cut file).
fn summary_topics(path: &Path) -> Result<Option<Vec<Topic>>> {
    let mut file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut reader = SummaryReader::new();
    while let Some(event) = reader.next_event() {
        let step = match event {
            Ok(SummaryReadEvent::ReadRequest(n)) => file.read(reader.insert(n)).map(|got| {
                reader.notify_read(got);
            }),
            Ok(SummaryReadEvent::SeekRequest(to)) => file.seek(to).map(|at| {
                reader.notify_seeked(at);
            }),
            Err(_) => return Ok(None),
        };
        if step.is_err() {
            return Ok(None);
        }
    }
    Ok(reader
        .finish()
        .filter(|s| !s.channels.is_empty())
        .map(|s| s.channels.values().map(|c| Topic::of(c)).collect()))
}

/// The topics of the messages of the MCAP file at `path`, read through
/// (up to a cut or damage).
fn scanned_topics(path: &Path) -> Result<Vec<Topic>> {
    let mut topics: Vec<Topic> = Vec::new();
    for message in mcap::io::MessageReader::new(open_file(path)?) {
        let Ok(message) = message else { break };
        if !topics.iter().any(|t| t.name == message.channel.topic) {
            topics.push(Topic::of(&message.channel));
        }
    }
    Ok(topics)
}

/// The topics of every file of a bag, sorted, each once.
pub fn topics(files: &[PathBuf]) -> Result<Vec<Topic>> {
    let mut all = Vec::new();
    for path in files {
        match summary_topics(path)? {
            Some(t) => all.extend(t),
            None => all.extend(scanned_topics(path)?),
        }
    }
    all.sort();
    all.dedup();
    Ok(all)
}

/// The names of `topics`, comma-separated, each with its type.
fn listed(topics: &[&Topic]) -> String {
    topics
        .iter()
        .map(|t| format!("{} ({})", t.name, t.schema))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The topic to read: `want`, or the only LaserScan topic.
fn choose(path: &Path, topics: &[Topic], want: Option<&str>) -> Result<Topic> {
    let scans: Vec<&Topic> = topics.iter().filter(|t| t.schema == SCHEMA_NAME).collect();
    let all: Vec<&Topic> = topics.iter().collect();
    let known = if all.is_empty() {
        "none".to_string()
    } else {
        listed(&all)
    };
    let topic = match want {
        Some(name) => match topics.iter().find(|t| t.name == name) {
            Some(t) if t.schema == SCHEMA_NAME => t,
            Some(t) => bail!(
                "{}: topic {name} holds {}, not {SCHEMA_NAME}",
                path.display(),
                t.schema
            ),
            None => bail!("{}: no topic {name}; its topics: {}", path.display(), known),
        },
        None => match scans[..] {
            [only] => only,
            [] => bail!(
                "{}: no {SCHEMA_NAME} topic; its topics: {}",
                path.display(),
                known
            ),
            _ => bail!(
                "{}: {} {SCHEMA_NAME} topics: {}; choose one with --topic",
                path.display(),
                scans.len(),
                scans
                    .iter()
                    .map(|t| t.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
    };
    if topic.encoding != MESSAGE_ENCODING {
        bail!(
            "{}: topic {}: message encoding {:?} is not supported (ROS 2 CDR, \"{MESSAGE_ENCODING}\", only)",
            path.display(),
            topic.name,
            topic.encoding
        );
    }
    Ok(topic.clone())
}

/// A bag file opened for streaming, checked to be MCAP.
fn open_file(path: &Path) -> Result<BufReader<File>> {
    let mut file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut head = [0u8; 8];
    let got = file.read(&mut head).unwrap_or(0);
    if head[..got] != MAGIC[..] {
        bail!(
            "{}: not an MCAP file (no MCAP magic at its start)",
            path.display()
        );
    }
    file.rewind()
        .with_context(|| format!("cannot read {}", path.display()))?;
    Ok(BufReader::with_capacity(READ_BUFFER, file))
}

/// One scan of a bag's topic.
#[derive(Clone, Debug)]
pub struct BagScan {
    /// Index among the topic's messages, from 0.
    pub index: usize,
    /// The frame in metres, invalid beams with their reason.
    pub frame: Frame,
    /// The stamp of the message's header (ns since the epoch).
    pub stamp_ns: i64,
    /// The frame id of the message's header.
    pub frame_id: String,
}

/// The scans of one topic of a bag, streamed (see the [module docs](self)).
pub struct BagScans {
    path: PathBuf,
    files: BagFiles,
    /// The file being read (index into `files.files`) and its reader.
    at: usize,
    reader: Option<mcap::io::MessageReader<BufReader<File>>>,
    topic: Topic,
    unit: Unit,
    unit_forced: bool,
    range_max: f32,
    /// The first scan, read when the bag is opened.
    first: Option<Result<BagScan>>,
    index: usize,
    counts: InvalidCounts,
    cut: Option<String>,
}

impl std::fmt::Debug for BagScans {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagScans")
            .field("path", &self.path)
            .field("topic", &self.topic)
            .field("unit", &self.unit)
            .field("index", &self.index)
            .finish()
    }
}

impl BagScans {
    /// Open the bag at `path` (a `.mcap` file, a rosbag2 folder or its
    /// `metadata.yaml`), choose the topic (`topic`, or the only LaserScan
    /// one) and read its first scan, which decides the unit when `unit`
    /// is `None`. A folder whose metadata names missing files warns and
    /// reads the others.
    pub fn open(path: &Path, unit: Option<Unit>, topic: Option<&str>) -> Result<BagScans> {
        let files = files::locate(path)?;
        if !files.missing.is_empty() {
            crate::warning::warn(&format!(
                "{}: {} of the {} files its metadata names are missing and skipped: {}",
                path.display(),
                files.missing.len(),
                files.missing.len() + files.files.len(),
                files::names_of(&files.missing)
            ));
        }
        let topic = choose(path, &topics(&files.files)?, topic)?;
        BagScans::start(path, files, topic, unit)
    }

    /// The same scans again from the first, in the same unit (for a
    /// survey of the data before the scans are used).
    pub fn reopen(&self) -> Result<BagScans> {
        BagScans::start(
            &self.path,
            self.files.clone(),
            self.topic.clone(),
            Some(self.unit),
        )
    }

    fn start(path: &Path, files: BagFiles, topic: Topic, unit: Option<Unit>) -> Result<BagScans> {
        let mut bag = BagScans {
            path: path.to_owned(),
            files,
            at: 0,
            reader: None,
            topic,
            unit: unit.unwrap_or(Unit::Centimetre),
            unit_forced: unit.is_some(),
            range_max: f32::NAN,
            first: None,
            index: 0,
            counts: InvalidCounts::default(),
            cut: None,
        };
        bag.first = bag.read_first()?;
        Ok(bag)
    }

    /// The first scan: its message decides the unit (unless forced).
    fn read_first(&mut self) -> Result<Option<Result<BagScan>>> {
        let message = match self.next_message() {
            None => return Ok(None),
            Some(Err(e)) => return Err(e),
            Some(Ok(m)) => m,
        };
        let scan = self.decode(&message)?;
        self.range_max = scan.range_max;
        if !self.unit_forced {
            self.unit = scan_frame::unit_for(&scan);
        }
        Ok(Some(self.input_of(scan, &message)))
    }

    /// The topic read.
    pub fn topic(&self) -> &str {
        &self.topic.name
    }

    /// The unit the ranges are quantised in.
    pub fn unit(&self) -> Unit {
        self.unit
    }

    /// The invalid beams of the scans read so far, by reason.
    pub fn invalid(&self) -> InvalidCounts {
        self.counts
    }

    /// The bag for a summary line, e.g. `ROS 2 bag, topic /scan, cm ranges
    /// (range_max 81.82 m)`.
    pub fn describe(&self) -> String {
        let why = if self.unit_forced {
            "--unit".to_string()
        } else {
            format!("auto, first scan: range_max {} m", self.range_max)
        };
        format!(
            "ROS 2 bag, topic {}, {} ranges ({why})",
            self.topic.name, self.unit
        )
    }

    /// Where and why the bag is cut, once its scans ended at a cut.
    pub fn cut(&self) -> Option<String> {
        self.cut.clone()
    }

    /// The stderr line on the scans read: how many, and the invalid
    /// beams by reason.
    pub fn report(&self) -> String {
        format!(
            "{}: {} scans of {}: {} invalid beams ({})",
            self.path.display(),
            self.index,
            self.topic.name,
            self.counts.total(),
            self.counts
        )
    }

    /// The error for a bag whose topic holds no scan.
    pub fn no_scans(&self) -> anyhow::Error {
        let cut = self.cut().map(|c| format!(" ({c})")).unwrap_or_default();
        anyhow!(
            "{} holds no scans on {}{cut}",
            self.path.display(),
            self.topic.name
        )
    }

    /// The next message of the topic, across the bag's files in order.
    fn next_message(&mut self) -> Option<Result<mcap::Message<'static>>> {
        loop {
            if self.cut.is_some() {
                return None;
            }
            let file = self.files.files.get(self.at)?.clone();
            let reader = match &mut self.reader {
                Some(r) => r,
                None => match open_file(&file) {
                    Ok(r) => self.reader.insert(mcap::io::MessageReader::new(r)),
                    Err(e) => return Some(Err(e)),
                },
            };
            match reader.next() {
                Some(Ok(m)) if m.channel.topic == self.topic.name => return Some(Ok(m)),
                Some(Ok(_)) => {}
                Some(Err(mcap::McapError::UnexpectedEof)) => {
                    self.cut = Some(format!(
                        "{}: the file ends inside a record (a cut recording); \
                         the {} complete scans before it are used",
                        file.display(),
                        self.index
                    ));
                }
                Some(Err(e)) => {
                    return Some(Err(anyhow!(e).context(format!(
                        "{}: after scan {} of {}",
                        file.display(),
                        self.index,
                        self.topic.name
                    ))))
                }
                None => {
                    self.reader = None;
                    self.at += 1;
                }
            }
        }
    }

    /// The message's LaserScan, or an error naming it.
    fn decode(&self, message: &mcap::Message<'_>) -> Result<LaserScan> {
        if message.channel.message_encoding != MESSAGE_ENCODING {
            bail!(
                "{}: scan {} of {}: message encoding {:?} is not supported (\"{MESSAGE_ENCODING}\" only)",
                self.path.display(),
                self.index,
                self.topic.name,
                message.channel.message_encoding
            );
        }
        laser_scan::decode(&message.data).with_context(|| self.where_is(message))
    }

    /// Where `message` is, for an error: the bag, the scan's index, the
    /// topic and the log time.
    fn where_is(&self, message: &mcap::Message<'_>) -> String {
        format!(
            "{}: scan {} of {} (log time {} ns)",
            self.path.display(),
            self.index,
            self.topic.name,
            message.log_time
        )
    }

    /// The scan of a decoded message (its frame, stamp and frame id).
    fn input_of(&mut self, scan: LaserScan, message: &mcap::Message<'_>) -> Result<BagScan> {
        let place = self.where_is(message);
        let frame = scan_frame::frame_of(&scan, self.unit, &mut self.counts).context(place)?;
        let input = BagScan {
            index: self.index,
            frame,
            stamp_ns: scan.header.stamp.as_nanos(),
            frame_id: scan.header.frame_id,
        };
        self.index += 1;
        Ok(input)
    }
}

impl Iterator for BagScans {
    type Item = Result<BagScan>;

    fn next(&mut self) -> Option<Result<BagScan>> {
        if let Some(first) = self.first.take() {
            return Some(first);
        }
        let message = match self.next_message()? {
            Ok(m) => m,
            Err(e) => return Some(Err(e)),
        };
        Some(
            self.decode(&message)
                .and_then(|scan| self.input_of(scan, &message)),
        )
    }
}
