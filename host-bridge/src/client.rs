//! An LMS 2xx client: the host side of the serial protocol (PROTOCOL.md §1–§5).
//!
//! Two layers, kept apart:
//!
//! * **The link** ([`Link`], [`crate::serial`]): moves bytes and keeps time — send, receive
//!   with a timeout, change the baud rate, drop unread input, and a
//!   monotonic clock. [`SerialLink`](crate::serial::SerialLink) is a real serial port (the
//!   `serialport` crate); tests use the core's LMS emulator behind an
//!   in-memory line with a virtual clock and fault injection
//!   ([`crate::emulated_link::EmulatedLink`]).
//! * **The protocol** ([`Client`]): a blocking driver of the core's client
//!   machine ([`lms_core::device::client`], sans I/O, shared with the
//!   co-processor's bring-up). The machine frames every byte received,
//!   tracks `ACK`/`NAK`/reply, resends and counts; this driver sends its
//!   requests, feeds it what the link receives, hands it the link's time,
//!   and parses replies with [`Reply::parse`]. All waiting is bounded by
//!   the [`Timeouts`] given to the client, measured on the link's clock, so
//!   the same code runs against a real sensor, the simulator on a
//!   pseudo-terminal, or the in-memory emulator.
//!
//! # The handshake (as the machine implements it)
//!
//! A request is sent, then the client waits for `ACK` (`06`) and the reply
//! whose command is the request's `| 0x80`:
//!
//! * `NAK` (`15`): the sensor saw a bad checksum; the request is sent again,
//!   at most [`Client::retries`] times.
//! * A reply without an `ACK` before it is accepted (some sensors skip it)
//!   and counted in [`ClientStats::missing_acks`].
//! * Telegrams whose address byte is not `0x80 | address` are ignored and
//!   counted ([`ClientStats::wrong_address`]), as real clients do; so are
//!   other telegrams that are not the awaited reply (e.g. `B0` scans still
//!   streaming while `20 25` stops the stream: [`ClientStats::ignored`]).
//! * `92` (unknown command) ends the request with
//!   [`ClientError::UnknownCommand`].
//! * Nothing in time: [`ClientError::Timeout`], naming the bytes sent last,
//!   what was awaited and how long the client waited.
//!
//! Corrupted, truncated or stray bytes on the line never stop the client:
//! the framer skips them and counts them ([`FramerStats`]: CRC errors,
//! resyncs, bytes skipped), and the next good telegram is used.
//!
//! # Times
//!
//! Every wait is a fixed allowance from [`Timeouts`] plus the time the
//! longest telegram ([`MAX_TELEGRAM_LEN`] = 818 bytes) takes on the line at
//! the current rate (10 bits per byte: 8 data bits, start and stop bit):
//! 852 ms at 9600 Bd, 16.4 ms at 500000 Bd ([`line_time`]).

use std::fmt;
use std::io;
use std::time::Duration;

use lms_core::device::client::{BaudProbe, Client as Machine, Limits, Outcome};
use lms_core::telegram::{
    Baud, Config, Direction, FramerStats, Handshake, MeasuredError, MeasuredValues, ModeResult,
    Reply, Request, Telegram, DEFAULT_PASSWORD, MAX_TELEGRAM_LEN,
};
use lms_core::Unit;
use lms_core::Variant;

use crate::serial::{line_time, Link};

/// How long the client waits. Each wait also allows the time the longest
/// telegram takes on the line at the current rate ([`line_time`]), since a
/// streamed scan may be on the line first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// For the `ACK` after a request (real sensors answer within ~60 ms).
    pub ack: Duration,
    /// For the reply after the `ACK`, and between streamed scans (a real
    /// sensor takes up to a few seconds for a variant or configuration
    /// change).
    pub reply: Duration,
    /// For the `ACK` while probing a rate in [`Client::find_baud`]: short,
    /// since most rates tried are wrong.
    pub probe: Duration,
}

impl Default for Timeouts {
    /// `ack` 300 ms, `reply` 5 s, `probe` 300 ms.
    fn default() -> Self {
        Timeouts {
            ack: Duration::from_millis(300),
            reply: Duration::from_secs(5),
            probe: Duration::from_millis(300),
        }
    }
}

pub use lms_core::device::client::{Awaited, ClientStats};

/// A request as it went on the line, for messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sent {
    /// The telegram's bytes.
    pub bytes: Vec<u8>,
    /// What it asks, e.g. `20 25 (values on request)`.
    pub what: String,
}

impl fmt::Display for Sent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} [{}]", self.what, hex(&self.bytes))
    }
}

/// Bytes as `02 00 01 00 31 15 12`, shortened after 24 bytes.
pub fn hex(bytes: &[u8]) -> String {
    let shown: Vec<String> = bytes.iter().take(24).map(|b| format!("{b:02X}")).collect();
    let mut s = shown.join(" ");
    if bytes.len() > 24 {
        s.push_str(&format!(" … ({} bytes)", bytes.len()));
    }
    s
}

/// A request's payload in words, e.g. `20 25 (values on request)`.
pub fn describe(request: &Request<'_>) -> String {
    match request {
        Request::InstallationMode { .. } => "20 00 (installation mode)".into(),
        Request::Continuous => "20 24 (continuous output)".into(),
        Request::OnRequest => "20 25 (values on request)".into(),
        Request::SetBaud(b) => format!("20 {:02X} (baud {})", b.mode_byte(), b.bits_per_second()),
        Request::OneScan => "30 01 (one scan)".into(),
        Request::Status => "31 (status)".into(),
        Request::SensorType => "3A (sensor type)".into(),
        Request::SetVariant(asked) => format!(
            "3B (variant {}°/{}°)",
            asked.fov_deg,
            f64::from(asked.res_centideg) / 100.0
        ),
        Request::ReadConfig => "74 (read configuration)".into(),
        Request::WriteConfig(_) => "77 (write configuration)".into(),
        Request::Reset => "10 (reset)".into(),
        Request::Unknown { command, .. } => format!("{command:02X}"),
        other => format!("{:02X}", other.command()),
    }
}

/// Why a client operation failed.
#[derive(Debug)]
pub enum ClientError {
    /// Reading, writing or configuring the port failed.
    Io {
        /// The port.
        port: String,
        /// What was being done.
        action: &'static str,
        /// The error.
        source: io::Error,
    },
    /// Nothing (valid) arrived in time.
    Timeout {
        /// The port.
        port: String,
        /// The rate the port was at.
        baud: Baud,
        /// The request sent last.
        sent: Option<Sent>,
        /// What was awaited.
        awaited: Awaited,
        /// How long the client waited.
        waited: Duration,
    },
    /// The sensor answered every try with `NAK`.
    Nak {
        /// The port.
        port: String,
        /// The request.
        sent: Sent,
        /// How many times it was sent.
        attempts: u32,
    },
    /// The sensor answered `92`: unknown or malformed command.
    UnknownCommand {
        /// The request.
        sent: Sent,
    },
    /// The sensor answered but refused or did not do what was asked.
    Refused {
        /// The request.
        sent: Sent,
        /// What the reply said.
        detail: String,
    },
    /// The awaited reply arrived but could not be parsed.
    BadReply {
        /// The request.
        sent: Sent,
        /// The reply's bytes.
        reply: Vec<u8>,
        /// Why it could not be parsed.
        detail: String,
    },
    /// No rate got an answer in [`Client::find_baud`].
    NoSensor {
        /// The port.
        port: String,
        /// The rates tried, each with what came back there (e.g.
        /// `2 NAK, 1 telegrams`, or `nothing`).
        tried: Vec<(Baud, String)>,
        /// The probe sent at each.
        sent: Sent,
        /// The longest wait at one rate.
        waited: Duration,
    },
    /// A unit the sensor cannot be configured to (10 cm has no code).
    Unsupported {
        /// What.
        detail: String,
    },
}

impl fmt::Display for ClientError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientError::Io {
                port,
                action,
                source,
            } => write!(f, "serial port {port}: {action} failed: {source}"),
            ClientError::Timeout {
                port,
                baud,
                sent,
                awaited,
                waited,
            } => {
                write!(
                    f,
                    "no answer on {port} at {} Bd: waited {} ms for {awaited}",
                    baud.bits_per_second(),
                    waited.as_millis()
                )?;
                match sent {
                    Some(s) => write!(f, " after sending {s}"),
                    None => Ok(()),
                }
            }
            ClientError::Nak {
                port,
                sent,
                attempts,
            } => write!(
                f,
                "the sensor on {port} rejected {sent} with NAK {attempts} times (line noise or wrong rate?)"
            ),
            ClientError::UnknownCommand { sent } => {
                write!(f, "the sensor answered 92 (unknown command) to {sent}")
            }
            ClientError::Refused { sent, detail } => {
                write!(f, "the sensor refused {sent}: {detail}")
            }
            ClientError::BadReply {
                sent,
                reply,
                detail,
            } => write!(f, "bad reply to {sent}: {detail} [{}]", hex(reply)),
            ClientError::NoSensor {
                port,
                tried,
                sent,
                waited,
            } => {
                let rates: Vec<String> = tried
                    .iter()
                    .map(|(b, _)| b.bits_per_second().to_string())
                    .collect();
                let heard: Vec<String> = tried
                    .iter()
                    .map(|(b, h)| format!("{} Bd: {h}", b.bits_per_second()))
                    .collect();
                write!(
                    f,
                    "no LMS 2xx answers on {port}: sent {sent} at {} Bd and waited up to {} ms at each for ACK and the A0 reply \
                     (is the sensor powered and connected?); heard: {}",
                    rates.join(", "),
                    waited.as_millis(),
                    heard.join("; ")
                )
            }
            ClientError::Unsupported { detail } => f.write_str(detail),
        }
    }
}

/// The I/O error's text is part of the message already: no `source`, or
/// `{:#}` would print it twice ("Broken pipe: Broken pipe").
impl std::error::Error for ClientError {}

impl ClientError {
    /// `true` for the errors that mean "no (understandable) answer at this
    /// rate": a timeout or repeated `NAK`s.
    pub fn is_no_answer(&self) -> bool {
        matches!(self, ClientError::Timeout { .. } | ClientError::Nak { .. })
    }
}

/// One scan as received.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Scan {
    /// When the telegram was complete, on the link's clock.
    pub time: Duration,
    /// The complete `B0` telegram, `STX` … `CRC`.
    pub telegram: Vec<u8>,
    /// Its values.
    pub values: MeasuredValues,
}

impl Scan {
    /// The scan in a `B0` telegram received at `time`.
    pub fn from_telegram(time: Duration, telegram: Vec<u8>) -> Result<Self, MeasuredError> {
        let values = MeasuredValues::parse(&Telegram::new_unchecked(
            &telegram[..],
            Direction::SensorToHost,
        ))?;
        Ok(Scan {
            time,
            telegram,
            values,
        })
    }
}

/// Bytes read from the link per call.
const CHUNK: usize = 4096;

/// A duration in whole µs (the machine's time unit), saturated.
/// What the framer took in at one rate of the search, for the message.
fn heard_at(before: &FramerStats, after: &FramerStats) -> String {
    let d = |a: u32, b: u32| a.wrapping_sub(b);
    let parts: Vec<String> = [
        (d(after.telegrams, before.telegrams), "telegrams"),
        (d(after.acks, before.acks), "ACK"),
        (d(after.naks, before.naks), "NAK"),
        (d(after.crc_errors, before.crc_errors), "CRC errors"),
        (d(after.bytes_skipped, before.bytes_skipped), "noise bytes"),
    ]
    .iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, what)| format!("{n} {what}"))
    .collect();
    if parts.is_empty() {
        "nothing".to_string()
    } else {
        parts.join(", ")
    }
}

fn micros(d: Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}

/// The allowances of the current waits, for messages.
#[derive(Clone, Copy, Debug, Default)]
struct Waits {
    ack: Duration,
    reply: Duration,
    stream: Duration,
}

/// The protocol side of an LMS 2xx client over a [`Link`] (see the
/// [module docs](self)): a blocking driver of the core's client machine.
pub struct Client<L: Link> {
    link: L,
    machine: Machine,
    /// Bytes received and not yet fed to the machine: `pending[pending_at..]`.
    pending: Vec<u8>,
    pending_at: usize,
    chunk: Vec<u8>,
    /// The rate the link is at.
    baud: Baud,
    timeouts: Timeouts,
    /// Resends after a `NAK` before giving up.
    pub retries: u32,
    streaming: bool,
    last_sent: Option<Sent>,
    waits: Waits,
}

impl<L: Link> fmt::Debug for Client<L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Client")
            .field("port", &self.link.name())
            .field("baud", &self.baud)
            .field("address", &self.machine.address())
            .field("streaming", &self.streaming)
            .field("stats", self.machine.stats())
            .finish_non_exhaustive()
    }
}

impl<L: Link> Client<L> {
    /// A client for the sensor at address 0 on `link`, which is at `baud`;
    /// 3 resends on `NAK`.
    pub fn new(link: L, baud: Baud, timeouts: Timeouts) -> Self {
        Client {
            link,
            machine: Machine::new(0),
            pending: Vec::with_capacity(CHUNK),
            pending_at: 0,
            chunk: vec![0; CHUNK],
            baud,
            timeouts,
            retries: 3,
            streaming: false,
            last_sent: None,
            waits: Waits::default(),
        }
    }

    /// Talk to the sensor at `address` (0..=0x7F) instead of 0.
    pub fn with_address(mut self, address: u8) -> Self {
        self.machine.set_address(address);
        self
    }

    /// The link.
    pub fn link(&self) -> &L {
        &self.link
    }

    /// The link, e.g. to inject faults into a test double.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// Give back the link.
    pub fn into_link(self) -> L {
        self.link
    }

    /// The rate the link is at.
    pub fn baud(&self) -> Baud {
        self.baud
    }

    /// The timeouts in use.
    pub fn timeouts(&self) -> Timeouts {
        self.timeouts
    }

    /// Change the timeouts.
    pub fn set_timeouts(&mut self, timeouts: Timeouts) {
        self.timeouts = timeouts;
    }

    /// `true` between [`start_stream`](Self::start_stream) and
    /// [`stop_stream`](Self::stop_stream).
    pub fn is_streaming(&self) -> bool {
        self.streaming
    }

    /// Handshake counters.
    pub fn stats(&self) -> ClientStats {
        *self.machine.stats()
    }

    /// Byte-level counters of the framer (CRC errors, resyncs, bytes
    /// skipped, …) since the client was made.
    pub fn framer_stats(&self) -> FramerStats {
        *self.machine.framer_stats()
    }

    /// The request sent last.
    pub fn last_sent(&self) -> Option<&Sent> {
        self.last_sent.as_ref()
    }

    /// The link's clock.
    pub fn now(&self) -> Duration {
        self.link.now()
    }

    /// The link's clock in µs, the machine's time.
    fn now_us(&self) -> u64 {
        micros(self.link.now())
    }

    fn io_error(&self, action: &'static str, source: io::Error) -> ClientError {
        ClientError::Io {
            port: self.link.name(),
            action,
            source,
        }
    }

    /// Put the link at `baud` and forget everything received so far.
    fn switch_link(&mut self, baud: Baud) -> Result<(), ClientError> {
        self.link
            .set_baud(baud)
            .map_err(|e| self.io_error("setting the baud rate", e))?;
        self.baud = baud;
        self.flush_input()
    }

    /// Drop unread input: the link's, the pending bytes and the framer's.
    fn flush_input(&mut self) -> Result<(), ClientError> {
        self.link
            .discard_input()
            .map_err(|e| self.io_error("discarding input", e))?;
        self.pending.clear();
        self.pending_at = 0;
        self.machine.discard();
        Ok(())
    }

    /// Run the machine on what arrives until it reports an outcome (a
    /// time-out included); power-on telegrams are passed over.
    fn next_outcome(&mut self) -> Result<Outcome, ClientError> {
        loop {
            let input = self.pending.get(self.pending_at..).unwrap_or_default();
            let (outcome, rest) = self.machine.feed(input, micros(self.link.now()));
            self.pending_at += input.len() - rest.len();
            match outcome {
                Some(Outcome::PowerOn) => continue,
                Some(outcome) => return Ok(outcome),
                None => {}
            }
            // Everything held has been taken: time, then more bytes.
            let now = self.now_us();
            if let Some(outcome) = self.machine.poll(now) {
                return Ok(outcome);
            }
            match self.machine.deadline_us() {
                Some(deadline) if deadline > now => {
                    self.receive(Duration::from_micros(deadline - now))?;
                }
                // At the deadline: the machine gave up a false STX; take
                // what it held back before waiting again.
                Some(_) => {}
                None => self.receive(self.timeouts.reply)?,
            }
        }
    }

    /// Wait up to `timeout` for bytes into `pending`.
    fn receive(&mut self, timeout: Duration) -> Result<(), ClientError> {
        let n = self
            .link
            .receive(&mut self.chunk, timeout)
            .map_err(|e| ClientError::Io {
                port: self.link.name(),
                action: "reading",
                source: e,
            })?;
        self.pending.clear();
        self.pending
            .extend_from_slice(self.chunk.get(..n).unwrap_or_default());
        self.pending_at = 0;
        Ok(())
    }

    fn timeout(&self, awaited: Awaited) -> ClientError {
        let waited = match awaited {
            Awaited::Ack => self.waits.ack,
            Awaited::Reply(_) => self.waits.reply,
            Awaited::StreamScan => self.waits.stream,
        };
        ClientError::Timeout {
            port: self.link.name(),
            baud: self.baud,
            sent: self.last_sent.clone(),
            awaited,
            waited,
        }
    }

    /// Send `request` and return the awaited reply telegram (`STX` …
    /// `CRC`), handling `ACK`/`NAK` as in the [module docs](self). `ack`
    /// is the allowance for the `ACK`; the longest telegram's line time
    /// is added to every wait (a streamed scan may be on the line first).
    fn exchange(&mut self, request: &Request<'_>, ack: Duration) -> Result<Vec<u8>, ClientError> {
        let longest = line_time(MAX_TELEGRAM_LEN, self.baud);
        self.waits.ack = line_time(request.buffer_len(), self.baud) + ack + longest;
        // At most one more streamed scan may come before the reply.
        self.waits.reply = self.timeouts.reply + 2 * longest;
        let limits = Limits {
            ack_us: micros(self.waits.ack),
            reply_us: Some(micros(self.waits.reply)),
            retries: self.retries,
        };
        let what = describe(request);
        let bytes = match self.machine.prepare(request, limits) {
            Ok(bytes) => bytes.to_vec(),
            Err(e) => {
                return Err(ClientError::Unsupported {
                    detail: format!("cannot build {what}: {e}"),
                })
            }
        };
        let sent = Sent { bytes, what };
        loop {
            self.link
                .send(&sent.bytes)
                .map_err(|e| self.io_error("writing", e))?;
            self.last_sent = Some(sent.clone());
            self.machine.mark_sent(self.now_us());
            return match self.next_outcome()? {
                Outcome::Resend => continue,
                // (Power-on telegrams are passed over by `next_outcome`;
                // scans are reported only in the stream.)
                Outcome::Reply | Outcome::Scan | Outcome::PowerOn => {
                    Ok(self.machine.telegram_bytes().to_vec())
                }
                Outcome::NakLimit { attempts } => Err(ClientError::Nak {
                    port: self.link.name(),
                    sent,
                    attempts,
                }),
                Outcome::UnknownCommand => Err(ClientError::UnknownCommand { sent }),
                Outcome::Timeout(awaited) => Err(self.timeout(awaited)),
            };
        }
    }

    /// Send `request` and parse the awaited reply with `f`.
    fn transact<T>(
        &mut self,
        request: &Request<'_>,
        f: impl FnOnce(Reply<'_>) -> Result<T, String>,
    ) -> Result<T, ClientError> {
        let ack = self.timeouts.ack;
        self.transact_with(request, ack, f)
    }

    fn transact_with<T>(
        &mut self,
        request: &Request<'_>,
        ack: Duration,
        f: impl FnOnce(Reply<'_>) -> Result<T, String>,
    ) -> Result<T, ClientError> {
        let bytes = self.exchange(request, ack)?;
        let sent = self.sent_or(request);
        let telegram = Telegram::new_unchecked(&bytes[..], Direction::SensorToHost);
        let reply = Reply::parse(&telegram).map_err(|e| ClientError::BadReply {
            sent: sent.clone(),
            reply: bytes.clone(),
            detail: e.to_string(),
        })?;
        f(reply).map_err(|detail| ClientError::Refused { sent, detail })
    }

    /// The request sent last, or `request` described (for messages).
    fn sent_or(&self, request: &Request<'_>) -> Sent {
        self.last_sent.clone().unwrap_or_else(|| Sent {
            bytes: Vec::new(),
            what: describe(request),
        })
    }

    /// A `20 xx` mode change that must be answered `A0 00`.
    fn mode_change(&mut self, request: &Request<'_>, ack: Duration) -> Result<(), ClientError> {
        self.transact_with(request, ack, |reply| match reply {
            Reply::ModeChanged(ModeResult::Ok) => Ok(()),
            Reply::ModeChanged(ModeResult::BadPassword) => Err("A0 01: wrong password".into()),
            Reply::ModeChanged(ModeResult::Fault) => Err("A0 02: mode not changed".into()),
            Reply::ModeChanged(ModeResult::Unknown(b)) => Err(format!("A0 {b:02X}")),
            other => Err(format!("unexpected reply {:02X}", other.command())),
        })
    }

    /// Find the rate the sensor is at ([`BaudProbe`]): at each rate of
    /// `rates` in turn, set the link, send `20 25` (which also stops a
    /// stream left running) and wait for `ACK` and `A0 00`
    /// ([`Timeouts::probe`] for the `ACK`, at most one resend). The first
    /// rate answered is kept and returned. Sensors power up at 9600 Bd, so
    /// put it first.
    pub fn find_baud(&mut self, rates: &[Baud]) -> Result<Baud, ClientError> {
        self.machine.set_handshake(Handshake::Expected);
        let retries = self.retries;
        // A wrong rate can look like NAKs: don't insist.
        self.retries = retries.min(BaudProbe::RETRIES);
        let result = self.probe(BaudProbe::new(rates));
        self.retries = retries;
        result
    }

    /// Tries at one rate where the sensor's telegrams are heard but the
    /// probe is not answered (stray `06`/`15` bytes inside a stream left
    /// running read as handshakes until the framer is in step).
    const STREAM_TRIES: u32 = 4;

    fn probe(&mut self, mut probe: BaudProbe<'_>) -> Result<Baud, ClientError> {
        let mut longest = Duration::ZERO;
        let mut heard = Vec::new();
        while let Some(rate) = probe.next_rate() {
            self.switch_link(rate)?;
            let before = self.framer_stats();
            let mut tries = 0;
            let result = loop {
                tries += 1;
                let result = self.mode_change(&BaudProbe::REQUEST, self.timeouts.probe);
                longest = longest.max(self.waits.ack);
                let telegrams = self.framer_stats().telegrams.wrapping_sub(before.telegrams);
                let naked = matches!(result, Err(ClientError::Nak { .. }));
                // NAKs may be data bytes of a stream left running: listen
                // (handshake bytes ignored) until the framer is in step
                // with the telegrams, then ask again; likewise while
                // telegrams show that a sensor talks at this rate.
                match result {
                    Err(e)
                        if e.is_no_answer()
                            && (naked || telegrams > 0)
                            && tries < Self::STREAM_TRIES =>
                    {
                        self.listen(line_time(MAX_TELEGRAM_LEN, rate) + Duration::from_millis(20))?;
                    }
                    other => break other,
                }
            };
            match result {
                Ok(()) => {
                    self.streaming = false;
                    self.machine.set_handshake(Handshake::Expected);
                    return Ok(rate);
                }
                Err(e) if e.is_no_answer() => {}
                Err(e) => return Err(e),
            }
            heard.push((rate, heard_at(&before, &self.framer_stats())));
        }
        Err(ClientError::NoSensor {
            port: self.link.name(),
            tried: heard,
            sent: self.sent_or(&BaudProbe::REQUEST),
            waited: longest,
        })
    }

    /// Take what arrives for `span` with handshake bytes ignored: the
    /// framer skips the rest of a telegram it dropped into and frames the
    /// next ones (counted as ignored), so that it is in step afterwards.
    fn listen(&mut self, span: Duration) -> Result<(), ClientError> {
        self.machine.set_handshake(Handshake::Ignored);
        let end = self.link.now() + span;
        loop {
            let input = self.pending.get(self.pending_at..).unwrap_or_default();
            let (_, rest) = self.machine.feed(input, self.now_us());
            self.pending_at += input.len() - rest.len();
            if rest.is_empty() {
                let now = self.link.now();
                if now >= end {
                    break;
                }
                self.receive(end - now)?;
            }
        }
        self.machine.set_handshake(Handshake::Expected);
        Ok(())
    }

    /// `20 25`: values on request only (the power-on mode). Stops a stream:
    /// scans still arriving before the `A0` are dropped (counted in
    /// [`ClientStats::ignored`]).
    pub fn stop_stream(&mut self) -> Result<(), ClientError> {
        self.machine.set_handshake(Handshake::Expected);
        let ack = self.timeouts.ack;
        self.mode_change(&Request::OnRequest, ack)?;
        self.streaming = false;
        Ok(())
    }

    /// `20 24`: continuous output; read the scans with
    /// [`next_scan`](Self::next_scan).
    pub fn start_stream(&mut self) -> Result<(), ClientError> {
        let ack = self.timeouts.ack;
        self.mode_change(&Request::Continuous, ack)?;
        self.streaming = true;
        // Streamed telegrams come without ACK: a 06 or 15 between them is noise.
        self.machine.set_handshake(Handshake::Ignored);
        Ok(())
    }

    /// The next scan of the stream. Corrupted or truncated telegrams and
    /// noise are skipped (see [`framer_stats`](Self::framer_stats)), as are
    /// telegrams that are not scans; times out after [`Timeouts::reply`]
    /// plus two telegram times without a scan.
    pub fn next_scan(&mut self) -> Result<Scan, ClientError> {
        self.waits.stream = self.timeouts.reply + 2 * line_time(MAX_TELEGRAM_LEN, self.baud);
        let now = self.now_us();
        self.machine
            .await_stream(now, Some(micros(self.waits.stream)));
        loop {
            match self.next_outcome()? {
                Outcome::Timeout(awaited) => return Err(self.timeout(awaited)),
                Outcome::Scan => {
                    let time = self.link.now();
                    let telegram = self.machine.telegram_bytes().to_vec();
                    match Scan::from_telegram(time, telegram) {
                        Ok(scan) => return Ok(scan),
                        // Never taken: the machine has checked the scan.
                        Err(_) => {
                            debug_assert!(false, "a checked scan did not parse");
                            self.machine.stats_mut().bad_scans += 1;
                        }
                    }
                }
                // Not reported in the stream.
                _ => {}
            }
        }
    }

    /// `30 01`: one scan on request.
    pub fn single_scan(&mut self) -> Result<Scan, ClientError> {
        let ack = self.timeouts.ack;
        let bytes = self.exchange(&Request::OneScan, ack)?;
        let time = self.link.now();
        Scan::from_telegram(time, bytes.clone()).map_err(|e| {
            self.machine.stats_mut().bad_scans += 1;
            ClientError::BadReply {
                sent: self.sent_or(&Request::OneScan),
                reply: bytes,
                detail: e.to_string(),
            }
        })
    }

    /// `3B`: set the scan variant; the sensor must accept it (`BB 01`) and
    /// report the variant asked for.
    pub fn set_variant(&mut self, variant: Variant) -> Result<(), ClientError> {
        let ack = self.timeouts.ack;
        self.transact_with(&Request::set_variant(variant), ack, |reply| match reply {
            Reply::Variant(v) if v.accepted && v.variant() == Some(variant) => Ok(()),
            Reply::Variant(v) => Err(format!(
                "BB {:02X}: {} (now {}°/{}°)",
                u8::from(v.accepted),
                if v.accepted { "accepted" } else { "refused" },
                v.angle_deg,
                f64::from(v.resolution_centideg) / 100.0
            )),
            other => Err(format!("unexpected reply {:02X}", other.command())),
        })
    }

    /// `74`: read the configuration block.
    pub fn read_config(&mut self) -> Result<Config, ClientError> {
        self.transact(&Request::ReadConfig, |reply| match reply {
            Reply::Config(c) => Ok(c),
            other => Err(format!("unexpected reply {:02X}", other.command())),
        })
    }

    /// Set the range units: read the configuration (`74`); if its units
    /// byte differs, enter installation mode (`20 00 SICK_LMS`), write the
    /// configuration with the units byte changed (`77`, answered `F7 01`),
    /// and go back to values on request (`20 25`).
    pub fn set_units(&mut self, units: Unit) -> Result<(), ClientError> {
        let code = units.code().ok_or_else(|| ClientError::Unsupported {
            detail: format!("{units:?} cannot be configured (only cm and mm)"),
        })?;
        let mut config = self.read_config()?;
        if config.units_code() == code {
            return Ok(());
        }
        let ack = self.timeouts.ack;
        self.mode_change(
            &Request::InstallationMode {
                password: DEFAULT_PASSWORD,
            },
            ack,
        )?;
        config.set_units_code(code);
        self.transact(&Request::WriteConfig(config), |reply| match reply {
            Reply::ConfigWritten {
                accepted: true,
                config: c,
            } if c.units_code() == code => Ok(()),
            Reply::ConfigWritten { accepted, config } => Err(format!(
                "F7 {:02X}, units byte now {}",
                u8::from(accepted),
                config.units_code()
            )),
            other => Err(format!("unexpected reply {:02X}", other.command())),
        })?;
        self.mode_change(&Request::OnRequest, ack)
    }

    /// `20 4x`: switch the sensor to `baud`. The reply comes at the old
    /// rate; then the link is switched, and `20 25` at the new rate checks
    /// that the sensor is there.
    ///
    /// If no answer to `20 4x` arrives (a reply lost on the line, while the
    /// sensor may have switched all the same), the client tries `20 25` at
    /// the new rate; if the sensor answers there, the switch counts as done
    /// ([`ClientStats::lost_baud_replies`]), else the link goes back to the
    /// old rate and the time-out is returned.
    pub fn set_baud(&mut self, baud: Baud) -> Result<(), ClientError> {
        if baud == self.baud {
            return Ok(());
        }
        let ack = self.timeouts.ack;
        match self.mode_change(&Request::SetBaud(baud), ack) {
            Ok(()) => {}
            Err(e @ ClientError::Timeout { .. }) => {
                let old = self.baud;
                self.switch_link(baud)?;
                if self.mode_change(&Request::OnRequest, ack).is_ok() {
                    self.machine.stats_mut().lost_baud_replies += 1;
                    return Ok(());
                }
                self.switch_link(old)?;
                return Err(e);
            }
            Err(e) => return Err(e),
        }
        self.switch_link(baud)?;
        self.mode_change(&Request::OnRequest, ack)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_times() {
        assert_eq!(line_time(732, Baud::B500000), Duration::from_micros(14_640));
        assert_eq!(line_time(1, Baud::B9600).as_micros(), 1041);
        assert_eq!(line_time(818, Baud::B9600).as_millis(), 852);
    }

    #[test]
    fn descriptions() {
        assert_eq!(hex(&[0x02, 0x00, 0x01]), "02 00 01");
        assert!(hex(&[0u8; 30]).ends_with("… (30 bytes)"));
        assert_eq!(
            describe(&Request::SetBaud(Baud::B500000)),
            "20 48 (baud 500000)"
        );
        assert_eq!(
            describe(&Request::set_variant(Variant::Fov100Res25)),
            "3B (variant 100°/0.25°)"
        );
    }
}
