//! A transparent forwarder with the co-processor's interface, built instead
//! of it with the `standin` feature: to test the UART plumbing on its own
//! (`qemu-smoke.py --standin`).
//!
//! Host bytes go to the sensor unchanged, sensor bytes to the host
//! unchanged. The sensor bytes are also fed to the core's [`Framer`], and
//! every complete, checked telegram counts as a scan.

use embedded_io::{Read, ReadReady, Write};
use lms_core::device::coprocessor::{PollError, PollOutcome};
use lms_core::telegram::features::Counters;
use lms_core::telegram::{Direction, Event, Framer, Handshake};

/// Bytes moved per read.
const CHUNK: usize = 64;

/// The forwarder.
pub struct Forwarder {
    framer: Framer,
    counters: Counters,
}

impl Forwarder {
    /// A forwarder with an empty framer.
    pub const fn new() -> Self {
        Forwarder {
            framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
            counters: Counters::ZERO,
        }
    }

    /// `scans_in` counts the sensor telegrams; the framer's counters as the
    /// co-processor reports them.
    pub fn counters(&self) -> Counters {
        let s = self.framer.stats();
        Counters {
            sensor_crc_errors: s.crc_errors,
            sensor_resyncs: s.resyncs,
            sensor_bytes_skipped: s.bytes_skipped,
            ..self.counters
        }
    }

    /// Count a loss in the sensor receive queue.
    pub fn note_sensor_overflow(&mut self) {
        self.counters.scans_dropped = self.counters.scans_dropped.wrapping_add(1);
    }

    /// Count `bytes` lost in the sensor receive queue (one loss).
    pub fn note_sensor_lost(&mut self, _bytes: u32) {
        self.note_sensor_overflow();
    }

    /// Move what is waiting on either side to the other. Never blocks on input.
    pub fn poll<S, H>(
        &mut self,
        sensor: &mut S,
        host: &mut H,
        _now_us: u64,
    ) -> Result<PollOutcome, PollError<S::Error, H::Error>>
    where
        S: Read + ReadReady + Write,
        H: Read + ReadReady + Write,
    {
        let mut outcome = PollOutcome::default();
        let mut buf = [0u8; CHUNK];
        while host.read_ready().map_err(PollError::Host)? {
            let n = host.read(&mut buf).map_err(PollError::Host)?;
            sensor.write_all(&buf[..n]).map_err(PollError::Sensor)?;
        }
        while sensor.read_ready().map_err(PollError::Sensor)? {
            let n = sensor.read(&mut buf).map_err(PollError::Sensor)?;
            host.write_all(&buf[..n]).map_err(PollError::Host)?;
            let mut input = &buf[..n];
            loop {
                let fed = self.framer.feed(input);
                input = fed.remaining;
                match fed.event {
                    Some(Event::Telegram(_)) => outcome.scans += 1,
                    Some(Event::Ack | Event::Nak | Event::Long { .. }) => {}
                    None if input.is_empty() => break,
                    None => {}
                }
            }
        }
        self.counters.scans_in = self.counters.scans_in.wrapping_add(outcome.scans);
        Ok(outcome)
    }
}
