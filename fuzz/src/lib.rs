//! Input formats of the fuzz targets, shared by the targets
//! (`fuzz_targets/*.rs`) and the seed generator (`examples/seeds.rs`), so
//! that real telegrams can be written as seeds in exactly the layout each
//! target reads.
//!
//! Every decoder reads what is there and substitutes zeros for missing
//! bytes: any byte string is a valid input.

use lms_core::frame::MAX_BEAMS;
use lms_core::maths::Sym2;
use lms_core::telegram::{Direction, Event, Framer, RangeBits};
use lms_core::Unit;
use lms_core::{Features, Stats, MAX_CORNERS, MAX_LINES, MAX_SEGMENTS};
use lms_core::{Frame, Geometry, Invalid, Params, Variant};

/// A reader over the fuzzer's bytes; zeros once they run out.
pub struct Input<'a>(&'a [u8]);

impl<'a> Input<'a> {
    /// Read from `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Input(data)
    }
    /// `true` when every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    /// Up to `n` bytes (fewer at the end).
    pub fn bytes(&mut self, n: usize) -> &'a [u8] {
        let (head, rest) = self.0.split_at(n.min(self.0.len()));
        self.0 = rest;
        head
    }
    /// All remaining bytes.
    pub fn rest(&mut self) -> &'a [u8] {
        core::mem::take(&mut self.0)
    }
    /// One byte (0 at the end).
    pub fn u8(&mut self) -> u8 {
        self.bytes(1).first().copied().unwrap_or(0)
    }
    /// Little-endian `u16`.
    pub fn u16(&mut self) -> u16 {
        let mut b = [0u8; 2];
        b[..]
            .iter_mut()
            .zip(self.bytes(2))
            .for_each(|(d, s)| *d = *s);
        u16::from_le_bytes(b)
    }
    /// Little-endian `u32`.
    pub fn u32(&mut self) -> u32 {
        let mut b = [0u8; 4];
        b[..]
            .iter_mut()
            .zip(self.bytes(4))
            .for_each(|(d, s)| *d = *s);
        u32::from_le_bytes(b)
    }
    /// An `f32` from its bits (NaN, infinities and subnormals included).
    pub fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }
}

/// The writer the seed generator uses to build inputs.
#[derive(Default)]
pub struct Output(pub Vec<u8>);

impl Output {
    /// Append one byte.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    /// Append a little-endian `u16`.
    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    /// Append a little-endian `u32`.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    /// Append an `f32`'s bits.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.u32(v.to_bits())
    }
    /// Append bytes.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.0.extend_from_slice(b);
        self
    }
}

// ---------------------------------------------------------------- framer --

/// Framer input flag: the host → sensor direction (else sensor → host).
pub const FRAMER_HOST_TO_SENSOR: u8 = 1;
/// Framer input flag: report `ACK`/`NAK` bytes.
pub const FRAMER_HANDSHAKE: u8 = 2;
/// Framer input flag: call `abandon` at every split point (a time-out).
pub const FRAMER_ABANDON: u8 = 4;
/// Framer input flag: call `discard` at the last split point.
pub const FRAMER_DISCARD: u8 = 8;

/// `flags | k | k × split offset (u16) | stream`.
pub struct FramerInput<'a> {
    /// `FRAMER_*` bits.
    pub flags: u8,
    /// Offsets into `stream` where a chunk ends, ascending, deduplicated.
    pub splits: Vec<usize>,
    /// The bytes on the line.
    pub stream: &'a [u8],
}

impl<'a> FramerInput<'a> {
    /// Decode.
    pub fn decode(data: &'a [u8]) -> Self {
        let mut input = Input::new(data);
        let flags = input.u8();
        let k = usize::from(input.u8() % 32);
        let raw: Vec<u16> = (0..k).map(|_| input.u16()).collect();
        let stream = input.rest();
        let mut splits: Vec<usize> = raw
            .into_iter()
            .map(|s| usize::from(s) % (stream.len() + 1))
            .collect();
        splits.sort_unstable();
        splits.dedup();
        FramerInput {
            flags,
            splits,
            stream,
        }
    }

    /// Encode (for seeds).
    pub fn encode(flags: u8, splits: &[u16], stream: &[u8]) -> Vec<u8> {
        let mut out = Output::default();
        out.u8(flags).u8(splits.len() as u8);
        for &s in splits {
            out.u16(s);
        }
        out.bytes(stream);
        out.0
    }

    /// The direction the flags select.
    pub fn direction(&self) -> Direction {
        if self.flags & FRAMER_HOST_TO_SENSOR != 0 {
            Direction::HostToSensor
        } else {
            Direction::SensorToHost
        }
    }
}

/// One direction of a serial line in memory: the co-processor reads `rx`
/// and writes `tx` (the co-processor target and the seed sessions); the
/// core's `test_support` port.
pub use lms_core::test_support::Port;

/// One framer event, owned.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Ev {
    /// A telegram's bytes.
    Telegram(Vec<u8>),
    /// `ACK`.
    Ack,
    /// `NAK`.
    Nak,
}

/// Feed `chunk` to `framer` until it has nothing more; collect the events.
pub fn drain(framer: &mut Framer, chunk: &[u8], out: &mut Vec<Ev>) {
    let mut input = chunk;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => out.push(Ev::Telegram(t.as_bytes().to_vec())),
            Some(Event::Ack) => out.push(Ev::Ack),
            Some(Event::Nak) => out.push(Ev::Nak),
            Some(Event::Long { .. }) => panic!("a full-size framer holds every telegram"),
            None => {
                assert!(input.is_empty(), "no event but input left");
                return;
            }
        }
    }
}

// --------------------------------------------------------------- b0 frame --

/// The units selected by a byte.
pub fn units_of(b: u8) -> Unit {
    match b % 3 {
        0 => Unit::Centimetre,
        1 => Unit::Millimetre,
        _ => Unit::Decimetre,
    }
}

/// The byte that selects `units` in [`units_of`].
pub fn units_byte(u: Unit) -> u8 {
    match u {
        Unit::Centimetre => 0,
        Unit::Millimetre => 1,
        Unit::Decimetre => 2,
    }
}

/// The range bits selected by a byte.
pub fn bits_of(b: u8) -> RangeBits {
    match b % 3 {
        0 => RangeBits::Bits13,
        1 => RangeBits::Bits14,
        _ => RangeBits::Bits15,
    }
}

// --------------------------------------------------------------- features --

/// Read a [`Features`] value (counts within the capacities) and the
/// summary fields `(scan_counter, beams)` from the fuzzer's bytes.
pub fn decode_features(input: &mut Input<'_>) -> (u32, u16, Features) {
    let counter = input.u32();
    let beams = input.u16();
    let mut f = Features::default();
    let segments = usize::from(input.u8()) % (MAX_SEGMENTS + 1);
    let edges = usize::from(input.u16()) % (MAX_BEAMS + 1);
    let lines = usize::from(input.u8()) % (MAX_LINES + 1);
    let corners = usize::from(input.u8()) % (MAX_CORNERS + 1);
    let mut st = [0u16; Stats::D0_FIELDS];
    for v in st.iter_mut() {
        *v = input.u16();
    }
    // The split counters are not carried by D0 (split before reject is off
    // on the co-processor): they stay 0.
    *f.stats_mut() = Stats::from_fields(&st);
    for _ in 0..segments {
        let s = lms_core::Segment {
            first: input.u16(),
            last: input.u16(),
        };
        let _ = f.push_segment(s);
    }
    for _ in 0..edges {
        let _ = f.push_edge(input.u16());
    }
    for _ in 0..lines {
        let mut v = [0.0f32; 10];
        for x in v.iter_mut() {
            *x = input.f32();
        }
        let l = lms_core::Line {
            alpha: v[0],
            r: v[1],
            cov: Sym2 {
                a: v[2],
                b: v[3],
                c: v[4],
            },
            chi2: v[5],
            endpoints: [[v[6], v[7]], [v[8], v[9]]],
            first: input.u16(),
            last: input.u16(),
            points: input.u16(),
        };
        let _ = f.push_line(l);
    }
    for _ in 0..corners {
        let mut v = [0.0f32; 6];
        for x in v.iter_mut() {
            *x = input.f32();
        }
        let c = lms_core::Corner {
            x: v[0],
            y: v[1],
            cov: Sym2 {
                a: v[2],
                b: v[3],
                c: v[4],
            },
            angle_deg: v[5],
            well_conditioned: input.u8() & 1 != 0,
            line_a: input.u8(),
            line_b: input.u8(),
        };
        let _ = f.push_corner(c);
    }
    (counter, beams, f)
}

/// Write `features` in the layout [`decode_features`] reads (for seeds).
pub fn encode_features(out: &mut Output, counter: u32, beams: u16, f: &Features) {
    out.u32(counter).u16(beams);
    out.u8(f.segments().len() as u8)
        .u16(f.edges().len() as u16)
        .u8(f.lines().len() as u8)
        .u8(f.corners().len() as u8);
    for (_, get) in Stats::FIELDS.iter().take(Stats::D0_FIELDS) {
        out.u16(get(f.stats()));
    }
    for s in f.segments() {
        out.u16(s.first).u16(s.last);
    }
    for e in f.edges() {
        out.u16(e);
    }
    for l in f.lines() {
        for v in l.floats() {
            out.f32(v);
        }
        out.u16(l.first).u16(l.last).u16(l.points);
    }
    for c in f.corners() {
        for v in [c.x, c.y, c.cov.a, c.cov.b, c.cov.c, c.angle_deg] {
            out.f32(v);
        }
        out.u8(u8::from(c.well_conditioned))
            .u8(c.line_a)
            .u8(c.line_b);
    }
}

/// Every bit of a [`Features`] value, for exact comparisons (NaN included).
pub fn feature_bits(f: &Features) -> Vec<u32> {
    let mut v = Vec::new();
    for s in f.segments() {
        v.extend([u32::from(s.first), u32::from(s.last)]);
    }
    v.push(u32::MAX);
    v.extend(f.edges().iter().map(u32::from));
    v.push(u32::MAX);
    for l in f.lines() {
        v.extend(
            [
                l.alpha,
                l.r,
                l.cov.a,
                l.cov.b,
                l.cov.c,
                l.chi2,
                l.endpoints[0][0],
                l.endpoints[0][1],
                l.endpoints[1][0],
                l.endpoints[1][1],
            ]
            .map(f32::to_bits),
        );
        v.extend([l.first, l.last, l.points].map(u32::from));
    }
    v.push(u32::MAX);
    for c in f.corners() {
        v.extend([c.x, c.y, c.cov.a, c.cov.b, c.cov.c, c.angle_deg].map(f32::to_bits));
        v.extend([
            u32::from(c.well_conditioned),
            u32::from(c.line_a),
            u32::from(c.line_b),
        ]);
    }
    v.push(u32::MAX);
    v.extend(
        Stats::FIELDS
            .iter()
            .take(Stats::D0_FIELDS)
            .map(|(_, get)| u32::from(get(f.stats()))),
    );
    v
}

// --------------------------------------------------------------- pipeline --

/// Parameter mode: every field from raw bits (most fail validation).
pub const PARAMS_RAW: u8 = 0;
/// Parameter mode: every field mapped into its valid range.
pub const PARAMS_SANE: u8 = 1;
/// Parameter mode: the defaults, with `1 + raw % 40` passes.
pub const PARAMS_DEFAULT: u8 = 2;
/// Range mode: `B0` value words in the given units and range bits.
pub const RANGES_WORDS: u8 = 0;
/// Range mode: every range an arbitrary `f32` (NaN, ±inf, huge, negative…).
pub const RANGES_RAW: u8 = 1;
/// Range mode: `u16` millimetres (0 = invalid).
pub const RANGES_MM: u8 = 2;
/// Most passes the pipeline target runs (validation allows 1000; more
/// passes exercise no new code, and the fuzzer's speed matters).
pub const MAX_FUZZ_ITERATIONS: u16 = 64;

/// `[0, 1)` from 24 bits of `x`.
fn unit(x: u32) -> f32 {
    (x >> 8) as f32 / (1u32 << 24) as f32
}

/// The pipeline target's input: a frame and parameters.
pub struct PipelineInput {
    /// The frame.
    pub frame: Frame,
    /// The parameters (possibly invalid).
    pub params: Params,
}

/// Decode `n | geometry | parameters | ranges` (see the `PARAMS_*` and
/// `RANGES_*` modes).
pub fn decode_pipeline(data: &[u8]) -> PipelineInput {
    let mut input = Input::new(data);
    let n = 3 + usize::from(input.u16()) % (MAX_BEAMS - 2);
    let geom = input.u8();
    let (g1, g2) = (input.u32(), input.u32());
    let variant = Variant::ALL[usize::from(geom % 5)];
    let geometry = match geom % 8 {
        0..=4 => variant.geometry(),
        5 => Geometry {
            first_bearing: f32::from_bits(g1),
            step: f32::from_bits(g2),
        },
        _ => Geometry {
            first_bearing: -core::f32::consts::PI + unit(g1) * 2.0 * core::f32::consts::PI,
            step: 1e-5 + unit(g2) * 0.05,
        },
    };
    let mut frame = Frame::new(geometry, n)
        .or_else(|_| Frame::new(variant.geometry(), n))
        .unwrap_or_else(|_| Frame::for_variant(variant));

    let mode = input.u8() % 3;
    let raw: [u32; 12] = core::array::from_fn(|_| input.u32());
    let flags = input.u8();
    // ALGORITHM.md v2's range limit and the line gate.
    // The ALGORITHM.md §10 proposals: grazing term, fit σ (limits 2, 3);
    // per-turn extraction: the top bit of raw[11]; the merge across
    // rejected segments: flags bit 7; the footprint κ: raw[7]'s top half.
    let limits: [u32; 4] = core::array::from_fn(|_| input.u32());
    let params = match mode {
        PARAMS_RAW => {
            let iterations = raw[2] as u16;
            Params::DEFAULT
                .with_sigma(f32::from_bits(raw[0]))
                .with_q(f32::from_bits(raw[1]))
                // Valid counts above the cap are capped; invalid ones stay.
                .with_iterations(if (MAX_FUZZ_ITERATIONS..=1000).contains(&iterations) {
                    MAX_FUZZ_ITERATIONS
                } else {
                    iterations
                })
                .with_tau(f32::from_bits(raw[3]))
                .with_min_points(raw[4] as u16)
                .with_max_chi2(f32::from_bits(raw[5]))
                .with_min_length(f32::from_bits(raw[6]))
                .with_fit_shared_points(flags & 1 != 0)
                .with_merge(flags & 2 != 0)
                .with_merge_gap_beams(raw[7] as u16)
                .with_merge_gate(f32::from_bits(raw[8]))
                .with_corner_gap(f32::from_bits(raw[9]))
                .with_min_corner_angle_deg(f32::from_bits(raw[10]))
                .with_split_depth(raw[11] as u8)
                .with_max_range(f32::from_bits(limits[0]))
                .with_merge_collinear(flags & 8 != 0)
                .with_max_alpha_sd_deg(f32::from_bits(limits[1]))
                .with_grazing_noise(f32::from_bits(limits[2]))
                .with_same_turn_windows(flags & 64 != 0)
                .with_fit_sigma(f32::from_bits(limits[3]))
                .with_per_turn(raw[11] & 0x8000_0000 != 0)
                .with_bridge_merge(flags & 128 != 0)
                .with_footprint(f32::from_bits(raw[7] ^ raw[9]))
                .with_arc_chain((raw[10] >> 24) as u8)
                .with_arc_min_turn_deg(f32::from_bits(raw[8] ^ raw[10]))
                .with_arc_max_turn_deg(f32::from_bits(limits[0] ^ raw[3]))
                .with_split_budget((raw[11] >> 8) as u16)
                .with_merge_anchor_gate(f32::from_bits(raw[6] ^ limits[1]))
                .with_turn_offsets(raw[6] & 0x10 != 0)
                .with_arc_pairs(raw[6] & 0x20 != 0)
                .with_merge_f_test(f32::from_bits(raw[5] ^ limits[2]))
        }
        PARAMS_SANE => Params::DEFAULT
            .with_sigma(2e-4 + unit(raw[0]) * 0.1)
            .with_q(if raw[1] & 1 == 0 {
                0.0
            } else {
                unit(raw[1]) * 1e-3
            })
            .with_iterations(1 + (raw[2] % u32::from(MAX_FUZZ_ITERATIONS)) as u16)
            .with_tau(0.01 + unit(raw[3]) * 100.0)
            .with_min_points(3 + (raw[4] % 40) as u16)
            .with_max_chi2(0.01 + unit(raw[5]) * 100.0)
            .with_min_length(unit(raw[6]) * 2.0)
            .with_fit_shared_points(flags & 1 != 0)
            .with_merge(flags & 2 != 0)
            .with_merge_gap_beams((raw[7] % 20) as u16)
            .with_merge_gate(0.01 + unit(raw[8]) * 100.0)
            .with_corner_gap(unit(raw[9]) * 2.0)
            .with_min_corner_angle_deg(unit(raw[10]) * 90.0)
            .with_split_depth(if flags & 4 == 0 {
                0
            } else {
                (raw[11] % (u32::from(lms_core::params::MAX_SPLIT_DEPTH) + 1)) as u8
            })
            .with_max_range(if flags & 16 == 0 {
                f32::INFINITY
            } else {
                0.1 + unit(limits[0]) * 100.0
            })
            .with_merge_collinear(flags & 8 != 0)
            .with_max_alpha_sd_deg(if flags & 32 == 0 {
                f32::INFINITY
            } else {
                0.01 + unit(limits[1]) * 90.0
            })
            .with_grazing_noise(if flags & 128 == 0 {
                0.0
            } else {
                unit(limits[2]) * 3.0
            })
            .with_same_turn_windows(flags & 64 != 0)
            .with_fit_sigma(if limits[3] & 1 == 0 {
                0.0
            } else {
                1e-4 + unit(limits[3]) * 0.1
            })
            .with_per_turn(raw[11] & 0x8000_0000 != 0)
            .with_bridge_merge(flags & 128 != 0)
            .with_footprint(if raw[7] & 0x1_0000 == 0 {
                0.0
            } else {
                unit(raw[7].rotate_left(16)) * 0.02
            })
            .with_arc_chain(match raw[10] >> 28 {
                0..=3 => 0,
                k => (k - 2) as u8,
            })
            .with_arc_min_turn_deg(unit(raw[8].rotate_left(8)) * 20.0)
            .with_arc_max_turn_deg(20.0 + unit(raw[9].rotate_left(8)) * 160.0)
            .with_split_budget((raw[11] >> 16) as u16 % 2048)
            .with_turn_offsets(raw[6] & 0x10 != 0)
            .with_merge_anchor_gate(if raw[6] & 0x100 == 0 {
                f32::INFINITY
            } else {
                0.5 + unit(raw[6].rotate_left(12)) * 50.0
            })
            .with_arc_pairs(raw[6] & 0x20 != 0)
            .with_merge_f_test(if raw[6] & 0x200 == 0 {
                0.0
            } else {
                unit(raw[5].rotate_left(12)) * 50.0
            }),
        _ => Params::DEFAULT.with_iterations(1 + (raw[2] % 40) as u16),
    };

    match input.u8() % 3 {
        RANGES_WORDS => {
            let (units, bits) = (units_of(input.u8()), bits_of(input.u8()));
            for j in 0..n {
                if input.is_empty() {
                    break;
                }
                match bits.decode(input.u16()) {
                    Ok(r) => frame.set_metres(j, f32::from(r) / units.per_metre()),
                    Err(why) => frame.set_invalid(j, why),
                }
            }
        }
        RANGES_RAW => {
            for j in 0..n {
                if input.is_empty() {
                    break;
                }
                frame.set_metres(j, input.f32());
            }
        }
        _ => {
            for j in 0..n {
                if input.is_empty() {
                    break;
                }
                match input.u16() {
                    0 => frame.set_invalid(j, Invalid::Zero),
                    mm => frame.set_metres(j, f32::from(mm) * 1e-3),
                }
            }
        }
    }
    PipelineInput { frame, params }
}

/// Encode a frame of value words for [`decode_pipeline`] (for seeds):
/// geometry of `variant`, default parameters with `iterations` passes.
pub fn encode_pipeline_words(
    variant: Variant,
    iterations: u16,
    units: Unit,
    words: &[u16],
) -> Vec<u8> {
    let mut out = Output::default();
    let idx = Variant::ALL.iter().position(|v| *v == variant).unwrap_or(0) as u8;
    out.u16((words.len() as u16).saturating_sub(3))
        .u8(idx)
        .u32(0)
        .u32(0)
        .u8(PARAMS_DEFAULT);
    for k in 0..12 {
        out.u32(if k == 2 {
            u32::from(iterations.saturating_sub(1))
        } else {
            0
        });
    }
    out.u8(3) // fit shared points, merge
        .u8(RANGES_WORDS)
        .u8(units_byte(units))
        .u8(0); // 13 range bits
    for &w in words {
        out.u16(w);
    }
    out.0
}

// --------------------------------------------------- emulator / co-processor --

/// Operation codes of the emulator and co-processor targets (low 2 bits).
pub mod op {
    /// Emulator: host bytes in (`len u8`, bytes). Co-processor: sensor
    /// bytes in (`len u16 % 1024`, bytes).
    pub const INPUT: u8 = 0;
    /// Advance the clock by `u16 × 4` µs (backwards with [`BACKWARDS`]);
    /// the co-processor is polled.
    pub const ADVANCE: u8 = 1;
    /// Emulator: take its output into a buffer of `(u8 + 1) × 8` bytes.
    /// Co-processor: host bytes in (`len u8`, bytes).
    pub const OUTPUT: u8 = 2;
    /// Emulator: drain its events ([`POWER_ON`]: switch it off and on).
    /// Co-processor: note a sensor queue overflow.
    pub const OTHER: u8 = 3;
    /// With [`ADVANCE`]: the time goes backwards.
    pub const BACKWARDS: u8 = 0x10;
    /// With [`OTHER`] (emulator): power-cycle the sensor.
    pub const POWER_ON: u8 = 0x20;
}

/// A builder of operation sequences (for seeds).
#[derive(Default)]
pub struct Ops(pub Output);

impl Ops {
    /// Emulator: host bytes (split into chunks of ≤ 255).
    pub fn host_bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for c in bytes.chunks(255) {
            self.0.u8(op::INPUT).u8(c.len() as u8).bytes(c);
        }
        self
    }
    /// Co-processor: sensor bytes (chunks of ≤ 1023).
    pub fn sensor_bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for c in bytes.chunks(1023) {
            self.0.u8(op::INPUT).u16(c.len() as u16).bytes(c);
        }
        self
    }
    /// Co-processor: host bytes (chunks of ≤ 255).
    pub fn cop_host_bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for c in bytes.chunks(255) {
            self.0.u8(op::OUTPUT).u8(c.len() as u8).bytes(c);
        }
        self
    }
    /// Advance the clock by about `us` µs.
    pub fn advance(&mut self, us: u64) -> &mut Self {
        let mut left = us / 4;
        while left > 0 {
            let step = left.min(u64::from(u16::MAX));
            self.0.u8(op::ADVANCE).u16(step as u16);
            left -= step;
        }
        self
    }
    /// Emulator: take its output (buffer of `(cap + 1) × 8` bytes).
    pub fn transmit(&mut self, cap: u8) -> &mut Self {
        self.0.u8(op::OUTPUT).u8(cap);
        self
    }
    /// Emulator: drain events.
    pub fn events(&mut self) -> &mut Self {
        self.0.u8(op::OTHER);
        self
    }
}

/// A scan source for the emulator target: value words from a seed, with
/// error codes and flag bits mixed in.
pub fn pattern_words(seed: u8, scan: u32, out: &mut [u16]) -> usize {
    let mut x = u32::from(seed) << 16 ^ scan.wrapping_mul(0x9E37_79B9);
    for w in out.iter_mut() {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        *w = match x % 16 {
            0 => 8191,
            1 => 0,
            2 => 8183 + (x >> 8) as u16 % 9,
            3 => (x >> 4) as u16, // any word, flags included
            _ => 500 + (x >> 8) as u16 % 3000,
        };
    }
    if seed & 0x80 != 0 {
        out.len() / 2 // a short scan: the rest is sent as "not valid"
    } else {
        out.len()
    }
}
