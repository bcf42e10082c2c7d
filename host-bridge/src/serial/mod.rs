//! The host's serial lines: one trait for every line the host tool talks
//! over as a client, and the real port behind it.
//!
//! * [`Link`] — bytes and time: send, receive with a time-out, change the
//!   rate, drop unread input, a monotonic clock, a name for messages. The
//!   LMS 2xx client ([`crate::client::Client`]), `host-bridge scan` and both
//!   ends of `host-bridge verify` use it; implementations are
//!   [`SerialLink`] (a real serial port or a pseudo-terminal's slave),
//!   verify's TCP connection to QEMU's UARTs, and the in-memory sensor of
//!   the tests ([`crate::emulated_link::EmulatedLink`]).
//! * [`PtyPort`] — the other end: a pseudo-terminal's master as an
//!   `embedded-io` 0.7 port, for the core's `CoProcessor` running in a
//!   thread (`host-bridge verify --host`).
//! * [`Arrivals`] — the co-processor's sensor port on a computer, each
//!   byte with its estimated arrival time (the co-processor on a loaded
//!   machine judges scans by when they arrived, not when its loop ran).
//! * [`line_time`] — how long bytes take on the line (8N1).
//!
//! `host-bridge simulate` plays a sensor on a pty's master with its own
//! speed-mismatch and fault model ([`crate::pty`]); it is a device end, not a
//! client line, so it does not go through [`Link`].

use std::io;
use std::time::Duration;

use lms_core::telegram::Baud;

mod arrivals;
mod port;
mod pty_port;

pub use arrivals::{Arrivals, STEP};
pub use port::{OpenError, SerialLink};
pub use pty_port::PtyPort;

/// A co-processor's serial lines, from its peers' ends, and what runs it
/// (`R`: the firmware under QEMU, a thread, a board on serial ports).
/// Dropped in field order: the lines first, then what runs it.
pub struct CoLines<R> {
    /// Its sensor line (the LMS's end).
    pub sensor: Box<dyn Link>,
    /// Its host line (the client's end).
    pub host: Box<dyn Link>,
    /// The firmware's console, if it has one here.
    pub console: Option<Box<dyn Link>>,
    /// What runs the co-processor.
    pub runner: R,
    /// How it is connected, for the log.
    pub how: String,
}

impl<R> CoLines<R> {
    /// The same lines, with what runs the co-processor seen through `f`.
    pub fn map_runner<S>(self, f: impl FnOnce(R) -> S) -> CoLines<S> {
        CoLines {
            sensor: self.sensor,
            host: self.host,
            console: self.console,
            runner: f(self.runner),
            how: self.how,
        }
    }
}

/// Bits on the line per byte: start bit, 8 data bits, stop bit (8N1).
pub const BITS_PER_BYTE: u64 = 10;

/// A write that cannot go out in this time is an error (the peer is stuck).
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(2);

/// Longest wait for bytes in one round of a host loop: the co-processor on a
/// PC, `verify`'s sensor and client, the QEMU bridge (1 ms, the pacing
/// granularity of their emulated lines).
pub const TICK: Duration = Duration::from_millis(1);

/// Time `bytes` take on the line at `baud` (8N1: 10 bits per byte).
pub fn line_time(bytes: usize, baud: Baud) -> Duration {
    let bits = bytes as u64 * BITS_PER_BYTE;
    Duration::from_nanos(bits * 1_000_000_000 / u64::from(baud.bits_per_second()))
}

/// Bytes and time: what a client needs from a serial line.
pub trait Link {
    /// Send all of `bytes` (blocking until they are queued for the line).
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Wait up to `timeout` for bytes and put what arrived into `buf`;
    /// `Ok(0)` means nothing arrived in that time. `Duration::ZERO` only
    /// takes what is already there.
    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;
    /// Set the line's rate (after what was sent has gone out).
    fn set_baud(&mut self, baud: Baud) -> io::Result<()>;
    /// Drop bytes received but not read yet.
    fn discard_input(&mut self) -> io::Result<()>;
    /// Monotonic time since an origin of the link's choosing.
    fn now(&self) -> Duration;
    /// Name of the line for messages (e.g. the device path).
    fn name(&self) -> String;
}

/// `true` for the errors of a read that merely found nothing in time.
pub(crate) fn is_quiet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}
