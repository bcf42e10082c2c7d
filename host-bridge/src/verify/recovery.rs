//! The disruptions a run asks for (the LMS power cycle of
//! `--power-cycle-sensor-after`, the MCU reset of `--reset-mcu-after`) and
//! what each did: when it happened and when the co-processor recovered.

use std::time::Duration;

use super::VerifyArgs;
use crate::qemu::QemuIntake;

/// A disruption and the recovery from it (emulator clock, µs): the LMS
/// power cycle of `--power-cycle-sensor-after` or the MCU reset of
/// `--reset-mcu-after`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Recovery {
    /// Scans of the selection back when it happened.
    pub(super) after: usize,
    /// When it happened (the LMS switched on again; the MCU reset).
    pub(super) on_us: Option<u64>,
    /// When the co-processor had started its stream again.
    pub(super) streaming_us: Option<u64>,
    /// When the first scan of the selection came back after it.
    pub(super) back_us: Option<u64>,
    /// MCU reset: when the first scan of any kind came back after it (the
    /// selection resumes then).
    pub(super) first_back_us: Option<u64>,
    /// MCU reset: wall time the sensor waited, until that first scan, for
    /// QEMU's UART to take what it had sent (see `Recoveries::qemu_intake`);
    /// not on the sensor clock.
    pub(super) waited_for_qemu: Duration,
}

/// The disruptions asked for, what happened, and the scans written off.
pub(super) struct Recoveries {
    /// `--power-cycle-sensor-after`: wanted, and what happened.
    pub(super) power_cycle_after: Option<usize>,
    pub(super) power_cycle: Option<Recovery>,
    /// `--reset-mcu-after`: wanted, and what happened.
    pub(super) reset_mcu_after: Option<usize>,
    pub(super) mcu_reset: Option<Recovery>,
    /// Scans outside the selection that the sensor side sent while the
    /// co-processor was rebooting and that did not come back: lost to the
    /// reset, by design, so not counted as lost.
    pub(super) written_off: usize,
    /// The co-processor is recovering from an MCU reset: the sensor runs
    /// (the firmware must find it), with scans outside the selection.
    pub(super) recovering: bool,
    /// While recovering: what QEMU's sensor USART has not taken yet. The
    /// sensor waits while it is full, as a real line never queues (QEMU
    /// takes about 10 KB/s, the LMS streams up to 28 KB/s at 500 kBd):
    /// unpaced, seconds of stale scans queued ahead of the firmware's
    /// search and the first scan came back 7.7 s after a reset.
    pub(super) qemu_intake: QemuIntake,
}

impl Recoveries {
    /// The disruptions `args` asks for, none happened yet.
    pub(super) fn new(args: &VerifyArgs) -> Self {
        Recoveries {
            power_cycle_after: args.power_cycle_sensor_after,
            power_cycle: None,
            reset_mcu_after: args.reset_mcu_after,
            mcu_reset: None,
            written_off: 0,
            recovering: false,
            qemu_intake: QemuIntake::new(),
        }
    }

    /// The power cycle's outcome and the MCU reset's, where asked for.
    pub(super) fn outcomes(&self) -> (Option<Recovery>, Option<Recovery>) {
        (
            asked_recovery(self.power_cycle_after, self.power_cycle),
            asked_recovery(self.reset_mcu_after, self.mcu_reset),
        )
    }
}

/// A disruption wanted after `after` scans of the selection back: `true`
/// once that many are back and it has not happened yet; once it has
/// (`done`), notes when the first scan of the selection came back after it.
pub(super) fn disruption_due(
    after: Option<usize>,
    done: &mut Option<Recovery>,
    back: usize,
    now_us: u64,
) -> bool {
    if let Some(r) = done.as_mut() {
        if r.back_us.is_none() && back > r.after {
            r.back_us = Some(now_us);
        }
        return false;
    }
    after.is_some_and(|n| back >= n)
}

/// A disruption's outcome if it was asked for (`after`): what happened, or,
/// if it never happened, one that says after how many scans it was due.
fn asked_recovery(after: Option<usize>, done: Option<Recovery>) -> Option<Recovery> {
    after.map(|after| {
        done.unwrap_or(Recovery {
            after,
            ..Default::default()
        })
    })
}
