//! The control console on USART3 (QEMU's third `-serial`): one-byte
//! commands, answered with one line of `key=value` text.
//!
//! | byte | effect |
//! |---|---|
//! | `s` | report (the line below, also logged) |
//! | `q` | report, then exit through semihosting with code 0 (QEMU); a software reset (board) |
//! | anything else | ignored |
//!
//! The report line, all values decimal:
//!
//! ```text
//! now_us=… scans=… stack_peak=… stack_size=… emulator_us=… host_rx=… host_dropped=… host_overrun=… host_line_errors=… host_peak=… sensor_rx=… sensor_dropped=… sensor_overrun=… sensor_line_errors=… sensor_peak=… scans_in=… feature_scans_out=… feature_telegrams_out=… sensor_crc_errors=… sensor_resyncs=… sensor_bytes_skipped=… host_crc_errors=… scans_dropped=… scans_rejected=… host_scans_dropped=… scans_other_setting=… scans_out=… host_requests_dropped=… relays_refused=… relays_failed=… partial_scans_unassembled=… sysclk_hz=… reset_flags=… fault_cause=… fault_pc=… fault_lr=… fault_detail=…
//! ```
//!
//! Then twelve of the co-processor's [`Counters`] (also readable by the host
//! with request `55`), then the boot's: SYSCLK (Hz), `RCC_CSR`'s reset flags
//! ([`crate::fault::ResetCause`]; 0 under QEMU), and the previous boot's
//! fault record (cause 0 = none, 1 panic, 2 HardFault, 3 unexpected
//! interrupt).
//!
//! `emulator_us` is the emulator's own clock read at the same moment
//! (semihosting `SYS_ELAPSED` / `SYS_TICKFREQ`; QEMU: the host's monotonic
//! clock since QEMU started), printed beside `now_us` to check the time
//! base; 0 on the board (no semihosting there).

use lms_core::telegram::features::Counters;

use embedded_io::Write;

use crate::board::{stack_usage, Boot, ControlPort, StackUsage};
use crate::serial::RxCounts;

/// What the console is asked to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// Report.
    Report,
    /// Report, then exit with success.
    Quit,
}

impl Command {
    /// The command a received byte stands for.
    pub fn from_byte(b: u8) -> Option<Self> {
        match b {
            b's' => Some(Command::Report),
            b'q' => Some(Command::Quit),
            _ => None,
        }
    }
}

/// The numbers the console reports.
#[derive(Clone, Copy, Debug)]
pub struct Report {
    /// Time base (µs since boot).
    pub now_us: u64,
    /// Scans completed.
    pub scans: u32,
    /// The co-processor's counters.
    pub counters: Counters,
    /// Stack high-water mark.
    pub stack: StackUsage,
    /// The emulator's clock (µs), 0 if unknown.
    pub emulator_us: u64,
    /// Host port receive counters.
    pub host: RxCounts,
    /// Sensor port receive counters.
    pub sensor: RxCounts,
    /// What the boot found.
    pub boot: Boot,
}

impl Report {
    /// Gather the numbers now.
    pub fn collect(
        now_us: u64,
        scans: u32,
        counters: Counters,
        host: RxCounts,
        sensor: RxCounts,
        boot: &Boot,
    ) -> Self {
        Report {
            now_us,
            scans,
            counters,
            stack: stack_usage(),
            emulator_us: emulator_us().unwrap_or(0),
            host,
            sensor,
            boot: *boot,
        }
    }

    /// Write the report as one text line.
    pub fn write_line(&self, out: &mut ControlPort) {
        let mut w = Line { out, first: true };
        w.field("now_us", self.now_us);
        w.field("scans", self.scans.into());
        w.field("stack_peak", self.stack.peak.into());
        w.field("stack_size", self.stack.size.into());
        w.field("emulator_us", self.emulator_us);
        for (side, c) in [("host", &self.host), ("sensor", &self.sensor)] {
            w.counts(side, c);
        }
        let c = &self.counters;
        for (name, v) in [
            ("scans_in", c.scans_in),
            ("feature_scans_out", c.feature_scans_out),
            ("feature_telegrams_out", c.feature_telegrams_out),
            ("sensor_crc_errors", c.sensor_crc_errors),
            ("sensor_resyncs", c.sensor_resyncs),
            ("sensor_bytes_skipped", c.sensor_bytes_skipped),
            ("host_crc_errors", c.host_crc_errors),
            ("scans_dropped", c.scans_dropped),
            ("scans_rejected", c.scans_rejected),
            ("host_scans_dropped", c.host_scans_dropped),
            ("scans_other_setting", c.scans_other_setting),
            ("scans_out", c.scans_out),
            ("host_requests_dropped", c.host_requests_dropped),
            ("relays_refused", c.relays_refused),
            ("relays_failed", c.relays_failed),
            ("partial_scans_unassembled", c.partial_scans_unassembled),
        ] {
            w.field(name, v.into());
        }
        let b = &self.boot;
        let f = b.last_fault;
        for (name, v) in [
            ("sysclk_hz", b.clocks.sysclk_hz),
            ("reset_flags", b.reset.0),
            ("fault_cause", f.map_or(0, |f| f.cause as u32)),
            ("fault_pc", f.map_or(0, |f| f.pc)),
            ("fault_lr", f.map_or(0, |f| f.lr)),
            ("fault_detail", f.map_or(0, |f| f.detail)),
        ] {
            w.field(name, v.into());
        }
        w.put(b"\n");
    }
}

/// The emulator's clock in µs (semihosting `SYS_ELAPSED` ticks at
/// `SYS_TICKFREQ` Hz), if it has one; `None` on the board.
fn emulator_us() -> Option<u64> {
    use semihosting::sys::arm_compat::{sys_elapsed, sys_tickfreq};
    if !crate::board::on_emulator() {
        return None;
    }
    let ticks = sys_elapsed().ok()?;
    let hz = u64::try_from(sys_tickfreq().ok()?).ok()?;
    if hz == 0 {
        return None;
    }
    Some((u128::from(ticks) * 1_000_000 / u128::from(hz)) as u64)
}

/// `key=value` fields separated by spaces.
struct Line<'a> {
    out: &'a mut ControlPort,
    first: bool,
}

impl Line<'_> {
    fn put(&mut self, bytes: &[u8]) {
        // Infallible: the port's error type is `Infallible`.
        let Ok(()) = self.out.write_all(bytes);
    }

    fn field(&mut self, key: &str, value: u64) {
        if !self.first {
            self.put(b" ");
        }
        self.first = false;
        self.put(key.as_bytes());
        self.put(b"=");
        let mut digits = [0u8; 20];
        self.put(decimal(value, &mut digits));
    }

    fn counts(&mut self, side: &str, c: &RxCounts) {
        for (name, v) in [
            ("rx", c.received),
            ("dropped", c.dropped_full),
            ("overrun", c.overrun),
            ("line_errors", c.line_errors),
            ("peak", c.peak_queued),
        ] {
            if !self.first {
                self.put(b" ");
            }
            self.first = false;
            self.put(side.as_bytes());
            self.put(b"_");
            self.first = true;
            self.field(name, v.into());
        }
    }
}

/// `value` in decimal, in the tail of `buf` (20 digits hold any u64).
/// Written without indexing: a bounds check here was the firmware's only
/// `panic_bounds_check`, which links `core::fmt`'s integer formatting
/// (~0.6 KiB of flash) for a message the panic handler never formats.
fn decimal(mut value: u64, buf: &mut [u8; 20]) -> &[u8] {
    let mut used = 0;
    for slot in buf.iter_mut().rev() {
        // Not `%` and `/`: on u64 they pull in the compiler's 0.9 KB
        // division routine (lms_core::maths::div_rem_u64).
        let (rest, digit) = lms_core::maths::div_rem_u64(value, 10);
        *slot = b'0' + digit as u8;
        value = rest;
        used += 1;
        if value == 0 {
            break;
        }
    }
    let start = buf.len().saturating_sub(used);
    buf.get(start..).unwrap_or_default()
}
