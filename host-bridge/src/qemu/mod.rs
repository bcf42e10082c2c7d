//! The firmware under QEMU (`qemu-system-arm -M netduinoplus2`): its three
//! UARTs on TCP sockets (`launch`), and the rate at which QEMU's sensor
//! USART takes bytes (`intake`). `verify --qemu` and `coprocessor --qemu`
//! both run the firmware through here.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Result;

pub(crate) mod intake;
pub(crate) mod launch;

pub(crate) use intake::QemuIntake;
pub(crate) use launch::{connect, Connected, Qemu};

/// Default firmware ELF (relative to the working directory, then to the
/// source tree).
pub const DEFAULT_ELF: &str = "firmware/target/thumbv7em-none-eabihf/release/lms-firmware";

/// The firmware under QEMU with its host, sensor and console UARTs as
/// [`crate::serial::Link`]s; QEMU is stopped when this is dropped (for
/// `host-bridge coprocessor --qemu`).
pub struct QemuLines {
    /// USART1, the host line.
    pub host: Box<dyn crate::serial::Link>,
    /// USART2, the sensor line.
    pub sensor: Box<dyn crate::serial::Link>,
    /// USART3, the console.
    pub console: Option<Box<dyn crate::serial::Link>>,
    /// Last, so that QEMU goes after its lines.
    _qemu: Qemu,
}

/// Start the firmware `elf` (default [`DEFAULT_ELF`]) under QEMU, bounded
/// by `bound`, and connect to its UARTs.
pub fn qemu_lines(
    elf: Option<&std::path::Path>,
    bound: Duration,
    stop: &Arc<AtomicBool>,
) -> Result<QemuLines> {
    let c = connect(elf, bound, stop)?;
    Ok(QemuLines {
        host: c.host,
        sensor: c.sensor,
        console: c.console,
        _qemu: c.qemu,
    })
}
