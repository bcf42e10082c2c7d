//! The co-processor's sensor side: bring the LMS 2xx up and take its `B0`
//! stream (sans I/O: bytes and time in, bytes and events out).
//!
//! Bring-up, one request at a time, each resent after [`REPLY_TIMEOUT_US`]
//! without its reply (the first bytes may be lost while the line settles):
//!
//! 1. `20 25` — values on request only (stops a stream left running);
//! 2. `3B` — the variant (default 180°/0.5°);
//! 3. `20 00 SICK_LMS` — installation mode;
//! 4. `74` — read the configuration;
//! 5. `77` — write it back with the wanted units (default mm);
//! 6. `20 4x` — the wanted baud rate; after the reply both sides switch
//!    ([`LinkEvent::SwitchBaud`]);
//! 7. `20 24` — continuous output; from then on every `B0` is a scan.

use crate::telegram::{
    Baud, Config, Direction, Event, Framer, FramerStats, Handshake, ModeResult, Reply, Request,
    DEFAULT_ADDRESS, DEFAULT_PASSWORD, MAX_TELEGRAM_LEN,
};
use crate::Unit;
use crate::Variant;

/// How long to wait for a reply before sending the request again (µs).
pub const REPLY_TIMEOUT_US: u64 = 300_000;

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
    framer: Framer,
    step: Step,
    /// When the current request was last sent (µs); `None` = not yet sent.
    sent_at: Option<u64>,
    config: Option<Config>,
    /// Requests sent again after a time-out.
    retries: u32,
    /// The last `B0` telegram, STX … CRC.
    scan: [u8; MAX_TELEGRAM_LEN],
    scan_len: usize,
}

impl SensorLink {
    /// A link that will bring the sensor up with `setup`.
    pub const fn new(setup: SensorSetup) -> Self {
        SensorLink {
            setup,
            framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
            step: Step::StopStream,
            sent_at: None,
            config: None,
            retries: 0,
            scan: [0; MAX_TELEGRAM_LEN],
            scan_len: 0,
        }
    }

    /// The bytes of the last `B0` telegram reported by [`LinkEvent::Scan`].
    pub fn scan_bytes(&self) -> &[u8] {
        self.scan.get(..self.scan_len).unwrap_or_default()
    }

    /// The current bring-up step.
    pub fn step(&self) -> Step {
        self.step
    }

    /// Requests resent after a time-out.
    pub fn retries(&self) -> u32 {
        self.retries
    }

    /// The framer's counters (CRC errors, resyncs, bytes skipped).
    pub fn framer_stats(&self) -> &FramerStats {
        self.framer.stats()
    }

    /// Start the bring-up again (e.g. after the sensor reset).
    pub fn restart(&mut self) {
        self.step = Step::StopStream;
        self.sent_at = None;
        self.config = None;
    }

    /// The request to send now, if one is due (not sent yet, or timed out),
    /// written into `buf`; returns its length. Call it every poll.
    pub fn due_request(&mut self, now_us: u64, buf: &mut [u8]) -> Option<usize> {
        if self.step == Step::Streaming {
            return None;
        }
        if let Some(at) = self.sent_at {
            if now_us.saturating_sub(at) < REPLY_TIMEOUT_US {
                return None;
            }
            self.retries = self.retries.wrapping_add(1);
            // A late reply may sit half-received in the framer: start clean.
            self.framer.abandon();
        }
        let request = match self.step {
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
        };
        let n = request.emit(DEFAULT_ADDRESS, buf).ok()?;
        self.sent_at = Some(now_us);
        Some(n)
    }

    /// Take bytes from the sensor. Returns the first event found and the
    /// bytes not yet consumed; call again with the rest until it returns
    /// `None` with nothing left.
    pub fn feed<'i>(&mut self, input: &'i [u8]) -> (Option<LinkEvent>, &'i [u8]) {
        let step = self.step;
        let fed = self.framer.feed(input);
        let rest = fed.remaining;
        let telegram = match fed.event {
            Some(Event::Telegram(t)) => t,
            // ACK/NAK: a NAK means our request was damaged; resend at once.
            Some(Event::Nak) => {
                self.sent_at = Some(0);
                return (None, rest);
            }
            Some(Event::Ack) | None => return (None, rest),
        };
        let (advance, event) = match Reply::parse(&telegram) {
            Ok(Reply::Measured(_)) if step == Step::Streaming => {
                let bytes = telegram.as_bytes();
                let n = bytes.len().min(MAX_TELEGRAM_LEN);
                self.scan[..n].copy_from_slice(&bytes[..n]);
                self.scan_len = n;
                return (Some(LinkEvent::Scan), rest);
            }
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
            // The sensor restarted: bring it up again.
            Ok(Reply::PowerOn(_)) => {
                self.restart();
                return (None, rest);
            }
            _ => (false, None),
        };
        if advance {
            self.step = match step {
                Step::StopStream => Step::SetVariant,
                Step::SetVariant => Step::InstallationMode,
                Step::InstallationMode => Step::ReadConfig,
                Step::ReadConfig => Step::WriteConfig,
                Step::WriteConfig => Step::SetBaud,
                Step::SetBaud => Step::StartStream,
                Step::StartStream | Step::Streaming => Step::Streaming,
            };
            self.sent_at = None;
        }
        (event, rest)
    }
}

/// The longest telegram the link sends (`77` + 34 bytes).
pub const MAX_REQUEST_LEN: usize = MAX_TELEGRAM_LEN;
