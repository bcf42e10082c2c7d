//! [`PtyPort`]: a pseudo-terminal's master as an `embedded-io` 0.7 serial
//! port, the device end of a line whose other end is a [`super::SerialLink`].

use std::io;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::pty::{Pty, ReadOutcome, Scrambler, WriteOutcome};

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
///
/// With a line rate set ([`PtyPort::set_line_rate`]: the rate of the UART
/// this port stands for), the port also models a client at another speed
/// as a real line would: what such a client sends is noise to the UART
/// (dropped, counted in [`PtyPort::bytes_at_another_rate`]) and what the
/// UART sends is noise to the client (scrambled, never framing bytes). A
/// pty itself carries bytes whatever its speed says; the client's speed is
/// the one it set on the slave ([`Pty::client_speed`]).
pub struct PtyPort {
    pty: Pty,
    line_rate: Option<u32>,
    scrambler: Scrambler,
    /// Bytes received (dropped) or sent (scrambled) while the client's
    /// speed was not the line rate.
    bytes_at_another_rate: u64,
}

impl PtyPort {
    /// Wrap a pseudo-terminal (no line rate: bytes pass whatever the
    /// client's speed).
    pub fn new(pty: Pty) -> Self {
        PtyPort {
            pty,
            line_rate: None,
            scrambler: Scrambler::default(),
            bytes_at_another_rate: 0,
        }
    }

    /// The rate of the UART this port stands for, in bits per second.
    pub fn set_line_rate(&mut self, bps: u32) {
        self.line_rate = Some(bps);
    }

    /// Bytes lost to a client at another speed (see the type's docs).
    pub fn bytes_at_another_rate(&self) -> u64 {
        self.bytes_at_another_rate
    }

    /// `true` if the client's speed is the line rate (or none is set).
    fn speeds_match(&self) -> io::Result<bool> {
        match self.line_rate {
            None => Ok(true),
            Some(rate) => Ok(self.pty.client_speed().map_err(to_io)? == Some(rate)),
        }
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
    /// What the client sent; bytes sent at another speed are noise the UART
    /// drops (0 is returned once they are all gone).
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            match self.pty.read(buf).map_err(to_io)? {
                ReadOutcome::Data(n) if self.speeds_match()? => return Ok(n),
                ReadOutcome::Data(n) => self.bytes_at_another_rate += n as u64,
                ReadOutcome::Empty | ReadOutcome::Closed => return Ok(0),
            }
        }
    }
}

impl embedded_io::Write for PtyPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let noise: Vec<u8>;
        let scrambled = !self.speeds_match()?;
        let buf = if scrambled {
            noise = buf.iter().map(|&b| self.scrambler.byte(b)).collect();
            &noise
        } else {
            buf
        };
        let until = Instant::now() + WRITE_TIMEOUT;
        loop {
            match self.pty.write(buf).map_err(to_io)? {
                WriteOutcome::Written(n) if n > 0 => {
                    if scrambled {
                        self.bytes_at_another_rate += n as u64;
                    }
                    return Ok(n);
                }
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
