//! Requests in: the framer, and one answer per request (PROTOCOL.md §2).

use super::transmit::ReplyKind;
use super::*;
use crate::frame::FovRes;
use crate::telegram::request::code;
use crate::telegram::{Head, Telegram};

/// A received telegram, copied out of the framer.
#[derive(Clone, Copy, Debug)]
pub(super) struct Incoming {
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
        Request::SetVariant(asked) => Request::SetVariant(asked),
        Request::ReadConfig => Request::ReadConfig,
        Request::WriteConfig(c) => Request::WriteConfig(c),
        Request::Reset => Request::Reset,
        Request::Unknown { command, .. } => Request::Unknown { command, data: &[] },
    }
}

/// A received request and what answers it.
struct Classified {
    incoming: Incoming,
    data_len: usize,
    /// The source's reply to a command the sensor does not know.
    extra: Option<(u8, usize)>,
    /// A value mode the sensor model answers itself.
    value_mode: Option<ValueMode>,
    /// `20 2A` (partial scans), answered by the sensor model itself.
    partial: bool,
    /// The sensor behind the face answers it (co-processor).
    relay: bool,
}

impl Classified {
    /// A request `head` of `len` (`LEN`) bytes too long to be kept: unknown.
    fn unknown(head: Head, len: u16) -> Self {
        Classified {
            incoming: Incoming {
                address: head.address,
                request: Request::Unknown {
                    command: head.command,
                    data: &[],
                },
            },
            data_len: usize::from(len).saturating_sub(1),
            extra: None,
            value_mode: None,
            partial: false,
            relay: false,
        }
    }
}

/// What `t` asks and who answers it: the sensor model, the source
/// (`extra_command`, its reply data into `extra`) or the sensor behind the
/// face (`relay`).
fn classify<S: ScanSource>(
    t: &Telegram<&[u8]>,
    settings: &Settings,
    source: &mut S,
    extra: &mut [u8; EXTRA_REPLY_CAPACITY],
    room: bool,
) -> Option<Classified> {
    let request = Request::parse(t).ok()?;
    let ours = t.address() == settings.address;
    let mut classified = Classified {
        incoming: Incoming {
            address: t.address(),
            request: detach(request),
        },
        data_len: t.data().len(),
        extra: None,
        value_mode: None,
        partial: false,
        relay: false,
    };
    if let Request::Unknown { command, data } = request {
        // A command the sensor does not know may be the source's.
        if ours {
            classified.extra = source
                .extra_command(command, data, extra)
                .filter(|&(_, len)| len <= EXTRA_REPLY_CAPACITY);
        }
        // A value mode (`20 26`/`27`/`28`), answered by the sensor model
        // itself (not on the co-processor's face).
        if !settings.external_scans {
            classified.value_mode = ValueMode::parse(command, data);
            classified.partial = (command, data) == (code::MODE, &[MODE_PARTIAL][..]);
        }
    }
    // A request the sensor behind the face answers (co-processor), taken
    // only if the reply queue has room for it: a request the queue cannot
    // hold is dropped and counted whole (`handle`), never left claimed by
    // the source with no reply to come.
    classified.relay =
        settings.external_scans && ours && room && source.relay(t.command(), t.data());
    Some(classified)
}

impl<S: ScanSource, const TX: usize> Emulator<S, TX> {
    /// Feed the framer until it has nothing more, answering what it finds.
    pub(super) fn feed(&mut self, now_us: u64, bytes: &[u8]) {
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
            let done = fed.event.is_none();
            let request = match fed.event {
                Some(FramerEvent::Telegram(t)) => {
                    let room = !self.pending.is_full();
                    classify(&t, &self.settings, &mut self.source, &mut self.extra, room)
                }
                // Longer than the request buffer: no request the sensor
                // interprets is (`92`, as for any unknown or malformed one).
                Some(FramerEvent::Long {
                    address,
                    command,
                    len,
                }) => Some(Classified::unknown(Head { address, command }, len)),
                Some(FramerEvent::Ack | FramerEvent::Nak) | None => None,
            };
            for _ in 0..naks {
                self.nak(now_us);
            }
            match request {
                Some(r) if r.relay => self.relay(now_us, r.incoming.request.command()),
                Some(r) if r.partial => self.handle_partial(now_us, r.incoming),
                Some(r) => self.handle(now_us, r.incoming, r.data_len, r.extra, r.value_mode),
                None => {}
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

    /// A bad checksum: one `NAK`, joined to the `NAK`s queued right before
    /// it (so a burst of bad telegrams gets one `NAK` each however long it
    /// is, [`NAKS_PER_FRAME`] to a queue slot).
    fn nak(&mut self, now_us: u64) {
        self.stats.naks = self.stats.naks.wrapping_add(1);
        self.event(Event::BadChecksum);
        if let Some(Pending {
            what: Outgoing::Naks(n),
            ..
        }) = self.pending.back_mut()
        {
            if usize::from(*n) < NAKS_PER_FRAME {
                *n = n.saturating_add(1);
                return;
            }
        }
        self.queue(now_us, Outgoing::Naks(1));
    }

    /// A relayed request (the source has taken it, the queue has room):
    /// `ACK` now, the sensor's reply when it comes.
    fn relay(&mut self, now_us: u64, command: u8) {
        self.stats.requests = self.stats.requests.wrapping_add(1);
        if self
            .pending
            .push_back(Pending {
                ready_us: now_us,
                what: Outgoing::Relay { acked: false },
            })
            .is_err()
        {
            // Never taken (`classify` checked the room); were it taken, the
            // source lets the request go, counted.
            debug_assert!(false, "no room for a relayed request");
            self.stats.dropped_requests = self.stats.dropped_requests.wrapping_add(1);
            self.source.relay_dropped();
            return;
        }
        self.event(Event::Request(Handled::Extra { command }));
    }

    /// Answer one request.
    fn handle(
        &mut self,
        now_us: u64,
        incoming: Incoming,
        data_len: usize,
        extra: Option<(u8, usize)>,
        value_mode: Option<ValueMode>,
    ) {
        if !self.admit(incoming.address) {
            return;
        }
        let (reply, then, handled) = match value_mode {
            Some(mode) => self.value_mode(mode),
            None => self.answer(now_us, incoming.request, data_len, extra),
        };
        self.queue(now_us, Outgoing::Reply { reply, then });
        self.event(Event::Request(handled));
    }

    /// The reply to `request`, what happens after it, and what to report;
    /// applies the request's effect on the sensor's state.
    fn answer(
        &mut self,
        now_us: u64,
        request: Request<'static>,
        data_len: usize,
        extra: Option<(u8, usize)>,
    ) -> (ReplyKind, Done, Handled) {
        let ok = ReplyKind::Mode(ModeResult::Ok);
        match request {
            Request::InstallationMode { password } => self.installation_mode(password),
            Request::Continuous => {
                self.mode = OperatingMode::Continuous;
                (ok, Done::StartStream, Handled::Continuous)
            }
            Request::OnRequest => {
                self.mode = OperatingMode::OnRequest;
                self.stop_stream();
                (ok, Done::Nothing, Handled::OnRequest)
            }
            Request::SetBaud(b) => {
                // Every LMS client sets the rate as it starts: a new session.
                self.source.new_session();
                (ok, Done::SwitchBaud(b), Handled::SetBaud(b))
            }
            Request::OneScan => (ReplyKind::OneScan, Done::Nothing, Handled::OneScan),
            Request::Status => (
                ReplyKind::Status(self.status_fields()),
                Done::Nothing,
                Handled::Status,
            ),
            Request::SensorType => (ReplyKind::SensorType, Done::Nothing, Handled::SensorType),
            Request::SetVariant(asked) => self.variant_request(now_us, asked),
            Request::ReadConfig => (
                ReplyKind::Config(self.config),
                Done::Nothing,
                Handled::ReadConfig,
            ),
            Request::WriteConfig(c) => self.config_write(c),
            Request::Reset => {
                self.source.new_session();
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
        }
    }

    /// Whether a request for `address` is answered: it is for this sensor
    /// (else ignored and counted) and the reply queue has room (else
    /// dropped and counted); an answered request is counted.
    fn admit(&mut self, address: u8) -> bool {
        if address != self.settings.address {
            self.stats.ignored = self.stats.ignored.wrapping_add(1);
            self.event(Event::IgnoredAddress { address });
            return false;
        }
        if self.pending.is_full() {
            self.stats.dropped_requests = self.stats.dropped_requests.wrapping_add(1);
            return false;
        }
        self.stats.requests = self.stats.requests.wrapping_add(1);
        true
    }

    /// `20 2A` for this sensor: `A0 00`, then the partial scans (every
    /// variant has them; at 1° each is the whole scan).
    fn handle_partial(&mut self, now_us: u64, incoming: Incoming) {
        if !self.admit(incoming.address) {
            return;
        }
        self.mode = OperatingMode::Partial;
        let reply = ReplyKind::Mode(ModeResult::Ok);
        self.queue(
            now_us,
            Outgoing::Reply {
                reply,
                then: Done::StartStream,
            },
        );
        self.event(Event::Request(Handled::PartialScans));
    }

    /// `20 26`/`27`/`28`: the value mode, if its parameters fit the
    /// variant (`A0 00`, the stream starts after the reply); else `A0 02`.
    fn value_mode(&mut self, mode: ValueMode) -> (ReplyKind, Done, Handled) {
        let accepted = mode.valid(self.variant);
        let handled = Handled::ValueMode { mode, accepted };
        if !accepted {
            return (ReplyKind::Mode(ModeResult::Fault), Done::Nothing, handled);
        }
        self.mode = OperatingMode::Values(mode);
        (ReplyKind::Mode(ModeResult::Ok), Done::StartStream, handled)
    }

    /// `20 00` + password: installation mode (stops a stream) if the
    /// password is right, else `A0 01`.
    fn installation_mode(&mut self, password: [u8; 8]) -> (ReplyKind, Done, Handled) {
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

    /// `3B`: switch to the variant if it exists and the source supports it;
    /// the `BB` reply names the variant in force either way.
    fn variant_request(&mut self, now_us: u64, asked: FovRes) -> (ReplyKind, Done, Handled) {
        let wanted = Variant::from_fov_res(asked).filter(|&v| self.source.supports(v));
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
            Handled::SetVariant { asked, accepted },
        )
    }

    /// `77`: taken in installation mode with known units; the `F7` reply
    /// carries the configuration in force either way.
    fn config_write(&mut self, c: Config) -> (ReplyKind, Done, Handled) {
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

    /// Change the variant; a running stream restarts its scan clock.
    fn set_variant(&mut self, now_us: u64, v: Variant) {
        self.variant = v;
        if let Some(stream) = self.stream.as_mut() {
            *stream = Stream {
                start_us: now_us,
                sent: 0,
            };
        }
    }

    fn stop_stream(&mut self) {
        let external = core::mem::replace(&mut self.external_stream, false);
        if self.stream.take().is_some() || external {
            self.event(Event::StreamStopped);
        }
    }

    pub(super) fn set_baud(&mut self, to: Baud) {
        let from = self.baud;
        if from != to {
            self.baud = to;
            self.event(Event::BaudSwitched { from, to });
        }
    }

    pub(super) fn queue(&mut self, now_us: u64, what: Outgoing) {
        let pending = Pending {
            ready_us: now_us,
            what,
        };
        if self.pending.push_back(pending).is_err() {
            self.stats.dropped_requests = self.stats.dropped_requests.wrapping_add(1);
        }
    }

    pub(super) fn event(&mut self, e: Event) {
        if self.events.push_back(e).is_err() {
            self.stats.events_dropped = self.stats.events_dropped.wrapping_add(1);
        }
    }
}
