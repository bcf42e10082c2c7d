//! CARMEN text logs (`FLASER` lines) → [`Frame`]s: the one reader of the
//! workspace (tools, tests, benches, examples and the fuzz seeds use it).
//!
//! One scan per line:
//!
//! ```text
//! FLASER n r_0 … r_{n-1} x y θ odom_x odom_y odom_θ ipc_timestamp hostname logger_timestamp
//! ```
//!
//! Every other line (`PARAM`, `ODOM`, `NEFF`, comments, blank) is skipped.
//!
//! # Layers
//!
//! * Always (no_std, no allocation, no panic): one line at a time.
//!   [`Flaser::parse`] checks a line's syntax and reads its pose and time
//!   fields; [`Flaser::fill`] writes its ranges into a caller's [`Frame`]
//!   in a given [`Unit`].
//! * With the `std` feature: `Reader`, a streaming iterator over any
//!   `std::io::BufRead` (one line in memory at a time, frame by frame),
//!   and `decide_unit`, the per-file unit decision (a pass over the text
//!   given: `host-bridge` gives a log's head, kept in memory).
//!   Opening files and gzip are the caller's (`host-bridge`'s `carmen`
//!   module; `test_support::open_log` for tests).
//!
//! # Beam counts and geometry
//!
//! | n   | field | first bearing | step | note |
//! |-----|-------|---------------|------|------|
//! | 181 | 180°  | −90°          | 1°   | LMS 180°/1° |
//! | 361 | 180°  | −90°          | 0.5° | LMS 180°/0.5° |
//! | 180 | 180°  | −90°          | 1°   | CARMEN drops the last beam |
//! | 360 | 180°  | −90°          | 0.5° | CARMEN drops the last beam |
//! | 101 | 100°  | −50°          | 1°   | LMS 100°/1° |
//! | 201 | 100°  | −50°          | 0.5° | LMS 100°/0.5° |
//! | 401 | 100°  | −50°          | 0.25°| LMS 100°/0.25° |
//!
//! The geometry is always [`Variant::geometry`], so frames read here have the
//! same bearing bits as frames decoded from telegrams.
//!
//! # Units and error codes (decision)
//!
//! A CARMEN log stores metres, but the LMS error codes survive as values in
//! the sensor's unit: in cm mode 8183 … 8191 cm read 81.83 … 81.91 m, in the
//! 32 m mm mode 32759 … 32767 mm read 32.759 … 32.767 m. The two modes
//! cannot be told apart from one value (cm logs hold genuine 32.8 m
//! readings), so the unit is decided **per file** ([`UnitVote`]) from the
//! share of range values with three or more decimals:
//!
//! * none: **cm** (two decimals at most: CSAIL, Intel, Belgioioso,
//!   Freiburg, Acapulco);
//! * at least a quarter ([`MM_SHARE_DENOMINATOR`]): **mm** (the Örebro log:
//!   CARMEN trims trailing zeros, so 90 % of its values show three);
//! * some, but fewer than a quarter: **ambiguous** — read as **cm** (most
//!   values say so; a stray three-decimal value must not turn a whole cm
//!   log into mm and its genuine 32.76 m readings into error codes), and the
//!   tools say so and suggest `--unit`.
//!
//! The decision names the value that decided (its line, beam and text).
//! [`Flaser::three_decimals`] is the per-line fact; callers may also force
//! a unit.
//!
//! Readings at or above the unit's [`Unit::first_error_code`] are invalid
//! with the reason [`Invalid::from_code_offset`]`(all_ones − value)`
//! ([`Unit::all_ones`]). A reading above `all_ones` cannot come from an LMS
//! in that mode and is an error ([`LineError::AboveAllOnes`]; a mm log
//! never has one, since a value above 32.767 m with three decimals would
//! make it inconsistent). Zero readings are invalid ([`Invalid::Zero`]);
//! negative, NaN or infinite readings are errors.

use core::fmt;

use crate::{Frame, Invalid, Unit, Variant};

/// The beam counts [`variant_for_beams`] accepts.
pub const SUPPORTED_BEAMS: [usize; 7] = [101, 180, 181, 201, 360, 361, 401];

/// Pose and time fields after the ranges: `FLASER n`, `n` ranges, these
/// nine (six pose values, IPC time, host name, logger time).
const TRAILING_FIELDS: usize = 9;

/// The geometry variant for a CARMEN beam count, if supported (180 and 360:
/// the 180° variants without their last beam).
pub fn variant_for_beams(n: usize) -> Option<Variant> {
    match n {
        180 => Some(Variant::Fov180Res100),
        360 => Some(Variant::Fov180Res50),
        other => Variant::from_beams(other),
    }
}

/// `true` if the line's first word is `FLASER` (the only lines read).
pub fn is_flaser(line: &[u8]) -> bool {
    line.split(u8::is_ascii_whitespace)
        .find(|w| !w.is_empty())
        .is_some_and(|w| w == b"FLASER")
}

/// Pose and time stamps that follow the ranges of a `FLASER` line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Meta {
    /// Laser pose `[x, y, θ]` (m, m, rad).
    pub pose: [f64; 3],
    /// Odometry pose `[x, y, θ]` (m, m, rad).
    pub odom: [f64; 3],
    /// IPC time stamp (s); unreliable in some logs.
    pub ipc_timestamp: f64,
    /// Logger time stamp (s); unreliable in some logs.
    pub logger_timestamp: f64,
}

/// Why a `FLASER` line cannot be read; the texts borrow from the line.
/// The line number is the caller's (the std `ReadError` adds it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum LineError<'a> {
    /// The line does not start with `FLASER`.
    NotFlaser,
    /// The beam count after `FLASER` is not a number.
    MalformedBeamCount(&'a str),
    /// The beam count is not one of [`SUPPORTED_BEAMS`].
    UnsupportedBeamCount(usize),
    /// The line has `after_n` values after `n` instead of `n + 9`.
    FieldCount {
        /// The beam count.
        n: usize,
        /// Values found after the beam count.
        after_n: usize,
    },
    /// A range is not a finite number.
    MalformedRange {
        /// Beam index.
        beam: usize,
        /// The text.
        text: &'a str,
    },
    /// A range is negative.
    NegativeRange {
        /// Beam index.
        beam: usize,
        /// The text.
        text: &'a str,
    },
    /// A pose or time field is not a number.
    MalformedField(&'a str),
    /// A range lies above the unit's [`Unit::all_ones`].
    AboveAllOnes {
        /// Beam index.
        beam: usize,
        /// The range (m).
        metres: f64,
        /// The unit the log is read in.
        unit: Unit,
    },
}

/// Characters of a bad token quoted in an error; a longer token is quoted
/// by its start and its length ([`Excerpt`]).
pub const EXCERPT_CHARS: usize = 16;

/// A token of a line as an error quotes it: whole (as a quoted string) up
/// to [`EXCERPT_CHARS`] characters, else its first [`EXCERPT_CHARS`]
/// characters, `…` and its length, e.g. `"1234567890123456…" (5000
/// characters)`, so that no input makes an error message long.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Excerpt<'a>(pub &'a str);

impl fmt::Display for Excerpt<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.char_indices().nth(EXCERPT_CHARS) {
            None => write!(f, "{:?}", self.0),
            Some((end, _)) => write!(
                f,
                "\"{}…\" ({} characters)",
                self.0[..end].escape_debug(),
                self.0.chars().count()
            ),
        }
    }
}

impl fmt::Display for LineError<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LineError::NotFlaser => f.write_str("not a FLASER line"),
            LineError::MalformedBeamCount(t) => {
                write!(f, "malformed beam count {} after FLASER", Excerpt(t))
            }
            LineError::UnsupportedBeamCount(n) => {
                write!(f, "unsupported beam count n = {n} (supported: {SUPPORTED_BEAMS:?})")
            }
            LineError::FieldCount { n, after_n } => write!(
                f,
                "FLASER n = {n} but the line has {after_n} values after n (expected {n} ranges + {TRAILING_FIELDS} pose/time fields = {})",
                n + TRAILING_FIELDS
            ),
            LineError::MalformedRange { beam, text } => {
                write!(f, "malformed number {} for range {beam}", Excerpt(text))
            }
            LineError::NegativeRange { beam, text } => match text.char_indices().nth(EXCERPT_CHARS) {
                None => write!(f, "negative range {text} for beam {beam}"),
                Some(_) => write!(f, "negative range {} for beam {beam}", Excerpt(text)),
            },
            LineError::MalformedField(t) => {
                write!(f, "malformed number {} in the pose/time fields", Excerpt(t))
            }
            LineError::AboveAllOnes { beam, metres, unit } => write!(
                f,
                "range {metres} m of beam {beam} is above the largest LMS value {} {unit} for a {unit} log",
                unit.all_ones()
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LineError<'_> {}

/// One `FLASER` line, its syntax checked: everything but the ranges'
/// interpretation, which needs the log's unit ([`Flaser::fill`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flaser<'a> {
    /// The geometry variant of the beam count.
    pub variant: Variant,
    /// Number of ranges (`n`).
    pub beams: usize,
    /// Pose and time stamps.
    pub meta: Meta,
    /// The host name field.
    pub hostname: &'a str,
    /// `true` if a range shows three or more decimals (a mm log).
    pub three_decimals: bool,
    /// How many ranges show three or more decimals.
    pub three_decimal_ranges: usize,
    /// The first range with three or more decimals: beam index and text.
    pub first_three_decimals: Option<(usize, &'a str)>,
    /// The whole line (the ranges are read again by [`Flaser::fill`]).
    line: &'a str,
}

impl<'a> Flaser<'a> {
    /// Check a `FLASER` line: beam count, field count, every range a finite
    /// number ≥ 0, the pose and time fields numbers.
    pub fn parse(line: &'a str) -> Result<Self, LineError<'a>> {
        let mut fields = line.split_ascii_whitespace();
        if fields.next() != Some("FLASER") {
            return Err(LineError::NotFlaser);
        }
        let n_text = fields.next().unwrap_or("");
        let n: usize = n_text
            .parse()
            .map_err(|_| LineError::MalformedBeamCount(n_text))?;
        let variant = variant_for_beams(n).ok_or(LineError::UnsupportedBeamCount(n))?;
        let after_n = fields.clone().count();
        if after_n != n + TRAILING_FIELDS {
            return Err(LineError::FieldCount { n, after_n });
        }
        let mut three_decimal_ranges = 0usize;
        let mut first_three_decimals = None;
        for (beam, text) in fields.by_ref().take(n).enumerate() {
            parse_range(beam, text)?;
            if decimals(text) >= 3 {
                three_decimal_ranges += 1;
                first_three_decimals = first_three_decimals.or(Some((beam, text)));
            }
        }
        // Nine fields are left (counted above).
        let mut num = || {
            let text = fields.next().unwrap_or("");
            text.parse::<f64>()
                .map_err(|_| LineError::MalformedField(text))
        };
        let pose = [num()?, num()?, num()?];
        let odom = [num()?, num()?, num()?];
        let ipc_timestamp = num()?;
        let hostname = fields.next().unwrap_or("");
        let text = fields.next().unwrap_or("");
        let logger_timestamp = text
            .parse::<f64>()
            .map_err(|_| LineError::MalformedField(text))?;
        Ok(Flaser {
            variant,
            beams: n,
            meta: Meta {
                pose,
                odom,
                ipc_timestamp,
                logger_timestamp,
            },
            hostname,
            three_decimals: three_decimal_ranges > 0,
            three_decimal_ranges,
            first_three_decimals,
            line,
        })
    }

    /// Write the ranges into `frame` (geometry of [`Flaser::variant`],
    /// [`Flaser::beams`] beams), read in `unit`: codes at or above
    /// [`Unit::first_error_code`] and zeros invalid with their reason, every
    /// other range the `f32` nearest its decimal text.
    pub fn fill(&self, unit: Unit, frame: &mut Frame) -> Result<(), LineError<'a>> {
        // `beams` is a supported count, so the frame is always built.
        *frame = Frame::new(self.variant.geometry(), self.beams)
            .map_err(|_| LineError::UnsupportedBeamCount(self.beams))?;
        let per_metre = f64::from(unit.per_metre());
        let (all_ones, first_code) = (
            i64::from(unit.all_ones()),
            i64::from(unit.first_error_code()),
        );
        let texts = self.line.split_ascii_whitespace().skip(2).take(self.beams);
        for (beam, text) in texts.enumerate() {
            let metres = parse_range(beam, text)?;
            let code = libm::round(metres * per_metre) as i64;
            if code > all_ones {
                return Err(LineError::AboveAllOnes { beam, metres, unit });
            }
            if code >= first_code {
                // 0 ≤ all_ones − code ≤ 8 here.
                let offset = u16::try_from(all_ones - code).unwrap_or(0);
                frame.set_invalid(beam, Invalid::from_code_offset(offset));
            } else {
                // Parsed as f32 directly: the correctly rounded f32 of the decimal.
                frame.set_metres(beam, text.parse().unwrap_or(metres as f32));
            }
        }
        Ok(())
    }
}

/// A file is read in mm when at least 1/4 of its range values show three
/// decimals (see the module docs).
pub const MM_SHARE_DENOMINATOR: u64 = 4;

/// Longest range text kept as evidence of a decision ([`UnitVote::evidence`]).
pub const EVIDENCE_LEN: usize = 24;

/// The range that decided for mm: the first with three or more decimals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Evidence {
    /// Line number (1-based; 0 if the caller gave none).
    pub line: usize,
    /// Beam index.
    pub beam: usize,
    text: [u8; EVIDENCE_LEN],
    len: u8,
}

impl Evidence {
    /// The range's text as in the log (cut to [`EVIDENCE_LEN`] bytes).
    pub fn text(&self) -> &str {
        let bytes = self.text.get(..usize::from(self.len)).unwrap_or_default();
        core::str::from_utf8(bytes).unwrap_or("?")
    }
}

/// How a file's unit was decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// No range shows three decimals: cm.
    Centimetre,
    /// At least a quarter of the ranges show three decimals: mm.
    Millimetre,
    /// Some ranges show three decimals, fewer than a quarter: read as cm,
    /// but the file should be given a unit (`--unit`).
    Ambiguous,
}

/// The per-file unit decision, one line at a time (see the module docs):
/// counts of range values and of those showing three or more decimals,
/// and the first of them. Without allocation, for callers that read the
/// log themselves; `decide` (with `std`) runs it over a whole log.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnitVote {
    ranges: u64,
    three: u64,
    evidence: Option<Evidence>,
}

impl UnitVote {
    /// Count one `FLASER` line (no line number).
    pub fn observe(&mut self, line: &Flaser<'_>) {
        self.observe_at(0, line);
    }

    /// Count one `FLASER` line, which is line `number` of the log.
    pub fn observe_at(&mut self, number: usize, line: &Flaser<'_>) {
        self.ranges = self.ranges.saturating_add(line.beams as u64);
        self.three = self.three.saturating_add(line.three_decimal_ranges as u64);
        if self.evidence.is_none() {
            if let Some((beam, text)) = line.first_three_decimals {
                let mut e = Evidence {
                    line: number,
                    beam,
                    text: [0; EVIDENCE_LEN],
                    len: 0,
                };
                // Cut at a character boundary.
                let mut n = text.len().min(EVIDENCE_LEN);
                while !text.is_char_boundary(n) {
                    n -= 1;
                }
                e.text[..n].copy_from_slice(&text.as_bytes()[..n]);
                e.len = n as u8;
                self.evidence = Some(e);
            }
        }
    }

    /// Range values counted.
    pub fn ranges(&self) -> u64 {
        self.ranges
    }

    /// Range values with three or more decimals.
    pub fn three_decimal_ranges(&self) -> u64 {
        self.three
    }

    /// The first range with three or more decimals, if any.
    pub fn evidence(&self) -> Option<Evidence> {
        self.evidence
    }

    /// The decision so far.
    pub fn verdict(&self) -> Verdict {
        if self.three == 0 {
            Verdict::Centimetre
        } else if self.three.saturating_mul(MM_SHARE_DENOMINATOR) >= self.ranges {
            Verdict::Millimetre
        } else {
            Verdict::Ambiguous
        }
    }

    /// The unit of the lines observed so far (an ambiguous file is read in cm).
    pub fn unit(&self) -> Unit {
        match self.verdict() {
            Verdict::Millimetre => Unit::Millimetre,
            Verdict::Centimetre | Verdict::Ambiguous => Unit::Centimetre,
        }
    }
}

impl fmt::Display for UnitVote {
    /// Why: e.g. `mm: 38690 of 42897 range values show 3 decimals (the first
    /// "3.382", line 2, beam 1)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verdict = match self.verdict() {
            Verdict::Centimetre => "cm",
            Verdict::Millimetre => "mm",
            Verdict::Ambiguous => "ambiguous, read as cm",
        };
        write!(
            f,
            "{verdict}: {} of {} range values show 3 or more decimals",
            self.three, self.ranges
        )?;
        if let Some(e) = self.evidence {
            write!(
                f,
                " (the first {:?}, line {}, beam {})",
                e.text(),
                e.line,
                e.beam
            )?;
        }
        if self.verdict() == Verdict::Ambiguous {
            write!(
                f,
                "; mm needs at least 1/{MM_SHARE_DENOMINATOR} of them: give --unit mm or --unit cm"
            )?;
        }
        Ok(())
    }
}

/// One range text as metres: finite and not negative.
fn parse_range(beam: usize, text: &str) -> Result<f64, LineError<'_>> {
    let v: f64 = text
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite())
        .ok_or(LineError::MalformedRange { beam, text })?;
    if v < 0.0 {
        return Err(LineError::NegativeRange { beam, text });
    }
    Ok(v)
}

/// Digits after the decimal point (before any exponent).
fn decimals(text: &str) -> usize {
    match text.split_once('.') {
        Some((_, frac)) => frac.bytes().take_while(u8::is_ascii_digit).count(),
        None => 0,
    }
}

#[cfg(any(test, feature = "std"))]
mod reader;
#[cfg(any(test, feature = "std"))]
pub use reader::{
    decide, decide_unit, near_flaser, Cut, Note, ReadError, Reader, Scan, MAX_LINE_LEN,
    MAX_PENDING_NOTES,
};

#[cfg(test)]
mod tests;
