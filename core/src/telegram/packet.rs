//! A typed view over the bytes of one telegram, and the emitter.
//!
//! ```text
//! offset  0     1      2..4        4     5 …            4+LEN−1    4+LEN..6+LEN
//!         STX   ADDR   LEN (LE)    CMD   DATA …         [STATUS]   CRC (LE)
//! ```
//!
//! `LEN` counts `CMD`, `DATA` and, in sensor → host telegrams, `STATUS`.
//! The [`Direction`] given to the view decides whether the byte before the
//! CRC is a status byte or the last data byte.
//!
//! After [`Telegram::new_checked`] succeeds no accessor can panic, and each
//! returns its field. The accessors never panic on an unchecked view either:
//! missing fields read as 0 or as an empty slice.

use core::fmt;

use super::crc::crc16;
use super::{copy_into, le_u16, Direction, CRC_LEN, HEADER_LEN, MAX_LEN, STX};

/// Offsets of the fixed fields.
mod field {
    pub const STX: usize = 0;
    pub const ADDR: usize = 1;
    pub const LEN: usize = 2;
    pub const CMD: usize = 4;
    pub const DATA: usize = 5;
}

/// Why bytes are not a telegram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TelegramError {
    /// The buffer holds fewer bytes than the telegram needs.
    Truncated {
        /// Bytes needed: 4 for the header, `6 + LEN` once `LEN` is known.
        needed: usize,
    },
    /// The first byte is not `STX` (0x02).
    NoStx {
        /// The byte found instead.
        found: u8,
    },
    /// `LEN` is smaller than the command (+ status byte) of this direction.
    TooShort {
        /// The `LEN` field.
        len: u16,
    },
    /// `LEN` exceeds [`MAX_LEN`].
    TooLong {
        /// The `LEN` field.
        len: u16,
    },
    /// The checksum does not match.
    BadCrc {
        /// Checksum in the telegram.
        received: u16,
        /// Checksum computed over the bytes.
        computed: u16,
    },
}

impl fmt::Display for TelegramError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TelegramError::Truncated { needed } => {
                write!(f, "truncated telegram: {needed} bytes needed")
            }
            TelegramError::NoStx { found } => write!(f, "expected STX 0x02, found {found:#04x}"),
            TelegramError::TooShort { len } => write!(f, "LEN {len} too short"),
            TelegramError::TooLong { len } => write!(f, "LEN {len} above {MAX_LEN}"),
            TelegramError::BadCrc { received, computed } => write!(
                f,
                "bad checksum: received {received:#06x}, computed {computed:#06x}"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for TelegramError {}

/// Why a telegram could not be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum EmitError {
    /// The output buffer is too small; nothing useful was written.
    BufferTooSmall {
        /// Bytes the complete telegram needs.
        needed: usize,
    },
    /// The payload would make `LEN` exceed [`MAX_LEN`].
    TooLong {
        /// The `LEN` the telegram would have (saturated at `usize::MAX`).
        len: usize,
    },
}

impl fmt::Display for EmitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EmitError::BufferTooSmall { needed } => {
                write!(f, "output buffer too small: {needed} bytes needed")
            }
            EmitError::TooLong { len } => write!(f, "LEN {len} above {MAX_LEN}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EmitError {}

/// A view over the bytes of one telegram (see the [module docs](self)).
///
/// The buffer may be longer than the telegram; the view covers its first
/// [`total_len`](Telegram::total_len) bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Telegram<T: AsRef<[u8]>> {
    buffer: T,
    direction: Direction,
}

impl<T: AsRef<[u8]>> Telegram<T> {
    /// Wrap bytes without checking them (accessors still never panic).
    #[inline]
    pub const fn new_unchecked(buffer: T, direction: Direction) -> Self {
        Telegram { buffer, direction }
    }

    /// Wrap bytes and check `STX`, `LEN` (at least the command (+ status),
    /// at most [`MAX_LEN`], within the buffer) and the CRC.
    pub fn new_checked(buffer: T, direction: Direction) -> Result<Self, TelegramError> {
        let t = Self::new_unchecked(buffer, direction);
        t.check()?;
        Ok(t)
    }

    /// The checks of [`new_checked`](Telegram::new_checked).
    pub fn check(&self) -> Result<(), TelegramError> {
        let b = self.buffer.as_ref();
        match b.first() {
            None => return Err(TelegramError::Truncated { needed: HEADER_LEN }),
            Some(&STX) => {}
            Some(&found) => return Err(TelegramError::NoStx { found }),
        }
        if b.len() < HEADER_LEN {
            return Err(TelegramError::Truncated { needed: HEADER_LEN });
        }
        let len = le_u16(b, field::LEN);
        if usize::from(len) < self.direction.min_len() {
            return Err(TelegramError::TooShort { len });
        }
        if usize::from(len) > MAX_LEN {
            return Err(TelegramError::TooLong { len });
        }
        let total = HEADER_LEN + usize::from(len) + CRC_LEN;
        if b.len() < total {
            return Err(TelegramError::Truncated { needed: total });
        }
        let covered = b.get(..total - CRC_LEN).unwrap_or_default();
        let received = le_u16(b, total - CRC_LEN);
        let computed = crc16(covered);
        if received != computed {
            return Err(TelegramError::BadCrc { received, computed });
        }
        Ok(())
    }

    /// The direction given at construction.
    #[inline]
    pub fn direction(&self) -> Direction {
        self.direction
    }

    /// The underlying buffer.
    #[inline]
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The raw `ADDR` byte (`0x80 | address` from the sensor).
    #[inline]
    pub fn address(&self) -> u8 {
        self.buffer.as_ref().get(field::ADDR).copied().unwrap_or(0)
    }

    /// The sensor address: `ADDR` without the reply bit (0..=0x7F).
    #[inline]
    pub fn sensor_address(&self) -> u8 {
        self.address() & !super::REPLY_ADDRESS_BIT
    }

    /// The `LEN` field: bytes from `CMD` up to, not including, the CRC.
    #[inline]
    pub fn length(&self) -> u16 {
        le_u16(self.buffer.as_ref(), field::LEN)
    }

    /// Bytes of the whole telegram, `6 + LEN`.
    #[inline]
    pub fn total_len(&self) -> usize {
        HEADER_LEN + usize::from(self.length()) + CRC_LEN
    }

    /// The command code.
    #[inline]
    pub fn command(&self) -> u8 {
        self.buffer.as_ref().get(field::CMD).copied().unwrap_or(0)
    }

    /// `LEN` bytes from `CMD` on: command, data (and status).
    #[inline]
    pub fn payload(&self) -> &[u8] {
        let end = HEADER_LEN + usize::from(self.length());
        self.buffer
            .as_ref()
            .get(field::CMD..end)
            .unwrap_or_default()
    }

    /// The data bytes between the command and the status byte (or the CRC
    /// in host → sensor telegrams).
    #[inline]
    pub fn data(&self) -> &[u8] {
        self.buffer
            .as_ref()
            .get(self.data_range())
            .unwrap_or_default()
    }

    /// Where [`data`](Telegram::data) lies in the buffer.
    #[inline]
    fn data_range(&self) -> core::ops::Range<usize> {
        let status = usize::from(self.direction.has_status());
        let end = (HEADER_LEN + usize::from(self.length())).saturating_sub(status);
        field::DATA..end
    }

    /// The status byte of a sensor → host telegram; `None` host → sensor.
    #[inline]
    pub fn status(&self) -> Option<u8> {
        if !self.direction.has_status() {
            return None;
        }
        let at = (HEADER_LEN + usize::from(self.length())).checked_sub(1)?;
        if at < field::DATA {
            return None;
        }
        self.buffer.as_ref().get(at).copied()
    }

    /// The checksum as received.
    #[inline]
    pub fn crc(&self) -> u16 {
        le_u16(
            self.buffer.as_ref(),
            HEADER_LEN + usize::from(self.length()),
        )
    }

    /// The checksum computed over `STX` … the byte before the CRC.
    pub fn compute_crc(&self) -> u16 {
        let end = HEADER_LEN + usize::from(self.length());
        crc16(self.buffer.as_ref().get(..end).unwrap_or_default())
    }

    /// The telegram's bytes, `STX` to CRC (empty if the buffer is shorter).
    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        self.buffer
            .as_ref()
            .get(..self.total_len())
            .unwrap_or_default()
    }

    /// `true` if the first byte is `STX` (cheap pre-check).
    #[inline]
    pub fn starts_with_stx(&self) -> bool {
        self.buffer.as_ref().get(field::STX) == Some(&STX)
    }
}

impl<'a> Telegram<&'a [u8]> {
    /// [`data`](Telegram::data), borrowed for as long as the bytes
    /// themselves (so parsed values can outlive the view).
    #[inline]
    pub fn into_data(self) -> &'a [u8] {
        self.buffer.get(self.data_range()).unwrap_or_default()
    }
}

/// Bytes of a complete telegram with `data_len` data bytes:
/// `4 + 1 + data_len (+ 1 status) + 2`.
#[inline]
pub const fn buffer_len(data_len: usize, direction: Direction) -> usize {
    let status = if direction.has_status() { 1 } else { 0 };
    HEADER_LEN
        .saturating_add(1)
        .saturating_add(data_len)
        .saturating_add(status)
        .saturating_add(CRC_LEN)
}

/// The bytes that say whom a telegram is for and what it asks or answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Head {
    /// The raw `ADDR` byte (`0x80 | address` from the sensor).
    pub address: u8,
    /// The command byte.
    pub command: u8,
}

impl Head {
    /// `command` from a host to the sensor at address 0 (`ADDR` 0x00).
    pub const fn to_sensor(command: u8) -> Head {
        Head {
            address: 0x00,
            command,
        }
    }

    /// `command` from the sensor at address 0 to its host (`ADDR` 0x80).
    pub const fn from_sensor(command: u8) -> Head {
        Head {
            address: super::REPLY_ADDRESS_BIT,
            command,
        }
    }
}

/// Write a complete telegram `STX | address | LEN | command | data |
/// [status] | CRC` into `buf`; returns its length in bytes.
///
/// `head.address` is the raw `ADDR` byte (see [`Direction::address_byte`]);
/// a `status` makes it a sensor → host telegram.
///
/// ```
/// use lms_core::telegram::{emit_telegram, Head};
/// let mut buf = [0u8; 8];
/// assert_eq!(emit_telegram(&mut buf, Head::from_sensor(0x92), &[], Some(0x10)), Ok(8));
/// assert_eq!(buf, [0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33]);
/// ```
pub fn emit_telegram(
    buf: &mut [u8],
    head: Head,
    data: &[u8],
    status: Option<u8>,
) -> Result<usize, EmitError> {
    emit_telegram_with(buf, head, data.len(), status, |d| copy_into(d, data))
}

/// Like [`emit_telegram`], but `fill` writes the `data_len` data bytes in
/// place (it gets a slice of exactly that length), so large payloads need
/// no second buffer. The CRC is computed after `fill` returns.
pub fn emit_telegram_with<F: FnOnce(&mut [u8])>(
    buf: &mut [u8],
    head: Head,
    data_len: usize,
    status: Option<u8>,
    fill: F,
) -> Result<usize, EmitError> {
    let len = data_len
        .saturating_add(1)
        .saturating_add(usize::from(status.is_some()));
    if len > MAX_LEN {
        return Err(EmitError::TooLong { len });
    }
    let total = HEADER_LEN + len + CRC_LEN;
    let too_small = EmitError::BufferTooSmall { needed: total };
    let out = buf.get_mut(..total).ok_or(too_small)?;
    // `len <= MAX_LEN` fits in a u16.
    let len_bytes = u16::try_from(len).map_err(|_| EmitError::TooLong { len })?;
    let (header, rest) = out
        .split_first_chunk_mut::<{ HEADER_LEN + 1 }>()
        .ok_or(too_small)?;
    let [lo, hi] = len_bytes.to_le_bytes();
    *header = [STX, head.address, lo, hi, head.command];
    let (body, _crc) = rest.split_last_chunk_mut::<CRC_LEN>().ok_or(too_small)?;
    let (data, tail) = body.split_at_mut_checked(data_len).ok_or(too_small)?;
    fill(data);
    if let (Some(s), Some(slot)) = (status, tail.first_mut()) {
        *slot = s;
    }
    let covered = out.get(..total - CRC_LEN).ok_or(too_small)?;
    let crc = crc16(covered).to_le_bytes();
    let crc_slot = out.get_mut(total - CRC_LEN..).ok_or(too_small)?;
    copy_into(crc_slot, &crc);
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    const STATUS_REQUEST: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12];
    const BB_REPLY: [u8; 13] = [
        0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D,
    ];

    #[test]
    fn telegram_deconstruct_request() {
        let t = Telegram::new_checked(&STATUS_REQUEST[..], Direction::HostToSensor).unwrap();
        assert_eq!(t.address(), 0x00);
        assert_eq!(t.length(), 1);
        assert_eq!(t.total_len(), 7);
        assert_eq!(t.command(), 0x31);
        assert_eq!(t.data(), &[] as &[u8]);
        assert_eq!(t.payload(), &[0x31]);
        assert_eq!(t.status(), None);
        assert_eq!(t.crc(), 0x1215);
        assert_eq!(t.compute_crc(), 0x1215);
        assert_eq!(t.as_bytes(), &STATUS_REQUEST);
    }

    #[test]
    fn telegram_deconstruct_reply() {
        let t = Telegram::new_checked(&BB_REPLY[..], Direction::SensorToHost).unwrap();
        assert_eq!(t.address(), 0x80);
        assert_eq!(t.sensor_address(), 0x00);
        assert_eq!(t.length(), 7);
        assert_eq!(t.command(), 0xBB);
        assert_eq!(t.data(), &[0x01, 0xB4, 0x00, 0x32, 0x00]);
        assert_eq!(t.status(), Some(0x10));
        assert_eq!(t.crc(), 0x9D03);
        // The same bytes read host → sensor: the status byte is data.
        let h = Telegram::new_checked(&BB_REPLY[..], Direction::HostToSensor).unwrap();
        assert_eq!(h.data(), &[0x01, 0xB4, 0x00, 0x32, 0x00, 0x10]);
        assert_eq!(h.status(), None);
    }

    #[test]
    fn telegram_construct() {
        let mut buf = [0xEEu8; 20];
        let n = emit_telegram(
            &mut buf,
            Head::from_sensor(0xBB),
            &[0x01, 0xB4, 0x00, 0x32, 0x00],
            Some(0x10),
        );
        assert_eq!(n, Ok(13));
        assert_eq!(&buf[..13], &BB_REPLY);
        assert!(buf[13..].iter().all(|&b| b == 0xEE));
        assert_eq!(buffer_len(5, Direction::SensorToHost), 13);
        assert_eq!(buffer_len(0, Direction::HostToSensor), 7);
        let n = emit_telegram(&mut buf, Head::to_sensor(0x31), &[], None);
        assert_eq!(n, Ok(7));
        assert_eq!(&buf[..7], &STATUS_REQUEST);
    }

    #[test]
    fn telegram_emit_errors() {
        let mut small = [0u8; 12];
        assert_eq!(
            emit_telegram(
                &mut small,
                Head::from_sensor(0xBB),
                &[1, 2, 3, 4, 5],
                Some(0x10)
            ),
            Err(EmitError::BufferTooSmall { needed: 13 })
        );
        let mut big = [0u8; 900];
        let data = [0u8; 812];
        assert_eq!(
            emit_telegram(&mut big, Head::to_sensor(0x77), &data, None),
            Err(EmitError::TooLong { len: 813 })
        );
        assert_eq!(
            emit_telegram(&mut big, Head::to_sensor(0x77), &data[..811], None),
            Ok(818)
        );
        assert_eq!(
            emit_telegram_with(&mut big, Head::to_sensor(0), usize::MAX, Some(0), |_| {}),
            Err(EmitError::TooLong { len: usize::MAX })
        );
    }

    #[test]
    fn telegram_check_errors() {
        let d = Direction::SensorToHost;
        assert_eq!(
            Telegram::new_checked(&[][..], d),
            Err(TelegramError::Truncated { needed: 4 })
        );
        assert_eq!(
            Telegram::new_checked(&[0x03, 0, 0, 0][..], d),
            Err(TelegramError::NoStx { found: 3 })
        );
        assert_eq!(
            Telegram::new_checked(&[0x02, 0x80, 0x02][..], d),
            Err(TelegramError::Truncated { needed: 4 })
        );
        assert_eq!(
            Telegram::new_checked(&[0x02, 0x80, 0x01, 0x00, 0x92, 0, 0][..], d),
            Err(TelegramError::TooShort { len: 1 })
        );
        assert_eq!(
            Telegram::new_checked(&[0x02, 0x80, 0x2D, 0x03][..], d),
            Err(TelegramError::TooLong { len: 813 })
        );
        assert_eq!(
            Telegram::new_checked(&BB_REPLY[..12], d),
            Err(TelegramError::Truncated { needed: 13 })
        );
        let mut bad = BB_REPLY;
        bad[12] ^= 1;
        assert_eq!(
            Telegram::new_checked(&bad[..], d),
            Err(TelegramError::BadCrc {
                received: 0x9C03,
                computed: 0x9D03
            })
        );
        // LEN 0 is fine for nobody.
        assert_eq!(
            Telegram::new_checked(&[0x02, 0x00, 0x00, 0x00, 0, 0][..], Direction::HostToSensor),
            Err(TelegramError::TooShort { len: 0 })
        );
    }

    #[test]
    fn telegram_unchecked_accessors_never_panic() {
        let cases: [&[u8]; 6] = [
            &[],
            &[0x02],
            &[0x02, 0x80, 0xFF, 0xFF],
            &[0x02, 0x80, 0x00, 0x00],
            &[0x02, 0x80, 0x01, 0x00, 0xB0],
            &BB_REPLY[..9],
        ];
        for bytes in cases {
            for dir in [Direction::HostToSensor, Direction::SensorToHost] {
                let t = Telegram::new_unchecked(bytes, dir);
                let _ = (t.address(), t.length(), t.total_len(), t.command());
                let _ = (t.payload(), t.data(), t.status(), t.crc(), t.compute_crc());
                let _ = t.as_bytes();
                assert!(t.check().is_err());
            }
        }
        // LEN 1 from the sensor: status byte would be the command itself.
        let t =
            Telegram::new_unchecked(&[0x02, 0x80, 0x01, 0x00, 0xB0][..], Direction::SensorToHost);
        assert_eq!(t.status(), None);
        assert_eq!(t.data(), &[] as &[u8]);
    }
}
