//! [`ReplaySource`]: the scans of a CARMEN log or of a capture, in order,
//! looping, resampled to the variant the client asks for.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lms_core::device::emulator::ScanSource;
use lms_core::{Frame, Unit, Variant};

use crate::carmen;
use crate::input::{self, Kind, ScanFile};
use crate::options::UnitArg;
use crate::resample::{self, field};
use crate::scan::variant_name;
use crate::warning::warn;

/// The scans of a CARMEN log or a capture as a scan source (see the
/// module docs), streamed: one scan in memory, the file read again from
/// the start at its end. Input that cannot be read twice (a pipe, a FIFO,
/// standard input `-`) is read once and its scans kept in memory (about
/// 2 KB a 361-beam scan), to loop over them.
pub struct ReplaySource {
    path: PathBuf,
    /// The topic of a ROS 2 bag (`None`: its only LaserScan topic).
    topic: Option<String>,
    file: Box<ScanFile>,
    /// The scans of input that cannot be read again, and the next one.
    held: Option<(Vec<Frame>, usize)>,
    /// The scan sent last (sent again if the file cannot be read again).
    current: Box<Frame>,
    /// Scans in the file (counted by the first pass).
    scans: usize,
    /// The variant of the file's beams, and its beam count (180 and 360 are
    /// CARMEN's 181/361 without the last beam).
    variant: Variant,
    beams: usize,
    /// Variants already announced on stderr.
    announced: HashSet<Variant>,
    /// Times the log started again from its first scan.
    pub loops: u64,
}

impl std::fmt::Debug for ReplaySource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReplaySource")
            .field("path", &self.path)
            .field("scans", &self.scans)
            .field("variant", &self.variant)
            .field("loops", &self.loops)
            .finish()
    }
}

/// The log, capture or bag at `path`, its unit decided per file.
fn open_input(path: &Path, topic: Option<&str>) -> Result<ScanFile> {
    let options = input::ReadOptions {
        unit: UnitArg::Auto,
        keep_damaged: false,
    };
    input::open_topic(path, options, topic)
}

/// `true` for a regular file or a folder (a rosbag2 bag): input that can
/// be opened again to loop; `false` for a pipe, a FIFO or standard input.
fn can_read_again(path: &Path) -> bool {
    path != Path::new("-") && std::fs::metadata(path).is_ok_and(|m| m.is_file() || m.is_dir())
}

impl ReplaySource {
    /// Read a capture recorded by `host-bridge scan` (recognised by its
    /// magic) or a CARMEN log (error codes per file as `carmen` decides),
    /// through [`crate::input`]: a first pass checks that every scan has the
    /// first one's beam count (a cut file keeps its complete scans), then
    /// the scans are streamed.
    pub fn open(path: &Path) -> Result<Self> {
        ReplaySource::open_topic(path, None)
    }

    /// [`ReplaySource::open`] reading `topic` of a ROS 2 bag (`None`: the
    /// bag's only LaserScan topic).
    pub fn open_topic(path: &Path, topic: Option<&str>) -> Result<Self> {
        let mut file = open_input(path, topic)?;
        let capture = *file.kind() == Kind::Capture;
        let first = file
            .next()
            .with_context(|| format!("{}: no scans", path.display()))??;
        let beams = first.frame.len();
        let mut held = (!can_read_again(path)).then(|| vec![first.frame.clone()]);
        for scan in file.by_ref() {
            let scan = scan?;
            if scan.frame.len() != beams {
                let at = scan
                    .line
                    .map_or_else(|| format!("scan {}", scan.index), |l| format!("line {l}"));
                bail!(
                    "{}: {at} has {} beams, the first scan {beams}; one beam count per file",
                    path.display(),
                    scan.frame.len()
                );
            }
            if let Some(held) = held.as_mut() {
                held.push(scan.frame);
            }
        }
        file.warn_if_cut();
        let scans = file.read();
        let variant = if capture {
            Variant::from_beams(beams)
        } else {
            carmen::variant_for_beams(beams)
        }
        .with_context(|| format!("{}: {beams} beams per scan", path.display()))?;
        let (file, held) = match held {
            // From the first scan, as a file opened again.
            Some(frames) => (file, Some((frames, 0))),
            None => (open_input(path, topic)?, None),
        };
        Ok(ReplaySource {
            path: path.to_path_buf(),
            topic: topic.map(str::to_owned),
            file: Box::new(file),
            held,
            current: Box::new(first.frame),
            scans,
            variant,
            beams,
            announced: HashSet::new(),
            loops: 0,
        })
    }

    /// Start again from the first scan.
    fn rewind(&mut self) {
        match open_input(&self.path, self.topic.as_deref()) {
            Ok(f) => *self.file = f,
            Err(e) => warn(&format!("replay: {e:#}; the last scan is sent again")),
        }
    }

    /// The index of the next held scan (input read once), from the first
    /// again after the last; `None` for a file read again.
    fn next_held(&mut self) -> Option<usize> {
        let (frames, next) = self.held.as_mut()?;
        if *next >= frames.len() {
            *next = 0;
            self.loops += 1;
        }
        *next += 1;
        Some(*next - 1)
    }

    /// The next scan of the file, from the start again after the last.
    fn next_frame(&mut self) -> &Frame {
        if let Some(i) = self.next_held() {
            if let Some((frames, _)) = &self.held {
                (*self.current).clone_from(&frames[i]);
            }
            return &self.current;
        }
        for _ in 0..2 {
            match self.file.next() {
                Some(Ok(scan)) if scan.frame.len() == self.beams => {
                    *self.current = scan.frame;
                    return &self.current;
                }
                Some(Ok(_)) | Some(Err(_)) | None => {
                    self.rewind();
                    self.loops += 1;
                }
            }
        }
        &self.current
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        format!(
            "replay of {} ({} scans of {} beams, {}, looping)",
            self.path.display(),
            self.scans,
            self.beams,
            variant_name(self.variant)
        )
    }

    /// Say once per variant how the log's scans are turned into it.
    fn announce(&mut self, target: Variant) {
        if target == self.variant && self.beams == target.beams() {
            return;
        }
        if !self.announced.insert(target) {
            return;
        }
        let (_, res_s) = field(self.variant);
        let (_, res_t) = field(target);
        let mut how = if res_t > res_s {
            format!("every {}th beam of the log", res_t / res_s)
        } else if res_t < res_s {
            "the nearest beam of the log, repeated".to_string()
        } else {
            "the log's beams".to_string()
        };
        if target.fov_deg() < self.variant.fov_deg() {
            how.push_str(", 40°…140° only");
        }
        if self.beams < self.variant.beams() {
            how.push_str("; the 180° beam the log lacks is sent as not valid (8191)");
        }
        eprintln!(
            "host-bridge simulate: replay: the log has {}; {} scans are resampled: {how}",
            variant_name(self.variant),
            variant_name(target)
        );
    }
}

impl ScanSource for ReplaySource {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        self.announce(variant);
        let source = self.variant;
        let frame = self.next_frame();
        // The file's values in the sensor's units (the core's conversion),
        // nearest beam.
        resample::frame_words(frame, source, variant, units, out);
        out.len()
    }

    fn supports(&self, variant: Variant) -> bool {
        resample::covers(self.variant, variant)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn log_path(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/data/carmen")
            .join(name)
    }

    #[test]
    fn replay_resamples_and_refuses() {
        // Intel: 180 beams at 1° (the 181st missing).
        let mut src = ReplaySource::open(&log_path("intel-corrected.log.gz")).unwrap();
        assert_eq!(src.variant, Variant::Fov180Res100);
        assert!(Variant::ALL.iter().all(|&v| src.supports(v)));
        let mut cm = [0u16; 181];
        src.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut cm);
        assert_eq!(cm[180], 8191);
        // Second scan at 0.5°: even beams are the log's, odd ones repeat
        // the next.
        src.rewind();
        let mut half = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Centimetre, &mut half);
        for j in 0..180 {
            assert_eq!(half[2 * j], cm[j]);
            assert_eq!(half[2 * j + 1], cm[j + 1]);
        }
        src.rewind();
        let mut narrow = [0u16; 101];
        src.next_scan(Variant::Fov100Res100, Unit::Centimetre, &mut narrow);
        assert_eq!(&narrow[..], &cm[40..=140]);

        // CSAIL: 361 beams; 1° takes every 2nd.
        let mut src = ReplaySource::open(&log_path("csail-corrected.log.gz")).unwrap();
        let mut full = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut full);
        src.rewind();
        let mut coarse = [0u16; 181];
        src.next_scan(Variant::Fov180Res100, Unit::Millimetre, &mut coarse);
        for j in 0..181 {
            assert_eq!(coarse[j], full[2 * j]);
        }

        // A 100° log cannot give 180°.
        let src = ReplaySource {
            variant: Variant::Fov100Res50,
            beams: 201,
            ..src
        };
        assert!(!src.supports(Variant::Fov180Res50));
        assert!(src.supports(Variant::Fov100Res25));
    }

    /// A log on a pipe (standard input, a FIFO) is read once and looped
    /// from memory, scan for scan as the file.
    #[test]
    fn replay_of_a_fifo_loops_as_the_file() {
        let dir = std::env::temp_dir().join(format!("replay-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let line = |r: &str| format!("FLASER 181 {} 0 0 0 0 0 0 1 h 1\n", vec![r; 181].join(" "));
        let text = format!("{}{}{}", line("1.50"), line("2.50"), line("3.50"));
        let file = dir.join("log.log");
        std::fs::write(&file, &text).unwrap();
        let fifo = dir.join("log.fifo");
        let _ = std::fs::remove_file(&fifo);
        nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
        let writer = {
            let (fifo, text) = (fifo.clone(), text.clone());
            std::thread::spawn(move || std::fs::write(fifo, text).unwrap())
        };
        let mut piped = ReplaySource::open(&fifo).unwrap();
        writer.join().unwrap();
        let mut from_file = ReplaySource::open(&file).unwrap();
        assert_eq!(piped.scans, 3);
        let (mut a, mut b) = ([0u16; 181], [0u16; 181]);
        for _ in 0..7 {
            piped.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut a);
            from_file.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut b);
            assert_eq!(a, b);
        }
        assert_eq!((piped.loops, from_file.loops), (2, 2));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A cut log is replayed with its complete scans, looping, one scan in
    /// memory.
    #[test]
    fn replay_of_a_cut_log_loops_over_its_complete_scans() {
        let dir = std::env::temp_dir().join(format!("replay-cut-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let line = |r: &str| format!("FLASER 181 {} 0 0 0 0 0 0 1 h 1\n", vec![r; 181].join(" "));
        let text = format!("{}{}{}", line("1.50"), line("2.50"), line("3.50"));
        let path = dir.join("cut.log");
        std::fs::write(&path, &text[..text.len() - 400]).unwrap();
        let mut src = ReplaySource::open(&path).unwrap();
        assert_eq!(src.scans, 2);
        let mut out = [0u16; 181];
        let mut firsts = Vec::new();
        for _ in 0..5 {
            src.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut out);
            firsts.push(out[0]);
        }
        assert_eq!(firsts, [150, 250, 150, 250, 150]);
        assert_eq!(src.loops, 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
