//! The status byte of sensor replies, and the 152-byte `B1` status block
//! (PROTOCOL.md §1–§2).
//!
//! `B1` field offsets in PROTOCOL.md count the payload from the command
//! (index 0 = `B1`); [`StatusBlock`] holds the 152 data bytes, so its byte
//! `k` is payload index `k + 1`.
//!
//! | payload index | field |
//! |---|---|
//! | `[8]` | operating mode (e.g. `0x25` on request, `0x24` continuous) |
//! | `[107..=108]` | scan angle in degrees (u16 LE) |
//! | `[109..=110]` | angular resolution in 1/100 ° (u16 LE) |
//! | `[116..=117]` | baud word, 10⁶ / baud − 1 (u16 LE) |
//! | `[120]` | sensor address |
//! | `[122]` | units (0 cm, 1 mm) |

use super::request::Baud;
use super::{le_u16, put_le_u16};
use crate::frame::{FovRes, Variant};

/// Bytes of `B1` data (without the command and the status byte).
pub const STATUS_BLOCK_LEN: usize = 152;

/// Severity in bits 0–2 of the status byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Severity {
    /// 0: no error.
    Ok,
    /// 1: information.
    Info,
    /// 2: warning.
    Warning,
    /// 3: error.
    Error,
    /// 4: fatal error.
    Fatal,
    /// 5..=7: not defined.
    Unknown(u8),
}

/// The status byte at the end of every sensor → host telegram.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorStatus(pub u8);

impl SensorStatus {
    /// Severity, bits 0–2.
    pub const fn severity(self) -> Severity {
        match self.0 & 0x07 {
            0 => Severity::Ok,
            1 => Severity::Info,
            2 => Severity::Warning,
            3 => Severity::Error,
            4 => Severity::Fatal,
            other => Severity::Unknown(other),
        }
    }

    /// Bit 6: implausible measured values.
    pub const fn implausible(self) -> bool {
        self.0 & 0x40 != 0
    }

    /// Bit 7: pollution (dirty front screen).
    pub const fn pollution(self) -> bool {
        self.0 & 0x80 != 0
    }
}

/// The fields of [`StatusBlock`] this crate names: enough for a simulator
/// to answer `31` from its state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StatusFields {
    /// Operating mode code (`0x25` on request, `0x24` continuous, `0x00`
    /// installation).
    pub operating_mode: u8,
    /// Scan angle in degrees (100 or 180).
    pub scan_angle_deg: u16,
    /// Angular resolution in 1/100 ° (25, 50 or 100).
    pub resolution_centideg: u16,
    /// Serial line speed.
    pub baud: Baud,
    /// Sensor address (0..=0x7F).
    pub address: u8,
    /// Unit code (0 cm, 1 mm).
    pub units_code: u8,
}

impl Default for StatusFields {
    /// The power-on state: on request, 180°/1°, 9600 Bd, address 0, cm.
    fn default() -> Self {
        StatusFields {
            operating_mode: 0x25,
            scan_angle_deg: 180,
            resolution_centideg: 100,
            baud: Baud::B9600,
            address: 0,
            units_code: 0,
        }
    }
}

byte_block!(
    StatusBlock,
    STATUS_BLOCK_LEN,
    "152",
    "The 152 data bytes of a `B1` status reply."
);

impl StatusBlock {
    /// Data offset of the operating mode (payload index 8).
    pub const OPERATING_MODE: usize = 7;
    /// Data offset of the scan angle word (payload 107..=108).
    pub const SCAN_ANGLE: usize = 106;
    /// Data offset of the resolution word (payload 109..=110).
    pub const RESOLUTION: usize = 108;
    /// Data offset of the baud word (payload 116..=117).
    pub const BAUD_WORD: usize = 115;
    /// Data offset of the address (payload 120).
    pub const ADDRESS: usize = 119;
    /// Data offset of the units code (payload 122).
    pub const UNITS: usize = 121;

    /// A block with the named fields set and every other byte 0.
    pub fn from_fields(fields: &StatusFields) -> Self {
        let mut b = StatusBlock::default();
        b.set_fields(fields);
        b
    }

    /// Write the named fields, leaving the other bytes as they are.
    pub fn set_fields(&mut self, f: &StatusFields) {
        self.bytes[Self::OPERATING_MODE] = f.operating_mode;
        put_le_u16(&mut self.bytes, Self::SCAN_ANGLE, f.scan_angle_deg);
        put_le_u16(&mut self.bytes, Self::RESOLUTION, f.resolution_centideg);
        put_le_u16(&mut self.bytes, Self::BAUD_WORD, f.baud.status_word());
        self.bytes[Self::ADDRESS] = f.address;
        self.bytes[Self::UNITS] = f.units_code;
    }

    /// The named fields, if the baud word is one of the four rates.
    pub fn fields(&self) -> Option<StatusFields> {
        Some(StatusFields {
            operating_mode: self.operating_mode(),
            scan_angle_deg: self.scan_angle_deg(),
            resolution_centideg: self.resolution_centideg(),
            baud: self.baud()?,
            address: self.address(),
            units_code: self.units_code(),
        })
    }

    /// Operating mode code (payload `[8]`).
    #[inline]
    pub const fn operating_mode(&self) -> u8 {
        self.bytes[Self::OPERATING_MODE]
    }

    /// Scan angle in degrees (payload `[107..=108]`).
    #[inline]
    pub fn scan_angle_deg(&self) -> u16 {
        le_u16(&self.bytes, Self::SCAN_ANGLE)
    }

    /// Angular resolution in 1/100 ° (payload `[109..=110]`).
    #[inline]
    pub fn resolution_centideg(&self) -> u16 {
        le_u16(&self.bytes, Self::RESOLUTION)
    }

    /// The scan variant, if angle and resolution name one.
    #[inline]
    pub fn variant(&self) -> Option<Variant> {
        Variant::from_fov_res(FovRes {
            fov_deg: self.scan_angle_deg(),
            res_centideg: self.resolution_centideg(),
        })
    }

    /// Baud word, 10⁶ / baud − 1 (payload `[116..=117]`).
    #[inline]
    pub fn baud_word(&self) -> u16 {
        le_u16(&self.bytes, Self::BAUD_WORD)
    }

    /// The serial speed, if the baud word is one of the four rates.
    #[inline]
    pub fn baud(&self) -> Option<Baud> {
        Baud::from_status_word(self.baud_word())
    }

    /// Sensor address (payload `[120]`).
    #[inline]
    pub const fn address(&self) -> u8 {
        self.bytes[Self::ADDRESS]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::Unit;

    #[test]
    fn telegram_status_byte() {
        let s = SensorStatus(0x10);
        assert_eq!(s.severity(), Severity::Ok);
        assert!(!s.implausible() && !s.pollution());
        let s = SensorStatus(0xC3);
        assert_eq!(s.severity(), Severity::Error);
        assert!(s.implausible() && s.pollution());
        assert_eq!(SensorStatus(0x07).severity(), Severity::Unknown(7));
    }

    #[test]
    fn telegram_status_block_fields() {
        let f = StatusFields {
            operating_mode: 0x24,
            scan_angle_deg: 180,
            resolution_centideg: 50,
            baud: Baud::B500000,
            address: 0x05,
            units_code: 1,
        };
        let b = StatusBlock::from_fields(&f);
        // Payload index p is block byte p − 1.
        let mut payload = [0u8; 153];
        payload[0] = 0xB1;
        payload[1..].copy_from_slice(b.as_bytes());
        assert_eq!(payload[8], 0x24);
        assert_eq!(&payload[107..=108], &[180, 0]);
        assert_eq!(&payload[109..=110], &[50, 0]);
        assert_eq!(&payload[116..=117], &[1, 0]);
        assert_eq!(payload[120], 0x05);
        assert_eq!(payload[122], 1);
        let nonzero = payload[1..].iter().filter(|&&x| x != 0).count();
        assert_eq!(nonzero, 6);
        assert_eq!(b.fields(), Some(f));
        assert_eq!(b.variant(), Some(Variant::Fov180Res50));
        assert_eq!(b.units(), Some(Unit::Millimetre));
        let d = StatusBlock::from_fields(&StatusFields::default());
        assert_eq!(d.baud_word(), 103);
        assert_eq!(d.baud(), Some(Baud::B9600));
        assert_eq!(d.variant(), Some(Variant::Fov180Res100));
    }
}
