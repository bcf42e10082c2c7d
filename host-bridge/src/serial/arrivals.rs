//! [`Arrivals`]: the sensor port of the co-processor running on a computer
//! (`host-bridge coprocessor`, `verify --host`), with the time each byte
//! reached the port estimated, so that the co-processor judges a scan by
//! when the sensor delivered it and not by when its loop got to it.
//!
//! On a board the co-processor's loop runs all the time and sees each
//! byte as it arrives. On a computer its thread may be held off the CPU,
//! and a terminal's bytes (a pseudo-terminal or a USB serial adapter) reach
//! the reader through the kernel's receive work, which runs on a worker
//! thread: on a loaded machine (both cores busy) that worker was measured
//! to run up to 360 ms late (`poll` with a 1 ms time-out on a
//! pseudo-terminal master returned after 329 ms, with 13 scans waiting; on a
//! socket pair under the same load at most 12 ms). Given to the
//! co-processor at once with the time the loop found them, those scans
//! looked back to back: its host-line budget (a scan passes only if the
//! host line is free within one scan period of its arrival) dropped all
//! but one or two.
//!
//! So the bytes found waiting are spread, in order and evenly, over the
//! time since the port was last seen empty (the only time they can have
//! arrived in), and handed to the co-processor in steps of [`STEP`]
//! bytes, one [`CoProcessor::poll`] per step at the time its last byte
//! arrived. When the loop keeps up (a look every millisecond) that is the
//! arrival time within a millisecond; after a stall, the scans that queued
//! meanwhile get the times the sensor sent them at, one scan period apart.
//! The co-processor's clock never runs backwards: every step's time lies
//! between the last poll's and now.

use std::collections::VecDeque;

use embedded_io::{ErrorType, Read, ReadReady, Write};
use lms_core::device::coprocessor::{CoProcessor, PollError, PollOutcome, WriteRoom};

/// Bytes handed to the co-processor per poll (2.6 ms of the sensor line at
/// 500 kBd; a 361-value `B0` takes six steps).
pub const STEP: usize = 128;

/// A sensor port whose bytes carry their estimated arrival time (from when
/// they were read and the line rate). It is itself the port the co-processor reads:
/// [`Arrivals::poll`] runs the co-processor on it.
pub struct Arrivals<P> {
    port: P,
    /// Bytes taken from the port and not yet read by the co-processor.
    bytes: VecDeque<u8>,
    /// The steps of `bytes`, in order: how many bytes, and when the last
    /// of them arrived (µs, the caller's clock).
    steps: VecDeque<(usize, u64)>,
    /// Bytes of the step being read by the co-processor still to read.
    current: usize,
    /// When the port was last found empty (µs).
    empty_us: Option<u64>,
}

impl<P> Arrivals<P> {
    /// The port, none of its bytes taken yet.
    pub fn new(port: P) -> Self {
        Arrivals {
            port,
            bytes: VecDeque::new(),
            steps: VecDeque::new(),
            current: 0,
            empty_us: None,
        }
    }

    /// The port (to switch its rate, wait for bytes, or send).
    pub fn port_mut(&mut self) -> &mut P {
        &mut self.port
    }

    /// Bytes taken from the port that the co-processor has not read yet.
    pub fn waiting(&self) -> usize {
        self.bytes.len()
    }

    /// Split `n` bytes found at `now_us` into steps, spread evenly over the
    /// time since the port was last found empty.
    fn stamp(&mut self, n: usize, now_us: u64) {
        let since = self.empty_us.unwrap_or(now_us).min(now_us);
        let span = now_us - since;
        let mut done = 0;
        while done < n {
            let step = STEP.min(n - done);
            done += step;
            // The last byte of the step, `done` of `n`.
            let at = since + span * done as u64 / n as u64;
            self.steps.push_back((step, at));
        }
    }
}

impl<P: Read + ReadReady> Arrivals<P> {
    /// Take in everything waiting at the port, stamped by `clock` (µs) as
    /// read once the port is empty: reading may wait (for the kernel's
    /// receive work, see the module docs), and the bytes arrived by then.
    /// Returns that time.
    fn take_in(&mut self, clock: impl Fn() -> u64) -> Result<u64, P::Error> {
        let mut buf = [0u8; 1024];
        let mut n = 0;
        while self.port.read_ready()? {
            let got = self.port.read(&mut buf)?;
            if got == 0 {
                break;
            }
            self.bytes.extend(&buf[..got.min(buf.len())]);
            n += got;
        }
        let now_us = clock();
        if n > 0 {
            self.stamp(n, now_us);
        }
        self.empty_us = Some(now_us);
        Ok(now_us)
    }
}

impl<P: Read + ReadReady + Write> Arrivals<P> {
    /// Take in what waits at the port and run `cop` on it: one poll per
    /// step of [`STEP`] bytes at its arrival time, or one poll now if
    /// nothing waits (`clock`: the co-processor's clock, µs). Returns at
    /// the first poll that asks for a rate switch (the caller switches the
    /// port before the next bytes go to the co-processor; the rest waits
    /// for the next call), with the scans of every poll counted.
    pub fn poll<H>(
        &mut self,
        cop: &mut CoProcessor,
        host: &mut H,
        clock: impl Fn() -> u64,
    ) -> Result<PollOutcome, PollError<P::Error, H::Error>>
    where
        H: embedded_io::Read + embedded_io::ReadReady + WriteRoom,
    {
        let now_us = self.take_in(clock).map_err(PollError::Sensor)?;
        let mut scans = 0u32;
        loop {
            let at = match self.steps.pop_front() {
                Some((n, at)) => {
                    self.current = n;
                    at
                }
                None => now_us,
            };
            let mut outcome = cop.poll(self, host, at)?;
            // What the co-processor left of the step stays for the next.
            if self.current > 0 {
                self.steps.push_front((self.current, at));
                self.current = 0;
            }
            scans = scans.saturating_add(outcome.scans);
            let switch = outcome.sensor_baud.is_some() || outcome.host_baud.is_some();
            if switch || self.steps.is_empty() {
                outcome.scans = scans;
                return Ok(outcome);
            }
        }
    }
}

impl<P: ErrorType> ErrorType for Arrivals<P> {
    type Error = P::Error;
}

impl<P: ErrorType> ReadReady for Arrivals<P> {
    /// `true` while the step being handed over has bytes left.
    fn read_ready(&mut self) -> Result<bool, P::Error> {
        Ok(self.current > 0)
    }
}

impl<P: ErrorType> Read for Arrivals<P> {
    fn read(&mut self, out: &mut [u8]) -> Result<usize, P::Error> {
        let n = out.len().min(self.current).min(self.bytes.len());
        for (slot, byte) in out.iter_mut().zip(self.bytes.drain(..n)) {
            *slot = byte;
        }
        self.current -= n;
        Ok(n)
    }
}

impl<P: Write> Write for Arrivals<P> {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, P::Error> {
        self.port.write(bytes)
    }

    fn flush(&mut self) -> Result<(), P::Error> {
        self.port.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An in-memory port: what `feed` put there is read at once.
    #[derive(Default)]
    struct Memory {
        waiting: Vec<u8>,
    }

    impl ErrorType for Memory {
        type Error = std::convert::Infallible;
    }

    impl ReadReady for Memory {
        fn read_ready(&mut self) -> Result<bool, Self::Error> {
            Ok(!self.waiting.is_empty())
        }
    }

    impl Read for Memory {
        fn read(&mut self, out: &mut [u8]) -> Result<usize, Self::Error> {
            let n = out.len().min(self.waiting.len());
            out[..n].copy_from_slice(&self.waiting[..n]);
            self.waiting.drain(..n);
            Ok(n)
        }
    }

    #[test]
    fn bytes_found_after_a_stall_are_spread_over_it() {
        let mut a = Arrivals::new(Memory::default());
        a.take_in(|| 1_000).unwrap();
        // 1000 bytes found 500 ms later: eight steps from 1 ms to 501 ms.
        a.port_mut().waiting = vec![7; 1000];
        a.take_in(|| 501_000).unwrap();
        let steps: Vec<_> = a.steps.iter().copied().collect();
        assert_eq!(steps.len(), 8);
        assert_eq!(steps[0], (128, 1_000 + 500_000 * 128 / 1000));
        assert_eq!(steps[7], (1000 - 7 * 128, 501_000));
        assert!(steps.windows(2).all(|w| w[0].1 < w[1].1));
        assert_eq!(a.waiting(), 1000);
        // The co-processor reads one step at a time.
        a.current = 128;
        let mut out = [0u8; 256];
        assert!(a.read_ready().unwrap());
        assert_eq!(a.read(&mut out).unwrap(), 128);
        assert!(!a.read_ready().unwrap());
        assert_eq!(a.waiting(), 872);
    }

    #[test]
    fn bytes_of_a_loop_that_keeps_up_arrive_when_found() {
        let mut a = Arrivals::new(Memory::default());
        // The first look: no earlier empty port, so found = arrived.
        a.port_mut().waiting = vec![1; 50];
        a.take_in(|| 10_000).unwrap();
        assert_eq!(a.steps.pop_front(), Some((50, 10_000)));
        // A millisecond later, 50 more: within that millisecond.
        a.port_mut().waiting = vec![1; 50];
        a.take_in(|| 11_000).unwrap();
        assert_eq!(a.steps.pop_front(), Some((50, 11_000)));
        // Nothing waiting: no step.
        a.take_in(|| 12_000).unwrap();
        assert!(a.steps.is_empty());
    }
}
