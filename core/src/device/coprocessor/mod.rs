//! The sensor co-processor: an LMS 2xx on one serial line, the robot's
//! computer on the other.
//!
//! - Sensor side ([`sensor_link`]): brings the LMS up (variant, units,
//!   baud, continuous output) and takes its `B0` stream.
//! - Every intact scan runs through the [`Extractor`].
//! - Host side: an [`Emulator`] answers the client exactly like an LMS 2xx
//!   (its scans are the sensor's latest); while the client has continuous
//!   output on, every sensor `B0` is passed through unchanged. By default
//!   the host line carries exactly what an LMS would; a client that sends
//!   `56 01` ([`REQ_FEATURES`]) also gets each scan's feature telegrams
//!   ([`crate::telegram::features`]) right after its `B0` (and after the
//!   `B0` of a `30 01`), until `56 00` or the end of its session: a rate
//!   request (`20 4x`, with which every LMS driver starts) or a reset
//!   (`10`) (docs/PROTOCOL.md §2a). The request `55` reads the [`Counters`].
//! - Transparency: the host face reports the sensor's variant and units
//!   (`B1`, `F4`, `BB`); a client's accepted `3B` or `77` that changes the
//!   variant or the units brings the sensor up again with them
//!   ([`SensorLink::reconfigure`]); until its scans come, scans of the old
//!   setting are not passed on ([`Counters::scans_other_setting`]); a
//!   `77` is written to the sensor whole. `3A`, the value modes
//!   (`20 26`/`27`/`28`) and the partial scans (`20 2A`) are relayed
//!   ([`ScanSource::relay`]): `ACK` at once, the sensor's reply byte for
//!   byte, then its `B6`/`B7`/`BF` passed through (no features: the
//!   pipeline takes whole single scans), or its partial `B0`s passed
//!   through and joined into whole scans for the pipeline
//!   ([`Counters::partial_scans_unassembled`] where they cannot be), until
//!   another mode, `3B`, `77` or `10` brings the sensor back to `B0`s.
//!   Scans with real-time indices (configuration availability bit 1) pass
//!   through as sent; the pipeline reads their values.
//! - Nothing stays claimed: a relayed request is taken only if the face's
//!   reply queue has room (else dropped whole and counted,
//!   [`Counters::host_requests_dropped`]); one that comes while another is
//!   in flight is refused at once ([`Counters::relays_refused`]); one the
//!   sensor does not answer within [`RELAY_TIMEOUT_US`] fails
//!   ([`Counters::relays_failed`]); a reset lets it go.
//! - Host-line budget ([`host_line`]): the co-processor models the host
//!   line's time at the client's rate; a scan (with its features, if on) is
//!   sent whole only if the line is free within one scan period, else it is
//!   dropped and counted ([`Counters::host_scans_dropped`]).
//! - The host line never blocks the loop ([`WriteRoom`]): a scan's `B0` is
//!   written before the pipeline runs and only if the host port has room
//!   for it whole; its feature telegrams follow one at a time as room
//!   frees (a *pump*, [`CoProcessor::features_pending`]), and the face's
//!   replies wait behind them (the wire order a blocking write gave). A
//!   scan that arrives while the features of the last one, or a frame of
//!   the face, are still going out is not taken (the features and the
//!   `30 01` scan stay those of the last one): counted in
//!   `host_scans_dropped` if the client streams.
//!
//! [`CoProcessor::poll`] is generic over `embedded-io` serial ports, so the
//! firmware (UARTs) and the host build (pseudo-terminals) run the same code;
//! time comes in as an argument.
//!
//! # Example: a board's main loop
//!
//! On a board, the UARTs' receive interrupts fill a queue per line and the
//! main loop polls the co-processor with both ports and the time (µs); a
//! poll moves what has arrived both ways, runs the pipeline on each whole
//! scan and says when to switch a UART's rate. Here the sensor is the
//! crate's LMS 2xx emulator and both lines are in memory (`Port` of
//! `lms_core::test_support`, feature `test-support`): the co-processor
//! brings the sensor up, then takes its scans.
//!
//! ```
//! use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
//! use lms_core::device::emulator::{Emulator, FnSource, Settings};
//! use lms_core::test_support::Port;
//! use lms_core::{Unit, ValidParams, Variant};
//!
//! // A `static` on a board (about 14 KiB, all in `.bss`); boxed here.
//! let mut cop = Box::new(CoProcessor::new(ValidParams::DEFAULT, SensorSetup::DEFAULT));
//! // The LMS: a wall 2 m ahead.
//! let wall = FnSource::new(|variant: Variant, unit: Unit, out: &mut [u16]| {
//!     let per_metre = if unit == Unit::Millimetre { 1000.0 } else { 100.0 };
//!     for (j, v) in out.iter_mut().enumerate() {
//!         let phi = variant.geometry().bearing(j);
//!         *v = (2.0 / libm::sinf(phi).max(0.25) * per_metre) as u16;
//!     }
//!     out.len()
//! });
//! let mut lms = Emulator::new(wall, Settings::default(), 0);
//! let (mut sensor_line, mut host_line) = (Port::default(), Port::default());
//! let mut buf = [0u8; 1024];
//! cop.start(0);
//! let mut scans = 0;
//! for tick in 1..=15_000u64 {
//!     let now_us = tick * 200;
//!     // The sensor's end of the line (on a board: the LMS and the sensor
//!     // UART's receive interrupt, which queues its bytes).
//!     lms.receive(now_us, &std::mem::take(&mut sensor_line.tx));
//!     while let n @ 1.. = lms.transmit(now_us, &mut buf) {
//!         sensor_line.rx.extend(&buf[..n]);
//!     }
//!     while lms.next_event().is_some() {}
//!     // The main loop.
//!     let outcome = cop.poll(&mut sensor_line, &mut host_line, now_us).unwrap();
//!     if let Some(_rate) = outcome.sensor_baud {
//!         // On a board: switch the sensor UART to `_rate` now.
//!     }
//!     scans += outcome.scans;
//! }
//! assert_eq!(cop.link().step(), Step::Streaming);
//! assert!(scans > 10, "{scans} scans");
//! assert_eq!(cop.counters().scans_in, scans);
//! assert_eq!(cop.features().lines().len(), 1); // the wall
//! ```

pub mod host_line;
pub mod sensor_link;
#[cfg(test)]
mod tests;

use embedded_io::{Read, ReadReady, Write};

use crate::device::emulator::{
    partial_values, turns_per_scan, Emulator, Event as HostEvent, Handled, ScanSource, Settings,
    ValueMode, MIN_TX_CAPACITY, MODE_PARTIAL,
};
use crate::features::Features;
use crate::maths::divisor;
use crate::params::ValidParams;
use crate::pipeline::extractor::Extractor;
use crate::telegram::features::{
    emit_features_from, BootRecord, Counters, EchoedParams, FeaturesOf, CMD_FEATURES, REQ_COUNTERS,
    REQ_FEATURES,
};
use crate::telegram::reply::{self, ModeResult};
use crate::telegram::request;
use crate::telegram::{
    Baud, Config, Direction, MeasuredView, RangeBits, Telegram, HEADER_LEN, MAX_TELEGRAM_LEN,
    MAX_VALUES,
};
use crate::Unit;
use crate::{Frame, Variant};

pub use host_line::{HostLine, WriteRoom, HOST_TX_MIN_ROOM};
pub use sensor_link::{LinkEvent, SensorLink, SensorSetup, Step};

/// Bytes handed to the host port per call.
const CHUNK: usize = 256;

/// Bytes read from a port per call (the buffer is cleared at every read).
/// A board that polls only once this many sensor bytes wait (or a tick has
/// passed) reads a chunk per call.
pub const READ_CHUNK: usize = 64;

/// Bytes kept of a relayed request's reply (`BA` of `3A`: 28; `A0`: 10).
pub const RELAY_REPLY_CAPACITY: usize = 48;

/// Where the client's relayed request is ([`LatestScan::relay`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Relay {
    /// None (first: all zero).
    Idle,
    /// Taken from the client, not yet handed to the sensor link.
    Asked(RelayedRequest),
    /// Forwarded; the sensor's reply awaited.
    Sent(RelayedRequest),
    /// The sensor's reply, for the face to pass on.
    Ready(RelayedReply),
    /// No reply came: the client gets none either.
    Failed,
}

/// A client's request for the sensor: its command and data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RelayedRequest {
    command: u8,
    data: [u8; sensor_link::FORWARD_DATA_CAPACITY],
    len: u8,
}

impl RelayedRequest {
    /// The request's data bytes.
    fn data(&self) -> &[u8] {
        self.data.get(..usize::from(self.len)).unwrap_or_default()
    }
}

/// The sensor's reply to a relayed request, byte for byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RelayedReply {
    bytes: [u8; RELAY_REPLY_CAPACITY],
    len: u8,
}

/// Whether the client gets each scan's feature telegrams (`56 01`/`56 00`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FeatureTelegrams {
    /// Exactly what an LMS sends (the default, and after the client's
    /// session ends).
    Off,
    /// Each scan's feature telegrams after its `B0`.
    On,
}

/// Whether the sensor link streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SensorLine {
    /// The sensor is being brought up (or again).
    BringingUp,
    /// Its bring-up is done: it streams.
    Streaming,
}

/// The sensor's latest scan, served to the host for `30 01` and `31`, and
/// the counters for `55`.
pub struct LatestScan {
    values: [u16; MAX_VALUES],
    count: usize,
    variant: Variant,
    /// The latest scan's real-time index, if the sensor sent one.
    index: Option<u8>,
    counters: Counters,
    /// Whether the client has switched the feature telegrams on (`56 01`).
    features: FeatureTelegrams,
    /// A request the sensor answers (`3A`, `20 26`/`27`/`28`, …), where it
    /// is, and the sensor's reply.
    relay: Relay,
    /// Whether the sensor link streams (its bring-up is done): `3A` is
    /// relayed only then (before, the face answers it, as the sensor may
    /// take seconds to come up).
    sensor: SensorLine,
    /// Relayed requests answered by the face instead because another
    /// one was in flight ([`Counters::relays_refused`]).
    relays_refused: u32,
}

impl LatestScan {
    /// Every byte zero (no scan yet; the variant is set by
    /// [`CoProcessor::configure`]).
    const fn new() -> Self {
        LatestScan {
            values: [0; MAX_VALUES],
            count: 0,
            variant: Variant::Fov180Res100,
            index: None,
            counters: Counters::ZERO,
            features: FeatureTelegrams::Off,
            relay: Relay::Idle,
            sensor: SensorLine::BringingUp,
            relays_refused: 0,
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

    /// The face streams its `30 01` `B0` from the latest scan, word by
    /// word (no transmit copy of it).
    fn word(&self, variant: Variant, _units: Unit, index: usize) -> Option<u16> {
        let values = self.values.get(..self.count)?;
        values
            .get(index)
            .copied()
            .filter(|_| variant == self.variant)
    }

    /// The sensor's index of the latest scan, sent with a `30 01` `B0`
    /// when the configuration asks for indices.
    fn real_time_index(&self) -> Option<u8> {
        self.index
    }

    /// Every variant: the co-processor sets the sensor up for the one the
    /// client asks for (an LMS 2xx has all five).
    fn supports(&self, _variant: Variant) -> bool {
        true
    }

    fn extra_command(&mut self, command: u8, data: &[u8], reply: &mut [u8]) -> Option<(u8, usize)> {
        match (command, data) {
            (REQ_COUNTERS, []) => {
                let n = crate::telegram::features::COUNTERS_LEN;
                let slot = reply.get_mut(..n)?;
                self.counters.encode(slot);
                Some((crate::telegram::features::CMD_COUNTERS, n))
            }
            (REQ_FEATURES, &[state @ (0 | 1)]) => {
                *reply.first_mut()? = state;
                self.features = match state {
                    1 => FeatureTelegrams::On,
                    _ => FeatureTelegrams::Off,
                };
                Some((CMD_FEATURES, 1))
            }
            _ => None,
        }
    }

    /// The sensor answers `3A` (its type string), the value modes
    /// `20 26`/`27`/`28` (it checks their parameters and streams
    /// `B6`/`B7`/`BF`) and every request whose command the face does not
    /// interpret ([`face_interprets`]; once the sensor streams, with at most
    /// [`sensor_link::FORWARD_DATA_CAPACITY`] data bytes), one at a time.
    fn relay(&mut self, command: u8, data: &[u8]) -> bool {
        let wanted = match command {
            request::code::SENSOR_TYPE => data.is_empty() && self.sensor == SensorLine::Streaming,
            _ if face_interprets(command) => relayed_mode(command, data),
            _ => self.sensor == SensorLine::Streaming,
        };
        let mut request = RelayedRequest {
            command,
            data: [0; sensor_link::FORWARD_DATA_CAPACITY],
            len: data.len() as u8,
        };
        let Some(slot) = request.data.get_mut(..data.len()) else {
            return false;
        };
        if !wanted {
            return false;
        }
        if self.relay != Relay::Idle {
            // Refused at once (the face answers it: `92`, or its own `BA`
            // for `3A`), counted.
            self.relays_refused = self.relays_refused.wrapping_add(1);
            return false;
        }
        slot.copy_from_slice(data);
        self.relay = Relay::Asked(request);
        true
    }

    fn relayed_reply(&mut self, out: &mut [u8]) -> Option<usize> {
        match self.relay {
            Relay::Ready(reply) => {
                self.relay = Relay::Idle;
                let reply = reply.bytes.get(..usize::from(reply.len))?;
                let slot = out.get_mut(..reply.len())?;
                slot.copy_from_slice(reply);
                Some(reply.len())
            }
            Relay::Failed => {
                self.relay = Relay::Idle;
                Some(0)
            }
            Relay::Idle | Relay::Asked(_) | Relay::Sent(_) => None,
        }
    }

    fn relay_dropped(&mut self) {
        self.relay = Relay::Idle;
    }

    /// The feature opt-in (`56 01`) belongs to the client that sent it.
    fn new_session(&mut self) {
        self.features = FeatureTelegrams::Off;
    }
}

/// `true` for the mode requests the sensor answers through the face: the
/// value modes `20 26`/`27`/`28` and the partial scans `20 2A`.
fn relayed_mode(command: u8, data: &[u8]) -> bool {
    ValueMode::parse(command, data).is_some() || is_partial_mode(command, data)
}

/// `true` for `20 2A` (continuous output of partial scans).
fn is_partial_mode(command: u8, data: &[u8]) -> bool {
    (command, data) == (request::code::MODE, &[MODE_PARTIAL][..])
}

/// `true` for the commands the face answers itself: those of an LMS 2xx it
/// emulates (`10`, `20`, `30`, `31`, `3A`, `3B`, `74`, `77`; malformed
/// ones get `92`, a mode `20 xx` it does not know too: the sensor must stay
/// on the stream the co-processor lives on) and the co-processor's own
/// `55`/`56`. A request with any other command is relayed to the sensor
/// ([`ScanSource::relay`]).
pub const fn face_interprets(command: u8) -> bool {
    use crate::telegram::request::code;
    matches!(
        command,
        code::MODE
            | code::MEASURED
            | code::STATUS
            | code::SENSOR_TYPE
            | code::VARIANT
            | code::READ_CONFIG
            | code::WRITE_CONFIG
            | code::RESET
            | REQ_COUNTERS
            | REQ_FEATURES
    )
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
    host: Emulator<LatestScan, MIN_TX_CAPACITY>,
    /// The host line's time budget.
    host_line: HostLine,
    counters: Counters,
    /// Which scan the extractor's features are of, if they are of the
    /// latest scan (ready for a `30 01`).
    latest_features: Option<FeaturesOf>,
    /// The latest scan in metres, decoded in place.
    frame: Frame,
    /// Whether [`CoProcessor::configure`] has run.
    setup: Setup,
    /// Whether the face reports the sensor's configuration of its latest
    /// bring-up.
    face: FaceConfig,
    /// What the sensor streams for the client.
    stream: SensorStream,
    /// Feature telegrams of the latest scan still to go to the host.
    pump: Option<Pump>,
    /// Whose request the sensor link's forward under way is.
    forward: ForwardOwner,
    /// A relayed request not answered by then (µs) fails: the client gets
    /// no reply, as from a sensor that does not answer (0: none waits).
    relay_deadline_us: u64,
}

/// Time a relayed request may wait for the sensor's reply, from when the
/// co-processor took it (µs): past it the request fails
/// ([`Counters::relays_failed`]) and the face's queue moves on (a sensor
/// being brought up again may take longer).
pub const RELAY_TIMEOUT_US: u64 = 2_000_000;

/// The feature telegrams of a scan still to go to the host: from index
/// `next` on (of [`emit_features_from`]), each when the host port has room
/// for it whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pump {
    of: FeaturesOf,
    next: u32,
    /// When its `B0` was written (µs): the host-line budget counts the
    /// features right behind it, as one group (on the line they follow the
    /// `B0` once the pipeline has run, which takes about as long as the
    /// `B0` at 500 kBd and far less at lower rates).
    at_us: u64,
}

impl Pump {
    /// Every telegram of `of` from the first, behind a `B0` written at
    /// `at_us`.
    const fn start(of: FeaturesOf, at_us: u64) -> Self {
        Pump { of, next: 0, at_us }
    }
}

/// Whether a co-processor has its parameters and sensor set-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Setup {
    /// [`CoProcessor::unconfigured`]: polls touch no port.
    Unconfigured,
    /// [`CoProcessor::configure`] has run.
    Configured,
}

/// Whether the face reports the sensor's configuration (`F4`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FaceConfig {
    /// The sensor is being brought up: the face takes its configuration
    /// once it streams.
    AwaitingSensor,
    /// The face has the configuration of the sensor's latest bring-up.
    Synced,
}

/// What the sensor streams for the client.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SensorStream {
    /// Whole scans (`B0`): the pipeline runs on each.
    Scans,
    /// A value mode the client asked for (`B6`/`B7`/`BF` passed on, no
    /// features), averaging `samples` scans (1: none).
    Values { samples: u8 },
    /// Partial scans (`20 2A`), each passed on, joined into whole scans for
    /// the pipeline; `next` is the partial scan expected next of the scan
    /// being joined (0: none begun).
    Partial { next: u8 },
    /// The client has left its value mode: the sensor is to go back to
    /// `B0`s (`20 24`, forwarded by the co-processor itself).
    Restoring,
}

impl SensorStream {
    /// The sensor streams telegrams of a mode the client asked for.
    const fn is_relayed(self) -> bool {
        matches!(
            self,
            SensorStream::Values { .. } | SensorStream::Partial { .. }
        )
    }
}

/// Whose request the sensor link's forward under way is, if one is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ForwardOwner {
    /// The co-processor's own `20 24`, or none.
    CoProcessor,
    /// The client's relayed request.
    Client,
}

impl ForwardOwner {
    /// Withdraw the client's relayed request from `link`, if the forward
    /// under way is the client's and not on the line yet (else its reply is
    /// dropped when it comes).
    fn cancel_client(&mut self, link: &mut SensorLink) {
        if *self == ForwardOwner::Client && link.cancel_forward() {
            *self = ForwardOwner::CoProcessor;
        }
    }
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
            host_line: HostLine::new(),
            counters: Counters::ZERO,
            latest_features: None,
            frame: Frame::zeroed(),
            setup: Setup::Unconfigured,
            face: FaceConfig::AwaitingSensor,
            stream: SensorStream::Scans,
            pump: None,
            forward: ForwardOwner::CoProcessor,
            relay_deadline_us: 0,
        }
    }

    /// Set the parameters and the sensor set-up of an
    /// [`unconfigured`](CoProcessor::unconfigured) co-processor (in place,
    /// no copy through the stack).
    pub const fn configure(&mut self, params: ValidParams, setup: SensorSetup) {
        let mut settings = Settings::DEFAULT;
        settings.variant = setup.variant;
        settings.external_scans = true;
        // The face reports the sensor's units (F4, B1): those of `setup`.
        settings.config = Config::ZERO.with_units_code(units_code(setup.units));
        self.params = params;
        self.link.configure(setup);
        self.host.set_settings(settings);
        self.host.source_mut().variant = setup.variant;
        self.setup = Setup::Configured;
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

    /// The host face (the LMS the client sees: its rate, mode, variant, units).
    pub fn host_face(&self) -> &Emulator<LatestScan, MIN_TX_CAPACITY> {
        &self.host
    }

    /// `true` while the client has the feature telegrams on (`56 01`).
    pub fn features_on(&self) -> bool {
        self.host.source().features == FeatureTelegrams::On
    }

    /// `true` while feature telegrams of the latest scan wait for room on
    /// the host port (the face's replies and the next scan wait too).
    pub fn features_pending(&self) -> bool {
        self.pump.is_some()
    }

    /// Count bytes the board lost before they reached [`CoProcessor::poll`]
    /// (receive queue overflow), when it does not know how many: one scan
    /// dropped. Prefer [`note_sensor_lost`](CoProcessor::note_sensor_lost).
    pub fn note_sensor_overflow(&mut self) {
        self.counters.scans_dropped = self.counters.scans_dropped.wrapping_add(1);
    }

    /// Record what the board found at boot (reset flags, the previous boot's
    /// fault record), reported with the counters (`55` → `D5`).
    pub fn note_boot(&mut self, boot: BootRecord) {
        self.counters.set_boot(boot);
        self.host.source_mut().counters = self.counters;
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
    /// reads only what `read_ready` says is there) nor on the host line (it
    /// writes only what [`WriteRoom::write_room`] says fits; the rest waits
    /// for the next poll). The sensor port gets only the short bring-up
    /// requests (`write_all`).
    pub fn poll<S, H>(
        &mut self,
        sensor: &mut S,
        host: &mut H,
        now_us: u64,
    ) -> Result<PollOutcome, PollError<S::Error, H::Error>>
    where
        S: Read + ReadReady + Write,
        H: Read + ReadReady + WriteRoom,
    {
        let mut outcome = PollOutcome::default();
        if self.setup == Setup::Unconfigured {
            return Ok(outcome);
        }
        // 1. Host requests into the emulator; its replies out.
        self.read_host(host, now_us, &mut outcome)?;
        self.drain_host(host, now_us, &mut outcome)?;

        // 2. Sensor bytes: bring-up replies and scans.
        while sensor.read_ready().map_err(PollError::Sensor)? {
            let mut chunk = [0u8; READ_CHUNK];
            let n = sensor.read(&mut chunk).map_err(PollError::Sensor)?;
            if n == 0 {
                break;
            }
            let mut input = &chunk[..n.min(READ_CHUNK)];
            loop {
                let (event, rest) = self.link.feed(input, now_us);
                input = rest;
                match event {
                    Some(LinkEvent::Scan) => {
                        self.process_scan(host, now_us)?;
                        outcome.scans += 1;
                    }
                    Some(LinkEvent::SwitchBaud(b)) => outcome.sensor_baud = Some(b),
                    Some(LinkEvent::Forwarded { answered }) => {
                        self.forwarded(answered);
                        // The relayed reply goes out before the stream it
                        // starts (its first B6/B7/BF may be in this chunk:
                        // seen under load, a B7 before the A0).
                        self.drain_host(host, now_us, &mut outcome)?;
                    }
                    Some(LinkEvent::Refused(_)) | None => {}
                }
                if event.is_none() && input.is_empty() {
                    break;
                }
            }
        }

        self.sync_face();
        // 3. Time-outs: the baud search's next rate, a silent stream.
        match self.link.poll(now_us) {
            Some(LinkEvent::SwitchBaud(b)) => outcome.sensor_baud = Some(b),
            Some(LinkEvent::Forwarded { answered }) => self.forwarded(answered),
            _ => {}
        }
        self.hand_to_sensor(now_us);
        // 4. The next bring-up request, if one is due (none in a poll that
        // switches the sensor UART: the board switches after it returns).
        if outcome.sensor_baud.is_none() && self.link.may_request() {
            self.send_due_request(sensor, now_us)?;
        }
        self.sync_counters();
        Ok(outcome)
    }

    /// The sensor link's due request, if it has one, to the sensor port
    /// (the buffer is cleared only when a request may be due: a streaming
    /// poll costs no 818-byte clear).
    fn send_due_request<S: Write, E>(
        &mut self,
        sensor: &mut S,
        now_us: u64,
    ) -> Result<(), PollError<S::Error, E>> {
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        let due = self.link.due_request(now_us, &mut buf);
        if let Some(request) = due.and_then(|n| buf.get(..n)) {
            sensor.write_all(request).map_err(PollError::Sensor)?;
        }
        Ok(())
    }

    /// Every request the host port has ready, into the face; the events of
    /// each chunk acted on at once (a burst must not overflow them).
    fn read_host<H: Read + ReadReady, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
        outcome: &mut PollOutcome,
    ) -> Result<(), PollError<E, H::Error>> {
        while host.read_ready().map_err(PollError::Host)? {
            let mut chunk = [0u8; READ_CHUNK];
            let n = host.read(&mut chunk).map_err(PollError::Host)?;
            if n == 0 {
                break;
            }
            // `min`: a port that claims more than it was given is not trusted.
            self.host.receive(now_us, &chunk[..n.min(READ_CHUNK)]);
            while let Some(event) = self.host.next_event() {
                self.on_host_event(event, now_us, outcome);
            }
        }
        Ok(())
    }

    /// Hand the host what the emulator has queued, as far as the host port
    /// has room (none while feature telegrams wait: they go first), and act
    /// on its events.
    fn drain_host<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
        outcome: &mut PollOutcome,
    ) -> Result<(), PollError<E, H::Error>> {
        self.pump(host)?;
        let mut buf = [0u8; CHUNK];
        while self.pump.is_none() {
            // `transmit` stops after the last byte before a baud switch,
            // and when `out` is full (the rest of a frame waits in the face).
            let room = host.write_room().map_err(PollError::Host)?;
            let rate = self.host.baud();
            let out = buf.get_mut(..room.min(CHUNK)).unwrap_or_default();
            let n = self.host.transmit(now_us, out);
            let Some(bytes) = buf.get(..n).filter(|b| !b.is_empty()) else {
                break;
            };
            host.write_all(bytes).map_err(PollError::Host)?;
            self.host_line.occupy(now_us, bytes.len(), rate);
        }
        while let Some(event) = self.host.next_event() {
            self.on_host_event(event, now_us, outcome);
        }
        // The features of a `30 01` whose `B0` has just gone out.
        self.pump(host)
    }

    /// Act on an event of the host face.
    fn on_host_event(&mut self, event: HostEvent, now_us: u64, outcome: &mut PollOutcome) {
        match event {
            HostEvent::BaudSwitched { to, .. } => outcome.host_baud = Some(to),
            // The B0 of a `30 01` has gone out whole: its features follow.
            HostEvent::ScanSent {
                continuous: false, ..
            } if self.features_on() && self.latest_features.is_some() => {
                self.pump = self.latest_features.map(|of| Pump::start(of, now_us));
            }
            HostEvent::Request(Handled::SetVariant { accepted: true, .. }) => {
                self.leave_values();
                self.follow_client(false);
            }
            HostEvent::Request(Handled::WriteConfig { accepted: true }) => {
                self.leave_values();
                let differs = self.link.write_config(*self.host.config());
                self.follow_client(differs);
            }
            HostEvent::Request(Handled::Reset) => {
                self.leave_values();
                // Nothing of the last session goes on: its features either.
                self.pump = None;
                self.latest_features = None;
            }
            // A new client session (docs/PROTOCOL.md §2a): the rest of the
            // last client's feature group is not sent (the reply goes next).
            HostEvent::Request(Handled::SetBaud(_)) => {
                self.pump = None;
                self.latest_features = None;
            }
            HostEvent::Request(
                Handled::Continuous | Handled::OnRequest | Handled::InstallationMode { .. },
            ) => self.leave_values(),
            _ => {}
        }
    }

    /// The sensor streams: the face reports its configuration (F4).
    fn sync_face(&mut self) {
        let streaming = self.link.step() == sensor_link::Step::Streaming;
        if streaming && self.face == FaceConfig::AwaitingSensor {
            if let Some(c) = self.link.config() {
                self.host.set_config(c);
            }
            self.face = FaceConfig::Synced;
        }
    }

    /// Requests for the sensor: back to `B0`s after a value mode, then the
    /// client's relayed request; a relayed request the link dropped (a
    /// restart) or that waits past [`RELAY_TIMEOUT_US`] fails (counted),
    /// and a forward of a relayed request the face let go (a reset) is
    /// withdrawn: nothing stays claimed.
    fn hand_to_sensor(&mut self, now_us: u64) {
        if self.host.source().relay == Relay::Idle {
            // The face let the request go (power-on): not to be sent.
            self.forward.cancel_client(&mut self.link);
        }
        let restore = self.stream == SensorStream::Restoring;
        let back_to_scans = [request::code::MODE_CONTINUOUS];
        if restore
            && self.forward == ForwardOwner::CoProcessor
            && self.link.forward(request::code::MODE, &back_to_scans)
        {
            self.stream = SensorStream::Scans;
        }
        let latest = &mut self.host.source_mut();
        let waiting = matches!(latest.relay, Relay::Asked(_) | Relay::Sent(_));
        self.relay_deadline_us = match (waiting, self.relay_deadline_us) {
            (false, _) => 0,
            (true, 0) => now_us.saturating_add(RELAY_TIMEOUT_US).max(1),
            (true, d) => d,
        };
        let late = waiting && now_us >= self.relay_deadline_us;
        match latest.relay {
            // A forward on the line ends by the link's own time-out.
            Relay::Asked(_) | Relay::Sent(_) if late && !self.link.forward_sent() => {
                self.forward.cancel_client(&mut self.link);
                latest.relay = Relay::Failed;
                self.counters.relays_failed = self.counters.relays_failed.wrapping_add(1);
            }
            // Handed to the link if it takes it now (else tried next poll).
            Relay::Asked(request) if self.link.forward(request.command, request.data()) => {
                latest.relay = Relay::Sent(request);
                self.forward = ForwardOwner::Client;
            }
            Relay::Sent(_) if !self.link.forwarding() => {
                latest.relay = Relay::Failed;
                self.forward = ForwardOwner::CoProcessor;
                self.counters.relays_failed = self.counters.relays_failed.wrapping_add(1);
            }
            _ => {}
        }
    }

    /// A forwarded request is done: the client's (its reply relayed; an
    /// accepted value mode starts its stream) or ours (`20 24`, retried
    /// until answered).
    fn forwarded(&mut self, answered: bool) {
        let latest = self.host.source_mut();
        let owner = core::mem::replace(&mut self.forward, ForwardOwner::CoProcessor);
        let request = match (owner, latest.relay) {
            (ForwardOwner::Client, Relay::Sent(request)) => request,
            // The client's, let go meanwhile (a reset): its reply is dropped.
            (ForwardOwner::Client, _) => return,
            // Ours (`20 24`): done when the sensor took it (`A0`).
            (ForwardOwner::CoProcessor, _) => {
                let taken = mode_change_result(self.link.scan_bytes()).is_some();
                if answered && taken {
                    self.link.set_stream_samples(1);
                } else {
                    self.stream = SensorStream::Restoring;
                }
                return;
            }
        };
        let reply = self.link.scan_bytes();
        let mut ready = RelayedReply {
            bytes: [0; RELAY_REPLY_CAPACITY],
            len: reply.len() as u8,
        };
        let Some(slot) = ready.bytes.get_mut(..reply.len()).filter(|_| answered) else {
            latest.relay = Relay::Failed;
            self.counters.relays_failed = self.counters.relays_failed.wrapping_add(1);
            return;
        };
        slot.copy_from_slice(reply);
        latest.relay = Relay::Ready(ready);
        let mode = ValueMode::parse(request.command, request.data());
        let partial = is_partial_mode(request.command, request.data());
        let ok = mode_change_result(reply) == Some(ModeResult::Ok);
        let samples = match (mode, partial) {
            (Some(mode), _) => Some(mode.samples().max(1)),
            (None, true) => Some(1),
            (None, false) => None,
        };
        if let (Some(samples), true) = (samples, ok) {
            // A client that left the mode while its request was on the line
            // (`20 24`, `20 25`, …) has the sensor brought back to `B0`s.
            if self.stream != SensorStream::Restoring {
                self.stream = match partial {
                    true => SensorStream::Partial { next: 0 },
                    false => SensorStream::Values { samples },
                };
            }
            self.link.set_stream_samples(samples);
        }
    }

    /// The client left the value mode (any mode change, a reset, a new
    /// variant or configuration): the sensor goes back to `B0`s.
    fn leave_values(&mut self) {
        if self.stream.is_relayed() {
            self.stream = SensorStream::Restoring;
        }
    }

    /// The client changed the face's variant, units or configuration:
    /// bring the sensor up with them (its scans of the old setting are not passed on meanwhile).
    /// `config_differs`: the client's `77` changed more than the units.
    fn follow_client(&mut self, config_differs: bool) {
        let current = self.link.setup();
        let wanted = SensorSetup {
            variant: self.host.variant(),
            units: self.host.units(),
            ..current
        };
        if wanted != current || config_differs {
            self.link.reconfigure(wanted);
            self.face = FaceConfig::AwaitingSensor;
        }
    }

    /// One intact `B0` from the sensor: decode, run the pipeline, pass the
    /// scan and its features to a streaming host.
    fn process_scan<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
    ) -> Result<(), PollError<E, H::Error>> {
        self.counters.scans_in = self.counters.scans_in.wrapping_add(1);
        // What of the last scan's features fits now goes first (the line
        // has been sending since the last poll): then this scan may be taken.
        self.pump(host)?;
        let command = self.link.scan_bytes().get(HEADER_LEN);
        if command != Some(&crate::telegram::measured::MEASURED_COMMAND) {
            return self.pass_values(host, now_us);
        }
        // The sensor's measuring mode decides the range bits (13/14/15).
        let bits = self.link.config().map_or(RangeBits::Bits13, |c| {
            RangeBits::from_measuring_mode(c.measuring_mode())
        });
        let bytes = self.link.scan_bytes();
        let partial = Telegram::new_checked(bytes, Direction::SensorToHost)
            .ok()
            .and_then(|t| MeasuredView::parse(&t).ok())
            .and_then(|m| m.partial_offset());
        if let Some(offset) = partial {
            return self.process_partial(host, now_us, offset, bits);
        }
        let bytes = self.link.scan_bytes();
        let frame = &mut self.frame;
        let measured = Telegram::new_checked(bytes, Direction::SensorToHost)
            .ok()
            .and_then(|t| MeasuredView::parse(&t).ok())
            .filter(|m| m.to_frame_into(bits, frame).is_ok());
        let Some(measured) = measured else {
            self.counters.scans_rejected = self.counters.scans_rejected.wrapping_add(1);
            self.latest_features = None;
            return Ok(());
        };
        let variant = Variant::from_beams(measured.count());
        if variant != Some(self.host.variant()) || measured.units() != self.host.units() {
            self.counters.scans_other_setting = self.counters.scans_other_setting.wrapping_add(1);
            return Ok(());
        }
        if self.host_busy() {
            // The last scan's features or the face's `B0` of it are still
            // going out: they stay that scan's (this one is not taken).
            if self.host.streaming() && !self.stream.is_relayed() {
                self.counters.host_scans_dropped = self.counters.host_scans_dropped.wrapping_add(1);
            }
            return Ok(());
        }
        // The host's `30 01` and `31` see this scan.
        let face_variant = self.host.variant();
        let index = measured.real_time_index();
        let latest = self.host.source_mut();
        latest.variant = face_variant;
        latest.index = index;
        latest.count = 0;
        for (slot, word) in latest.values.iter_mut().zip(measured.words()) {
            *slot = word;
            latest.count += 1;
        }
        // The `B0` first: it leaves while the pipeline runs.
        let passed =
            self.host.streaming() && !self.stream.is_relayed() && self.pass_scan(host, now_us)?;
        self.run_pipeline(host, now_us, passed)
    }

    /// A partial scan (`20 2A`) at `offset` × 0.25° from the sensor: to the
    /// client as is ([`Self::pass_values`]); its values into the latest
    /// scan at their places; when the last partial scan of a scan has come
    /// after all the others in order, the pipeline runs on the whole scan
    /// and an opted-in client gets its features. A partial scan that cannot
    /// be joined (one missing or out of order, the host line still busy
    /// with the last features) is counted
    /// ([`Counters::partial_scans_unassembled`]), with those of its scan
    /// already taken.
    fn process_partial<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
        offset: u8,
        bits: RangeBits,
    ) -> Result<(), PollError<E, H::Error>> {
        let variant = self.host.variant();
        let sent_before = self.counters.scans_out;
        self.pass_values(host, now_us)?;
        let passed = self.counters.scans_out != sent_before;
        let SensorStream::Partial { next } = self.stream else {
            return Ok(());
        };
        let turns = turns_per_scan(variant) as u8;
        let step = (variant.resolution_centideg() / 25) as u8;
        let part = offset / step.max(1);
        let (first, stride, count) = partial_values(variant, part);
        let bytes = self.link.scan_bytes();
        let measured = Telegram::new_checked(bytes, Direction::SensorToHost)
            .ok()
            .and_then(|t| MeasuredView::parse(&t).ok())
            .filter(|m| m.count() == count && m.units() == self.host.units())
            .filter(|_| offset % step.max(1) == 0 && part < turns);
        let fits = measured.is_some() && part == next && !self.host_busy();
        let Some(measured) = measured.filter(|_| fits) else {
            // This one and those of its scan taken so far.
            self.count_unassembled(u32::from(next) + 1);
            self.stream = SensorStream::Partial { next: 0 };
            return Ok(());
        };
        let latest = self.host.source_mut();
        let slots = latest.values.iter_mut().skip(first).step_by(stride.max(1));
        for (slot, word) in slots.zip(measured.words()) {
            *slot = word;
        }
        latest.index = measured.real_time_index();
        if part + 1 < turns {
            self.stream = SensorStream::Partial { next: part + 1 };
            return Ok(());
        }
        self.stream = SensorStream::Partial { next: 0 };
        let units = self.host.units();
        let latest = self.host.source_mut();
        latest.variant = variant;
        latest.count = variant.beams();
        let words = latest.values.get(..variant.beams()).unwrap_or_default();
        if crate::telegram::measured::frame_from_words(words, units, bits, &mut self.frame).is_err()
        {
            self.counters.scans_rejected = self.counters.scans_rejected.wrapping_add(1);
            return Ok(());
        }
        self.run_pipeline(host, now_us, passed)
    }

    /// The pipeline on the latest scan (in `frame`); its features to an
    /// opted-in client behind its `B0` if that was `passed` on.
    fn run_pipeline<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
        passed: bool,
    ) -> Result<(), PollError<E, H::Error>> {
        let of = FeaturesOf {
            scan: self.counters.scans_in,
            beams: self.frame.len() as u16,
        };
        self.extractor.run(&self.frame, &self.params);
        self.latest_features = Some(of);
        if passed && self.features_on() {
            self.pump = Some(Pump::start(of, now_us));
            self.pump(host)?;
        }
        Ok(())
    }

    fn count_unassembled(&mut self, n: u32) {
        let c = &mut self.counters.partial_scans_unassembled;
        *c = c.wrapping_add(n);
    }

    /// `true` while the host line still carries the latest scan: its
    /// feature telegrams wait for room, or the face has handed out part of
    /// a frame (its `30 01` `B0` reads the latest scan word by word).
    fn host_busy(&self) -> bool {
        self.pump.is_some() || self.host.frame_in_progress()
    }

    /// A value mode's telegram (`B6`/`B7`/`BF`) from the sensor: to the
    /// client that asked for it, as is and whole if the host line is free
    /// within its period (else dropped and counted); no features (the
    /// pipeline takes single whole scans, `B0`).
    fn pass_values<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
    ) -> Result<(), PollError<E, H::Error>> {
        self.latest_features = None;
        let variant = self.host.variant();
        let scan_period = crate::device::emulator::scan_period_us(variant);
        let period = match self.stream {
            // One partial scan per mirror turn.
            SensorStream::Partial { .. } => {
                crate::maths::div_u64(scan_period, divisor(turns_per_scan(variant)))
            }
            SensorStream::Values { samples } => {
                scan_period.saturating_mul(u64::from(samples.max(1)))
            }
            SensorStream::Scans | SensorStream::Restoring => {
                self.counters.scans_other_setting =
                    self.counters.scans_other_setting.wrapping_add(1);
                return Ok(());
            }
        };
        let by_us = now_us.saturating_add(period);
        let fits = self.fits_now(host, by_us, self.link.scan_bytes().len())?;
        if !fits {
            self.counters.host_scans_dropped = self.counters.host_scans_dropped.wrapping_add(1);
            return Ok(());
        }
        let bytes = self.link.scan_bytes();
        host.write_all(bytes).map_err(PollError::Host)?;
        self.counters.scans_out = self.counters.scans_out.wrapping_add(1);
        self.host_line.occupy(now_us, bytes.len(), self.host.baud());
        Ok(())
    }

    /// `true` if a stream telegram of `len` bytes may go to the host now:
    /// the host line is free by `by_us` (now plus the budget, µs), nothing
    /// of the latest scan or of the face is half out, and the port has
    /// room for it whole. (Never inside or ahead of a reply: `drain_host`
    /// stops only when the face has nothing ready or the port is full.)
    fn fits_now<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        by_us: u64,
        len: usize,
    ) -> Result<bool, PollError<E, H::Error>> {
        if !self.host_line.free_by(by_us) || self.host_busy() {
            return Ok(false);
        }
        Ok(host.write_room().map_err(PollError::Host)? >= len)
    }

    /// The scan's `B0` to a streaming host, whole, if it may go now
    /// ([`Self::fits_now`] within one scan period; its features follow
    /// through the pump); else dropped and counted. Returns `true` if sent.
    fn pass_scan<H: WriteRoom, E>(
        &mut self,
        host: &mut H,
        now_us: u64,
    ) -> Result<bool, PollError<E, H::Error>> {
        let rate = self.host.baud();
        let period = crate::device::emulator::scan_period_us(self.host.variant());
        let len = self.link.scan_bytes().len();
        if !self.fits_now(host, now_us.saturating_add(period), len)? {
            self.counters.host_scans_dropped = self.counters.host_scans_dropped.wrapping_add(1);
            return Ok(false);
        }
        host.write_all(self.link.scan_bytes())
            .map_err(PollError::Host)?;
        self.counters.scans_out = self.counters.scans_out.wrapping_add(1);
        self.host_line.occupy(now_us, len, rate);
        Ok(true)
    }

    /// The pump: the latest scan's feature telegrams that wait, to the
    /// host, each if the port has room for it whole (none while the face
    /// has a frame half out: its `B0` comes first).
    fn pump<H: WriteRoom, E>(&mut self, host: &mut H) -> Result<(), PollError<E, H::Error>> {
        let Some(pump) = self.pump.filter(|_| !self.host.frame_in_progress()) else {
            return Ok(());
        };
        let mut room = host.write_room().map_err(PollError::Host)?;
        let echoed = EchoedParams::from(self.params.get());
        let (first, mut sent, mut bytes) = (pump.next, 0u32, 0usize);
        let result =
            emit_features_from(first, pump.of, &echoed, self.extractor.features(), 0, |t| {
                // `None`: no room now (the next poll goes on from here).
                if t.len() > room {
                    return Err(None);
                }
                host.write_all(t).map_err(Some)?;
                room = room.saturating_sub(t.len());
                (sent, bytes) = (sent.wrapping_add(1), bytes.saturating_add(t.len()));
                Ok(())
            });
        self.host_line.occupy(pump.at_us, bytes, self.host.baud());
        self.counters.feature_telegrams_out =
            self.counters.feature_telegrams_out.wrapping_add(sent);
        match result {
            Ok(_) => {
                self.pump = None;
                self.counters.feature_scans_out = self.counters.feature_scans_out.wrapping_add(1);
            }
            Err(None) => {
                self.pump = Some(Pump {
                    next: first.wrapping_add(sent),
                    ..pump
                });
            }
            Err(Some(e)) => return Err(PollError::Host(e)),
        }
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
        // Every bad host telegram (each got its NAK), every request the
        // face's full queue dropped, every relay refused.
        let face = *self.host.stats();
        self.counters.host_crc_errors = face.naks;
        self.counters.host_requests_dropped = face.dropped_requests;
        self.counters.relays_refused = self.host.source().relays_refused;
        self.host.source_mut().counters = self.counters;
        self.host.source_mut().sensor = match self.link.step() {
            sensor_link::Step::Streaming => SensorLine::Streaming,
            _ => SensorLine::BringingUp,
        };
    }
}

/// The result of the mode change (`A0`) that the framed `telegram` is, if
/// it is one: its command follows the [`HEADER_LEN`] header bytes, the
/// result byte comes next.
fn mode_change_result(telegram: &[u8]) -> Option<ModeResult> {
    match telegram.get(HEADER_LEN..) {
        Some(&[reply::code::MODE_CHANGED, result, ..]) => Some(ModeResult::from_byte(result)),
        _ => None,
    }
}

/// The LMS configuration's units code for `unit` (0 cm, 1 mm; 10 cm is not
/// a code the LMS 2xx configuration takes: cm).
const fn units_code(unit: Unit) -> u8 {
    match unit {
        Unit::Millimetre => 1,
        _ => 0,
    }
}
