//! The range unit of the LMS 2xx (PROTOCOL.md §3): the one unit type of the
//! workspace, used by the `B0` codec, the configuration and status blocks,
//! the recorded-log readers and the command-line tools.

use core::fmt;

/// Unit of the range values, from bits 14–15 of the count word.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Unit {
    /// Centimetres (`00`, the default; largest range 81.82 m).
    Centimetre,
    /// Millimetres (`01`; largest range 8.182 m).
    Millimetre,
    /// Decimetres, 10 cm (`10`).
    Decimetre,
}

impl Unit {
    /// The units in a count word; `None` for the undefined `11`.
    pub const fn from_count_word(w: u16) -> Option<Self> {
        match w >> 14 {
            0 => Some(Unit::Centimetre),
            1 => Some(Unit::Millimetre),
            2 => Some(Unit::Decimetre),
            _ => None,
        }
    }

    /// Bits 14–15 of the count word for these units.
    pub const fn count_word_bits(self) -> u16 {
        match self {
            Unit::Centimetre => 0x0000,
            Unit::Millimetre => 0x4000,
            Unit::Decimetre => 0x8000,
        }
    }

    /// Units from the code in the `B1` status block and the configuration
    /// block (0 cm, 1 mm).
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Unit::Centimetre),
            1 => Some(Unit::Millimetre),
            _ => None,
        }
    }

    /// The code in `B1` and the configuration (0 cm, 1 mm; 10 cm has none).
    pub const fn code(self) -> Option<u8> {
        match self {
            Unit::Centimetre => Some(0),
            Unit::Millimetre => Some(1),
            Unit::Decimetre => None,
        }
    }

    /// Units in one metre: 100 (cm), 1000 (mm), 10 (10 cm).
    pub const fn per_metre(self) -> f32 {
        match self {
            Unit::Centimetre => 100.0,
            Unit::Millimetre => 1000.0,
            Unit::Decimetre => 10.0,
        }
    }

    /// The all-ones value of the range field of a recorded log in this unit
    /// (PROTOCOL.md §3; `shared/data/README.md`): the last error code, "not
    /// valid". 8191 for cm and 10 cm (13 range bits), 32 767 for mm (the
    /// 32 m mode, 15 range bits: the Örebro log's 32.767 m).
    pub const fn all_ones(self) -> u16 {
        match self {
            Unit::Centimetre | Unit::Decimetre => 0x1FFF,
            Unit::Millimetre => 0x7FFF,
        }
    }

    /// The first (lowest) error code of a recorded log in this unit,
    /// `all_ones − 8` (8183 cm = 81.83 m, 32 759 mm = 32.759 m): every
    /// reading at or above it is invalid, with the reason
    /// [`Invalid::from_code_offset`](crate::Invalid::from_code_offset)`(all_ones − value)`.
    pub const fn first_error_code(self) -> u16 {
        self.all_ones() - 8
    }
}

impl fmt::Display for Unit {
    /// `cm`, `mm` or `10 cm`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unit::Centimetre => "cm",
            Unit::Millimetre => "mm",
            Unit::Decimetre => "10 cm",
        })
    }
}
