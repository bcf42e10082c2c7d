//! The options of `host-bridge verify`.

use std::path::PathBuf;

use clap::Args;

use crate::options::{FrameRange, ParamArgs};
use crate::synthetic::SceneArgs;

/// Default firmware ELF (relative to the working directory, then to the
/// source tree).
pub const DEFAULT_ELF: &str = "firmware/target/thumbv7em-none-eabihf/release/lms-firmware";

/// Options of `host-bridge verify`.
#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// Run the firmware ELF under QEMU (netduinoplus2) [default ELF:
    /// firmware/target/thumbv7em-none-eabihf/release/lms-firmware]
    #[arg(long, value_name = "ELF", num_args = 0..=1, conflicts_with_all = ["host", "ports"])]
    pub qemu: Option<Option<PathBuf>>,
    /// Run the co-processor natively in a thread behind two pseudo-terminals
    /// (the default)
    #[arg(long, conflicts_with = "ports")]
    pub host: bool,
    /// Two serial ports wired to a co-processor: its host line, its sensor line
    #[arg(long, num_args = 2, value_names = ["HOST", "SENSOR"])]
    pub ports: Option<Vec<PathBuf>>,
    /// The synthetic scene (when no `--replay` log is given).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Play the FLASER frames of a CARMEN log (gzip or plain) instead of the
    /// synthetic scene
    #[arg(long = "replay", value_name = "LOG")]
    pub log: Option<PathBuf>,
    /// Frames of the log to play: A..B (B exclusive), A..=B, A.., ..B or A
    #[arg(long, value_name = "A..B", requires = "log")]
    pub frames: Option<FrameRange>,
    /// Scans to check: the first N of the selection [default: all of it]
    #[arg(long, value_name = "N")]
    pub scans: Option<usize>,
    /// Give up after this many seconds (the run then fails if fewer than
    /// --scans scans were checked)
    #[arg(long, value_name = "S", default_value_t = 60.0)]
    pub timeout: f64,
    /// Rate the client switches the host line to before streaming
    /// (9600 = no switch)
    #[arg(long, value_name = "BAUD", default_value_t = 500_000)]
    pub host_baud: u32,
    /// Hold the sensor's stream while this many scans are out and not back
    /// with features (0 = never) [default: 5 with --qemu, whose UARTs take
    /// a third of the line rate (five scans fit the firmware's 4 KiB sensor
    /// queue); else 0, as a real sensor never waits]
    #[arg(long, value_name = "N")]
    pub max_in_flight: Option<usize>,
    /// Switch the simulated LMS off and on once, after this many scans of the
    /// selection have come back (with nothing in flight): the co-processor
    /// must stream again by itself within one second (recovery test)
    #[arg(long, value_name = "N")]
    pub power_cycle_sensor_after: Option<usize>,
    /// Pipeline parameters: the co-processor's in --host mode; in every mode
    /// those the D0 summary does not echo (min points, max chi2, merging)
    #[command(flatten)]
    pub params: ParamArgs,
    /// Log the phases of the run and the sensor-side requests on stderr
    #[arg(long, short)]
    pub verbose: bool,
    /// Testing only: recompute with this tau instead of the echoed one (so
    /// that the check must fail)
    #[arg(long, hide = true, value_name = "T", allow_negative_numbers = true)]
    pub recompute_tau: Option<f32>,
}
