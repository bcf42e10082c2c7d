//! The streaming side of the CARMEN reader (feature `std`): [`Reader`] over
//! any [`BufRead`], frame by frame, and the per-file unit decision
//! [`decide_unit`] / [`decide`]. Memory does not grow with the log: one
//! line (at most [`MAX_LINE_LEN`] bytes) and one [`Frame`] at a time.
//!
//! # Cut logs
//!
//! A log cut short (a recorder killed, a truncated download) keeps every
//! complete scan: a last line without its newline that is not a valid
//! `FLASER` line, or input that ends early or is corrupt (a cut gzip
//! stream: `UnexpectedEof`, `InvalidData`, `InvalidInput`), ends the scans
//! without an error, and [`Reader::cut`] says where and why. A bad line
//! *inside* the log is still an error.
//!
//! # Notes
//!
//! Lines read past that look damaged are not errors, but the reader keeps
//! a [`Note`] of them for the caller to warn about ([`Reader::next_note`]):
//! a first line starting with a UTF-8 byte order mark (read through: the
//! line is read without it) and a record keyword one edit from `FLASER`
//! (`FLASEQ`, `FLASR`, `FFLASER`: a damaged scan line, skipped, so every
//! later scan's index is one lower than in the intact log). At most
//! [`MAX_PENDING_NOTES`] wait to be taken; the rest are counted
//! ([`Reader::notes_dropped`]).

use std::collections::VecDeque;
use std::fmt;
use std::io::BufRead;

use super::{is_flaser, Excerpt, Flaser, Meta, UnitVote};

/// Notes kept until the caller takes them ([`Reader::next_note`]).
pub const MAX_PENDING_NOTES: usize = 64;

/// The UTF-8 byte order mark.
const BOM: [u8; 3] = [0xEF, 0xBB, 0xBF];

/// Record keywords of CARMEN logs that are one edit from `FLASER` and
/// are not damaged `FLASER`s (the rear laser).
const KEYWORDS_NEAR_FLASER: [&[u8]; 1] = [b"RLASER"];

/// A line read past that looks damaged (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Note {
    /// The first line starts with a UTF-8 byte order mark; it is read
    /// without it.
    ByteOrderMark,
    /// A line's first word is one edit from `FLASER`; the line is skipped.
    NearFlaser {
        /// Line number (1-based).
        line: usize,
        /// The word as [`Excerpt`] quotes it.
        word: String,
    },
}

impl Note {
    /// The line the note is about.
    pub fn line(&self) -> usize {
        match self {
            Note::ByteOrderMark => 1,
            Note::NearFlaser { line, .. } => *line,
        }
    }
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Note::ByteOrderMark => f.write_str(
                "line 1 starts with a UTF-8 byte order mark (EF BB BF): read without it",
            ),
            Note::NearFlaser { line, word } => write!(
                f,
                "line {line}: the record keyword {word} is one edit from FLASER: a damaged \
                 scan line? It is skipped, so every later scan's index is one lower than \
                 in the intact log"
            ),
        }
    }
}

/// `true` if `word` is one insertion, deletion or substitution from
/// `FLASER` (and not another keyword of the format).
pub fn near_flaser(word: &[u8]) -> bool {
    const TARGET: &[u8] = b"FLASER";
    if KEYWORDS_NEAR_FLASER.contains(&word) {
        return false;
    }
    let (long, short) = if word.len() >= TARGET.len() {
        (word, TARGET)
    } else {
        (TARGET, word)
    };
    if long.len() - short.len() > 1 {
        return false;
    }
    // The first difference; what follows it must match after one edit.
    let Some(i) = long.iter().zip(short).position(|(a, b)| a != b) else {
        // Equal, or one longer by a last byte.
        return long.len() != short.len();
    };
    if long.len() == short.len() {
        long[i + 1..] == short[i + 1..]
    } else {
        long[i + 1..] == short[i..]
    }
}

/// Longest line kept (bytes): a 401-beam `FLASER` line with 12-character
/// values is about 5 KiB. Longer `FLASER` lines are errors, longer other
/// lines are skipped, so that no input can make the reader hold more.
pub const MAX_LINE_LEN: usize = 64 * 1024;
use crate::{Frame, Unit};

/// One `FLASER` scan of a log.
#[derive(Clone, Debug)]
pub struct Scan {
    /// Index among the `FLASER` lines of the log (0-based).
    pub index: usize,
    /// Line number in the log (1-based).
    pub line: usize,
    /// The frame, invalid beams marked with their reason.
    pub frame: Frame,
    /// Pose and time stamps.
    pub meta: Meta,
    /// The host name field.
    pub hostname: String,
}

/// Why a log could not be read; line numbers are 1-based.
#[derive(Debug)]
#[non_exhaustive]
pub enum ReadError {
    /// Reading (or decompressing) failed.
    Io(std::io::Error),
    /// A `FLASER` line is not valid UTF-8.
    NotUtf8 {
        /// Line number.
        line: usize,
    },
    /// A `FLASER` line is longer than [`MAX_LINE_LEN`] bytes.
    LineTooLong {
        /// Line number.
        line: usize,
    },
    /// A `FLASER` line is malformed (the [`LineError`](super::LineError)'s text).
    Line {
        /// Line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
}

impl ReadError {
    /// The line the error is in, if it is about one.
    pub fn line(&self) -> Option<usize> {
        match self {
            ReadError::Io(_) => None,
            ReadError::NotUtf8 { line }
            | ReadError::LineTooLong { line }
            | ReadError::Line { line, .. } => Some(*line),
        }
    }
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "reading the log: {e}"),
            ReadError::NotUtf8 { line } => write!(f, "line {line}: FLASER line is not valid UTF-8"),
            ReadError::LineTooLong { line } => write!(
                f,
                "line {line}: FLASER line longer than {MAX_LINE_LEN} bytes (not a CARMEN log?)"
            ),
            ReadError::Line { line, message } => write!(f, "line {line}: {message}"),
        }
    }
}

/// The I/O error's text is part of the message already: no `source`, or
/// `{:#}` would print it twice.
impl std::error::Error for ReadError {}

/// Where and why a log ends early (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cut {
    /// The line the log is cut in (1-based): the first line not read.
    pub line: usize,
    /// Why.
    pub reason: String,
}

impl fmt::Display for Cut {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "the log is cut at line {}: {}", self.line, self.reason)
    }
}

/// The lines of a log, one buffer reused.
struct Lines<R> {
    input: R,
    buf: Vec<u8>,
    /// Number of the line in `buf` (1-based; 0 before the first).
    number: usize,
    /// The line in `buf` was longer than [`MAX_LINE_LEN`] (only its start kept).
    overlong: bool,
    /// The line in `buf` ended with a newline.
    terminated: bool,
    /// Set once the log turned out to be cut.
    cut: Option<Cut>,
    /// Notes not yet taken, and how many did not fit.
    notes: VecDeque<Note>,
    notes_dropped: usize,
}

/// `true` for the read errors that mean "the data stop here" (a cut or
/// corrupt gzip stream) rather than a failing device.
fn is_cut(e: &std::io::Error) -> bool {
    use std::io::ErrorKind::{InvalidData, InvalidInput, UnexpectedEof};
    matches!(e.kind(), UnexpectedEof | InvalidData | InvalidInput)
}

impl<R: BufRead> Lines<R> {
    fn new(input: R) -> Self {
        Lines {
            input,
            buf: Vec::new(),
            number: 0,
            overlong: false,
            terminated: false,
            cut: None,
            notes: VecDeque::new(),
            notes_dropped: 0,
        }
    }

    fn note(&mut self, note: Note) {
        if self.notes.len() < MAX_PENDING_NOTES {
            self.notes.push_back(note);
        } else {
            self.notes_dropped += 1;
        }
    }

    /// After reading line `self.number` into `buf`: drop a first line's
    /// byte order mark, note a keyword one edit from `FLASER`.
    fn look_at_line(&mut self) {
        if self.number == 1 && self.buf.starts_with(&BOM) {
            self.buf.drain(..BOM.len());
            self.note(Note::ByteOrderMark);
        }
    }

    /// Note the line in `buf` if its first word is one edit from `FLASER`.
    fn note_near_flaser(&mut self) {
        let Some(word) = self
            .buf
            .split(u8::is_ascii_whitespace)
            .find(|w| !w.is_empty())
        else {
            return;
        };
        if near_flaser(word) {
            let word = Excerpt(&String::from_utf8_lossy(word)).to_string();
            let line = self.number;
            self.note(Note::NearFlaser { line, word });
        }
    }

    /// Read the next line into `buf` (at most [`MAX_LINE_LEN`] bytes kept);
    /// `false` at the end.
    fn read_line(&mut self) -> std::io::Result<bool> {
        self.buf.clear();
        self.overlong = false;
        self.terminated = false;
        let mut any = false;
        loop {
            let avail = match self.input.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if avail.is_empty() {
                return Ok(any);
            }
            any = true;
            let (take, found) = match avail.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (avail.len(), false),
            };
            let room = MAX_LINE_LEN.saturating_sub(self.buf.len());
            if take > room {
                self.overlong = true;
            }
            self.buf.extend_from_slice(&avail[..take.min(room)]);
            self.input.consume(take);
            if found {
                self.terminated = true;
                return Ok(true);
            }
        }
    }

    /// The next `FLASER` line, parsed, and its number; `None` at the end
    /// or at a cut ([`Lines::cut`]).
    fn next_parsed(&mut self) -> Result<Option<(usize, Flaser<'_>)>, ReadError> {
        if self.cut.is_some() {
            return Ok(None);
        }
        loop {
            match self.read_line() {
                Ok(false) => return Ok(None),
                Ok(true) => {}
                Err(e) if is_cut(&e) => {
                    self.cut = Some(Cut {
                        line: self.number + 1,
                        reason: format!("the data end early or are corrupt ({e})"),
                    });
                    return Ok(None);
                }
                Err(e) => return Err(ReadError::Io(e)),
            }
            self.number += 1;
            self.look_at_line();
            if is_flaser(&self.buf) {
                break;
            }
            // A last line cut inside the word FLASER.
            let word = self.buf.trim_ascii();
            if !self.terminated && !word.is_empty() && b"FLASER".starts_with(word) {
                self.cut = Some(Cut {
                    line: self.number,
                    reason: "the last line has no newline and is incomplete".to_string(),
                });
                return Ok(None);
            }
            self.note_near_flaser();
        }
        let line = self.number;
        if self.overlong {
            return Err(ReadError::LineTooLong { line });
        }
        let last = !self.terminated;
        let parsed = match std::str::from_utf8(&self.buf) {
            Ok(text) => Flaser::parse(text).map_err(|e| at_line(line, e)),
            Err(_) => Err(ReadError::NotUtf8 { line }),
        };
        match parsed {
            Ok(f) => Ok(Some((line, f))),
            Err(e) if last => {
                self.cut = Some(Cut {
                    line,
                    reason: format!("the last line has no newline and is incomplete ({e})"),
                });
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }
}

/// A line error with its line number.
fn at_line(line: usize, e: super::LineError<'_>) -> ReadError {
    ReadError::Line {
        line,
        message: e.to_string(),
    }
}

/// The unit decision of a whole log (a first pass over it, see the
/// [module docs](super)): the counts, the verdict and the value that
/// decided. Checks the syntax of every `FLASER` line on the way, so that a
/// log's syntax errors are reported before the unit's range errors of
/// [`Reader`]. A cut log is decided on its complete lines.
pub fn decide<R: BufRead>(input: R) -> Result<UnitVote, ReadError> {
    let mut lines = Lines::new(input);
    let mut vote = UnitVote::default();
    while let Some((line, flaser)) = lines.next_parsed()? {
        vote.observe_at(line, &flaser);
    }
    Ok(vote)
}

/// The unit of a whole log: [`decide`]'s [`UnitVote::unit`].
pub fn decide_unit<R: BufRead>(input: R) -> Result<Unit, ReadError> {
    decide(input).map(|v| v.unit())
}

/// The `FLASER` scans of a log in one unit, frame by frame.
pub struct Reader<R> {
    lines: Lines<R>,
    unit: Unit,
    index: usize,
    done: bool,
}

impl<R: BufRead> Reader<R> {
    /// Read `input`, interpreting error codes in `unit` (from
    /// [`decide_unit`] on the same log, or forced).
    pub fn new(input: R, unit: Unit) -> Self {
        Reader {
            lines: Lines::new(input),
            unit,
            index: 0,
            done: false,
        }
    }

    /// The unit the error codes are read in.
    pub fn unit(&self) -> Unit {
        self.unit
    }

    /// Scans read so far.
    pub fn scans(&self) -> usize {
        self.index
    }

    /// Lines read so far.
    pub fn lines(&self) -> usize {
        self.lines.number
    }

    /// Where and why the log is cut, once the scans have ended at a cut.
    pub fn cut(&self) -> Option<&Cut> {
        self.lines.cut.as_ref()
    }

    /// The oldest [`Note`] not yet taken (see the [module docs](self)).
    pub fn next_note(&mut self) -> Option<Note> {
        self.lines.notes.pop_front()
    }

    /// Notes that did not fit the [`MAX_PENDING_NOTES`] waiting.
    pub fn notes_dropped(&self) -> usize {
        self.lines.notes_dropped
    }

    /// The next scan into `frame` (no allocation): its index among the
    /// `FLASER` lines, its line number and the line itself (pose, time and
    /// host name), or `None` at the end of the log (or at a cut).
    pub fn read_into(
        &mut self,
        frame: &mut Frame,
    ) -> Result<Option<(usize, usize, Flaser<'_>)>, ReadError> {
        let unit = self.unit;
        let Some((line, flaser)) = self.lines.next_parsed()? else {
            return Ok(None);
        };
        flaser.fill(unit, frame).map_err(|e| at_line(line, e))?;
        let index = self.index;
        self.index += 1;
        Ok(Some((index, line, flaser)))
    }

    fn next_scan(&mut self) -> Result<Option<Scan>, ReadError> {
        let mut frame = Frame::empty();
        let Some((index, line, flaser)) = self.read_into(&mut frame)? else {
            return Ok(None);
        };
        Ok(Some(Scan {
            index,
            line,
            meta: flaser.meta,
            hostname: flaser.hostname.to_string(),
            frame,
        }))
    }
}

impl<R: BufRead> Iterator for Reader<R> {
    type Item = Result<Scan, ReadError>;

    /// The next scan; after an error or the end, `None`.
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let next = self.next_scan().transpose();
        self.done = !matches!(next, Some(Ok(_)));
        next
    }
}
