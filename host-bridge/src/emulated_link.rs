//! The core's LMS 2xx model ([`lms_core::device::emulator`]) behind the
//! client's [`Link`] trait: an in-memory serial line with a virtual clock
//! and fault injection, the test double of [`crate::client`].
//!
//! The sensor is the same [`Emulator`] that `simulate`, `verify` and the
//! co-processor use, unchanged: it answers the requests of PROTOCOL.md §2
//! and paces every byte at its line rate. [`EmulatedLink`] only carries the
//! bytes: a request goes to the emulator when it is sent (arriving after
//! its line time), and the emulator's bytes reach the client as their stop
//! bits pass on a virtual clock (µs) that moves only while the client waits
//! in [`Link::receive`]. Nothing sleeps, so tests at 9600 Bd run in
//! milliseconds of real time.
//!
//! Faults are injected on the line, never in the sensor:
//!
//! * [`EmulatedLink::corrupt_next`]: flip a bit of the next requests on
//!   their way (bit 4 of the command byte); the emulator finds the bad
//!   checksum and answers `NAK`.
//! * [`EmulatedLink::add_stream_fault`]: corrupt a bit of a streamed scan
//!   (a CRC error), truncate it, re-address it (CRC recomputed) or put
//!   noise before it ([`StreamFault`]).
//! * [`EmulatedLink::drop_acks`]: the `ACK` bytes are lost.
//! * [`EmulatedLink::mute`]: the line is cut both ways (what already
//!   reached the client stays readable).
//! * Always: a client at the wrong rate sees garbage — bytes sent at a rate
//!   other than the receiver's are scrambled (XOR `0xA5`), both ways.
//!
//! To judge a streamed scan, the line holds each sensor telegram until its
//! last byte is in (the client could not use it earlier anyway), then
//! passes it on, changed or not. A `B0` right after an `ACK` is the reply to
//! `30 01`; any other is a streamed scan, counted from 0 over the link's
//! life. Every `B0` passed on intact is kept ([`EmulatedLink::intact_scans`])
//! so that a test can compare what the client received with what went out,
//! and every emulator [`Event`] is kept ([`EmulatedLink::events`]).

use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::time::Duration;

use lms_core::device::emulator::{line_time_us, Emulator, Event, ScanSource, Settings};
use lms_core::telegram::reply::code::MEASURED;
use lms_core::telegram::{
    crc16, Baud, Direction, MeasuredValues, Telegram, ACK, CRC_LEN, HEADER_LEN, STX,
};
use lms_core::{Unit, Variant};

use crate::serial::Link;

/// What happens to one streamed scan.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StreamFault {
    /// Flip bit 0 of the byte at this offset of the telegram: the CRC fails.
    Corrupt {
        /// Byte offset in the telegram (0 = `STX`).
        at: usize,
    },
    /// Pass on only the first `keep` bytes of the telegram.
    Truncate {
        /// Bytes passed on.
        keep: usize,
    },
    /// Pass the telegram on with this address byte (CRC recomputed).
    Address(u8),
    /// Put these bytes just before the (intact) telegram.
    NoiseBefore(Vec<u8>),
}

/// A deterministic scan source: ranges 1..=8000 in the sensor's units in a
/// pattern that changes from scan to scan, with "not valid" (8191) on
/// every 97th beam.
#[derive(Clone, Copy, Debug, Default)]
pub struct PatternSource {
    /// Scans made so far.
    pub scans: usize,
}

impl ScanSource for PatternSource {
    fn next_scan(&mut self, _variant: Variant, _units: Unit, out: &mut [u16]) -> usize {
        let index = self.scans;
        self.scans += 1;
        for (j, w) in out.iter_mut().enumerate() {
            *w = if (j + index).is_multiple_of(97) {
                8191
            } else {
                ((j * 31 + index * 17) % 8000 + 1) as u16
            };
        }
        out.len()
    }
}

/// Scramble a byte received at the wrong rate.
fn scramble(b: u8) -> u8 {
    b ^ 0xA5
}

/// The whole length of the telegram starting `held`, once its header is in.
fn telegram_len(held: &[u8]) -> Option<usize> {
    let header = held.get(..HEADER_LEN)?;
    let len = usize::from(u16::from_le_bytes([header[2], header[3]]));
    Some(HEADER_LEN + len + CRC_LEN)
}

/// The in-memory line to an emulated sensor (see the [module docs](self)).
pub struct EmulatedLink<S: ScanSource> {
    emu: Emulator<S>,
    now_us: u64,
    host_baud: Baud,
    /// The rate the emulator's next bytes go at.
    sensor_baud: Baud,
    /// Bytes that reached the client's side, with the rate they went at.
    arrived: VecDeque<(u8, Baud)>,
    /// The sensor telegram coming in, held until complete.
    held: Vec<u8>,
    /// How many of `held` the client dropped ([`Link::discard_input`]).
    held_dropped: usize,
    /// The previous byte from the sensor was an `ACK`.
    after_ack: bool,
    stream_index: usize,
    stream_faults: BTreeMap<usize, StreamFault>,
    intact: Vec<MeasuredValues>,
    events: Vec<Event>,
    /// Flip a bit in this many coming requests (the sensor answers `NAK`).
    pub corrupt_next: u32,
    /// Lose every `ACK` byte from the sensor.
    pub drop_acks: bool,
    /// Cut the line both ways.
    pub mute: bool,
}

impl<S: ScanSource> std::fmt::Debug for EmulatedLink<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EmulatedLink")
            .field("now_us", &self.now_us)
            .field("host_baud", &self.host_baud)
            .field("sensor_baud", &self.emu.baud())
            .field("variant", &self.emu.variant())
            .field("streaming", &self.emu.streaming())
            .finish_non_exhaustive()
    }
}

impl Default for EmulatedLink<PatternSource> {
    fn default() -> Self {
        EmulatedLink::new(PatternSource::default())
    }
}

impl<S: ScanSource> EmulatedLink<S> {
    /// A sensor with [`Settings::default`] (address 0, 180°/1°, cm)
    /// switched on at time 0 with scans from `source`; both ends at
    /// 9600 Bd.
    pub fn new(source: S) -> Self {
        EmulatedLink::with_settings(source, Settings::default())
    }

    /// A sensor with `settings`, switched on at time 0.
    pub fn with_settings(source: S, settings: Settings) -> Self {
        EmulatedLink {
            emu: Emulator::new(source, settings, 0),
            now_us: 0,
            host_baud: Baud::B9600,
            sensor_baud: Baud::B9600,
            arrived: VecDeque::new(),
            held: Vec::new(),
            held_dropped: 0,
            after_ack: false,
            stream_index: 0,
            stream_faults: BTreeMap::new(),
            intact: Vec::new(),
            events: Vec::new(),
            corrupt_next: 0,
            drop_acks: false,
            mute: false,
        }
    }

    /// The sensor.
    pub fn emulator(&self) -> &Emulator<S> {
        &self.emu
    }

    /// Apply `fault` to streamed scan `index` (counting from 0 over all
    /// streams on this link).
    pub fn add_stream_fault(&mut self, index: usize, fault: StreamFault) {
        self.stream_faults.insert(index, fault);
    }

    /// Every `B0` passed on intact (streamed or on request), in order.
    pub fn intact_scans(&self) -> &[MeasuredValues] {
        &self.intact
    }

    /// Every event of the emulator so far, oldest first.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Take the emulator's bytes due by now onto the line.
    fn pump(&mut self) {
        let mut buf = [0u8; 1024];
        loop {
            let baud = self.sensor_baud;
            let n = self.emu.transmit(self.now_us, &mut buf);
            self.drain_events();
            if n == 0 {
                return;
            }
            for &b in buf.get(..n).unwrap_or_default() {
                self.on_sensor_byte(b, baud);
            }
        }
    }

    fn drain_events(&mut self) {
        while let Some(e) = self.emu.next_event() {
            if let Event::BaudSwitched { to, .. } = e {
                self.sensor_baud = to;
            }
            self.events.push(e);
        }
    }

    /// One byte from the sensor: handshake bytes pass at once, telegrams
    /// when complete.
    fn on_sensor_byte(&mut self, b: u8, baud: Baud) {
        if self.held.is_empty() && b != STX {
            self.after_ack = b == ACK;
            if !(b == ACK && self.drop_acks) {
                self.pass(&[b], baud);
            }
            return;
        }
        self.held.push(b);
        if telegram_len(&self.held).is_some_and(|n| self.held.len() >= n) {
            let telegram = std::mem::take(&mut self.held);
            let dropped = std::mem::take(&mut self.held_dropped);
            self.on_telegram(telegram, dropped, baud);
        }
    }

    /// A complete sensor telegram: apply its fault, keep it if intact, pass
    /// it on (without the first `dropped` bytes, which the client
    /// discarded).
    fn on_telegram(&mut self, mut bytes: Vec<u8>, dropped: usize, baud: Baud) {
        let after_ack = std::mem::take(&mut self.after_ack);
        let is_scan = bytes.get(HEADER_LEN) == Some(&MEASURED);
        let fault = if is_scan && !after_ack {
            self.stream_index += 1;
            self.stream_faults.remove(&(self.stream_index - 1))
        } else {
            None
        };
        let intact = matches!(fault, None | Some(StreamFault::NoiseBefore(_)));
        let mut noise = Vec::new();
        match fault {
            None => {}
            Some(StreamFault::Corrupt { at }) => {
                if let Some(b) = bytes.get_mut(at) {
                    *b ^= 0x01;
                }
            }
            Some(StreamFault::Truncate { keep }) => bytes.truncate(keep),
            Some(StreamFault::Address(a)) => readdress(&mut bytes, a),
            Some(StreamFault::NoiseBefore(n)) => noise = n,
        }
        if is_scan && intact {
            let t = Telegram::new_unchecked(&bytes[..], Direction::SensorToHost);
            if let Ok(values) = MeasuredValues::parse(&t) {
                self.intact.push(values);
            }
        }
        noise.extend_from_slice(bytes.get(dropped.min(bytes.len())..).unwrap_or_default());
        self.pass(&noise, baud);
    }

    /// Bytes reach the client's side (unless the line is cut).
    fn pass(&mut self, bytes: &[u8], baud: Baud) {
        if !self.mute {
            self.arrived.extend(bytes.iter().map(|&b| (b, baud)));
        }
    }
}

/// Give a telegram another address byte and a CRC to match.
fn readdress(bytes: &mut [u8], address: u8) {
    let n = bytes.len();
    if n < HEADER_LEN + CRC_LEN {
        return;
    }
    bytes[1] = address;
    let crc = crc16(&bytes[..n - CRC_LEN]).to_le_bytes();
    bytes[n - CRC_LEN..].copy_from_slice(&crc);
}

impl<S: ScanSource> Link for EmulatedLink<S> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.pump();
        if self.mute {
            return Ok(());
        }
        let mut rx = bytes.to_vec();
        if self.corrupt_next > 0 && rx.len() > 5 {
            self.corrupt_next -= 1;
            rx[4] ^= 0x10;
        }
        if self.host_baud != self.emu.baud() {
            rx.iter_mut().for_each(|b| *b = scramble(*b));
        }
        // The request is in once its last byte is.
        let arrival = self.now_us + line_time_us(rx.len(), self.host_baud);
        self.emu.receive(arrival, &rx);
        self.drain_events();
        Ok(())
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let wait = u64::try_from(timeout.as_nanos().div_ceil(1000)).unwrap_or(u64::MAX);
        let deadline = self.now_us.saturating_add(wait);
        loop {
            self.pump();
            if !self.arrived.is_empty() {
                let n = buf.len().min(self.arrived.len());
                for (d, (b, baud)) in buf.iter_mut().zip(self.arrived.drain(..n)) {
                    *d = if baud == self.host_baud {
                        b
                    } else {
                        scramble(b)
                    };
                }
                return Ok(n);
            }
            match self.emu.next_wakeup_us() {
                Some(t) if t <= deadline => self.now_us = t.max(self.now_us + 1),
                _ => {
                    self.now_us = deadline;
                    return Ok(0);
                }
            }
        }
    }

    fn set_baud(&mut self, baud: Baud) -> io::Result<()> {
        self.host_baud = baud;
        Ok(())
    }

    fn discard_input(&mut self) -> io::Result<()> {
        self.pump();
        self.arrived.clear();
        self.held_dropped = self.held.len();
        Ok(())
    }

    fn now(&self) -> Duration {
        Duration::from_micros(self.now_us)
    }

    fn name(&self) -> String {
        "emulated-lms".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readdress_recomputes_the_crc() {
        let mut t = vec![0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0, 0];
        readdress(&mut t, 0x81);
        assert_eq!(t[1], 0x81);
        assert_eq!(crc16(&t[..7]).to_le_bytes(), [t[7], t[8]]);
        assert_eq!(telegram_len(&t[..4]), Some(9));
        assert_eq!(telegram_len(&t[..3]), None);
    }

    #[test]
    fn the_pattern_changes_from_scan_to_scan() {
        let mut p = PatternSource::default();
        let (mut a, mut b) = ([0u16; 181], [0u16; 181]);
        assert_eq!(
            p.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut a),
            181
        );
        p.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut b);
        assert_ne!(a, b);
        assert_eq!((a[0], a[97], a[1]), (8191, 8191, 32));
    }
}
