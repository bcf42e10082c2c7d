//! The emulator's fixed settings and its operating mode.

use super::*;

/// `20 2A`: continuous output of partial scans.
pub const MODE_PARTIAL: u8 = 0x2A;

/// The power-on state and fixed properties of the simulated sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// Sensor address (0..=0x7F; default 0). Replies carry `0x80 | address`.
    pub address: u8,
    /// Variant after power-on and reset (default 180°/1°, as
    /// [`StatusFields::default`]).
    pub variant: Variant,
    /// Configuration at the first power-on (default all zero: cm).
    pub config: Config,
    /// Status byte at the end of every reply (default `0x10`).
    pub status: u8,
    /// Time from the end of the `91` reply to the `90` telegram (µs).
    pub restart_us: u64,
    /// `false` (a simulated sensor): in continuous mode the emulator sends
    /// scans on its own mirror clock, and paces every byte at the line
    /// rate. `true` (the co-processor's face towards its client): it sends
    /// no scans by itself — the caller writes each scan when the real
    /// sensor delivers it, while [`Emulator::streaming`] — and hands out
    /// its replies at once, the UART doing the pacing.
    pub external_scans: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings::DEFAULT
    }
}

impl Settings {
    /// The defaults, usable in `const` contexts.
    pub const DEFAULT: Settings = Settings {
        address: DEFAULT_ADDRESS,
        variant: Variant::Fov180Res100,
        config: Config::ZERO,
        status: DEFAULT_STATUS,
        restart_us: DEFAULT_RESTART_US,
        external_scans: false,
    };
}

/// The operating mode (the `B1` mode byte, payload `[8]`).
///
/// `repr(u8)`: an explicit tag, 0 for `Installation`, so that an all-zero
/// emulator (the firmware's `static`, in `.bss`) is in installation mode;
/// without it the niche in [`ValueMode`] made `Installation` a non-zero
/// byte and put the firmware's whole co-processor into `.data` (21 KiB of
/// flash for one byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum OperatingMode {
    /// `00`: installation mode (configuration may be written).
    Installation,
    /// `24`: continuous output of all values.
    Continuous,
    /// `25`: values on request only (power-on default).
    OnRequest,
    /// `26`/`27`/`28`: mean values, a subrange, a mean subrange.
    Values(ValueMode),
    /// `2A`: continuous output of the partial scans, one `B0` per mirror
    /// turn (count word bit 13 set, bits 11–12 its offset).
    Partial,
}

impl OperatingMode {
    /// The mode byte (`00`, `24`, `25`).
    pub const fn code(self) -> u8 {
        match self {
            OperatingMode::Installation => 0x00,
            OperatingMode::Continuous => 0x24,
            OperatingMode::OnRequest => 0x25,
            OperatingMode::Values(m) => m.mode_code(),
            OperatingMode::Partial => MODE_PARTIAL,
        }
    }
}
