//! The streaming side of the CARMEN reader (feature `std`): [`Reader`] over
//! any [`BufRead`], frame by frame, and the per-file unit decision
//! [`decide_unit`]. Memory does not grow with the log: one line and one
//! [`Frame`] at a time.

use std::fmt;
use std::io::BufRead;

use super::{is_flaser, Flaser, Meta, UnitVote};
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
            ReadError::NotUtf8 { line } | ReadError::Line { line, .. } => Some(*line),
        }
    }
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "reading the log: {e}"),
            ReadError::NotUtf8 { line } => write!(f, "line {line}: FLASER line is not valid UTF-8"),
            ReadError::Line { line, message } => write!(f, "line {line}: {message}"),
        }
    }
}

impl std::error::Error for ReadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ReadError::Io(e) => Some(e),
            _ => None,
        }
    }
}

/// The lines of a log, one buffer reused.
struct Lines<R> {
    input: R,
    buf: Vec<u8>,
    /// Number of the line in `buf` (1-based; 0 before the first).
    number: usize,
}

impl<R: BufRead> Lines<R> {
    fn new(input: R) -> Self {
        Lines {
            input,
            buf: Vec::new(),
            number: 0,
        }
    }

    /// The next `FLASER` line and its number, or `None` at the end.
    fn next_flaser(&mut self) -> Result<Option<(usize, &str)>, ReadError> {
        loop {
            self.buf.clear();
            if self
                .input
                .read_until(b'\n', &mut self.buf)
                .map_err(ReadError::Io)?
                == 0
            {
                return Ok(None);
            }
            self.number += 1;
            if is_flaser(&self.buf) {
                let line = self.number;
                return std::str::from_utf8(&self.buf)
                    .map(|text| Some((line, text)))
                    .map_err(|_| ReadError::NotUtf8 { line });
            }
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

/// The unit of a whole log (a first pass over it): [`Unit::Millimetre`]
/// if any range of any `FLASER` line shows three or more decimals, else
/// [`Unit::Centimetre`] (see the [module docs](super)). Checks the syntax
/// of every `FLASER` line on the way, so that a log's syntax errors are
/// reported before the unit's range errors of [`Reader`].
pub fn decide_unit<R: BufRead>(input: R) -> Result<Unit, ReadError> {
    let mut lines = Lines::new(input);
    let mut vote = UnitVote::default();
    while let Some((line, text)) = lines.next_flaser()? {
        vote.observe(&Flaser::parse(text).map_err(|e| at_line(line, e))?);
    }
    Ok(vote.unit())
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

    /// The next scan into `frame` (no allocation): its index among the
    /// `FLASER` lines, its line number and the line itself (pose, time and
    /// host name), or `None` at the end of the log.
    pub fn read_into(
        &mut self,
        frame: &mut Frame,
    ) -> Result<Option<(usize, usize, Flaser<'_>)>, ReadError> {
        let Some((line, text)) = self.lines.next_flaser()? else {
            return Ok(None);
        };
        let flaser = Flaser::parse(text).map_err(|e| at_line(line, e))?;
        flaser
            .fill(self.unit, frame)
            .map_err(|e| at_line(line, e))?;
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
