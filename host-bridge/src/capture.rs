//! Capture files: sensor → host telegrams recorded by `host-bridge scan`,
//! replayed by `host-bridge simulate` and read by `host-bridge extract`.
//!
//! # Format (version 1)
//!
//! A capture is a binary file: an 8-byte magic, then records back to back
//! until the end of the file. All integers are little-endian.
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic: ASCII `LMSCAP01` (`4C 4D 53 43 41 50 30 31`); the last two characters are the format version |
//! | 8 | … | records, each as below, none after the last |
//!
//! One record:
//!
//! | offset in record | size | field |
//! |---|---|---|
//! | 0 | 8 | `time_us`, u64: microseconds from the start of the capture (the moment the recorder started streaming) to the moment the telegram had been received completely; non-decreasing within a file |
//! | 8 | 2 | `length`, u16: bytes of the telegram that follows, [`MIN_TELEGRAM_LEN`] (8) to [`MAX_TELEGRAM_LEN`] (818) |
//! | 10 | `length` | the complete sensor → host telegram exactly as received, `STX` … `CRC` (PROTOCOL.md §1): `02`, `ADDR` (`0x80 \| address`), `LEN` (u16), `CMD`, data, status, `CRC` (u16) |
//!
//! A record is 10 + `length` bytes; a 361-value `B0` telegram is 732 bytes,
//! its record 742. Records normally hold `B0` measured values; a reader may
//! find other sensor → host telegrams (e.g. an `A0`) and skips them when it
//! wants scans ([`read_values`]). Every telegram is checked
//! when read: `STX` first, `LEN` consistent with `length`, a sensor → host
//! address (bit 7 set), and a correct CRC.
//!
//! Example: a capture holding one `A0` reply received 1.5 ms after the start:
//!
//! ```text
//! 4C 4D 53 43 41 50 30 31            magic "LMSCAP01"
//! DC 05 00 00 00 00 00 00            time_us = 1500
//! 09 00                              length = 9
//! 02 80 03 00 A0 00 10 16 0A         the telegram
//! ```
//!
//! # Errors
//!
//! Reading reports, with the byte offset in the file: a wrong magic (the
//! bytes found), a record cut short by the end of the file (where the record
//! starts and how many bytes it needed), an impossible `length`, and a
//! telegram that fails its checks. [`CaptureFile`] writes to a temporary
//! name beside the target (`NAME.partial`) and renames it only in
//! [`CaptureFile::commit`], so a run that fails leaves no file under the
//! final name.

// This file is also compiled into the fuzz crate (`fuzz/fuzz_targets/
// capture.rs`, by `#[path]`): it may use std, lms-core and anyhow only.

use std::fmt;
use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use lms_core::telegram::{
    Direction, MeasuredValues, RangeBits, Telegram, TelegramError, MAX_TELEGRAM_LEN,
};
use lms_core::Frame;

/// The 8 bytes every capture starts with.
pub const MAGIC: [u8; 8] = *b"LMSCAP01";
/// Bytes of a record header: `time_us` (8) + `length` (2).
pub const RECORD_HEADER_LEN: usize = 10;
/// Shortest sensor → host telegram: `STX ADDR LEN(2) CMD STATUS CRC(2)`.
pub const MIN_TELEGRAM_LEN: usize = 8;

/// One record of a capture.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Record {
    /// Microseconds from the start of the capture to the end of the telegram.
    pub time_us: u64,
    /// The complete telegram, `STX` … `CRC`.
    pub telegram: Vec<u8>,
}

impl Record {
    /// The telegram as a checked sensor → host view.
    pub fn view(&self) -> Telegram<&[u8]> {
        Telegram::new_unchecked(&self.telegram[..], Direction::SensorToHost)
    }
}

/// Why a capture cannot be read or written.
#[derive(Debug)]
pub enum CaptureError {
    /// Reading or writing failed at this byte offset.
    Io {
        /// Byte offset in the file.
        offset: u64,
        /// The underlying error.
        source: io::Error,
    },
    /// The file does not start with [`MAGIC`].
    BadMagic {
        /// The first bytes found (up to 8).
        found: Vec<u8>,
    },
    /// The file ends inside a record.
    Truncated {
        /// Index of the record (from 0).
        record: u64,
        /// Byte offset where the record starts.
        offset: u64,
        /// Bytes the record needs (header + telegram, as far as known).
        needed: usize,
        /// Bytes present before the end of the file.
        got: usize,
    },
    /// A record's `length` is outside `MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN`.
    BadLength {
        /// Index of the record.
        record: u64,
        /// Byte offset where the record starts.
        offset: u64,
        /// The `length` field.
        length: u16,
    },
    /// A record's bytes are not a valid sensor → host telegram.
    BadTelegram {
        /// Index of the record.
        record: u64,
        /// Byte offset where the record starts.
        offset: u64,
        /// What is wrong with it.
        reason: TelegramProblem,
    },
}

/// What is wrong with a recorded telegram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TelegramProblem {
    /// The telegram's own checks failed (STX, LEN, CRC).
    Check(TelegramError),
    /// `6 + LEN` differs from the record's `length`.
    LengthMismatch {
        /// The record's `length`.
        record_length: usize,
        /// `6 + LEN` from the telegram header.
        telegram_length: usize,
    },
    /// The address byte lacks bit 7: not sensor → host.
    NotFromSensor {
        /// The address byte.
        address: u8,
    },
}

impl fmt::Display for TelegramProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TelegramProblem::Check(e) => write!(f, "{e}"),
            TelegramProblem::LengthMismatch {
                record_length,
                telegram_length,
            } => write!(
                f,
                "record length {record_length} but the telegram's LEN makes {telegram_length} bytes"
            ),
            TelegramProblem::NotFromSensor { address } => {
                write!(f, "address {address:#04x} is not a sensor → host address")
            }
        }
    }
}

impl fmt::Display for CaptureError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CaptureError::Io { offset, source } => write!(f, "I/O error at byte {offset}: {source}"),
            CaptureError::BadMagic { found } => {
                write!(f, "not a capture file: expected magic \"LMSCAP01\", found ")?;
                if found.is_empty() {
                    f.write_str("an empty file")
                } else {
                    write!(f, "{:02X?} ({:?})", found, String::from_utf8_lossy(found))
                }
            }
            CaptureError::Truncated {
                record,
                offset,
                needed,
                got,
            } => write!(
                f,
                "truncated record {record} at byte {offset}: needs {needed} bytes, the file ends after {got}"
            ),
            CaptureError::BadLength {
                record,
                offset,
                length,
            } => write!(
                f,
                "record {record} at byte {offset}: telegram length {length} is outside {MIN_TELEGRAM_LEN}..={MAX_TELEGRAM_LEN}"
            ),
            CaptureError::BadTelegram {
                record,
                offset,
                reason,
            } => write!(f, "record {record} at byte {offset}: {reason}"),
        }
    }
}

/// The I/O error's text is part of the message already: no `source`, or
/// `{:#}` would print it twice.
impl std::error::Error for CaptureError {}

/// Check one recorded telegram (see the [module docs](self)).
pub fn check_telegram(bytes: &[u8]) -> Result<(), TelegramProblem> {
    let t =
        Telegram::new_checked(bytes, Direction::SensorToHost).map_err(TelegramProblem::Check)?;
    if t.total_len() != bytes.len() {
        return Err(TelegramProblem::LengthMismatch {
            record_length: bytes.len(),
            telegram_length: t.total_len(),
        });
    }
    if t.address() & lms_core::telegram::REPLY_ADDRESS_BIT == 0 {
        return Err(TelegramProblem::NotFromSensor {
            address: t.address(),
        });
    }
    Ok(())
}

/// Writes a capture: the magic at creation, then one record per
/// [`write`](CaptureWriter::write).
#[derive(Debug)]
pub struct CaptureWriter<W: Write> {
    out: W,
    records: u64,
    bytes: u64,
    last_time_us: u64,
}

impl<W: Write> CaptureWriter<W> {
    /// Start a capture on `out` (writes the magic).
    pub fn new(mut out: W) -> Result<Self, CaptureError> {
        out.write_all(&MAGIC)
            .map_err(|source| CaptureError::Io { offset: 0, source })?;
        Ok(CaptureWriter {
            out,
            records: 0,
            bytes: MAGIC.len() as u64,
            last_time_us: 0,
        })
    }

    /// Append one record. The telegram is checked first; a `time_us` earlier
    /// than the previous record's is raised to it (the format promises
    /// non-decreasing times).
    pub fn write(&mut self, time_us: u64, telegram: &[u8]) -> Result<(), CaptureError> {
        let record = self.records;
        let offset = self.bytes;
        let length = u16::try_from(telegram.len())
            .ok()
            .filter(|&l| (MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN).contains(&usize::from(l)))
            .ok_or(CaptureError::BadLength {
                record,
                offset,
                length: u16::try_from(telegram.len()).unwrap_or(u16::MAX),
            })?;
        check_telegram(telegram).map_err(|reason| CaptureError::BadTelegram {
            record,
            offset,
            reason,
        })?;
        let time_us = time_us.max(self.last_time_us);
        let mut header = [0u8; RECORD_HEADER_LEN];
        header[..8].copy_from_slice(&time_us.to_le_bytes());
        header[8..].copy_from_slice(&length.to_le_bytes());
        // One buffer, one write: a record reaches the file whole or cut.
        let mut record_bytes = [0u8; RECORD_HEADER_LEN + MAX_TELEGRAM_LEN];
        record_bytes[..RECORD_HEADER_LEN].copy_from_slice(&header);
        record_bytes[RECORD_HEADER_LEN..RECORD_HEADER_LEN + telegram.len()]
            .copy_from_slice(telegram);
        self.out
            .write_all(&record_bytes[..RECORD_HEADER_LEN + telegram.len()])
            .map_err(|source| CaptureError::Io { offset, source })?;
        self.records += 1;
        self.bytes += (RECORD_HEADER_LEN + telegram.len()) as u64;
        self.last_time_us = time_us;
        Ok(())
    }

    /// Records written so far.
    pub fn records(&self) -> u64 {
        self.records
    }

    /// Bytes written so far (magic included).
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Flush and hand back the output.
    pub fn finish(mut self) -> Result<W, CaptureError> {
        let offset = self.bytes;
        self.out
            .flush()
            .map_err(|source| CaptureError::Io { offset, source })?;
        Ok(self.out)
    }
}

/// A capture being written to `NAME.partial` beside its final `NAME`;
/// [`commit`](CaptureFile::commit) renames it. Dropped without a commit, the
/// partial file stays (it holds the records written so far) and the final
/// name is never created.
#[derive(Debug)]
pub struct CaptureFile {
    writer: CaptureWriter<BufWriter<File>>,
    path: PathBuf,
    partial: PathBuf,
}

impl CaptureFile {
    /// The temporary name used while writing `path`: `path` + `.partial`.
    pub fn partial_path(path: &Path) -> PathBuf {
        let mut name = path.as_os_str().to_owned();
        name.push(".partial");
        PathBuf::from(name)
    }

    /// Create `path.partial` and write the magic.
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        use anyhow::Context;
        let partial = Self::partial_path(path);
        let file = File::create(&partial)
            .with_context(|| format!("cannot create capture file {}", partial.display()))?;
        let writer = CaptureWriter::new(BufWriter::new(file))
            .with_context(|| format!("cannot write capture file {}", partial.display()))?;
        Ok(CaptureFile {
            writer,
            path: path.to_owned(),
            partial,
        })
    }

    /// Append one record (see [`CaptureWriter::write`]) and flush it to the
    /// file, so that a kill or a power loss costs at most the record being
    /// written (readers keep every complete record of a cut file).
    pub fn write(&mut self, time_us: u64, telegram: &[u8]) -> anyhow::Result<()> {
        use anyhow::Context;
        let offset = self.writer.bytes();
        self.writer
            .write(time_us, telegram)
            .and_then(|()| {
                self.writer
                    .out
                    .flush()
                    .map_err(|source| CaptureError::Io { offset, source })
            })
            .with_context(|| format!("cannot write capture file {}", self.partial.display()))
    }

    /// Records written so far.
    pub fn records(&self) -> u64 {
        self.writer.records()
    }

    /// Bytes written so far.
    pub fn bytes(&self) -> u64 {
        self.writer.bytes()
    }

    /// The final name.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary name written to until the commit.
    pub fn partial(&self) -> &Path {
        &self.partial
    }

    /// Flush, sync and rename to the final name; returns it.
    pub fn commit(self) -> anyhow::Result<PathBuf> {
        use anyhow::Context;
        let CaptureFile {
            writer,
            path,
            partial,
        } = self;
        let file = writer
            .finish()
            .with_context(|| format!("cannot write capture file {}", partial.display()))?
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("cannot write capture file {}", partial.display()))?;
        file.sync_all()
            .with_context(|| format!("cannot write capture file {}", partial.display()))?;
        drop(file);
        std::fs::rename(&partial, &path).with_context(|| {
            format!("cannot rename {} to {}", partial.display(), path.display())
        })?;
        Ok(path)
    }
}

/// Reads records one by one (an iterator of `Result<Record, CaptureError>`
/// that ends after the first error).
#[derive(Debug)]
pub struct CaptureReader<R: Read> {
    input: R,
    offset: u64,
    record: u64,
    failed: bool,
}

/// Read until `buf` is full or the input ends; returns the bytes read.
fn read_full<R: Read>(input: &mut R, buf: &mut [u8]) -> io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match input.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

impl<R: Read> CaptureReader<R> {
    /// Check the magic and get ready to read the first record.
    pub fn new(mut input: R) -> Result<Self, CaptureError> {
        let mut magic = [0u8; 8];
        let got = read_full(&mut input, &mut magic)
            .map_err(|source| CaptureError::Io { offset: 0, source })?;
        if got < magic.len() || magic != MAGIC {
            return Err(CaptureError::BadMagic {
                found: magic[..got].to_vec(),
            });
        }
        Ok(CaptureReader {
            input,
            offset: MAGIC.len() as u64,
            record: 0,
            failed: false,
        })
    }

    /// Byte offset of the next record.
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// The next record, `Ok(None)` at a clean end of the file.
    pub fn next_record(&mut self) -> Result<Option<Record>, CaptureError> {
        let record = self.record;
        let offset = self.offset;
        let io_err = |source| CaptureError::Io { offset, source };
        let mut header = [0u8; RECORD_HEADER_LEN];
        let got = read_full(&mut self.input, &mut header).map_err(io_err)?;
        if got == 0 {
            return Ok(None);
        }
        if got < RECORD_HEADER_LEN {
            return Err(CaptureError::Truncated {
                record,
                offset,
                needed: RECORD_HEADER_LEN,
                got,
            });
        }
        let mut time = [0u8; 8];
        time.copy_from_slice(&header[..8]);
        let time_us = u64::from_le_bytes(time);
        let length = u16::from_le_bytes([header[8], header[9]]);
        let len = usize::from(length);
        if !(MIN_TELEGRAM_LEN..=MAX_TELEGRAM_LEN).contains(&len) {
            return Err(CaptureError::BadLength {
                record,
                offset,
                length,
            });
        }
        let mut telegram = vec![0u8; len];
        let got = read_full(&mut self.input, &mut telegram).map_err(io_err)?;
        if got < len {
            return Err(CaptureError::Truncated {
                record,
                offset,
                needed: RECORD_HEADER_LEN + len,
                got: RECORD_HEADER_LEN + got,
            });
        }
        check_telegram(&telegram).map_err(|reason| CaptureError::BadTelegram {
            record,
            offset,
            reason,
        })?;
        self.record += 1;
        self.offset += (RECORD_HEADER_LEN + len) as u64;
        Ok(Some(Record { time_us, telegram }))
    }
}

impl<R: Read> Iterator for CaptureReader<R> {
    type Item = Result<Record, CaptureError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        match self.next_record() {
            Ok(r) => r.map(Ok),
            Err(e) => {
                self.failed = true;
                Some(Err(e))
            }
        }
    }
}

/// Open a capture file and check its magic.
pub fn open(path: &Path) -> anyhow::Result<CaptureReader<BufReader<File>>> {
    use anyhow::Context;
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    CaptureReader::new(BufReader::new(file)).with_context(|| format!("{}", path.display()))
}

/// `true` if the file at `path` starts with the capture [`MAGIC`].
pub fn is_capture(path: &Path) -> io::Result<bool> {
    let mut file = File::open(path)?;
    let mut magic = [0u8; 8];
    let got = read_full(&mut file, &mut magic)?;
    Ok(got == magic.len() && magic == MAGIC)
}

/// One scan read back from a capture.
#[derive(Clone, Debug, PartialEq)]
pub struct CapturedScan {
    /// Index among the scans (`B0` records) of the file, from 0.
    pub index: usize,
    /// Microseconds from the start of the capture.
    pub time_us: u64,
    /// The raw value words, units, scan flags and status byte.
    pub values: MeasuredValues,
}

/// The `B0` records of a capture as raw values, in file order (other
/// telegrams are skipped), for replay (`simulate`) and for
/// [`crate::input`]. A file cut inside a record (a recorder killed, a
/// power loss) ends the scans without an error: every complete record
/// before the cut is read and [`CaptureScans::cut`] says where and why.
/// Any other damage is an error naming the file and the record; the
/// iterator ends after it.
///
/// Records that break the format's promises without being unreadable are
/// read, and noted for a warning ([`CaptureScans::next_note`], naming the
/// record and its byte offset): a `time_us` earlier than the previous
/// record's (the time runs backwards) and a record identical to the
/// previous one (time and telegram: a duplicate). At most
/// [`MAX_PENDING_NOTES`] wait to be taken; the rest are counted.
#[derive(Debug)]
pub struct CaptureScans<R: Read> {
    reader: CaptureReader<R>,
    path: PathBuf,
    index: usize,
    cut: Option<CaptureError>,
    done: bool,
    previous: Option<Record>,
    notes: std::collections::VecDeque<String>,
    notes_dropped: usize,
}

/// Notes kept until taken ([`CaptureScans::next_note`]).
pub const MAX_PENDING_NOTES: usize = 64;

/// Where a record is in a capture: its number, from 0, and its byte offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RecordAt {
    record: u64,
    offset: u64,
}

impl<R: Read> CaptureScans<R> {
    /// The scans of the capture on `input` (its magic already checked);
    /// `path` names it in messages.
    pub fn new(reader: CaptureReader<R>, path: &Path) -> Self {
        CaptureScans {
            reader,
            path: path.to_owned(),
            index: 0,
            cut: None,
            done: false,
            previous: None,
            notes: std::collections::VecDeque::new(),
            notes_dropped: 0,
        }
    }

    /// The oldest note not yet taken: a record whose time runs backwards
    /// or that duplicates the previous one (see [`CaptureScans`]).
    pub fn next_note(&mut self) -> Option<String> {
        self.notes.pop_front()
    }

    /// Notes that did not fit the [`MAX_PENDING_NOTES`] waiting.
    pub fn notes_dropped(&self) -> usize {
        self.notes_dropped
    }

    /// Compare the record `rec` at `at` with the previous one.
    fn look_at(&mut self, at: RecordAt, rec: &Record) {
        let RecordAt { record, offset } = at;
        let note = match &self.previous {
            Some(p) if p == rec => Some(format!(
                "record {record} at byte {offset} duplicates the previous record \
                 (same time_us {} and telegram)",
                rec.time_us
            )),
            Some(p) if rec.time_us < p.time_us => Some(format!(
                "record {record} at byte {offset}: time_us {} is earlier than the previous \
                 record's {}: the capture's time runs backwards",
                rec.time_us, p.time_us
            )),
            _ => None,
        };
        if let Some(note) = note {
            if self.notes.len() < MAX_PENDING_NOTES {
                self.notes.push_back(note);
            } else {
                self.notes_dropped += 1;
            }
        }
        match &mut self.previous {
            Some(p) => {
                p.time_us = rec.time_us;
                p.telegram.clear();
                p.telegram.extend_from_slice(&rec.telegram);
            }
            None => self.previous = Some(rec.clone()),
        }
    }

    /// The cut ([`CaptureError::Truncated`]) the scans ended at, if any.
    pub fn cut(&self) -> Option<&CaptureError> {
        self.cut.as_ref()
    }

    /// Complete records read so far (scans and other telegrams).
    pub fn records(&self) -> u64 {
        self.reader.record
    }

    /// `B0` scans read so far.
    pub fn scans(&self) -> usize {
        self.index
    }

    /// The cut as a sentence for the user, if the file is cut.
    pub fn cut_message(&self) -> Option<String> {
        self.cut.as_ref().map(|e| {
            format!(
                "{}: {e}: the file is cut (a recording killed or a power loss?); \
                 the {} complete records before it are used",
                self.path.display(),
                self.reader.record
            )
        })
    }

    fn next_scan(&mut self) -> Option<anyhow::Result<CapturedScan>> {
        loop {
            let (record, offset) = (self.reader.record, self.reader.offset);
            let rec = match self.reader.next_record() {
                Ok(Some(r)) => r,
                Ok(None) => return None,
                Err(e @ CaptureError::Truncated { .. }) => {
                    self.cut = Some(e);
                    return None;
                }
                Err(e) => {
                    return Some(Err(
                        anyhow::Error::new(e).context(self.path.display().to_string())
                    ))
                }
            };
            self.look_at(RecordAt { record, offset }, &rec);
            let view = rec.view();
            if view.command() != lms_core::telegram::measured::MEASURED_COMMAND {
                continue;
            }
            let i = self.index;
            self.index += 1;
            return Some(
                MeasuredValues::parse(&view)
                    .map(|values| CapturedScan {
                        index: i,
                        time_us: rec.time_us,
                        values,
                    })
                    .map_err(|e| {
                        anyhow::anyhow!("{}: scan {i}: B0 telegram: {e}", self.path.display())
                    }),
            );
        }
    }
}

impl<R: Read> Iterator for CaptureScans<R> {
    type Item = anyhow::Result<CapturedScan>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let next = self.next_scan();
        self.done = !matches!(next, Some(Ok(_)));
        next
    }
}

/// The `B0` scans of the capture at `path` ([`CaptureScans`]).
pub fn read_values(path: &Path) -> anyhow::Result<CaptureScans<BufReader<File>>> {
    Ok(CaptureScans::new(open(path)?, path))
}

/// A scan's frame in metres, ranges with the default 13 range bits
/// ([`RangeBits::Bits13`]) as `extract` reads them.
pub fn frame_of(scan: &CapturedScan) -> Result<Frame, lms_core::telegram::MeasuredError> {
    scan.values.to_frame(RangeBits::Bits13)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lms_core::Unit;

    const A0: [u8; 9] = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];

    fn b0(seed: u16) -> Vec<u8> {
        let words: Vec<u16> = (0..181).map(|j| (j * 7 + seed) % 8000 + 1).collect();
        let v = MeasuredValues::from_raw(&words, Unit::Millimetre, 0x10).unwrap();
        let mut buf = vec![0u8; v.buffer_len()];
        let n = v.emit(0, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    #[test]
    fn capture_byte_layout_matches_the_doc() {
        let mut w = CaptureWriter::new(Vec::new()).unwrap();
        w.write(1500, &A0).unwrap();
        let bytes = w.finish().unwrap();
        let expected: Vec<u8> = [
            &b"LMSCAP01"[..],
            &[0xDC, 0x05, 0, 0, 0, 0, 0, 0],
            &[0x09, 0x00],
            &A0,
        ]
        .concat();
        assert_eq!(bytes, expected);
    }

    #[test]
    fn capture_round_trip() {
        let mut w = CaptureWriter::new(Vec::new()).unwrap();
        w.write(10, &b0(1)).unwrap();
        w.write(20, &A0).unwrap();
        // An earlier time is raised to the previous one.
        w.write(15, &b0(2)).unwrap();
        assert_eq!(w.records(), 3);
        let bytes = w.finish().unwrap();
        let recs: Vec<Record> = CaptureReader::new(&bytes[..])
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(recs.len(), 3);
        assert_eq!(recs[0].telegram, b0(1));
        assert_eq!(recs[1].telegram, A0);
        assert_eq!(recs[2].time_us, 20);
    }

    #[test]
    fn capture_errors_name_the_offset() {
        assert!(matches!(
            CaptureReader::new(&b"LMSCAP02"[..]),
            Err(CaptureError::BadMagic { .. })
        ));
        let e = CaptureReader::new(&b"FLASER 3"[..]).unwrap_err();
        assert!(e.to_string().contains("FLASER 3"), "{e}");
        assert!(CaptureReader::new(&b""[..])
            .unwrap_err()
            .to_string()
            .contains("empty file"));

        let mut w = CaptureWriter::new(Vec::new()).unwrap();
        w.write(1, &A0).unwrap();
        w.write(2, &b0(3)).unwrap();
        let full = w.finish().unwrap();
        // Cut inside the second record's telegram.
        let cut = &full[..full.len() - 5];
        let mut r = CaptureReader::new(cut).unwrap();
        assert!(r.next().unwrap().is_ok());
        let e = r.next().unwrap().unwrap_err();
        let second = 8 + 10 + A0.len();
        assert!(
            matches!(e, CaptureError::Truncated { record: 1, offset, .. } if offset == second as u64),
            "{e}"
        );
        assert!(e.to_string().contains(&format!("at byte {second}")), "{e}");
        assert!(r.next().is_none());
        // Cut inside a header.
        let cut = &full[..second + 4];
        let e = CaptureReader::new(cut)
            .unwrap()
            .nth(1)
            .unwrap()
            .unwrap_err();
        assert!(matches!(
            e,
            CaptureError::Truncated {
                needed: 10,
                got: 4,
                ..
            }
        ));
        // A flipped bit in a telegram fails its CRC.
        let mut bad = full.clone();
        bad[second + 10 + 20] ^= 0x01;
        let e = CaptureReader::new(&bad[..])
            .unwrap()
            .nth(1)
            .unwrap()
            .unwrap_err();
        assert!(
            matches!(
                e,
                CaptureError::BadTelegram {
                    reason: TelegramProblem::Check(TelegramError::BadCrc { .. }),
                    ..
                }
            ),
            "{e}"
        );
        // An impossible length.
        let mut bad = full;
        bad[8 + 8] = 0xFF;
        bad[8 + 9] = 0xFF;
        let e = CaptureReader::new(&bad[..])
            .unwrap()
            .next()
            .unwrap()
            .unwrap_err();
        assert!(matches!(
            e,
            CaptureError::BadLength {
                length: 0xFFFF,
                offset: 8,
                ..
            }
        ));
        // The writer refuses what the reader would refuse.
        let mut w = CaptureWriter::new(Vec::new()).unwrap();
        assert!(w.write(0, &A0[..7]).is_err());
        let host = [0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12, 0x00];
        assert!(w.write(0, &host).is_err());
        assert_eq!(w.records(), 0);
    }

    #[test]
    fn capture_file_commit_and_frames() {
        let dir = std::env::temp_dir().join(format!("capture-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("scans.lmscap");
        let _ = std::fs::remove_file(&path);
        let mut f = CaptureFile::create(&path).unwrap();
        f.write(0, &b0(5)).unwrap();
        f.write(5, &A0).unwrap();
        f.write(26_700, &b0(6)).unwrap();
        assert!(f.partial().exists());
        assert!(!path.exists());
        let done = f.commit().unwrap();
        assert_eq!(done, path);
        assert!(!CaptureFile::partial_path(&path).exists());
        assert!(is_capture(&path).unwrap());
        let scans: Vec<_> = read_values(&path)
            .unwrap()
            .collect::<anyhow::Result<_>>()
            .unwrap();
        assert_eq!(scans.len(), 2);
        assert_eq!(scans[1].time_us, 26_700);
        let frame = frame_of(&scans[0]).unwrap();
        assert_eq!(frame.len(), 181);
        assert_eq!(frame.ranges()[0], 0.006);
        assert_eq!(scans[1].values.units(), Unit::Millimetre);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
