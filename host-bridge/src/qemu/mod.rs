//! The firmware under QEMU (`qemu-system-arm -M netduinoplus2`): its three
//! UARTs on TCP sockets (`launch`), and the rate at which QEMU's sensor
//! USART takes bytes (`intake`). `verify --qemu` and `coprocessor --qemu`
//! both run the firmware through here.

pub(crate) mod intake;
pub(crate) mod launch;

pub(crate) use intake::QemuIntake;
pub(crate) use launch::{connect, Connected, Qemu};

/// Default firmware ELF (relative to the working directory, then to the
/// source tree).
pub const DEFAULT_ELF: &str = "firmware/target/thumbv7em-none-eabihf/release/lms-firmware";
