//! The co-processor under test ([`Dut`]) and verify's ends of its lines
//! ([`Lines`]); `super::connect` connects them as the mode asks (`--host`,
//! `--qemu`, `--ports`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use lms_core::telegram::features::Counters;

use crate::qemu::Qemu;
use crate::serial::CoLines;

/// The lines to the co-processor and what it is: its sensor line (verify
/// plays the sensor there), its host line (verify is the client there),
/// the firmware's console (`--qemu` only).
pub(super) type Lines = CoLines<Dut>;

/// What the co-processor under test is.
pub(super) enum Dut {
    /// A [`CoProcessor`] in a thread (`--host`).
    Thread {
        handle: Option<JoinHandle<Result<Counters, String>>>,
        stop: Arc<AtomicBool>,
    },
    /// The firmware under QEMU (`--qemu`).
    Qemu(Qemu),
    /// Something on two serial ports (`--ports`).
    Ports,
}

impl Dut {
    /// An error if the co-processor is gone.
    pub(super) fn check(&mut self) -> Result<()> {
        match self {
            Dut::Thread { handle, .. } => {
                if handle.as_ref().is_some_and(|h| h.is_finished()) {
                    let result = handle.take().map(|h| h.join());
                    match result {
                        Some(Ok(Err(e))) => bail!("{e}"),
                        Some(Err(_)) => bail!("the co-processor thread panicked"),
                        _ => bail!("the co-processor thread stopped"),
                    }
                }
                Ok(())
            }
            Dut::Qemu(q) => q.check(),
            Dut::Ports => Ok(()),
        }
    }

    /// Reset the co-processor's MCU (`--reset-mcu-after`): QEMU only.
    pub(super) fn reset_mcu(&mut self) -> Result<()> {
        match self {
            Dut::Qemu(q) => q.reset(),
            _ => bail!("--reset-mcu-after needs --qemu (only QEMU can reset the co-processor)"),
        }
    }

    /// The sensor line's rate as the co-processor has set its UART, where
    /// that can be seen (QEMU: USART2's `BRR`); `Ok(None)` elsewhere or
    /// while unset.
    pub(super) fn sensor_baud(&mut self) -> Result<Option<u32>> {
        match self {
            Dut::Qemu(q) => q.sensor_baud(),
            _ => Ok(None),
        }
    }

    /// `error` happened on a line: if the co-processor has gone (QEMU
    /// exits a moment after it closes its sockets), say that instead.
    pub(super) fn explain(&mut self, error: anyhow::Error) -> anyhow::Error {
        if let Dut::Qemu(q) = self {
            q.wait_exit(Duration::from_secs(1));
        }
        match self.check() {
            Err(gone) => anyhow!("{gone:#} (seen as: {error:#})"),
            Ok(()) => error,
        }
    }

    /// After the run: a failed run keeps QEMU's log and prints its tail; a
    /// good one waits for QEMU to exit on the console's `q`.
    pub(super) fn after_run(&mut self, failed: bool) {
        if let Dut::Qemu(q) = self {
            if failed {
                q.keep = true;
                eprintln!("host-bridge verify: {}", q.log_tail());
            } else if q.wait_exit(Duration::from_secs(2)).is_none() {
                eprintln!("host-bridge verify: note: QEMU did not exit on the console's q; killed");
            }
        }
    }
}

impl Drop for Dut {
    fn drop(&mut self) {
        if let Dut::Thread { handle, stop } = self {
            stop.store(true, Ordering::Relaxed);
            if let Some(h) = handle.take() {
                let _ = h.join();
            }
        }
    }
}
