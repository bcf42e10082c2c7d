//! The LMS 2xx client's handshake, sans I/O: one request at a time, its
//! `ACK`/`NAK`, its reply, the time-outs and resends, and the `B0` stream
//! (PROTOCOL.md §1, §2 and §5). Bytes and the time (µs, an argument — there
//! is no clock) go in; the request's bytes and [`Outcome`]s come out. The
//! host's blocking client (`host_bridge::client`, over a serial port) and
//! the co-processor's bring-up of its sensor
//! ([`super::coprocessor::sensor_link`]) both drive this one machine.
//!
//! # The flow
//!
//! 1. [`Client::prepare`] writes a request (to the sensor at
//!    [`Client::address`]) and takes its [`Limits`]; the driver puts
//!    [`Client::request_bytes`] on the line and calls
//!    [`Client::mark_sent`] with the time.
//! 2. Every byte received goes to [`Client::feed`] (one framer, sensor →
//!    host, with handshake bytes). While a request is out:
//!    * `ACK` (`06`) starts the wait for the reply ([`Limits::reply_us`]);
//!    * `NAK` (`15`, a bad checksum on the sensor's side) gives
//!      [`Outcome::Resend`] — send the same bytes again and call
//!      `mark_sent` — until [`Limits::retries`] resends have been made,
//!      then [`Outcome::NakLimit`];
//!    * the telegram whose command is the request's `| 0x80` is
//!      [`Outcome::Reply`] (its bytes in [`Client::telegram`]); one without
//!      an `ACK` before it is taken all the same (some sensors skip it) and
//!      counted in [`ClientStats::missing_acks`];
//!    * `92` ends the request with [`Outcome::UnknownCommand`];
//!    * any other telegram is ignored and counted
//!      ([`ClientStats::ignored`], e.g. `B0` scans still streaming while
//!      `20 25` stops the stream); the `90` power-on telegram is also
//!      reported ([`Outcome::PowerOn`]: the sensor restarted).
//! 3. [`Client::poll`] with the time gives [`Outcome::Timeout`], naming what
//!    was awaited, once the wait is over ([`Client::deadline_us`]). A false
//!    `STX` may hold a real telegram back while the line is quiet: at the
//!    deadline `poll` first gives it up and returns `None` — feed `&[]`
//!    again, then poll again.
//! 4. After `20 24` has been answered, [`Client::await_stream`]: every good
//!    `B0` is [`Outcome::Scan`] (and every `B6`/`B7`/`BF` of a value mode,
//!    [`VALUE_STREAM_CODES`]); one whose data is not a scan is counted
//!    ([`ClientStats::bad_scans`]); the wait (if any) runs from the last
//!    scan.
//!
//! Telegrams whose address byte is not `0x80 | address` are ignored and
//! counted ([`ClientStats::wrong_address`]), as real clients do. Corrupted,
//! truncated or stray bytes never stop the machine: the framer skips and
//! counts them ([`FramerStats`]) and the next good telegram is used.
//!
//! A driver that does not take a reply it got (e.g. a `3B` refused with
//! `BB 00`) may [`keep_waiting`](Client::keep_waiting) for the rest of the
//! wait. [`BaudProbe`] is the rate search of PROTOCOL.md §5 on top (`20 25`
//! at each rate in turn).
//!
//! Nothing here allocates, panics or uses `unsafe`.

use core::fmt;

use crate::telegram::reply::code::{MEASURED, POWER_ON, UNKNOWN_COMMAND};
use crate::telegram::{
    Baud, Direction, EmitError, Event, Framer, FramerStats, Handshake, MeasuredView, Request,
    Telegram, MAX_TELEGRAM_LEN,
};

/// The value modes' stream telegrams (`B6` means, `B7` subrange, `BF`
/// mean subrange): [`Outcome::Scan`]s of the stream too, not checked as
/// `B0`s.
pub const VALUE_STREAM_CODES: [u8; 3] = [0xB6, 0xB7, 0xBF];

/// Bytes held for the request: the longest request (`77` with its
/// 34-byte configuration) is 41 bytes.
pub const REQUEST_CAPACITY: usize = 64;

/// What the client waited for when time ran out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Awaited {
    /// The `ACK` after a request.
    Ack,
    /// The reply with this command code.
    Reply(u8),
    /// The next `B0` of the continuous stream.
    StreamScan,
}

impl fmt::Display for Awaited {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Awaited::Ack => f.write_str("ACK (06)"),
            Awaited::Reply(code) => write!(f, "reply {code:02X}"),
            Awaited::StreamScan => f.write_str("the next streamed scan (B0)"),
        }
    }
}

/// Counters of the handshake (the byte-level ones are in [`FramerStats`]);
/// all wrap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ClientStats {
    /// Request telegrams sent, resends included.
    pub sent: u32,
    /// Requests sent again (after a `NAK`, or by a driver after a
    /// time-out).
    pub resends: u32,
    /// Replies accepted without an `ACK` before them.
    pub missing_acks: u32,
    /// `ACK` bytes that came when none was awaited.
    pub stray_acks: u32,
    /// Telegrams ignored for an address other than `0x80 | address`.
    pub wrong_address: u32,
    /// Telegrams ignored because they were not the awaited reply (e.g.
    /// streamed scans before the reply to `20 25`).
    pub ignored: u32,
    /// `B0` telegrams with a good CRC whose data is not a scan (counted
    /// here for the stream, by the driver for a `30 01` reply).
    pub bad_scans: u32,
    /// Baud changes whose reply never came, found done at the new rate
    /// (counted by the driver of the change).
    pub lost_baud_replies: u32,
}

impl ClientStats {
    /// All counters at zero (`const`).
    pub const ZERO: ClientStats = ClientStats {
        sent: 0,
        resends: 0,
        missing_acks: 0,
        stray_acks: 0,
        wrong_address: 0,
        ignored: 0,
        bad_scans: 0,
        lost_baud_replies: 0,
    };
}

/// How long the client waits for one request, and how often it resends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// From sending the request to its `ACK` (µs).
    pub ack_us: u64,
    /// From the `ACK` to the reply (µs). `None`: the `ACK` gives no more
    /// time — the reply too is due within `ack_us` of sending.
    pub reply_us: Option<u64>,
    /// Resends after a `NAK` before [`Outcome::NakLimit`].
    pub retries: u32,
}

/// What [`Client::feed`] or [`Client::poll`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    /// The awaited reply; its bytes are in [`Client::telegram`].
    Reply,
    /// A scan of the stream; its bytes are in [`Client::telegram`].
    Scan,
    /// `NAK`: send [`Client::request_bytes`] again, then
    /// [`Client::mark_sent`].
    Resend,
    /// `NAK` after the last allowed resend: the request is given up.
    NakLimit {
        /// Times the request was sent.
        attempts: u32,
    },
    /// The sensor answered `92` (unknown or malformed command).
    UnknownCommand,
    /// The `90` power-on telegram (the sensor restarted); the wait goes
    /// on.
    PowerOn,
    /// Nothing (valid) came in time.
    Timeout(Awaited),
}

/// Where the machine is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// No request prepared, or one prepared and not sent yet.
    Idle,
    AwaitAck,
    AwaitReply,
    /// The request is answered, given up or timed out.
    Done,
    Stream,
}

/// Everything but the framer (so a framer event can be judged while it
/// borrows the framer).
struct Exchange {
    /// The sensor's address (0..=0x7F).
    address: u8,
    request: [u8; REQUEST_CAPACITY],
    request_len: usize,
    /// The reply's command code.
    expected: u8,
    limits: Limits,
    phase: Phase,
    /// Times the request was sent.
    attempts: u32,
    /// When the request was last sent (µs).
    sent_us: u64,
    /// When its `ACK` came (µs), if it did.
    acked_us: Option<u64>,
    /// The sensor's last stream telegram while the reply was awaited (µs):
    /// the reply is queued behind it, so the wait runs from it, but from at
    /// most `behind_us` after sending ([`Client::wait_behind_stream`]; 0:
    /// from sending).
    behind_since_us: u64,
    behind_us: u64,
    /// Stream: the allowed gap between scans (µs) and the wait's start.
    stream_wait_us: Option<u64>,
    stream_since_us: u64,
    /// The last outcome was a reply or scan: its bytes are still the
    /// framer's [`Framer::delivered`] (no copy of the scan is kept here).
    kept: bool,
    stats: ClientStats,
}

/// The client machine (see the [module docs](self)).
pub struct Client {
    framer: Framer,
    x: Exchange,
}

impl Client {
    /// A client for the sensor at `address` (0..=0x7F; replies carry
    /// `0x80 | address`), with nothing to send yet.
    pub const fn new(address: u8) -> Self {
        let mut client = Client::zeroed();
        client.framer.set_direction(Direction::SensorToHost);
        client.x.address = address & 0x7F;
        client
    }

    /// [`Client::new`] with every byte zero (its framer's direction not set:
    /// [`Client::set_sensor_side`] before use), for an all-zero `static`.
    pub(crate) const fn zeroed() -> Self {
        Client {
            framer: Framer::new(Direction::HostToSensor, Handshake::Expected),
            x: Exchange {
                address: 0,
                request: [0; REQUEST_CAPACITY],
                request_len: 0,
                expected: 0,
                limits: Limits {
                    ack_us: 0,
                    reply_us: None,
                    retries: 0,
                },
                phase: Phase::Idle,
                attempts: 0,
                sent_us: 0,
                acked_us: None,
                behind_since_us: 0,
                behind_us: 0,
                stream_wait_us: None,
                stream_since_us: 0,
                kept: false,
                stats: ClientStats::ZERO,
            },
        }
    }

    /// Make a [`Client::zeroed`] client what [`Client::new`] makes.
    pub(crate) const fn set_sensor_side(&mut self, address: u8) {
        self.framer.set_direction(Direction::SensorToHost);
        self.x.address = address & 0x7F;
    }

    /// The sensor's address.
    pub fn address(&self) -> u8 {
        self.x.address
    }

    /// Talk to the sensor at `address` (0..=0x7F) from the next request on.
    pub fn set_address(&mut self, address: u8) {
        self.x.address = address & 0x7F;
    }

    /// Handshake counters.
    pub fn stats(&self) -> &ClientStats {
        &self.x.stats
    }

    /// The counters a driver keeps itself ([`ClientStats::bad_scans`] of a
    /// `30 01` reply, [`ClientStats::lost_baud_replies`]).
    pub fn stats_mut(&mut self) -> &mut ClientStats {
        &mut self.x.stats
    }

    /// The framer's counters (CRC errors, resyncs, bytes skipped, …).
    pub fn framer_stats(&self) -> &FramerStats {
        self.framer.stats()
    }

    /// Report `ACK`/`NAK` bytes ([`Handshake::Expected`], the default), or
    /// skip them like noise ([`Handshake::Ignored`]: in the stream, where
    /// the sensor sends none).
    pub fn set_handshake(&mut self, handshake: Handshake) {
        self.framer.set_handshake(handshake);
    }

    /// Drop every byte received and not framed yet (e.g. after a baud-rate
    /// change; counted as skipped).
    pub fn discard(&mut self) {
        self.x.kept = false;
        self.framer.discard();
    }

    /// Give up a telegram half-received (e.g. before resending after a
    /// time-out: a late reply's start would hold the next one back).
    /// `false` if none was being collected.
    pub fn abandon(&mut self) -> bool {
        self.x.kept = false;
        self.framer.abandon()
    }

    /// Write `request` for the sensor and start a new exchange with
    /// `limits`; returns the bytes to send (also [`request_bytes`]). Call
    /// [`mark_sent`] once they are on the line.
    ///
    /// [`request_bytes`]: Client::request_bytes
    /// [`mark_sent`]: Client::mark_sent
    pub fn prepare(&mut self, request: &Request<'_>, limits: Limits) -> Result<&[u8], EmitError> {
        let x = &mut self.x;
        x.request_len = 0;
        x.phase = Phase::Idle;
        x.request_len = request.emit(x.address, &mut x.request)?;
        x.expected = request.reply_command();
        x.limits = limits;
        x.attempts = 0;
        x.behind_us = 0;
        Ok(self.request_bytes())
    }

    /// For the prepared request: each stream telegram (`B0`, `B6`/`B7`/`BF`)
    /// that comes while its reply is awaited was sent before the request
    /// was read (the reply is queued behind it on the line, or in a slow
    /// link's buffers), so the wait starts again from it, up to `cap_us`
    /// after sending. A line carrying the stream at this rate is alive and
    /// at the right rate; a request lost on it is still sent again, at most
    /// `cap_us` later.
    pub fn wait_behind_stream(&mut self, cap_us: u64) {
        self.x.behind_us = cap_us;
    }

    /// The prepared request's bytes (empty before the first
    /// [`prepare`](Client::prepare)).
    pub fn request_bytes(&self) -> &[u8] {
        self.x.request.get(..self.x.request_len).unwrap_or_default()
    }

    /// The request went on the line at `now_us` (first time or again):
    /// counted, and the wait for its `ACK` starts.
    pub fn mark_sent(&mut self, now_us: u64) {
        let x = &mut self.x;
        if x.request_len == 0 {
            return;
        }
        x.attempts = x.attempts.saturating_add(1);
        x.stats.sent = x.stats.sent.wrapping_add(1);
        if x.attempts > 1 {
            x.stats.resends = x.stats.resends.wrapping_add(1);
        }
        x.phase = Phase::AwaitAck;
        x.sent_us = now_us;
        x.behind_since_us = now_us;
        x.acked_us = None;
    }

    /// The stream is on (its `20 24` answered): from `now_us` on, every
    /// `B0` is a scan; `wait_us` is the allowed time from the start (or
    /// the last scan) to the next scan, `None` for no limit.
    pub fn await_stream(&mut self, now_us: u64, wait_us: Option<u64>) {
        self.x.phase = Phase::Stream;
        self.x.stream_since_us = now_us;
        self.x.stream_wait_us = wait_us;
    }

    /// Do not take the reply (or `92`) just reported: wait on until the
    /// request's deadline.
    pub fn keep_waiting(&mut self) {
        if self.x.phase == Phase::Done {
            self.x.phase = match self.x.acked_us {
                Some(_) => Phase::AwaitReply,
                None => Phase::AwaitAck,
            };
        }
    }

    /// The last reply or scan reported, `STX` … `CRC` (until the next
    /// [`feed`](Client::feed), [`poll`](Client::poll),
    /// [`abandon`](Client::abandon) or [`discard`](Client::discard); read in
    /// place in the framer).
    pub fn telegram_bytes(&self) -> &[u8] {
        if self.x.kept {
            self.framer.delivered()
        } else {
            &[]
        }
    }

    /// [`telegram_bytes`](Client::telegram_bytes) as a telegram.
    pub fn telegram(&self) -> Telegram<&[u8]> {
        Telegram::new_unchecked(self.telegram_bytes(), Direction::SensorToHost)
    }

    /// When the current wait ends (µs), if one is running.
    pub fn deadline_us(&self) -> Option<u64> {
        let x = &self.x;
        let behind = x.behind_since_us.min(x.sent_us.saturating_add(x.behind_us));
        let ack_deadline = x.sent_us.max(behind).saturating_add(x.limits.ack_us);
        match x.phase {
            Phase::AwaitAck => Some(ack_deadline),
            Phase::AwaitReply => match (x.limits.reply_us, x.acked_us) {
                (Some(wait), Some(acked)) => Some(acked.saturating_add(wait)),
                _ => Some(ack_deadline),
            },
            Phase::Stream => x
                .stream_wait_us
                .map(|wait| x.stream_since_us.saturating_add(wait)),
            Phase::Idle | Phase::Done => None,
        }
    }

    /// `true` once the current wait is over at `now_us`.
    pub fn expired(&self, now_us: u64) -> bool {
        self.deadline_us().is_some_and(|d| now_us >= d)
    }

    /// The time-out, if the wait is over at `now_us` (see the
    /// [module docs](self) for the `None` after a false `STX`).
    pub fn poll(&mut self, now_us: u64) -> Option<Outcome> {
        if !self.expired(now_us) {
            return None;
        }
        self.x.kept = false;
        if self.framer.abandon() {
            return None;
        }
        let awaited = match self.x.phase {
            Phase::AwaitAck => Awaited::Ack,
            Phase::Stream => Awaited::StreamScan,
            _ => Awaited::Reply(self.x.expected),
        };
        self.x.phase = Phase::Done;
        Some(Outcome::Timeout(awaited))
    }

    /// Take bytes received by `now_us`. Returns the first outcome and the
    /// input not consumed yet: call again with the rest. `None` means all
    /// input was taken without an outcome.
    pub fn feed<'i>(&mut self, input: &'i [u8], now_us: u64) -> (Option<Outcome>, &'i [u8]) {
        let mut input = input;
        self.x.kept = false;
        // Each round consumes input or takes an event; the bound only
        // guards against a framer bug.
        for _ in 0..input.len().saturating_add(MAX_TELEGRAM_LEN) {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            let outcome = match fed.event {
                None => return (None, input),
                Some(Event::Ack) => self.x.on_ack(now_us),
                Some(Event::Nak) => self.x.on_nak(),
                Some(Event::Telegram(t)) => self.x.on_telegram(&t, now_us),
                // Not from a framer that holds every telegram (this one).
                Some(Event::Long { .. }) => None,
            };
            if outcome.is_some() {
                return (outcome, input);
            }
        }
        (None, input)
    }
}

impl Exchange {
    fn on_ack(&mut self, now_us: u64) -> Option<Outcome> {
        if self.phase == Phase::AwaitAck {
            self.phase = Phase::AwaitReply;
            self.acked_us = Some(now_us);
        } else {
            self.stats.stray_acks = self.stats.stray_acks.wrapping_add(1);
        }
        None
    }

    fn on_nak(&mut self) -> Option<Outcome> {
        if !matches!(self.phase, Phase::AwaitAck | Phase::AwaitReply) {
            return None;
        }
        if self.attempts > self.limits.retries {
            self.phase = Phase::Done;
            return Some(Outcome::NakLimit {
                attempts: self.attempts,
            });
        }
        Some(Outcome::Resend)
    }

    fn on_telegram(&mut self, t: &Telegram<&[u8]>, now_us: u64) -> Option<Outcome> {
        if t.address() != Direction::SensorToHost.address_byte(self.address) {
            self.stats.wrong_address = self.stats.wrong_address.wrapping_add(1);
            return None;
        }
        let command = t.command();
        match self.phase {
            Phase::AwaitAck | Phase::AwaitReply if command == self.expected => {
                if self.phase == Phase::AwaitAck {
                    self.stats.missing_acks = self.stats.missing_acks.wrapping_add(1);
                }
                self.keep(t);
                self.phase = Phase::Done;
                Some(Outcome::Reply)
            }
            Phase::AwaitAck | Phase::AwaitReply if command == UNKNOWN_COMMAND => {
                // Kept: a relayed request's `92` goes to its client as sent.
                self.keep(t);
                self.phase = Phase::Done;
                Some(Outcome::UnknownCommand)
            }
            Phase::Stream if command == MEASURED => {
                if MeasuredView::parse(t).is_err() {
                    self.stats.bad_scans = self.stats.bad_scans.wrapping_add(1);
                    return None;
                }
                self.keep(t);
                self.stream_since_us = now_us;
                Some(Outcome::Scan)
            }
            // A value mode's stream (`20 26`/`27`/`28`): passed on as is.
            Phase::Stream if VALUE_STREAM_CODES.contains(&command) => {
                self.keep(t);
                self.stream_since_us = now_us;
                Some(Outcome::Scan)
            }
            _ => {
                self.stats.ignored = self.stats.ignored.wrapping_add(1);
                let stream = command == MEASURED || VALUE_STREAM_CODES.contains(&command);
                if stream && matches!(self.phase, Phase::AwaitAck | Phase::AwaitReply) {
                    self.behind_since_us = now_us;
                }
                (command == POWER_ON).then_some(Outcome::PowerOn)
            }
        }
    }

    /// The telegram (still in the framer) is the outcome's.
    fn keep(&mut self, _t: &Telegram<&[u8]>) {
        self.kept = true;
    }
}

/// The search for the sensor's rate (PROTOCOL.md §5): at each rate in
/// turn, switch the line, send `20 25` ([`BaudProbe::REQUEST`], which also
/// stops a stream left running) with at most [`BaudProbe::RETRIES`]
/// resends (a wrong rate can look like `NAK`s), and take the first rate
/// answered `A0 00`. Sensors power up at 9600 Bd, so put it first.
#[derive(Clone, Copy, Debug)]
pub struct BaudProbe<'r> {
    rates: &'r [Baud],
    next: usize,
}

impl<'r> BaudProbe<'r> {
    /// The probe request.
    pub const REQUEST: Request<'static> = Request::OnRequest;
    /// Resends after a `NAK` at one rate.
    pub const RETRIES: u32 = 1;

    /// A search over `rates`, in order.
    pub const fn new(rates: &'r [Baud]) -> Self {
        BaudProbe { rates, next: 0 }
    }

    /// The rates to try, as given.
    pub fn rates(&self) -> &'r [Baud] {
        self.rates
    }

    /// A search over `rates` that has already handed out `tried` of them
    /// (a driver that keeps only the count, e.g. to stay all-zero in a
    /// `static`, rebuilds its probe with this).
    pub const fn resume(rates: &'r [Baud], tried: usize) -> Self {
        BaudProbe { rates, next: tried }
    }

    /// Rates handed out so far by [`next_rate`](BaudProbe::next_rate).
    pub fn tried(&self) -> usize {
        self.next
    }

    /// The next rate to try (`None`: every rate went unanswered). A probe
    /// that ends in [`Outcome::Timeout`] or [`Outcome::NakLimit`] means
    /// "not this rate": take the next.
    pub fn next_rate(&mut self) -> Option<Baud> {
        let rate = self.rates.get(self.next).copied();
        self.next = self.next.saturating_add(1);
        rate
    }
}

#[cfg(test)]
mod tests;
