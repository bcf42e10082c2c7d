//! CARMEN text logs (`FLASER` lines) → [`Frame`]s.
//!
//! The file may be gzip-compressed or plain; the gzip magic bytes
//! (`1f 8b`) decide, not the file name. One scan per line:
//!
//! ```text
//! FLASER n r_0 … r_{n-1} x y θ odom_x odom_y odom_θ ipc_timestamp hostname logger_timestamp
//! ```
//!
//! Every other line (`PARAM`, `ODOM`, `NEFF`, comments, blank) is skipped.
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
//! The geometry is always the core's [`Variant::geometry`], so frames read
//! here have the same bearing bits as frames decoded from telegrams.
//!
//! # Units and error codes (decision)
//!
//! A CARMEN log stores metres, but the LMS error codes survive as values in
//! the sensor's unit: in cm mode 8183 … 8191 cm read 81.83 … 81.91 m, in the
//! 32 m mm mode 32759 … 32767 mm read 32.759 … 32.767 m. The two modes
//! cannot be told apart from one value (cm logs hold genuine 32.8 m
//! readings), so the unit is decided **per file**:
//!
//! * [`UnitMode::Auto`] (default): the file is in **mm** if any range value
//!   of any `FLASER` line has three or more decimals (the Örebro log; CARMEN
//!   trims trailing zeros, so most but not all of its values show three), else
//!   in **cm** (two decimals at most: CSAIL, Intel, Belgioioso, Freiburg).
//! * [`UnitMode::Centimetre`] / [`UnitMode::Millimetre`] force the unit.
//!
//! Readings at or above the mode's first error code (8183 cm, 32759 mm) are
//! invalid with the reason [`Invalid::from_code_offset`]`(all_ones − value)`
//! (`all_ones` = 8191 resp. 32767). A reading above `all_ones` cannot come
//! from an LMS in that mode and is an error naming the line (in auto mode a
//! mm log never has one, since a value above 32.767 m with three decimals
//! would make it inconsistent). Zero readings are invalid ([`Invalid::Zero`]);
//! negative, NaN or infinite readings are errors.

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lms_core::{Frame, Invalid, Variant};

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

/// The resolved unit of a log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unit {
    /// Centimetres.
    Centimetre,
    /// Millimetres.
    Millimetre,
}

impl Unit {
    /// Sensor units per metre.
    pub fn per_metre(self) -> f64 {
        match self {
            Unit::Centimetre => 100.0,
            Unit::Millimetre => 1000.0,
        }
    }

    /// The all-ones value of the range field (last error code).
    pub fn all_ones(self) -> i64 {
        match self {
            Unit::Centimetre => 8191,
            Unit::Millimetre => 32767,
        }
    }

    /// The first (lowest) error code: everything at or above is invalid.
    pub fn first_error_code(self) -> i64 {
        self.all_ones() - 8
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unit::Centimetre => "cm",
            Unit::Millimetre => "mm",
        })
    }
}

/// Pose and time stamps that follow the ranges of a `FLASER` line.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanMeta {
    /// Laser pose `[x, y, θ]` (m, m, rad).
    pub pose: [f64; 3],
    /// Odometry pose `[x, y, θ]`.
    pub odom: [f64; 3],
    /// IPC time stamp (s); unreliable in some logs.
    pub ipc_timestamp: f64,
    /// Host name field.
    pub hostname: String,
    /// Logger time stamp (s); unreliable in some logs.
    pub logger_timestamp: f64,
}

/// One `FLASER` scan of a log.
#[derive(Clone, Debug)]
pub struct Scan {
    /// Index among the `FLASER` lines of the file (0-based).
    pub index: usize,
    /// Line number in the file (1-based).
    pub line: usize,
    /// The frame, invalid beams marked with their reason.
    pub frame: Frame,
    /// Pose and time stamps.
    pub meta: ScanMeta,
}

/// A whole CARMEN log.
#[derive(Clone, Debug)]
pub struct CarmenLog {
    /// Where it was read from (for messages).
    pub path: PathBuf,
    /// The unit the error codes were interpreted in.
    pub unit: Unit,
    /// All `FLASER` scans in file order.
    pub scans: Vec<Scan>,
}

/// The geometry variant for a CARMEN beam count, if supported.
pub fn variant_for_beams(n: usize) -> Option<Variant> {
    match n {
        180 => Some(Variant::Fov180Res100),
        360 => Some(Variant::Fov180Res50),
        other => Variant::from_beams(other),
    }
}

/// The beam counts [`variant_for_beams`] accepts.
pub const SUPPORTED_BEAMS: [usize; 7] = [101, 180, 181, 201, 360, 361, 401];

/// Read a CARMEN log (gzip or plain, decided by the magic bytes).
pub fn read_log(path: &Path, unit: UnitMode) -> Result<CarmenLog> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let text =
        decompress(bytes).with_context(|| format!("cannot decompress {}", path.display()))?;
    let (unit, scans) = parse_log(&text, unit).with_context(|| format!("in {}", path.display()))?;
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

/// One parsed but not yet unit-resolved `FLASER` line.
struct RawScan {
    line: usize,
    variant: Variant,
    /// Each range as the f32 nearest its decimal text, and as f64 (for the code).
    values: Vec<(f32, f64)>,
    meta: ScanMeta,
}

/// Parse the text of a log. Errors name the 1-based line number.
pub fn parse_log(text: &[u8], mode: UnitMode) -> Result<(Unit, Vec<Scan>)> {
    let mut raw = Vec::new();
    let mut saw_three_decimals = false;
    for (k, line) in text.split(|&b| b == b'\n').enumerate() {
        let number = k + 1;
        let first = line
            .split(|b| b.is_ascii_whitespace())
            .find(|w| !w.is_empty());
        if first != Some(b"FLASER".as_slice()) {
            continue;
        }
        let line = std::str::from_utf8(line)
            .map_err(|_| anyhow::anyhow!("line {number}: FLASER line is not valid UTF-8"))?;
        let scan = parse_flaser(line, number, &mut saw_three_decimals)
            .with_context(|| format!("line {number}"))?;
        raw.push(scan);
    }
    let unit = match mode {
        UnitMode::Centimetre => Unit::Centimetre,
        UnitMode::Millimetre => Unit::Millimetre,
        UnitMode::Auto if saw_three_decimals => Unit::Millimetre,
        UnitMode::Auto => Unit::Centimetre,
    };
    let scans = raw
        .into_iter()
        .enumerate()
        .map(|(index, r)| {
            let frame = build_frame(&r, unit).with_context(|| format!("line {}", r.line))?;
            Ok(Scan {
                index,
                line: r.line,
                frame,
                meta: r.meta,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((unit, scans))
}

fn parse_flaser(line: &str, number: usize, three_decimals: &mut bool) -> Result<RawScan> {
    let fields: Vec<&str> = line.split_ascii_whitespace().collect();
    let n_text = fields.get(1).copied().unwrap_or("");
    let n: usize = n_text
        .parse()
        .map_err(|_| anyhow::anyhow!("malformed beam count {n_text:?} after FLASER"))?;
    let variant = variant_for_beams(n).ok_or_else(|| {
        anyhow::anyhow!("unsupported beam count n = {n} (supported: {SUPPORTED_BEAMS:?})")
    })?;
    // FLASER n, n ranges, 6 pose values, ipc time, host, logger time.
    let expected = 2 + n + 9;
    if fields.len() != expected {
        bail!(
            "FLASER n = {n} but the line has {} values after n (expected {n} ranges + 9 pose/time fields = {})",
            fields.len() - 2,
            n + 9
        );
    }
    let mut values = Vec::with_capacity(n);
    for (j, text) in fields[2..2 + n].iter().enumerate() {
        let v: f64 = text
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| anyhow::anyhow!("malformed number {text:?} for range {j}"))?;
        if v < 0.0 {
            bail!("negative range {text} for beam {j}");
        }
        if decimals(text) >= 3 {
            *three_decimals = true;
        }
        // Parsed as f32 directly: the correctly rounded f32 of the decimal.
        let metres: f32 = text.parse().unwrap_or(v as f32);
        values.push((metres, v));
    }
    let num = |i: usize| -> Result<f64> {
        let text = fields[2 + n + i];
        text.parse::<f64>()
            .map_err(|_| anyhow::anyhow!("malformed number {text:?} in the pose/time fields"))
    };
    let meta = ScanMeta {
        pose: [num(0)?, num(1)?, num(2)?],
        odom: [num(3)?, num(4)?, num(5)?],
        ipc_timestamp: num(6)?,
        hostname: fields[2 + n + 7].to_string(),
        logger_timestamp: num(8)?,
    };
    Ok(RawScan {
        line: number,
        variant,
        values,
        meta,
    })
}

/// Digits after the decimal point (before any exponent).
fn decimals(text: &str) -> usize {
    match text.split_once('.') {
        Some((_, frac)) => frac.bytes().take_while(u8::is_ascii_digit).count(),
        None => 0,
    }
}

fn build_frame(raw: &RawScan, unit: Unit) -> Result<Frame> {
    let mut frame = Frame::new(raw.variant.geometry(), raw.values.len())
        .map_err(|e| anyhow::anyhow!("cannot build a frame: {e}"))?;
    for (j, &(metres, v)) in raw.values.iter().enumerate() {
        let code = (v * unit.per_metre()).round() as i64;
        if code > unit.all_ones() {
            bail!(
                "range {v} m of beam {j} is above the largest LMS value {} {unit} for a {unit} log",
                unit.all_ones()
            );
        }
        if code >= unit.first_error_code() {
            let offset = (unit.all_ones() - code) as u16;
            frame.set_invalid(j, Invalid::from_code_offset(offset));
        } else {
            frame.set_metres(j, metres);
        }
    }
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lms_core::Beam;

    fn line(n: usize, ranges: &str) -> String {
        format!("FLASER {n} {ranges} 1 2 0.5 1 2 0.5 12.5 host 12.6\n")
    }

    #[test]
    fn parses_cm_codes_and_geometry() {
        let mut r = vec!["1.00"; 181];
        r[3] = "81.91";
        r[4] = "81.83";
        r[5] = "0";
        r[6] = "32.76";
        let text = format!("PARAM x 1\n{}", line(181, &r.join(" ")));
        let (unit, scans) = parse_log(text.as_bytes(), UnitMode::Auto).unwrap();
        assert_eq!(unit, Unit::Centimetre);
        assert_eq!(scans.len(), 1);
        let f = &scans[0].frame;
        assert_eq!(scans[0].line, 2);
        assert_eq!(f.geometry(), Variant::Fov180Res100.geometry());
        assert_eq!(f.beams()[3], Beam::Invalid(Invalid::NoEcho));
        assert_eq!(f.beams()[4], Beam::Invalid(Invalid::AboveMax));
        assert_eq!(f.beams()[5], Beam::Invalid(Invalid::Zero));
        assert_eq!(f.beams()[6], Beam::Valid);
        assert_eq!(f.ranges()[6], 32.76f32);
        assert_eq!(scans[0].meta.pose, [1.0, 2.0, 0.5]);
    }

    #[test]
    fn detects_mm_logs() {
        let mut r = vec!["1.5"; 181];
        r[0] = "1.234";
        r[1] = "32.767";
        r[2] = "32.76"; // 32760 mm = offset 7
        r[3] = "32.759";
        let (unit, scans) = parse_log(line(181, &r.join(" ")).as_bytes(), UnitMode::Auto).unwrap();
        assert_eq!(unit, Unit::Millimetre);
        let b = scans[0].frame.beams();
        assert_eq!(b[0], Beam::Valid);
        assert_eq!(b[1], Beam::Invalid(Invalid::NoEcho));
        assert_eq!(b[2], Beam::Invalid(Invalid::OtherCode(7)));
        assert_eq!(b[3], Beam::Invalid(Invalid::AboveMax));
        assert_eq!(b[4], Beam::Valid);
    }

    #[test]
    fn beam_counts_and_geometry() {
        for (n, fov) in [(180, 180), (360, 180), (101, 100), (201, 100), (401, 100)] {
            let r = vec!["2"; n].join(" ");
            let (_, scans) = parse_log(line(n, &r).as_bytes(), UnitMode::Auto).unwrap();
            let g = scans[0].frame.geometry();
            let first = -(fov as f32 / 2.0).to_radians();
            assert!((g.first_bearing - first).abs() < 1e-6, "n = {n}");
            assert_eq!(scans[0].frame.len(), n);
        }
        let r = vec!["2"; 182].join(" ");
        let err = parse_log(line(182, &r).as_bytes(), UnitMode::Auto).unwrap_err();
        assert!(format!("{err:#}").contains("unsupported beam count n = 182"));
    }

    #[test]
    fn errors_name_the_line() {
        let r = vec!["2"; 181];
        let mut bad = r.clone();
        bad[7] = "2.x";
        let text = format!(
            "# c\n{}{}",
            line(181, &r.join(" ")),
            line(181, &bad.join(" "))
        );
        let err = format!(
            "{:#}",
            parse_log(text.as_bytes(), UnitMode::Auto).unwrap_err()
        );
        assert!(err.contains("line 3"), "{err}");
        assert!(err.contains("malformed number \"2.x\""), "{err}");

        let text = line(181, &r[..180].join(" "));
        let err = format!(
            "{:#}",
            parse_log(text.as_bytes(), UnitMode::Auto).unwrap_err()
        );
        assert!(err.contains("line 1") && err.contains("n = 181"), "{err}");

        let mut big = r.clone();
        big[0] = "90.00";
        let err = format!(
            "{:#}",
            parse_log(line(181, &big.join(" ")).as_bytes(), UnitMode::Auto).unwrap_err()
        );
        assert!(err.contains("line 1") && err.contains("above"), "{err}");
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
