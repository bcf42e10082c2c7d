//! The control console on USART3 (QEMU's third `-serial`): one-byte
//! commands, answered with one line of `key=value` text.
//!
//! | byte | effect |
//! |---|---|
//! | `s` | report (the line below, also logged) |
//! | `q` | report, then exit through semihosting with code 0 (QEMU); a software reset (board) |
//! | anything else | ignored |
//!
//! The report line, `key=value` pairs, all values decimal:
//!
//! - `now_us`, `scans`, `stack_peak`, `stack_size`, `emulator_us`;
//! - the host and the sensor port's receive counts: `host_rx`,
//!   `host_dropped`, `host_overrun`, `host_line_errors`, `host_peak`, and
//!   the same with `sensor_`;
//! - the co-processor's [`Counters`] but the boot's (also readable by the
//!   host with request `55`), in their declaration order
//!   (docs/reference/counters.md);
//! - the boot's: `sysclk_hz` (SYSCLK, Hz), the counters of kind boot (the
//!   reset flags of `RCC_CSR`, [`crate::fault::ResetCause`], 0 under QEMU;
//!   the previous boot's fault record: cause 0 = none, 1 panic,
//!   2 HardFault, 3 unexpected interrupt; its PC and LR), `fault_detail`;
//! - the scans' cycles by the core's cycle counter ([`crate::scan_cycles`]):
//!   `cycle_counter` (1 on the board, 0 under QEMU, which models none),
//!   `scan_poll_cycles_max`, `scan_poll_cycles_last`;
//! - `params_fingerprint`: [`lms_core::Params::fingerprint`] of the
//!   parameters this build runs (`LMS_PRESET`, `LMS_ITERATIONS`), so that
//!   `host-bridge verify --qemu` can tell whether it recomputes with them.
//!
//! `emulator_us` is the emulator's own clock read at the same moment
//! (semihosting `SYS_ELAPSED` / `SYS_TICKFREQ`; QEMU: the host's monotonic
//! clock since QEMU started), printed beside `now_us` to check the time
//! base; 0 on the board (no semihosting there).

use lms_core::telegram::features::{CounterKind, Counters};

use embedded_io::Write;

use crate::board::{stack_usage, Boot, ControlPort, StackUsage};
use crate::scan_cycles::ScanCycles;
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
    /// The scans' cycles by the core's cycle counter.
    pub scan_cycles: ScanCycles,
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
        scan_cycles: ScanCycles,
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
            scan_cycles,
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
        // The co-processor's counters, then the boot's: SYSCLK, the boot
        // record's fields in counter order, the fault's detail.
        let mut counters = self.counters;
        counters.set_boot(self.boot.record());
        for (name, _, v) in counters.entries().filter(|e| e.1 != CounterKind::Boot) {
            w.field(name, v.into());
        }
        w.field("sysclk_hz", self.boot.clocks.sysclk_hz.into());
        for (name, _, v) in counters.entries().filter(|e| e.1 == CounterKind::Boot) {
            w.field(name, v.into());
        }
        let detail = self.boot.last_fault.map_or(0, |f| f.detail);
        w.field("fault_detail", detail.into());
        let l = &self.scan_cycles;
        w.field("cycle_counter", u64::from(l.counting));
        w.field("scan_poll_cycles_max", l.scan_poll_max.into());
        w.field("scan_poll_cycles_last", l.scan_poll_last.into());
        w.field("params_fingerprint", crate::app::PARAMS_FINGERPRINT.into());
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
    const TEN: core::num::NonZeroU64 = lms_core::maths::divisor(10);
    let mut used = 0;
    for slot in buf.iter_mut().rev() {
        // Not `%` and `/`: on u64 they pull in the compiler's 0.9 KB
        // division routine (lms_core::maths::div_rem_u64).
        let (rest, digit) = lms_core::maths::div_rem_u64(value, TEN);
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
