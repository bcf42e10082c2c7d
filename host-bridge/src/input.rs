//! The scans of a file, whatever it is: a CARMEN log (gzip or plain) or a
//! capture recorded by `host-bridge scan`, streamed one scan at a time
//! ([`ScanFile`]). Every command that reads scans (`extract`, `plot`,
//! `verify --replay`, `simulate --replay`) goes through here, so they all
//! read both kinds, keep every complete scan of a cut file (saying where
//! and why it is cut) and explain a file that holds no scans.
//!
//! Every input is read exactly once, in one pass, from its start: a file,
//! a pipe, a FIFO, or standard input (the path `-`). What it is (a capture,
//! gzip or plain text) is told from its first bytes; a log's unit
//! (`--unit auto`) and its defaults per data are decided on the first
//! [`crate::carmen::HEAD_TEXT`] bytes of its text, kept in memory, and the text
//! then streams on from the same reader ([`LogText`]). Memory does
//! not depend on the file's length: the head, then one line or one record
//! at a time, buffers of [`crate::carmen::READ_BUFFER`] bytes.
//!
//! Damage that does not stop the reading is warned about on stderr with
//! its line or byte offset (at most [`crate::warning::Limited::SHOWN`]
//! lines per input, the rest counted): a log's first-line byte order mark
//! and record keywords one edit from `FLASER`
//! ([`lms_core::carmen::Note`]), a capture's time running backwards and
//! duplicated records ([`CaptureScans`]). A damaged gzip stream (its
//! checksum fails) is an error, unless [`ReadOptions::keep_damaged`].

use std::cell::RefCell;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use anyhow::{bail, Context, Result};
use lms_core::carmen::{Reader, UnitVote, Verdict};
use lms_core::{Frame, Unit};

use crate::capture::{self, CaptureReader, CaptureScans, MAGIC};
use crate::carmen::{LogText, READ_BUFFER};
use crate::options::UnitArg;
use crate::ros2::bag_in::{self, BagScans};
use crate::ros2::messages::Stamp;
use crate::ros2::rosbag2_out::stamp_for;
pub use crate::warning::warn;
use crate::warning::Limited;

/// The path that names standard input.
pub const STDIN: &str = "-";

/// The MCAP magic (a ROS 2 bag file).
pub const MCAP_MAGIC: [u8; 8] = *b"\x89MCAP0\r\n";

/// How to read an input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadOptions {
    /// The log's unit (`auto`: decided on its head).
    pub unit: UnitArg,
    /// Keep the scans of a gzip log whose checksum fails (they may carry
    /// altered ranges), with a warning, instead of failing.
    pub keep_damaged: bool,
}

/// One frame to extract: the pipeline's input, with what the record
/// reports of its source.
#[derive(Clone, Debug)]
pub struct InputFrame {
    /// Index reported in the record.
    pub index: usize,
    /// The frame.
    pub frame: Frame,
    /// Pose to report, if the source has one.
    pub pose: Option<[f64; 3]>,
}

/// One scan of a file.
#[derive(Clone, Debug)]
pub struct InputScan {
    /// Index among the scans of the file (`FLASER` lines or `B0` records), from 0.
    pub index: usize,
    /// The frame in metres, invalid beams with their reason.
    pub frame: Frame,
    /// The laser pose of a log's line (m, m, rad).
    pub pose: Option<[f64; 3]>,
    /// The line of a log (1-based).
    pub line: Option<usize>,
    /// The time of a capture's record (µs from its start).
    pub time_us: Option<u64>,
    /// The stamp of a ROS 2 message's header (ns since the epoch).
    pub stamp_ns: Option<i64>,
    /// The frame id of a ROS 2 message's header.
    pub frame_id: Option<String>,
}

impl InputScan {
    /// Its stamp for the ROS 2 outputs and the live view: its own, a
    /// capture's time, or its index at the scan period ([`stamp_for`]).
    pub fn stamp(&self) -> Stamp {
        stamp_for(
            self.index,
            &self.frame,
            self.stamp_ns,
            self.time_us,
            self.frame_id.as_deref(),
        )
    }

    /// The pipeline's input of this scan.
    pub fn into_frame(self) -> InputFrame {
        InputFrame {
            index: self.index,
            frame: self.frame,
            pose: self.pose,
        }
    }
}

/// What the file is.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    /// A CARMEN log read in `unit`; `vote` is the decision when the unit
    /// was `auto` (`None`: forced).
    Log {
        /// The unit the error codes are read in.
        unit: Unit,
        /// How `auto` decided (`None` if the unit was given).
        vote: Option<UnitVote>,
    },
    /// A capture (`LMSCAP01`).
    Capture,
    /// A ROS 2 bag (MCAP storage): one topic's LaserScans, their ranges
    /// quantised in `unit` ([`crate::ros2::bag_in`]).
    Bag {
        /// The unit the ranges are quantised in.
        unit: Unit,
    },
}

/// A log's scans, streamed from its text.
type LogReader = Reader<Box<dyn BufRead>>;

enum Inner {
    Log(LogReader),
    Capture(CaptureScans<Box<dyn BufRead>>),
    Bag(Box<BagScans>),
}

/// What a log keeps beside its reader: the head its decisions were made
/// on, and the damage of its gzip stream, once found.
struct LogExtra {
    head: Rc<[u8]>,
    damage: Rc<RefCell<Option<String>>>,
}

/// The scans of a log or a capture, streamed (see the [module docs](self)).
/// The iterator ends after the first error; a file without any scan gives
/// an error that says what the file seems to be.
pub struct ScanFile {
    path: PathBuf,
    kind: Kind,
    inner: Inner,
    done: bool,
    read: usize,
    log: Option<LogExtra>,
    warnings: Limited,
}

impl std::fmt::Debug for ScanFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScanFile")
            .field("path", &self.path)
            .field("kind", &self.kind)
            .field("read", &self.read)
            .finish()
    }
}

/// The input at `path` (`-`: standard input), opened once, and its first
/// bytes (up to 8, fewer only if the input is shorter), which the reader
/// hands out again first.
fn open_source(path: &Path) -> Result<(Box<dyn BufRead>, Vec<u8>)> {
    let mut raw: Box<dyn Read> = if path.as_os_str() == STDIN {
        // Standard input can be read once per run: a second reader would
        // find it used up and call it empty.
        static TAKEN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        if TAKEN.swap(true, std::sync::atomic::Ordering::SeqCst) {
            bail!(
                "standard input is read already: this command reads its input more than once \
                 (simulate --replay plays it in a loop); give the path of a file"
            );
        }
        Box::new(std::io::stdin())
    } else {
        let meta =
            std::fs::metadata(path).with_context(|| format!("cannot open {}", path.display()))?;
        if meta.is_dir() {
            bail!("{} is a directory, not a log or a capture", path.display());
        }
        Box::new(File::open(path).with_context(|| format!("cannot open {}", path.display()))?)
    };
    let mut first = [0u8; 8];
    let mut got = 0;
    while got < first.len() {
        match raw.read(&mut first[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        }
    }
    let first = first[..got].to_vec();
    let all = std::io::Cursor::new(first.clone()).chain(raw);
    Ok((Box::new(BufReader::with_capacity(READ_BUFFER, all)), first))
}

/// `true` if `a` and `b` name the same file (same device and inode: hard
/// links and symlinks included; `-` is standard input). A name that does not
/// exist is no file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let meta = |p: &Path| {
        if p.as_os_str() == STDIN {
            std::fs::metadata("/dev/stdin")
        } else {
            std::fs::metadata(p)
        }
    };
    match (meta(a), meta(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// How messages name `path`.
fn name_of(path: &Path) -> String {
    if path.as_os_str() == STDIN {
        "standard input".to_string()
    } else {
        path.display().to_string()
    }
}

/// Open `path` (`-`: standard input) as a log or a capture (told by the
/// capture magic), reading it once. `unit` is the log's unit (`auto`:
/// decided on its head); it does not apply to captures, whose telegrams
/// carry their units.
pub fn open(path: &Path, unit: UnitArg) -> Result<ScanFile> {
    open_with(
        path,
        ReadOptions {
            unit,
            keep_damaged: false,
        },
    )
}

/// [`open`] with every option.
pub fn open_with(path: &Path, options: ReadOptions) -> Result<ScanFile> {
    if bag_in::files::is_folder(path) {
        return open_bag(path, options, None);
    }
    let (input, first) = open_source(path)?;
    let name = name_of(path);
    if first.starts_with(&MCAP_MAGIC) {
        return open_bag(path, options, None);
    }
    if first.is_empty() {
        bail!("{name} is empty: no scans (a recording that never started?)");
    }
    // What the input is, told by its first bytes.
    let (kind, inner, log) = if first.starts_with(b"LMSCAP") {
        if first[..] != MAGIC[..] {
            bail!(
                "{name}: capture format {:?} is not supported (this tool reads {:?})",
                String::from_utf8_lossy(&first),
                String::from_utf8_lossy(&MAGIC)
            );
        }
        let reader = CaptureReader::new(input).with_context(|| name.clone())?;
        let scans = CaptureScans::new(reader, path);
        (Kind::Capture, Inner::Capture(scans), None)
    } else {
        let (kind, reader, extra) = open_log(input, &name, options)?;
        (kind, Inner::Log(reader), Some(extra))
    };
    Ok(ScanFile {
        path: path.to_owned(),
        kind,
        inner,
        done: false,
        read: 0,
        log,
        warnings: Limited::default(),
    })
}

/// [`open_with`] reading `topic` of a ROS 2 bag (`None`: the bag's only
/// LaserScan topic); a topic for an input that is not a bag is an error.
pub fn open_topic(path: &Path, options: ReadOptions, topic: Option<&str>) -> Result<ScanFile> {
    match topic {
        None => open_with(path, options),
        Some(_) if bag_in::is_bag_path(path) => open_bag(path, options, topic),
        Some(t) => bail!(
            "--topic {t}: {} is not a ROS 2 bag (an MCAP file or a rosbag2 folder)",
            name_of(path)
        ),
    }
}

/// A ROS 2 bag, by its path (the summary of an MCAP file is read from
/// its end): not from standard input.
fn open_bag(path: &Path, options: ReadOptions, topic: Option<&str>) -> Result<ScanFile> {
    if path.as_os_str() == STDIN {
        bail!("a ROS 2 bag is read from its file, not from standard input: give its path");
    }
    let bag = BagScans::open(path, options.unit.unit(), topic)?;
    Ok(ScanFile {
        path: path.to_owned(),
        kind: Kind::Bag { unit: bag.unit() },
        inner: Inner::Bag(Box::new(bag)),
        done: false,
        read: 0,
        log: None,
        warnings: Limited::default(),
    })
}

/// A log's text (gzip or plain), its unit decided on its head.
fn open_log(
    input: Box<dyn BufRead>,
    name: &str,
    options: ReadOptions,
) -> Result<(Kind, LogReader, LogExtra)> {
    let text = LogText::open(input, options.keep_damaged)
        .with_context(|| format!("cannot read {name}"))?;
    // Damage in the head fails before any scan is given out.
    if let Some(why) = text.damage_handle().borrow().as_ref() {
        if !options.keep_damaged {
            bail!(
                "{name}: {why}: its scans may carry altered ranges \
                 (give --keep-damaged to keep them anyway)"
            );
        }
    }
    let (unit, vote) = match options.unit.unit() {
        Some(u) => (u, None),
        None => {
            let vote =
                lms_core::carmen::decide(text.head()).with_context(|| format!("in {name}"))?;
            if vote.verdict() == Verdict::Ambiguous {
                warn(&format!("{name}: unit {vote}"));
            }
            (vote.unit(), Some(vote))
        }
    };
    let extra = LogExtra {
        head: text.head_shared(),
        damage: text.damage_handle(),
    };
    Ok((
        Kind::Log { unit, vote },
        Reader::new(text.text, unit),
        extra,
    ))
}

impl ScanFile {
    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What it is.
    pub fn kind(&self) -> &Kind {
        &self.kind
    }

    /// Scans read so far.
    pub fn read(&self) -> usize {
        self.read
    }

    /// The file's kind for a summary line, e.g. `CARMEN log, mm ranges`.
    pub fn describe(&self) -> String {
        match &self.kind {
            Kind::Log { unit, vote: None } => format!("CARMEN log, {unit} ranges (--unit)"),
            Kind::Log {
                unit,
                vote: Some(v),
            } => format!(
                "CARMEN log, {unit} ranges ({} of {} values with 3 decimals)",
                v.three_decimal_ranges(),
                v.ranges()
            ),
            Kind::Capture => "capture".to_string(),
            Kind::Bag { .. } => match &self.inner {
                Inner::Bag(b) => b.describe(),
                _ => "ROS 2 bag".to_string(),
            },
        }
    }

    /// How messages name the input (`standard input` for `-`).
    pub fn name(&self) -> String {
        name_of(&self.path)
    }

    /// The scans of a log's head, the text its unit was decided on (every
    /// scan of a log shorter than [`crate::carmen::HEAD_TEXT`]), read again
    /// from memory in the log's unit: for surveys of the data before the
    /// scans stream. `None` for a capture.
    pub fn head_scans(&self) -> Option<Reader<&[u8]>> {
        let Kind::Log { unit, .. } = self.kind else {
            return None;
        };
        self.log.as_ref().map(|l| Reader::new(&l.head[..], unit))
    }

    /// The frames the defaults per data are surveyed on, and their unit:
    /// a log's head ([`ScanFile::head_scans`]), a bag's scans read once
    /// more from its files, each up to its first damaged scan. `None` for
    /// a capture.
    pub fn survey_frames(&self) -> Option<(Unit, Box<dyn Iterator<Item = Frame> + '_>)> {
        match (&self.kind, &self.inner) {
            (Kind::Bag { unit }, Inner::Bag(bag)) => {
                let again = bag.reopen().ok()?;
                Some((
                    *unit,
                    Box::new(again.map_while(Result::ok).map(|s| s.frame)),
                ))
            }
            (Kind::Log { unit, .. }, _) => {
                let scans = self.head_scans()?;
                Some((
                    *unit,
                    Box::new(scans.map_while(Result::ok).map(|s| s.frame)),
                ))
            }
            _ => None,
        }
    }

    /// Why the log's gzip stream is damaged, once found.
    fn damage(&self) -> Option<String> {
        self.log.as_ref().and_then(|l| l.damage.borrow().clone())
    }

    /// Where and why the file is cut, once the scans ended at a cut (or,
    /// with [`ReadOptions::keep_damaged`], at a damaged gzip stream).
    pub fn cut(&self) -> Option<String> {
        match &self.inner {
            Inner::Log(r) => r.cut().map(|c| match self.damage() {
                Some(why) => format!(
                    "{}: {why} at line {}; the {} scans before it are kept (--keep-damaged), \
                     but may carry altered ranges",
                    self.name(),
                    c.line,
                    r.scans()
                ),
                None => format!(
                    "{}: {c}; the {} complete scans before it are used",
                    self.name(),
                    r.scans()
                ),
            }),
            Inner::Capture(c) => c.cut_message(),
            Inner::Bag(b) => b.cut(),
        }
    }

    /// Warn on stderr if the file was cut ([`ScanFile::cut`]); for a bag,
    /// also say how many beams were invalid and why.
    pub fn warn_if_cut(&self) {
        if let Some(m) = self.cut() {
            warn(&m);
        }
        if let Inner::Bag(b) = &self.inner {
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "host-bridge: {}", b.report());
        }
    }

    /// Why a log's error mentions its unit: the decision, and the advice.
    fn unit_hint(&self) -> String {
        match &self.kind {
            Kind::Log {
                vote: Some(v),
                unit,
            } => format!(
                " (the log is read in {unit}: {v}; give --unit {} if that is wrong)",
                if *unit == Unit::Millimetre {
                    "cm"
                } else {
                    "mm"
                }
            ),
            _ => String::new(),
        }
    }

    fn next_log(&mut self) -> Option<Result<InputScan>> {
        let Inner::Log(reader) = &mut self.inner else {
            return None;
        };
        match reader.next()? {
            Ok(s) => Some(Ok(InputScan {
                index: s.index,
                frame: s.frame,
                pose: Some(s.meta.pose),
                line: Some(s.line),
                time_us: None,
                stamp_ns: None,
                frame_id: None,
            })),
            Err(e) => {
                let scans = reader.scans();
                let lines = reader.lines();
                if let Some(why) = self.damage() {
                    return Some(Err(anyhow::anyhow!(
                        "{}: {why} after line {lines}: the {scans} scans read before it may \
                         carry altered ranges (give --keep-damaged to keep them anyway)",
                        self.name()
                    )));
                }
                let hint = if e.to_string().contains("above the largest LMS value") {
                    self.unit_hint()
                } else {
                    String::new()
                };
                Some(Err(
                    anyhow::Error::new(e).context(format!("in {}{hint}", self.name()))
                ))
            }
        }
    }

    /// Warn about the damage the reader noted (at most
    /// [`Limited::SHOWN`] lines, the rest counted); at the `end`, say how
    /// many were not shown.
    fn warn_notes(&mut self, end: bool) {
        let name = self.name();
        match &mut self.inner {
            Inner::Log(r) => {
                while let Some(note) = r.next_note() {
                    self.warnings.warn(&format!("{name}: {note}"));
                }
                if end {
                    self.warnings.hide(r.notes_dropped());
                }
            }
            Inner::Capture(c) => {
                while let Some(note) = c.next_note() {
                    self.warnings.warn(&format!("{name}: {note}"));
                }
                if end {
                    self.warnings.hide(c.notes_dropped());
                }
            }
            Inner::Bag(_) => {}
        }
        if end {
            self.warnings.finish(&name);
        }
    }

    /// Warnings given about the input so far (damage noted on the way).
    pub fn warnings(&self) -> usize {
        self.warnings.count()
    }

    fn next_capture(&mut self) -> Option<Result<InputScan>> {
        let Inner::Capture(scans) = &mut self.inner else {
            return None;
        };
        let scan = match scans.next()? {
            Ok(s) => s,
            Err(e) => return Some(Err(e)),
        };
        let path = &self.path;
        Some(
            capture::frame_of(&scan)
                .map(|frame| InputScan {
                    index: scan.index,
                    frame,
                    pose: None,
                    line: None,
                    time_us: Some(scan.time_us),
                    stamp_ns: None,
                    frame_id: None,
                })
                .map_err(|e| anyhow::anyhow!("{}: scan {}: {e}", path.display(), scan.index)),
        )
    }

    /// The error for a file that ended without a single scan.
    fn no_scans(&self) -> anyhow::Error {
        let cut = self.cut().map(|c| format!(" ({c})")).unwrap_or_default();
        match &self.inner {
            Inner::Log(r) => anyhow::anyhow!(
                "{} holds no scans: none of its {} lines is a FLASER line{cut} \
                 (not a CARMEN log, nor a capture: those start with \"LMSCAP01\")",
                self.path.display(),
                r.lines()
            ),
            Inner::Capture(c) => anyhow::anyhow!(
                "{} holds no scans: a capture with {} records, none a B0 scan{cut}",
                self.path.display(),
                c.records()
            ),
            Inner::Bag(b) => b.no_scans(),
        }
    }
}

impl Iterator for ScanFile {
    type Item = Result<InputScan>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let next = match self.inner {
            Inner::Log(_) => self.next_log(),
            Inner::Capture(_) => self.next_capture(),
            Inner::Bag(ref mut b) => b.next().map(|r| {
                r.map(|s| InputScan {
                    index: s.index,
                    frame: s.frame,
                    pose: None,
                    line: None,
                    time_us: None,
                    stamp_ns: Some(s.stamp_ns),
                    frame_id: Some(s.frame_id),
                })
            }),
        };
        let next = match next {
            None if self.read == 0 => Some(Err(self.no_scans())),
            other => other,
        };
        match &next {
            Some(Ok(_)) => self.read += 1,
            _ => self.done = true,
        }
        self.warn_notes(self.done);
        next
    }
}
