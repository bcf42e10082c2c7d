//! The options of `host-bridge verify`.

use std::path::PathBuf;

use clap::Args;

use crate::options::{FrameRange, ParamArgs};
use crate::qemu::DEFAULT_ELF;

/// ELF `e_machine` of 32-bit ARM (the firmware's thumbv7em).
pub const EM_ARM: u16 = 40;

/// `--qemu ELF`: a file that exists and is a 32-bit little-endian ARM ELF
/// (checked when the arguments are read: QEMU given anything else only
/// reports a lock-up).
pub fn arm_elf(s: &str) -> Result<PathBuf, String> {
    use std::io::Read;
    let path = PathBuf::from(s);
    let mut head = [0u8; 20];
    let mut file = std::fs::File::open(&path).map_err(|e| format!("cannot open {s}: {e}"))?;
    let got = file
        .read(&mut head)
        .map_err(|e| format!("cannot read {s}: {e}"))?;
    if got < head.len() || &head[..4] != b"\x7fELF" {
        return Err(format!(
            "{s} is not an ELF file (the firmware, e.g. {DEFAULT_ELF})"
        ));
    }
    let machine = u16::from_le_bytes([head[18], head[19]]);
    if head[4] != 1 || head[5] != 1 || machine != EM_ARM {
        return Err(format!(
            "{s} is not a 32-bit little-endian ARM ELF (class {}, data {}, machine {machine}; \
             the firmware is built for thumbv7em-none-eabihf, machine {EM_ARM})",
            head[4], head[5]
        ));
    }
    Ok(path)
}

/// Options of `host-bridge verify`.
#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// Run the firmware ELF under QEMU (netduinoplus2) [default ELF:
    /// firmware/target/thumbv7em-none-eabihf/release/lms-firmware]
    #[arg(long, value_name = "ELF", num_args = 0..=1, conflicts_with_all = ["host", "ports"],
          value_parser = arm_elf)]
    pub qemu: Option<Option<PathBuf>>,
    /// Run the co-processor natively in a thread behind two pseudo-terminals
    /// (the default)
    #[arg(long, conflicts_with = "ports")]
    pub host: bool,
    /// Two serial ports wired to a co-processor: its host line, its sensor line
    #[arg(long, num_args = 2, value_names = ["HOST", "SENSOR"])]
    pub ports: Option<Vec<PathBuf>>,
    /// The synthetic scene, or a log replayed.
    #[command(flatten)]
    pub play: crate::synthetic::PlayArgs,
    /// Frames of the log to play: A..B (B exclusive), A..=B, A.., ..B or A
    #[arg(long, value_name = "A..B", requires = "log")]
    pub frames: Option<FrameRange>,
    /// Scans to check: the first N of the selection [default: all of it]
    #[arg(long, value_name = "N")]
    pub scans: Option<usize>,
    /// Give up after this many seconds (the run then fails if fewer than
    /// --scans scans were checked)
    #[arg(long, value_name = "S", default_value_t = 60.0, value_parser = crate::options::seconds)]
    pub timeout: f64,
    /// Rate the client switches the host line to before streaming
    /// (9600 = no switch)
    #[arg(long, value_name = "BAUD", default_value_t = 500_000)]
    pub host_baud: u32,
    /// Hold the sensor's stream while this many scans are out and not back
    /// with features (0 = never) [default: 1 with --qemu, whose UARTs take
    /// a third of the line rate (more would queue in the firmware and reach
    /// its host-line budget back to back, which drops what does not fit one
    /// scan period); 1 with --host, whose thread a loaded computer holds off
    /// the CPU (the sensor would run free meanwhile, faster than a scan
    /// with its features fits the host line); 0 with --ports, as a real
    /// sensor never waits]
    #[arg(long, value_name = "N")]
    pub max_in_flight: Option<usize>,
    /// Switch the simulated LMS off and on once, after this many scans of the
    /// selection have come back (with nothing in flight): the co-processor
    /// must stream again by itself within one second (recovery test)
    #[arg(long, value_name = "N")]
    pub power_cycle_sensor_after: Option<usize>,
    /// Reset the co-processor's MCU once (QEMU's system reset; --qemu only),
    /// after this many scans of the selection have come back (with nothing
    /// in flight): it must find the LMS, still at its fast rate, and stream
    /// again within one second; the client then sets its host line up again
    /// (recovery test)
    #[arg(long, value_name = "N", requires = "qemu")]
    pub reset_mcu_after: Option<usize>,
    /// Pipeline parameters: the co-processor's in --host mode; in every mode
    /// those the D0 summary does not echo (min points, max chi2, merging);
    /// with --qemu or --ports only the firmware's --preset (its LMS_PRESET)
    #[command(flatten)]
    pub params: ParamArgs,
    /// Log the phases of the run and the sensor-side requests on stderr
    #[arg(long, short)]
    pub verbose: bool,
    /// Testing only: the sensor streams at its own pace, held neither for
    /// the host line nor for scans in flight (so that a host line slower
    /// than the sensor's stream makes the co-processor drop scans)
    #[arg(long, hide = true)]
    pub sensor_runs_free: bool,
    /// Testing only: recompute with this tau instead of the echoed one (so
    /// that the check must fail)
    #[arg(long, hide = true, value_name = "T", allow_negative_numbers = true)]
    pub recompute_tau: Option<f32>,
}
