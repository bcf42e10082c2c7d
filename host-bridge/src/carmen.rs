//! CARMEN text logs (`FLASER` lines) → [`Frame`](lms_core::Frame)s: opening
//! the file, gzip, and the command line's unit choice over the core's one
//! reader, [`lms_core::carmen`] (format, geometry, units and error codes
//! are documented there).
//!
//! The file may be gzip-compressed or plain; the gzip magic bytes
//! (`1f 8b`) decide, not the file name.
//!
//! # Units (decision)
//!
//! * [`UnitMode::Auto`] (default): the file is in **mm** if at least a
//!   quarter of the range values of its head (the first [`HEAD_TEXT`] bytes
//!   of text: the whole log unless it is longer) show three or more
//!   decimals (the Örebro log), in **cm** if none does, and ambiguous (read as cm, `--unit`
//!   suggested) in between ([`lms_core::carmen::UnitVote`]).
//! * [`UnitMode::Centimetre`] / [`UnitMode::Millimetre`] force the unit.
//!
//! Errors name the file and the 1-based line.
//!
//! # One pass ([`LogText`])
//!
//! A log is read once, from the start, whatever it is (a file, a pipe, a
//! FIFO, standard input): the first [`HEAD_TEXT`] bytes of its text are
//! kept in memory (the unit and the defaults per data are decided on
//! them; every shared log fits whole), then the text streams on from the
//! same reader, head first. Memory stays bounded whatever the log's length.
//!
//! # Damaged gzip
//!
//! A gzip stream that ends early (no trailer: a cut download) is a cut:
//! the complete scans before it are kept. A stream whose CRC-32 or length
//! check fails, or whose deflate data are corrupt, is damaged: scans read
//! before the failure may carry altered ranges, so reading fails, unless
//! the caller keeps them ([`LogText::open`]'s `keep_damaged`): then the
//! scans end there as at a cut, and [`LogText::damage_handle`] says why.

use std::cell::RefCell;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use anyhow::{Context, Result};
use lms_core::carmen::{decide_unit, Reader};
pub use lms_core::carmen::{variant_for_beams, Meta as ScanMeta, Scan, SUPPORTED_BEAMS};
pub use lms_core::carmen::{Cut, UnitVote, Verdict};
pub use lms_core::Unit;

/// Range unit of a log's readings (for error-code detection).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum UnitMode {
    /// Decide from the number of decimals in the file (see the module docs).
    #[default]
    Auto,
    /// Centimetre mode: error codes 81.83 … 81.91 m.
    Centimetre,
    /// Millimetre (32 m) mode: error codes 32.759 … 32.767 m.
    Millimetre,
}

/// A whole CARMEN log.
#[derive(Clone, Debug)]
pub struct CarmenLog {
    /// Where it was read from (for messages).
    pub path: PathBuf,
    /// The unit the error codes were interpreted in (cm or mm).
    pub unit: Unit,
    /// All `FLASER` scans in file order.
    pub scans: Vec<Scan>,
}

/// Bytes read from the file, and decompressed, at a time: memory stays
/// the same whatever the log's length (or a gzip bomb's ratio).
pub const READ_BUFFER: usize = 64 * 1024;

/// Bytes of a log's text kept to decide its unit and its defaults per data
/// (8 MiB: the largest shared log has 5.1 MB of text).
pub const HEAD_TEXT: usize = 8 * 1024 * 1024;

/// The gzip magic bytes.
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Why a gzip stream is damaged, once it is (shared by the decoder and the
/// [`LogText`] that reports it).
type Damage = Rc<RefCell<Option<String>>>;

/// A gzip decoder that tells a cut stream (`UnexpectedEof`, left as it is)
/// from a damaged one (checksum, corrupt data): the damage is recorded and
/// reported as an error (`Other`: reading fails) or, when kept, as the
/// end of the data (`InvalidData`: the reader ends the scans there).
struct GzGuard<R: BufRead> {
    inner: flate2::bufread::MultiGzDecoder<R>,
    keep_damaged: bool,
    damage: Damage,
}

impl<R: BufRead> Read for GzGuard<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.inner.read(buf) {
            Err(e)
                if !matches!(
                    e.kind(),
                    io::ErrorKind::UnexpectedEof | io::ErrorKind::Interrupted
                ) =>
            {
                let why = format!("the gzip data are damaged ({e})");
                *self.damage.borrow_mut() = Some(why.clone());
                let kind = if self.keep_damaged {
                    io::ErrorKind::InvalidData
                } else {
                    io::ErrorKind::Other
                };
                Err(io::Error::new(kind, why))
            }
            other => other,
        }
    }
}

/// The head of a text kept in memory, then the rest of the same reader
/// (an error met while filling the head comes after the head).
struct HeadThen<R> {
    head: Rc<[u8]>,
    at: usize,
    pending: Option<io::Error>,
    rest: R,
}

impl<R: Read> Read for HeadThen<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.at < self.head.len() {
            let n = buf.len().min(self.head.len() - self.at);
            buf[..n].copy_from_slice(&self.head[self.at..self.at + n]);
            self.at += n;
            return Ok(n);
        }
        if let Some(e) = self.pending.take() {
            // The data end at the error.
            self.head = Rc::from(Vec::new());
            self.at = usize::MAX;
            return Err(e);
        }
        if self.at == usize::MAX {
            return Ok(0);
        }
        self.rest.read(buf)
    }
}

/// Read up to `limit` bytes of `input`; an error ends the head and is
/// returned beside it.
fn read_head(input: &mut impl Read, limit: usize) -> (Vec<u8>, Option<io::Error>) {
    let mut head = Vec::new();
    let mut chunk = vec![0u8; READ_BUFFER];
    while head.len() < limit {
        let want = chunk.len().min(limit - head.len());
        match input.read(&mut chunk[..want]) {
            Ok(0) => break,
            Ok(n) => head.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return (head, Some(e)),
        }
    }
    (head, None)
}

/// The text of a log opened once (see the [module docs](self)): its head
/// in memory, the whole text streamed.
pub struct LogText {
    /// The whole text from its start (the head, then the rest).
    pub text: Box<dyn BufRead>,
    head: Rc<[u8]>,
    gzip: bool,
    damage: Damage,
}

impl LogText {
    /// Gunzip `input` if it starts with the gzip magic (several members
    /// allowed), else take it as it is, and read the head. With
    /// `keep_damaged`, a damaged gzip stream ends the scans as a cut does
    /// instead of failing.
    pub fn open(mut input: Box<dyn BufRead>, keep_damaged: bool) -> io::Result<LogText> {
        let gzip = input.fill_buf()?.starts_with(&GZIP_MAGIC);
        let damage = Damage::default();
        let mut decoded: Box<dyn Read> = if gzip {
            Box::new(GzGuard {
                inner: flate2::bufread::MultiGzDecoder::new(input),
                keep_damaged,
                damage: damage.clone(),
            })
        } else {
            Box::new(input)
        };
        let (head, pending) = read_head(&mut decoded, HEAD_TEXT);
        let head: Rc<[u8]> = Rc::from(head);
        let text = HeadThen {
            head: head.clone(),
            at: 0,
            pending,
            rest: decoded,
        };
        Ok(LogText {
            text: Box::new(BufReader::with_capacity(READ_BUFFER, text)),
            head,
            gzip,
            damage,
        })
    }

    /// The first [`HEAD_TEXT`] bytes of the text (all of it if shorter).
    pub fn head(&self) -> &[u8] {
        &self.head
    }

    /// A handle on the head that outlives `self` (for scans of the head).
    pub fn head_shared(&self) -> Rc<[u8]> {
        self.head.clone()
    }

    /// `true` if the log is gzip-compressed.
    pub fn is_gzip(&self) -> bool {
        self.gzip
    }

    /// A handle on the damage of the gzip stream, once found.
    pub fn damage_handle(&self) -> Rc<RefCell<Option<String>>> {
        self.damage.clone()
    }
}

/// The text of the log file at `path`, streamed: gunzipped if it starts
/// with the gzip magic `1f 8b` (several members allowed), else as it is;
/// buffers of [`READ_BUFFER`] bytes. A damaged gzip stream fails.
pub fn open_text(path: &Path) -> Result<Box<dyn BufRead>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let file = BufReader::with_capacity(READ_BUFFER, file);
    Ok(LogText::open(Box::new(file), false)
        .with_context(|| format!("cannot read {}", path.display()))?
        .text)
}

/// The unit decision of the log at `path`, on its head ([`HEAD_TEXT`]
/// bytes): the counts, the verdict and the value that decided.
pub fn decide(path: &Path) -> Result<UnitVote> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let text = LogText::open(Box::new(BufReader::new(file)), false)
        .with_context(|| format!("cannot read {}", path.display()))?;
    lms_core::carmen::decide(text.head()).with_context(|| format!("in {}", path.display()))
}

/// The scans of the log at `path`, streamed, in `unit` (see
/// [`lms_core::carmen::Reader`], which also reports a cut log).
pub fn stream(path: &Path, unit: Unit) -> Result<Reader<Box<dyn BufRead>>> {
    Ok(Reader::new(open_text(path)?, unit))
}

/// Read a whole CARMEN log into memory (gzip or plain, decided by the
/// magic bytes); a cut log keeps its complete scans and warns on stderr.
/// Tools that go through a log once use [`crate::input`] instead.
pub fn read_log(path: &Path, unit: UnitMode) -> Result<CarmenLog> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let text = LogText::open(Box::new(BufReader::with_capacity(READ_BUFFER, file)), false)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let unit = match unit {
        UnitMode::Centimetre => Unit::Centimetre,
        UnitMode::Millimetre => Unit::Millimetre,
        UnitMode::Auto => lms_core::carmen::decide(text.head())
            .with_context(|| format!("in {}", path.display()))?
            .unit(),
    };
    let mut reader = Reader::new(text.text, unit);
    let scans = reader
        .by_ref()
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("in {}", path.display()))?;
    if let Some(cut) = reader.cut() {
        crate::warning::warn(&format!(
            "{}: {cut}; the {} complete scans before it are used",
            path.display(),
            scans.len()
        ));
    }
    Ok(CarmenLog {
        path: path.to_path_buf(),
        unit,
        scans,
    })
}

/// Gunzip `bytes` if they start with the gzip magic, else return them.
pub fn decompress(bytes: Vec<u8>) -> Result<Vec<u8>> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::with_capacity(bytes.len() * 4);
        flate2::read::MultiGzDecoder::new(&bytes[..]).read_to_end(&mut out)?;
        Ok(out)
    } else {
        Ok(bytes)
    }
}

/// Parse the text of a log. Errors name the 1-based line number. The
/// syntax of every line is checked first (the unit decision's pass), so a
/// syntax error is reported before a range beyond a forced unit's codes.
pub fn parse_log(text: &[u8], mode: UnitMode) -> Result<(Unit, Vec<Scan>)> {
    let auto = decide_unit(text)?;
    let unit = match mode {
        UnitMode::Centimetre => Unit::Centimetre,
        UnitMode::Millimetre => Unit::Millimetre,
        UnitMode::Auto => auto,
    };
    let scans = Reader::new(text, unit).collect::<Result<Vec<_>, _>>()?;
    Ok((unit, scans))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lms_core::{Beam, Invalid};

    fn line(n: usize, ranges: &str) -> String {
        format!("FLASER {n} {ranges} 1 2 0.5 1 2 0.5 12.5 host 12.6\n")
    }

    #[test]
    fn the_unit_mode_decides_the_codes() {
        let mut r = vec!["1.505"; 181];
        r[0] = "1.234";
        r[1] = "32.767";
        let text = line(181, &r.join(" "));
        let (unit, scans) = parse_log(text.as_bytes(), UnitMode::Auto).unwrap();
        assert_eq!(unit, Unit::Millimetre);
        assert_eq!(scans[0].frame.beams()[1], Beam::Invalid(Invalid::NoEcho));
        let (unit, scans) = parse_log(text.as_bytes(), UnitMode::Centimetre).unwrap();
        assert_eq!(unit, Unit::Centimetre);
        assert_eq!(scans[0].frame.beams()[1], Beam::Valid);
        assert_eq!(scans[0].meta.pose, [1.0, 2.0, 0.5]);
        let cm = line(181, &vec!["1.50"; 181].join(" "));
        let (unit, _) = parse_log(cm.as_bytes(), UnitMode::Millimetre).unwrap();
        assert_eq!(unit, Unit::Millimetre);
    }

    #[test]
    fn errors_name_the_line() {
        let mut bad = vec!["2"; 181];
        bad[7] = "2.x";
        let text = format!("# c\n{}", line(181, &bad.join(" ")));
        let err = format!(
            "{:#}",
            parse_log(text.as_bytes(), UnitMode::Auto).unwrap_err()
        );
        assert!(err.contains("line 2"), "{err}");
        assert!(err.contains("malformed number \"2.x\""), "{err}");
    }

    /// A reader of `len` bytes of log text made up as it is read (nothing
    /// of it held), for inputs longer than the head.
    struct Endless {
        line: Vec<u8>,
        at: usize,
        left: usize,
    }

    impl Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            let n = buf.len().min(self.left).min(self.line.len() - self.at);
            buf[..n].copy_from_slice(&self.line[self.at..self.at + n]);
            self.at = (self.at + n) % self.line.len();
            self.left -= n;
            Ok(n)
        }
    }

    #[test]
    fn the_head_is_bounded_and_the_text_streams_on_whole() {
        let one = line(181, &vec!["2.50"; 181].join(" ")).into_bytes();
        let lines = HEAD_TEXT / one.len() + 100;
        let input = Endless {
            line: one.clone(),
            at: 0,
            left: one.len() * lines,
        };
        let text = LogText::open(Box::new(BufReader::new(input)), false).unwrap();
        assert_eq!(text.head().len(), HEAD_TEXT);
        assert!(!text.is_gzip());
        let scans = Reader::new(text.text, Unit::Centimetre)
            .collect::<Result<Vec<_>, _>>()
            .unwrap();
        assert_eq!(scans.len(), lines);
        assert_eq!(scans.last().unwrap().line, lines);
    }

    fn gzip(text: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        gz.write_all(text).unwrap();
        gz.finish().unwrap()
    }

    /// A failing checksum is damage (an error, or kept as a cut with the
    /// reason); a stream without its trailer is a cut.
    #[test]
    fn a_failing_checksum_is_damage_and_a_missing_trailer_a_cut() {
        let text = line(181, &vec!["2.50"; 181].join(" ")).repeat(20);
        let mut bad = gzip(text.as_bytes());
        let crc = bad.len() - 8;
        bad[crc] ^= 0x01;
        let open = |bytes: &[u8], keep| {
            LogText::open(
                Box::new(BufReader::new(io::Cursor::new(bytes.to_vec()))),
                keep,
            )
            .unwrap()
        };
        let damaged = open(&bad, false);
        assert!(damaged.is_gzip());
        let damage = damaged.damage_handle();
        assert!(damage.borrow().as_ref().unwrap().contains("checksum"));
        let mut reader = Reader::new(damaged.text, Unit::Centimetre);
        assert_eq!(reader.by_ref().filter(Result::is_ok).count(), 20);
        // After the 20 scans: the error, not a cut.
        let mut reader = Reader::new(open(&bad, false).text, Unit::Centimetre);
        let last = reader.by_ref().last().unwrap();
        assert!(last
            .unwrap_err()
            .to_string()
            .contains("gzip data are damaged"));
        assert!(reader.cut().is_none());
        // Kept: the scans end as at a cut, whose reason names the damage.
        let mut reader = Reader::new(open(&bad, true).text, Unit::Centimetre);
        assert_eq!(reader.by_ref().filter(Result::is_ok).count(), 20);
        assert!(reader.cut().unwrap().reason.contains("damaged"));
        // Without its trailer: a cut, no damage.
        let good = gzip(text.as_bytes());
        let cut = open(&good[..good.len() - 8], false);
        let damage = cut.damage_handle();
        let mut reader = Reader::new(cut.text, Unit::Centimetre);
        assert_eq!(reader.by_ref().filter(Result::is_ok).count(), 20);
        assert!(reader.cut().is_some());
        assert!(damage.borrow().is_none());
    }

    #[test]
    fn plain_and_gzip_give_the_same() {
        use std::io::Write;
        let text = line(361, &vec!["3.25"; 361].join(" "));
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        gz.write_all(text.as_bytes()).unwrap();
        let gz = gz.finish().unwrap();
        assert_eq!(decompress(gz).unwrap(), text.as_bytes());
        assert_eq!(
            decompress(text.clone().into_bytes()).unwrap(),
            text.as_bytes()
        );
    }
}
