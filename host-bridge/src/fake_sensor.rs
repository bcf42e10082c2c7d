//! An in-memory LMS 2xx behind the client's [`Link`] trait, with a virtual
//! clock and fault injection: the test double for [`crate::client`].
//!
//! [`FakeSensor`] answers the requests of PROTOCOL.md §2 from its own state
//! (rate, variant, configuration, installation mode, streaming), paces every
//! byte it sends at its current rate (10 bits per byte, [`line_time`]) on a
//! virtual clock that only moves when the client waits, and streams `B0`
//! scans every [`FakeSensor::scan_period`] (26.7 ms, the mirror's 75 Hz)
//! or as fast as the line allows. Nothing sleeps, so tests at 9600 Bd run in
//! microseconds of real time.
//!
//! Like a real line, a client at the wrong rate sees garbage: bytes sent or
//! received while the client's rate differs from the sensor's are scrambled
//! (XOR `0xA5`).
//!
//! Faults to inject:
//!
//! * [`FakeSensor::corrupt_next`]: flip a bit in the next requests on
//!   their way; the sensor's framer finds the bad CRC and answers `NAK`.
//! * [`FakeSensor::nak_next`]: answer the next requests with `NAK`.
//! * [`FakeSensor::add_stream_fault`]: corrupt a bit of a streamed scan (a
//!   CRC error), truncate it, send it with a wrong address, or put noise
//!   bytes before it.
//! * [`FakeSensor::send_acks`]: leave out the `ACK` byte.
//! * [`FakeSensor::mute`]: answer nothing.
//!
//! Every scan sent intact is kept ([`FakeSensor::intact_scans`]) so a test
//! can compare what the client received with what went out.

use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::time::Duration;

use lms_core::telegram::{
    Baud, Config, Direction, Event, Framer, Handshake, MeasuredValues, ModeResult, Reply, Request,
    StatusBlock, StatusFields, ACK, DEFAULT_PASSWORD, DEFAULT_STATUS, NAK, SENSOR_TYPE_LMS200,
};
use lms_core::Unit;
use lms_core::Variant;

use crate::serial::{line_time, Link};

/// What happens to one streamed scan.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StreamFault {
    /// Flip bit 0 of the byte at this offset of the telegram: the CRC fails.
    Corrupt {
        /// Byte offset in the telegram (0 = `STX`).
        at: usize,
    },
    /// Send only the first `keep` bytes of the telegram.
    Truncate {
        /// Bytes sent.
        keep: usize,
    },
    /// Send the telegram with this address byte (CRC recomputed).
    Address(u8),
    /// Send these bytes just before the (intact) telegram.
    NoiseBefore(Vec<u8>),
}

/// Makes the value words of scan `index` for a variant and units.
pub type ScanSource = Box<dyn FnMut(usize, Variant, Unit) -> MeasuredValues + Send>;

/// Bytes on their way to the host.
#[derive(Debug)]
struct Chunk {
    /// When the last byte has arrived.
    at: Duration,
    /// The rate they were sent at.
    baud: Baud,
    bytes: Vec<u8>,
    /// Bytes already handed to the host.
    read: usize,
}

/// Scramble a byte sent at the wrong rate.
fn scramble(b: u8) -> u8 {
    b ^ 0xA5
}

/// The default scan source: a deterministic pattern of ranges (1..=8000
/// in the sensor's units) with a few error codes.
pub fn pattern_scan(index: usize, variant: Variant, units: Unit) -> MeasuredValues {
    let words: Vec<u16> = (0..variant.beams())
        .map(|j| {
            if (j + index).is_multiple_of(97) {
                8191
            } else {
                ((j * 31 + index * 17) % 8000 + 1) as u16
            }
        })
        .collect();
    MeasuredValues::from_raw(&words, units, DEFAULT_STATUS).unwrap_or_else(|_| {
        // Not reached: variants have at most MAX_VALUES beams.
        MeasuredValues::empty(units, DEFAULT_STATUS)
    })
}

/// The in-memory sensor (see the [module docs](self)).
pub struct FakeSensor {
    now: Duration,
    host_baud: Baud,
    sensor_baud: Baud,
    address: u8,
    variant: Variant,
    config: Config,
    installation: bool,
    streaming: bool,
    framer: Framer,
    out: VecDeque<Chunk>,
    line_free_at: Duration,
    next_scan_at: Duration,
    source: ScanSource,
    scans_made: usize,
    stream_index: usize,
    intact: Vec<MeasuredValues>,
    stream_faults: BTreeMap<usize, StreamFault>,
    requests: Vec<Vec<u8>>,
    /// Answer this many coming requests with `NAK`.
    pub nak_next: u32,
    /// Flip a bit in this many coming requests on their way to the sensor,
    /// whose framer then finds a bad CRC and answers `NAK`.
    pub corrupt_next: u32,
    /// Send `ACK` before replies (default `true`).
    pub send_acks: bool,
    /// Answer nothing at all, and stop streaming (what is already on the
    /// line still arrives).
    pub mute: bool,
    /// Time between streamed scans when the line is fast enough (26.7 ms).
    pub scan_period: Duration,
    /// Time from the end of a request to the start of its answer (1 ms).
    pub latency: Duration,
}

impl std::fmt::Debug for FakeSensor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FakeSensor")
            .field("now", &self.now)
            .field("host_baud", &self.host_baud)
            .field("sensor_baud", &self.sensor_baud)
            .field("variant", &self.variant)
            .field("streaming", &self.streaming)
            .finish_non_exhaustive()
    }
}

impl Default for FakeSensor {
    fn default() -> Self {
        FakeSensor::new(Baud::B9600)
    }
}

impl FakeSensor {
    /// A sensor at `baud` (a real one powers up at 9600), address 0,
    /// 180°/1°, cm, values on request, [`pattern_scan`] values; the
    /// client's line starts at 9600 Bd.
    pub fn new(baud: Baud) -> Self {
        FakeSensor {
            now: Duration::ZERO,
            host_baud: Baud::B9600,
            sensor_baud: baud,
            address: 0,
            variant: Variant::Fov180Res100,
            config: Config::default(),
            installation: false,
            streaming: false,
            framer: Framer::new(Direction::HostToSensor, Handshake::Ignored),
            out: VecDeque::new(),
            line_free_at: Duration::ZERO,
            next_scan_at: Duration::ZERO,
            source: Box::new(pattern_scan),
            scans_made: 0,
            stream_index: 0,
            intact: Vec::new(),
            stream_faults: BTreeMap::new(),
            requests: Vec::new(),
            nak_next: 0,
            corrupt_next: 0,
            send_acks: true,
            mute: false,
            scan_period: Duration::from_micros(26_667),
            latency: Duration::from_millis(1),
        }
    }

    /// Make scan values with `source` instead of [`pattern_scan`].
    pub fn with_source(mut self, source: ScanSource) -> Self {
        self.source = source;
        self
    }

    /// Answer as the sensor at `address` (replies carry `0x80 | address`).
    pub fn with_address(mut self, address: u8) -> Self {
        self.address = address & 0x7F;
        self
    }

    /// Apply `fault` to streamed scan `index` (counting from 0 over all
    /// streams of this sensor).
    pub fn add_stream_fault(&mut self, index: usize, fault: StreamFault) {
        self.stream_faults.insert(index, fault);
    }

    /// The sensor's rate.
    pub fn baud(&self) -> Baud {
        self.sensor_baud
    }

    /// The sensor's variant.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// The units in the sensor's configuration.
    pub fn units(&self) -> Option<Unit> {
        self.config.units()
    }

    /// `true` while streaming.
    pub fn is_streaming(&self) -> bool {
        self.streaming
    }

    /// Every scan sent intact (streamed or on request), in order.
    pub fn intact_scans(&self) -> &[MeasuredValues] {
        &self.intact
    }

    /// The payload (command + data) of every request received intact.
    pub fn requests(&self) -> &[Vec<u8>] {
        &self.requests
    }

    /// Queue `bytes` to start no earlier than `earliest`; returns when the
    /// line is free again.
    fn transmit(&mut self, earliest: Duration, bytes: Vec<u8>) -> Duration {
        let start = earliest.max(self.line_free_at);
        let end = start + line_time(bytes.len(), self.sensor_baud);
        self.out.push_back(Chunk {
            at: end,
            baud: self.sensor_baud,
            bytes,
            read: 0,
        });
        self.line_free_at = end;
        end
    }

    fn reply(&mut self, at: Duration, reply: &Reply<'_>) {
        let mut buf = vec![0u8; reply.buffer_len()];
        if let Ok(n) = reply.emit(self.address, DEFAULT_STATUS, &mut buf) {
            buf.truncate(n);
            self.transmit(at, buf);
        }
    }

    fn next_values(&mut self) -> MeasuredValues {
        let units = self.config.units().unwrap_or(Unit::Centimetre);
        let v = (self.source)(self.scans_made, self.variant, units);
        self.scans_made += 1;
        v
    }

    fn b0_bytes(&self, values: &MeasuredValues, address: u8) -> Vec<u8> {
        let mut buf = vec![0u8; values.buffer_len()];
        let n = values.emit(address, &mut buf).unwrap_or(0);
        buf.truncate(n);
        buf
    }

    /// Stream scans whose start is due before `limit` and before anything
    /// queued reaches the host (so a stop request cuts the stream in time).
    fn produce_stream(&mut self, limit: Duration) {
        while self.streaming && !self.mute {
            let first_arrival = self.out.front().map_or(limit, |c| c.at.min(limit));
            let start = self.next_scan_at.max(self.line_free_at);
            if start > first_arrival {
                break;
            }
            let values = self.next_values();
            let index = self.stream_index;
            self.stream_index += 1;
            let mut bytes = self.b0_bytes(&values, self.address);
            let mut intact = true;
            match self.stream_faults.remove(&index) {
                None => {}
                Some(StreamFault::Corrupt { at }) => {
                    if let Some(b) = bytes.get_mut(at) {
                        *b ^= 0x01;
                    }
                    intact = false;
                }
                Some(StreamFault::Truncate { keep }) => {
                    bytes.truncate(keep);
                    intact = false;
                }
                Some(StreamFault::Address(a)) => {
                    let mut buf = vec![0u8; values.buffer_len()];
                    let n = lms_core::telegram::emit_telegram_with(
                        &mut buf,
                        a,
                        lms_core::telegram::measured::MEASURED_COMMAND,
                        values.data_len(),
                        Some(values.status()),
                        |data| values.write_data(data),
                    )
                    .unwrap_or(0);
                    buf.truncate(n);
                    bytes = buf;
                    intact = false;
                }
                Some(StreamFault::NoiseBefore(noise)) => {
                    self.transmit(start, noise);
                }
            }
            if intact {
                self.intact.push(values);
            }
            let end = self.transmit(start, bytes);
            self.next_scan_at = (start + self.scan_period).max(end);
        }
    }

    /// Answer one intact request received at `at`.
    fn handle(&mut self, at: Duration, request: &Request<'_>) {
        let t = at + self.latency;
        if self.nak_next > 0 {
            self.nak_next -= 1;
            self.transmit(t, vec![NAK]);
            return;
        }
        if self.send_acks {
            self.transmit(t, vec![ACK]);
        }
        match *request {
            Request::InstallationMode { password } => {
                let ok = password == DEFAULT_PASSWORD;
                self.installation = ok;
                let r = if ok {
                    ModeResult::Ok
                } else {
                    ModeResult::BadPassword
                };
                self.reply(t, &Reply::ModeChanged(r));
            }
            Request::Continuous => {
                self.installation = false;
                self.reply(t, &Reply::ModeChanged(ModeResult::Ok));
                self.streaming = true;
                self.next_scan_at = self.line_free_at;
            }
            Request::OnRequest => {
                // The reply goes after the scan on the line.
                self.streaming = false;
                self.installation = false;
                self.reply(t, &Reply::ModeChanged(ModeResult::Ok));
            }
            Request::SetBaud(b) => {
                self.reply(t, &Reply::ModeChanged(ModeResult::Ok));
                self.sensor_baud = b;
            }
            Request::OneScan => {
                let values = self.next_values();
                let bytes = self.b0_bytes(&values, self.address);
                self.intact.push(values);
                self.transmit(t, bytes);
            }
            Request::Status => {
                let fields = StatusFields {
                    operating_mode: if self.streaming {
                        0x24
                    } else if self.installation {
                        0x00
                    } else {
                        0x25
                    },
                    scan_angle_deg: self.variant.fov_deg(),
                    resolution_centideg: self.variant.resolution_centideg(),
                    baud: self.sensor_baud,
                    address: self.address,
                    units_code: self.config.units_code(),
                };
                self.reply(t, &Reply::Status(StatusBlock::from_fields(&fields)));
            }
            Request::SensorType => {
                self.reply(t, &Reply::SensorType(SENSOR_TYPE_LMS200.as_bytes()));
            }
            Request::SetVariant { .. } => {
                let accepted = match request.variant() {
                    Some(v) => {
                        self.variant = v;
                        true
                    }
                    None => false,
                };
                self.reply(t, &Reply::variant(accepted, self.variant));
            }
            Request::ReadConfig => self.reply(t, &Reply::Config(self.config)),
            Request::WriteConfig(c) => {
                let accepted = self.installation;
                if accepted {
                    self.config = c;
                }
                self.reply(
                    t,
                    &Reply::ConfigWritten {
                        accepted,
                        config: self.config,
                    },
                );
            }
            Request::Reset => {
                self.streaming = false;
                self.installation = false;
                self.reply(t, &Reply::ResetAck);
                self.reply(t, &Reply::PowerOn([0; 21]));
                self.sensor_baud = Baud::B9600;
            }
            Request::Unknown { .. } => self.reply(t, &Reply::UnknownCommand),
        }
    }
}

impl Link for FakeSensor {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        // The request has arrived once its last byte is on the sensor side.
        let at = self.now + line_time(bytes.len(), self.host_baud);
        self.produce_stream(at);
        let mut received = bytes.to_vec();
        if self.host_baud != self.sensor_baud {
            received.iter_mut().for_each(|b| *b = scramble(*b));
        }
        if self.corrupt_next > 0 && received.len() > 5 {
            self.corrupt_next -= 1;
            // A bit of the command byte.
            received[4] ^= 0x10;
        }
        let mut input: &[u8] = &received;
        if self.mute {
            return Ok(());
        }
        // Collect what the framer finds first (it borrows its buffer).
        let mut found: Vec<Result<Vec<u8>, ()>> = Vec::new();
        loop {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            for _ in 0..fed.crc_errors {
                found.push(Err(()));
            }
            match fed.event {
                Some(Event::Telegram(t)) => found.push(Ok(t.as_bytes().to_vec())),
                Some(_) => {}
                None => break,
            }
        }
        for item in found {
            match item {
                Err(()) => {
                    self.transmit(at + self.latency, vec![NAK]);
                }
                Ok(bytes) => {
                    let t = lms_core::telegram::Telegram::new_unchecked(
                        &bytes[..],
                        Direction::HostToSensor,
                    );
                    self.requests.push(t.payload().to_vec());
                    if let Ok(request) = Request::parse(&t) {
                        self.handle(at, &request);
                    }
                }
            }
        }
        Ok(())
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let horizon = self.now + timeout;
        self.produce_stream(horizon);
        let host_baud = self.host_baud;
        match self.out.front_mut() {
            Some(chunk) if chunk.at <= horizon => {
                self.now = self.now.max(chunk.at);
                let rest = chunk.bytes.get(chunk.read..).unwrap_or_default();
                let n = rest.len().min(buf.len());
                for (d, &s) in buf.iter_mut().zip(rest.iter().take(n)) {
                    *d = if chunk.baud == host_baud {
                        s
                    } else {
                        scramble(s)
                    };
                }
                chunk.read += n;
                if chunk.read >= chunk.bytes.len() {
                    self.out.pop_front();
                }
                Ok(n)
            }
            _ => {
                self.now = horizon;
                Ok(0)
            }
        }
    }

    fn set_baud(&mut self, baud: Baud) -> io::Result<()> {
        self.host_baud = baud;
        Ok(())
    }

    fn discard_input(&mut self) -> io::Result<()> {
        let now = self.now;
        self.out.retain(|c| c.at > now);
        Ok(())
    }

    fn now(&self) -> Duration {
        self.now
    }

    fn name(&self) -> String {
        "fake-sensor".into()
    }
}
