//! How much of what was written into QEMU's sensor USART socket the
//! emulated USART has not taken yet: QEMU takes a received byte per turn of
//! its main loop, about 10 KB/s, while a sensor streams 15–28 KB/s at 500
//! kBd. Shared by `coprocessor --qemu` and `verify --qemu`.

use std::time::Instant;

/// The rate QEMU's sensor USART is assumed to take bytes at (B/s): half of
/// the ≈ 10 KB/s it takes on an idle machine, for a loaded one.
const QEMU_BYTES_PER_S: f64 = 5_000.0;
/// The most of the sensor's stream let wait for QEMU (bytes; 0.2 s at
/// [`QEMU_BYTES_PER_S`]): a stream telegram that finds more is dropped.
pub(crate) const QEMU_QUEUE_BYTES: f64 = 1_000.0;

/// What QEMU's sensor USART has not taken yet of the bytes written into
/// its socket: an estimate, at [`QEMU_BYTES_PER_S`]. Used by `coprocessor
/// --qemu` (its sensor feed) and by `verify`, whose sensor streams into
/// QEMU while the firmware reboots.
#[derive(Debug)]
pub(crate) struct QemuIntake {
    /// Bytes written that QEMU has not taken yet (estimate) as of `at`.
    queued: f64,
    at: Instant,
}

impl QemuIntake {
    /// Nothing queued.
    pub(crate) fn new() -> Self {
        QemuIntake {
            queued: 0.0,
            at: Instant::now(),
        }
    }

    /// Bytes still queued ahead of QEMU now (estimate).
    pub(crate) fn queued(&mut self) -> f64 {
        let now = Instant::now();
        let taken = now.duration_since(self.at).as_secs_f64() * QEMU_BYTES_PER_S;
        self.queued = (self.queued - taken).max(0.0);
        self.at = now;
        self.queued
    }

    /// More than [`QEMU_QUEUE_BYTES`] queued: a sensor should wait (or
    /// drop a stream telegram) rather than add to it.
    pub(crate) fn full(&mut self) -> bool {
        self.queued() > QEMU_QUEUE_BYTES
    }

    /// `bytes` were written into QEMU's socket.
    pub(crate) fn add(&mut self, bytes: usize) {
        self.queued();
        self.queued += bytes as f64;
    }
}
