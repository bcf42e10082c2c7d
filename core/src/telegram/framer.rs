//! A sans-I/O framer: bytes in, in any chunks; telegrams out, one at a time.
//!
//! The UART interrupt on the MCU and the serial loop on the host both feed
//! what they received into [`Framer::feed`], which returns at most one
//! [`Event`] and the input it has not consumed yet. Call it again with the
//! rest — and once more with an empty slice after the last event, since a
//! resynchronisation can leave further complete telegrams in the internal
//! buffer — until it returns no event:
//!
//! ```
//! use lms_core::telegram::{Direction, Event, Framer, Handshake};
//! let mut framer = Framer::new(Direction::HostToSensor, Handshake::Ignored);
//! let chunk = [0xFF, 0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12, 0x02, 0x00];
//! let mut input = &chunk[..];
//! let mut commands = [0u8; 4];
//! let mut n = 0;
//! loop {
//!     let fed = framer.feed(input);
//!     input = fed.remaining;
//!     match fed.event {
//!         Some(Event::Telegram(t)) => { commands[n] = t.command(); n += 1; }
//!         Some(_) => {}
//!         None => break,
//!     }
//! }
//! assert_eq!(&commands[..n], &[0x31]);
//! assert_eq!(framer.stats().bytes_skipped, 1); // the 0xFF
//! assert_eq!(framer.buffered(), 2); // `02 00` of the next telegram
//! ```
//!
//! How it finds telegrams:
//!
//! * Between telegrams every byte up to the next `STX` is skipped and
//!   counted; `ACK`/`NAK` bytes there are reported as events instead when the
//!   framer was made to expect them (the host side of the handshake).
//! * From an `STX` it reads the 4-byte header. A header is impossible when
//!   `LEN` is below the command (+ status) of the direction, above
//!   [`MAX_LEN`], or — sensor → host only — the address lacks the `0x80` bit.
//! * Otherwise it collects `6 + LEN` bytes and checks the CRC.
//! * After an impossible header or a bad CRC it drops only the false `STX`
//!   and re-scans the bytes it had collected after it, so a real telegram
//!   hidden behind a false start (a truncated telegram, a `02` inside data)
//!   is still found.
//!
//! A sensor-side user (a simulator) answers a bad checksum with `NAK`: each
//! [`Feed`] says how many candidates failed their CRC during that call.
//!
//! Every byte fed ends up in exactly one place, so at any time
//! `bytes fed = Σ telegram lengths + acks + naks + bytes_skipped +
//! buffered()` (until the counters wrap at 2³²; a [`Event::Long`] is
//! `6 + len` bytes).
//!
//! The framer never allocates and never panics: its buffer is a fixed
//! array, [`MAX_TELEGRAM_LEN`] bytes by default, and no candidate telegram
//! is longer. A smaller buffer ([`Framer::with_capacity`], e.g. for
//! requests, which are short) keeps the first bytes of a longer telegram
//! and checks the checksum of the rest as it passes: a correct one is
//! reported as [`Event::Long`] (its header only), a wrong one is counted
//! like any other, and the bytes the buffer holds are re-scanned.
//! It keeps no clock: a caller with a receive timeout calls
//! [`Framer::abandon`] when the line goes idle (so a real telegram held
//! back behind a false `STX` with a long `LEN` is still found), or
//! [`Framer::discard`] to drop everything (e.g. after a baud-rate change).

use super::crc::{crc16, Crc};
use super::packet::Telegram;
use super::{
    le_u16, Direction, ACK, CRC_LEN, HEADER_LEN, MAX_LEN, MAX_TELEGRAM_LEN, NAK, REPLY_ADDRESS_BIT,
    STX,
};

/// What [`Framer::feed`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event<'a> {
    /// A complete telegram with a correct CRC, borrowed from the framer's
    /// buffer until the next call to [`Framer::feed`].
    Telegram(Telegram<&'a [u8]>),
    /// An `ACK` byte (0x06) between telegrams (handshake mode only).
    Ack,
    /// A `NAK` byte (0x15) between telegrams (handshake mode only).
    Nak,
    /// A telegram longer than the buffer of a framer made with
    /// [`Framer::with_capacity`] (never from [`Framer::new`]), its checksum
    /// correct: only its header was kept. `len` is its `LEN` field
    /// (command to checksum, exclusive: the telegram is `6 + len` bytes).
    Long {
        /// The `ADDR` byte.
        address: u8,
        /// The command byte.
        command: u8,
        /// The `LEN` field.
        len: u16,
    },
}

/// The result of one [`Framer::feed`] call.
#[must_use = "feed `remaining` again until `event` is None"]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Feed<'f, 'i> {
    /// The event found, if any. `None` means all input was consumed and no
    /// complete telegram is left in the buffer.
    pub event: Option<Event<'f>>,
    /// The input not consumed yet: feed it next.
    pub remaining: &'i [u8],
    /// Candidates rejected for a bad checksum during this call (also
    /// counted in [`FramerStats::crc_errors`]). A sensor-side user answers
    /// with `NAK` when this is not 0, before handling `event`.
    pub crc_errors: u32,
}

/// Counters of everything the framer saw (all wrap at 2³²).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FramerStats {
    /// Telegrams delivered (correct CRC).
    pub telegrams: u32,
    /// `ACK` bytes delivered (handshake mode).
    pub acks: u32,
    /// `NAK` bytes delivered (handshake mode).
    pub naks: u32,
    /// Candidates of plausible length whose CRC did not match (a corrupted
    /// or truncated telegram, or a false `STX`).
    pub crc_errors: u32,
    /// Candidates with `LEN` above [`MAX_LEN`].
    pub oversize: u32,
    /// Candidates with `LEN` too short for the direction, or (sensor →
    /// host) an address without the `0x80` bit.
    pub bad_headers: u32,
    /// Candidates given up by [`Framer::abandon`] (a timeout).
    pub abandoned: u32,
    /// Re-scans after a false start (`crc_errors + oversize + bad_headers +
    /// abandoned`).
    pub resyncs: u32,
    /// Bytes thrown away: garbage between telegrams, false `STX` bytes, and
    /// bytes dropped by [`Framer::discard`].
    pub bytes_skipped: u32,
}

/// What one step of the scan found (before borrowing the buffer).
enum Found {
    Nothing,
    Ack,
    Nak,
    /// A telegram of this many bytes at the front of the buffer.
    Telegram(usize),
    /// A telegram longer than the buffer, checksum correct.
    Long {
        address: u8,
        command: u8,
        len: u16,
    },
}

/// What the buffered candidate (starting with `STX`) needs next.
enum Candidate {
    /// This many bytes in total before it can be judged.
    Need(usize),
    /// A complete telegram of this many bytes with a correct CRC.
    Complete(usize),
    /// Not a telegram; the counter to bump.
    False(FalseStart),
}

/// Why a candidate was given up.
enum FalseStart {
    Crc,
    Oversize,
    BadHeader,
}

/// Whether `ACK`/`NAK` bytes between telegrams mean something to a framer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Handshake {
    /// `ACK`/`NAK` bytes between telegrams are reported as events (the host
    /// side reading a sensor).
    Expected,
    /// `ACK`/`NAK` bytes are skipped like any garbage (the sensor side
    /// reading requests, or a stream without handshake).
    Ignored,
}

impl Handshake {
    const fn is_expected(self) -> bool {
        matches!(self, Handshake::Expected)
    }
}

/// Smallest buffer a [`Framer`] takes: the shortest telegram (header,
/// command, status, CRC).
pub const MIN_CAPACITY: usize = HEADER_LEN + 2 + CRC_LEN;

/// The framer (see the [module docs](self)). `N` is its buffer in bytes:
/// [`MAX_TELEGRAM_LEN`] (the default, [`Framer::new`]) holds every
/// telegram; a smaller one ([`Framer::with_capacity`]) keeps the first `N`
/// bytes of a longer telegram and checks the rest's CRC as it passes
/// ([`Event::Long`]).
#[derive(Clone, Debug)]
pub struct Framer<const N: usize = MAX_TELEGRAM_LEN> {
    buf: [u8; N],
    /// Everything but the buffer; its code is shared by every `N`.
    state: State,
}

/// A [`Framer`]'s state besides its buffer.
#[derive(Clone, Debug)]
struct State {
    /// Bytes held in the buffer.
    len: usize,
    /// Bytes at the front of the buffer handed out as a telegram, dropped
    /// at the start of the next call.
    delivered: usize,
    /// A candidate longer than the buffer being checked.
    long: Long,
    direction: Direction,
    handshake: Handshake,
    stats: FramerStats,
}

/// A candidate longer than the buffer: its first bytes fill the buffer,
/// the rest only pass through the checksum.
#[derive(Clone, Copy, Debug)]
struct Long {
    /// Its length in bytes (0: no such candidate; at most
    /// [`MAX_TELEGRAM_LEN`]).
    total: u16,
    /// Bytes of it seen so far (the buffer's and those passed through).
    seen: u16,
    /// The checksum of the bytes it covers, so far.
    crc: Crc,
    /// The checksum bytes as they came.
    sent: [u8; CRC_LEN],
}

impl Long {
    const NONE: Long = Long {
        total: 0,
        seen: 0,
        crc: Crc::new(),
        sent: [0; CRC_LEN],
    };

    /// Take the next byte of the candidate.
    fn push(&mut self, b: u8) {
        let covered = self.total.saturating_sub(CRC_LEN as u16);
        match self.seen.checked_sub(covered) {
            None => self.crc.push(b),
            Some(k) => {
                if let Some(slot) = self.sent.get_mut(usize::from(k)) {
                    *slot = b;
                }
            }
        }
        self.seen = self.seen.saturating_add(1);
    }
}

impl Framer {
    /// Size of the default buffer in bytes (the largest telegram).
    pub const CAPACITY: usize = MAX_TELEGRAM_LEN;

    /// A framer for telegrams travelling in `direction` that holds every
    /// telegram ([`MAX_TELEGRAM_LEN`] bytes); `handshake` says whether
    /// `ACK`/`NAK` bytes between telegrams are events.
    pub const fn new(direction: Direction, handshake: Handshake) -> Self {
        Framer::with_capacity(direction, handshake)
    }
}

impl<const N: usize> Framer<N> {
    /// A framer with an `N`-byte buffer (at least [`MIN_CAPACITY`],
    /// checked at compile time): a telegram of up to `N` bytes is handed
    /// out whole ([`Event::Telegram`]); of a longer one only its header is
    /// kept and the checksum of the rest is computed as it passes
    /// ([`Event::Long`]). A false `STX` with a long `LEN` is then re-scanned
    /// only as far as the buffer holds (the bytes passed through are
    /// counted as skipped).
    pub const fn with_capacity(direction: Direction, handshake: Handshake) -> Self {
        const { assert!(N >= MIN_CAPACITY, "framer buffer below MIN_CAPACITY") };
        Framer {
            buf: [0; N],
            state: State {
                len: 0,
                delivered: 0,
                long: Long::NONE,
                direction,
                handshake,
                stats: FramerStats {
                    telegrams: 0,
                    acks: 0,
                    naks: 0,
                    crc_errors: 0,
                    oversize: 0,
                    bad_headers: 0,
                    abandoned: 0,
                    resyncs: 0,
                    bytes_skipped: 0,
                },
            },
        }
    }

    /// The direction given at construction.
    #[inline]
    pub fn direction(&self) -> Direction {
        self.state.direction
    }

    /// Whether `ACK`/`NAK` bytes are reported.
    #[inline]
    pub fn handshake(&self) -> Handshake {
        self.state.handshake
    }

    /// Frame telegrams travelling in `direction` from now on (a framer built
    /// all-zero in a `static` is given its direction at start-up).
    #[inline]
    pub const fn set_direction(&mut self, direction: Direction) {
        self.state.direction = direction;
    }

    /// Report `ACK`/`NAK` bytes from now on (or stop, e.g. in continuous
    /// mode, where the sensor sends none).
    #[inline]
    pub const fn set_handshake(&mut self, handshake: Handshake) {
        self.state.handshake = handshake;
    }

    /// The counters so far.
    #[inline]
    pub fn stats(&self) -> &FramerStats {
        &self.state.stats
    }

    /// Zero the counters.
    #[inline]
    pub fn reset_stats(&mut self) {
        self.state.stats = FramerStats::default();
    }

    /// The telegram handed out by the last [`feed`](Framer::feed), until the
    /// next `feed`, [`abandon`](Framer::abandon) or
    /// [`discard`](Framer::discard) (empty if that call found none): read
    /// it here rather than copy it out.
    #[inline]
    pub fn delivered(&self) -> &[u8] {
        self.buf.get(..self.state.delivered).unwrap_or_default()
    }

    /// Bytes held for a telegram not complete yet (not counting a telegram
    /// already delivered; counting those of a long one passed through).
    #[inline]
    pub fn buffered(&self) -> usize {
        self.state.buffered(N)
    }

    /// Give up the telegram being collected, e.g. when the line has been
    /// idle too long: its `STX` is dropped (counted as skipped) and the bytes
    /// after it are re-scanned by the next [`feed`](Framer::feed) — call
    /// `feed(&[])` to drain them. This finds a real telegram that a false
    /// `STX` with a long `LEN` was holding back while no more bytes come.
    /// Returns `false` if no telegram was being collected.
    pub fn abandon(&mut self) -> bool {
        self.state.abandon(&mut self.buf)
    }

    /// Drop everything buffered (e.g. after a baud-rate change);
    /// the bytes count as skipped. Returns how many were dropped.
    pub fn discard(&mut self) -> usize {
        self.state.discard(&mut self.buf)
    }

    /// Feed received bytes; see the [module docs](self) for the loop.
    pub fn feed<'f, 'i>(&'f mut self, input: &'i [u8]) -> Feed<'f, 'i> {
        let (found, remaining, crc_errors) = self.state.feed(&mut self.buf, input);
        let event = match found {
            Found::Nothing => None,
            Found::Ack => Some(Event::Ack),
            Found::Nak => Some(Event::Nak),
            Found::Long {
                address,
                command,
                len,
            } => Some(Event::Long {
                address,
                command,
                len,
            }),
            Found::Telegram(total) => {
                let bytes: &'f [u8] = self.buf.get(..total).unwrap_or_default();
                Some(Event::Telegram(Telegram::new_unchecked(
                    bytes,
                    self.state.direction,
                )))
            }
        };
        Feed {
            event,
            remaining,
            crc_errors,
        }
    }
}

/// The framer's logic, on the buffer `buf` (one copy in flash for every
/// buffer size).
impl State {
    fn buffered(&self, capacity: usize) -> usize {
        let passed = match self.long.total {
            0 => 0,
            _ => usize::from(self.long.seen).saturating_sub(capacity),
        };
        self.len
            .saturating_sub(self.delivered)
            .saturating_add(passed)
    }

    fn abandon(&mut self, buf: &mut [u8]) -> bool {
        self.release_delivered(buf);
        if self.front(buf) != Some(STX) {
            return false;
        }
        self.drop_long(buf.len());
        self.stats.abandoned = self.stats.abandoned.wrapping_add(1);
        self.stats.resyncs = self.stats.resyncs.wrapping_add(1);
        self.skip(buf, 1);
        true
    }

    fn discard(&mut self, buf: &mut [u8]) -> usize {
        self.release_delivered(buf);
        let n = self.buffered(buf.len());
        self.drop_long(buf.len());
        self.skip(buf, self.len);
        n
    }

    /// What one `feed` found, the input left, and the CRC errors it met.
    fn feed<'i>(&mut self, buf: &mut [u8], input: &'i [u8]) -> (Found, &'i [u8], u32) {
        self.release_delivered(buf);
        let crc_start = self.stats.crc_errors;
        let (found, remaining) = self.step(buf, input);
        if let Found::Telegram(total) = found {
            self.delivered = total;
        }
        let crc_errors = self.stats.crc_errors.wrapping_sub(crc_start);
        (found, remaining, crc_errors)
    }

    /// Consume input until something is found or the input runs out.
    fn step<'i>(&mut self, buf: &mut [u8], input: &'i [u8]) -> (Found, &'i [u8]) {
        let mut input = input;
        loop {
            if self.long.total != 0 {
                let (found, rest) = self.pass_long(buf, input);
                input = rest;
                match found {
                    Found::Nothing if self.long.total != 0 => return (found, input),
                    Found::Nothing => continue,
                    _ => return (found, input),
                }
            }
            // Buffer holds unsynchronised bytes (left over from a re-scan):
            // bring an STX to the front, or report a handshake byte.
            if self.len > 0 && self.front(buf) != Some(STX) {
                if let Some(found) = self.sync_buffer(buf) {
                    return (found, input);
                }
                continue;
            }
            if self.len == 0 {
                // Nothing buffered: scan the input directly.
                let Some(at) = input.iter().position(|&b| self.is_marker(b)) else {
                    self.count_skipped(input.len());
                    return (Found::Nothing, input.get(input.len()..).unwrap_or_default());
                };
                self.count_skipped(at);
                let marker = input.get(at).copied().unwrap_or(STX);
                input = input.get(at + 1..).unwrap_or_default();
                match self.handshake_byte(marker) {
                    Some(found) => return (found, input),
                    None => self.push(buf, &[STX]),
                }
                continue;
            }
            // buf[0] == STX: judge the candidate.
            match self.candidate(buf) {
                Candidate::Complete(total) => {
                    self.stats.telegrams = self.stats.telegrams.wrapping_add(1);
                    return (Found::Telegram(total), input);
                }
                Candidate::False(why) => {
                    self.false_start(why);
                    // Drop the false STX only; re-scan what follows it.
                    self.skip(buf, 1);
                }
                Candidate::Need(total) => {
                    if input.is_empty() {
                        return (Found::Nothing, input);
                    }
                    if total > buf.len() && self.len >= buf.len() {
                        self.begin_long(buf, total);
                        continue;
                    }
                    let want = total
                        .min(buf.len())
                        .saturating_sub(self.len)
                        .min(input.len());
                    let (take, rest) = input.split_at_checked(want).unwrap_or((input, &[]));
                    self.push(buf, take);
                    input = rest;
                }
            }
        }
    }

    /// Count a false start.
    fn false_start(&mut self, why: FalseStart) {
        let counter = match why {
            FalseStart::Crc => &mut self.stats.crc_errors,
            FalseStart::Oversize => &mut self.stats.oversize,
            FalseStart::BadHeader => &mut self.stats.bad_headers,
        };
        *counter = counter.wrapping_add(1);
        self.stats.resyncs = self.stats.resyncs.wrapping_add(1);
    }

    /// The buffer is full with the start of a `total`-byte candidate: check
    /// the rest as it passes.
    fn begin_long(&mut self, buf: &[u8], total: usize) {
        self.long = Long {
            // `total` <= MAX_TELEGRAM_LEN (the header was judged possible).
            total: u16::try_from(total).unwrap_or(u16::MAX),
            ..Long::NONE
        };
        for &b in buf.get(..self.len).unwrap_or_default() {
            self.long.push(b);
        }
    }

    /// Pass input through the long candidate's checksum; when it is
    /// complete, report it (CRC right) or drop its `STX` and re-scan the
    /// buffer (CRC wrong; the bytes passed through count as skipped).
    fn pass_long<'i>(&mut self, buf: &mut [u8], input: &'i [u8]) -> (Found, &'i [u8]) {
        let need = usize::from(self.long.total.saturating_sub(self.long.seen));
        let (take, rest) = input
            .split_at_checked(need.min(input.len()))
            .unwrap_or((input, &[]));
        for &b in take {
            self.long.push(b);
        }
        if self.long.seen < self.long.total {
            return (Found::Nothing, rest);
        }
        let ok = self.long.crc.value() == u16::from_le_bytes(self.long.sent);
        let len = le_u16(buf, 2);
        let (address, command) = (buf.get(1).copied(), buf.get(HEADER_LEN).copied());
        if ok {
            self.long = Long::NONE;
            self.stats.telegrams = self.stats.telegrams.wrapping_add(1);
            self.drop_front(buf, self.len);
            let found = Found::Long {
                address: address.unwrap_or(0),
                command: command.unwrap_or(0),
                len,
            };
            return (found, rest);
        }
        self.drop_long(buf.len());
        self.false_start(FalseStart::Crc);
        self.skip(buf, 1);
        (Found::Nothing, rest)
    }

    /// Give up a long candidate: the bytes passed through are skipped.
    fn drop_long(&mut self, capacity: usize) {
        if self.long.total != 0 {
            self.count_skipped(usize::from(self.long.seen).saturating_sub(capacity));
        }
        self.long = Long::NONE;
    }

    /// Drop the telegram handed out by the previous call.
    fn release_delivered(&mut self, buf: &mut [u8]) {
        let n = self.delivered;
        self.delivered = 0;
        self.drop_front(buf, n);
    }

    /// First buffered byte.
    #[inline]
    fn front(&self, buf: &[u8]) -> Option<u8> {
        if self.len == 0 {
            None
        } else {
            buf.first().copied()
        }
    }

    /// `true` for bytes that end a skip: `STX`, and `ACK`/`NAK` in
    /// handshake mode.
    #[inline]
    fn is_marker(&self, b: u8) -> bool {
        b == STX || (self.handshake.is_expected() && (b == ACK || b == NAK))
    }

    /// A handshake byte (counted), `None` for `STX`.
    fn handshake_byte(&mut self, b: u8) -> Option<Found> {
        if !self.handshake.is_expected() {
            return None;
        }
        match b {
            ACK => {
                self.stats.acks = self.stats.acks.wrapping_add(1);
                Some(Found::Ack)
            }
            NAK => {
                self.stats.naks = self.stats.naks.wrapping_add(1);
                Some(Found::Nak)
            }
            _ => None,
        }
    }

    /// Skip buffered bytes up to the next marker; report (and drop) a
    /// handshake byte found at the front.
    fn sync_buffer(&mut self, buf: &mut [u8]) -> Option<Found> {
        let held = buf.get(..self.len).unwrap_or_default();
        match held.iter().position(|&b| self.is_marker(b)) {
            None => {
                self.skip(buf, self.len);
                None
            }
            Some(0) => {
                let b = self.front(buf).unwrap_or(STX);
                let event = self.handshake_byte(b);
                if event.is_some() {
                    self.drop_front(buf, 1);
                } else {
                    // The front is a handshake byte, so this is never taken;
                    // were it taken, skipping the byte keeps the caller's
                    // loop making progress.
                    debug_assert!(false, "handshake byte not recognised");
                    self.skip(buf, 1);
                }
                event
            }
            Some(at) => {
                self.skip(buf, at);
                None
            }
        }
    }

    /// Judge the candidate at the front of the buffer (which is `STX`).
    fn candidate(&self, buf: &[u8]) -> Candidate {
        if self.len < HEADER_LEN {
            return Candidate::Need(HEADER_LEN);
        }
        let addr = buf.get(1).copied().unwrap_or(0);
        let len = usize::from(le_u16(buf, 2));
        if len > MAX_LEN {
            return Candidate::False(FalseStart::Oversize);
        }
        let bad_addr = self.direction == Direction::SensorToHost && addr & REPLY_ADDRESS_BIT == 0;
        if len < self.direction.min_len() || bad_addr {
            return Candidate::False(FalseStart::BadHeader);
        }
        let total = HEADER_LEN + len + CRC_LEN;
        if self.len < total {
            return Candidate::Need(total);
        }
        let covered = buf.get(..total - CRC_LEN).unwrap_or_default();
        if crc16(covered) == le_u16(buf, total - CRC_LEN) {
            Candidate::Complete(total)
        } else {
            Candidate::False(FalseStart::Crc)
        }
    }

    /// Append bytes (as many as fit; callers never offer more).
    fn push(&mut self, buf: &mut [u8], bytes: &[u8]) {
        let start = self.len.min(buf.len());
        let n = bytes.len().min(buf.len() - start);
        if let Some(dst) = buf.get_mut(start..start + n) {
            super::copy_into(dst, bytes);
            self.len = start + n;
        }
    }

    /// Drop `n` bytes from the front, counting them as skipped.
    fn skip(&mut self, buf: &mut [u8], n: usize) {
        let n = n.min(self.len);
        self.count_skipped(n);
        self.drop_front(buf, n);
    }

    /// Drop `n` bytes from the front without counting.
    fn drop_front(&mut self, buf: &mut [u8], n: usize) {
        let len = self.len.min(buf.len());
        let n = n.min(len);
        if n == 0 {
            return;
        }
        // A byte loop rather than `copy_within`, whose range check would
        // leave a panic path in the binary.
        for i in 0..len - n {
            let b = buf.get(i + n).copied().unwrap_or(0);
            if let Some(d) = buf.get_mut(i) {
                *d = b;
            }
        }
        self.len = len - n;
    }

    /// Count `n` skipped bytes.
    #[inline]
    fn count_skipped(&mut self, n: usize) {
        // Saturate a huge chunk to u32 before the wrapping add.
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        self.stats.bytes_skipped = self.stats.bytes_skipped.wrapping_add(n);
    }
}

impl Default for Framer {
    /// A host-side framer: sensor → host with `ACK`/`NAK` events.
    fn default() -> Self {
        Framer::new(Direction::SensorToHost, Handshake::Expected)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feed everything; collect (kind, bytes) of each event.
    fn run(framer: &mut Framer, input: &[u8], out: &mut std::vec::Vec<std::vec::Vec<u8>>) {
        let mut input = input;
        loop {
            let fed = framer.feed(input);
            input = fed.remaining;
            match fed.event {
                Some(Event::Telegram(t)) => out.push(t.as_bytes().to_vec()),
                Some(Event::Ack) => out.push(std::vec![ACK]),
                Some(Event::Nak) => out.push(std::vec![NAK]),
                Some(Event::Long { .. }) => panic!("a full-size framer holds every telegram"),
                None => {
                    assert!(input.is_empty());
                    break;
                }
            }
        }
    }

    const A0: [u8; 9] = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
    const R92: [u8; 8] = [0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33];

    #[test]
    fn telegram_framer_truncated_then_good() {
        // A0 cut after 5 bytes, then a complete 92.
        let mut stream = std::vec::Vec::new();
        stream.extend_from_slice(&A0[..5]);
        stream.extend_from_slice(&R92);
        let mut f = Framer::new(Direction::SensorToHost, Handshake::Expected);
        let mut out = std::vec::Vec::new();
        run(&mut f, &stream, &mut out);
        assert_eq!(out, std::vec![R92.to_vec()]);
        let s = f.stats();
        assert_eq!(s.telegrams, 1);
        assert_eq!(s.crc_errors, 1);
        assert_eq!(s.resyncs, 1);
        // False STX + `80 03 00 A0`.
        assert_eq!(s.bytes_skipped, 5);
        assert_eq!(f.buffered(), 0);
    }

    #[test]
    fn telegram_framer_handshake_inside_rescan() {
        // Truncated A0 header, then ACK and a complete A0: the ACK sits in
        // the bytes swallowed by the false candidate and is still reported.
        let mut stream = std::vec::Vec::new();
        stream.extend_from_slice(&A0[..4]);
        stream.push(ACK);
        stream.extend_from_slice(&A0);
        let mut f = Framer::new(Direction::SensorToHost, Handshake::Expected);
        let mut out = std::vec::Vec::new();
        run(&mut f, &stream, &mut out);
        assert_eq!(out, std::vec![std::vec![ACK], A0.to_vec()]);
        assert_eq!(f.stats().crc_errors, 1);
        assert_eq!(f.stats().bytes_skipped, 4);
        // Without handshake the ACK is garbage.
        let mut f = Framer::new(Direction::SensorToHost, Handshake::Ignored);
        let mut out = std::vec::Vec::new();
        run(&mut f, &stream, &mut out);
        assert_eq!(out, std::vec![A0.to_vec()]);
        assert_eq!(f.stats().bytes_skipped, 5);
    }

    #[test]
    fn telegram_framer_headers() {
        let mut f = Framer::new(Direction::SensorToHost, Handshake::Ignored);
        let mut out = std::vec::Vec::new();
        // Address without 0x80, LEN 1, LEN 813: each a false STX.
        run(&mut f, &[0x02, 0x00, 0x03, 0x00], &mut out);
        run(&mut f, &[0x02, 0x80, 0x01, 0x00], &mut out);
        run(&mut f, &[0x02, 0x80, 0x2D, 0x03], &mut out);
        run(&mut f, &A0, &mut out);
        assert_eq!(out, std::vec![A0.to_vec()]);
        let s = *f.stats();
        assert_eq!(
            s,
            FramerStats {
                telegrams: 1,
                acks: 0,
                naks: 0,
                crc_errors: 0,
                oversize: 1,
                bad_headers: 2,
                abandoned: 0,
                resyncs: 3,
                bytes_skipped: 12,
            }
        );
        // Host side accepts address 0 and LEN 1.
        let mut h = Framer::new(Direction::HostToSensor, Handshake::Ignored);
        let mut out = std::vec::Vec::new();
        run(
            &mut h,
            &[0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12],
            &mut out,
        );
        assert_eq!(out.len(), 1);
        assert_eq!(h.stats().telegrams, 1);
    }

    /// A host telegram of `payload` (command, data) with a correct CRC.
    fn request(payload: &[u8]) -> std::vec::Vec<u8> {
        let len = payload.len() as u16;
        let mut v = std::vec![STX, 0x00];
        v.extend_from_slice(&len.to_le_bytes());
        v.extend_from_slice(payload);
        let crc = crc16(&v);
        v.extend_from_slice(&crc.to_le_bytes());
        v
    }

    /// Feed `stream` to a 16-byte framer in chunks of `chunk`; the events
    /// (a long telegram as `[command, len lo, len hi]`) and the framer.
    fn run_small(stream: &[u8], chunk: usize) -> (std::vec::Vec<std::vec::Vec<u8>>, Framer<16>) {
        let mut f = Framer::<16>::with_capacity(Direction::HostToSensor, Handshake::Ignored);
        let mut out = std::vec::Vec::new();
        for piece in stream.chunks(chunk) {
            let mut input = piece;
            loop {
                let fed = f.feed(input);
                input = fed.remaining;
                match fed.event {
                    Some(Event::Telegram(t)) => out.push(t.as_bytes().to_vec()),
                    Some(Event::Long { command, len, .. }) => {
                        let [lo, hi] = len.to_le_bytes();
                        out.push(std::vec![command, lo, hi]);
                    }
                    Some(_) => out.push(std::vec![]),
                    None => break,
                }
            }
        }
        (out, f)
    }

    #[test]
    fn telegram_framer_long_request_checked_as_it_passes() {
        // 40 data bytes: 47 in all, 16 kept; then a status request.
        let long = request(&[&[0x77][..], &[0xA5; 40][..]].concat());
        let status = request(&[0x31]);
        let stream = [&long[..], &status[..]].concat();
        for chunk in [1, 5, 16, 17, stream.len()] {
            let (out, f) = run_small(&stream, chunk);
            assert_eq!(
                out,
                std::vec![std::vec![0x77, 41, 0], status.clone()],
                "chunk {chunk}"
            );
            assert_eq!(f.stats().telegrams, 2);
            assert_eq!(f.stats().crc_errors, 0);
            assert_eq!(f.stats().bytes_skipped, 0);
            assert_eq!(f.buffered(), 0);
        }
        // Cut short: the bytes passed through are held until it completes.
        let (out, f) = run_small(&long[..30], 30);
        assert!(out.is_empty());
        assert_eq!(f.buffered(), 30);
    }

    #[test]
    fn telegram_framer_long_request_with_bad_crc_is_counted_and_resyncs() {
        let mut long = request(&[&[0x77][..], &[0xA5; 40][..]].concat());
        // A byte beyond the kept 16 is corrupted: only the checksum can tell.
        long[30] ^= 0x01;
        let status = request(&[0x31]);
        let stream = [&long[..], &status[..]].concat();
        for chunk in [1, 7, stream.len()] {
            let (out, f) = run_small(&stream, chunk);
            assert_eq!(out, std::vec![status.clone()], "chunk {chunk}");
            let s = f.stats();
            assert_eq!((s.crc_errors, s.resyncs, s.telegrams), (1, 1, 1));
            // Every byte of the bad one is skipped (its STX, the 15 kept
            // ones re-scanned, the 31 passed through).
            assert_eq!(s.bytes_skipped as usize, long.len());
            assert_eq!(f.buffered(), 0);
        }
    }

    #[test]
    fn telegram_framer_false_long_start_gives_up_what_the_buffer_holds() {
        // A false header announcing 511 bytes, then a real request: found
        // when the line goes idle (`abandon`), as the buffer holds it.
        let status = request(&[0x31]);
        let stream = [&[STX, 0x00, 0xFF, 0x01][..], &status[..]].concat();
        let (out, mut f) = run_small(&stream, 3);
        assert!(out.is_empty());
        assert!(f.abandon());
        let fed = f.feed(&[]);
        let found = match fed.event {
            Some(Event::Telegram(t)) => t.as_bytes().to_vec(),
            _ => std::vec![],
        };
        assert_eq!(found, status);
        assert_eq!(f.stats().abandoned, 1);
        assert_eq!(f.stats().bytes_skipped, 4);
        // Longer than the buffer: what passed through is skipped when it
        // is given up, and `discard` counts a long one whole.
        let garbage = [&[STX, 0x00, 0xFF, 0x01][..], &[0x55; 40][..]].concat();
        let (_, mut f) = run_small(&garbage, 44);
        assert_eq!(f.buffered(), 44);
        assert_eq!(f.discard(), 44);
        assert_eq!((f.buffered(), f.stats().bytes_skipped), (0, 44));
    }

    #[test]
    fn telegram_framer_discard() {
        let mut f = Framer::default();
        let mut out = std::vec::Vec::new();
        run(&mut f, &A0[..6], &mut out);
        assert_eq!(f.buffered(), 6);
        assert_eq!(f.discard(), 6);
        assert_eq!(f.buffered(), 0);
        run(&mut f, &A0, &mut out);
        assert_eq!(out, std::vec![A0.to_vec()]);
        assert_eq!(f.stats().bytes_skipped, 6);
        f.reset_stats();
        assert_eq!(*f.stats(), FramerStats::default());
    }
}
