//! A simulated SICK LMS 2xx: a sans-I/O model of the sensor's side of the
//! serial line (PROTOCOL.md §1–§5). Bytes from the host and the time go in;
//! the bytes the sensor sends, paced at its line rate, and [`Event`]s come
//! out. No clock, no port, no allocation: the host tool (`host-bridge
//! simulate`, over a pseudo-terminal) and the co-processor firmware (towards
//! its own client) drive the same code.
//!
//! # Behaviour
//!
//! | situation | the emulator |
//! |---|---|
//! | power-on ([`Emulator::new`], [`Emulator::power_on`]) | 9600 Bd, mode `25` (values on request), the power-on variant of [`Settings`]; sends the `90` telegram ([`POWER_ON_DATA`]) |
//! | a host telegram with a correct CRC for its address | `ACK` (0x06), then the reply telegram (one frame, back to back) |
//! | a telegram for another address | ignored (nothing sent; [`Event::IgnoredAddress`]) |
//! | a bad checksum | `NAK` (0x15) ([`Event::BadChecksum`]) |
//! | an unknown or malformed command | `ACK`, `92` |
//! | `20 00 'SICK_LMS'` | `A0 00`, installation mode (`B1` mode byte `00`); another password: `A0 01`, mode kept |
//! | `20 24` | `A0 00`; the `B0` stream starts when the reply has been sent |
//! | `20 25` | the stream stops at once (a `B0` already on the line is finished), then `A0 00` |
//! | `20 40`/`41`/`42`/`48` | `A0 00` at the old rate; when its last byte is out, the line switches ([`Event::BaudSwitched`]) |
//! | `30 01` | `ACK`, one `B0` |
//! | `31` | `B1`: operating mode, scan angle, resolution, baud word, address and units as they are now ([`Emulator::status_fields`]) |
//! | `3A` | `BA "LMS200;30106x;V02.10"` |
//! | `3B` | `BB 01` and the new variant, if it is one of the five and the [`ScanSource`] supports it; else `BB 00` and the variant kept (so 0.25° only with 100°) |
//! | `74` | `F4` + the 34-byte configuration |
//! | `77` | in installation mode: `F7 01` + the new configuration (units byte `[6]`: 0 cm, 1 mm; other codes are refused with `F7 00`); otherwise `F7 00` + the configuration kept |
//! | `10` | `ACK`, `91`; input ignored and the stream stopped; [`Settings::restart_us`] after the `91`, back to 9600 Bd, mode `25`, the power-on variant, and the `90` telegram. The configuration survives, as the real sensor keeps it in EEPROM. |
//!
//! Every reply ends with the status byte [`Settings::status`] (`0x10`).
//!
//! # Timing (PROTOCOL.md §3)
//!
//! The line is modelled byte by byte: a byte takes 10 bit times (8N1) at the
//! current rate, [`line_time_us`], and [`Emulator::transmit`] hands out only
//! the bytes whose stop bit has passed by `now_us`. Frames follow one another
//! on the line; a reply waits for a `B0` that is already being sent.
//!
//! In continuous mode the mirror completes a scan every
//! [`scan_period_us`]: 13.3 ms at 1°, 26.7 ms at 0.5° (two interlaced turns
//! of 1/75 s), 53.3 ms at 0.25° (four turns). Whenever the line is free the
//! newest complete scan is sent; scans completed while the line was busy are
//! skipped (counted in [`EmulatorStats::scans_skipped`]). So the stream is
//! paced by the mirror at 500000 Bd (a 732-byte `B0` takes 14.6 ms) and by
//! the line below it (190 ms per `B0` at 38400 Bd).
//!
//! # Scans
//!
//! The values come from a caller-supplied [`ScanSource`]: raw value words
//! (range in the low 13 bits, flags above, PROTOCOL.md §3) for the current
//! variant and units. [`FnSource`] turns a closure into one.
//!
//! # Driving it
//!
//! ```
//! use lms_core::device::emulator::{Emulator, Event, FnSource, Settings};
//! use lms_core::telegram::Baud;
//!
//! // A sensor that sees a wall 2 m (200 cm) away on every beam.
//! let source = FnSource::new(|_variant, _units, out| {
//!     out.fill(200);
//!     out.len()
//! });
//! let mut lms = Emulator::new(source, Settings::default(), 0);
//! let mut out = [0u8; 1024];
//!
//! // The power-on telegram (29 bytes) is on the line after 29 × 10 bits
//! // at 9600 Bd, 30.2 ms.
//! assert_eq!(lms.transmit(30_000, &mut out), 28);
//! assert_eq!(lms.transmit(31_000, &mut out[28..]), 1);
//! assert_eq!(&out[..5], &[0x02, 0x80, 0x17, 0x00, 0x90]);
//!
//! // The host asks for 38400 Bd: ACK and `A0 00` at 9600 Bd, then the switch.
//! lms.receive(40_000, &[0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08]);
//! let n = lms.transmit(100_000, &mut out);
//! assert_eq!(&out[..n], &[0x06, 0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A]);
//! assert_eq!(lms.baud(), Baud::B38400);
//! let mut switched = false;
//! while let Some(e) = lms.next_event() {
//!     switched |= matches!(e, Event::BaudSwitched { to: Baud::B38400, .. });
//! }
//! assert!(switched);
//! ```
//!
//! A driver loop: [`receive`](Emulator::receive) whatever arrived; call
//! [`transmit`](Emulator::transmit) and send what it returns, again until it
//! returns 0 (it stops early after the last byte before a baud switch, so
//! that the caller can switch its UART in between); drain
//! [`next_event`](Emulator::next_event); sleep until
//! [`next_wakeup_us`](Emulator::next_wakeup_us) or the next input.
//!
//! # Panic contract
//!
//! Nothing here panics, allocates or uses `unsafe`, whatever bytes, times or
//! scan values it is given. Full queues drop and count
//! ([`EmulatorStats`]); time going backwards is treated as no time passing.

use heapless::Deque;

use crate::frame::{Invalid, Variant};
use crate::telegram::reply::POWER_ON_LEN;
use crate::telegram::{
    copy_into, emit_telegram, Baud, Config, Direction, Event as FramerEvent, Framer, FramerStats,
    Handshake, MeasuredValues, ModeResult, RangeBits, Reply, Request, StatusBlock, StatusFields,
    VariantReply, ACK, DEFAULT_ADDRESS, DEFAULT_PASSWORD, DEFAULT_STATUS, MAX_TELEGRAM_LEN,
    MAX_VALUES, NAK, REPLY_ADDRESS_BIT, SENSOR_TYPE_LMS200,
};
use crate::Unit;

/// Data bytes of the `90` power-on telegram: the type string and a space
/// (the content is ours; PROTOCOL.md fixes only the length, 21 bytes).
pub const POWER_ON_DATA: [u8; POWER_ON_LEN] = *b"LMS200;30106x;V02.10 ";

/// A telegram being received is given up after the line has been idle this
/// long (µs), so that a false `STX` cannot hold back the next request.
pub const RX_IDLE_TIMEOUT_US: u64 = 50_000;

/// Default time from the end of the `91` reply to the `90` power-on
/// telegram after a reset (µs).
pub const DEFAULT_RESTART_US: u64 = 1_000_000;

/// Bits on the line per byte: start bit, 8 data bits, stop bit (8N1).
pub const BITS_PER_BYTE: u64 = 10;

/// One mirror turn is 1/75 s = 40000/3 µs; this is 3 × that, to keep the
/// scan times exact in integers.
const TURN_US_TIMES_3: u64 = 40_000;

/// Requests (and NAKs) waiting for the line.
pub const PENDING_CAPACITY: usize = 8;
/// Events held until [`Emulator::next_event`] takes them.
pub const EVENT_CAPACITY: usize = 32;
/// Largest frame on the line: `ACK` + the largest telegram.
const TX_CAPACITY: usize = 1 + MAX_TELEGRAM_LEN;

/// Time the line needs for `bytes` bytes at `baud` (µs, rounded up): 10 bits
/// per byte. A 732-byte `B0` takes 14640 µs at 500000 Bd, 190625 µs at
/// 38400 Bd.
pub const fn line_time_us(bytes: usize, baud: Baud) -> u64 {
    let bits = (bytes as u64).saturating_mul(BITS_PER_BYTE);
    let bps = baud.bits_per_second() as u64;
    bits.saturating_mul(1_000_000).div_ceil(bps)
}

/// Mirror turns per complete scan: 1 at 1°, 2 at 0.5° and 4 at 0.25°
/// (interlaced turns, PROTOCOL.md §3).
pub const fn turns_per_scan(variant: Variant) -> u64 {
    match variant.resolution_centideg() {
        100 => 1,
        50 => 2,
        _ => 4,
    }
}

/// Time between complete scans in continuous mode (µs, rounded): 13333 at
/// 1°, 26667 at 0.5°, 53333 at 0.25°.
pub const fn scan_period_us(variant: Variant) -> u64 {
    (turns_per_scan(variant) * TURN_US_TIMES_3 + 1) / 3
}

/// Where the scans come from: raw value words for the current variant and
/// units.
pub trait ScanSource {
    /// Write the next scan's value words (range in the low 13 bits, flags
    /// above; error codes 8183…8191, PROTOCOL.md §3) in `units` into `out`,
    /// which is exactly `variant.beams()` long; return how many were
    /// written. Values not written are sent as "not valid" (8191).
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize;

    /// `false` if this source cannot produce `variant` (the sensor then
    /// refuses a `3B` for it with `BB 00`). Every variant by default.
    fn supports(&self, variant: Variant) -> bool {
        let _ = variant;
        true
    }

    /// A command the LMS 2xx does not know (it would answer `92`): the
    /// source may answer it instead by writing a reply's data into `reply`
    /// (at most [`EXTRA_REPLY_CAPACITY`] bytes) and returning the reply's
    /// command code and data length; the emulator sends `ACK` and that
    /// reply. `None` (the default) keeps the `92`. The co-processor uses it
    /// for its counters request.
    fn extra_command(&mut self, command: u8, data: &[u8], reply: &mut [u8]) -> Option<(u8, usize)> {
        let _ = (command, data, reply);
        None
    }
}

/// Largest reply data a [`ScanSource::extra_command`] may write.
pub const EXTRA_REPLY_CAPACITY: usize = 64;

/// A [`ScanSource`] from a closure `(variant, units, out) -> written`.
#[derive(Clone, Copy, Debug)]
pub struct FnSource<F>(pub F);

impl<F: FnMut(Variant, Unit, &mut [u16]) -> usize> FnSource<F> {
    /// Wrap a closure (this constructor lets the compiler infer the
    /// closure's argument types).
    pub const fn new(f: F) -> Self {
        FnSource(f)
    }
}

impl<F: FnMut(Variant, Unit, &mut [u16]) -> usize> ScanSource for FnSource<F> {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        (self.0)(variant, units, out)
    }
}

/// The power-on state and fixed properties of the simulated sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Settings {
    /// Sensor address (0..=0x7F; default 0). Replies carry `0x80 | address`.
    pub address: u8,
    /// Variant after power-on and reset (default 180°/1°, as
    /// [`StatusFields::default`]).
    pub variant: Variant,
    /// Configuration at the first power-on (default all zero: cm).
    pub config: Config,
    /// Status byte at the end of every reply (default `0x10`).
    pub status: u8,
    /// Time from the end of the `91` reply to the `90` telegram (µs).
    pub restart_us: u64,
    /// `false` (a simulated sensor): in continuous mode the emulator sends
    /// scans on its own mirror clock, and paces every byte at the line
    /// rate. `true` (the co-processor's face towards its client): it sends
    /// no scans by itself — the caller writes each scan when the real
    /// sensor delivers it, while [`Emulator::streaming`] — and hands out
    /// its replies at once, the UART doing the pacing.
    pub external_scans: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings::DEFAULT
    }
}

impl Settings {
    /// The defaults, usable in `const` contexts.
    pub const DEFAULT: Settings = Settings {
        address: DEFAULT_ADDRESS,
        variant: Variant::Fov180Res100,
        config: Config::ZERO,
        status: DEFAULT_STATUS,
        restart_us: DEFAULT_RESTART_US,
        external_scans: false,
    };
}

/// The operating mode (the `B1` mode byte, payload `[8]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OperatingMode {
    /// `00`: installation mode (configuration may be written).
    Installation,
    /// `24`: continuous output of all values.
    Continuous,
    /// `25`: values on request only (power-on default).
    OnRequest,
}

impl OperatingMode {
    /// The mode byte (`00`, `24`, `25`).
    pub const fn code(self) -> u8 {
        match self {
            OperatingMode::Installation => 0x00,
            OperatingMode::Continuous => 0x24,
            OperatingMode::OnRequest => 0x25,
        }
    }
}

/// A correctly received request and what the emulator made of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Handled {
    /// `20 00`: installation mode, entered if the password was right.
    InstallationMode {
        /// `true` for the right password (`A0 00`), `false` for `A0 01`.
        accepted: bool,
    },
    /// `20 24`: continuous output.
    Continuous,
    /// `20 25`: values on request (the stream stopped).
    OnRequest,
    /// `20 4x`: the line switches to this rate after the reply.
    SetBaud(Baud),
    /// `30 01`: one scan.
    OneScan,
    /// `31`: status.
    Status,
    /// `3A`: type string.
    SensorType,
    /// `3B`: variant.
    SetVariant {
        /// Angle asked for (°).
        angle_deg: u16,
        /// Resolution asked for (1/100 °).
        resolution_centideg: u16,
        /// `true` if taken (`BB 01`).
        accepted: bool,
    },
    /// `74`: read the configuration.
    ReadConfig,
    /// `77`: write the configuration.
    WriteConfig {
        /// `true` if taken (`F7 01`): installation mode and a units code of
        /// 0 or 1.
        accepted: bool,
    },
    /// `10`: reset.
    Reset,
    /// A command the LMS does not know, answered by the source
    /// ([`ScanSource::extra_command`]).
    Extra {
        /// The command code.
        command: u8,
    },
    /// Unknown or malformed (answered with `92`).
    Unknown {
        /// The command code.
        command: u8,
        /// Data bytes after it.
        data_len: usize,
    },
}

/// Something the caller may want to know or log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// The `90` power-on telegram has been sent.
    PowerOnSent,
    /// A request was received and answered (the reply is queued).
    Request(Handled),
    /// A telegram failed its checksum: `NAK` queued.
    BadChecksum,
    /// A telegram for another address was ignored.
    IgnoredAddress {
        /// Its `ADDR` byte.
        address: u8,
    },
    /// The line rate changed now: every byte before it went at `from`,
    /// every byte after goes at `to`.
    BaudSwitched {
        /// The old rate.
        from: Baud,
        /// The new rate.
        to: Baud,
    },
    /// The continuous stream started (the `A0` of `20 24` has been sent).
    StreamStarted,
    /// The continuous stream stopped (`20 25` or `10`).
    StreamStopped,
    /// A `B0` telegram has been sent.
    ScanSent {
        /// Its variant.
        variant: Variant,
        /// `true` in the continuous stream, `false` for `30 01`.
        continuous: bool,
        /// Scans the mirror completed since the previous one sent, which
        /// were skipped because the line was busy.
        skipped: u32,
    },
    /// A reset was requested: input is ignored until the `90` telegram.
    Restarting,
}

/// Counters (all wrap).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EmulatorStats {
    /// Requests answered.
    pub requests: u32,
    /// `NAK`s queued for bad checksums.
    pub naks: u32,
    /// Telegrams for another address.
    pub ignored: u32,
    /// Requests dropped because [`PENDING_CAPACITY`] replies were waiting.
    pub dropped_requests: u32,
    /// Half-received telegrams given up after [`RX_IDLE_TIMEOUT_US`].
    pub abandoned: u32,
    /// Bytes received during a reset and ignored.
    pub ignored_bytes: u32,
    /// `B0` telegrams sent (stream and `30 01`).
    pub scans_sent: u32,
    /// Scans skipped in the stream because the line was busy.
    pub scans_skipped: u32,
    /// Bytes handed out by [`Emulator::transmit`].
    pub bytes_sent: u64,
    /// Events dropped because [`EVENT_CAPACITY`] were waiting.
    pub events_dropped: u32,
    /// Replies that could not be written (cannot happen; counted, not
    /// panicked on).
    pub emit_errors: u32,
}

impl EmulatorStats {
    /// All counters at zero (`const`).
    pub const ZERO: EmulatorStats = EmulatorStats {
        requests: 0,
        naks: 0,
        ignored: 0,
        dropped_requests: 0,
        abandoned: 0,
        ignored_bytes: 0,
        scans_sent: 0,
        scans_skipped: 0,
        bytes_sent: 0,
        events_dropped: 0,
        emit_errors: 0,
    };
}

/// A reply as decided when its request arrived.
#[derive(Clone, Copy, Debug)]
enum ReplyKind {
    Mode(ModeResult),
    Status(StatusFields),
    SensorType,
    Variant(VariantReply),
    Config(Config),
    ConfigWritten {
        accepted: bool,
        config: Config,
    },
    ResetAck,
    Unknown,
    /// `30 01`: a `B0` from the source when the frame starts.
    OneScan,
    /// A reply from [`ScanSource::extra_command`], its data in `extra`.
    Extra {
        command: u8,
        len: usize,
    },
}

/// What happens when a frame's last byte has gone out.
#[derive(Clone, Copy, Debug)]
enum Done {
    Nothing,
    SwitchBaud(Baud),
    StartStream,
    Restart,
    PowerOn,
    Scan { continuous: bool, skipped: u32 },
}

/// A frame waiting for the line.
#[derive(Clone, Copy, Debug)]
enum Outgoing {
    Nak,
    PowerOn,
    /// `ACK` + the reply, then `then`.
    Reply {
        reply: ReplyKind,
        then: Done,
    },
}

#[derive(Clone, Copy, Debug)]
struct Pending {
    /// When the request arrived (µs): the frame starts no earlier.
    ready_us: u64,
    what: Outgoing,
}

/// The continuous stream's clock.
#[derive(Clone, Copy, Debug)]
struct Stream {
    /// Time of scan 0 (µs).
    start_us: u64,
    /// Index of the last scan sent.
    last: Option<u64>,
}

impl Stream {
    /// Time scan `k` is complete (µs).
    fn tick_us(&self, k: u64, turns: u64) -> u64 {
        let offset = k.saturating_mul(turns * TURN_US_TIMES_3) / 3;
        self.start_us.saturating_add(offset)
    }

    /// The scan to send next when the line is free from `free_us` on: the
    /// newest complete by then if it has not been sent, else the one after
    /// the last sent. Returns its index and completion time.
    fn next(&self, free_us: u64, turns: u64) -> (u64, u64) {
        let free = free_us.max(self.start_us);
        let elapsed = free.saturating_sub(self.start_us);
        let newest = elapsed.saturating_mul(3) / (turns * TURN_US_TIMES_3);
        let k = match self.last {
            Some(last) if newest <= last => last.saturating_add(1),
            _ => newest,
        };
        (k, self.tick_us(k, turns))
    }
}

/// A received telegram, copied out of the framer.
#[derive(Clone, Copy, Debug)]
struct Incoming {
    address: u8,
    request: Request<'static>,
}

/// The request without its borrowed bytes (only `Unknown` has any; its
/// length is kept in `data_len`).
fn detach(request: Request<'_>) -> Request<'static> {
    match request {
        Request::InstallationMode { password } => Request::InstallationMode { password },
        Request::Continuous => Request::Continuous,
        Request::OnRequest => Request::OnRequest,
        Request::SetBaud(b) => Request::SetBaud(b),
        Request::OneScan => Request::OneScan,
        Request::Status => Request::Status,
        Request::SensorType => Request::SensorType,
        Request::SetVariant {
            angle_deg,
            resolution_centideg,
        } => Request::SetVariant {
            angle_deg,
            resolution_centideg,
        },
        Request::ReadConfig => Request::ReadConfig,
        Request::WriteConfig(c) => Request::WriteConfig(c),
        Request::Reset => Request::Reset,
        Request::Unknown { command, .. } => Request::Unknown { command, data: &[] },
    }
}

/// The simulated sensor (see the [module docs](self)).
pub struct Emulator<S> {
    source: S,
    settings: Settings,
    baud: Baud,
    mode: OperatingMode,
    variant: Variant,
    config: Config,
    framer: Framer,
    /// When bytes last arrived (µs).
    last_rx_us: u64,
    /// Between a `10` and the `90`: input ignored.
    resetting: bool,
    restart_at_us: Option<u64>,
    pending: Deque<Pending, PENDING_CAPACITY>,
    stream: Option<Stream>,
    /// Continuous mode with [`Settings::external_scans`]: the caller streams.
    external_stream: bool,
    /// Data of the last [`ReplyKind::Extra`] reply.
    extra: [u8; EXTRA_REPLY_CAPACITY],
    /// The frame on the line: `tx[..tx_len]`, of which `tx_sent` handed out.
    tx: [u8; TX_CAPACITY],
    tx_len: usize,
    tx_sent: usize,
    tx_start_us: u64,
    tx_done: Done,
    /// When the line finished the last frame (µs).
    line_free_us: u64,
    scan: [u16; MAX_VALUES],
    events: Deque<Event, EVENT_CAPACITY>,
    stats: EmulatorStats,
}

impl<S: ScanSource> Emulator<S> {
    /// A sensor switched on at `now_us`: 9600 Bd, mode `25`, the `90`
    /// telegram queued.
    pub fn new(source: S, settings: Settings, now_us: u64) -> Self {
        let mut emulator = Emulator::off(source, settings);
        emulator.power_on(now_us);
        emulator
    }

    /// A sensor not yet switched on: silent until [`Emulator::power_on`].
    /// `const`, so an emulator can be placed in a `static` without passing
    /// through the stack.
    pub const fn off(source: S, settings: Settings) -> Self {
        let mut settings = settings;
        settings.address &= 0x7F;
        Emulator {
            source,
            settings,
            baud: Baud::B9600,
            mode: OperatingMode::OnRequest,
            variant: settings.variant,
            config: settings.config,
            framer: Framer::new(Direction::HostToSensor, Handshake::Ignored),
            last_rx_us: 0,
            resetting: false,
            restart_at_us: None,
            pending: Deque::new(),
            stream: None,
            external_stream: false,
            extra: [0; EXTRA_REPLY_CAPACITY],
            tx: [0; TX_CAPACITY],
            tx_len: 0,
            tx_sent: 0,
            tx_start_us: 0,
            tx_done: Done::Nothing,
            line_free_us: 0,
            scan: [0; MAX_VALUES],
            events: Deque::new(),
            stats: EmulatorStats::ZERO,
        }
    }

    /// Switch the sensor off and on at `now_us`: whatever was queued or on
    /// the line is lost; 9600 Bd, mode `25`, the power-on variant, the `90`
    /// telegram. The configuration is kept (EEPROM).
    pub fn power_on(&mut self, now_us: u64) {
        self.set_baud(Baud::B9600);
        self.mode = OperatingMode::OnRequest;
        self.variant = self.settings.variant;
        self.framer.discard();
        self.pending.clear();
        self.stream = None;
        self.external_stream = false;
        self.resetting = false;
        self.restart_at_us = None;
        self.tx_len = 0;
        self.tx_sent = 0;
        self.tx_done = Done::Nothing;
        self.line_free_us = now_us;
        self.queue(now_us, Outgoing::PowerOn);
    }

    /// Bytes the host sent that arrived by `now_us`, in any chunks.
    pub fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        self.last_rx_us = now_us;
        if self.resetting {
            let n = u32::try_from(bytes.len()).unwrap_or(u32::MAX);
            self.stats.ignored_bytes = self.stats.ignored_bytes.wrapping_add(n);
            return;
        }
        self.feed(now_us, bytes);
    }

    /// Feed the framer until it has nothing more, answering what it finds.
    fn feed(&mut self, now_us: u64, bytes: &[u8]) {
        let mut input = bytes;
        // Each round consumes input or delivers a telegram; the bound only
        // guards against a framer bug.
        for _ in 0..bytes
            .len()
            .saturating_add(MAX_TELEGRAM_LEN)
            .saturating_add(2)
        {
            let fed = self.framer.feed(input);
            input = fed.remaining;
            let naks = fed.crc_errors;
            let incoming = match fed.event {
                Some(FramerEvent::Telegram(t)) => Request::parse(&t).ok().map(|r| Incoming {
                    address: t.address(),
                    request: detach(r),
                }),
                Some(FramerEvent::Ack | FramerEvent::Nak) | None => None,
            };
            let data_len = match fed.event {
                Some(FramerEvent::Telegram(t)) => t.data().len(),
                _ => 0,
            };
            // A command the sensor does not know may be the source's.
            let extra = match fed.event {
                Some(FramerEvent::Telegram(t)) if t.address() == self.settings.address => {
                    match Request::parse(&t) {
                        Ok(Request::Unknown { command, data }) => self
                            .source
                            .extra_command(command, data, &mut self.extra)
                            .filter(|&(_, len)| len <= EXTRA_REPLY_CAPACITY),
                        _ => None,
                    }
                }
                _ => None,
            };
            let done = fed.event.is_none();
            for _ in 0..naks {
                self.stats.naks = self.stats.naks.wrapping_add(1);
                self.queue(now_us, Outgoing::Nak);
                self.event(Event::BadChecksum);
            }
            if let Some(incoming) = incoming {
                self.handle(now_us, incoming, data_len, extra);
            }
            if self.resetting {
                // The sensor ignores what follows a reset in the same burst,
                // as it ignores later bytes (see `receive`).
                self.framer.discard();
                let n = u32::try_from(input.len()).unwrap_or(u32::MAX);
                self.stats.ignored_bytes = self.stats.ignored_bytes.wrapping_add(n);
                break;
            }
            if done {
                break;
            }
        }
    }

    /// Answer one request.
    fn handle(
        &mut self,
        now_us: u64,
        incoming: Incoming,
        data_len: usize,
        extra: Option<(u8, usize)>,
    ) {
        if incoming.address != self.settings.address {
            self.stats.ignored = self.stats.ignored.wrapping_add(1);
            self.event(Event::IgnoredAddress {
                address: incoming.address,
            });
            return;
        }
        if self.pending.is_full() {
            self.stats.dropped_requests = self.stats.dropped_requests.wrapping_add(1);
            return;
        }
        self.stats.requests = self.stats.requests.wrapping_add(1);
        let (reply, then, handled) = match incoming.request {
            Request::InstallationMode { password } => {
                let accepted = password == DEFAULT_PASSWORD;
                let result = if accepted {
                    self.mode = OperatingMode::Installation;
                    self.stop_stream();
                    ModeResult::Ok
                } else {
                    ModeResult::BadPassword
                };
                (
                    ReplyKind::Mode(result),
                    Done::Nothing,
                    Handled::InstallationMode { accepted },
                )
            }
            Request::Continuous => {
                self.mode = OperatingMode::Continuous;
                (
                    ReplyKind::Mode(ModeResult::Ok),
                    Done::StartStream,
                    Handled::Continuous,
                )
            }
            Request::OnRequest => {
                self.mode = OperatingMode::OnRequest;
                self.stop_stream();
                (
                    ReplyKind::Mode(ModeResult::Ok),
                    Done::Nothing,
                    Handled::OnRequest,
                )
            }
            Request::SetBaud(b) => (
                ReplyKind::Mode(ModeResult::Ok),
                Done::SwitchBaud(b),
                Handled::SetBaud(b),
            ),
            Request::OneScan => (ReplyKind::OneScan, Done::Nothing, Handled::OneScan),
            Request::Status => (
                ReplyKind::Status(self.status_fields()),
                Done::Nothing,
                Handled::Status,
            ),
            Request::SensorType => (ReplyKind::SensorType, Done::Nothing, Handled::SensorType),
            Request::SetVariant {
                angle_deg,
                resolution_centideg,
            } => {
                let wanted = Variant::from_fov_res(angle_deg, resolution_centideg)
                    .filter(|&v| self.source.supports(v));
                if let Some(v) = wanted {
                    self.set_variant(now_us, v);
                }
                let accepted = wanted.is_some();
                (
                    ReplyKind::Variant(VariantReply {
                        accepted,
                        angle_deg: self.variant.fov_deg(),
                        resolution_centideg: self.variant.resolution_centideg(),
                    }),
                    Done::Nothing,
                    Handled::SetVariant {
                        angle_deg,
                        resolution_centideg,
                        accepted,
                    },
                )
            }
            Request::ReadConfig => (
                ReplyKind::Config(self.config),
                Done::Nothing,
                Handled::ReadConfig,
            ),
            Request::WriteConfig(c) => {
                let accepted = self.mode == OperatingMode::Installation && c.units().is_some();
                if accepted {
                    self.config = c;
                }
                (
                    ReplyKind::ConfigWritten {
                        accepted,
                        config: self.config,
                    },
                    Done::Nothing,
                    Handled::WriteConfig { accepted },
                )
            }
            Request::Reset => {
                self.stop_stream();
                self.resetting = true;
                self.event(Event::Restarting);
                (ReplyKind::ResetAck, Done::Restart, Handled::Reset)
            }
            Request::Unknown { command, .. } => match extra {
                Some((reply, len)) => (
                    ReplyKind::Extra {
                        command: reply,
                        len,
                    },
                    Done::Nothing,
                    Handled::Extra { command },
                ),
                None => (
                    ReplyKind::Unknown,
                    Done::Nothing,
                    Handled::Unknown { command, data_len },
                ),
            },
        };
        self.queue(now_us, Outgoing::Reply { reply, then });
        self.event(Event::Request(handled));
    }

    /// Change the variant; a running stream restarts its scan clock.
    fn set_variant(&mut self, now_us: u64, v: Variant) {
        self.variant = v;
        if let Some(stream) = self.stream.as_mut() {
            *stream = Stream {
                start_us: now_us,
                last: None,
            };
        }
    }

    fn stop_stream(&mut self) {
        let external = core::mem::replace(&mut self.external_stream, false);
        if self.stream.take().is_some() || external {
            self.event(Event::StreamStopped);
        }
    }

    fn set_baud(&mut self, to: Baud) {
        let from = self.baud;
        if from != to {
            self.baud = to;
            self.event(Event::BaudSwitched { from, to });
        }
    }

    fn queue(&mut self, now_us: u64, what: Outgoing) {
        let pending = Pending {
            ready_us: now_us,
            what,
        };
        if self.pending.push_back(pending).is_err() {
            self.stats.dropped_requests = self.stats.dropped_requests.wrapping_add(1);
        }
    }

    fn event(&mut self, e: Event) {
        if self.events.push_back(e).is_err() {
            self.stats.events_dropped = self.stats.events_dropped.wrapping_add(1);
        }
    }

    /// The sensor → host bytes whose line time has come by `now_us` (see
    /// *Timing* in the module docs), at most `out.len()`; returns how
    /// many were written. It stops right after the last byte sent at the
    /// old rate when the line switches ([`Event::BaudSwitched`]): call it
    /// again until it returns 0.
    pub fn transmit(&mut self, now_us: u64, out: &mut [u8]) -> usize {
        let mut n = 0;
        // Each round completes a frame or stops; the bound only guards
        // against a logic error.
        for _ in 0..out.len().saturating_add(PENDING_CAPACITY).saturating_add(4) {
            self.advance(now_us);
            if self.tx_len == 0 {
                break;
            }
            let due = self.bytes_due(now_us);
            let k = due
                .saturating_sub(self.tx_sent)
                .min(out.len().saturating_sub(n));
            let src = self
                .tx
                .get(self.tx_sent..self.tx_sent.saturating_add(k))
                .unwrap_or_default();
            copy_into(out.get_mut(n..).unwrap_or_default(), src);
            n = n.saturating_add(k);
            self.tx_sent = self.tx_sent.saturating_add(k);
            self.stats.bytes_sent = self.stats.bytes_sent.wrapping_add(k as u64);
            if self.tx_sent < self.tx_len || self.finish_frame() {
                break;
            }
        }
        n
    }

    /// Bytes of the current frame whose stop bit has passed at `now_us`.
    fn bytes_due(&self, now_us: u64) -> usize {
        if self.settings.external_scans {
            return self.tx_len;
        }
        let Some(elapsed) = now_us.checked_sub(self.tx_start_us) else {
            return 0;
        };
        if elapsed >= line_time_us(self.tx_len, self.baud) {
            return self.tx_len;
        }
        // elapsed < 818 bytes at 9600 Bd < 10⁶ µs: no overflow.
        let bits = elapsed.saturating_mul(u64::from(self.baud.bits_per_second())) / 1_000_000;
        usize::try_from(bits / BITS_PER_BYTE)
            .unwrap_or(usize::MAX)
            .min(self.tx_len)
    }

    /// The frame's last byte has been handed out: free the line and do what
    /// follows. Returns `true` if the line switched rate.
    fn finish_frame(&mut self) -> bool {
        let end = self
            .tx_start_us
            .saturating_add(line_time_us(self.tx_len, self.baud));
        self.line_free_us = end;
        self.tx_len = 0;
        self.tx_sent = 0;
        let done = core::mem::replace(&mut self.tx_done, Done::Nothing);
        match done {
            Done::Nothing => {}
            Done::SwitchBaud(b) => {
                let before = self.baud;
                self.set_baud(b);
                return before != b;
            }
            Done::StartStream => {
                if self.mode == OperatingMode::Continuous && !self.resetting {
                    if self.settings.external_scans {
                        self.external_stream = true;
                    } else {
                        self.stream = Some(Stream {
                            start_us: end,
                            last: None,
                        });
                    }
                    self.event(Event::StreamStarted);
                }
            }
            Done::Restart => {
                self.restart_at_us = Some(end.saturating_add(self.settings.restart_us));
            }
            Done::PowerOn => self.event(Event::PowerOnSent),
            Done::Scan {
                continuous,
                skipped,
            } => {
                self.stats.scans_sent = self.stats.scans_sent.wrapping_add(1);
                self.stats.scans_skipped = self.stats.scans_skipped.wrapping_add(skipped);
                self.event(Event::ScanSent {
                    variant: self.variant,
                    continuous,
                    skipped,
                });
            }
        }
        false
    }

    /// Timers: the restart after a reset, the receive time-out; and the
    /// next frame when the line is free.
    fn advance(&mut self, now_us: u64) {
        if let Some(at) = self.restart_at_us {
            if now_us >= at {
                self.power_on(at);
            }
        }
        if !self.resetting {
            // Each round drops one false STX; a telegram is at most
            // MAX_TELEGRAM_LEN bytes.
            for _ in 0..MAX_TELEGRAM_LEN {
                let idle = now_us.saturating_sub(self.last_rx_us) >= RX_IDLE_TIMEOUT_US;
                if !(idle && self.framer.buffered() > 0 && self.framer.abandon()) {
                    break;
                }
                self.stats.abandoned = self.stats.abandoned.wrapping_add(1);
                // What the re-scan finds arrived before the time-out.
                let at = self.last_rx_us.saturating_add(RX_IDLE_TIMEOUT_US);
                self.feed(at, &[]);
            }
        }
        if self.tx_len != 0 {
            return;
        }
        if let Some(p) = self.pending.pop_front() {
            self.start_frame(p.ready_us, p.what);
            return;
        }
        let turns = turns_per_scan(self.variant);
        let Some(stream) = self.stream.as_mut() else {
            return;
        };
        // Decided as of when the line became free, however late the call.
        let (k, tick) = stream.next(self.line_free_us, turns);
        if tick > now_us {
            return;
        }
        let skipped = match stream.last {
            Some(last) => k.saturating_sub(last).saturating_sub(1),
            None => k,
        };
        stream.last = Some(k);
        let skipped = u32::try_from(skipped).unwrap_or(u32::MAX);
        self.start_scan(
            tick,
            false,
            Done::Scan {
                continuous: true,
                skipped,
            },
        );
    }

    /// Put a frame on the line, starting when both it and the line are ready.
    fn start_frame(&mut self, ready_us: u64, what: Outgoing) {
        let address = self.settings.address;
        let status = self.settings.status;
        match what {
            Outgoing::Nak => {
                if let Some(b) = self.tx.first_mut() {
                    *b = NAK;
                }
                self.set_frame(ready_us, Some(1), Done::Nothing);
            }
            Outgoing::PowerOn => {
                let n = Reply::PowerOn(POWER_ON_DATA).emit(address, status, &mut self.tx);
                self.set_frame(ready_us, n.ok(), Done::PowerOn);
            }
            Outgoing::Reply {
                reply: ReplyKind::OneScan,
                ..
            } => self.start_scan(
                ready_us,
                true,
                Done::Scan {
                    continuous: false,
                    skipped: 0,
                },
            ),
            Outgoing::Reply { reply, then } => {
                let reply = match reply {
                    ReplyKind::Mode(r) => Reply::ModeChanged(r),
                    ReplyKind::Status(f) => Reply::Status(StatusBlock::from_fields(&f)),
                    ReplyKind::SensorType => Reply::SensorType(SENSOR_TYPE_LMS200.as_bytes()),
                    ReplyKind::Variant(v) => Reply::Variant(v),
                    ReplyKind::Config(c) => Reply::Config(c),
                    ReplyKind::ConfigWritten { accepted, config } => {
                        Reply::ConfigWritten { accepted, config }
                    }
                    ReplyKind::ResetAck => Reply::ResetAck,
                    ReplyKind::Unknown | ReplyKind::OneScan => Reply::UnknownCommand,
                    ReplyKind::Extra { command, len } => {
                        let extra = self.extra;
                        let data = extra.get(..len).unwrap_or_default();
                        let n = self.emit_after_ack(|buf| {
                            emit_telegram(
                                buf,
                                REPLY_ADDRESS_BIT | address,
                                command,
                                data,
                                Some(status),
                            )
                        });
                        self.set_frame(ready_us, n.ok(), then);
                        return;
                    }
                };
                let n = self.emit_after_ack(|buf| reply.emit(address, status, buf));
                self.set_frame(ready_us, n.ok(), then);
            }
        }
    }

    /// `ACK` then what `emit` writes.
    fn emit_after_ack<E>(
        &mut self,
        emit: impl FnOnce(&mut [u8]) -> Result<usize, E>,
    ) -> Result<usize, E> {
        let (first, rest) = match self.tx.split_first_mut() {
            Some(split) => split,
            None => return Ok(0),
        };
        *first = ACK;
        emit(rest).map(|n| n.saturating_add(1))
    }

    /// A `B0` with the source's next scan, with `ACK` before it for `30 01`.
    fn start_scan(&mut self, ready_us: u64, ack: bool, done: Done) {
        let variant = self.variant;
        let units = self.units();
        let beams = variant.beams().min(MAX_VALUES);
        let out = self.scan.get_mut(..beams).unwrap_or_default();
        let written = self.source.next_scan(variant, units, out).min(out.len());
        let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
        out.get_mut(written..).unwrap_or_default().fill(not_valid);
        let address = self.settings.address;
        let values = MeasuredValues::from_raw(out, units, self.settings.status);
        let n = match values {
            Ok(v) if ack => self.emit_after_ack(|buf| v.emit(address, buf)),
            Ok(v) => v.emit(address, &mut self.tx),
            // Cannot happen: `beams <= MAX_VALUES`.
            Err(_) => Ok(0),
        };
        self.set_frame(ready_us, n.ok(), done);
    }

    /// Start the frame of `len` bytes in `tx` (`None`: it could not be
    /// written; nothing is sent and `done` is not carried out).
    fn set_frame(&mut self, ready_us: u64, len: Option<usize>, done: Done) {
        match len {
            Some(len) if len > 0 => {
                self.tx_len = len.min(TX_CAPACITY);
                self.tx_sent = 0;
                self.tx_start_us = ready_us.max(self.line_free_us);
                self.tx_done = done;
            }
            _ => self.stats.emit_errors = self.stats.emit_errors.wrapping_add(1),
        }
    }

    /// The next event, oldest first.
    pub fn next_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// The earliest time (µs) at which [`transmit`](Emulator::transmit) will
    /// have something to do: the next byte's stop bit, a queued reply, the
    /// next scan, the end of a reset or the receive time-out. `None` if
    /// nothing will happen without input.
    pub fn next_wakeup_us(&self) -> Option<u64> {
        let mut next: Option<u64> = None;
        let mut consider = |t: u64| next = Some(next.map_or(t, |n: u64| n.min(t)));
        if self.tx_len > 0 {
            let bytes = self.tx_sent.saturating_add(1);
            consider(
                self.tx_start_us
                    .saturating_add(line_time_us(bytes, self.baud)),
            );
        } else if let Some(p) = self.pending.front() {
            consider(p.ready_us.max(self.line_free_us));
        } else if let Some(stream) = &self.stream {
            let (_, tick) = stream.next(self.line_free_us, turns_per_scan(self.variant));
            consider(tick.max(self.line_free_us));
        }
        if let Some(at) = self.restart_at_us {
            consider(at);
        }
        if self.framer.buffered() > 0 && !self.resetting {
            consider(self.last_rx_us.saturating_add(RX_IDLE_TIMEOUT_US));
        }
        next
    }

    /// The `B1` fields as they are now.
    pub fn status_fields(&self) -> StatusFields {
        StatusFields {
            operating_mode: self.mode.code(),
            scan_angle_deg: self.variant.fov_deg(),
            resolution_centideg: self.variant.resolution_centideg(),
            baud: self.baud,
            address: self.settings.address,
            units_code: self.config.units_code(),
        }
    }

    /// The current line rate.
    pub fn baud(&self) -> Baud {
        self.baud
    }

    /// The operating mode.
    pub fn operating_mode(&self) -> OperatingMode {
        self.mode
    }

    /// The scan variant.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// The configuration block.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Unit of the range values (from the configuration; cm unless it says
    /// mm).
    pub fn units(&self) -> Unit {
        self.config.units().unwrap_or(Unit::Centimetre)
    }

    /// `true` while the continuous stream runs.
    pub fn streaming(&self) -> bool {
        self.stream.is_some() || self.external_stream
    }

    /// `true` between a `10` request and the `90` telegram.
    pub fn restarting(&self) -> bool {
        self.resetting
    }

    /// `true` if nothing is on the line or waiting for it.
    pub fn line_idle(&self) -> bool {
        self.tx_len == 0 && self.pending.is_empty()
    }

    /// The settings given to [`new`](Emulator::new).
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The counters.
    pub fn stats(&self) -> &EmulatorStats {
        &self.stats
    }

    /// The receive framer's counters (bytes skipped, CRC errors, …).
    pub fn framer_stats(&self) -> &FramerStats {
        self.framer.stats()
    }

    /// The scan source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// The scan source, to change it.
    pub fn source_mut(&mut self) -> &mut S {
        &mut self.source
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::telegram::{crc16, Telegram};
    use std::vec::Vec;

    /// Value `1000 + j` on beam `j`; counts the scans drawn.
    #[derive(Default)]
    struct Ramp {
        drawn: usize,
    }

    impl ScanSource for Ramp {
        fn next_scan(&mut self, _: Variant, _: Unit, out: &mut [u16]) -> usize {
            self.drawn += 1;
            for (j, v) in out.iter_mut().enumerate() {
                *v = 1000 + j as u16;
            }
            out.len()
        }
    }

    const STATUS: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12];
    const ONE_SCAN: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x30, 0x01, 0x31, 0x18];
    const START: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08];
    const STOP: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08];
    const BAUD_9600: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08];
    const BAUD_38400: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08];
    const BAUD_500K: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08];
    const INSTALL: [u8; 16] = [
        0x02, 0x00, 0x0A, 0x00, 0x20, 0x00, 0x53, 0x49, 0x43, 0x4B, 0x5F, 0x4C, 0x4D, 0x53, 0xBE,
        0xC5,
    ];
    const VARIANT_180_050: [u8; 11] = [
        0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F,
    ];
    const VARIANT_100_025: [u8; 11] = [
        0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xE7, 0x72,
    ];
    const READ_CONFIG: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x74, 0x50, 0x12];
    const SENSOR_TYPE: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x3A, 0x1E, 0x12];
    const RESET: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x10, 0x34, 0x12];

    const A0_OK: [u8; 9] = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
    const BB_180_050: [u8; 13] = [
        0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D,
    ];
    const REPLY_92: [u8; 8] = [0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33];

    /// ACK followed by `telegram`.
    fn acked(telegram: &[u8]) -> Vec<u8> {
        let mut v = std::vec![ACK];
        v.extend_from_slice(telegram);
        v
    }

    /// A host telegram with a correct CRC (built here from §1, not with the
    /// crate's emitter).
    fn request(payload: &[u8]) -> Vec<u8> {
        let len = payload.len() as u16;
        let mut v = std::vec![0x02, 0x00, len as u8, (len >> 8) as u8];
        v.extend_from_slice(payload);
        let crc = crc16(&v);
        v.extend_from_slice(&crc.to_le_bytes());
        v
    }

    /// A sensor telegram with a correct CRC.
    fn sensor(payload: &[u8]) -> Vec<u8> {
        let mut v = request(payload);
        v[1] = 0x80;
        let n = v.len() - 2;
        let crc = crc16(&v[..n]);
        v[n..].copy_from_slice(&crc.to_le_bytes());
        v
    }

    fn lms() -> Emulator<Ramp> {
        let mut e = Emulator::new(Ramp::default(), Settings::default(), 0);
        // Let the power-on telegram go out.
        let got = drain(&mut e, 1_000_000);
        assert_eq!(got.len(), 29);
        while e.next_event().is_some() {}
        e
    }

    /// Everything sent up to `until_us`.
    fn drain<S: ScanSource>(e: &mut Emulator<S>, until_us: u64) -> Vec<u8> {
        let mut out = Vec::new();
        let mut buf = [0u8; 256];
        loop {
            let n = e.transmit(until_us, &mut buf);
            if n == 0 {
                break;
            }
            out.extend_from_slice(&buf[..n]);
        }
        out
    }

    fn events<S: ScanSource>(e: &mut Emulator<S>) -> Vec<Event> {
        core::iter::from_fn(|| e.next_event()).collect()
    }

    /// Split a sensor byte stream into ACK/NAK bytes and checked telegrams.
    fn split(bytes: &[u8]) -> Vec<Vec<u8>> {
        let mut parts = Vec::new();
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i] == ACK || bytes[i] == NAK {
                parts.push(std::vec![bytes[i]]);
                i += 1;
                continue;
            }
            let t = match Telegram::new_checked(&bytes[i..], Direction::SensorToHost) {
                Ok(t) => t,
                // A telegram still on the line at the end.
                Err(crate::telegram::TelegramError::Truncated { .. }) => break,
                Err(e) => panic!("no telegram at {i}: {e}"),
            };
            parts.push(t.as_bytes().to_vec());
            i += t.total_len();
        }
        parts
    }

    #[test]
    fn emulator_power_on_telegram() {
        let mut e = Emulator::new(Ramp::default(), Settings::default(), 5_000);
        assert_eq!(e.baud(), Baud::B9600);
        assert_eq!(e.operating_mode().code(), 0x25);
        // 29 bytes × 10 bits at 9600 Bd = 30208.3 µs: not all out before.
        let mut got = drain(&mut e, 5_000 + 30_208);
        assert_eq!(got.len(), 28);
        got.extend(drain(&mut e, 5_000 + 30_209));
        let expected = sensor(&[&[0x90][..], &POWER_ON_DATA[..], &[0x10][..]].concat());
        assert_eq!(&expected[..5], &[0x02, 0x80, 0x17, 0x00, 0x90]);
        assert_eq!(got, expected);
        assert_eq!(events(&mut e), [Event::PowerOnSent]);
        assert_eq!(e.next_wakeup_us(), None);
    }

    #[test]
    fn emulator_a0_bb_92_byte_exact() {
        let mut e = lms();
        e.receive(2_000_000, &STOP);
        assert_eq!(drain(&mut e, 3_000_000), acked(&A0_OK));
        e.receive(3_000_000, &VARIANT_180_050);
        assert_eq!(drain(&mut e, 4_000_000), acked(&BB_180_050));
        assert_eq!(e.variant(), Variant::Fov180Res50);
        // Unknown command `55`, and `31` with a data byte (malformed).
        e.receive(4_000_000, &request(&[0x55]));
        e.receive(4_000_000, &request(&[0x31, 0x00]));
        let mut expected = acked(&REPLY_92);
        expected.extend(acked(&REPLY_92));
        assert_eq!(drain(&mut e, 5_000_000), expected);
        assert_eq!(
            events(&mut e)[2..],
            [
                Event::Request(Handled::Unknown {
                    command: 0x55,
                    data_len: 0
                }),
                Event::Request(Handled::Unknown {
                    command: 0x31,
                    data_len: 1
                }),
            ]
        );
    }

    #[test]
    fn emulator_nak_on_bad_checksum_then_resend() {
        let mut e = lms();
        let mut bad = STATUS;
        bad[6] ^= 0x01;
        e.receive(2_000_000, &bad);
        assert_eq!(drain(&mut e, 3_000_000), [NAK]);
        assert_eq!(events(&mut e), [Event::BadChecksum]);
        e.receive(3_000_000, &STATUS);
        let parts = split(&drain(&mut e, 4_000_000));
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[1][4], 0xB1);
    }

    #[test]
    fn emulator_status_in_any_chunks_reflects_state() {
        let mut e = lms();
        // Byte by byte, with garbage before.
        e.receive(2_000_000, &[0xFF, 0x00]);
        for (k, b) in STATUS.iter().enumerate() {
            e.receive(2_000_000 + k as u64, core::slice::from_ref(b));
        }
        let parts = split(&drain(&mut e, 3_000_000));
        assert_eq!(parts[0], [ACK]);
        let b1 = &parts[1];
        assert_eq!(&b1[..5], &[0x02, 0x80, 0x9A, 0x00, 0xB1]); // LEN 154
        let p = &b1[4..b1.len() - 2]; // payload: B1 … status
        assert_eq!(p[8], 0x25);
        assert_eq!(&p[107..=108], &[180, 0]);
        assert_eq!(&p[109..=110], &[100, 0]);
        assert_eq!(&p[116..=117], &[103, 0]); // 10⁶/9600 − 1
        assert_eq!(p[120], 0);
        assert_eq!(p[122], 0); // cm
        assert_eq!(p[153], 0x10);

        // After installation mode, mm, 100°/0.25° and 500 kBd.
        e.receive(3_000_000, &INSTALL);
        e.receive(3_000_000, &READ_CONFIG);
        let parts = split(&drain(&mut e, 4_000_000));
        assert_eq!(parts[1], A0_OK);
        let f4 = &parts[3];
        assert_eq!(&f4[..5], &[0x02, 0x80, 0x24, 0x00, 0xF4]); // LEN 36
        let mut config = f4[5..39].to_vec();
        config[6] = 1;
        e.receive(4_000_000, &request(&[&[0x77][..], &config].concat()));
        e.receive(4_000_000, &VARIANT_100_025);
        e.receive(4_000_000, &BAUD_500K);
        let parts = split(&drain(&mut e, 5_000_000));
        assert_eq!(&parts[1][..7], &[0x02, 0x80, 0x25, 0x00, 0xF7, 0x01, 0x00]);
        assert_eq!(parts[1][5 + 1 + 6], 1);
        assert_eq!(
            parts[3],
            sensor(&[0xBB, 0x01, 0x64, 0x00, 0x19, 0x00, 0x10])
        );
        assert_eq!(parts[5], A0_OK);
        assert_eq!(e.baud(), Baud::B500000);
        e.receive(5_000_000, &STATUS);
        let parts = split(&drain(&mut e, 6_000_000));
        let p = &parts[1][4..];
        assert_eq!(p[8], 0x00);
        assert_eq!(&p[107..=108], &[100, 0]);
        assert_eq!(&p[109..=110], &[25, 0]);
        assert_eq!(&p[116..=117], &[1, 0]);
        assert_eq!(p[122], 1);
        assert_eq!(e.units(), Unit::Millimetre);
    }

    #[test]
    fn emulator_installation_password_and_config_write() {
        let mut e = lms();
        let mut config = [0u8; 34];
        config[6] = 1;
        let write = request(&[&[0x77][..], &config].concat());
        // Not in installation mode: refused, configuration kept.
        e.receive(2_000_000, &write);
        let parts = split(&drain(&mut e, 3_000_000));
        assert_eq!(&parts[1][4..6], &[0xF7, 0x00]);
        assert_eq!(parts[1][5 + 1 + 6], 0);
        // Bad password: A0 01, mode kept.
        e.receive(3_000_000, &request(b"\x20\x00SICK_LMX"));
        let parts = split(&drain(&mut e, 4_000_000));
        assert_eq!(parts[1], sensor(&[0xA0, 0x01, 0x10]));
        assert_eq!(e.operating_mode(), OperatingMode::OnRequest);
        // Right password; an undefined units code is refused.
        e.receive(4_000_000, &INSTALL);
        config[6] = 2;
        e.receive(4_000_000, &request(&[&[0x77][..], &config].concat()));
        e.receive(4_000_000, &write);
        let parts = split(&drain(&mut e, 5_000_000));
        assert_eq!(parts[1], A0_OK);
        assert_eq!(&parts[3][4..6], &[0xF7, 0x00]);
        assert_eq!(&parts[5][4..6], &[0xF7, 0x01]);
        assert_eq!(e.units(), Unit::Millimetre);
        // 30 01: ACK and 181 values in mm: count word B5 40.
        e.receive(5_000_000, &ONE_SCAN);
        let parts = split(&drain(&mut e, 6_000_000));
        assert_eq!(parts[0], [ACK]);
        assert_eq!(&parts[1][4..7], &[0xB0, 0xB5, 0x40]);
        assert_eq!(&parts[1][7..9], &1000u16.to_le_bytes());
    }

    #[test]
    fn emulator_variant_refusals_keep_the_variant() {
        let mut e = lms();
        for (angle, res) in [(180u16, 25u16), (90, 50), (100, 10)] {
            let [a0, a1] = angle.to_le_bytes();
            let [r0, r1] = res.to_le_bytes();
            e.receive(2_000_000, &request(&[0x3B, a0, a1, r0, r1]));
            let parts = split(&drain(&mut e, 3_000_000));
            assert_eq!(
                parts[1],
                sensor(&[0xBB, 0x00, 180, 0, 100, 0, 0x10]),
                "{angle}/{res}"
            );
        }
        // A source that cannot do 0.25° refuses 100°/0.25°.
        struct Coarse;
        impl ScanSource for Coarse {
            fn next_scan(&mut self, _: Variant, _: Unit, out: &mut [u16]) -> usize {
                out.len()
            }
            fn supports(&self, v: Variant) -> bool {
                v != Variant::Fov100Res25
            }
        }
        let mut e = Emulator::new(Coarse, Settings::default(), 0);
        drain(&mut e, 1_000_000);
        e.receive(1_000_000, &VARIANT_100_025);
        e.receive(1_000_000, &VARIANT_180_050);
        let parts = split(&drain(&mut e, 2_000_000));
        assert_eq!(parts[1], sensor(&[0xBB, 0x00, 180, 0, 100, 0, 0x10]));
        assert_eq!(parts[3], BB_180_050);
    }

    #[test]
    fn emulator_sensor_type() {
        let mut e = lms();
        e.receive(2_000_000, &SENSOR_TYPE);
        let parts = split(&drain(&mut e, 3_000_000));
        assert_eq!(parts[1], sensor(b"\xBALMS200;30106x;V02.10\x10"));
    }

    #[test]
    fn emulator_baud_switch_after_the_reply() {
        let mut e = lms();
        let t0 = 2_000_000;
        e.receive(t0, &BAUD_38400);
        // ACK + A0 = 10 bytes at 9600 Bd: 10416.7 µs.
        let mut out = [0u8; 64];
        assert_eq!(e.transmit(t0 + 10_416, &mut out), 9);
        assert_eq!(e.baud(), Baud::B9600);
        assert_eq!(e.transmit(t0 + 10_417, &mut out), 1);
        assert_eq!(out[0], A0_OK[8]);
        assert_eq!(e.baud(), Baud::B38400);
        assert_eq!(
            events(&mut e),
            [
                Event::Request(Handled::SetBaud(Baud::B38400)),
                Event::BaudSwitched {
                    from: Baud::B9600,
                    to: Baud::B38400
                }
            ]
        );
        // The next reply goes at 38400 Bd: 10 bytes in 2604.2 µs.
        let t1 = t0 + 20_000;
        e.receive(t1, &BAUD_9600);
        assert_eq!(e.transmit(t1 + 2_604, &mut out), 9);
        assert_eq!(e.transmit(t1 + 2_605, &mut out), 1);
        assert_eq!(e.baud(), Baud::B9600);
    }

    #[test]
    fn emulator_transmit_stops_at_the_switch() {
        // Two requests at once: the second reply must not be handed out in
        // the same call as the first, since it goes at the new rate.
        let mut e = lms();
        e.receive(2_000_000, &[&BAUD_500K[..], &STATUS[..]].concat());
        let mut out = [0u8; 512];
        assert_eq!(e.transmit(3_000_000, &mut out), 10);
        assert_eq!(e.baud(), Baud::B500000);
        assert_eq!(e.transmit(3_000_000, &mut out), 1 + 160);
    }

    /// Scans in `bytes` and the count word of the first.
    fn scans(bytes: &[u8]) -> (usize, u16) {
        let parts = split(bytes);
        let b0: Vec<_> = parts
            .iter()
            .filter(|p| p.len() > 4 && p[4] == 0xB0)
            .collect();
        let w = b0.first().map_or(0, |p| u16::from_le_bytes([p[5], p[6]]));
        (b0.len(), w)
    }

    #[test]
    fn emulator_stream_paced_by_mirror_and_line() {
        let mut e = lms();
        e.receive(2_000_000, &VARIANT_180_050);
        e.receive(2_000_000, &BAUD_500K);
        drain(&mut e, 2_100_000);
        e.receive(2_100_000, &START);
        // A0 at 500 kBd: 10 bytes, 200 µs; then one scan per 26.67 ms.
        let got = drain(&mut e, 2_100_200);
        assert_eq!(got, acked(&A0_OK));
        assert!(e.streaming());
        let got = drain(&mut e, 3_100_200);
        let (n, w) = scans(&got);
        // 1 s: scans at 0, 26.67, … 986.7 ms = 38 complete by 1 s + 14.6 ms
        // for the last one still on the line.
        assert_eq!(n, 37);
        assert_eq!(w, 0x0169);
        assert_eq!(e.stats().scans_skipped, 0);
        assert_eq!(
            got.len(),
            37 * 732 + (1_000_000 - 37 * 80_000 / 3) as usize / 20
        );

        // At 9600 Bd a 732-byte B0 takes 762.5 ms: the line limits the rate.
        let mut e = lms();
        e.receive(2_000_000, &VARIANT_180_050);
        e.receive(2_000_000, &START);
        let got = drain(&mut e, 12_000_000);
        let (n, _) = scans(&got);
        assert_eq!(n, 13);
        assert!(e.stats().scans_skipped > 300);
    }

    #[test]
    fn emulator_stop_comes_after_the_stream() {
        let mut e = lms();
        e.receive(2_000_000, &VARIANT_180_050);
        e.receive(2_000_000, &BAUD_38400);
        e.receive(2_000_000, &START);
        let mut got = drain(&mut e, 2_500_000);
        // Stop while a B0 (190.6 ms at 38400 Bd) is on the line.
        assert!(!e.line_idle());
        e.receive(2_500_000, &STOP);
        got.extend(drain(&mut e, 4_000_000));
        let parts = split(&got);
        let n = parts.len();
        // ACK BB, ACK A0 (baud), ACK A0 (start), B0 …, ACK A0 (stop).
        assert_eq!(parts[n - 1], A0_OK);
        assert_eq!(parts[n - 2], [ACK]);
        assert_eq!(parts[n - 3][4], 0xB0);
        assert_eq!(parts[n - 3].len(), 732);
        assert!(!e.streaming());
        assert!(drain(&mut e, 10_000_000).is_empty());
        let ev = events(&mut e);
        let stopped = ev.iter().position(|x| *x == Event::StreamStopped).unwrap();
        let req = ev
            .iter()
            .position(|x| *x == Event::Request(Handled::OnRequest))
            .unwrap();
        assert!(stopped < req);
        // The B0 in flight was finished after the request, no other.
        let after: Vec<_> = ev[req..]
            .iter()
            .filter(|x| matches!(x, Event::ScanSent { .. }))
            .collect();
        assert_eq!(after.len(), 1);
    }

    #[test]
    fn emulator_reset_restarts_at_9600() {
        let mut e = lms();
        e.receive(2_000_000, &VARIANT_180_050);
        e.receive(2_000_000, &BAUD_38400);
        e.receive(2_000_000, &START);
        drain(&mut e, 2_050_000);
        e.receive(2_050_000, &RESET);
        let got = drain(&mut e, 2_500_000);
        let tail = &got[got.len() - 9..];
        assert_eq!(tail, acked(&sensor(&[0x91, 0x10])));
        assert!(e.restarting());
        // Input during the restart is ignored.
        e.receive(2_600_000, &STATUS);
        assert!(drain(&mut e, 3_000_000).is_empty());
        assert_eq!(e.baud(), Baud::B38400);
        // About 1 s after the 91: back at 9600 Bd, default state, and 90.
        let got = drain(&mut e, 4_000_000);
        assert_eq!(got.len(), 29);
        assert_eq!(got[4], 0x90);
        assert_eq!(e.baud(), Baud::B9600);
        assert_eq!(e.variant(), Variant::Fov180Res100);
        assert_eq!(e.operating_mode(), OperatingMode::OnRequest);
        assert!(!e.streaming() && !e.restarting());
        let ev = events(&mut e);
        assert!(ev.contains(&Event::Restarting));
        assert!(ev.contains(&Event::BaudSwitched {
            from: Baud::B38400,
            to: Baud::B9600
        }));
        assert_eq!(ev.last(), Some(&Event::PowerOnSent));
    }

    #[test]
    fn emulator_ignores_requests_after_a_reset_in_the_same_burst() {
        // Found by the `emulator` fuzz target: a second `10` behind the first
        // was answered too, and the restart cut that second `91` short.
        let mut e = lms();
        drain(&mut e, 2_000_000);
        let burst: Vec<u8> = [RESET.as_slice(), &RESET, &STATUS].concat();
        e.receive(2_000_000, &burst);
        let got = drain(&mut e, 2_500_000);
        assert_eq!(got, acked(&sensor(&[0x91, 0x10])));
        assert_eq!(e.stats().ignored_bytes, (RESET.len() + STATUS.len()) as u32);
        // Much later, in one read: the 90, nothing cut, nothing more.
        let got = drain(&mut e, 60_000_000);
        assert_eq!(got.len(), 29);
        assert_eq!(got[4], 0x90);
    }

    #[test]
    fn emulator_false_stx_given_up_after_idle() {
        let mut e = lms();
        // `02 00 FF 01`: a plausible header announcing 511 bytes, then a
        // real request that it hides until the line has been idle.
        e.receive(2_000_000, &[0x02, 0x00, 0xFF, 0x01]);
        e.receive(2_000_001, &STATUS);
        assert!(drain(&mut e, 2_040_000).is_empty());
        assert_eq!(e.next_wakeup_us(), Some(2_000_001 + RX_IDLE_TIMEOUT_US));
        let parts = split(&drain(&mut e, 2_300_000));
        assert_eq!(parts[0], [ACK]);
        assert_eq!(parts[1][4], 0xB1);
        assert!(e.stats().abandoned >= 1);
    }

    #[test]
    fn emulator_other_address_ignored_and_short_scans_padded() {
        let mut e = lms();
        let mut other = request(&[0x31]);
        other[1] = 0x05;
        let n = other.len() - 2;
        let crc = crc16(&other[..n]);
        other[n..].copy_from_slice(&crc.to_le_bytes());
        e.receive(2_000_000, &other);
        assert!(drain(&mut e, 3_000_000).is_empty());
        assert_eq!(events(&mut e), [Event::IgnoredAddress { address: 5 }]);

        let source = FnSource::new(|_, _, out| {
            out[0] = 77;
            1
        });
        let mut e = Emulator::new(source, Settings::default(), 0);
        e.receive(0, &ONE_SCAN);
        let parts = split(&drain(&mut e, 2_000_000));
        let b0 = &parts[2];
        assert_eq!(&b0[5..11], &[0xB5, 0x00, 77, 0, 0xFF, 0x1F]);
    }

    #[test]
    fn emulator_random_input_never_outruns_the_line() {
        // Garbage, valid requests (no baud change, no reset) and corrupted
        // ones in random chunks at random times, read out with random
        // buffer sizes: nothing panics, and at 9600 Bd no more than
        // 960 bytes per second ever leave.
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut rnd = move |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        let requests: [&[u8]; 7] = [
            &STATUS,
            &ONE_SCAN,
            &START,
            &STOP,
            &VARIANT_100_025,
            &READ_CONFIG,
            &SENSOR_TYPE,
        ];
        let mut e = Emulator::new(Ramp::default(), Settings::default(), 0);
        let mut now = 0u64;
        let mut sent = 0u64;
        let mut buf = [0u8; 1024];
        for _ in 0..20_000 {
            now += rnd(5_000);
            let mut input: Vec<u8> = match rnd(4) {
                0 => (0..rnd(40)).map(|_| rnd(256) as u8).collect(),
                1 => {
                    let mut r = requests[rnd(7) as usize].to_vec();
                    let at = rnd(r.len() as u64) as usize;
                    r[at] ^= 1 << rnd(8);
                    r
                }
                _ => requests[rnd(7) as usize].to_vec(),
            };
            while !input.is_empty() {
                let k = (1 + rnd(input.len() as u64)) as usize;
                e.receive(now, &input[..k]);
                input.drain(..k);
            }
            let cap = 1 + rnd(buf.len() as u64) as usize;
            sent += e.transmit(now, &mut buf[..cap]) as u64;
            assert!(
                sent <= now * 960 / 1_000_000 + 1,
                "{sent} bytes by {now} µs"
            );
            while e.next_event().is_some() {}
        }
        assert_eq!(e.baud(), Baud::B9600);
        assert!(e.stats().naks > 0 && e.stats().scans_sent > 0);
    }

    #[test]
    fn emulator_scan_timing_constants() {
        assert_eq!(line_time_us(732, Baud::B500000), 14_640);
        assert_eq!(line_time_us(732, Baud::B38400), 190_625);
        assert_eq!(scan_period_us(Variant::Fov180Res100), 13_333);
        assert_eq!(scan_period_us(Variant::Fov180Res50), 26_667);
        assert_eq!(scan_period_us(Variant::Fov100Res25), 53_333);
    }
}
