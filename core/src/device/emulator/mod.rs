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
//! | `20 2A` | `A0 00`; then one `B0` per mirror turn, each a partial scan (count word bit 13, bits 11–12 its offset in 0.25°; see [`partial_values`]); on the co-processor's face relayed to the sensor |
//! | `20 26 n`, `20 27 a b`, `20 28 n a b` | mean values, subrange, mean subrange ([`ValueMode`]): `A0 00`, then a stream of `B6` / `B7` / `BF` (one per `n` scans for the means); `A0 02` for bad parameters; on the co-processor's face ([`Settings::external_scans`]) relayed to the sensor ([`ScanSource::relay`]) |
//! | `77` | in installation mode: `F7 01` + the new configuration (units byte `[6]`: 0 cm, 1 mm; other codes are refused with `F7 00`); otherwise `F7 00` + the configuration kept |
//! | `10` | `ACK`, `91`; input ignored and the stream stopped; [`Settings::restart_us`] after the `91`, back to 9600 Bd, mode `25`, the power-on variant, and the `90` telegram. The configuration survives, as the real sensor keeps it in EEPROM. |
//!
//! Every reply ends with the status byte [`Settings::status`] (`0x10`).
//! With real-time indices in the configuration (availability byte `[4]`
//! bit 1, written with `77`), every `B0`, `B6`, `B7` and `BF` carries one
//! more byte after its values, the real-time scan index: the number of the
//! mirror scan it holds (since the stream started; for `30 01`, one more
//! than the last), modulo 256.
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

mod events;
mod requests;
mod settings;
mod source;
#[cfg(test)]
mod tests;
mod transmit;
mod value_modes;

pub use events::{EmulatorStats, Event, Handled};
pub use settings::{OperatingMode, Settings, MODE_PARTIAL};
pub use source::{FnSource, ScanSource, EXTRA_REPLY_CAPACITY};
pub use value_modes::{ValueMode, MODE_MEAN, MODE_MEAN_SUBRANGE, MODE_SUBRANGE};

use transmit::{Done, Outgoing, Pending, Stream};

use heapless::Deque;

use crate::frame::{Invalid, Variant};
use crate::maths::divisor;
use crate::telegram::crc::Crc;
use crate::telegram::measured::{count_word as measured_count_word, MEASURED_COMMAND};
use crate::telegram::partial_scan_flags;
use crate::telegram::reply::POWER_ON_LEN;
use crate::telegram::status::STATUS_BLOCK_LEN;
use crate::telegram::{
    copy_into, emit_telegram, Baud, Config, Direction, Event as FramerEvent, Framer, FramerStats,
    Handshake, Head, MeasuredValues, ModeResult, RangeBits, Reply, Request, SensorStatus,
    StatusBlock, StatusFields, VariantReply, ACK, CRC_LEN, DEFAULT_ADDRESS, DEFAULT_PASSWORD,
    DEFAULT_STATUS, HEADER_LEN, MAX_TELEGRAM_LEN, MAX_VALUES, NAK, REPLY_ADDRESS_BIT,
    SENSOR_TYPE_LMS200, STX,
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

/// Bytes of the request framer's buffer: the longest request an LMS 2xx
/// interprets, `77` with its 34-byte configuration (41 B), behind a false
/// start's 4-byte header, with room to spare. A longer request is
/// answered like any malformed one (`ACK`, `92`; `NAK` for a bad
/// checksum): its checksum is checked as it passes and only its header is
/// kept ([`Framer::with_capacity`], [`crate::telegram::Event::Long`]); it
/// reaches neither [`ScanSource::extra_command`] nor [`ScanSource::relay`].
pub const REQUEST_CAPACITY: usize = 64;

/// Requests (and runs of NAKs) waiting for the line.
pub const PENDING_CAPACITY: usize = 8;
/// `NAK`s one queue slot holds (a run of bad telegrams in a row).
pub const NAKS_PER_FRAME: usize = 64;
/// Events held until [`Emulator::next_event`] takes them.
pub const EVENT_CAPACITY: usize = 32;
/// Largest frame on the line: `ACK` + the largest telegram; the default
/// transmit buffer of an [`Emulator`].
pub const TX_CAPACITY: usize = 1 + MAX_TELEGRAM_LEN;
/// The smallest transmit buffer an [`Emulator`] takes: `ACK` + the largest
/// reply that is not a scan, the `B1` status telegram (161 B). With a buffer
/// below [`TX_CAPACITY`] the emulator streams each `B0` from
/// [`ScanSource::word`] (header in the buffer, values and a running CRC
/// produced byte by byte as they go out) and sends no value-mode telegrams
/// of its own (the co-processor's face relays the sensor's).
pub const MIN_TX_CAPACITY: usize = 1 + HEADER_LEN + 1 + STATUS_BLOCK_LEN + 1 + CRC_LEN;

/// Time the line needs for `bytes` bytes at `baud` (µs, rounded up): 10 bits
/// per byte. A 732-byte `B0` takes 14640 µs at 500000 Bd, 190625 µs at
/// 38400 Bd.
pub const fn line_time_us(bytes: usize, baud: Baud) -> u64 {
    let bits = (bytes as u64).saturating_mul(BITS_PER_BYTE);
    crate::maths::div_ceil_u64(
        bits.saturating_mul(US_PER_HUNDRED_BITS),
        divisor(hundred_bps(baud)),
    )
}

/// µs per second over 100: with [`hundred_bps`], `US_PER_HUNDRED_BITS /
/// hundred_bps` is `10⁶ / bps` exactly, and a scan's bits times it stay
/// within 32 bits, which the Cortex-M4 divides in hardware
/// ([`crate::maths::div_rem_u64`]).
pub(crate) const US_PER_HUNDRED_BITS: u64 = 10_000;

/// The rate `baud` in hundreds of bits per second (every LMS rate is a
/// whole number of hundreds: checked below).
pub(crate) const fn hundred_bps(baud: Baud) -> u64 {
    (baud.bits_per_second() / 100) as u64
}

const _: () = {
    let mut i = 0;
    while i < Baud::ALL.len() {
        assert!(Baud::ALL[i].bits_per_second() % 100 == 0);
        i += 1;
    }
};

/// Mirror turns per complete scan: 1 at 1°, 2 at 0.5° and 4 at 0.25°
/// (interlaced turns, PROTOCOL.md §3).
pub const fn turns_per_scan(variant: Variant) -> u64 {
    match variant.resolution_centideg() {
        100 => 1,
        50 => 2,
        _ => 4,
    }
}

/// The values of partial scan `part` (0 … turns − 1) of a `variant` scan:
/// the whole scan's values `part`, `part + turns`, `part + 2·turns`, …
/// (`turns` = [`turns_per_scan`]): every value of the 1° grid shifted by
/// `part` × the resolution that falls inside the field. So at 0.25° the
/// four partial scans have 101, 100, 100 and 100 values (offsets 0, 1, 2,
/// 3 × 0.25°), at 0.5° the two have 181 and 180 (offsets 0 and 2 × 0.25°)
/// or 101 and 100, and at 1° the one partial scan is the whole scan.
/// Returns the first index, the step and the count.
pub const fn partial_values(variant: Variant, part: u8) -> (usize, usize, usize) {
    let turns = match turns_per_scan(variant) as usize {
        0 => 1,
        t => t,
    };
    let first = (part as usize) % turns;
    let beams = variant.beams();
    let count = (beams - first).div_ceil(turns);
    (first, turns, count)
}

/// The count-word offset (in 0.25°) of partial scan `part` of `variant`.
/// (`turns` is never 0; the `match` says so to the link-time panic proof.)
pub const fn partial_offset_code(variant: Variant, part: u8) -> u8 {
    let turns = match turns_per_scan(variant) as u8 {
        0 => 1,
        t => t,
    };
    let step = (variant.resolution_centideg() / 25) as u8;
    (part % turns) * step
}

/// Time between complete scans in continuous mode (µs, rounded): 13333 at
/// 1°, 26667 at 0.5°, 53333 at 0.25°.
pub const fn scan_period_us(variant: Variant) -> u64 {
    crate::maths::div_u64(turns_per_scan(variant) * TURN_US_TIMES_3 + 1, divisor(3))
}

/// The simulated sensor (see the [module docs](self)). `TX` is its
/// transmit buffer in bytes: [`TX_CAPACITY`] (the default) holds any frame;
/// down to [`MIN_TX_CAPACITY`] a `B0` is streamed from the source instead.
pub struct Emulator<S, const TX: usize = TX_CAPACITY> {
    source: S,
    settings: Settings,
    baud: Baud,
    mode: OperatingMode,
    variant: Variant,
    config: Config,
    framer: Framer<REQUEST_CAPACITY>,
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
    /// The frame on the line: `tx[..tx_len]`, of which `tx_sent` handed out
    /// (a streamed `B0`: its first `streamed_head` bytes, see `streamed`).
    tx: [u8; TX],
    tx_len: usize,
    tx_sent: usize,
    tx_start_us: u64,
    tx_done: Done,
    /// The frame is a `B0` streamed from [`ScanSource::word`]: `tx` holds
    /// its first `streamed_head` bytes (`ACK`, header, count word), then
    /// come `streamed_values` words, the status byte and the CRC, whose
    /// running value is `streamed_crc`.
    streamed: bool,
    streamed_head: u8,
    streamed_values: u16,
    /// The streamed `B0`'s real-time index, if it has one.
    streamed_index: Option<u8>,
    streamed_crc: Crc,
    /// When the line finished the last frame (µs).
    line_free_us: u64,
    /// The real-time scan index of the last `B0` (mirror scans, modulo
    /// 256): sent after the values when the configuration asks for it.
    scan_index: u8,
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
        Emulator::off_sized(source, settings)
    }
}

impl<S: ScanSource, const TX: usize> Emulator<S, TX> {
    /// [`Emulator::off`] with a transmit buffer of `TX` bytes (at least
    /// [`MIN_TX_CAPACITY`], checked at compile time).
    pub const fn off_sized(source: S, settings: Settings) -> Self {
        const {
            assert!(
                TX >= MIN_TX_CAPACITY,
                "transmit buffer below MIN_TX_CAPACITY"
            )
        };
        let mut settings = settings;
        settings.address &= 0x7F;
        Emulator {
            source,
            settings,
            baud: Baud::B9600,
            mode: OperatingMode::OnRequest,
            variant: settings.variant,
            config: settings.config,
            framer: Framer::with_capacity(Direction::HostToSensor, Handshake::Ignored),
            last_rx_us: 0,
            resetting: false,
            restart_at_us: None,
            pending: Deque::new(),
            stream: None,
            external_stream: false,
            extra: [0; EXTRA_REPLY_CAPACITY],
            tx: [0; TX],
            tx_len: 0,
            tx_sent: 0,
            tx_start_us: 0,
            tx_done: Done::Nothing,
            streamed: false,
            streamed_head: 0,
            streamed_values: 0,
            streamed_index: None,
            streamed_crc: Crc::new(),
            line_free_us: 0,
            scan_index: 0,
            events: Deque::new(),
            stats: EmulatorStats::ZERO,
        }
    }

    /// [`Emulator::off`] with every byte zero but the source's (settings
    /// zero, mode `00`), for an all-zero `static`: [`set_settings`], then
    /// [`power_on`] sets the rest.
    ///
    /// [`set_settings`]: Emulator::set_settings
    /// [`power_on`]: Emulator::power_on
    pub const fn unpowered(source: S) -> Self {
        let zero = Settings {
            address: 0,
            variant: Variant::Fov180Res100,
            config: Config::ZERO,
            status: 0,
            restart_us: 0,
            external_scans: false,
        };
        let mut emulator = Emulator::off_sized(source, zero);
        emulator.mode = OperatingMode::Installation;
        emulator.framer.set_handshake(Handshake::Expected);
        emulator
    }

    /// Replace the settings of an emulator that is off (before
    /// [`Emulator::power_on`]; `const`, for a face built all-zero in a
    /// `static` and configured at start-up).
    pub const fn set_settings(&mut self, settings: Settings) {
        self.settings = settings;
        self.settings.address &= 0x7F;
        self.variant = settings.variant;
        self.config = settings.config;
    }

    /// Switch the sensor off and on at `now_us`: whatever was queued or on
    /// the line is lost; 9600 Bd, mode `25`, the power-on variant, the `90`
    /// telegram. The configuration is kept (EEPROM).
    pub fn power_on(&mut self, now_us: u64) {
        self.framer.set_handshake(Handshake::Ignored);
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
        self.streamed = false;
        self.line_free_us = now_us;
        // What was queued is lost: a relayed request too; and the client's
        // session ends.
        self.source.relay_dropped();
        self.source.new_session();
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

    /// Replace the configuration block (the co-processor's face takes the
    /// sensor's, so that `F4` tells the truth).
    pub fn set_config(&mut self, config: Config) {
        self.config = config;
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

    /// `true` while a frame has been handed out in part: the rest must
    /// follow before anything else goes on the line (a caller whose port
    /// took only part of it).
    pub fn frame_in_progress(&self) -> bool {
        self.tx_len != 0
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
    pub const fn source_mut(&mut self) -> &mut S {
        &mut self.source
    }
}
