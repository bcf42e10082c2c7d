//! Every feature of every frame of a CARMEN log as raw IEEE-754 bits, one
//! line per item, so that two builds can be compared with `cmp` and a
//! whole log's results pinned by one digest.
//!
//! The log is read through the one reader's line layer
//! ([`lms_core::carmen::Flaser`], the unit decided per file by
//! [`lms_core::carmen::UnitVote`]), in two streaming passes; the pipeline
//! runs with the ALGORITHM.md defaults and the given number of passes.
//!
//! The text per frame: `frame k` and the smoothed ranges, then `D` per
//! window, `edges […]`, `segments […]`, one `line first last points
//! [10 × f32 bits]` per line, one `corner a b well [6 × f32 bits]` per
//! corner, and `stats {…}`.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::Path;

use lms_core::carmen::{is_flaser, Flaser, UnitVote};
use lms_core::{DataSurvey, Extractor, Frame, Params, Trace, Unit, Variant};

/// Open a log, gzip-compressed (by its magic bytes) or plain.
pub fn open(path: &Path) -> io::Result<Box<dyn BufRead>> {
    let mut file = BufReader::new(File::open(path)?);
    let gzip = file.fill_buf()?.starts_with(&[0x1f, 0x8b]);
    Ok(if gzip {
        Box::new(BufReader::new(flate2::read::GzDecoder::new(file)))
    } else {
        Box::new(file)
    })
}

/// Call `each` with every `FLASER` line of the log at `path`, in order.
fn for_each_flaser(
    path: &Path,
    mut each: impl FnMut(&Flaser<'_>) -> io::Result<()>,
) -> io::Result<()> {
    let mut input = open(path)?;
    let mut line = String::new();
    let mut number = 0usize;
    loop {
        line.clear();
        if input.read_line(&mut line)? == 0 {
            return Ok(());
        }
        number += 1;
        if !is_flaser(line.as_bytes()) {
            continue;
        }
        let flaser = Flaser::parse(line.trim_end()).map_err(|e| bad_line(path, number, e))?;
        each(&flaser)?;
    }
}

fn bad_line(path: &Path, number: usize, e: impl std::fmt::Display) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("{}: line {number}: {e}", path.display()),
    )
}

/// The unit of the log at `path` (the first pass).
pub fn log_unit(path: &Path) -> io::Result<Unit> {
    let mut vote = UnitVote::default();
    for_each_flaser(path, |f| {
        vote.observe(f);
        Ok(())
    })?;
    Ok(vote.unit())
}

/// Write the bits of every frame of the log at `path` after `iterations`
/// smoothing passes to `out`; returns the number of frames.
pub fn write_log_bits(path: &Path, iterations: u16, out: &mut impl Write) -> io::Result<usize> {
    let params = Params::default().with_iterations(iterations);
    write_log_bits_with(path, &params, out)
}

/// The parameters `host-bridge extract LOG` uses with no flags: the whole
/// log surveyed ([`DataSurvey`]), σ and `max_range`
/// from its [`lms_core::DataProfile`], everything else the defaults.
pub fn per_data_params(path: &Path) -> io::Result<Params> {
    let mut survey = DataSurvey::new(log_unit(path)?);
    for_each_frame(path, |_, frame| {
        survey.add(frame);
        Ok(())
    })?;
    Ok(survey.profile().params())
}

/// Call `each` with the index and the frame of every scan of the log at
/// `path`, filled in the log's unit ([`log_unit`]); returns the number of
/// frames.
fn for_each_frame(
    path: &Path,
    mut each: impl FnMut(usize, &Frame) -> io::Result<()>,
) -> io::Result<usize> {
    let unit = log_unit(path)?;
    let mut frame = Frame::for_variant(Variant::Fov180Res50);
    let mut index = 0usize;
    for_each_flaser(path, |f| {
        f.fill(unit, &mut frame)
            .map_err(|e| bad_line(path, index, e))?;
        each(index, &frame)?;
        index += 1;
        Ok(())
    })?;
    Ok(index)
}

/// As [`write_log_bits`], with the given parameters (validated first).
pub fn write_log_bits_with(
    path: &Path,
    params: &Params,
    out: &mut impl Write,
) -> io::Result<usize> {
    let params = params
        .validate()
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
    let mut extractor = Extractor::new();
    let mut trace = Trace::new();
    for_each_frame(path, |index, frame| {
        extractor.run_traced(frame, &params, &mut trace);
        write_frame_bits(index, &extractor, &trace, out)
    })
}

/// The bits of the extractor's last run as frame `index`.
pub fn write_frame_bits(
    index: usize,
    extractor: &Extractor,
    trace: &Trace,
    out: &mut impl Write,
) -> io::Result<()> {
    let f = extractor.features();
    write!(out, "frame {index}")?;
    for x in extractor.smoothed() {
        write!(out, " {:08x}", x.to_bits())?;
    }
    writeln!(out)?;
    for x in trace.mahalanobis() {
        write!(out, " {:08x}", x.to_bits())?;
    }
    writeln!(out)?;
    writeln!(out, "edges {:?}", f.edges())?;
    writeln!(out, "segments {:?}", f.segments())?;
    for l in f.lines() {
        let bits = l.floats().map(f32::to_bits);
        writeln!(out, "line {} {} {} {bits:08x?}", l.first, l.last, l.points)?;
    }
    for c in f.corners() {
        let bits = c.floats().map(f32::to_bits);
        writeln!(
            out,
            "corner {} {} {} {bits:08x?}",
            c.line_a, c.line_b, c.well_conditioned
        )?;
    }
    writeln!(out, "stats {:?}", f.stats())
}

/// FNV-1a (64 bit) of everything written: a digest that pins a whole
/// log's output in one number.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(pub u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Write for Fnv64 {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// The FNV-1a digest of a reader's bytes (e.g. a whole JSON output).
pub fn digest_of(mut input: impl Read) -> io::Result<u64> {
    let mut d = Fnv64::default();
    io::copy(&mut input, &mut d)?;
    Ok(d.0)
}
