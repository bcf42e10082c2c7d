//! The co-processor's own telegrams (PROTOCOL.md §6; byte tables in the
//! project's `docs/PROTOCOL.md`).
//!
//! After every scan it has processed, the co-processor sends the scan's
//! features to the host as a group of telegrams in the LMS framing
//! (`02 80 LEN CMD DATA STATUS CRC`), in this order:
//!
//! | code | name | content |
//! |---|---|---|
//! | `D4` | segments | `[first, last]` beam pairs |
//! | `D3` | edge points | beam indices |
//! | `D1` | lines | up to [`LINES_PER_TELEGRAM`] lines per telegram |
//! | `D2` | corners | up to [`CORNERS_PER_TELEGRAM`] corners per telegram |
//! | `D0` | summary | counts, [`Stats`], the parameters used — sent last |
//!
//! Every telegram starts with the 32-bit scan counter, so a receiver can tell
//! the groups apart; the summary closes a group and carries the counts that
//! let the receiver check that nothing is missing. Every float is sent as its
//! IEEE-754 bits, little-endian, so the host sees exactly the bits the
//! co-processor computed.
//!
//! The host may ask for the co-processor's counters with the request `55`
//! (no data); the reply is `D5` ([`Counters`]). No LMS 2xx client uses the
//! codes `55`, `D0`–`D5`; a client that does not know them skips them like
//! any unexpected reply.
//!
//! Nothing here panics or allocates; encoders measure their buffer first.

use crate::features::{Corner, Line, Segment};
use crate::features::{Features, Stats, MAX_CORNERS, MAX_LINES, MAX_SEGMENTS};
use crate::frame::MAX_BEAMS;
use crate::maths::Sym2;
use crate::params::Params;

use super::packet::{emit_telegram_with, EmitError, Head, Telegram};
use super::{DEFAULT_STATUS, MAX_TELEGRAM_LEN, REPLY_ADDRESS_BIT};

/// Summary of one scan's features; closes the group.
pub const CMD_SUMMARY: u8 = 0xD0;
/// Lines of one scan (one or more telegrams).
pub const CMD_LINES: u8 = 0xD1;
/// Corners of one scan (zero or more telegrams).
pub const CMD_CORNERS: u8 = 0xD2;
/// Edge points of one scan.
pub const CMD_EDGES: u8 = 0xD3;
/// Segments of one scan.
pub const CMD_SEGMENTS: u8 = 0xD4;
/// Host → co-processor: read the counters (no data).
pub const REQ_COUNTERS: u8 = 0x55;
/// Co-processor → host: the counters.
pub const CMD_COUNTERS: u8 = 0xD5;
/// Host → co-processor: feature output off (data `00`) or on (`01`).
pub const REQ_FEATURES: u8 = 0x56;
/// Co-processor → host: the feature output now in force (`00` off, `01` on).
pub const CMD_FEATURES: u8 = 0xD6;

/// Lines per `D1` telegram (16 × 46 bytes + 7 = 743 data bytes).
pub const LINES_PER_TELEGRAM: usize = 16;
/// Corners per `D2` telegram (16 × 27 bytes + 7 = 439 data bytes).
pub const CORNERS_PER_TELEGRAM: usize = 16;
/// Bytes of one line record.
pub const LINE_RECORD_LEN: usize = 46;
/// Bytes of one corner record.
pub const CORNER_RECORD_LEN: usize = 27;
/// Bytes of the summary's data.
pub const SUMMARY_LEN: usize = 49;
/// Bytes of the counters' data ([`Counters::LEN`] × u32).
pub const COUNTERS_LEN: usize = 4 * Counters::LEN;
/// Bytes of the counters' data before the request and partial-scan
/// counters were added (16 × u32), which [`Counters::decode`] still reads
/// (those fields 0).
pub const COUNTERS_LEN_V2: usize = 64;
/// Bytes of the counters' data before the boot fields were added (12 ×
/// u32), which [`Counters::decode`] still reads (boot fields 0).
pub const COUNTERS_LEN_V1: usize = 48;

/// What a counter of [`Counters`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CounterKind {
    /// Events since boot.
    Count,
    /// Scans of the sensor's stream not passed on to the client: together
    /// they account for every scan the client did not get.
    ScanLoss,
    /// A fact of this boot, set by the board ([`CoProcessor::note_boot`](crate::device::coprocessor::CoProcessor::note_boot)).
    Boot,
}

macro_rules! declare_counters {
    ($($(#[doc = $doc:literal])+ $field:ident: $kind:ident,)+) => {
        /// Counters the co-processor reports (`D5`); all wrap at `u32::MAX`.
        ///
        /// Every counter is listed, in declaration order (the `D5` word
        /// order), in [`Counters::NAMES`]; [`Counters::entries`] gives them
        /// with their values, for every report.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct Counters {
            $($(#[doc = $doc])+ pub $field: u32,)+
        }

        impl Counters {
            /// How many counters there are (the `D5` data is this many `u32`).
            pub const LEN: usize = declare_counters!(@count $($field)+);

            /// Every counter as (name, kind), in declaration order. The
            /// names are the field names.
            pub const NAMES: [(&'static str, CounterKind); Self::LEN] =
                [$((stringify!($field), CounterKind::$kind),)+];

            /// Every counter as (name, meaning), in [`Counters::NAMES`]
            /// order: the meaning is the field's documentation.
            pub const MEANINGS: [(&'static str, &'static str); Self::LEN] =
                [$((stringify!($field), concat!($($doc),+).trim_ascii_start()),)+];

            /// All counters at zero (`const`).
            pub const ZERO: Counters = Counters { $($field: 0,)+ };

            /// Every value, in [`Counters::NAMES`] order.
            pub const fn values(&self) -> [u32; Self::LEN] {
                [$(self.$field,)+]
            }

            /// Counters from `values` in [`Counters::NAMES`] order; missing
            /// values are 0, extra values are ignored.
            pub fn from_values(values: &[u32]) -> Counters {
                let mut it = values.iter().copied();
                Counters { $($field: it.next().unwrap_or(0),)+ }
            }
        }
    };
    (@count $($field:ident)+) => { 0 $(+ declare_counters!(@one $field))+ };
    (@one $field:ident) => { 1 };
}

declare_counters! {
    /// `B0` scans received intact from the sensor.
    scans_in: Count,
    /// Scans whose features were sent to the host.
    feature_scans_out: Count,
    /// Feature telegrams sent (`D0`–`D4`).
    feature_telegrams_out: Count,
    /// Telegrams from the sensor with a bad checksum.
    sensor_crc_errors: Count,
    /// Times the sensor-side framer resynchronised.
    sensor_resyncs: Count,
    /// Bytes from the sensor skipped while resynchronising.
    sensor_bytes_skipped: Count,
    /// Telegrams from the host with a bad checksum (answered with NAK).
    host_crc_errors: Count,
    /// Scans of the sensor's stream lost on the way in: damaged on the line,
    /// cut by a receive queue overflow, or missing (counted by the
    /// co-processor's sensor link from the stream's bytes between good
    /// scans).
    scans_dropped: ScanLoss,
    /// Scans that could not be processed (unsupported value count, …).
    scans_rejected: ScanLoss,
    /// Scans not sent to a streaming host because its line was still busy
    /// with an earlier scan (the host-line drop policy, docs/PROTOCOL.md).
    host_scans_dropped: ScanLoss,
    /// Scans of another variant or unit than the client's, not passed on
    /// (the sensor was being set up for the client's new choice).
    scans_other_setting: ScanLoss,
    /// `B0` scans passed on to the host (stream and `30 01`).
    scans_out: Count,
    /// The board's reset flags at this boot (STM32 `RCC_CSR` bits 25–31
    /// shifted down: 1 brown-out, 2 pin, 4 power-on, 8 software,
    /// 16 watchdog, 32 window watchdog, 64 low-power; 0 if unknown).
    reset_flags: Boot,
    /// How the previous boot ended, from its fault record: 0 no record,
    /// 1 panic, 2 hard fault, 3 unexpected interrupt.
    fault_cause: Boot,
    /// Program counter of that fault (address; 0 if none).
    fault_pc: Boot,
    /// Link register of that fault (0 if none).
    fault_lr: Boot,
    /// Requests from the host dropped unanswered (no `ACK`, no reply)
    /// because the face's reply queue was full: a client that sends many
    /// requests without waiting for their replies (each one it resends is
    /// answered).
    host_requests_dropped: Count,
    /// Requests for the sensor (relayed) that came while another was in
    /// flight: answered at once by the face (`92`, or its own `BA` for
    /// `3A`).
    relays_refused: Count,
    /// Relayed requests the sensor did not answer in time (the client got
    /// its `ACK` and no reply).
    relays_failed: Count,
    /// Partial scans (`20 2A`) that could not be joined into a whole scan
    /// for the pipeline (one of its partial scans missing or out of order);
    /// the client still got each one.
    partial_scans_unassembled: Count,
}

/// What the board found at boot, reported with the counters (their
/// [`CounterKind::Boot`] fields).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BootRecord {
    /// The board's reset flags ([`Counters::reset_flags`]).
    pub reset_flags: u32,
    /// How the previous boot ended ([`Counters::fault_cause`]).
    pub fault_cause: u32,
    /// Program counter of that fault ([`Counters::fault_pc`]).
    pub fault_pc: u32,
    /// Link register of that fault ([`Counters::fault_lr`]).
    pub fault_lr: u32,
}

impl Counters {
    /// Set the boot fields from `boot`.
    pub fn set_boot(&mut self, boot: BootRecord) {
        self.reset_flags = boot.reset_flags;
        self.fault_cause = boot.fault_cause;
        self.fault_pc = boot.fault_pc;
        self.fault_lr = boot.fault_lr;
    }

    /// Every counter as (name, kind, value), in [`Counters::NAMES`] order.
    pub fn entries(&self) -> impl Iterator<Item = (&'static str, CounterKind, u32)> {
        Self::NAMES
            .into_iter()
            .zip(self.values())
            .map(|((name, kind), value)| (name, kind, value))
    }

    /// Write the `D5` data ([`Counters::LEN`] × u32 LE, in field order)
    /// into `out`.
    pub fn encode(&self, out: &mut [u8]) {
        let mut w = Writer::new(out);
        for v in self.values() {
            w.u32(v);
        }
    }

    /// Read the `D5` data; `None` if it is none of [`COUNTERS_LEN`],
    /// [`COUNTERS_LEN_V2`] and [`COUNTERS_LEN_V1`] bytes (each shorter
    /// record is a prefix of the longer: the fields it lacks read 0).
    pub fn decode(data: &[u8]) -> Option<Counters> {
        if ![COUNTERS_LEN, COUNTERS_LEN_V2, COUNTERS_LEN_V1].contains(&data.len()) {
            return None;
        }
        let mut r = Reader::new(data);
        let mut values = [0u32; Counters::LEN];
        for v in values.iter_mut().take(data.len() / 4) {
            *v = r.u32()?;
        }
        Some(Counters::from_values(&values))
    }

    /// Emit the complete `D5` telegram into `buf`; returns its length.
    pub fn emit(&self, address: u8, buf: &mut [u8]) -> Result<usize, EmitError> {
        emit_telegram_with(
            buf,
            Head {
                address: REPLY_ADDRESS_BIT | address,
                command: CMD_COUNTERS,
            },
            COUNTERS_LEN,
            Some(DEFAULT_STATUS),
            |d| self.encode(d),
        )
    }
}

/// The parameters echoed in the summary, so a checker can recompute with the
/// same ones.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EchoedParams {
    /// Smoothing passes.
    pub iterations: u16,
    /// Range noise `sigma` (m).
    pub sigma: f32,
    /// Process noise `q` (m²).
    pub q: f32,
    /// Segmentation gate `tau`.
    pub tau: f32,
}

impl EchoedParams {
    /// `base` with the echoed parameters set: what a scan ran with, as far
    /// as its summary tells.
    #[must_use]
    pub const fn over(&self, base: Params) -> Params {
        base.with_iterations(self.iterations)
            .with_sigma(self.sigma)
            .with_q(self.q)
            .with_tau(self.tau)
    }
}

impl From<&Params> for EchoedParams {
    fn from(p: &Params) -> Self {
        EchoedParams {
            iterations: p.iterations,
            sigma: p.sigma,
            q: p.q,
            tau: p.tau,
        }
    }
}

/// Emit every feature telegram of one scan, handing each complete telegram
/// to `send` in order (segments, edges, lines, corners, summary). Returns
/// the number of telegrams sent, or the first error of `send`.
///
/// `beams` is the scan's beam count; `address` the sensor address (the
/// telegrams carry `0x80 | address`).
pub fn emit_features<E>(
    scan_counter: u32,
    beams: u16,
    params: &EchoedParams,
    features: &Features,
    address: u8,
    send: impl FnMut(&[u8]) -> Result<(), E>,
) -> Result<u32, E> {
    let of = FeaturesOf {
        scan: scan_counter,
        beams,
    };
    emit_features_from(0, of, params, features, address, send)
}

/// The scan whose features the telegrams describe: its number (the scan
/// counter they carry) and its beam count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FeaturesOf {
    /// The scan counter.
    pub scan: u32,
    /// Beams per scan.
    pub beams: u16,
}

/// [`emit_features`] from the telegram with index `first` on (0 is the
/// first `D4`): the telegrams before it are counted but neither built nor
/// sent, so that a sender that stopped (its `send` failed at telegram `k`)
/// resumes with `first = k`. Returns the scan's number of telegrams.
pub fn emit_features_from<E, F>(
    first: u32,
    of: FeaturesOf,
    params: &EchoedParams,
    features: &Features,
    address: u8,
    send: F,
) -> Result<u32, E>
where
    F: FnMut(&[u8]) -> Result<(), E>,
{
    let mut out = Sender {
        buf: [0u8; MAX_TELEGRAM_LEN],
        address: REPLY_ADDRESS_BIT | address,
        scan_counter: of.scan,
        first,
        sent: 0,
        send,
    };
    // D4: counter, count (u8), count × (first u16, last u16).
    let segs = &features.segments;
    out.telegram(CMD_SEGMENTS, 5 + 4 * segs.len(), |w| {
        w.u8(segs.len() as u8);
        for s in segs {
            w.u16(s.first);
            w.u16(s.last);
        }
    })?;
    // D3: counter, count (u16), count × beam (u16).
    let edges = &features.edges;
    out.telegram(CMD_EDGES, 6 + 2 * edges.len(), |w| {
        w.u16(edges.len() as u16);
        for e in edges {
            w.u16(e);
        }
    })?;
    // D1: at least one telegram, so an empty list is explicit.
    let lines = Parts {
        command: CMD_LINES,
        per_telegram: LINES_PER_TELEGRAM,
        record_len: LINE_RECORD_LEN,
    };
    out.parts(&lines, &features.lines, 1, encode_line)?;
    // D2: none if there are no corners.
    let corners = Parts {
        command: CMD_CORNERS,
        per_telegram: CORNERS_PER_TELEGRAM,
        record_len: CORNER_RECORD_LEN,
    };
    out.parts(&corners, &features.corners, 0, encode_corner)?;
    // D0: the summary, last.
    out.telegram(CMD_SUMMARY, SUMMARY_LEN, |w| {
        encode_summary(w, of.beams, params, features)
    })?;
    Ok(out.sent)
}

/// The telegrams of one scan as they are built: one buffer, the reply
/// address, the scan counter that opens every payload, and the count sent.
struct Sender<F> {
    buf: [u8; MAX_TELEGRAM_LEN],
    address: u8,
    scan_counter: u32,
    /// Telegrams before this index are skipped.
    first: u32,
    sent: u32,
    send: F,
}

/// How a list of records is spread over telegrams (`D1`, `D2`).
struct Parts {
    command: u8,
    per_telegram: usize,
    record_len: usize,
}

impl<F> Sender<F> {
    /// Build one telegram of `command` whose payload is the scan counter
    /// and then what `body` writes (`len` bytes in all), and send it.
    fn telegram<E>(
        &mut self,
        command: u8,
        len: usize,
        body: impl FnOnce(&mut Writer<'_>),
    ) -> Result<(), E>
    where
        F: FnMut(&[u8]) -> Result<(), E>,
    {
        if self.sent < self.first {
            self.sent = self.sent.wrapping_add(1);
            return Ok(());
        }
        let counter = self.scan_counter;
        let n = emit_telegram_with(
            &mut self.buf,
            Head {
                address: self.address,
                command,
            },
            len,
            Some(DEFAULT_STATUS),
            |d| {
                let mut w = Writer::new(d);
                w.u32(counter);
                body(&mut w);
            },
        );
        // Every length here is within MAX_LEN by construction; an emit
        // error would be a bug in this module and sends nothing.
        if let Some(t) = n.ok().and_then(|n| self.buf.get(..n)) {
            (self.send)(t)?;
            self.sent = self.sent.wrapping_add(1);
        }
        Ok(())
    }

    /// `items` in telegrams of at most `parts.per_telegram` records (at
    /// least `min_parts` telegrams): counter, part, parts, count, records.
    fn parts<E, T>(
        &mut self,
        parts: &Parts,
        items: &[T],
        min_parts: usize,
        encode: fn(&mut Writer<'_>, &T),
    ) -> Result<(), E>
    where
        F: FnMut(&[u8]) -> Result<(), E>,
    {
        let count = items.len().div_ceil(parts.per_telegram).max(min_parts);
        for part in 0..count {
            let chunk = items
                .get(part * parts.per_telegram..)
                .map_or(&[][..], |rest| &rest[..rest.len().min(parts.per_telegram)]);
            self.telegram(parts.command, 7 + parts.record_len * chunk.len(), |w| {
                w.u8(part as u8);
                w.u8(count as u8);
                w.u8(chunk.len() as u8);
                for item in chunk {
                    encode(w, item);
                }
            })?;
        }
        Ok(())
    }
}

/// `D0` after the counter: beams, the four counts, the `D0` stats words and
/// the echoed parameters.
fn encode_summary(w: &mut Writer<'_>, beams: u16, params: &EchoedParams, features: &Features) {
    w.u16(beams);
    w.u8(features.segments.len() as u8);
    w.u8(features.lines.len() as u8);
    w.u8(features.corners.len() as u8);
    w.u16(features.edges.len() as u16);
    for (_, get) in Stats::FIELDS.iter().take(Stats::D0_FIELDS) {
        w.u16(get(&features.stats));
    }
    w.u16(params.iterations);
    w.f32(params.sigma);
    w.f32(params.q);
    w.f32(params.tau);
}

/// Line record, 46 bytes: α, r, cov αα, αr, rr, chi2, x₀, y₀, x₁, y₁
/// (10 × f32), first, last, points (3 × u16).
fn encode_line(w: &mut Writer<'_>, l: &Line) {
    for v in l.floats() {
        w.f32(v);
    }
    w.u16(l.first);
    w.u16(l.last);
    w.u16(l.points);
}

fn decode_line(r: &mut Reader<'_>) -> Option<Line> {
    let mut f = [0.0f32; 10];
    for v in f.iter_mut() {
        *v = r.f32()?;
    }
    Some(Line {
        alpha: f[0],
        r: f[1],
        cov: Sym2 {
            a: f[2],
            b: f[3],
            c: f[4],
        },
        chi2: f[5],
        endpoints: [[f[6], f[7]], [f[8], f[9]]],
        first: r.u16()?,
        last: r.u16()?,
        points: r.u16()?,
    })
}

/// Corner record, 27 bytes: x, y, cov xx, xy, yy, angle (6 × f32), flags
/// (bit 0 = well conditioned), line a, line b (u8 each).
fn encode_corner(w: &mut Writer<'_>, c: &Corner) {
    for v in c.floats() {
        w.f32(v);
    }
    w.u8(u8::from(c.well_conditioned));
    w.u8(c.line_a);
    w.u8(c.line_b);
}

fn decode_corner(r: &mut Reader<'_>) -> Option<Corner> {
    let mut f = [0.0f32; 6];
    for v in f.iter_mut() {
        *v = r.f32()?;
    }
    let flags = r.u8()?;
    Some(Corner {
        x: f[0],
        y: f[1],
        cov: Sym2 {
            a: f[2],
            b: f[3],
            c: f[4],
        },
        angle_deg: f[5],
        well_conditioned: flags & 1 != 0,
        line_a: r.u8()?,
        line_b: r.u8()?,
    })
}

/// The summary of a scan as received.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Summary {
    /// Scan counter.
    pub scan_counter: u32,
    /// Beams in the scan.
    pub beams: u16,
    /// Segments, lines, corners, edge points announced.
    pub counts: [u16; 4],
    /// The extractor's counters.
    pub stats: Stats,
    /// The parameters used.
    pub params: EchoedParams,
}

/// Why a feature telegram could not be taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FeatureError {
    /// The data is shorter or longer than its counts say.
    Malformed {
        /// The telegram's command code.
        command: u8,
    },
    /// The summary's counts do not match what was received.
    Incomplete {
        /// Counter of the scan.
        scan_counter: u32,
    },
    /// More items than the fixed capacity.
    Overflow,
}

impl core::fmt::Display for FeatureError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FeatureError::Malformed { command } => {
                write!(f, "malformed feature telegram {command:02X}")
            }
            FeatureError::Incomplete { scan_counter } => {
                write!(
                    f,
                    "features of scan {scan_counter} incomplete at its summary"
                )
            }
            FeatureError::Overflow => f.write_str("more features than the fixed capacity"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FeatureError {}

/// Reassembles the feature telegrams of one scan at a time.
#[derive(Clone, Debug, Default)]
pub struct FeatureAssembler {
    current: Option<u32>,
    features: Features,
    discarded: u32,
}

/// What [`FeatureAssembler::push`] made of a telegram.
#[derive(Debug)]
pub enum Assembled<'a> {
    /// Not a feature telegram (e.g. a `B0`): ignored.
    NotFeatures,
    /// Taken; the scan is not complete yet.
    Partial,
    /// The summary arrived and the counts match: the scan's features.
    Complete(Summary, &'a Features),
}

impl FeatureAssembler {
    /// An empty assembler.
    pub fn new() -> Self {
        Self::default()
    }

    /// Take one sensor → host telegram.
    pub fn push<T: AsRef<[u8]>>(&mut self, t: &Telegram<T>) -> Result<Assembled<'_>, FeatureError> {
        let command = t.command();
        if !matches!(
            command,
            CMD_SUMMARY | CMD_LINES | CMD_CORNERS | CMD_EDGES | CMD_SEGMENTS
        ) {
            return Ok(Assembled::NotFeatures);
        }
        let malformed = FeatureError::Malformed { command };
        let mut r = Reader::new(t.data());
        let counter = r.u32().ok_or(malformed)?;
        if self.current != Some(counter) {
            if self.current.is_some() {
                // The previous scan's summary never came: count it, start anew.
                self.discarded = self.discarded.wrapping_add(1);
            }
            self.start(counter);
        }
        let f = &mut self.features;
        match command {
            CMD_SEGMENTS => read_records(&mut r, malformed, |r| {
                let n = r.u8()?;
                Some((usize::from(n), |r: &mut Reader<'_>| {
                    let (first, last) = (r.u16()?, r.u16()?);
                    Some(f.segments.push(Segment { first, last }).is_ok())
                }))
            })?,
            CMD_EDGES => read_records(&mut r, malformed, |r| {
                let n = r.u16()?;
                Some((usize::from(n), |r: &mut Reader<'_>| {
                    // Edge points are ascending beams below MAX_BEAMS: any
                    // other is a malformed D3 (the bitset cannot hold it).
                    f.edges.push(r.u16()?).ok().map(|()| true)
                }))
            })?,
            CMD_LINES => read_records(&mut r, malformed, |r| {
                let (_part, _parts, n) = (r.u8(), r.u8(), r.u8()?);
                Some((usize::from(n), |r: &mut Reader<'_>| {
                    Some(f.lines.push(decode_line(r)?).is_ok())
                }))
            })?,
            CMD_CORNERS => read_records(&mut r, malformed, |r| {
                let (_part, _parts, n) = (r.u8(), r.u8(), r.u8()?);
                Some((usize::from(n), |r: &mut Reader<'_>| {
                    Some(f.corners.push(decode_corner(r)?).is_ok())
                }))
            })?,
            _ => {
                // CMD_SUMMARY
                let (summary, complete) = read_summary(&mut r, counter, f).ok_or(malformed)?;
                self.current = None;
                if !complete {
                    return Err(FeatureError::Incomplete {
                        scan_counter: counter,
                    });
                }
                return Ok(Assembled::Complete(summary, &self.features));
            }
        }
        if !r.is_empty() {
            return Err(malformed);
        }
        Ok(Assembled::Partial)
    }

    /// Scans whose telegrams were cut short by another scan's (their
    /// summary never arrived) and were therefore discarded.
    pub fn discarded(&self) -> u32 {
        self.discarded
    }

    fn start(&mut self, counter: u32) {
        self.current = Some(counter);
        let f = &mut self.features;
        f.segments.clear();
        f.edges.clear();
        f.lines.clear();
        f.corners.clear();
        f.stats = Stats::default();
    }
}

/// Read a record list: `header` reads the count and gives a reader of one
/// record that stores it (`Some(false)` when the list is full). A short
/// telegram is `malformed`; a full list is [`FeatureError::Overflow`].
fn read_records<'r, H, R>(
    r: &mut Reader<'r>,
    malformed: FeatureError,
    header: H,
) -> Result<(), FeatureError>
where
    H: FnOnce(&mut Reader<'r>) -> Option<(usize, R)>,
    R: FnMut(&mut Reader<'r>) -> Option<bool>,
{
    let (n, mut record) = header(r).ok_or(malformed)?;
    for _ in 0..n {
        if !record(r).ok_or(malformed)? {
            return Err(FeatureError::Overflow);
        }
    }
    Ok(())
}

/// The `D0` payload after the counter: sets `f`'s stats and returns the
/// summary and whether the counts match what was assembled (and nothing
/// follows). `None` if the telegram is short.
fn read_summary(r: &mut Reader<'_>, counter: u32, f: &mut Features) -> Option<(Summary, bool)> {
    let beams = r.u16()?;
    let counts = [
        u16::from(r.u8()?),
        u16::from(r.u8()?),
        u16::from(r.u8()?),
        r.u16()?,
    ];
    let mut st = [0u16; Stats::D0_FIELDS];
    for v in st.iter_mut() {
        *v = r.u16()?;
    }
    let params = EchoedParams {
        iterations: r.u16()?,
        sigma: r.f32()?,
        q: r.f32()?,
        tau: r.f32()?,
    };
    f.stats = Stats::from_fields(&st);
    let got = [
        f.segments.len() as u16,
        f.lines.len() as u16,
        f.corners.len() as u16,
        f.edges.len() as u16,
    ];
    let summary = Summary {
        scan_counter: counter,
        beams,
        counts,
        stats: f.stats,
        params,
    };
    Some((summary, got == counts && r.is_empty()))
}

// Compile-time checks that the largest telegrams fit the LMS framing.
const _: () = {
    assert!(5 + 4 * MAX_SEGMENTS + 2 <= super::MAX_LEN);
    assert!(6 + 2 * MAX_BEAMS + 2 <= super::MAX_LEN);
    assert!(7 + LINE_RECORD_LEN * LINES_PER_TELEGRAM + 2 <= super::MAX_LEN);
    assert!(7 + CORNER_RECORD_LEN * CORNERS_PER_TELEGRAM + 2 <= super::MAX_LEN);
    assert!(MAX_LINES.div_ceil(LINES_PER_TELEGRAM) <= u8::MAX as usize);
    assert!(MAX_CORNERS <= u8::MAX as usize);
};

/// Little-endian writer over a slice; writes past the end are dropped (the
/// callers size the slice exactly).
struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl<'a> Writer<'a> {
    fn new(buf: &'a mut [u8]) -> Self {
        Writer { buf, pos: 0 }
    }
    fn bytes(&mut self, b: &[u8]) {
        if let Some(slot) = self.buf.get_mut(self.pos..self.pos + b.len()) {
            slot.copy_from_slice(b);
        }
        self.pos += b.len();
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
}

/// Little-endian reader; `None` past the end.
struct Reader<'a> {
    buf: &'a [u8],
}

impl<'a> Reader<'a> {
    fn new(buf: &'a [u8]) -> Self {
        Reader { buf }
    }
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let (head, rest) = self.buf.split_first_chunk::<N>()?;
        self.buf = rest;
        Some(*head)
    }
    fn is_empty(&self) -> bool {
        self.buf.is_empty()
    }
    fn u8(&mut self) -> Option<u8> {
        self.take::<1>().map(|[b]| b)
    }
    fn u16(&mut self) -> Option<u16> {
        self.take::<2>().map(u16::from_le_bytes)
    }
    fn u32(&mut self) -> Option<u32> {
        self.take::<4>().map(u32::from_le_bytes)
    }
    fn f32(&mut self) -> Option<f32> {
        self.u32().map(f32::from_bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::telegram::Direction;

    fn sample() -> Features {
        let mut f = Features::default();
        f.segments.push(Segment { first: 3, last: 40 }).unwrap();
        f.segments
            .push(Segment {
                first: 40,
                last: 90,
            })
            .unwrap();
        f.edges.push(40).unwrap();
        for i in 0..20u16 {
            f.lines
                .push(Line {
                    alpha: 0.1 * f32::from(i),
                    r: 2.0,
                    cov: Sym2 {
                        a: 1e-5,
                        b: -2e-6,
                        c: 4e-6,
                    },
                    first: i,
                    last: i + 10,
                    points: 11,
                    chi2: 0.9,
                    endpoints: [[1.0, -1.0], [2.0, f32::NAN]],
                })
                .unwrap();
        }
        f.corners
            .push(Corner {
                x: 1.5,
                y: -0.25,
                cov: Sym2 {
                    a: 1e-5,
                    b: 0.0,
                    c: 2e-5,
                },
                angle_deg: 89.5,
                well_conditioned: true,
                line_a: 0,
                line_b: 1,
            })
            .unwrap();
        f.stats.valid_beams = 361;
        f.stats.merges = 2;
        f
    }

    #[test]
    fn a_scan_round_trips_bit_for_bit() {
        let f = sample();
        let params = EchoedParams::from(&Params::default());
        let mut wire: std::vec::Vec<std::vec::Vec<u8>> = std::vec::Vec::new();
        let sent = emit_features(7, 361, &params, &f, 0, |t| {
            wire.push(t.to_vec());
            Ok::<(), ()>(())
        })
        .unwrap();
        // segments, edges, 2 × lines (20 = 16 + 4), 1 × corners, summary
        assert_eq!(sent, 6);
        let codes: std::vec::Vec<u8> = wire.iter().map(|t| t[4]).collect();
        assert_eq!(
            codes,
            [
                CMD_SEGMENTS,
                CMD_EDGES,
                CMD_LINES,
                CMD_LINES,
                CMD_CORNERS,
                CMD_SUMMARY
            ]
        );
        let mut asm = FeatureAssembler::new();
        let mut done = None;
        for t in &wire {
            let t = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
            if let Assembled::Complete(s, got) = asm.push(&t).unwrap() {
                done = Some((s, got.clone()));
            }
        }
        let (summary, got) = done.expect("complete");
        assert_eq!(summary.scan_counter, 7);
        assert_eq!(summary.beams, 361);
        assert_eq!(summary.params, params);
        assert_eq!(got.segments, f.segments);
        assert_eq!(got.edges, f.edges);
        assert_eq!(got.stats, f.stats);
        for (a, b) in got.lines.iter().zip(f.lines.iter()) {
            assert_eq!(a.endpoints[1][1].to_bits(), b.endpoints[1][1].to_bits());
            assert_eq!(a.alpha.to_bits(), b.alpha.to_bits());
            assert_eq!((a.first, a.last, a.points), (b.first, b.last, b.points));
        }
        assert_eq!(got.lines.len(), 20);
        assert_eq!(got.corners.as_slice(), f.corners.as_slice());
    }

    #[test]
    fn a_stopped_emission_resumes_where_it_stopped() {
        let f = sample();
        let params = EchoedParams::from(&Params::default());
        let mut whole: std::vec::Vec<std::vec::Vec<u8>> = std::vec::Vec::new();
        emit_features(7, 361, &params, &f, 0, |t| {
            whole.push(t.to_vec());
            Ok::<(), ()>(())
        })
        .unwrap();
        // A sender that takes two telegrams per call, then stops.
        let mut pieces: std::vec::Vec<std::vec::Vec<u8>> = std::vec::Vec::new();
        let mut first = 0;
        for _ in 0..whole.len() {
            let mut taken = 0;
            let of = FeaturesOf {
                scan: 7,
                beams: 361,
            };
            let r = emit_features_from(first, of, &params, &f, 0, |t| {
                if taken == 2 {
                    return Err(());
                }
                pieces.push(t.to_vec());
                taken += 1;
                Ok(())
            });
            first += taken;
            if r.is_ok() {
                assert_eq!(r, Ok(6));
                break;
            }
        }
        assert_eq!(pieces, whole);
        assert_eq!(first, 6);
    }

    #[test]
    fn the_summary_telegram_of_an_empty_scan_is_byte_exact() {
        let f = Features::default();
        let params = EchoedParams {
            iterations: 30,
            sigma: 0.005,
            q: 0.0,
            tau: 9.0,
        };
        let mut last = std::vec::Vec::new();
        emit_features(1, 361, &params, &f, 0, |t| {
            last = t.to_vec();
            Ok::<(), ()>(())
        })
        .unwrap();
        // 02 80 | LEN 51 = 1 + 49 + 1 | D0 | counter 1 | beams 361 | 0,0,0 | 0 edges
        // | 12 × u16 stats | 30 | 0.005 | 0.0 | 9.0 | 10 | CRC
        assert_eq!(&last[..4], &[0x02, 0x80, 51, 0]);
        assert_eq!(last[4], CMD_SUMMARY);
        assert_eq!(&last[5..9], &[1, 0, 0, 0]);
        assert_eq!(&last[9..11], &[0x69, 0x01]);
        assert_eq!(&last[40..42], &[30, 0]);
        assert_eq!(&last[42..46], &0.005f32.to_bits().to_le_bytes());
        assert_eq!(&last[50..54], &[0x00, 0x00, 0x10, 0x41]);
        assert_eq!(last[54], 0x10);
        assert_eq!(last.len(), 57);
        let crc = crate::telegram::crc16(&last[..55]).to_le_bytes();
        assert_eq!(&last[55..], &crc);
    }

    #[test]
    fn a_scan_cut_short_is_reported_not_merged() {
        let f = sample();
        let params = EchoedParams::from(&Params::default());
        let mut wire = std::vec::Vec::new();
        for counter in [1u32, 2] {
            emit_features(counter, 361, &params, &f, 0, |t| {
                wire.push(t.to_vec());
                Ok::<(), ()>(())
            })
            .unwrap();
        }
        // Drop the summary of scan 1.
        wire.remove(5);
        let mut asm = FeatureAssembler::new();
        let mut results = std::vec::Vec::new();
        for t in &wire {
            let t = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
            results.push(match asm.push(&t) {
                Ok(Assembled::Complete(s, _)) => Ok(s.scan_counter),
                Ok(_) => Ok(0),
                Err(e) => Err(e),
            });
        }
        assert_eq!(asm.discarded(), 1);
        assert_eq!(results.last(), Some(&Ok(2)));
        assert!(results.iter().all(|r| *r == Ok(0) || *r == Ok(2)));
    }

    #[test]
    fn counters_round_trip() {
        let c = Counters {
            scans_in: 1,
            feature_scans_out: 2,
            feature_telegrams_out: 3,
            sensor_crc_errors: 4,
            sensor_resyncs: 5,
            sensor_bytes_skipped: 6,
            host_crc_errors: 7,
            scans_dropped: 8,
            scans_rejected: 9,
            host_scans_dropped: 10,
            scans_other_setting: 11,
            scans_out: 12,
            reset_flags: 13,
            fault_cause: 14,
            fault_pc: 15,
            fault_lr: 16,
            host_requests_dropped: 17,
            relays_refused: 18,
            relays_failed: 19,
            partial_scans_unassembled: 20,
        };
        let mut buf = [0u8; 96];
        let n = c.emit(0, &mut buf).unwrap();
        assert_eq!(n, 4 + 1 + COUNTERS_LEN + 1 + 2);
        let t = Telegram::new_checked(&buf[..n], Direction::SensorToHost).unwrap();
        assert_eq!(t.command(), CMD_COUNTERS);
        assert_eq!(Counters::decode(t.data()), Some(c));
    }
}
