//! [`Source`]: where `simulate` takes its scans from.

use anyhow::Result;
use lms_core::device::emulator::ScanSource;
use lms_core::{Unit, Variant};

use super::{ReplaySource, SceneSource, SimulateArgs};

/// Where `simulate` takes its scans from.
#[derive(Debug)]
pub enum Source {
    /// The built-in synthetic scene.
    Scene(SceneSource),
    /// A CARMEN log or a capture of `host-bridge scan`.
    Replay(ReplaySource),
}

impl Source {
    /// The source the options ask for.
    pub fn open(args: &SimulateArgs) -> Result<Self> {
        match &args.play.log {
            Some(path) => Ok(Source::Replay(ReplaySource::open_topic(
                path,
                args.play.topic.name(),
            )?)),
            None => {
                let bits =
                    lms_core::telegram::RangeBits::from_measuring_mode(args.measuring_mode());
                Ok(Source::Scene(
                    SceneSource::new(&args.play.scene)?.with_range_bits(bits),
                ))
            }
        }
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        match self {
            Source::Scene(s) => s.describe(),
            Source::Replay(r) => r.describe(),
        }
    }
}

impl ScanSource for Source {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        match self {
            Source::Scene(s) => s.next_scan(variant, units, out),
            Source::Replay(r) => r.next_scan(variant, units, out),
        }
    }

    fn supports(&self, variant: Variant) -> bool {
        match self {
            Source::Scene(s) => s.supports(variant),
            Source::Replay(r) => r.supports(variant),
        }
    }
}
