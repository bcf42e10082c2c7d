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
//!   quarter of its range values show three or more decimals (the Örebro
//!   log), in **cm** if none does, and ambiguous (read as cm, `--unit`
//!   suggested) in between ([`lms_core::carmen::UnitVote`]).
//! * [`UnitMode::Centimetre`] / [`UnitMode::Millimetre`] force the unit.
//!
//! Errors name the file and the 1-based line.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

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

/// The text of a log, streamed: gunzipped if it starts with the gzip magic
/// `1f 8b` (several members allowed), else as it is; buffers of
/// [`READ_BUFFER`] bytes.
pub fn open_text(path: &Path) -> Result<Box<dyn BufRead>> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut file = BufReader::with_capacity(READ_BUFFER, file);
    let gzip = file
        .fill_buf()
        .with_context(|| format!("cannot read {}", path.display()))?
        .starts_with(&[0x1f, 0x8b]);
    Ok(if gzip {
        Box::new(BufReader::with_capacity(
            READ_BUFFER,
            flate2::bufread::MultiGzDecoder::new(file),
        ))
    } else {
        Box::new(file)
    })
}

/// The unit decision of the log at `path` (a first pass over the file):
/// the counts, the verdict and the value that decided.
pub fn decide(path: &Path) -> Result<UnitVote> {
    lms_core::carmen::decide(open_text(path)?).with_context(|| format!("in {}", path.display()))
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
    let unit = match unit {
        UnitMode::Centimetre => Unit::Centimetre,
        UnitMode::Millimetre => Unit::Millimetre,
        UnitMode::Auto => decide(path)?.unit(),
    };
    let mut reader = stream(path, unit)?;
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
