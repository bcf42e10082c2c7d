//! What the emulator reports: requests handled, events, counters.

use super::*;
use crate::frame::FovRes;

/// A correctly received request and what the emulator made of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Handled {
    // The stream: on, off, or the values of a value mode.
    /// `20 24`: continuous output.
    Continuous,
    /// `20 2A`: continuous output of partial scans.
    PartialScans,
    /// `20 25`: values on request (the stream stopped).
    OnRequest,
    /// `20 26`/`27`/`28`: a value mode.
    ValueMode {
        /// The mode and its parameters.
        mode: ValueMode,
        /// `true` if taken (`A0 00`), `false` for bad parameters (`A0 02`).
        accepted: bool,
    },
    // Replies that carry data.
    /// `30 01`: one scan.
    OneScan,
    /// `31`: status.
    Status,
    /// `3A`: type string.
    SensorType,
    /// `74`: read the configuration.
    ReadConfig,
    // Settings.
    /// `20 00`: installation mode, entered if the password was right.
    InstallationMode {
        /// `true` for the right password (`A0 00`), `false` for `A0 01`.
        accepted: bool,
    },
    /// `20 4x`: the line switches to this rate after the reply.
    SetBaud(Baud),
    /// `3B`: variant.
    SetVariant {
        /// The field of view and resolution asked for.
        asked: FovRes,
        /// `true` if taken (`BB 01`).
        accepted: bool,
    },
    /// `77`: write the configuration.
    WriteConfig {
        /// `true` if taken (`F7 01`): installation mode and a units code of
        /// 0 or 1.
        accepted: bool,
    },
    /// `10`: reset.
    Reset,
    // Outside the LMS's table.
    /// A command the LMS does not know, answered by the source
    /// ([`ScanSource::extra_command`]).
    Extra {
        /// The command code.
        command: u8,
    },
    /// Unknown or malformed (answered with `92`).
    Unknown {
        /// The command code.
        command: u8,
        /// Data bytes after it.
        data_len: usize,
    },
}

/// Something the caller may want to know or log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Event {
    /// The `90` power-on telegram has been sent.
    PowerOnSent,
    /// A request was received and answered (the reply is queued).
    Request(Handled),
    /// A telegram failed its checksum: `NAK` queued.
    BadChecksum,
    /// A telegram for another address was ignored.
    IgnoredAddress {
        /// Its `ADDR` byte.
        address: u8,
    },
    /// The line rate changed now: every byte before it went at `from`,
    /// every byte after goes at `to`.
    BaudSwitched {
        /// The old rate.
        from: Baud,
        /// The new rate.
        to: Baud,
    },
    /// The continuous stream started (the `A0` of `20 24` has been sent).
    StreamStarted,
    /// The continuous stream stopped (`20 25` or `10`).
    StreamStopped,
    /// A `B0` telegram has been sent.
    ScanSent {
        /// Its variant.
        variant: Variant,
        /// `true` in the continuous stream, `false` for `30 01`.
        continuous: bool,
        /// Scans the mirror completed since the previous one sent, which
        /// were skipped because the line was busy.
        skipped: u32,
    },
    /// A reset was requested: input is ignored until the `90` telegram.
    Restarting,
}

/// Counters (all wrap).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmulatorStats {
    /// Requests answered.
    pub requests: u32,
    /// `NAK`s queued for bad checksums.
    pub naks: u32,
    /// Telegrams for another address.
    pub ignored: u32,
    /// Requests dropped because [`PENDING_CAPACITY`] replies were waiting.
    pub dropped_requests: u32,
    /// Half-received telegrams given up after [`RX_IDLE_TIMEOUT_US`].
    pub abandoned: u32,
    /// Bytes received during a reset and ignored.
    pub ignored_bytes: u32,
    /// `B0` telegrams sent (stream and `30 01`).
    pub scans_sent: u32,
    /// Scans skipped in the stream because the line was busy.
    pub scans_skipped: u32,
    /// Bytes handed out by [`Emulator::transmit`].
    pub bytes_sent: u64,
    /// Events dropped because [`EVENT_CAPACITY`] were waiting.
    pub events_dropped: u32,
    /// Replies that could not be written (cannot happen; counted, not
    /// panicked on).
    pub emit_errors: u32,
}

impl EmulatorStats {
    /// All counters at zero (`const`).
    pub const ZERO: EmulatorStats = EmulatorStats {
        requests: 0,
        naks: 0,
        ignored: 0,
        dropped_requests: 0,
        abandoned: 0,
        ignored_bytes: 0,
        scans_sent: 0,
        scans_skipped: 0,
        bytes_sent: 0,
        events_dropped: 0,
        emit_errors: 0,
    };
}
