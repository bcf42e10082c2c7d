//! The host line's time budget: when the bytes written to the client's
//! line will have left it, at the client's rate (8N1, 10 bits a byte).
//!
//! The co-processor writes to its host port as fast as the port takes
//! bytes; a UART (or a pseudo-terminal) does not tell when they are out.
//! [`HostLine`] keeps that time itself, from the bytes written and the host
//! face's current rate, so that the drop policy does not depend on the
//! port: a scan is passed on only if the line is free within one scan
//! period of its arrival (so its first byte leaves at most one scan period
//! after the sensor delivered it, and the backlog never exceeds one scan
//! group); otherwise the scan is dropped whole and counted.

use embedded_io::Write;

use crate::device::emulator::line_time_us;
use crate::telegram::{Baud, MAX_TELEGRAM_LEN};

/// Room a host port must have when nothing waits in it (bytes): an `ACK`
/// and the largest telegram (a 401-beam `B0` is 813 B, the largest feature
/// telegram 749 B), so that every frame fits whole once the line is idle.
pub const HOST_TX_MIN_ROOM: usize = 1 + MAX_TELEGRAM_LEN;

/// A host port that says how many bytes it takes now without waiting, so
/// that the co-processor never blocks on the host line
/// ([`CoProcessor::poll`](super::CoProcessor::poll)): a scan's `B0` is
/// written only if it fits whole, its feature telegrams one at a time as
/// room frees, the face's replies as far as they fit.
///
/// `embedded-io`'s `WriteReady` says only that one byte fits; a UART's
/// transmit queue knows its free space.
pub trait WriteRoom: Write {
    /// Bytes a `write_all` of at most this many queues now without waiting
    /// for the line; at least [`HOST_TX_MIN_ROOM`] when nothing waits.
    /// `usize::MAX` for a port that buffers what it is given and does not
    /// say how much (a pseudo-terminal, an in-memory port): it is written
    /// to as before, whole.
    fn write_room(&mut self) -> Result<usize, Self::Error>;
}

/// When the host line will be idle (µs, the co-processor's clock).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostLine {
    free_us: u64,
}

impl HostLine {
    /// An idle line (`const`).
    pub const fn new() -> Self {
        HostLine { free_us: 0 }
    }

    /// `bytes` written at `now_us` at `baud`: they follow what is still on
    /// the line.
    pub fn occupy(&mut self, now_us: u64, bytes: usize, baud: Baud) {
        let start = self.free_us.max(now_us);
        self.free_us = start.saturating_add(line_time_us(bytes, baud));
    }

    /// `true` if what is on the line has left by `by_us`.
    pub fn free_by(&self, by_us: u64) -> bool {
        self.free_us <= by_us
    }

    /// When the line is idle (µs).
    pub fn free_at_us(&self) -> u64 {
        self.free_us
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_queue_behind_each_other_at_the_line_rate() {
        let mut line = HostLine::new();
        assert!(line.free_by(0));
        // 732 bytes at 38400 Bd: 190 625 µs.
        line.occupy(1_000, 732, Baud::B38400);
        assert_eq!(line.free_at_us(), 191_625);
        assert!(!line.free_by(100_000 + 26_667));
        assert!(line.free_by(165_000 + 26_667));
        // Written while busy: queued behind.
        line.occupy(2_000, 3, Baud::B9600);
        assert_eq!(line.free_at_us(), 191_625 + 3_125);
    }
}
