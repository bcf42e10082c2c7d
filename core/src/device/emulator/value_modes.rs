//! The LMS 2xx value modes beyond "all values": mean values (`20 26`),
//! a subrange (`20 27`) and the mean of a subrange (`20 28`), each a
//! continuous output with its own telegram (the public LMS 2xx telegram
//! listing as common drivers use it):
//!
//! | request | stream telegram data |
//! |---|---|
//! | `20 26 n` (n = 2…250 scans) | `B6`: `n`, `W`, the mean of each value over `n` scans |
//! | `20 27 a_lo a_hi b_lo b_hi` (values a…b, 1-based) | `B7`: `a`, `b` (u16), `W`, values a…b |
//! | `20 28 n a_lo a_hi b_lo b_hi` | `BF`: `n`, `a`, `b`, `W`, the mean of values a…b over `n` scans |
//!
//! `W` is the count word of `B0` (number of values sent, units in bits
//! 14–15). The reply to the request is `A0 00`; a sample count outside
//! 2…250 or a subrange outside the variant's values gets `A0 02` (fault,
//! mode kept). Our model: one mean telegram after every `n` complete scans
//! (the block mean, rounded to the nearest unit); a value with an error
//! code in any of the `n` scans is sent as that code (the last one).

use crate::frame::Variant;
use crate::telegram::{
    emit_telegram_with, EmitError, Head, RangeBits, SensorStatus, REPLY_ADDRESS_BIT,
};
use crate::Unit;

/// `20 26`: mean values.
pub const MODE_MEAN: u8 = 0x26;
/// `20 27`: a subrange of the values.
pub const MODE_SUBRANGE: u8 = 0x27;
/// `20 28`: the mean of a subrange.
pub const MODE_MEAN_SUBRANGE: u8 = 0x28;

/// A value mode and its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ValueMode {
    /// `20 26 n`: the mean of every value over `samples` scans (`B6`).
    Mean {
        /// Scans averaged (2…250).
        samples: u8,
    },
    /// `20 27`: values `first`…`last` (1-based, inclusive) of each scan (`B7`).
    Subrange {
        /// First value sent (1-based).
        first: u16,
        /// Last value sent.
        last: u16,
    },
    /// `20 28`: the mean of values `first`…`last` over `samples` scans (`BF`).
    MeanSubrange {
        /// Scans averaged (2…250).
        samples: u8,
        /// First value sent (1-based).
        first: u16,
        /// Last value sent.
        last: u16,
    },
}

impl ValueMode {
    /// The value mode of a `20` request's data (`26 n`, `27 a a b b`,
    /// `28 n a a b b`), if it is one.
    pub fn parse(command: u8, data: &[u8]) -> Option<ValueMode> {
        let u16_at = |i: usize| Some(u16::from_le_bytes([*data.get(i)?, *data.get(i + 1)?]));
        if command != 0x20 {
            return None;
        }
        match data {
            [MODE_MEAN, n] => Some(ValueMode::Mean { samples: *n }),
            [MODE_SUBRANGE, _, _, _, _] => Some(ValueMode::Subrange {
                first: u16_at(1)?,
                last: u16_at(3)?,
            }),
            [MODE_MEAN_SUBRANGE, n, _, _, _, _] => Some(ValueMode::MeanSubrange {
                samples: *n,
                first: u16_at(2)?,
                last: u16_at(4)?,
            }),
            _ => None,
        }
    }

    /// The mode byte (`26`, `27`, `28`; also the `B1` operating mode).
    pub const fn mode_code(self) -> u8 {
        match self {
            ValueMode::Mean { .. } => MODE_MEAN,
            ValueMode::Subrange { .. } => MODE_SUBRANGE,
            ValueMode::MeanSubrange { .. } => MODE_MEAN_SUBRANGE,
        }
    }

    /// The stream telegram's code (`B6`, `B7`, `BF`).
    pub const fn reply_code(self) -> u8 {
        match self {
            ValueMode::Mean { .. } => 0xB6,
            ValueMode::Subrange { .. } => 0xB7,
            ValueMode::MeanSubrange { .. } => 0xBF,
        }
    }

    /// Scans averaged per telegram (1 for a plain subrange).
    pub const fn samples(self) -> u8 {
        match self {
            ValueMode::Mean { samples } | ValueMode::MeanSubrange { samples, .. } => samples,
            ValueMode::Subrange { .. } => 1,
        }
    }

    /// The values sent of a `variant` scan: 0-based start and count.
    pub const fn span(self, variant: Variant) -> (usize, usize) {
        match self {
            ValueMode::Mean { .. } => (0, variant.beams()),
            ValueMode::Subrange { first, last } | ValueMode::MeanSubrange { first, last, .. } => {
                let first = first as usize;
                let last = last as usize;
                (first.saturating_sub(1), (last + 1).saturating_sub(first))
            }
        }
    }

    /// `true` if the sensor takes this mode at `variant`: 2…250 samples, a
    /// subrange within the variant's values.
    pub const fn valid(self, variant: Variant) -> bool {
        let samples_ok = match self {
            ValueMode::Mean { samples } | ValueMode::MeanSubrange { samples, .. } => {
                samples >= 2 && samples <= 250
            }
            ValueMode::Subrange { .. } => true,
        };
        let range_ok = match self {
            ValueMode::Mean { .. } => true,
            ValueMode::Subrange { first, last } | ValueMode::MeanSubrange { first, last, .. } => {
                first >= 1 && first <= last && last as usize <= variant.beams()
            }
        };
        samples_ok && range_ok
    }

    /// The stream telegram for `values` (already averaged and cut to the
    /// span) in `units`, into `buf`; returns its length.
    pub fn emit(
        self,
        address: u8,
        status: SensorStatus,
        units: Unit,
        values: &[u16],
        buf: &mut [u8],
    ) -> Result<usize, EmitError> {
        self.emit_with_index(address, status, units, values, None, buf)
    }

    /// [`ValueMode::emit`] with the real-time scan `index` after the values
    /// (`Some` when the configuration asks for indices).
    pub fn emit_with_index(
        self,
        address: u8,
        status: SensorStatus,
        units: Unit,
        values: &[u16],
        index: Option<u8>,
        buf: &mut [u8],
    ) -> Result<usize, EmitError> {
        let prefix: &[u8] = &match self {
            ValueMode::Mean { samples } => [samples, 0, 0, 0, 0],
            ValueMode::Subrange { first, last } => {
                let [a0, a1] = first.to_le_bytes();
                let [b0, b1] = last.to_le_bytes();
                [a0, a1, b0, b1, 0]
            }
            ValueMode::MeanSubrange {
                samples,
                first,
                last,
            } => {
                let [a0, a1] = first.to_le_bytes();
                let [b0, b1] = last.to_le_bytes();
                [samples, a0, a1, b0, b1]
            }
        };
        let prefix = match self {
            ValueMode::Mean { .. } => prefix.get(..1).unwrap_or_default(),
            ValueMode::Subrange { .. } => prefix.get(..4).unwrap_or_default(),
            ValueMode::MeanSubrange { .. } => prefix,
        };
        let count = u16::try_from(values.len()).unwrap_or(0) & 0x3FF;
        let word = count | (units.count_word_bits() & 0xC000);
        let len = prefix.len() + 2 + 2 * values.len() + usize::from(index.is_some());
        emit_telegram_with(
            buf,
            Head {
                address: REPLY_ADDRESS_BIT | address,
                command: self.reply_code(),
            },
            len,
            Some(status.0),
            |d| {
                for (slot, b) in d.iter_mut().zip(prefix.iter().copied()) {
                    *slot = b;
                }
                let rest = d.get_mut(prefix.len()..).unwrap_or_default();
                let words = core::iter::once(word).chain(values.iter().copied());
                for (pair, w) in rest.chunks_exact_mut(2).zip(words) {
                    if let [lo, hi] = pair {
                        [*lo, *hi] = w.to_le_bytes();
                    }
                }
                if let (Some(i), Some(last)) = (index, rest.last_mut()) {
                    *last = i;
                }
            },
        )
    }
}

/// Block means of value words over scans: sums per value, then the mean.
pub(super) struct MeanAccumulator {
    sums: [u32; crate::telegram::MAX_VALUES],
    /// A value's error code seen in the block (kept over the mean).
    codes: [u16; crate::telegram::MAX_VALUES],
    scans: u8,
}

impl MeanAccumulator {
    pub(super) const fn new() -> Self {
        MeanAccumulator {
            sums: [0; crate::telegram::MAX_VALUES],
            codes: [0; crate::telegram::MAX_VALUES],
            scans: 0,
        }
    }

    /// Add one scan's `words` (13-bit ranges, flags dropped).
    pub(super) fn add(&mut self, words: &[u16]) {
        let bits = RangeBits::Bits13;
        for ((sum, code), &w) in self.sums.iter_mut().zip(self.codes.iter_mut()).zip(words) {
            let range = bits.range(w);
            if range >= bits.first_error_code() {
                *code = range;
            } else {
                *sum = sum.saturating_add(u32::from(range));
            }
        }
        self.scans = self.scans.saturating_add(1);
    }

    /// The rounded means into `out` (error codes where one was seen), and
    /// start a new block.
    pub(super) fn take(&mut self, out: &mut [u16]) {
        let n = u32::from(self.scans.max(1));
        for ((o, sum), code) in out
            .iter_mut()
            .zip(self.sums.iter_mut())
            .zip(self.codes.iter_mut())
        {
            *o = if *code != 0 {
                *code
            } else {
                let mean = sum.saturating_add(n / 2).checked_div(n).unwrap_or(0);
                u16::try_from(mean).unwrap_or(u16::MAX)
            };
            *sum = 0;
            *code = 0;
        }
        self.scans = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_three_modes_and_checks_their_parameters() {
        let v = Variant::Fov180Res50;
        let mean = ValueMode::parse(0x20, &[0x26, 5]).unwrap();
        assert_eq!(mean, ValueMode::Mean { samples: 5 });
        assert!(mean.valid(v) && !ValueMode::Mean { samples: 1 }.valid(v));
        let sub = ValueMode::parse(0x20, &[0x27, 1, 0, 22, 0]).unwrap();
        assert_eq!(sub, ValueMode::Subrange { first: 1, last: 22 });
        assert_eq!(sub.span(v), (0, 22));
        assert!(!ValueMode::Subrange { first: 0, last: 5 }.valid(v));
        assert!(!ValueMode::Subrange {
            first: 5,
            last: 362
        }
        .valid(v));
        let ms = ValueMode::parse(0x20, &[0x28, 3, 10, 0, 20, 0]).unwrap();
        assert_eq!(ms.span(v), (9, 11));
        assert_eq!(ValueMode::parse(0x20, &[0x26]), None);
        assert_eq!(ValueMode::parse(0x20, &[0x24]), None);
    }

    #[test]
    fn b7_bytes() {
        // Values 1..2 = 100, 200 cm: B7 01 00 02 00 | 02 00 | 64 00 C8 00 | 10.
        let mut buf = [0u8; 32];
        let sub = ValueMode::Subrange { first: 1, last: 2 };
        let n = sub
            .emit(
                0,
                SensorStatus(0x10),
                Unit::Centimetre,
                &[100, 200],
                &mut buf,
            )
            .unwrap();
        assert_eq!(
            &buf[..n - 2],
            &[0x02, 0x80, 0x0C, 0x00, 0xB7, 1, 0, 2, 0, 2, 0, 100, 0, 200, 0, 0x10]
        );
    }

    #[test]
    fn b7_bytes_with_a_real_time_index() {
        // The index 0x2C after the values, before the status: LEN 13.
        let mut buf = [0u8; 32];
        let sub = ValueMode::Subrange { first: 1, last: 2 };
        let n = sub
            .emit_with_index(
                0,
                SensorStatus(0x10),
                Unit::Centimetre,
                &[100, 200],
                Some(0x2C),
                &mut buf,
            )
            .unwrap();
        assert_eq!(
            &buf[..n - 2],
            &[0x02, 0x80, 0x0D, 0x00, 0xB7, 1, 0, 2, 0, 2, 0, 100, 0, 200, 0, 0x2C, 0x10]
        );
    }

    #[test]
    fn block_means_round_and_keep_error_codes() {
        let mut acc = MeanAccumulator::new();
        acc.add(&[100, 8191, 7]);
        acc.add(&[101, 50, 8]);
        let mut out = [0u16; 3];
        acc.take(&mut out);
        assert_eq!(out, [101, 8191, 8]);
        assert_eq!(acc.scans, 0);
    }
}
