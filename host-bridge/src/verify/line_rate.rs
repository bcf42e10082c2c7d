//! The sensor line's rate, modelled where the co-processor's end cannot
//! show it. QEMU ignores the USARTs' baud-rate registers and passes every
//! byte intact, so a firmware listening at the wrong rate would still hear
//! the LMS, and a broken baud search (after an MCU reset the LMS is still
//! at 500 kBd; after an LMS power cycle it is back at 9600) would pass.
//! Here a byte between the simulated LMS and the firmware arrives as sent
//! only when the rate the firmware has programmed (USART2's `BRR`, read
//! through QEMU's monitor: [`Dut::sensor_baud`]) is within
//! [`TOLERANCE_PERCENT`] of the LMS's; otherwise the receiver gets noise:
//! fewer bytes when it is slower than the sender (one per
//! `sender / receiver` bytes, at least one), two per byte when it is faster
//! (each start bit and each run of zero bits is a frame of its own), with
//! pseudo-random values (no start bit is ever aligned, so no telegram and
//! no CRC survives; framing-error flags are not modelled).
//!
//! What it cannot show: the timing of a real UART at each rate (QEMU still
//! moves about 10 KB/s whatever the rate), noise that happens to look like
//! a handshake byte more often than chance, and the moment within a byte
//! at which a rate switch takes effect.

use std::time::{Duration, Instant};

use anyhow::Result;

use super::dut::Dut;

/// Rates closer than this (percent of the sender's) still frame bytes.
pub(super) const TOLERANCE_PERCENT: u32 = 3;

/// Read the firmware's rate again after this long, even if it sent nothing
/// (it switches rates while searching for the LMS).
const REREAD: Duration = Duration::from_millis(20);

/// Which end of the sensor line receives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Toward {
    /// The simulated LMS (bytes from the firmware).
    Sensor,
    /// The firmware (bytes from the LMS).
    Firmware,
}

/// The model and what it garbled.
pub(super) struct LineRate {
    /// The firmware's rate (bit/s) as last read, `None` while unset.
    firmware: Option<u32>,
    read_at: Option<Instant>,
    /// xorshift32 state of the noise.
    noise: u32,
    /// Bytes garbled on their way to the LMS and to the firmware.
    pub(super) garbled_to_sensor: u64,
    pub(super) garbled_to_firmware: u64,
}

impl LineRate {
    pub(super) fn new() -> Self {
        LineRate {
            firmware: None,
            read_at: None,
            noise: 0x2545_f491,
            garbled_to_sensor: 0,
            garbled_to_firmware: 0,
        }
    }

    /// The firmware's rate: read now if `fresh` (it has just sent bytes, at
    /// the rate it has now) or if the last reading is older than
    /// [`REREAD`]. `None` if the co-processor's end cannot tell (not QEMU).
    fn firmware_rate(&mut self, dut: &mut Dut, fresh: bool) -> Result<Option<u32>> {
        let stale = self.read_at.is_none_or(|t| t.elapsed() >= REREAD);
        if fresh || stale {
            self.firmware = dut.sensor_baud()?;
            self.read_at = Some(Instant::now());
        }
        Ok(self.firmware)
    }

    /// Bytes between the firmware and an LMS at `lms_rate`, in the
    /// direction `to`: what the receiver gets, appended to `out`.
    pub(super) fn carry_line(
        &mut self,
        to: Toward,
        dut: &mut Dut,
        lms_rate: u32,
        bytes: &[u8],
        out: &mut Vec<u8>,
    ) -> Result<()> {
        // The firmware sends at the rate it has now: read it afresh then.
        let firmware = self.firmware_rate(dut, to == Toward::Sensor)?;
        let before = out.len();
        match to {
            Toward::Sensor => self.carry(firmware, lms_rate, bytes, out, |fw, lms| (fw, lms)),
            Toward::Firmware => self.carry(firmware, lms_rate, bytes, out, |fw, lms| (lms, fw)),
        }
        if out[before..] != *bytes {
            match to {
                Toward::Sensor => self.garbled_to_sensor += bytes.len() as u64,
                Toward::Firmware => self.garbled_to_firmware += bytes.len() as u64,
            }
        }
        Ok(())
    }

    /// Append what the receiver gets of `bytes`; `roles` orders
    /// (firmware, lms) as (sender, receiver).
    fn carry(
        &mut self,
        firmware: Option<u32>,
        lms_rate: u32,
        bytes: &[u8],
        out: &mut Vec<u8>,
        roles: impl Fn(u32, u32) -> (u32, u32),
    ) {
        let Some(firmware) = firmware else {
            // Not observable (not QEMU) or not yet programmed: pass as is.
            out.extend_from_slice(bytes);
            return;
        };
        let (sender, receiver) = roles(firmware, lms_rate);
        if rates_match(Rates { sender, receiver }) {
            out.extend_from_slice(bytes);
            return;
        }
        let count = if receiver < sender {
            (bytes.len() as u64 * u64::from(receiver) / u64::from(sender)).max(1) as usize
        } else {
            2 * bytes.len()
        };
        for _ in 0..count {
            out.push(self.next_noise());
        }
    }

    fn next_noise(&mut self) -> u8 {
        let mut x = self.noise;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.noise = x;
        (x >> 24) as u8
    }
}

/// The line rates of the two ends of a line (bit/s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Rates {
    /// The sender's rate.
    pub sender: u32,
    /// The receiver's rate.
    pub receiver: u32,
}

/// True when a receiver at `rates.receiver` bit/s frames the bytes of a
/// sender at `rates.sender`.
pub(super) fn rates_match(rates: Rates) -> bool {
    let Rates { sender, receiver } = rates;
    let diff = u64::from(sender.abs_diff(receiver));
    diff * 100 <= u64::from(sender) * u64::from(TOLERANCE_PERCENT)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_within_three_percent_match() {
        assert!(rates_match(Rates {
            sender: 9600,
            receiver: 9600
        }));
        assert!(rates_match(Rates {
            sender: 500_000,
            receiver: 500_000
        }));
        assert!(rates_match(Rates {
            sender: 9600,
            receiver: 9880
        })); // 2.9 %
        assert!(!rates_match(Rates {
            sender: 9600,
            receiver: 9900
        })); // 3.1 %
        assert!(!rates_match(Rates {
            sender: 500_000,
            receiver: 38_400
        }));
        assert!(!rates_match(Rates {
            sender: 9600,
            receiver: 19_200
        }));
    }

    #[test]
    fn mismatched_rates_give_fewer_or_more_bytes_of_noise() {
        let mut m = LineRate::new();
        let bytes: Vec<u8> = (0..100).collect();
        let mut out = Vec::new();
        // The LMS at 500 kBd, the firmware listening at 9600: one byte
        // (100 · 9600 / 500 000 = 1.9, at least one).
        m.carry(Some(9600), 500_000, &bytes, &mut out, |fw, lms| (lms, fw));
        assert_eq!(out.len(), 1);
        out.clear();
        // The LMS at 9600, the firmware at 500 kBd: twice as many.
        m.carry(Some(500_000), 9600, &bytes, &mut out, |fw, lms| (lms, fw));
        assert_eq!(out.len(), 200);
        assert_ne!(out[..100], bytes[..]);
        out.clear();
        m.carry(Some(9600), 9600, &bytes, &mut out, |fw, lms| (lms, fw));
        assert_eq!(out, bytes);
    }
}
