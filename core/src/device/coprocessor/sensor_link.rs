//! The co-processor's sensor side: bring the LMS 2xx up and take its `B0`
//! stream (sans I/O: bytes and time in, bytes and events out).
//!
//! Bring-up, one request at a time through the client machine
//! ([`crate::device::client`]), each resent after [`REPLY_TIMEOUT_US`]
//! without its reply (the first bytes may be lost while the line settles)
//! and at once after a `NAK`, without limit:
//!
//! 1. `20 25` — values on request only (stops a stream left running), as a
//!    baud search ([`BaudProbe`]): at each rate of [`search_order`] in turn
//!    (9600 first, then the wanted rate: the LMS keeps it across a reset of
//!    the co-processor), [`probe_wait_us`] each, round and round until one
//!    answers `A0 00`; the UART is switched before each
//!    ([`LinkEvent::SwitchBaud`] from [`SensorLink::poll`]);
//! 2. `3B` — the variant (default 180°/0.5°);
//! 3. `20 00 SICK_LMS` — installation mode;
//! 4. `74` — read the configuration;
//! 5. `77` — write it back with the wanted units (default mm);
//! 6. `20 4x` — the wanted baud rate; after the reply both sides switch
//!    ([`LinkEvent::SwitchBaud`]);
//! 7. `20 24` — continuous output; from then on every `B0` is a scan.
//!
//! A refused step (a reply that is not what was asked, or `92`) is sent
//! again when its time is up.
//!
//! A reply to a request sent while the sensor streams (`20 25` at the
//! stream's rate, a [`forward`](SensorLink::forward)ed request) comes behind
//! the scans already on the line or in a slow link's buffers (the firmware
//! under QEMU takes ≈ 10 KB/s of a 500 kBd stream): each `B0` that comes
//! first starts the wait again, for up to [`STREAM_SILENCE_US`] after
//! sending ([`Client::wait_behind_stream`]). Without it the search left the
//! right rate, and relayed requests went unanswered, whenever more than
//! 300 ms of scans were queued ahead of the reply.
//!
//! # Recovery
//!
//! * A scan time-out: no good `B0` for [`stream_wait_us`] (353 ms at
//!   180°/0.5° and 500 kBd) while bytes that frame nothing come (e.g. the
//!   LMS was switched off and on and its `90` came at 9600 Bd while the
//!   UART listens at 500 k: noise), or for [`STREAM_SILENCE_US`] (2 s) of
//!   any kind (a dead line, or a sensor that stopped by itself): counted in
//!   [`SensorLink::scan_timeouts`], and the bring-up starts again with the
//!   baud search at 9600 Bd. A line merely silent for a while (a cable
//!   pulled, or a test bench holding its sensor) is given the longer time:
//!   nothing has changed at the sensor's end that a restart would mend
//!   sooner.
//! * The `90` power-on telegram (the sensor restarted, seen when the UART is
//!   at its rate): the bring-up starts again at once.
//! * The co-processor itself restarts (reset, power): the search finds the
//!   LMS at the rate it kept.
//!
//! Every restart ([`SensorLink::restart`]) switches the UART back to
//! 9600 Bd (reported by the next [`SensorLink::poll`]) and is counted in
//! [`SensorLink::restarts`].

use crate::device::client::{BaudProbe, Client, Limits, Outcome};
use crate::device::emulator::{line_time_us, scan_period_us};
use crate::telegram::{
    Baud, Config, FramerStats, ModeResult, Reply, Request, DEFAULT_ADDRESS, DEFAULT_PASSWORD,
    MAX_TELEGRAM_LEN,
};
use crate::Unit;
use crate::Variant;

/// How long to wait for a reply before sending the request again (µs).
pub const REPLY_TIMEOUT_US: u64 = 300_000;

/// The waits of every bring-up request: the reply is due within
/// [`REPLY_TIMEOUT_US`] of sending, `ACK` or not; `NAK`s are answered by
/// resending, however many.
const LIMITS: Limits = Limits {
    ack_us: REPLY_TIMEOUT_US,
    reply_us: None,
    retries: u32::MAX,
};

/// The search's time for a rate beyond the line time of the probe and its
/// reply (µs): the LMS answers a request within a few ms.
pub const PROBE_GRACE_US: u64 = 150_000;

/// The stream's allowance beyond two scan times (µs): a scan late by more
/// than this means the sensor is gone (or restarted).
pub const STREAM_GRACE_US: u64 = 300_000;

/// Bytes of the probe exchange on the line: `20 25` (8), `ACK`, `A0 00` (10).
const PROBE_BYTES: usize = 19;

/// The rates the baud search tries, in order, for a link that wants
/// `wanted`: 9600 Bd first (the power-on rate), then `wanted` (kept by the
/// LMS across a reset of the co-processor), then the others.
pub const fn search_order(wanted: Baud) -> &'static [Baud] {
    match wanted {
        Baud::B9600 | Baud::B500000 => &[Baud::B9600, Baud::B500000, Baud::B38400, Baud::B19200],
        Baud::B19200 => &[Baud::B9600, Baud::B19200, Baud::B500000, Baud::B38400],
        Baud::B38400 => &[Baud::B9600, Baud::B38400, Baud::B500000, Baud::B19200],
    }
}

/// How long the search waits for `A0 00` at `rate` (µs): the probe and its
/// reply on the line plus [`PROBE_GRACE_US`], plus a whole `B0` where a
/// stream may still run (at `wanted`: the reply waits for the `B0` on the
/// line). 9600 Bd: 170 ms; 500 kBd: 167 ms.
pub const fn probe_wait_us(rate: Baud, wanted: Baud) -> u64 {
    let stream = if rate as u8 == wanted as u8 {
        line_time_us(MAX_TELEGRAM_LEN, rate)
    } else {
        0
    };
    PROBE_GRACE_US + line_time_us(PROBE_BYTES, rate) + stream
}

/// The longest gap between two good scans of the stream, with noise on the
/// line, before the link starts again (µs): two scan times (the mirror's period or a `B0`'s line time,
/// whichever is longer) plus [`STREAM_GRACE_US`]. 180°/0.5° at 500 kBd:
/// 353 ms; at 9600 Bd: 2.0 s.
pub const fn stream_wait_us(setup: &SensorSetup) -> u64 {
    let mirror = scan_period_us(setup.variant);
    let line = line_time_us(crate::telegram::MAX_TELEGRAM_LEN, setup.baud);
    let scan = if mirror > line { mirror } else { line };
    STREAM_GRACE_US + 2 * scan
}

/// The longest silence in the stream (no good scan and no noise) before the
/// link starts again (µs; at least [`stream_wait_us`]).
pub const STREAM_SILENCE_US: u64 = 2_000_000;

/// What the link wants from the sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorSetup {
    /// Scan variant (default 180°/0.5°).
    pub variant: Variant,
    /// Range units (default mm).
    pub units: Unit,
    /// Serial speed to switch to (default 500000 Bd).
    pub baud: Baud,
}

impl Default for SensorSetup {
    fn default() -> Self {
        SensorSetup::DEFAULT
    }
}

impl SensorSetup {
    /// 180°/0.5°, mm, 500000 Bd (`const`).
    pub const DEFAULT: SensorSetup = SensorSetup {
        variant: Variant::Fov180Res50,
        units: Unit::Millimetre,
        baud: Baud::B500000,
    };
}

/// Steps of the bring-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Step {
    /// `20 25`.
    StopStream,
    /// `3B`.
    SetVariant,
    /// `20 00 SICK_LMS`.
    InstallationMode,
    /// `74`.
    ReadConfig,
    /// `77`.
    WriteConfig,
    /// `20 4x`.
    SetBaud,
    /// `20 24`.
    StartStream,
    /// Bring-up done: `B0` telegrams are scans.
    Streaming,
}

/// What the link reports after taking bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkEvent {
    /// A complete, checked `B0` telegram; its bytes (STX … CRC) are in
    /// [`SensorLink::scan_bytes`] until the next scan.
    Scan,
    /// Switch the UART to this rate now: the sensor has acknowledged the
    /// new rate, or the baud search tries the next one, or a restart
    /// returns to 9600 Bd.
    SwitchBaud(Baud),
    /// The sensor refused a step (e.g. the variant); the link retries it.
    Refused(Step),
    /// A [`forward`](SensorLink::forward)ed request is done: answered (its
    /// reply's bytes, the expected code or the sensor's `92`, in
    /// [`SensorLink::scan_bytes`] until the next feed) or not (no reply
    /// within [`REPLY_TIMEOUT_US`] twice).
    Forwarded {
        /// The sensor's reply came.
        answered: bool,
    },
}

/// Data bytes of the longest request [`SensorLink::forward`] takes
/// (`20 28 n a a b b`: 6).
pub const FORWARD_DATA_CAPACITY: usize = 8;

/// Where a forwarded request is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Forward {
    /// None (first: a zeroed link has none).
    Idle,
    /// Waiting to be sent (the link is not streaming yet).
    Due,
    /// Sent; its reply awaited.
    Sent,
}

/// The sensor side of the co-processor.
pub struct SensorLink {
    setup: SensorSetup,
    client: Client,
    step: Step,
    /// The current step's request has been sent.
    requested: bool,
    /// A `NAK` came: send the request again at the next poll.
    nak: bool,
    config: Option<Config>,
    /// The rate the UART is (to be) at.
    line: Baud,
    /// `line` changed and the board has not been told yet.
    switch_due: bool,
    /// The index in [`search_order`] of the rate the search tries now.
    probe_index: u8,
    restarts: u32,
    scan_timeouts: u32,
    /// Stream bytes (received and lost before reaching the link) since the
    /// last good scan, less the whole scans already accounted for.
    stream_bytes: i32,
    /// Length of the last good scan's telegram (bytes; 0 before the first).
    scan_len: u16,
    /// Scans lost in the stream, not yet taken by [`SensorLink::take_missed`].
    missed: u32,
    /// When the last good scan (or the stream's start) came (µs), and the
    /// framer's skipped bytes then.
    scan_us: u64,
    skipped_at_scan: u32,
    /// [`SensorLink::reconfigure`] came during the bring-up
    /// (`has_pending`): bring the sensor up again with `pending` once it
    /// streams. Not an `Option`, so that a zeroed link stays all zero.
    pending: SensorSetup,
    has_pending: bool,
    /// A request forwarded for the co-processor's client (`20 26`…, `3A`).
    forward: Forward,
    forward_command: u8,
    forward_data: [u8; FORWARD_DATA_CAPACITY],
    forward_len: u8,
    /// Scans averaged per stream telegram (a mean value mode; 0 or 1: one).
    samples: u8,
    /// The configuration to write in the bring-up's `77` (a client's, all
    /// of it: [`SensorLink::write_config`]); else the one read, with the
    /// units.
    client_config: Config,
    has_client_config: bool,
}

impl SensorLink {
    /// A link that will bring the sensor up with `setup`; the UART starts
    /// at 9600 Bd.
    pub const fn new(setup: SensorSetup) -> Self {
        let mut link = SensorLink::zeroed();
        link.configure(setup);
        link
    }

    /// A link with every byte zero, for an all-zero `static`: give it its
    /// set-up with [`SensorLink::configure`] before use.
    pub(crate) const fn zeroed() -> Self {
        SensorLink {
            // All variants first in their enums: 180°/1°, cm, 9600 Bd.
            setup: SensorSetup {
                variant: Variant::Fov180Res100,
                units: Unit::Centimetre,
                baud: Baud::B9600,
            },
            client: Client::zeroed(),
            step: Step::StopStream,
            requested: false,
            nak: false,
            config: None,
            line: Baud::B9600,
            switch_due: false,
            probe_index: 0,
            restarts: 0,
            scan_timeouts: 0,
            stream_bytes: 0,
            scan_len: 0,
            missed: 0,
            scan_us: 0,
            skipped_at_scan: 0,
            pending: SensorSetup {
                variant: Variant::Fov180Res100,
                units: Unit::Centimetre,
                baud: Baud::B9600,
            },
            has_pending: false,
            forward: Forward::Idle,
            forward_command: 0,
            forward_data: [0; FORWARD_DATA_CAPACITY],
            forward_len: 0,
            samples: 0,
            client_config: Config::ZERO,
            has_client_config: false,
        }
    }

    /// Bring the sensor up with `setup` (before the first poll).
    pub(crate) const fn configure(&mut self, setup: SensorSetup) {
        self.setup = setup;
        self.client.set_sensor_side(DEFAULT_ADDRESS);
    }

    /// The bytes of the last `B0` telegram reported by [`LinkEvent::Scan`]
    /// (until the next [`feed`](SensorLink::feed)).
    pub fn scan_bytes(&self) -> &[u8] {
        self.client.telegram_bytes()
    }

    /// The sensor's configuration as read in the bring-up (`74`), with the
    /// units written back (`77`); `None` before.
    pub fn config(&self) -> Option<Config> {
        let code = match self.setup.units {
            Unit::Millimetre => 1,
            _ => 0,
        };
        let written = |c: Config| match self.has_client_config {
            true => self.client_config,
            false => c,
        };
        self.config.map(|c| written(c).with_units_code(code))
    }

    /// The current bring-up step.
    pub fn step(&self) -> Step {
        self.step
    }

    /// Requests resent (after a time-out or a `NAK`).
    pub fn retries(&self) -> u32 {
        self.client.stats().resends
    }

    /// The framer's counters (CRC errors, resyncs, bytes skipped).
    pub fn framer_stats(&self) -> &FramerStats {
        self.client.framer_stats()
    }

    /// Bring-up restarts (scan time-outs and `90` telegrams).
    pub fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Scan time-outs ([`stream_wait_us`] with noise, or
    /// [`STREAM_SILENCE_US`]).
    pub fn scan_timeouts(&self) -> u32 {
        self.scan_timeouts
    }

    /// The rate the UART should be at now.
    pub fn line_baud(&self) -> Baud {
        self.line
    }

    /// `bytes` of the sensor's stream were lost before they reached
    /// [`feed`](SensorLink::feed) (the board's receive queue overflowed):
    /// they count towards the scans lost (see [`take_missed`]).
    ///
    /// [`take_missed`]: SensorLink::take_missed
    pub fn note_lost(&mut self, bytes: u32) {
        if self.step == Step::Streaming {
            let bytes = i32::try_from(bytes).unwrap_or(i32::MAX);
            self.stream_bytes = self.stream_bytes.saturating_add(bytes);
        }
    }

    /// Scans of the stream lost since the last call: the stream's bytes
    /// between two good scans (received and [lost](SensorLink::note_lost))
    /// held this many more whole scans than arrived intact (damaged on the
    /// line, cut by a queue overflow, or missing). Only `B0`s are on the
    /// line while it streams, so the count is exact up to rounding, and
    /// the rounding is carried over.
    pub fn take_missed(&mut self) -> u32 {
        core::mem::take(&mut self.missed)
    }

    /// A good scan of `len` bytes ended the stream bytes counted so far:
    /// the whole scans among them, less this one, were lost.
    fn account_scan(&mut self, len: usize) {
        let len = u16::try_from(len).unwrap_or(u16::MAX);
        self.scan_len = len;
        let whole = self.whole_scans().max(1);
        self.missed = self.missed.wrapping_add(whole.unsigned_abs() - 1);
        self.stream_bytes = self
            .stream_bytes
            .saturating_sub(whole.saturating_mul(i32::from(len)));
    }

    /// Whole scans in the stream bytes counted (rounded to nearest).
    fn whole_scans(&self) -> i32 {
        let len = i32::from(self.scan_len);
        if len == 0 {
            return 0;
        }
        self.stream_bytes.saturating_add(len / 2).max(0) / len
    }

    /// The setup the link brings the sensor up with (the one to come, if
    /// a [`reconfigure`](SensorLink::reconfigure) waits for the bring-up).
    pub fn setup(&self) -> SensorSetup {
        if self.has_pending {
            self.pending
        } else {
            self.setup
        }
    }

    /// Bring the sensor up again with `setup` (the co-processor's client
    /// chose another variant or unit): at once if it streams, else when the
    /// bring-up in progress is done (a reply in flight, e.g. to the baud
    /// switch, must not be taken for another step's).
    pub fn reconfigure(&mut self, setup: SensorSetup) {
        if self.step == Step::Streaming {
            // The sensor answers at the rate it streams at: no baud search.
            let line = self.line;
            self.setup = setup;
            self.restart();
            self.line = line;
            self.switch_due = false;
        } else {
            self.pending = setup;
            self.has_pending = true;
        }
    }

    /// A client's configuration (`77`, every byte): written to the sensor
    /// from the next bring-up on (its units byte is the setup's); returns
    /// `true` if it differs from the sensor's, i.e. a
    /// [`reconfigure`](SensorLink::reconfigure) is needed.
    pub fn write_config(&mut self, config: Config) -> bool {
        let before = self.config();
        self.client_config = config;
        self.has_client_config = true;
        before != Some(self.wanted_config(config))
    }

    /// `config` with the setup's units.
    fn wanted_config(&self, config: Config) -> Config {
        let units = match self.setup().units {
            Unit::Millimetre => 1,
            _ => 0,
        };
        config.with_units_code(units)
    }

    /// Send `command data` to the sensor once it streams (between its
    /// scans) and report its reply ([`LinkEvent::Forwarded`]); the stream
    /// goes on after it. `false` (nothing done) if a forward is under way
    /// or `data` is longer than [`FORWARD_DATA_CAPACITY`].
    pub fn forward(&mut self, command: u8, data: &[u8]) -> bool {
        let Some(slot) = self.forward_data.get_mut(..data.len()) else {
            return false;
        };
        if self.forward != Forward::Idle {
            return false;
        }
        slot.copy_from_slice(data);
        self.forward_command = command;
        self.forward_len = data.len() as u8;
        self.forward = Forward::Due;
        true
    }

    /// Withdraw a [`forward`](SensorLink::forward)ed request not yet sent:
    /// `true` if there is none now (withdrawn, or none was under way);
    /// `false` if it is on the line (its reply or time-out ends it).
    pub fn cancel_forward(&mut self) -> bool {
        if self.forward == Forward::Due {
            self.forward = Forward::Idle;
        }
        self.forward == Forward::Idle
    }

    /// `true` while a forwarded request is on the line (its reply awaited).
    pub fn forward_sent(&self) -> bool {
        self.forward == Forward::Sent
    }

    /// `true` while a [`forward`](SensorLink::forward)ed request waits or
    /// is out.
    pub fn forwarding(&self) -> bool {
        self.forward != Forward::Idle
    }

    /// The stream's telegrams average `samples` scans (a mean value mode;
    /// 1: single scans): the stream's time-outs grow with it.
    pub fn set_stream_samples(&mut self, samples: u8) {
        self.samples = samples;
    }

    /// The longest gap between good stream telegrams with noise (µs):
    /// [`stream_wait_us`], plus two periods per extra scan averaged.
    fn stream_wait(&self) -> u64 {
        let extra = u64::from(self.samples.saturating_sub(1));
        let period = scan_period_us(self.setup.variant);
        stream_wait_us(&self.setup).saturating_add(2 * extra * period)
    }

    /// Back to the stream after a forwarded request at `now_us`.
    fn resume_stream(&mut self, now_us: u64) {
        self.forward = Forward::Idle;
        let wait = self.stream_wait().max(STREAM_SILENCE_US);
        self.client.await_stream(now_us, Some(wait));
    }

    /// Start the bring-up again (e.g. after the sensor reset): the baud
    /// search from 9600 Bd, the UART back to 9600 Bd (reported by the next
    /// [`poll`](SensorLink::poll)).
    pub fn restart(&mut self) {
        if core::mem::take(&mut self.has_pending) {
            self.setup = self.pending;
        }
        self.step = Step::StopStream;
        self.requested = false;
        self.nak = false;
        self.config = None;
        self.probe_index = 0;
        self.samples = 0;
        if self.forward == Forward::Sent {
            self.forward = Forward::Idle;
        }
        self.restarts = self.restarts.wrapping_add(1);
        self.switch_to(Baud::B9600);
    }

    /// Switch the UART to `rate` (told by the next poll); bytes half-framed
    /// at the old rate are dropped.
    fn switch_to(&mut self, rate: Baud) {
        self.line = rate;
        self.switch_due = true;
        self.client.discard();
    }

    /// The time-outs at `now_us`: the next rate of the baud search, or a
    /// silent stream (restart). Returns the rate to switch the UART to, if
    /// any; call it every poll, before [`due_request`](SensorLink::due_request)
    /// (which sends nothing in a poll that switches: the board switches
    /// after the poll).
    pub fn poll(&mut self, now_us: u64) -> Option<LinkEvent> {
        if !self.switch_due {
            match self.step {
                Step::Streaming if self.forward == Forward::Sent && self.client.expired(now_us) => {
                    self.resume_stream(now_us);
                    return Some(LinkEvent::Forwarded { answered: false });
                }
                // The stream's time-outs wait for the forward's reply.
                Step::Streaming if self.forward == Forward::Sent => {}
                Step::Streaming if self.stream_timed_out(now_us) => {
                    self.scan_timeouts = self.scan_timeouts.wrapping_add(1);
                    let lost = self.whole_scans().unsigned_abs();
                    self.missed = self.missed.wrapping_add(lost);
                    self.restart();
                }
                Step::StopStream if self.requested && self.client.expired(now_us) => {
                    self.next_probe_rate();
                }
                _ => {}
            }
        }
        if !self.switch_due {
            return None;
        }
        self.switch_due = false;
        Some(LinkEvent::SwitchBaud(self.line))
    }

    /// No good scan for [`stream_wait_us`] with noise since, or for
    /// [`STREAM_SILENCE_US`] (the client's stream deadline).
    fn stream_timed_out(&self, now_us: u64) -> bool {
        let noise = self.client.framer_stats().bytes_skipped != self.skipped_at_scan;
        let late = now_us >= self.scan_us.saturating_add(self.stream_wait());
        (noise && late) || self.client.expired(now_us)
    }

    /// Note a good scan (or the stream's start) at `now_us`.
    fn mark_scan(&mut self, now_us: u64) {
        self.scan_us = now_us;
        self.skipped_at_scan = self.client.framer_stats().bytes_skipped;
    }

    /// The probe at this rate went unanswered: the next rate of
    /// [`search_order`] (round and round).
    fn next_probe_rate(&mut self) {
        let order = search_order(self.setup.baud);
        let mut probe = BaudProbe::resume(order, usize::from(self.probe_index) + 1);
        let rate = match probe.next_rate() {
            Some(rate) => rate,
            None => {
                probe = BaudProbe::new(order);
                probe.next_rate().unwrap_or(Baud::B9600)
            }
        };
        self.probe_index = u8::try_from(probe.tried().saturating_sub(1)).unwrap_or(0);
        self.requested = false;
        self.nak = false;
        self.switch_to(rate);
    }

    /// The request to send now, if one is due (not sent yet, timed out, or
    /// refused with `NAK`), written into `buf`; returns its length. Call it
    /// every poll, after [`poll`](SensorLink::poll).
    pub fn due_request(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        if !self.may_request() {
            return None;
        }
        if self.step == Step::Streaming {
            return self.send_forward(now_us, buf);
        }
        if self.requested {
            let searching = self.step == Step::StopStream;
            if !(self.nak || (!searching && self.client.expired(now_us))) {
                return None;
            }
            // A late reply may sit half-received in the framer: start clean.
            self.client.abandon();
        } else {
            let request = self.request()?;
            self.client.prepare(&request, self.limits()).ok()?;
            // `20 25` to a streaming sensor: its `B0`s ahead of the reply
            // prove the rate; the reply waits behind them.
            if self.step == Step::StopStream {
                self.client.wait_behind_stream(STREAM_SILENCE_US);
            }
        }
        let bytes = self.client.request_bytes();
        let n = bytes.len();
        crate::telegram::copy_into(buf.get_mut(..n)?, bytes);
        self.requested = true;
        self.nak = false;
        self.client.mark_sent(now_us);
        Some(n)
    }

    /// Whether [`SensorLink::due_request`] may have a request: while the
    /// stream runs only a forwarded one, and none while a rate switch is
    /// due.
    pub fn may_request(&self) -> bool {
        if self.switch_due {
            return false;
        }
        self.step != Step::Streaming || self.forward == Forward::Due
    }

    /// The forwarded request into `buf`, sent at `now_us`.
    fn send_forward(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        let data = self.forward_data.get(..usize::from(self.forward_len))?;
        let request = Request::Unknown {
            command: self.forward_command,
            data,
        };
        let limits = Limits {
            ack_us: REPLY_TIMEOUT_US,
            reply_us: None,
            retries: 1,
        };
        self.client.prepare(&request, limits).ok()?;
        self.client.wait_behind_stream(STREAM_SILENCE_US);
        let bytes = self.client.request_bytes();
        let n = bytes.len();
        crate::telegram::copy_into(buf.get_mut(..n)?, bytes);
        self.client.mark_sent(now_us);
        self.forward = Forward::Sent;
        Some(n)
    }

    /// The waits of the current step: the probe's at the search's rate, or
    /// [`LIMITS`].
    fn limits(&self) -> Limits {
        if self.step != Step::StopStream {
            return LIMITS;
        }
        Limits {
            ack_us: probe_wait_us(self.line, self.setup.baud),
            reply_us: None,
            retries: BaudProbe::RETRIES,
        }
    }

    /// The request of the current step.
    fn request(&self) -> Option<Request<'static>> {
        Some(match self.step {
            Step::StopStream => Request::OnRequest,
            Step::SetVariant => Request::set_variant(self.setup.variant),
            Step::InstallationMode => Request::InstallationMode {
                password: DEFAULT_PASSWORD,
            },
            Step::ReadConfig => Request::ReadConfig,
            Step::WriteConfig => {
                let read = self.config?;
                let base = if self.has_client_config {
                    self.client_config
                } else {
                    read
                };
                Request::WriteConfig(self.wanted_config(base))
            }
            Step::SetBaud => Request::SetBaud(self.setup.baud),
            Step::StartStream => Request::Continuous,
            Step::Streaming => return None,
        })
    }

    /// Take bytes from the sensor received by `now_us`. Returns the first
    /// event found and the bytes not yet consumed; call again with the rest
    /// until it returns `None` with nothing left.
    pub fn feed<'i>(&mut self, input: &'i [u8], now_us: u64) -> (Option<LinkEvent>, &'i [u8]) {
        let (outcome, rest) = self.client.feed(input, now_us);
        if self.step == Step::Streaming {
            let fed = i32::try_from(input.len().saturating_sub(rest.len())).unwrap_or(i32::MAX);
            self.stream_bytes = self.stream_bytes.saturating_add(fed);
        }
        let event = match outcome {
            Some(Outcome::Scan) => {
                self.account_scan(self.client.telegram_bytes().len());
                self.mark_scan(now_us);
                Some(LinkEvent::Scan)
            }
            Some(Outcome::Reply) if self.forward == Forward::Sent => {
                self.resume_stream(now_us);
                Some(LinkEvent::Forwarded { answered: true })
            }
            // The sensor does not know it: its `92` is the answer.
            Some(Outcome::UnknownCommand) if self.forward == Forward::Sent => {
                self.resume_stream(now_us);
                Some(LinkEvent::Forwarded { answered: true })
            }
            Some(Outcome::Reply) => self.on_reply(now_us),
            // Our request was damaged: resend at once.
            Some(Outcome::Resend) => {
                self.nak = true;
                None
            }
            // Sent again when its time is up.
            Some(Outcome::UnknownCommand) => {
                self.client.keep_waiting();
                None
            }
            // The sensor restarted: bring it up again (while searching at
            // 9600 Bd, the LMS has just come up: probe again at once).
            Some(Outcome::PowerOn) => {
                if self.step == Step::StopStream && self.line == Baud::B9600 {
                    self.nak = self.requested;
                } else {
                    self.restart();
                }
                None
            }
            // A wrong rate can look like NAKs: the search moves on.
            Some(Outcome::NakLimit { .. }) if self.step == Step::StopStream => {
                self.next_probe_rate();
                None
            }
            Some(Outcome::NakLimit { .. } | Outcome::Timeout(_)) | None => None,
        };
        (event, rest)
    }

    /// The current step's reply: go on to the next step, or wait on (and
    /// resend when the time is up).
    fn on_reply(&mut self, now_us: u64) -> Option<LinkEvent> {
        let step = self.step;
        let (advance, event) = match Reply::parse(&self.client.telegram()) {
            Ok(Reply::ModeChanged(r)) => match step {
                Step::StopStream | Step::StartStream => (r == ModeResult::Ok, None),
                Step::InstallationMode => (r == ModeResult::Ok, None),
                Step::SetBaud if r == ModeResult::Ok => {
                    self.line = self.setup.baud;
                    (true, Some(LinkEvent::SwitchBaud(self.setup.baud)))
                }
                _ => (false, None),
            },
            Ok(Reply::Variant(v)) if step == Step::SetVariant => {
                let ok = v.accepted && v.variant() == Some(self.setup.variant);
                (ok, (!ok).then_some(LinkEvent::Refused(step)))
            }
            Ok(Reply::Config(c)) if step == Step::ReadConfig => {
                self.config = Some(c);
                (true, None)
            }
            Ok(Reply::ConfigWritten { accepted, .. }) if step == Step::WriteConfig => {
                (accepted, (!accepted).then_some(LinkEvent::Refused(step)))
            }
            _ => (false, None),
        };
        if !advance {
            self.client.keep_waiting();
            return event;
        }
        self.step = match step {
            Step::StopStream => Step::SetVariant,
            Step::SetVariant => Step::InstallationMode,
            Step::InstallationMode => Step::ReadConfig,
            Step::ReadConfig => Step::WriteConfig,
            Step::WriteConfig => Step::SetBaud,
            Step::SetBaud => Step::StartStream,
            Step::StartStream | Step::Streaming => Step::Streaming,
        };
        if self.step == Step::Streaming {
            let noisy = stream_wait_us(&self.setup);
            let silent = if noisy > STREAM_SILENCE_US {
                noisy
            } else {
                STREAM_SILENCE_US
            };
            self.client.await_stream(now_us, Some(silent));
            self.stream_bytes = 0;
            self.mark_scan(now_us);
        }
        self.requested = false;
        self.nak = false;
        if self.step == Step::Streaming && self.has_pending {
            self.restart();
        }
        event
    }
}

/// The longest telegram the link sends (`77` + 34 bytes).
pub const MAX_REQUEST_LEN: usize = MAX_TELEGRAM_LEN;
