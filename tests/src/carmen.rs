//! A small reader of CARMEN text logs (gzip) for the real LMS scans in
//! `../shared/data/carmen/` (see `shared/data/README.md`).
//!
//! Only `FLASER` lines are read: `FLASER n r_0 … r_{n−1} x y θ …`. Readings
//! at or above the first error code of the log's range mode are invalid
//! (81.83 m for the cm mode of the CSAIL, Intel, Belgioioso and Freiburg
//! logs). Geometry: beam 0 at −90°, step 180°/(n−1) for odd `n` (181, 361),
//! 180°/n for even `n` (180, 360: those scans miss their last beam).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use flate2::read::GzDecoder;

/// The first error code of the cm range mode (8183 cm, "above the maximum").
pub const CM_MODE_FIRST_CODE: f32 = 81.83;
/// The first error code of the 32 m (mm) mode (32767 − 8 mm).
pub const MM_MODE_FIRST_CODE: f32 = 32.759;

/// One scan of a log.
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// Ranges in metres as written in the log (`f32`), error codes included.
    pub ranges: Vec<f32>,
    /// `false` where the reading is an error code (or not a positive number).
    pub valid: Vec<bool>,
}

impl Scan {
    /// Number of beams.
    pub fn len(&self) -> usize {
        self.ranges.len()
    }

    /// `true` if the scan has no beam.
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// `(first bearing, step)` in radians, as `f64`.
    pub fn geometry_f64(&self) -> (f64, f64) {
        geometry_for(self.len())
    }

    /// The same geometry in `f32` (what the core gets).
    pub fn geometry_f32(&self) -> (f32, f32) {
        let (first, step) = self.geometry_f64();
        (first as f32, step as f32)
    }
}

/// `(first bearing, step)` in radians for an `n`-beam 180° CARMEN scan.
pub fn geometry_for(n: usize) -> (f64, f64) {
    use std::f64::consts::PI;
    let step = if n % 2 == 1 {
        PI / (n as f64 - 1.0)
    } else {
        PI / n as f64
    };
    (-PI / 2.0, step)
}

/// The project's data folder: `$LMS_DATA_DIR` if set, otherwise
/// `<workspace>/../shared/data` (the layout of the work tree and of CI).
pub fn data_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("LMS_DATA_DIR") {
        return PathBuf::from(dir);
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data")
}

/// The path of a CARMEN log by its stem, e.g. `"csail-corrected"`.
pub fn log_path(stem: &str) -> PathBuf {
    data_dir().join("carmen").join(format!("{stem}.log.gz"))
}

/// Why a log could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// The file could not be opened or decompressed.
    Io(std::io::Error),
    /// A `FLASER` line is malformed (1-based line number).
    Malformed(usize),
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "reading the log: {e}"),
            ReadError::Malformed(l) => write!(f, "malformed FLASER line {l}"),
        }
    }
}

impl std::error::Error for ReadError {}

/// Parse one `FLASER` line's fields after the keyword; `None` if malformed.
pub fn parse_flaser(rest: &str, first_code: f32) -> Option<Scan> {
    let mut fields = rest.split_ascii_whitespace();
    let n: usize = fields.next()?.parse().ok()?;
    let mut ranges = Vec::with_capacity(n);
    let mut valid = Vec::with_capacity(n);
    for _ in 0..n {
        let r: f32 = fields.next()?.parse().ok()?;
        valid.push(r.is_finite() && r > 0.0 && r < first_code);
        ranges.push(r);
    }
    Some(Scan { ranges, valid })
}

/// Read at most `max_frames` `FLASER` scans (all if `None`) from a gzip'd
/// CARMEN log, with readings `>= first_code` invalid.
pub fn read_log(
    path: &Path,
    first_code: f32,
    max_frames: Option<usize>,
) -> Result<Vec<Scan>, ReadError> {
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    let reader = BufReader::new(GzDecoder::new(file));
    let mut scans = Vec::new();
    for (number, line) in reader.lines().enumerate() {
        if max_frames.is_some_and(|m| scans.len() >= m) {
            break;
        }
        let line = line.map_err(ReadError::Io)?;
        if let Some(rest) = line.strip_prefix("FLASER ") {
            scans.push(parse_flaser(rest, first_code).ok_or(ReadError::Malformed(number + 1))?);
        }
    }
    Ok(scans)
}

/// The first `max_frames` scans of a cm-mode log by its stem; panics with a
/// clear message if the data are missing (the tests need them).
pub fn load_cm_log(stem: &str, max_frames: usize) -> Vec<Scan> {
    let path = log_path(stem);
    read_log(&path, CM_MODE_FIRST_CODE, Some(max_frames)).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (../shared/data must sit beside the repo)",
            path.display()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flaser_lines_parse_with_error_codes_invalid() {
        let s = parse_flaser("4 1.5 81.91 81.83 81.82 0 0 0 0 0 0 1.0 host 2.0", 81.83).unwrap();
        assert_eq!(s.ranges, vec![1.5, 81.91, 81.83, 81.82]);
        assert_eq!(s.valid, vec![true, false, false, true]);
        assert!(parse_flaser("3 1.0 2.0", 81.83).is_none());
    }

    #[test]
    fn geometry_follows_the_beam_count() {
        let (first, step) = geometry_for(361);
        assert_eq!(first, -std::f64::consts::FRAC_PI_2);
        assert!((step - 0.5f64.to_radians()).abs() < 1e-15);
        assert!((geometry_for(180).1 - 1f64.to_radians()).abs() < 1e-15);
        assert!((geometry_for(181).1 - 1f64.to_radians()).abs() < 1e-15);
    }
}
