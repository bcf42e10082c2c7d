//! Bytes out: replies and scans paced at the line rate and the mirror's
//! turns (see *Timing* in the module docs).

use super::*;
use core::num::NonZeroU64;

use crate::maths::{div_rem_u64, div_u64, divisor};

/// A reply as decided when its request arrived.
#[derive(Clone, Copy, Debug)]
pub(super) enum ReplyKind {
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
pub(super) enum Done {
    Nothing,
    SwitchBaud(Baud),
    StartStream,
    Restart,
    PowerOn,
    Scan { continuous: bool, skipped: u32 },
}

/// A frame waiting for the line.
#[derive(Clone, Copy, Debug)]
pub(super) enum Outgoing {
    /// `NAK`s for this many bad telegrams in a row (one byte each).
    Naks(u16),
    /// A relayed request ([`ScanSource::relay`]): its `ACK` at once
    /// (`acked` then set), then the sensor's reply
    /// ([`ScanSource::relayed_reply`]). One queue slot for both, so that a
    /// request the queue takes is always answered whole.
    Relay {
        acked: bool,
    },
    PowerOn,
    /// `ACK` + the reply, then `then`.
    Reply {
        reply: ReplyKind,
        then: Done,
    },
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Pending {
    /// When the request arrived (µs): the frame starts no earlier.
    pub(super) ready_us: u64,
    pub(super) what: Outgoing,
}

/// The continuous stream's clock.
#[derive(Clone, Copy, Debug)]
pub(super) struct Stream {
    /// Time of scan 0 (µs).
    pub(super) start_us: u64,
    /// Index of the last scan sent plus one, 0 before the first. Not an
    /// `Option`: `None` of an `Option<Stream>` would then take the tag's
    /// niche (a non-zero byte), and the co-processor's face must be all
    /// zero in a `static`.
    pub(super) sent: u64,
}

impl Stream {
    /// Index of the last scan sent.
    fn last(&self) -> Option<u64> {
        self.sent.checked_sub(1)
    }

    /// Time scan `k` is complete (µs), `turns` mirror turns per scan.
    fn tick_us(&self, k: u64, turns: NonZeroU64) -> u64 {
        let offset = div_u64(k.saturating_mul(turns.get() * TURN_US_TIMES_3), divisor(3));
        self.start_us.saturating_add(offset)
    }

    /// The scan to send next when the line is free from `free_us` on: the
    /// newest complete by then if it has not been sent, else the one after
    /// the last sent, `turns` mirror turns per scan. Returns its index and
    /// completion time.
    fn next(&self, free_us: u64, turns: NonZeroU64) -> (u64, u64) {
        let free = free_us.max(self.start_us);
        let elapsed = free.saturating_sub(self.start_us);
        let newest = div_u64(
            elapsed.saturating_mul(3),
            turns.saturating_mul(divisor(TURN_US_TIMES_3)),
        );
        let k = match self.last() {
            Some(last) if newest <= last => last.saturating_add(1),
            _ => newest,
        };
        (k, self.tick_us(k, turns))
    }
}

impl<S: ScanSource, const TX: usize> Emulator<S, TX> {
    /// The sensor → host bytes whose line time has come by `now_us` (see
    /// *Timing* in the module docs), at most `out.len()`; returns how
    /// many were written. It stops right after the last byte sent at the
    /// old rate when the line switches ([`Event::BaudSwitched`]), and
    /// before the first byte when a power-on puts the line back to 9600 Bd:
    /// call it again until it returns 0 with [`Emulator::baud`] unchanged.
    pub fn transmit(&mut self, now_us: u64, out: &mut [u8]) -> usize {
        let mut n = 0;
        let entry_baud = self.baud;
        // Each round completes a frame or stops; the bound only guards
        // against a logic error.
        for _ in 0..out.len().saturating_add(PENDING_CAPACITY).saturating_add(4) {
            self.advance(now_us);
            // A power-on inside `advance` put the line back to 9600 Bd:
            // stop, so that every byte of a batch goes at the rate the
            // caller read before the call (it calls again at the new rate).
            if self.tx_len == 0 || self.baud != entry_baud {
                break;
            }
            let due = self.bytes_due(now_us);
            let k = due
                .saturating_sub(self.tx_sent)
                .min(out.len().saturating_sub(n));
            let dst = out.get_mut(n..n.saturating_add(k)).unwrap_or_default();
            self.frame_bytes(dst);
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
        let bits = div_u64(
            elapsed.saturating_mul(hundred_bps(self.baud)),
            divisor(US_PER_HUNDRED_BITS),
        );
        usize::try_from(div_u64(bits, divisor(BITS_PER_BYTE)))
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
                let streams = matches!(
                    self.mode,
                    OperatingMode::Continuous | OperatingMode::Values(_) | OperatingMode::Partial
                );
                if streams && !self.resetting {
                    if self.settings.external_scans {
                        self.external_stream = true;
                    } else {
                        self.stream = Some(Stream {
                            start_us: end,
                            sent: 0,
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
        if self.tx_len != 0 || self.next_pending() {
            return;
        }
        let turns = self.stream_turns();
        let Some(stream) = self.stream.as_mut() else {
            return;
        };
        // Decided as of when the line became free, however late the call.
        let (k, tick) = stream.next(self.line_free_us, turns);
        if tick > now_us {
            return;
        }
        let skipped = match stream.last() {
            Some(last) => k.saturating_sub(last).saturating_sub(1),
            None => k,
        };
        stream.sent = k.saturating_add(1);
        // The mirror scan's number: partial scans count turns, whole ones
        // scans.
        self.scan_index = k as u8;
        let skipped = u32::try_from(skipped).unwrap_or(u32::MAX);
        let done = Done::Scan {
            continuous: true,
            skipped,
        };
        match self.mode {
            // A buffer too small for a value telegram sends none (counted
            // in `emit_errors`); the co-processor's face never streams here.
            OperatingMode::Values(_) if TX < TX_CAPACITY => self.set_frame(tick, None, done),
            OperatingMode::Values(mode) => self.start_value_scan(tick, mode, done),
            OperatingMode::Partial if TX < TX_CAPACITY => self.set_frame(tick, None, done),
            OperatingMode::Partial => {
                let part = div_rem_u64(k, divisor(turns_per_scan(self.variant))).1 as u8;
                self.start_partial_scan(tick, part, done);
            }
            _ => self.start_scan(tick, false, done),
        }
    }

    /// The line is free: the first queued frame goes on it, if any (a
    /// relayed request's `ACK`, then its reply when it has come: all waits
    /// for it). Returns `true` if something is queued.
    fn next_pending(&mut self) -> bool {
        if let Some(p) = self.pending.front_mut() {
            if let Outgoing::Relay {
                acked: acked @ false,
            } = &mut p.what
            {
                *acked = true;
                let ready_us = p.ready_us;
                if let Some(b) = self.tx.first_mut() {
                    *b = ACK;
                }
                self.set_frame(ready_us, Some(1), Done::Nothing);
                return true;
            }
        }
        let Some(p) = self.pending.front().copied() else {
            return false;
        };
        if matches!(p.what, Outgoing::Relay { .. }) {
            let Some(n) = self.source.relayed_reply(&mut self.tx) else {
                return true;
            };
            self.pending.pop_front();
            if n > 0 {
                self.set_frame(p.ready_us, Some(n.min(TX)), Done::Nothing);
            }
            return true;
        }
        self.pending.pop_front();
        self.start_frame(p.ready_us, p.what);
        true
    }

    /// Mirror turns per stream telegram: a scan's, times the samples of a
    /// mean value mode; at least 1.
    fn stream_turns(&self) -> NonZeroU64 {
        let samples = match self.mode {
            OperatingMode::Values(m) => u64::from(m.samples()),
            // One partial scan per mirror turn.
            OperatingMode::Partial => return NonZeroU64::MIN,
            _ => 1,
        };
        divisor(turns_per_scan(self.variant).saturating_mul(samples.max(1)))
    }

    /// A `B6`/`B7`/`BF` of the value mode: `samples` scans from the source,
    /// averaged (means), cut to the subrange. Never inlined: its 2.4 KiB
    /// accumulator must not enlarge the frame of `transmit` on the
    /// co-processor's face, which never gets here (firmware stack budget).
    #[inline(never)]
    fn start_value_scan(&mut self, ready_us: u64, mode: ValueMode, done: Done) {
        let variant = self.variant;
        let units = self.units();
        let beams = variant.beams().min(MAX_VALUES);
        let mut means = value_modes::MeanAccumulator::new();
        let mut scan = [0u16; MAX_VALUES];
        let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
        for _ in 0..mode.samples() {
            let out = scan.get_mut(..beams).unwrap_or_default();
            let written = self.source.next_scan(variant, units, out).min(out.len());
            out.get_mut(written..).unwrap_or_default().fill(not_valid);
            means.add(out);
        }
        if mode.samples() > 1 {
            means.take(scan.get_mut(..beams).unwrap_or_default());
        }
        let (start, count) = mode.span(variant);
        let values = scan
            .get(start..start.saturating_add(count))
            .unwrap_or_default();
        let (address, status) = (self.settings.address, SensorStatus(self.settings.status));
        let index = self.index_byte();
        let n = mode.emit_with_index(address, status, units, values, index, &mut self.tx);
        self.set_frame(ready_us, n.ok(), done);
    }

    /// The real-time scan index to send after the values, if the
    /// configuration asks for it (the source's, if it has one: the
    /// co-processor's face sends the sensor's).
    fn index_byte(&self) -> Option<u8> {
        let index = self.source.real_time_index().unwrap_or(self.scan_index);
        self.config.real_time_indices().then_some(index)
    }

    /// Partial scan `part` of a scan from the source ([`partial_values`]):
    /// a `B0` with count word bit 13 and the partial scan's offset. Never
    /// inlined, as [`Self::start_value_scan`] (its scan buffer).
    #[inline(never)]
    fn start_partial_scan(&mut self, ready_us: u64, part: u8, done: Done) {
        let variant = self.variant;
        let units = self.units();
        let beams = variant.beams().min(MAX_VALUES);
        let mut scan = [0u16; MAX_VALUES];
        let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
        let out = scan.get_mut(..beams).unwrap_or_default();
        let written = self.source.next_scan(variant, units, out).min(out.len());
        out.get_mut(written..).unwrap_or_default().fill(not_valid);
        let (first, step, count) = partial_values(variant, part);
        let status = self.settings.status;
        let values = MeasuredValues::from_fill(count, units, status, |dst| {
            let picked = scan.iter().skip(first).step_by(step.max(1));
            for (slot, &w) in dst.iter_mut().zip(picked) {
                *slot = w;
            }
        });
        let address = self.settings.address;
        let index = self.index_byte();
        let n = match values {
            Ok(mut v) => {
                v.set_scan_flags(partial_scan_flags(partial_offset_code(variant, part)));
                v.set_real_time_index(index);
                v.emit(address, &mut self.tx)
            }
            Err(_) => Ok(0),
        };
        self.set_frame(ready_us, n.ok(), done);
    }

    /// Put a frame on the line, starting when both it and the line are ready.
    fn start_frame(&mut self, ready_us: u64, what: Outgoing) {
        let address = self.settings.address;
        let status = self.settings.status;
        match what {
            Outgoing::Naks(n) => {
                let n = usize::from(n).min(TX);
                self.tx.get_mut(..n).unwrap_or_default().fill(NAK);
                self.set_frame(ready_us, Some(n), Done::Nothing);
            }
            // Taken in `advance`.
            Outgoing::Relay { .. } => {}
            Outgoing::PowerOn => {
                let n =
                    Reply::PowerOn(POWER_ON_DATA).emit(address, SensorStatus(status), &mut self.tx);
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
                                Head {
                                    address: REPLY_ADDRESS_BIT | address,
                                    command,
                                },
                                data,
                                Some(status),
                            )
                        });
                        self.set_frame(ready_us, n.ok(), then);
                        return;
                    }
                };
                let n = self.emit_after_ack(|buf| reply.emit(address, SensorStatus(status), buf));
                self.set_frame(ready_us, n.ok(), then);
            }
        }
    }

    /// `ACK` then what `emit` writes.
    pub(super) fn emit_after_ack<E>(
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

    /// A `B0` with the source's next scan, with `ACK` before it for `30 01`
    /// (streamed from [`ScanSource::word`] if `tx` cannot hold it).
    fn start_scan(&mut self, ready_us: u64, ack: bool, done: Done) {
        if TX < TX_CAPACITY {
            self.start_streamed_scan(ready_us, ack, done);
            return;
        }
        let variant = self.variant;
        let units = self.units();
        let beams = variant.beams().min(MAX_VALUES);
        let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
        let source = &mut self.source;
        // The source writes straight into the telegram's values (no
        // staging copy in the emulator).
        let values = MeasuredValues::from_fill(beams, units, self.settings.status, |out| {
            let written = source.next_scan(variant, units, out).min(out.len());
            out.get_mut(written..).unwrap_or_default().fill(not_valid);
        });
        let address = self.settings.address;
        if ack {
            self.scan_index = self.scan_index.wrapping_add(1);
        }
        let index = self.index_byte();
        let values = values.map(|mut v| {
            v.set_real_time_index(index);
            v
        });
        let n = match values {
            Ok(v) if ack => self.emit_after_ack(|buf| v.emit(address, buf)),
            Ok(v) => v.emit(address, &mut self.tx),
            // Never taken: `beams <= MAX_VALUES`.
            Err(_) => {
                debug_assert!(false, "more beams than a B0 holds");
                Ok(0)
            }
        };
        self.set_frame(ready_us, n.ok(), done);
    }

    /// A `B0` streamed from the source's [`ScanSource::word`]: `ACK` (for
    /// `30 01`), the header and the count word into `tx`, their CRC begun;
    /// [`Self::streamed_byte`] produces the rest as it goes out. The bytes
    /// are those [`MeasuredValues::emit`] writes (flags 0).
    fn start_streamed_scan(&mut self, ready_us: u64, ack: bool, done: Done) {
        let beams = self.variant.beams().min(MAX_VALUES);
        if ack {
            self.scan_index = self.scan_index.wrapping_add(1);
        }
        self.streamed_index = self.index_byte();
        // count word + values + index + command + status: at most 807 < MAX_LEN.
        let len = 2 + 2 * beams + usize::from(self.streamed_index.is_some()) + 2;
        let [lo, hi] = (len as u16).to_le_bytes();
        let [w_lo, w_hi] = measured_count_word(beams, self.units()).to_le_bytes();
        let address = Direction::SensorToHost.address_byte(self.settings.address);
        let head = [STX, address, lo, hi, MEASURED_COMMAND, w_lo, w_hi];
        let at = usize::from(ack);
        if let Some(slot) = self.tx.get_mut(at..at + head.len()) {
            slot.copy_from_slice(&head);
        }
        if let (Some(b), true) = (self.tx.first_mut(), ack) {
            *b = ACK;
        }
        let mut crc = Crc::new();
        crc.update(&head);
        self.set_frame(ready_us, Some(at + HEADER_LEN + len + CRC_LEN), done);
        self.streamed = true;
        self.streamed_head = (at + head.len()) as u8;
        self.streamed_values = beams as u16;
        self.streamed_crc = crc;
    }

    /// Hand out the next `out.len()` bytes of the frame on the line, from
    /// `tx_sent` on (the caller advances `tx_sent`).
    fn frame_bytes(&mut self, out: &mut [u8]) {
        if !self.streamed {
            let end = self.tx_sent.saturating_add(out.len());
            copy_into(out, self.tx.get(self.tx_sent..end).unwrap_or_default());
            return;
        }
        let from = self.tx_sent;
        for (i, slot) in out.iter_mut().enumerate() {
            *slot = self.streamed_byte(from.saturating_add(i));
        }
    }

    /// Byte `at` of a streamed `B0` (asked for in order, each once): the
    /// head from `tx`, then each word's low and high byte, the status byte
    /// (all added to the CRC), the CRC low and high byte.
    fn streamed_byte(&mut self, at: usize) -> u8 {
        let head = usize::from(self.streamed_head);
        let Some(j) = at.checked_sub(head) else {
            return self.tx.get(at).copied().unwrap_or(0);
        };
        let values = 2 * usize::from(self.streamed_values);
        let (index, values) = match self.streamed_index {
            Some(i) if j == values => (Some(i), values + 1),
            Some(_) => (None, values + 1),
            None => (None, values),
        };
        let byte = if let Some(i) = index {
            i
        } else if j < values && j < 2 * usize::from(self.streamed_values) {
            let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
            let units = self.units();
            let word = self.source.word(self.variant, units, j / 2);
            word.unwrap_or(not_valid).to_le_bytes()[j % 2]
        } else if j == values {
            self.settings.status
        } else {
            let [lo, hi] = self.streamed_crc.value().to_le_bytes();
            return if j == values + 1 { lo } else { hi };
        };
        self.streamed_crc.push(byte);
        byte
    }

    /// Start the frame of `len` bytes in `tx` (`None`: it could not be
    /// written; nothing is sent and `done` is not carried out).
    fn set_frame(&mut self, ready_us: u64, len: Option<usize>, done: Done) {
        self.streamed = false;
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
            let (_, tick) = stream.next(self.line_free_us, self.stream_turns());
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
}
