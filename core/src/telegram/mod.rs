//! LMS 2xx serial telegrams (PROTOCOL.md §1–§4): bytes in, typed values out,
//! and back.
//!
//! The layers, from the wire up:
//!
//! 1. [`crc`] — the LMS checksum (not a textbook CRC-16, PROTOCOL.md §1).
//! 2. [`packet`] — [`Telegram`], a typed view over the bytes of one
//!    telegram `STX | ADDR | LEN | CMD | DATA… | [STATUS] | CRC`, and the
//!    emitter [`emit_telegram`] that writes one into a caller's buffer.
//! 3. [`request`] — [`Request`], what a host sends (`20`, `30`, `31`, `3A`,
//!    `3B`, `74`, `77`, `10`), parsed from and emitted to telegrams.
//! 4. [`reply`] — [`Reply`], what the sensor sends (`A0`, `B0`, `B1`, `BA`,
//!    `BB`, `F4`, `F7`, `90`, `91`, `92`), with the [`StatusBlock`] of `B1`
//!    and the [`Config`] block of `F4`/`F7`.
//! 5. [`measured`] — the `B0` measured values ([`MeasuredView`] over the
//!    bytes, [`MeasuredValues`] owned), converted to a [`crate::frame::Frame`]
//!    in metres.
//! 6. [`framer`] — [`Framer`], a sans-I/O accumulator fed bytes in arbitrary
//!    chunks that hands out complete telegrams (and `ACK`/`NAK` bytes),
//!    resynchronising on the next `STX` after a bad checksum or an impossible
//!    length, and counting everything it skips.
//!
//! # Panic contract
//!
//! Nothing in this module panics, allocates or uses `unsafe`, whatever bytes
//! it is given. Every constructor that takes bytes checks them and returns an
//! error instead. After [`Telegram::new_checked`] has succeeded, every
//! accessor returns the field it names; on a view made with
//! [`Telegram::new_unchecked`] the accessors still never panic, they return
//! `0` or an empty slice for fields that are not there. Emitters measure the
//! caller's buffer first and return [`EmitError::BufferTooSmall`] with the
//! size they need.
//!
//! # Example: a request, its reply, and the framer in between
//!
//! ```
//! use lms_core::telegram::{
//!     Direction, Event, Framer, Handshake, ModeResult, Reply, Request, SensorStatus,
//! };
//!
//! // Host side: the status request is `02 00 01 00 31 15 12`.
//! let mut buf = [0u8; 16];
//! let n = Request::Status.emit(0x00, &mut buf).unwrap();
//! assert_eq!(&buf[..n], &[0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12]);
//!
//! // Sensor side: ACK, then the `A0` reply to a mode change, fed to the
//! // host's framer one byte at a time.
//! let mut wire = [0u8; 16];
//! wire[0] = lms_core::telegram::ACK;
//! let n = Reply::ModeChanged(ModeResult::Ok)
//!     .emit(0, SensorStatus(0x10), &mut wire[1..])
//!     .unwrap();
//! let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
//! let mut seen = 0;
//! for b in &wire[..1 + n] {
//!     let mut input = core::slice::from_ref(b);
//!     loop {
//!         let fed = framer.feed(input);
//!         input = fed.remaining;
//!         match fed.event {
//!             Some(Event::Ack) => seen += 1,
//!             Some(Event::Telegram(t)) => {
//!                 assert_eq!(Reply::parse(&t), Ok(Reply::ModeChanged(ModeResult::Ok)));
//!                 assert_eq!(t.status(), Some(0x10));
//!                 seen += 1;
//!             }
//!             // A full-size framer never reports a telegram too long to keep.
//!             Some(Event::Nak | Event::Long { .. }) => unreachable!(),
//!             None => break,
//!         }
//!     }
//! }
//! assert_eq!(seen, 2);
//! ```

/// A fixed-size block of telegram data ([`Config`], [`StatusBlock`]): the
/// type, all bytes 0 as its default, its byte-array constructors and
/// accessors, and its units code (at the block's `UNITS` offset); one
/// definition for both.
macro_rules! byte_block {
    ($block:ident, $len:expr, $what:literal, $doc:literal) => {
        #[doc = $doc]
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $block {
            bytes: [u8; $len],
        }

        impl Default for $block {
            /// All bytes 0.
            fn default() -> Self {
                $block::ZERO
            }
        }

        impl $block {
            /// All bytes 0 (`const` form of the default).
            pub const ZERO: $block = $block { bytes: [0; $len] };

            /// The units code at [`Self::UNITS`] (0 cm, 1 mm).
            #[inline]
            pub const fn units_code(&self) -> u8 {
                self.bytes[Self::UNITS]
            }

            /// The unit, if the code is 0 (cm) or 1 (mm).
            #[inline]
            pub const fn units(&self) -> Option<$crate::units::Unit> {
                $crate::units::Unit::from_code(self.units_code())
            }

            #[doc = concat!("A block from its ", $what, " bytes.")]
            #[inline]
            pub const fn from_bytes(bytes: [u8; $len]) -> Self {
                $block { bytes }
            }

            #[doc = concat!("A block from a slice of exactly ", $what, " bytes.")]
            pub fn from_slice(bytes: &[u8]) -> Option<Self> {
                let bytes: [u8; $len] = bytes.try_into().ok()?;
                Some($block { bytes })
            }

            #[doc = concat!("The ", $what, " bytes.")]
            #[inline]
            pub const fn as_bytes(&self) -> &[u8; $len] {
                &self.bytes
            }

            #[doc = concat!("The ", $what, " bytes, for fields this type does not name.")]
            #[inline]
            pub fn as_bytes_mut(&mut self) -> &mut [u8; $len] {
                &mut self.bytes
            }
        }
    };
}

pub mod config;
pub mod crc;
pub mod features;
pub mod framer;
pub mod measured;
pub mod packet;
pub mod reply;
pub mod request;
pub mod status;

pub use config::Config;
pub use crc::{crc16, Crc};
pub use framer::{Event, Feed, Framer, FramerStats, Handshake};
pub use measured::{
    partial_offset, partial_scan_flags, MeasuredError, MeasuredValues, MeasuredView, RangeBits,
    MAX_VALUES, PARTIAL_SCAN_BIT,
};
pub use packet::{
    buffer_len, emit_telegram, emit_telegram_with, EmitError, Head, Telegram, TelegramError,
};
pub use reply::{ModeResult, Reply, ReplyError, VariantReply};
pub use request::{Baud, Request, RequestError};
pub use status::{SensorStatus, Severity, StatusBlock, StatusFields};

/// Start of every telegram.
pub const STX: u8 = 0x02;
/// Acknowledge: the sensor's one-byte answer to a correctly received request.
pub const ACK: u8 = 0x06;
/// Not acknowledged: the sensor's one-byte answer to a request with a bad
/// checksum (the host resends).
pub const NAK: u8 = 0x15;
/// Bit set in the address byte of every sensor → host telegram
/// (`ADDR = 0x80 | address`).
pub const REPLY_ADDRESS_BIT: u8 = 0x80;
/// Bit set in a reply's command code (`reply = request | 0x80`).
pub const REPLY_COMMAND_BIT: u8 = 0x80;
/// Default sensor address (host → sensor `ADDR`).
pub const DEFAULT_ADDRESS: u8 = 0x00;
/// Typical status byte of a sensor reply (PROTOCOL.md §1).
pub const DEFAULT_STATUS: u8 = 0x10;
/// Installation-mode password of an LMS 2xx (`20 00 'SICK_LMS'`).
pub const DEFAULT_PASSWORD: [u8; 8] = *b"SICK_LMS";
/// Type string of an LMS 200 as sent in the `BA` reply.
pub const SENSOR_TYPE_LMS200: &str = "LMS200;30106x;V02.10";

/// Bytes before `CMD`: `STX`, `ADDR`, `LEN` (2).
pub const HEADER_LEN: usize = 4;
/// Bytes of the checksum at the end.
pub const CRC_LEN: usize = 2;
/// Largest `LEN` this crate accepts (bytes from `CMD` up to, not including,
/// the CRC). 812 is the largest seen in real clients; a `B0` with 401 values
/// needs 806. A larger `LEN` is treated as impossible.
pub const MAX_LEN: usize = 812;
/// Largest complete telegram in bytes: `4 + MAX_LEN + 2` = 818.
pub const MAX_TELEGRAM_LEN: usize = HEADER_LEN + MAX_LEN + CRC_LEN;

/// Which way a telegram travels. It decides whether the byte before the CRC
/// is a status byte: only sensor → host telegrams carry one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// A request from the host: `ADDR` is the sensor's address, no status byte.
    HostToSensor,
    /// A reply or stream from the sensor: `ADDR = 0x80 | address`, and a
    /// status byte before the CRC.
    SensorToHost,
}

impl Direction {
    /// `true` if telegrams in this direction end with a status byte.
    #[inline]
    pub const fn has_status(self) -> bool {
        matches!(self, Direction::SensorToHost)
    }

    /// Smallest `LEN` in this direction: the command (+ the status byte).
    #[inline]
    pub const fn min_len(self) -> usize {
        match self {
            Direction::HostToSensor => 1,
            Direction::SensorToHost => 2,
        }
    }

    /// The `ADDR` byte for a sensor with this `address` (0..=0x7F):
    /// `address` towards the sensor, `0x80 | address` from it.
    #[inline]
    pub const fn address_byte(self, address: u8) -> u8 {
        match self {
            Direction::HostToSensor => address,
            Direction::SensorToHost => address | REPLY_ADDRESS_BIT,
        }
    }
}

/// Copy as many bytes as both slices hold (never panics on a length mismatch).
#[inline]
pub(crate) fn copy_into(dst: &mut [u8], src: &[u8]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

/// Little-endian `u16` at `at`, or 0 if the slice is too short.
#[inline]
pub(crate) fn le_u16(bytes: &[u8], at: usize) -> u16 {
    match (bytes.get(at), bytes.get(at.wrapping_add(1))) {
        (Some(&lo), Some(&hi)) => u16::from_le_bytes([lo, hi]),
        _ => 0,
    }
}

/// Write a little-endian `u16` at `at` if the slice is long enough.
#[inline]
pub(crate) fn put_le_u16(bytes: &mut [u8], at: usize, value: u16) {
    if let Some(dst) = bytes.get_mut(at..at.saturating_add(2)) {
        copy_into(dst, &value.to_le_bytes());
    }
}
