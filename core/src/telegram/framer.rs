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
//! buffered()` (until the counters wrap at 2³²).
//!
//! The framer never allocates and never panics: its buffer is a fixed
//! [`MAX_TELEGRAM_LEN`]-byte array, and no candidate telegram is longer.
//! It keeps no clock: a caller with a receive timeout calls
//! [`Framer::abandon`] when the line goes idle (so a real telegram held
//! back behind a false `STX` with a long `LEN` is still found), or
//! [`Framer::discard`] to drop everything (e.g. after a baud-rate change).

use super::crc::crc16;
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

/// The framer (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct Framer {
    buf: [u8; MAX_TELEGRAM_LEN],
    /// Bytes held in `buf`.
    len: usize,
    /// Bytes at the front of `buf` handed out as a telegram, dropped at the
    /// start of the next call.
    delivered: usize,
    direction: Direction,
    handshake: Handshake,
    stats: FramerStats,
}

impl Framer {
    /// Size of the internal buffer in bytes (the largest telegram).
    pub const CAPACITY: usize = MAX_TELEGRAM_LEN;

    /// A framer for telegrams travelling in `direction`; `handshake` says
    /// whether `ACK`/`NAK` bytes between telegrams are events.
    pub const fn new(direction: Direction, handshake: Handshake) -> Self {
        Framer {
            buf: [0; MAX_TELEGRAM_LEN],
            len: 0,
            delivered: 0,
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
        }
    }

    /// The direction given at construction.
    #[inline]
    pub fn direction(&self) -> Direction {
        self.direction
    }

    /// Whether `ACK`/`NAK` bytes are reported.
    #[inline]
    pub fn handshake(&self) -> Handshake {
        self.handshake
    }

    /// Frame telegrams travelling in `direction` from now on (a framer built
    /// all-zero in a `static` is given its direction at start-up).
    #[inline]
    pub const fn set_direction(&mut self, direction: Direction) {
        self.direction = direction;
    }

    /// Report `ACK`/`NAK` bytes from now on (or stop, e.g. in continuous
    /// mode, where the sensor sends none).
    #[inline]
    pub const fn set_handshake(&mut self, handshake: Handshake) {
        self.handshake = handshake;
    }

    /// The counters so far.
    #[inline]
    pub fn stats(&self) -> &FramerStats {
        &self.stats
    }

    /// Zero the counters.
    #[inline]
    pub fn reset_stats(&mut self) {
        self.stats = FramerStats::default();
    }

    /// The telegram handed out by the last [`feed`](Framer::feed), until the
    /// next `feed`, [`abandon`](Framer::abandon) or
    /// [`discard`](Framer::discard) (empty if that call found none): read
    /// it here rather than copy it out.
    #[inline]
    pub fn delivered(&self) -> &[u8] {
        self.buf.get(..self.delivered).unwrap_or_default()
    }

    /// Bytes held for a telegram not complete yet (not counting a telegram
    /// already delivered).
    #[inline]
    pub fn buffered(&self) -> usize {
        self.len.saturating_sub(self.delivered)
    }

    /// Give up the telegram being collected, e.g. when the line has been
    /// idle too long: its `STX` is dropped (counted as skipped) and the bytes
    /// after it are re-scanned by the next [`feed`](Framer::feed) — call
    /// `feed(&[])` to drain them. This finds a real telegram that a false
    /// `STX` with a long `LEN` was holding back while no more bytes come.
    /// Returns `false` if no telegram was being collected.
    pub fn abandon(&mut self) -> bool {
        self.release_delivered();
        if self.front() != Some(STX) {
            return false;
        }
        self.stats.abandoned = self.stats.abandoned.wrapping_add(1);
        self.stats.resyncs = self.stats.resyncs.wrapping_add(1);
        self.skip(1);
        true
    }

    /// Drop everything buffered (e.g. after a baud-rate change);
    /// the bytes count as skipped. Returns how many were dropped.
    pub fn discard(&mut self) -> usize {
        self.release_delivered();
        let n = self.len;
        self.skip(n);
        n
    }

    /// Feed received bytes; see the [module docs](self) for the loop.
    pub fn feed<'f, 'i>(&'f mut self, input: &'i [u8]) -> Feed<'f, 'i> {
        self.release_delivered();
        let crc_start = self.stats.crc_errors;
        let (found, remaining) = self.step(input);
        let crc_errors = self.stats.crc_errors.wrapping_sub(crc_start);
        let event = match found {
            Found::Nothing => None,
            Found::Ack => Some(Event::Ack),
            Found::Nak => Some(Event::Nak),
            Found::Telegram(total) => {
                self.delivered = total;
                let bytes: &'f [u8] = self.buf.get(..total).unwrap_or_default();
                Some(Event::Telegram(Telegram::new_unchecked(
                    bytes,
                    self.direction,
                )))
            }
        };
        Feed {
            event,
            remaining,
            crc_errors,
        }
    }

    /// Consume input until something is found or the input runs out.
    fn step<'i>(&mut self, input: &'i [u8]) -> (Found, &'i [u8]) {
        let mut input = input;
        loop {
            // Buffer holds unsynchronised bytes (left over from a re-scan):
            // bring an STX to the front, or report a handshake byte.
            if self.len > 0 && self.front() != Some(STX) {
                if let Some(found) = self.sync_buffer() {
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
                    None => self.push(&[STX]),
                }
                continue;
            }
            // buf[0] == STX: judge the candidate.
            match self.candidate() {
                Candidate::Complete(total) => {
                    self.stats.telegrams = self.stats.telegrams.wrapping_add(1);
                    return (Found::Telegram(total), input);
                }
                Candidate::False(why) => {
                    let counter = match why {
                        FalseStart::Crc => &mut self.stats.crc_errors,
                        FalseStart::Oversize => &mut self.stats.oversize,
                        FalseStart::BadHeader => &mut self.stats.bad_headers,
                    };
                    *counter = counter.wrapping_add(1);
                    self.stats.resyncs = self.stats.resyncs.wrapping_add(1);
                    // Drop the false STX only; re-scan what follows it.
                    self.skip(1);
                }
                Candidate::Need(total) => {
                    if input.is_empty() {
                        return (Found::Nothing, input);
                    }
                    let want = total.saturating_sub(self.len).min(input.len());
                    let (take, rest) = input.split_at_checked(want).unwrap_or((input, &[]));
                    self.push(take);
                    input = rest;
                }
            }
        }
    }

    /// Drop the telegram handed out by the previous call.
    fn release_delivered(&mut self) {
        let n = self.delivered;
        self.delivered = 0;
        self.drop_front(n);
    }

    /// First buffered byte.
    #[inline]
    fn front(&self) -> Option<u8> {
        if self.len == 0 {
            None
        } else {
            self.buf.first().copied()
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
    fn sync_buffer(&mut self) -> Option<Found> {
        let held = self.buf.get(..self.len).unwrap_or_default();
        match held.iter().position(|&b| self.is_marker(b)) {
            None => {
                self.skip(self.len);
                None
            }
            Some(0) => {
                let b = self.front().unwrap_or(STX);
                let event = self.handshake_byte(b);
                if event.is_some() {
                    self.drop_front(1);
                } else {
                    // Not reached (the front is not STX); skip to be sure
                    // the caller's loop makes progress.
                    self.skip(1);
                }
                event
            }
            Some(at) => {
                self.skip(at);
                None
            }
        }
    }

    /// Judge the candidate at the front of the buffer (which is `STX`).
    fn candidate(&self) -> Candidate {
        if self.len < HEADER_LEN {
            return Candidate::Need(HEADER_LEN);
        }
        let addr = self.buf.get(1).copied().unwrap_or(0);
        let len = usize::from(le_u16(&self.buf, 2));
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
        let covered = self.buf.get(..total - CRC_LEN).unwrap_or_default();
        if crc16(covered) == le_u16(&self.buf, total - CRC_LEN) {
            Candidate::Complete(total)
        } else {
            Candidate::False(FalseStart::Crc)
        }
    }

    /// Append bytes (as many as fit; callers never offer more).
    fn push(&mut self, bytes: &[u8]) {
        let start = self.len.min(MAX_TELEGRAM_LEN);
        let n = bytes.len().min(MAX_TELEGRAM_LEN - start);
        if let Some(dst) = self.buf.get_mut(start..start + n) {
            super::copy_into(dst, bytes);
            self.len = start + n;
        }
    }

    /// Drop `n` bytes from the front, counting them as skipped.
    fn skip(&mut self, n: usize) {
        let n = n.min(self.len);
        self.count_skipped(n);
        self.drop_front(n);
    }

    /// Drop `n` bytes from the front without counting.
    fn drop_front(&mut self, n: usize) {
        let len = self.len.min(MAX_TELEGRAM_LEN);
        let n = n.min(len);
        if n == 0 {
            return;
        }
        // A byte loop rather than `copy_within`, whose range check would
        // leave a panic path in the binary.
        for i in 0..len - n {
            let b = self.buf.get(i + n).copied().unwrap_or(0);
            if let Some(d) = self.buf.get_mut(i) {
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
