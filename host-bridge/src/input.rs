//! The scans of a file, whatever it is: a CARMEN log (gzip or plain) or a
//! capture recorded by `host-bridge scan`, streamed one scan at a time
//! ([`ScanFile`]). Every command that reads scans (`extract`, `plot`,
//! `verify --replay`, `simulate --replay`) goes through here, so they all
//! read both kinds, keep every complete scan of a cut file (saying where
//! and why it is cut) and explain a file that holds no scans.
//!
//! Memory does not depend on the file's length: one line or one record at
//! a time, buffers of [`crate::carmen::READ_BUFFER`] bytes. A log's unit
//! (`--unit auto`) is decided by a first pass over the file
//! ([`crate::carmen::decide`]); a forced unit needs none.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lms_core::carmen::{Reader, UnitVote, Verdict};
use lms_core::{Frame, Unit};

use crate::capture::{self, CaptureScans, MAGIC};
use crate::carmen;
use crate::options::UnitArg;
pub use crate::warning::warn;

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
}

enum Inner {
    Log(Reader<Box<dyn BufRead>>),
    Capture(CaptureScans<BufReader<File>>),
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

/// The first bytes of a file, for telling what it is.
fn head(path: &Path) -> Result<Vec<u8>> {
    let meta =
        std::fs::metadata(path).with_context(|| format!("cannot open {}", path.display()))?;
    if meta.is_dir() {
        bail!("{} is a directory, not a log or a capture", path.display());
    }
    let mut file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut buf = [0u8; 8];
    let mut got = 0;
    while got < buf.len() {
        match file.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        }
    }
    Ok(buf[..got].to_vec())
}

/// Open `path` as a log or a capture (told by the capture magic).
/// `unit` is the log's unit (`auto`: decided per file); it does not apply
/// to captures, whose telegrams carry their units.
pub fn open(path: &Path, unit: UnitArg) -> Result<ScanFile> {
    let first = head(path)?;
    if first.is_empty() {
        bail!(
            "{} is empty: no scans (a recording that never started?)",
            path.display()
        );
    }
    if first.starts_with(b"LMSCAP") {
        if first[..] != MAGIC[..] {
            bail!(
                "{}: capture format {:?} is not supported (this tool reads {:?})",
                path.display(),
                String::from_utf8_lossy(&first),
                String::from_utf8_lossy(&MAGIC)
            );
        }
        return Ok(ScanFile {
            path: path.to_owned(),
            kind: Kind::Capture,
            inner: Inner::Capture(capture::read_values(path)?),
            done: false,
            read: 0,
        });
    }
    let (unit, vote) = match unit.unit() {
        Some(u) => (u, None),
        None => {
            let vote = carmen::decide(path)?;
            if vote.verdict() == Verdict::Ambiguous {
                warn(&format!("{}: unit {vote}", path.display()));
            }
            (vote.unit(), Some(vote))
        }
    };
    Ok(ScanFile {
        path: path.to_owned(),
        kind: Kind::Log { unit, vote },
        inner: Inner::Log(carmen::stream(path, unit)?),
        done: false,
        read: 0,
    })
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
        }
    }

    /// Where and why the file is cut, once the scans ended at a cut.
    pub fn cut(&self) -> Option<String> {
        match &self.inner {
            Inner::Log(r) => r.cut().map(|c| {
                format!(
                    "{}: {c}; the {} complete scans before it are used",
                    self.path.display(),
                    r.scans()
                )
            }),
            Inner::Capture(c) => c.cut_message(),
        }
    }

    /// Warn on stderr if the file was cut ([`ScanFile::cut`]).
    pub fn warn_if_cut(&self) {
        if let Some(m) = self.cut() {
            warn(&m);
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
            })),
            Err(e) => {
                let hint = if e.to_string().contains("above the largest LMS value") {
                    self.unit_hint()
                } else {
                    String::new()
                };
                Some(Err(
                    anyhow::Error::new(e).context(format!("in {}{hint}", self.path.display()))
                ))
            }
        }
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
        };
        let next = match next {
            None if self.read == 0 => Some(Err(self.no_scans())),
            other => other,
        };
        match &next {
            Some(Ok(_)) => self.read += 1,
            _ => self.done = true,
        }
        next
    }
}
