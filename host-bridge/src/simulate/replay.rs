//! [`ReplaySource`]: the scans of a CARMEN log or of a capture, in order,
//! looping, resampled to the variant the client asks for.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use lms_core::device::emulator::ScanSource;
use lms_core::{Frame, Unit, Variant};

use super::source::variant_name;
use crate::carmen;
use crate::resample::{self, field};
/// The scans of a CARMEN log as a scan source (see the module docs).
#[derive(Debug)]
pub struct ReplaySource {
    path: PathBuf,
    scans: Vec<Frame>,
    /// The variant of the log's beams, and its beam count (180 and 360 are
    /// CARMEN's 181/361 without the last beam).
    variant: Variant,
    beams: usize,
    next: usize,
    /// Variants already announced on stderr.
    announced: HashSet<Variant>,
    /// Times the log started again from its first scan.
    pub loops: u64,
}

impl ReplaySource {
    /// Read a capture recorded by `host-bridge scan` (recognised by its
    /// magic) or a CARMEN log (error codes per file as `carmen` decides),
    /// through [`crate::input`]: a cut file keeps its complete scans.
    pub fn open(path: &Path) -> Result<Self> {
        let mut file = crate::input::open(path, crate::options::UnitArg::Auto)?;
        let capture = *file.kind() == crate::input::Kind::Capture;
        let mut scans: Vec<Frame> = Vec::new();
        for scan in file.by_ref() {
            let scan = scan?;
            if let Some(first) = scans.first() {
                if first.len() != scan.frame.len() {
                    let at = scan
                        .line
                        .map_or_else(|| format!("scan {}", scan.index), |l| format!("line {l}"));
                    bail!(
                        "{}: {at} has {} beams, the first scan {}; one beam count per file",
                        path.display(),
                        scan.frame.len(),
                        first.len()
                    );
                }
            }
            scans.push(scan.frame);
        }
        file.warn_if_cut();
        let beams = scans.first().map_or(0, Frame::len);
        let variant = if capture {
            Variant::from_beams(beams)
        } else {
            carmen::variant_for_beams(beams)
        }
        .with_context(|| format!("{}: {beams} beams per scan", path.display()))?;
        Ok(Self::from_scans(path, scans, variant, beams))
    }

    /// Replay `scans` (of `beams` beams of `variant`) read from `path`.
    fn from_scans(path: &Path, scans: Vec<Frame>, variant: Variant, beams: usize) -> Self {
        ReplaySource {
            path: path.to_path_buf(),
            scans,
            variant,
            beams,
            next: 0,
            announced: HashSet::new(),
            loops: 0,
        }
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        format!(
            "replay of {} ({} scans of {} beams, {}, looping)",
            self.path.display(),
            self.scans.len(),
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
        if self.scans.is_empty() {
            return 0;
        }
        if self.next >= self.scans.len() {
            self.next = 0;
            self.loops += 1;
        }
        let frame = &self.scans[self.next];
        self.next += 1;
        // The log's values in the sensor's units (the core's conversion),
        // nearest beam.
        resample::frame_words(frame, self.variant, variant, units, out);
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
        src.next = 0;
        let mut half = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Centimetre, &mut half);
        for j in 0..180 {
            assert_eq!(half[2 * j], cm[j]);
            assert_eq!(half[2 * j + 1], cm[j + 1]);
        }
        src.next = 0;
        let mut narrow = [0u16; 101];
        src.next_scan(Variant::Fov100Res100, Unit::Centimetre, &mut narrow);
        assert_eq!(&narrow[..], &cm[40..=140]);

        // CSAIL: 361 beams; 1° takes every 2nd.
        let mut src = ReplaySource::open(&log_path("csail-corrected.log.gz")).unwrap();
        let mut full = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut full);
        src.next = 0;
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
}
