//! The cycles the scans take, measured by the core's cycle counter (DWT
//! `CYCCNT`, one count per core clock: 168 MHz on the board), for the
//! console report: `scan_poll_cycles_max` / `_last`, the cycles of the
//! longest and of the last poll that processed a scan (one scan, unless
//! the loop fell behind), interrupts included, since boot. At 168 MHz a
//! 361-beam scan arrives every 4.48 M cycles (26.7 ms), a 181-beam scan
//! every 2.24 M, a 401-beam scan every 8.96 M.
//!
//! These are the measured counterparts of the upper bound that
//! `tools/qemu-icount/realtime.sh` estimates (docs/DESIGN.md, Firmware).
//! QEMU models no cycle counter (it reads 0): there the report says
//! `cycle_counter=0` and the figures are 0. Two counter reads a poll; the
//! loop's sleep is not timed (a busy share would take two reads at every
//! interrupt's wake-up, about 1 700 a 361-beam scan at 500 kBd).

use cortex_m::peripheral::{DCB, DWT};

/// The cycle counter's figures since boot.
#[derive(Clone, Copy, Debug, Default)]
pub struct ScanCycles {
    /// Whether the counter counts (a board; not QEMU).
    pub counting: bool,
    /// The longest poll that processed a scan (cycles).
    pub scan_poll_max: u32,
    /// The last poll that processed a scan (cycles).
    pub scan_poll_last: u32,
}

impl ScanCycles {
    /// Switch the cycle counter on (trace enable, then `CYCCNTENA`) and
    /// find out whether it counts.
    pub fn start(mut dcb: DCB, mut dwt: DWT) -> Self {
        dcb.enable_trace();
        dwt.enable_cycle_counter();
        let before = DWT::cycle_count();
        cortex_m::asm::delay(64);
        ScanCycles {
            counting: DWT::cycle_count() != before,
            ..ScanCycles::default()
        }
    }

    /// The cycle counter now (wraps every 25.6 s at 168 MHz).
    #[inline]
    pub fn now() -> u32 {
        DWT::cycle_count()
    }

    /// A poll that began at `began` (a [`ScanCycles::now`]) has processed
    /// a scan (or more, if the loop fell behind).
    #[inline]
    pub fn scan_poll(&mut self, began: u32) {
        let cycles = Self::now().wrapping_sub(began);
        self.scan_poll_last = cycles;
        self.scan_poll_max = self.scan_poll_max.max(cycles);
    }
}
