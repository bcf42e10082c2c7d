//! The `B0` measured-values telegram (PROTOCOL.md §3) and its conversion
//! to a [`Frame`] in metres.
//!
//! ```text
//! 02 80 | LEN | B0 | W (u16 LE) | n × value (u16 LE) | [index] | status | CRC
//! ```
//!
//! `index`: one byte, the real-time scan index (mirror scans modulo 256),
//! present only when the sensor's configuration asks for it (availability,
//! configuration byte `[4]` bit 1, [`crate::telegram::Config::real_time_indices`]);
//! the data length tells: `2 + 2n` without it, `2 + 2n + 1` with it.
//!
//! Count word `W`: bits 0–9 number of values; bits 10–13 scan flags (11–12
//! partial-scan offset in 0.25°, 13 partial scan), kept as they came; bits
//! 14–15 units (`00` cm, `01` mm, `10` 10 cm).
//!
//! Value word: the low 13, 14 or 15 bits are the range (the measuring mode
//! decides, see [`RangeBits`]); the bits above are flags, kept and exposed
//! but not interpreted. A range at or above `all_ones − 8` (8183 in 13-bit
//! mode) is an error code, classified with
//! [`Invalid::from_code_offset`]`(all_ones − range)`; a range of 0 is
//! [`Invalid::Zero`].
//!
//! [`MeasuredView`] reads the values in place (zero-copy, for a client);
//! [`MeasuredValues`] owns up to [`MAX_VALUES`] words (for a simulator, or
//! to keep a scan after the receive buffer moves on).
//!
//! # Example: from `B0` bytes to features
//!
//! The bytes of a sensor's line go through a [`Framer`](crate::telegram::Framer),
//! which hands out each whole telegram; its [`MeasuredView`] decodes the
//! values in place into a [`Frame`] in metres, and the
//! [`Extractor`](crate::Extractor) turns that into features.
//!
//! ```
//! use lms_core::telegram::{Direction, Event, Framer, Handshake};
//! use lms_core::telegram::{MeasuredValues, MeasuredView, RangeBits};
//! use lms_core::{Extractor, Frame, Unit, ValidParams, Variant};
//!
//! // What an LMS sends: a 180°/0.5° scan in mm of a wall 2 m ahead.
//! let variant = Variant::Fov180Res50;
//! let mm: Vec<u16> = (0..variant.beams())
//!     .map(|j| {
//!         let phi = variant.geometry().bearing(j); // rad, 0 to the right
//!         (2000.0 / libm::sinf(phi).max(0.25)) as u16
//!     })
//!     .collect();
//! let mut wire = [0u8; 1024];
//! let n = MeasuredValues::from_raw(&mm, Unit::Millimetre, 0x10)
//!     .unwrap()
//!     .emit(0, &mut wire)
//!     .unwrap();
//!
//! // The receiving side: bytes in as they come, a frame out per `B0`.
//! let mut framer: Framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
//! let mut frame = Frame::for_variant(variant);
//! let mut extractor = Box::new(Extractor::new()); // ~7 KiB; a `static` on a board
//! let mut input = &wire[..n];
//! let mut scans = 0;
//! loop {
//!     let fed = framer.feed(input);
//!     input = fed.remaining;
//!     match fed.event {
//!         Some(Event::Telegram(t)) => {
//!             // The sensor's measuring mode gives the range bits (13 by default).
//!             let view = MeasuredView::parse(&t).unwrap();
//!             view.to_frame_into(RangeBits::Bits13, &mut frame).unwrap();
//!             let features = extractor.run(&frame, &ValidParams::DEFAULT);
//!             assert_eq!(features.lines().len(), 1); // the wall
//!             let wall = features.lines()[0];
//!             assert!((wall.r - 2.0).abs() < 0.01); // 2 m away (m)
//!             scans += 1;
//!         }
//!         Some(_) => {}    // ACK, NAK, a telegram too long to keep
//!         None => break, // everything fed
//!     }
//! }
//! assert_eq!(scans, 1);
//! ```

use core::fmt;

use super::packet::{buffer_len, emit_telegram_with, EmitError, Head, Telegram};
use super::{le_u16, put_le_u16, Direction};
use crate::frame::{Beam, Frame, Invalid, Variant};
use crate::units::Unit;

/// Command code of the measured-values reply.
pub const MEASURED_COMMAND: u8 = 0xB0;
/// Most values in one `B0` telegram (100°/0.25°).
pub const MAX_VALUES: usize = 401;

/// Count-word bits holding the number of values.
const COUNT_MASK: u16 = 0x03FF;
/// Count-word bits 10–13: scan flags (partial scan and its offset).
const SCAN_FLAGS_MASK: u16 = 0x3C00;
/// Count-word bit 13: a partial scan (mode `20 2A`).
pub const PARTIAL_SCAN_BIT: u16 = 0x2000;
/// Count-word bits 11–12: the partial scan's offset in 0.25° steps.
const PARTIAL_OFFSET_SHIFT: u16 = 11;

/// The count-word scan flags of a partial scan whose first value lies
/// `offset` × 0.25° past the field's start (`offset` 0…3).
pub const fn partial_scan_flags(offset: u8) -> u16 {
    PARTIAL_SCAN_BIT | (((offset & 3) as u16) << PARTIAL_OFFSET_SHIFT)
}

/// The partial-scan offset (0…3, in 0.25°) of count-word scan flags that
/// mark a partial scan; `None` for a whole scan.
pub const fn partial_offset(scan_flags: u16) -> Option<u8> {
    if scan_flags & PARTIAL_SCAN_BIT == 0 {
        return None;
    }
    Some(((scan_flags >> PARTIAL_OFFSET_SHIFT) & 3) as u8)
}
/// Count-word bits 14–15: units.
const UNITS_MASK: u16 = 0xC000;

/// How many low bits of a value word are range (the measuring mode decides;
/// PROTOCOL.md §3). The default measuring mode uses 13.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RangeBits {
    /// Bits 0–12 range (`& 0x1FFF`), bits 13–15 flags.
    #[default]
    Bits13,
    /// Bits 0–13 range (`& 0x3FFF`), bits 14–15 flags.
    Bits14,
    /// Bits 0–14 range (`& 0x7FFF`), bit 15 flag.
    Bits15,
}

impl RangeBits {
    /// The range bits of a configuration's measuring-mode byte (`F4`
    /// `[5]`): codes `03`/`04` (16 m modes) 14 bits, `05`/`06`/`0F` (32 m
    /// modes) 15 bits, everything else (`00`–`02`, the 8 m / 80 m modes) 13.
    pub const fn from_measuring_mode(code: u8) -> RangeBits {
        match code {
            0x03 | 0x04 => RangeBits::Bits14,
            0x05 | 0x06 | 0x0F => RangeBits::Bits15,
            _ => RangeBits::Bits13,
        }
    }

    /// Mask of the range bits; also the all-ones value (error code "not
    /// valid").
    pub const fn mask(self) -> u16 {
        match self {
            RangeBits::Bits13 => 0x1FFF,
            RangeBits::Bits14 => 0x3FFF,
            RangeBits::Bits15 => 0x7FFF,
        }
    }

    /// Smallest error code: `mask − 8` (8183 for 13 bits).
    pub const fn first_error_code(self) -> u16 {
        self.mask() - 8
    }

    /// The range bits of a value word.
    pub const fn range(self, word: u16) -> u16 {
        word & self.mask()
    }

    /// The flag bits of a value word, in place (not shifted).
    pub const fn flags(self, word: u16) -> u16 {
        word & !self.mask()
    }

    /// The range in sensor units, or why the word holds none.
    pub const fn decode(self, word: u16) -> Result<u16, Invalid> {
        let r = self.range(word);
        if r == 0 {
            Err(Invalid::Zero)
        } else if r >= self.first_error_code() {
            Err(Invalid::from_code_offset(self.mask() - r))
        } else {
            Ok(r)
        }
    }

    /// The range word (flags 0) for an invalid reading: the error code, or
    /// 0 for [`Invalid::Zero`]. Host-side reasons and unknown offsets
    /// become "not valid" (all ones).
    pub const fn encode_invalid(self, why: Invalid) -> u16 {
        let offset = match why {
            Invalid::Zero => return 0,
            Invalid::NoEcho | Invalid::NotFinite => 0,
            Invalid::Dazzle => 1,
            Invalid::Overflow => 2,
            Invalid::LowSignal => 4,
            Invalid::ChannelError => 5,
            Invalid::AboveMax => 8,
            Invalid::OtherCode(o) if o <= 8 => o as u16,
            Invalid::OtherCode(_) => 0,
        };
        self.mask() - offset
    }
}

/// Why `B0` bytes or values are not a scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MeasuredError {
    /// The telegram is not sensor → host.
    WrongDirection,
    /// The telegram's command is not `B0`.
    NotMeasured {
        /// The command code found.
        command: u8,
    },
    /// Fewer than the two bytes of the count word.
    MissingCount,
    /// Unit bits 14–15 are `11`.
    BadUnits {
        /// The count word.
        count_word: u16,
    },
    /// More than [`MAX_VALUES`] values.
    TooManyValues {
        /// The number of values.
        count: usize,
    },
    /// The data length does not match the count word (`2 + 2 × count`, or
    /// one more with a real-time index).
    LengthMismatch {
        /// Values announced by the count word.
        count: usize,
        /// Data bytes present (count word included).
        data_len: usize,
    },
    /// No scan variant sends this many values (101, 181, 201, 361, 401).
    UnsupportedCount {
        /// The number of values.
        count: usize,
    },
}

impl fmt::Display for MeasuredError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeasuredError::WrongDirection => f.write_str("not a sensor → host telegram"),
            MeasuredError::NotMeasured { command } => {
                write!(f, "command {command:#04x} is not B0")
            }
            MeasuredError::MissingCount => f.write_str("B0 data shorter than the count word"),
            MeasuredError::BadUnits { count_word } => {
                write!(f, "undefined units in count word {count_word:#06x}")
            }
            MeasuredError::TooManyValues { count } => {
                write!(f, "{count} values, at most {MAX_VALUES}")
            }
            MeasuredError::LengthMismatch { count, data_len } => write!(
                f,
                "{count} values need {} data bytes, got {data_len}",
                2 + 2 * count
            ),
            MeasuredError::UnsupportedCount { count } => {
                write!(f, "no scan variant has {count} values")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for MeasuredError {}

/// Check `B0` data (count word + values); returns the value count.
fn check_data(data: &[u8]) -> Result<(u16, usize), MeasuredError> {
    if data.len() < 2 {
        return Err(MeasuredError::MissingCount);
    }
    let w = le_u16(data, 0);
    if Unit::from_count_word(w).is_none() {
        return Err(MeasuredError::BadUnits { count_word: w });
    }
    let count = usize::from(w & COUNT_MASK);
    if count > MAX_VALUES {
        return Err(MeasuredError::TooManyValues { count });
    }
    // One byte more: the real-time index.
    if data.len() != 2 + 2 * count && data.len() != 3 + 2 * count {
        return Err(MeasuredError::LengthMismatch {
            count,
            data_len: data.len(),
        });
    }
    Ok((w, count))
}

/// Fill a frame from value words (shared by the view and the owned scan).
fn words_to_frame(
    count: usize,
    words: impl Iterator<Item = u16>,
    units: Unit,
    bits: RangeBits,
) -> Result<Frame, MeasuredError> {
    let mut frame = Frame::empty();
    words_into_frame(count, words, units, bits, &mut frame)?;
    Ok(frame)
}

/// Fill `frame` in place from value words; on error it is left unchanged.
fn words_into_frame(
    count: usize,
    words: impl Iterator<Item = u16>,
    units: Unit,
    bits: RangeBits,
    frame: &mut Frame,
) -> Result<(), MeasuredError> {
    let variant = Variant::from_beams(count).ok_or(MeasuredError::UnsupportedCount { count })?;
    frame.reset(variant);
    let per_metre = units.per_metre();
    for (j, word) in words.take(count).enumerate() {
        match bits.decode(word) {
            Ok(r) => frame.set_metres(j, f32::from(r) / per_metre),
            Err(why) => frame.set_invalid(j, why),
        }
    }
    Ok(())
}

/// Fill `frame` in place from a whole scan's value words (one of the
/// variants' counts) in `units` with `bits` range bits, e.g. a scan joined
/// from its partial scans; on error it is left unchanged.
pub fn frame_from_words(
    words: &[u16],
    units: Unit,
    bits: RangeBits,
    frame: &mut Frame,
) -> Result<(), MeasuredError> {
    words_into_frame(words.len(), words.iter().copied(), units, bits, frame)
}

/// The `B0` data (count word + values) read in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasuredView<'a> {
    data: &'a [u8],
}

impl<'a> MeasuredView<'a> {
    /// Check `B0` data: count word present, units defined, at most
    /// [`MAX_VALUES`] values, length `2 + 2 × count`.
    pub fn new(data: &'a [u8]) -> Result<Self, MeasuredError> {
        check_data(data)?;
        Ok(MeasuredView { data })
    }

    /// The view of a sensor → host `B0` telegram.
    pub fn parse(telegram: &Telegram<&'a [u8]>) -> Result<Self, MeasuredError> {
        if telegram.direction() != Direction::SensorToHost {
            return Err(MeasuredError::WrongDirection);
        }
        let command = telegram.command();
        if command != MEASURED_COMMAND {
            return Err(MeasuredError::NotMeasured { command });
        }
        MeasuredView::new(telegram.into_data())
    }

    /// The data bytes (count word + values).
    #[inline]
    pub fn as_bytes(&self) -> &'a [u8] {
        self.data
    }

    /// The count word `W`.
    #[inline]
    pub fn count_word(&self) -> u16 {
        le_u16(self.data, 0)
    }

    /// Number of values.
    #[inline]
    pub fn count(&self) -> usize {
        usize::from(self.count_word() & COUNT_MASK)
    }

    /// Unit of the ranges.
    #[inline]
    pub fn units(&self) -> Unit {
        Unit::from_count_word(self.count_word()).unwrap_or(Unit::Centimetre)
    }

    /// Count-word bits 10–13 in place (bit 13 partial scan, 11–12 its offset).
    #[inline]
    pub fn scan_flags(&self) -> u16 {
        self.count_word() & SCAN_FLAGS_MASK
    }

    /// The real-time scan index after the values, if the telegram has one.
    #[inline]
    pub fn real_time_index(&self) -> Option<u8> {
        let at = 2 + 2 * self.count();
        self.data.get(at).copied()
    }

    /// The partial-scan offset (0…3, in 0.25°) if this is a partial scan
    /// (mode `20 2A`), `None` for a whole scan.
    #[inline]
    pub fn partial_offset(&self) -> Option<u8> {
        partial_offset(self.scan_flags())
    }

    /// Value word `j` (range + flags), if `j < count`.
    #[inline]
    pub fn word(&self, j: usize) -> Option<u16> {
        if j >= self.count() {
            return None;
        }
        let at = j.checked_mul(2)?.checked_add(2)?;
        Some(le_u16(self.data, at))
    }

    /// All value words in order. (Inlined: its chunk size stays a visible
    /// constant, so a caller's `zip` has no division by zero to prove.)
    #[inline(always)]
    pub fn words(&self) -> impl Iterator<Item = u16> + 'a {
        self.data
            .get(2..2 + 2 * self.count())
            .unwrap_or_default()
            .chunks_exact(2)
            .map(|c| le_u16(c, 0))
    }

    /// A frame in metres with `bits` range bits (see the [module docs](self)).
    pub fn to_frame(&self, bits: RangeBits) -> Result<Frame, MeasuredError> {
        words_to_frame(self.count(), self.words(), self.units(), bits)
    }

    /// [`MeasuredView::to_frame`] into an existing frame (no temporary).
    pub fn to_frame_into(&self, bits: RangeBits, frame: &mut Frame) -> Result<(), MeasuredError> {
        words_into_frame(self.count(), self.words(), self.units(), bits, frame)
    }

    /// An owned copy, with the telegram's status byte.
    pub fn to_values(&self, status: u8) -> MeasuredValues {
        let mut v = MeasuredValues::empty(self.units(), status);
        for (slot, w) in v.values.iter_mut().zip(self.words()) {
            *slot = w;
        }
        v.count = self.count().min(MAX_VALUES);
        v.scan_flags = self.scan_flags();
        v.real_time_index = self.real_time_index();
        v
    }
}

/// The count word `W` of `count` values in `units`, scan flags 0 (what
/// [`MeasuredValues::count_word`] gives without flags).
pub fn count_word(count: usize, units: Unit) -> u16 {
    // count <= MAX_VALUES < 0x400.
    let count = u16::try_from(count).unwrap_or(0) & COUNT_MASK;
    count | (units.count_word_bits() & UNITS_MASK)
}

/// One scan's value words, owned: up to [`MAX_VALUES`] raw `u16` words,
/// their units, the count word's scan flags and the status byte.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MeasuredValues {
    values: [u16; MAX_VALUES],
    count: usize,
    units: Unit,
    scan_flags: u16,
    real_time_index: Option<u8>,
    status: u8,
}

impl MeasuredValues {
    /// No values yet.
    pub const fn empty(units: Unit, status: u8) -> Self {
        MeasuredValues {
            values: [0; MAX_VALUES],
            count: 0,
            units,
            scan_flags: 0,
            real_time_index: None,
            status,
        }
    }

    /// A scan of `count` raw value words (range + flags) that `fill` writes
    /// in place, so that a simulator needs no staging copy of them.
    pub fn from_fill(
        count: usize,
        units: Unit,
        status: u8,
        fill: impl FnOnce(&mut [u16]),
    ) -> Result<Self, MeasuredError> {
        let mut v = MeasuredValues::empty(units, status);
        fill(
            v.values
                .get_mut(..count)
                .ok_or(MeasuredError::TooManyValues { count })?,
        );
        v.count = count;
        Ok(v)
    }

    /// A scan from raw value words (range + flags), e.g. for a simulator.
    pub fn from_raw(values: &[u16], units: Unit, status: u8) -> Result<Self, MeasuredError> {
        if values.len() > MAX_VALUES {
            return Err(MeasuredError::TooManyValues {
                count: values.len(),
            });
        }
        let mut v = MeasuredValues::empty(units, status);
        for (slot, w) in v.values.iter_mut().zip(values) {
            *slot = *w;
        }
        v.count = values.len();
        Ok(v)
    }

    /// A scan from a frame in metres: valid ranges rounded to `units`
    /// (ranges at or above the first error code become "above the maximum
    /// range"), invalid beams as their error code
    /// ([`RangeBits::encode_invalid`]); flags 0.
    pub fn from_frame(frame: &Frame, units: Unit, bits: RangeBits, status: u8) -> Self {
        let mut v = MeasuredValues::empty(units, status);
        let first_code = bits.first_error_code();
        let beams = frame.ranges().iter().zip(frame.beams());
        for (slot, (&r, &beam)) in v.values.iter_mut().zip(beams) {
            *slot = match beam {
                Beam::Valid => {
                    let scaled = libm::roundf(r * units.per_metre());
                    if scaled < f32::from(first_code) {
                        // In 0.0..first_code: the cast is exact.
                        scaled as u16
                    } else {
                        bits.encode_invalid(Invalid::AboveMax)
                    }
                }
                Beam::Invalid(why) => bits.encode_invalid(why),
            };
        }
        v.count = frame.len().min(MAX_VALUES);
        v
    }

    /// The owned scan of a sensor → host `B0` telegram.
    pub fn parse(telegram: &Telegram<&[u8]>) -> Result<Self, MeasuredError> {
        let view = MeasuredView::parse(telegram)?;
        Ok(view.to_values(telegram.status().unwrap_or(0)))
    }

    /// The value words (range + flags).
    #[inline]
    pub fn values(&self) -> &[u16] {
        self.values.get(..self.count).unwrap_or_default()
    }

    /// The value words, to change them in place.
    #[inline]
    pub fn values_mut(&mut self) -> &mut [u16] {
        self.values.get_mut(..self.count).unwrap_or_default()
    }

    /// Number of values.
    #[inline]
    pub fn count(&self) -> usize {
        self.count
    }

    /// Unit of the ranges.
    #[inline]
    pub fn units(&self) -> Unit {
        self.units
    }

    /// The status byte sent after the values.
    #[inline]
    pub fn status(&self) -> u8 {
        self.status
    }

    /// Set the status byte.
    #[inline]
    pub fn set_status(&mut self, status: u8) {
        self.status = status;
    }

    /// Count-word bits 10–13 in place.
    #[inline]
    pub fn scan_flags(&self) -> u16 {
        self.scan_flags
    }

    /// Set count-word bits 10–13 (other bits of `flags` are ignored).
    #[inline]
    pub fn set_scan_flags(&mut self, flags: u16) {
        self.scan_flags = flags & SCAN_FLAGS_MASK;
    }

    /// The real-time scan index sent after the values, if any.
    #[inline]
    pub fn real_time_index(&self) -> Option<u8> {
        self.real_time_index
    }

    /// Send (`Some`) or leave out (`None`) the real-time scan index.
    #[inline]
    pub fn set_real_time_index(&mut self, index: Option<u8>) {
        self.real_time_index = index;
    }

    /// The count word `W`: count | scan flags | units.
    pub fn count_word(&self) -> u16 {
        count_word(self.count, self.units) | (self.scan_flags & SCAN_FLAGS_MASK)
    }

    /// The scan variant of this many values, if any.
    pub fn variant(&self) -> Option<Variant> {
        Variant::from_beams(self.count)
    }

    /// A frame in metres with `bits` range bits (see the [module docs](self)).
    pub fn to_frame(&self, bits: RangeBits) -> Result<Frame, MeasuredError> {
        words_to_frame(self.count, self.values().iter().copied(), self.units, bits)
    }

    /// Data bytes of the telegram: count word + 2 per value (+ 1 for the
    /// real-time index).
    #[inline]
    pub fn data_len(&self) -> usize {
        2 + 2 * self.count + usize::from(self.real_time_index.is_some())
    }

    /// Bytes of the complete telegram (732 for 361 values).
    #[inline]
    pub fn buffer_len(&self) -> usize {
        buffer_len(self.data_len(), Direction::SensorToHost)
    }

    /// Write the `B0` telegram from the sensor at `address` (0..=0x7F;
    /// `ADDR = 0x80 | address`); returns its length.
    pub fn emit(&self, address: u8, buf: &mut [u8]) -> Result<usize, EmitError> {
        emit_telegram_with(
            buf,
            Head {
                address: Direction::SensorToHost.address_byte(address),
                command: MEASURED_COMMAND,
            },
            self.data_len(),
            Some(self.status),
            |data| self.write_data(data),
        )
    }

    /// Write count word and values into `data` (as much as fits).
    pub fn write_data(&self, data: &mut [u8]) {
        put_le_u16(data, 0, self.count_word());
        let slots = data.get_mut(2..).unwrap_or_default().chunks_exact_mut(2);
        for (slot, w) in slots.zip(self.values()) {
            put_le_u16(slot, 0, *w);
        }
        if let (Some(index), Some(slot)) = (self.real_time_index, data.get_mut(2 + 2 * self.count))
        {
            *slot = index;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn telegram_range_bits_decode() {
        let b = RangeBits::Bits13;
        assert_eq!(b.decode(0), Err(Invalid::Zero));
        assert_eq!(b.decode(1), Ok(1));
        assert_eq!(b.decode(8182), Ok(8182));
        assert_eq!(b.decode(8183), Err(Invalid::AboveMax));
        assert_eq!(b.decode(8184), Err(Invalid::OtherCode(7)));
        assert_eq!(b.decode(8186), Err(Invalid::ChannelError));
        assert_eq!(b.decode(8187), Err(Invalid::LowSignal));
        assert_eq!(b.decode(8188), Err(Invalid::OtherCode(3)));
        assert_eq!(b.decode(8189), Err(Invalid::Overflow));
        assert_eq!(b.decode(8190), Err(Invalid::Dazzle));
        assert_eq!(b.decode(8191), Err(Invalid::NoEcho));
        // Flags do not change the range.
        assert_eq!(b.decode(0xE000 | 1234), Ok(1234));
        assert_eq!(b.flags(0xE000 | 1234), 0xE000);
        assert_eq!(b.decode(0xFFFF), Err(Invalid::NoEcho));
        let b = RangeBits::Bits14;
        assert_eq!(b.decode(8191), Ok(8191));
        assert_eq!(b.decode(16374), Ok(16374));
        assert_eq!(b.decode(16375), Err(Invalid::AboveMax));
        assert_eq!(b.decode(0xC000 | 16383), Err(Invalid::NoEcho));
        assert_eq!(b.flags(0xC000 | 5), 0xC000);
        let b = RangeBits::Bits15;
        assert_eq!(b.decode(32766), Err(Invalid::Dazzle));
        assert_eq!(b.decode(0x8000 | 16383), Ok(16383));
        assert_eq!(b.decode(0x8000), Err(Invalid::Zero));
        for bits in [RangeBits::Bits13, RangeBits::Bits14, RangeBits::Bits15] {
            for why in [
                Invalid::NoEcho,
                Invalid::Dazzle,
                Invalid::Overflow,
                Invalid::LowSignal,
                Invalid::ChannelError,
                Invalid::AboveMax,
                Invalid::OtherCode(3),
                Invalid::Zero,
            ] {
                assert_eq!(bits.decode(bits.encode_invalid(why)), Err(why));
            }
        }
    }

    #[test]
    fn telegram_units_bits() {
        assert_eq!(Unit::from_count_word(0x0169), Some(Unit::Centimetre));
        assert_eq!(Unit::from_count_word(0x4169), Some(Unit::Millimetre));
        assert_eq!(Unit::from_count_word(0x8169), Some(Unit::Decimetre));
        assert_eq!(Unit::from_count_word(0xC169), None);
        for u in [Unit::Centimetre, Unit::Millimetre, Unit::Decimetre] {
            assert_eq!(Unit::from_count_word(u.count_word_bits()), Some(u));
        }
    }

    #[test]
    fn telegram_measured_data_checks() {
        assert_eq!(MeasuredView::new(&[0x01]), Err(MeasuredError::MissingCount));
        assert_eq!(
            MeasuredView::new(&[0x00, 0xC0]),
            Err(MeasuredError::BadUnits { count_word: 0xC000 })
        );
        assert_eq!(
            MeasuredView::new(&[0x92, 0x01]),
            Err(MeasuredError::TooManyValues { count: 402 })
        );
        assert_eq!(
            MeasuredView::new(&[0x02, 0x00, 1, 0]),
            Err(MeasuredError::LengthMismatch {
                count: 2,
                data_len: 4
            })
        );
        let v = MeasuredView::new(&[0x02, 0x24, 0x34, 0x12, 0xFF, 0xFF]).unwrap();
        assert_eq!(v.count(), 2);
        assert_eq!(v.units(), Unit::Centimetre);
        assert_eq!(v.scan_flags(), 0x2400);
        assert_eq!(v.word(0), Some(0x1234));
        assert_eq!(v.word(1), Some(0xFFFF));
        assert_eq!(v.word(2), None);
        assert_eq!(
            v.to_frame(RangeBits::Bits13).err(),
            Some(MeasuredError::UnsupportedCount { count: 2 })
        );
        let owned = v.to_values(0x10);
        assert_eq!(owned.values(), &[0x1234, 0xFFFF]);
        assert_eq!(owned.count_word(), 0x2402);
        let mut data = [0u8; 6];
        owned.write_data(&mut data);
        assert_eq!(data, [0x02, 0x24, 0x34, 0x12, 0xFF, 0xFF]);
    }

    #[test]
    fn telegram_measured_to_frame_units() {
        let mut words = [0u16; 181];
        words[0] = 1234;
        words[1] = 0;
        words[2] = 8191;
        words[3] = 8183;
        words[4] = 8182 | 0xE000;
        words[180] = 1;
        for (units, m0, m4) in [
            (Unit::Centimetre, 12.34f32, 81.82f32),
            (Unit::Millimetre, 1.234, 8.182),
            (Unit::Decimetre, 123.4, 818.2),
        ] {
            let v = MeasuredValues::from_raw(&words, units, 0x10).unwrap();
            let f = v.to_frame(RangeBits::Bits13).unwrap();
            assert_eq!(f.len(), 181);
            assert_eq!(f.ranges()[0], m0);
            assert_eq!(f.beams()[1], Beam::Invalid(Invalid::Zero));
            assert_eq!(f.beams()[2], Beam::Invalid(Invalid::NoEcho));
            assert_eq!(f.beams()[3], Beam::Invalid(Invalid::AboveMax));
            assert_eq!(f.ranges()[4], m4);
            assert_eq!(f.beams()[4], Beam::Valid);
            assert_eq!(f.ranges()[180], 1.0 / units.per_metre());
            assert_eq!(f.valid_count(), 3);
        }
    }

    #[test]
    fn telegram_measured_from_frame_round_trip() {
        for variant in Variant::ALL {
            let n = variant.beams();
            let mut words = [0u16; MAX_VALUES];
            for (j, w) in words.iter_mut().enumerate().take(n) {
                *w = match j % 7 {
                    0 => 8191,
                    1 => 0,
                    2 => 8186,
                    _ => (j as u16 * 13) % 8183 + 1,
                };
            }
            let v = MeasuredValues::from_raw(&words[..n], Unit::Millimetre, 0x10).unwrap();
            assert_eq!(v.variant(), Some(variant));
            let f = v.to_frame(RangeBits::Bits13).unwrap();
            assert_eq!(f.len(), n);
            let back = MeasuredValues::from_frame(&f, Unit::Millimetre, RangeBits::Bits13, 0x10);
            assert_eq!(back.values(), v.values(), "{variant:?}");
        }
        // A range beyond the largest encodable becomes "above the maximum".
        let mut f = Frame::for_variant(Variant::Fov100Res100);
        f.set_metres(0, 8.19);
        f.set_metres(1, 8.1824);
        let v = MeasuredValues::from_frame(&f, Unit::Millimetre, RangeBits::Bits13, 0);
        assert_eq!(&v.values()[..3], &[8183, 8182, 8191]);
    }

    /// Bytes of a sensor telegram written out in hex.
    fn hex(s: &str) -> std::vec::Vec<u8> {
        s.split_whitespace()
            .map(|b| u8::from_str_radix(b, 16).unwrap())
            .collect()
    }

    #[test]
    fn b0_with_a_real_time_index_is_byte_exact() {
        // 3 values (100, 200, 300 cm), the index 0x2A, status 0x10.
        let want = hex("02 80 0B 00 B0 03 00 64 00 C8 00 2C 01 2A 10 2B 73");
        let mut v = MeasuredValues::from_raw(&[100, 200, 300], Unit::Centimetre, 0x10).unwrap();
        v.set_real_time_index(Some(0x2A));
        let mut buf = [0u8; 32];
        let n = v.emit(0, &mut buf).unwrap();
        assert_eq!(&buf[..n], &want[..]);
        let t = Telegram::new_checked(&want[..], Direction::SensorToHost).unwrap();
        let view = MeasuredView::parse(&t).unwrap();
        assert_eq!(view.real_time_index(), Some(0x2A));
        assert_eq!(view.words().collect::<std::vec::Vec<_>>(), [100, 200, 300]);
        assert_eq!(view.partial_offset(), None);
        assert_eq!(MeasuredValues::parse(&t), Ok(v));
        // Without the index: one byte less, none read.
        let plain = hex("02 80 0A 00 B0 03 00 64 00 C8 00 2C 01 10");
        let mut plain = plain.clone();
        let crc = crate::telegram::crc16(&plain);
        plain.extend_from_slice(&crc.to_le_bytes());
        let t = Telegram::new_checked(&plain[..], Direction::SensorToHost).unwrap();
        assert_eq!(MeasuredView::parse(&t).unwrap().real_time_index(), None);
    }

    #[test]
    fn a_partial_scan_with_an_index_is_byte_exact() {
        // 2 values (1000, 2000 mm) of the partial scan at 2 × 0.25°:
        // W = 0x7002 (bit 14 mm, bit 13 partial, bits 11–12 = 2, count 2).
        let want = hex("02 80 09 00 B0 02 70 E8 03 D0 07 07 10 7C EE");
        let mut v = MeasuredValues::from_raw(&[1000, 2000], Unit::Millimetre, 0x10).unwrap();
        v.set_scan_flags(partial_scan_flags(2));
        v.set_real_time_index(Some(7));
        let mut buf = [0u8; 32];
        let n = v.emit(0, &mut buf).unwrap();
        assert_eq!(&buf[..n], &want[..]);
        let t = Telegram::new_checked(&want[..], Direction::SensorToHost).unwrap();
        let view = MeasuredView::parse(&t).unwrap();
        assert_eq!(view.partial_offset(), Some(2));
        assert_eq!(view.real_time_index(), Some(7));
        assert_eq!(view.units(), Unit::Millimetre);
        assert_eq!(partial_offset(partial_scan_flags(3)), Some(3));
        assert_eq!(partial_offset(0x1800), None, "offset bits without bit 13");
    }
}
