//! Print every feature of every frame of a CARMEN log as raw IEEE-754 bits,
//! one line per item, so two builds can be compared with `cmp`.
//!
//! `.ci/run` runs it with and without the `std` feature and requires
//! byte-identical output (ALGORITHM.md §9: `std` changes no numeric path).
//!
//! Usage: `cargo run -p lms-core --example feature_bits [--features std] -- LOG.gz [ITERATIONS]`
//!
//! It parses the log itself rather than through the one reader,
//! `lms_core::carmen`, on purpose: its output is a recorded baseline, and
//! the reader would change it — the reader's bearing step is
//! `Variant::geometry`'s (`0x3c0efa36` for 0.5°, `0x3c8efa36` for 1°; here
//! `(180°/n).to_radians()`, one ulp less: `0x3c0efa35`, `0x3c8efa35`), and
//! it reads the Örebro log in mm, where 32.759 … 32.767 m are error codes
//! (here distances below 81.83 m).

use std::io::{BufRead, BufReader, Write};

use lms_core::{Extractor, Frame, Geometry, Params};

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "../shared/data/carmen/csail-corrected.log.gz".to_string());
    let iterations: u16 = args
        .next()
        .map_or(30, |s| s.parse().expect("ITERATIONS must be a number"));
    let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("cannot open {path}: {e}"));
    let reader = BufReader::new(flate2::read::GzDecoder::new(file));
    let params = Params {
        iterations,
        ..Params::default()
    };
    let mut extractor = Extractor::new();
    let out = std::io::stdout();
    let mut out = out.lock();
    let mut frame_index = 0usize;
    for line in reader.lines() {
        let line = line.expect("read error");
        let mut fields = line.split_ascii_whitespace();
        if fields.next() != Some("FLASER") {
            continue;
        }
        let n: usize = fields
            .next()
            .and_then(|s| s.parse().ok())
            .expect("beam count");
        let ranges: Vec<f32> = fields.take(n).map(|s| s.parse().expect("range")).collect();
        let step = if n % 2 == 1 {
            180.0 / (n - 1) as f32
        } else {
            180.0 / n as f32
        };
        let geometry = Geometry {
            first_bearing: -core::f32::consts::FRAC_PI_2,
            step: step.to_radians(),
        };
        let mut frame = Frame::from_metres(geometry, &ranges).expect("frame");
        for (j, &r) in ranges.iter().enumerate() {
            if r >= 81.83 {
                frame.set_invalid(j, lms_core::Invalid::NoEcho);
            }
        }
        extractor.run(&frame, &params.validate().expect("params"));
        let f = extractor.features();
        write!(out, "frame {frame_index}").unwrap();
        for x in extractor.smoothed() {
            write!(out, " {:08x}", x.to_bits()).unwrap();
        }
        writeln!(out).unwrap();
        for x in extractor.mahalanobis() {
            write!(out, " {:08x}", x.to_bits()).unwrap();
        }
        writeln!(out).unwrap();
        writeln!(out, "edges {:?}", f.edges()).unwrap();
        writeln!(out, "segments {:?}", f.segments()).unwrap();
        for l in f.lines() {
            let v = l.floats();
            writeln!(
                out,
                "line {} {} {} {:08x?}",
                l.first,
                l.last,
                l.points,
                v.map(f32::to_bits)
            )
            .unwrap();
        }
        for c in f.corners() {
            let v = [c.x, c.y, c.cov.a, c.cov.b, c.cov.c, c.angle_deg];
            writeln!(
                out,
                "corner {} {} {} {:08x?}",
                c.line_a,
                c.line_b,
                c.well_conditioned,
                v.map(f32::to_bits)
            )
            .unwrap();
        }
        writeln!(out, "stats {:?}", f.stats()).unwrap();
        frame_index += 1;
    }
}
