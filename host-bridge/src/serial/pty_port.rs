//! [`PtyPort`]: a pseudo-terminal's master as an `embedded-io` 0.7 serial
//! port, the device end of a line whose other end is a [`super::SerialLink`].

use std::io;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::pty::{Pty, ReadOutcome, WriteOutcome};

use super::WRITE_TIMEOUT;

/// A pseudo-terminal's master as an `embedded-io` 0.7 serial port, for
/// `lms_core::device::coprocessor::CoProcessor::poll`.
///
/// * `read_ready`: `poll` with a zero time-out (also `true` when the other
///   end has gone away; `read` then returns 0, which `poll` takes as "no
///   more bytes").
/// * `read`: never blocks (the co-processor reads only after `read_ready`).
/// * `write`: blocks while the other end's input queue is full (as a UART
///   transmits at its own pace), at most [`WRITE_TIMEOUT`] (2 s); bytes
///   written while nobody has the other end open are dropped, like a UART
///   with nothing attached.
pub struct PtyPort {
    pty: Pty,
}

impl PtyPort {
    /// Wrap a pseudo-terminal.
    pub fn new(pty: Pty) -> Self {
        PtyPort { pty }
    }

    /// The device the other end opens.
    pub fn slave_path(&self) -> &Path {
        self.pty.slave_path()
    }

    /// Wait up to `timeout` for input.
    pub fn wait_readable(&self, timeout: Duration) -> io::Result<bool> {
        self.pty.wait_readable(timeout).map_err(to_io)
    }
}

fn to_io(e: anyhow::Error) -> io::Error {
    io::Error::other(format!("{e:#}"))
}

impl embedded_io::ErrorType for PtyPort {
    type Error = io::Error;
}

impl embedded_io::ReadReady for PtyPort {
    fn read_ready(&mut self) -> io::Result<bool> {
        self.wait_readable(Duration::ZERO)
    }
}

impl embedded_io::Read for PtyPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.pty.read(buf).map_err(to_io)? {
            ReadOutcome::Data(n) => Ok(n),
            ReadOutcome::Empty | ReadOutcome::Closed => Ok(0),
        }
    }
}

impl embedded_io::Write for PtyPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let until = Instant::now() + WRITE_TIMEOUT;
        loop {
            match self.pty.write(buf).map_err(to_io)? {
                WriteOutcome::Written(n) if n > 0 => return Ok(n),
                WriteOutcome::Closed => return Ok(buf.len()),
                WriteOutcome::Written(_) | WriteOutcome::Full => {
                    if Instant::now() >= until {
                        return Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            format!("{}: nobody reads", self.pty.slave_path().display()),
                        ));
                    }
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A pseudo-terminal buffers what it is given (and `write` waits while the
/// other end's queue is full, as before): no limit known.
impl lms_core::device::coprocessor::WriteRoom for PtyPort {
    fn write_room(&mut self) -> io::Result<usize> {
        Ok(usize::MAX)
    }
}
