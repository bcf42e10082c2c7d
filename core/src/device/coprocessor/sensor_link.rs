//! The co-processor's sensor side: bring the LMS 2xx up and take its `B0`
//! stream (sans I/O: bytes and time in, bytes and events out).
//!
//! Bring-up, one request at a time through the client machine
//! ([`crate::device::client`]), each resent after [`REPLY_TIMEOUT_US`]
//! without its reply (the first bytes may be lost while the line settles)
//! and at once after a `NAK`, without limit:
//!
//! 1. `20 25` — values on request only (stops a stream left running);
//! 2. `3B` — the variant (default 180°/0.5°);
//! 3. `20 00 SICK_LMS` — installation mode;
//! 4. `74` — read the configuration;
//! 5. `77` — write it back with the wanted units (default mm);
//! 6. `20 4x` — the wanted baud rate; after the reply both sides switch
//!    ([`LinkEvent::SwitchBaud`]);
//! 7. `20 24` — continuous output; from then on every `B0` is a scan.
//!
//! A refused step (a reply that is not what was asked, or `92`) is sent
//! again when its time is up; the `90` power-on telegram (the sensor
//! restarted) starts the bring-up again.

use crate::device::client::{Client, Limits, Outcome};
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
    /// The sensor has acknowledged the new rate: switch the UART now.
    SwitchBaud(Baud),
    /// The sensor refused a step (e.g. the variant); the link retries it.
    Refused(Step),
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
}

impl SensorLink {
    /// A link that will bring the sensor up with `setup`.
    pub const fn new(setup: SensorSetup) -> Self {
        SensorLink {
            setup,
            client: Client::new(DEFAULT_ADDRESS),
            step: Step::StopStream,
            requested: false,
            nak: false,
            config: None,
        }
    }

    /// The bytes of the last `B0` telegram reported by [`LinkEvent::Scan`]
    /// (until the next [`feed`](SensorLink::feed)).
    pub fn scan_bytes(&self) -> &[u8] {
        self.client.telegram_bytes()
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

    /// Start the bring-up again (e.g. after the sensor reset).
    pub fn restart(&mut self) {
        self.step = Step::StopStream;
        self.requested = false;
        self.nak = false;
        self.config = None;
    }

    /// The request to send now, if one is due (not sent yet, timed out, or
    /// refused with `NAK`), written into `buf`; returns its length. Call it
    /// every poll.
    pub fn due_request(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        if self.step == Step::Streaming {
            return None;
        }
        if self.requested {
            if !(self.nak || self.client.expired(now_us)) {
                return None;
            }
            // A late reply may sit half-received in the framer: start clean.
            self.client.abandon();
        } else {
            let request = self.request()?;
            self.client.prepare(&request, LIMITS).ok()?;
        }
        let bytes = self.client.request_bytes();
        let n = bytes.len();
        crate::telegram::copy_into(buf.get_mut(..n)?, bytes);
        self.requested = true;
        self.nak = false;
        self.client.mark_sent(now_us);
        Some(n)
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
                let mut config = self.config?;
                config.set_units_code(match self.setup.units {
                    Unit::Millimetre => 1,
                    _ => 0,
                });
                Request::WriteConfig(config)
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
        let event = match outcome {
            Some(Outcome::Scan) => Some(LinkEvent::Scan),
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
            // The sensor restarted: bring it up again.
            Some(Outcome::PowerOn) => {
                self.restart();
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
            self.client.await_stream(now_us, None);
        }
        self.requested = false;
        self.nak = false;
        event
    }
}

/// The longest telegram the link sends (`77` + 34 bytes).
pub const MAX_REQUEST_LEN: usize = MAX_TELEGRAM_LEN;
