//! The sensor co-processor: an LMS 2xx on one serial line, the robot's
//! computer on the other.
//!
//! - Sensor side ([`sensor_link`]): brings the LMS up (variant, units,
//!   baud, continuous output) and takes its `B0` stream.
//! - Every intact scan runs through the [`Extractor`].
//! - Host side: an [`Emulator`] answers the client exactly like an LMS 2xx
//!   (its scans are the sensor's latest); while the client has continuous
//!   output on, every sensor `B0` is passed through unchanged and followed
//!   by the scan's feature telegrams ([`crate::telegram::features`]); a
//!   `30 01` gets the latest `B0` and its features. The request `55` reads
//!   the [`Counters`].
//!
//! [`CoProcessor::poll`] is generic over `embedded-io` serial ports, so the
//! firmware (UARTs) and the host build (pseudo-terminals) run the same code;
//! time comes in as an argument.

pub mod sensor_link;

use embedded_io::{Read, ReadReady, Write};

use crate::device::emulator::{Emulator, Event as HostEvent, Handled, ScanSource, Settings};
use crate::features::Features;
use crate::params::ValidParams;
use crate::pipeline::extractor::Extractor;
use crate::telegram::features::{emit_features, Counters, EchoedParams, REQ_COUNTERS};
use crate::telegram::{
    Baud, Direction, MeasuredView, RangeBits, Telegram, MAX_TELEGRAM_LEN, MAX_VALUES,
};
use crate::Unit;
use crate::{Frame, Variant};

pub use sensor_link::{LinkEvent, SensorLink, SensorSetup, Step};

/// Bytes read from a port per call.
const CHUNK: usize = 256;

/// The sensor's latest scan, served to the host for `30 01` and `31`, and
/// the counters for `55`.
pub struct LatestScan {
    values: [u16; MAX_VALUES],
    count: usize,
    variant: Variant,
    counters: Counters,
}

impl LatestScan {
    /// Every byte zero (no scan yet; the variant is set by
    /// [`CoProcessor::configure`]).
    const fn new() -> Self {
        LatestScan {
            values: [0; MAX_VALUES],
            count: 0,
            variant: Variant::Fov180Res100,
            counters: Counters {
                scans_in: 0,
                feature_scans_out: 0,
                feature_telegrams_out: 0,
                sensor_crc_errors: 0,
                sensor_resyncs: 0,
                sensor_bytes_skipped: 0,
                host_crc_errors: 0,
                scans_dropped: 0,
                scans_rejected: 0,
            },
        }
    }
}

impl ScanSource for LatestScan {
    fn next_scan(&mut self, variant: Variant, _units: Unit, out: &mut [u16]) -> usize {
        if variant != self.variant {
            return 0; // all "not valid": the sensor runs another variant
        }
        let mut n = 0;
        for (slot, &word) in out.iter_mut().zip(&self.values).take(self.count) {
            *slot = word;
            n += 1;
        }
        n
    }

    fn supports(&self, variant: Variant) -> bool {
        variant == self.variant
    }

    fn extra_command(&mut self, command: u8, data: &[u8], reply: &mut [u8]) -> Option<(u8, usize)> {
        if command != REQ_COUNTERS || !data.is_empty() {
            return None;
        }
        let n = crate::telegram::features::COUNTERS_LEN;
        let slot = reply.get_mut(..n)?;
        self.counters.encode(slot);
        Some((crate::telegram::features::CMD_COUNTERS, n))
    }
}

/// What a poll asks the board to do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PollOutcome {
    /// Switch the sensor UART to this rate now.
    pub sensor_baud: Option<Baud>,
    /// Switch the host UART to this rate now.
    pub host_baud: Option<Baud>,
    /// Scans processed during this poll.
    pub scans: u32,
}

/// A port failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PollError<S, H> {
    /// The sensor-side port.
    Sensor(S),
    /// The host-side port.
    Host(H),
}

impl<S: core::fmt::Debug, H: core::fmt::Debug> core::fmt::Display for PollError<S, H> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PollError::Sensor(e) => write!(f, "sensor port: {e:?}"),
            PollError::Host(e) => write!(f, "host port: {e:?}"),
        }
    }
}

#[cfg(feature = "std")]
impl<S: core::fmt::Debug, H: core::fmt::Debug> std::error::Error for PollError<S, H> {}

/// The co-processor: all its state in fixed buffers (about 20 KiB), so it
/// can live in a `static`.
pub struct CoProcessor {
    params: ValidParams,
    link: SensorLink,
    extractor: Extractor,
    host: Emulator<LatestScan>,
    /// The scan the host last got (by stream or `30 01`) has had its features sent.
    counters: Counters,
    scan_counter: u32,
    /// Features of the latest scan, ready for a `30 01`.
    have_features: bool,
    beams: u16,
    /// The latest scan in metres, decoded in place.
    frame: Frame,
    /// [`CoProcessor::configure`] has run.
    configured: bool,
}

impl CoProcessor {
    /// A co-processor with validated `params` that will bring the sensor up
    /// with `setup`. `const`, so it can be placed in a `static` without
    /// passing through the stack; call [`CoProcessor::start`] before the
    /// first poll.
    pub const fn new(params: ValidParams, setup: SensorSetup) -> Self {
        let mut cop = CoProcessor::unconfigured();
        cop.configure(params, setup);
        cop
    }

    /// A co-processor with nothing set: every byte zero, so that a `static`
    /// of it lands in `.bss` (no flash image, nothing copied at boot).
    /// [`configure`](CoProcessor::configure) it before
    /// [`start`](CoProcessor::start); until then [`poll`](CoProcessor::poll)
    /// touches no port.
    pub const fn unconfigured() -> Self {
        CoProcessor {
            params: ValidParams::UNSET,
            link: SensorLink::zeroed(),
            extractor: Extractor::new(),
            host: Emulator::unpowered(LatestScan::new()),
            counters: LatestScan::new().counters,
            scan_counter: 0,
            have_features: false,
            beams: 0,
            frame: Frame::zeroed(),
            configured: false,
        }
    }

    /// Set the parameters and the sensor set-up of an
    /// [`unconfigured`](CoProcessor::unconfigured) co-processor (in place,
    /// no copy through the stack).
    pub const fn configure(&mut self, params: ValidParams, setup: SensorSetup) {
        let mut settings = Settings::DEFAULT;
        settings.variant = setup.variant;
        settings.external_scans = true;
        self.params = params;
        self.link.configure(setup);
        self.host.set_settings(settings);
        self.host.source_mut().variant = setup.variant;
        self.configured = true;
    }

    /// Switch the host-side face on at `now_us`: like an LMS at power-on it
    /// sends the `90` telegram to the client.
    pub fn start(&mut self, now_us: u64) {
        self.host.power_on(now_us);
    }

    /// The counters (also readable by the host with request `55`).
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The sensor link (bring-up step, retries, framer counters).
    pub fn link(&self) -> &SensorLink {
        &self.link
    }

    /// The features of the latest scan.
    pub fn features(&self) -> &Features {
        self.extractor.features()
    }

    /// Count bytes the board lost before they reached [`CoProcessor::poll`]
    /// (receive queue overflow), when it does not know how many: one scan
    /// dropped. Prefer [`note_sensor_lost`](CoProcessor::note_sensor_lost).
    pub fn note_sensor_overflow(&mut self) {
        self.counters.scans_dropped = self.counters.scans_dropped.wrapping_add(1);
    }

    /// `bytes` from the sensor were lost before they reached
    /// [`CoProcessor::poll`] (receive queue overflow, overrun): every scan
    /// they cut is counted in `scans_dropped` (see
    /// [`SensorLink::take_missed`]).
    pub fn note_sensor_lost(&mut self, bytes: u32) {
        self.link.note_lost(bytes);
    }

    /// Move bytes both ways, process every complete scan, answer the host.
    /// Call it as often as the board can; it never blocks on reading (it
    /// reads only what `read_ready` says is there) and writes with
    /// `write_all`.
    pub fn poll<S, H>(
        &mut self,
        sensor: &mut S,
        host: &mut H,
        now_us: u64,
    ) -> Result<PollOutcome, PollError<S::Error, H::Error>>
    where
        S: Read + ReadReady + Write,
        H: Read + ReadReady + Write,
    {
        let mut outcome = PollOutcome::default();
        if !self.configured {
            return Ok(outcome);
        }
        let mut buf = [0u8; MAX_TELEGRAM_LEN];

        // 1. Host requests into the emulator; its replies out.
        while host.read_ready().map_err(PollError::Host)? {
            let mut chunk = [0u8; CHUNK];
            let n = host.read(&mut chunk).map_err(PollError::Host)?;
            if n == 0 {
                break;
            }
            // `min`: a port that claims more than it was given is not trusted.
            self.host.receive(now_us, &chunk[..n.min(CHUNK)]);
        }
        self.drain_host(host, now_us, &mut outcome)?;

        // 2. Sensor bytes: bring-up replies and scans.
        while sensor.read_ready().map_err(PollError::Sensor)? {
            let mut chunk = [0u8; CHUNK];
            let n = sensor.read(&mut chunk).map_err(PollError::Sensor)?;
            if n == 0 {
                break;
            }
            let mut input = &chunk[..n.min(CHUNK)];
            loop {
                let (event, rest) = self.link.feed(input, now_us);
                input = rest;
                match event {
                    Some(LinkEvent::Scan) => {
                        self.process_scan(host)?;
                        outcome.scans += 1;
                    }
                    Some(LinkEvent::SwitchBaud(b)) => outcome.sensor_baud = Some(b),
                    Some(LinkEvent::Refused(_)) | None => {}
                }
                if event.is_none() && input.is_empty() {
                    break;
                }
            }
        }

        // 3. Time-outs: the baud search's next rate, a silent stream.
        if let Some(LinkEvent::SwitchBaud(b)) = self.link.poll(now_us) {
            outcome.sensor_baud = Some(b);
        }
        // 4. The next bring-up request, if one is due (none in a poll that
        // switches the sensor UART: the board switches after it returns).
        let due = match outcome.sensor_baud {
            Some(_) => None,
            None => self.link.due_request(now_us, &mut buf),
        };
        if let Some(request) = due.and_then(|n| buf.get(..n)) {
            sensor.write_all(request).map_err(PollError::Sensor)?;
        }
        self.sync_counters();
        Ok(outcome)
    }

    /// Hand the host everything the emulator has queued, and act on its events.
    fn drain_host<H: Write, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
        outcome: &mut PollOutcome,
    ) -> Result<(), PollError<E, H::Error>> {
        let mut buf = [0u8; CHUNK];
        loop {
            let n = self.host.transmit(now_us, &mut buf);
            let Some(bytes) = buf.get(..n).filter(|b| !b.is_empty()) else {
                break;
            };
            host.write_all(bytes).map_err(PollError::Host)?;
        }
        while let Some(event) = self.host.next_event() {
            match event {
                HostEvent::BaudSwitched { to, .. } => outcome.host_baud = Some(to),
                HostEvent::BadChecksum => {
                    self.counters.host_crc_errors = self.counters.host_crc_errors.wrapping_add(1);
                }
                // The B0 of a `30 01` has gone out: its features follow.
                HostEvent::Request(Handled::OneScan) if self.have_features => {
                    self.send_features(host)?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// One intact `B0` from the sensor: decode, run the pipeline, pass the
    /// scan and its features to a streaming host.
    fn process_scan<H: Write, E>(&mut self, host: &mut H) -> Result<(), PollError<E, H::Error>> {
        self.counters.scans_in = self.counters.scans_in.wrapping_add(1);
        self.scan_counter = self.counters.scans_in;
        let bytes = self.link.scan_bytes();
        let frame = &mut self.frame;
        let measured = Telegram::new_checked(bytes, Direction::SensorToHost)
            .ok()
            .and_then(|t| MeasuredView::parse(&t).ok())
            .filter(|m| m.to_frame_into(RangeBits::Bits13, frame).is_ok());
        let Some(measured) = measured else {
            self.counters.scans_rejected = self.counters.scans_rejected.wrapping_add(1);
            self.have_features = false;
            return Ok(());
        };
        // The host's `30 01` and `31` see this scan.
        let latest = self.host.source_mut();
        latest.count = 0;
        for (slot, word) in latest.values.iter_mut().zip(measured.words()) {
            *slot = word;
            latest.count += 1;
        }
        self.beams = self.frame.len() as u16;
        self.extractor.run(&self.frame, &self.params);
        self.have_features = true;
        if self.host.streaming() {
            // Never inside a reply: the emulator hands out whole frames at
            // once in external-scan mode, and `drain_host` emptied it.
            host.write_all(self.link.scan_bytes())
                .map_err(PollError::Host)?;
            self.send_features(host)?;
        }
        Ok(())
    }

    /// The feature telegrams of the latest scan to the host.
    fn send_features<H: Write, E>(&mut self, host: &mut H) -> Result<(), PollError<E, H::Error>> {
        let echoed = EchoedParams::from(self.params.get());
        let sent = emit_features(
            self.scan_counter,
            self.beams,
            &echoed,
            self.extractor.features(),
            0,
            |t| host.write_all(t),
        )
        .map_err(PollError::Host)?;
        self.counters.feature_scans_out = self.counters.feature_scans_out.wrapping_add(1);
        self.counters.feature_telegrams_out =
            self.counters.feature_telegrams_out.wrapping_add(sent);
        Ok(())
    }

    /// Copy the framer counters into [`Counters`] and the host-visible copy.
    fn sync_counters(&mut self) {
        let missed = self.link.take_missed();
        self.counters.scans_dropped = self.counters.scans_dropped.wrapping_add(missed);
        let s = self.link.framer_stats();
        self.counters.sensor_crc_errors = s.crc_errors;
        self.counters.sensor_resyncs = s.resyncs;
        self.counters.sensor_bytes_skipped = s.bytes_skipped;
        self.host.source_mut().counters = self.counters;
    }
}
