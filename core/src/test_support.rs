//! What the tests, benches and examples of the workspace and the fuzz
//! crate share (feature `test-support`, which implies `std`; the product
//! never enables it), the way a storage crate ships its mock flash:
//!
//! * [`Port`]: one direction of a serial line in memory
//!   (`embedded-io` `Read + ReadReady + Write`);
//! * [`Rng`]: a seeded xorshift64* generator, so runs repeat exactly;
//! * [`open_log`] / [`log_path`]: the shared CARMEN logs
//!   (`../shared/data/carmen/*.log.gz`) through the one reader,
//!   [`crate::carmen`] (gzip decided by the magic bytes).
//!
//! Use it from a crate's tests, benches and examples with a dev-dependency
//! on the core with the feature, e.g. in `core/Cargo.toml` itself:
//! `[dev-dependencies] lms-core = { path = ".", features = ["test-support"] }`.

use std::collections::VecDeque;
use std::convert::Infallible;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use crate::carmen::{decide_unit, ReadError, Reader};
use crate::Params;

/// Preset `v3.1` (the defaults at v2's scale: 30 passes, τ = 9) with the
/// windows of ALGORITHM.md v2 §2–6 (consecutive beams over both mirror
/// turns) in every mode, and the additions measured on top of same-turn
/// windows left out: no work bound on split before reject, no anchor gate
/// on the merges, no turn offsets in the fits' χ², and pairs of lines kept
/// whatever a circle says of them. The tests that check the windows of
/// §2–6 on interleaved scans run with it.
pub const CONSECUTIVE_WINDOWS: Params = Params {
    same_turn_windows: false,
    split_budget: 0,
    merge_anchor_gate: f32::INFINITY,
    turn_offsets: false,
    arc_pairs: false,
    ..Params::V3_1
};

/// One direction of a serial line in memory: the device reads `rx` and
/// writes `tx`. Reads and writes allocate only when a buffer outgrows its
/// capacity ([`Port::with_capacity`] reserves it up front).
#[derive(Default)]
pub struct Port {
    /// Bytes waiting to be read.
    pub rx: VecDeque<u8>,
    /// Bytes written.
    pub tx: Vec<u8>,
}

impl Port {
    /// A port whose `rx` and `tx` each hold `bytes` without allocating.
    pub fn with_capacity(bytes: usize) -> Self {
        Port {
            rx: VecDeque::with_capacity(bytes),
            tx: Vec::with_capacity(bytes),
        }
    }

    /// Move up to `out.len()` written bytes, oldest first, into `out`;
    /// returns how many (never allocates).
    pub fn pop_tx(&mut self, out: &mut [u8]) -> usize {
        let n = out.len().min(self.tx.len());
        for (o, b) in out.iter_mut().zip(self.tx.drain(..n)) {
            *o = b;
        }
        n
    }
}

impl embedded_io::ErrorType for Port {
    type Error = Infallible;
}

impl embedded_io::Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.rx.len());
        for (b, v) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = v;
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.is_empty())
    }
}

impl embedded_io::Write for Port {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// An in-memory port keeps whatever it is given: no limit known.
impl crate::device::coprocessor::WriteRoom for Port {
    fn write_room(&mut self) -> Result<usize, Infallible> {
        Ok(usize::MAX)
    }
}

/// xorshift64*: a small deterministic generator (the seed must not be 0).
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[0, 1)` (53 bits).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// In `0..n` (0 for `n` = 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// A standard normal draw (Box–Muller, the cosine of the pair; two
    /// `unit` draws).
    pub fn normal(&mut self) -> f64 {
        let u = self.unit().max(f64::MIN_POSITIVE);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.unit()).cos()
    }

    /// Events of probability `p` per trial: the trials until the next one
    /// (geometric; `u64::MAX` for `p ≤ 0`).
    pub fn gap(&mut self, p: f64) -> u64 {
        if p <= 0.0 {
            return u64::MAX;
        }
        let u = self.unit().max(f64::MIN_POSITIVE);
        (u.ln() / (1.0 - p).ln()).floor() as u64
    }
}

/// The project's data folder: `$LMS_DATA_DIR` if set, otherwise
/// `../shared/data` beside the workspace (the layout of the work tree and
/// of CI).
pub fn data_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("LMS_DATA_DIR") {
        return PathBuf::from(dir);
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data")
}

/// The path of a shared CARMEN log by its stem, e.g. `"csail-corrected"`.
pub fn log_path(stem: &str) -> PathBuf {
    data_dir().join("carmen").join(format!("{stem}.log.gz"))
}

/// A log file's text, gunzipped if it starts with the gzip magic `1f 8b`.
pub fn open_text(path: &Path) -> std::io::Result<Box<dyn BufRead>> {
    let mut file = BufReader::new(File::open(path)?);
    let gzip = file.fill_buf()?.starts_with(&[0x1f, 0x8b]);
    Ok(if gzip {
        Box::new(BufReader::new(flate2::bufread::MultiGzDecoder::new(file)))
    } else {
        Box::new(file)
    })
}

/// The scans of a CARMEN log (gzip or plain), streamed through the one
/// reader, error codes in the log's own unit ([`decide_unit`]: a first
/// pass over the file).
pub fn open_log(path: &Path) -> Result<Reader<Box<dyn BufRead>>, ReadError> {
    let unit = decide_unit(open_text(path).map_err(ReadError::Io)?)?;
    Ok(Reader::new(open_text(path).map_err(ReadError::Io)?, unit))
}

/// The first `max` scans' frames of a shared log by its stem; panics
/// with a clear message if the data are missing (the tests need them).
pub fn load_frames(stem: &str, max: usize) -> Vec<crate::Frame> {
    let path = log_path(stem);
    let fail = |e: ReadError| -> ! {
        panic!(
            "{}: {e} (../shared/data must sit beside the repo)",
            path.display()
        )
    };
    let reader = open_log(&path).unwrap_or_else(|e| fail(e));
    reader
        .take(max)
        .map(|s| s.map(|s| s.frame).unwrap_or_else(|e| fail(e)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    #[test]
    fn the_generator_repeats_and_stays_in_range() {
        let (mut a, mut b) = (Rng(42), Rng(42));
        assert!((0..100).all(|_| a.next_u64() == b.next_u64()));
        assert!((0..1000).all(|_| a.below(7) < 7 && (0.0..1.0).contains(&a.unit())));
        assert_eq!(a.below(0), 0);
        assert_eq!(a.gap(0.0), u64::MAX);
    }

    #[test]
    fn the_port_reads_what_was_queued() {
        use embedded_io::{Read, ReadReady, Write};
        let mut p = Port::with_capacity(8);
        assert!(!p.read_ready().unwrap());
        p.rx.extend([1, 2, 3]);
        let mut buf = [0u8; 2];
        assert_eq!(p.read(&mut buf).unwrap(), 2);
        assert_eq!(buf, [1, 2]);
        assert!(p.read_ready().unwrap());
        p.write_all(&[9, 8, 7]).unwrap();
        assert_eq!(p.pop_tx(&mut buf), 2);
        assert_eq!((buf, p.tx.as_slice()), ([9, 8], &[7][..]));
    }

    #[test]
    fn plain_and_gzip_logs_read_alike() {
        let text = format!(
            "FLASER 361 {} 0 0 0 0 0 0 1.5 host 1.5\n",
            vec!["3.25"; 361].join(" ")
        );
        let dir = std::env::temp_dir().join(format!("lms-core-ts-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (plain, gz) = (dir.join("a.log"), dir.join("a.log.gz"));
        std::fs::write(&plain, &text).unwrap();
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(text.as_bytes()).unwrap();
        std::fs::write(&gz, enc.finish().unwrap()).unwrap();
        let mut a = String::new();
        open_text(&gz).unwrap().read_to_string(&mut a).unwrap();
        assert_eq!(a, text);
        let frames = |p: &Path| -> Vec<Vec<f32>> {
            open_log(p)
                .unwrap()
                .map(|s| s.unwrap().frame.ranges().to_vec())
                .collect()
        };
        assert_eq!(frames(&plain), frames(&gz));
        assert_eq!(frames(&gz).len(), 1);
        let _ = std::fs::remove_dir_all(dir);
    }
}
