//! The co-processor on a faulty serial line.
//!
//! A simulated LMS 2xx (the core's emulator, 180°/0.5°, mm, 500 kBd after
//! bring-up) streams scans to the co-processor; a fault injector sits on
//! the sensor line (LMS → co-processor) or on the host line (co-processor
//! → client). Faults, each for a few hundred scans after a clean bring-up:
//! bit errors at 10⁻⁵, 10⁻⁴ and 10⁻³ per bit, dropped, duplicated and
//! inserted bytes, noise bursts, truncated telegrams, and a wrong baud rate
//! for a while (the bytes become noise, fewer or more of them).
//!
//! Every scan carries its number in its first two values, so each `B0` the
//! client gets can be compared with the one the LMS sent. Measured per
//! fault: scans sent, scans the injector left intact, scans delivered
//! intact, scans detected as corrupt (and the framer's CRC errors, resyncs
//! and skipped bytes), scans wrongly accepted, and the telegrams it takes
//! to resynchronise after a damaged one. Asserted: nothing wrongly accepted
//! at these seeds; every telegram the injector left intact is delivered —
//! in particular the next good one after a burst (resync within one
//! telegram); the co-processor keeps running and its counters agree.
//!
//! How often may a damaged telegram pass? Its checksum (PROTOCOL.md §1)
//! is 16 bits, but it is not a CRC of the textbook kind: the register
//! shifts one bit per byte and every byte enters twice (as itself and as
//! the high byte of the next step), so the change caused by bit `k` of
//! byte `i` equals the change caused by bit `k + d` of byte `i + d`
//! (d = 1…7). Every single-bit error and every error inside one byte is
//! detected, but about one double-bit error in ten within a few bytes is
//! not ([`lms_checksum_misses_diagonal_double_bit_errors`]): at a bit error
//! rate `p`, a telegram of `L` bytes passes damaged with probability
//! ≈ `N₂(L)·p²` (`N₂`: undetectable bit pairs, ≈ 28·L) plus ≈ 2⁻¹⁶ for
//! heavier damage — well above 2⁻¹⁶ per corrupted telegram for short
//! telegrams at 10⁻³. Other faults (shifts, bursts of noise, truncation)
//! pass at ≈ 2⁻¹⁶ per damaged telegram (a `B0` must then also have a
//! consistent count word and length to be taken as a scan). The tables
//! print the expected number of false accepts of each run under this
//! model; the test asserts none where that expectation is below 0.05, and
//! at most a Poisson bound above it.
//!
//! Also: requests from the client with a bit error are refused (NAK) or
//! ignored, never executed as another request.
//!
//! `cargo test -p lms-core --test faulty_line -- --nocapture` prints the tables.

use std::collections::{HashMap, HashSet};

use lms_core::device::coprocessor::{CoProcessor, SensorSetup, Step};
use lms_core::device::emulator::{Emulator, FnSource, Settings};
use lms_core::telegram::features::{Assembled, FeatureAssembler, CMD_COUNTERS, REQ_COUNTERS};
use lms_core::telegram::{
    emit_telegram, Direction, Event, Framer, FramerStats, Handshake, Head, Request, ACK, NAK,
};
use lms_core::test_support::{Port, Rng};
use lms_core::Unit;
use lms_core::{Params, Variant};

mod common;

/// Scans per fault type.
const SCANS: u32 = 300;
/// Simulation step (µs).
const STEP_US: u64 = 1000;

// ------------------------------------------------------------- the faults --

#[derive(Clone, Copy, Debug)]
enum Fault {
    None,
    /// Each bit flipped with this probability.
    BitErrors(f64),
    /// Each byte lost with this probability.
    Drop(f64),
    /// Each byte received twice with this probability.
    Duplicate(f64),
    /// A random byte inserted before each byte with this probability.
    Insert(f64),
    /// A burst of noise (1..=max bytes replaced) in one telegram out of `every`.
    Burst {
        every: usize,
        max: usize,
    },
    /// One telegram in `every` cut short at a random point.
    Truncate {
        every: usize,
    },
    /// For `window_us` out of every `period_us`, the receiver runs at the
    /// wrong rate: every byte becomes noise, 0.3–1.7 times as many bytes.
    WrongBaud {
        period_us: u64,
        window_us: u64,
    },
}

impl Fault {
    fn name(&self) -> String {
        match *self {
            Fault::None => "none".into(),
            Fault::BitErrors(p) => format!("bit errors {p:.0e}/bit"),
            Fault::Drop(p) => format!("dropped bytes {p:.0e}/B"),
            Fault::Duplicate(p) => format!("duplicated bytes {p:.0e}/B"),
            Fault::Insert(p) => format!("inserted bytes {p:.0e}/B"),
            Fault::Burst { every, max } => format!("burst ≤{max} B, 1 in {every}"),
            Fault::Truncate { every } => format!("truncated, 1 in {every}"),
            Fault::WrongBaud {
                period_us,
                window_us,
            } => format!(
                "wrong baud {} ms of {} ms",
                window_us / 1000,
                period_us / 1000
            ),
        }
    }
}

/// Applies a fault to telegrams on their way; keeps state across them
/// (a burst may run into the next telegram).
struct Injector {
    fault: Fault,
    rng: Rng,
    /// Bits (or bytes) until the next error.
    until_next: u64,
    burst_left: usize,
    /// Bursts that started: (index of the telegram hit).
    bursts: Vec<usize>,
}

impl Injector {
    fn new(fault: Fault, seed: u64) -> Self {
        let mut rng = Rng(seed | 1);
        let until_next = match fault {
            Fault::BitErrors(p) | Fault::Drop(p) | Fault::Duplicate(p) | Fault::Insert(p) => {
                rng.gap(p)
            }
            _ => u64::MAX,
        };
        Injector {
            fault,
            rng,
            until_next,
            burst_left: 0,
            bursts: Vec::new(),
        }
    }

    /// Telegram number `index` at `now_us` onto the line: its bytes as the
    /// receiver gets them.
    fn apply(&mut self, index: usize, now_us: u64, t: &[u8], out: &mut Vec<u8>) {
        let start = out.len();
        match self.fault {
            Fault::None => out.extend_from_slice(t),
            Fault::BitErrors(p) => {
                out.extend_from_slice(t);
                let mut bit = 0u64;
                let bits = 8 * t.len() as u64;
                while self.until_next < bits - bit {
                    bit += self.until_next;
                    out[start + (bit / 8) as usize] ^= 1 << (bit % 8);
                    bit += 1;
                    self.until_next = self.rng.gap(p);
                }
                self.until_next -= bits - bit;
            }
            Fault::Drop(p) | Fault::Duplicate(p) | Fault::Insert(p) => {
                for &b in t {
                    if self.until_next > 0 {
                        self.until_next -= 1;
                        out.push(b);
                        continue;
                    }
                    self.until_next = self.rng.gap(p);
                    match self.fault {
                        Fault::Drop(_) => {}
                        Fault::Duplicate(_) => out.extend([b, b]),
                        _ => out.extend([self.rng.next_u64() as u8, b]),
                    }
                }
            }
            Fault::Burst { every, max } => {
                out.extend_from_slice(t);
                let mut at = 0;
                if self.burst_left == 0 && self.rng.below(every) == 0 {
                    at = self.rng.below(t.len());
                    self.burst_left = 1 + self.rng.below(max);
                    self.bursts.push(index);
                }
                while self.burst_left > 0 && at < t.len() {
                    out[start + at] = self.rng.next_u64() as u8;
                    at += 1;
                    self.burst_left -= 1;
                }
            }
            Fault::Truncate { every } => {
                if self.rng.below(every) == 0 {
                    out.extend_from_slice(&t[..1 + self.rng.below(t.len() - 1)]);
                } else {
                    out.extend_from_slice(t);
                }
            }
            Fault::WrongBaud {
                period_us,
                window_us,
            } => {
                if now_us % period_us < window_us {
                    let n = (t.len() as f64 * (0.3 + 1.4 * self.rng.unit())) as usize;
                    out.extend((0..n).map(|_| self.rng.next_u64() as u8));
                } else {
                    out.extend_from_slice(t);
                }
            }
        }
    }
}

// ------------------------------------------------------------- the bench --

/// The scan's number in its first two values (1..=8000 each).
fn scan_id(words: &[u16]) -> u32 {
    u32::from(words[0]).wrapping_sub(1) + 8000 * u32::from(words[1]).wrapping_sub(1)
}

/// Value words of a `B0` telegram's bytes.
fn b0_words(t: &[u8]) -> Vec<u16> {
    t[7..t.len() - 3]
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect()
}

/// A room seen from the middle, mm, with the scan number in beams 0 and 1.
fn room(k: u32, out: &mut [u16]) -> usize {
    let g = Variant::Fov180Res50.geometry();
    let mut seed = u64::from(k).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    for (j, v) in out.iter_mut().enumerate() {
        let phi = f64::from(g.bearing(j));
        let d = common::room_distance_m(phi);
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let noise = ((seed >> 40) as f64 / (1u64 << 24) as f64 - 0.5) * 0.01;
        *v = (((d + noise) * 1000.0).round() as u32).min(8182) as u16;
    }
    out[0] = (1 + k % 8000) as u16;
    out[1] = (1 + k / 8000) as u16;
    out.len()
}

/// Where the injector sits.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Side {
    /// LMS → co-processor.
    Sensor,
    /// Co-processor → client.
    Host,
}

#[derive(Default, Debug)]
struct Outcome {
    sent: usize,
    left_intact: usize,
    delivered: usize,
    wrongly_accepted: usize,
    /// Telegrams the injector changed.
    corrupted: usize,
    /// Intact telegrams not delivered.
    intact_lost: usize,
    /// Largest number of telegrams from a damaged one to the next delivered.
    resync_max: usize,
    bursts: usize,
    framer: FramerStats,
    /// Co-processor counters over the fault phase (sensor side), or the
    /// client's feature groups (host side).
    scans_in: u32,
    feature_groups: usize,
    feature_errors: usize,
    rejected: u32,
    /// Expected false accepts under the checksum model.
    expected_false: f64,
}

type Source = Box<dyn FnMut(Variant, Unit, &mut [u16]) -> usize>;

/// What happens to a telegram on its way: `(now_us, telegram or handshake
/// byte, bytes the receiver gets)`.
type Hook<'a> = dyn FnMut(u64, Option<&[u8]>, &mut Vec<u8>) + 'a;

struct Bench {
    lms: Emulator<FnSource<Source>>,
    cop: CoProcessor,
    sensor: Port,
    host: Port,
    now: u64,
    /// LMS → co-processor, split into telegrams (clean).
    sensor_framer: Framer,
    /// Co-processor → client, split into telegrams (clean).
    host_framer: Framer,
}

impl Bench {
    fn new() -> Self {
        let mut k = 0u32;
        let source: Source = Box::new(move |_, _, out| {
            k += 1;
            room(k, out)
        });
        let mut cop = CoProcessor::new(
            Params::DEFAULT
                .with_iterations(2)
                .validate()
                .expect("2 passes are valid"),
            SensorSetup::DEFAULT,
        );
        cop.start(0);
        Bench {
            lms: Emulator::new(FnSource(source), Settings::default(), 0),
            cop,
            sensor: Port::default(),
            host: Port::default(),
            now: 0,
            sensor_framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
            host_framer: Framer::new(Direction::SensorToHost, Handshake::Expected),
        }
    }

    /// One step: the LMS's telegrams go through `on_sensor` (telegram bytes
    /// or an ACK) into the co-processor; the co-processor's output through
    /// `on_host` to the client.
    fn step(&mut self, on_sensor: &mut Hook<'_>, on_host: &mut Hook<'_>, client_rx: &mut Vec<u8>) {
        self.now += STEP_US;
        let now = self.now;
        let to_sensor = std::mem::take(&mut self.sensor.tx);
        self.lms.receive(now, &to_sensor);
        let mut buf = [0u8; 4096];
        let mut line = Vec::new();
        loop {
            let n = self.lms.transmit(now, &mut buf);
            if n == 0 {
                break;
            }
            line.extend_from_slice(&buf[..n]);
        }
        while self.lms.next_event().is_some() {}
        let mut arrived = Vec::new();
        split(&mut self.sensor_framer, &line, |t| {
            on_sensor(now, t, &mut arrived)
        });
        self.sensor.rx.extend(arrived);
        self.cop
            .poll(&mut self.sensor, &mut self.host, now)
            .unwrap();
        let out = std::mem::take(&mut self.host.tx);
        split(&mut self.host_framer, &out, |t| on_host(now, t, client_rx));
    }

    fn send_host(&mut self, bytes: &[u8]) {
        self.host.rx.extend(bytes);
    }
}

/// Feed `bytes` to a framer; hand each telegram (or `None` for an ACK/NAK
/// byte: `Some` of one byte) on.
fn split(framer: &mut Framer, bytes: &[u8], mut each: impl FnMut(Option<&[u8]>)) {
    let mut input = bytes;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => each(Some(t.as_bytes())),
            Some(Event::Ack) => each(Some(&[ACK][..])),
            Some(Event::Nak) => each(Some(&[NAK][..])),
            Some(Event::Long { .. }) => unreachable!("a full-size framer holds every telegram"),
            None => break,
        }
    }
}

fn request(r: Request<'_>) -> Vec<u8> {
    let mut buf = [0u8; 64];
    let n = r.emit(0, &mut buf).unwrap();
    buf[..n].to_vec()
}

/// Bring the sensor up and the client's stream on, all clean.
fn bring_up(bench: &mut Bench, client: &mut Vec<u8>) {
    let mut pass = |_: u64, t: Option<&[u8]>, out: &mut Vec<u8>| out.extend(t.unwrap_or(&[]));
    let mut pass2 = |_: u64, t: Option<&[u8]>, out: &mut Vec<u8>| out.extend(t.unwrap_or(&[]));
    for _ in 0..700 {
        bench.step(&mut pass, &mut pass2, client);
    }
    assert_eq!(bench.cop.link().step(), Step::Streaming);
    // The host line at 500 kBd with the features on (`56 01`), then the stream.
    bench.send_host(&request(Request::SetBaud(
        lms_core::telegram::Baud::B500000,
    )));
    for _ in 0..50 {
        bench.step(&mut pass, &mut pass2, client);
    }
    let mut on = [0u8; 16];
    let n = lms_core::telegram::emit_telegram(&mut on, Head::to_sensor(0x56), &[1], None).unwrap();
    bench.send_host(&on[..n]);
    for _ in 0..50 {
        bench.step(&mut pass, &mut pass2, client);
    }
    bench.send_host(&request(Request::Continuous));
    for _ in 0..50 {
        bench.step(&mut pass, &mut pass2, client);
    }
    client.clear();
}

/// A telegram as the injector saw it.
struct Sent {
    bytes: Vec<u8>,
    /// The injector changed it.
    modified: bool,
    /// Sent while the fault was on (not in the clean tail).
    in_phase: bool,
}

/// From each damaged telegram, how many telegrams on to the next one
/// delivered, counting from the first undamaged one (1: the next good
/// telegram is delivered).
fn resync_max(sent: &[Sent], delivered: &[bool]) -> usize {
    let mut worst = 0;
    for (i, t) in sent.iter().enumerate() {
        if !t.modified || i + 1 == sent.len() {
            continue;
        }
        let skip = sent[i + 1..].iter().take_while(|t| t.modified).count();
        let next = delivered[i + 1..]
            .iter()
            .position(|d| *d)
            .map_or(usize::MAX, |p| p + 1);
        worst = worst.max(next.saturating_sub(skip));
    }
    worst
}

/// One run: `fault` on `side` for [`SCANS`] scans, then a clean tail.
fn run(side: Side, fault: Fault, seed: u64) -> Outcome {
    let mut bench = Bench::new();
    let mut client_rx = Vec::new();
    bring_up(&mut bench, &mut client_rx);
    let before = bench.cop.counters();

    let active = std::cell::Cell::new(true);
    let mut injector = Injector::new(fault, seed);
    // Every telegram after bring-up on the faulty side, in order.
    let mut sent: Vec<Sent> = Vec::new();
    let mut hook = |on: Side, now: u64, t: Option<&[u8]>, out: &mut Vec<u8>| {
        let t = t.unwrap_or(&[]);
        // Sensor side: only B0s are scans (ACKs and replies pass);
        // host side: every telegram.
        let counted = on == side && t.len() >= 8 && (side == Side::Host || t[4] == 0xB0);
        if !counted {
            out.extend_from_slice(t);
            return;
        }
        let start = out.len();
        if active.get() {
            injector.apply(sent.len(), now, t, out);
        } else {
            out.extend_from_slice(t);
        }
        sent.push(Sent {
            bytes: t.to_vec(),
            modified: out[start..] != *t,
            in_phase: active.get(),
        });
    };
    let period = 26_667;
    let steps = (u64::from(SCANS) * period).div_ceil(STEP_US);
    {
        let hook = std::cell::RefCell::new(&mut hook);
        let mut on_sensor = |now: u64, t: Option<&[u8]>, out: &mut Vec<u8>| {
            (hook.borrow_mut())(Side::Sensor, now, t, out)
        };
        let mut on_host = |now: u64, t: Option<&[u8]>, out: &mut Vec<u8>| {
            (hook.borrow_mut())(Side::Host, now, t, out)
        };
        for i in 0..steps + 300 {
            active.set(i < steps);
            bench.step(&mut on_sensor, &mut on_host, &mut client_rx);
        }
    }
    let bursts = injector.bursts.len();
    let after = bench.cop.counters();

    // The client's view (its line is clean when the fault is on the sensor side).
    let mut client = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut asm = FeatureAssembler::new();
    let mut got: Vec<Vec<u8>> = Vec::new();
    let (mut groups, mut feature_errors) = (0, 0);
    let mut input = &client_rx[..];
    loop {
        let fed = client.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => {
                got.push(t.as_bytes().to_vec());
                match asm.push(&t) {
                    Ok(Assembled::Complete(..)) => groups += 1,
                    Ok(_) => {}
                    Err(_) => feature_errors += 1,
                }
            }
            Some(_) => {}
            None => break,
        }
    }
    feature_errors += asm.discarded() as usize;

    // What was sent, what arrived.
    let clean: HashSet<&[u8]> = sent.iter().map(|t| &t.bytes[..]).collect();
    let arrived: HashSet<&[u8]> = got.iter().map(|t| &t[..]).collect();
    let delivered: Vec<bool> = sent
        .iter()
        .map(|t| arrived.contains(&t.bytes[..]))
        .collect();
    let wrongly_accepted = match side {
        // Every B0 the client got must be one the LMS sent (by scan number).
        Side::Sensor => {
            let by_id: HashMap<u32, &[u8]> = sent
                .iter()
                .map(|t| (scan_id(&b0_words(&t.bytes)), &t.bytes[..]))
                .collect();
            got.iter()
                .filter(|t| t[4] == 0xB0)
                .filter(|t| by_id.get(&scan_id(&b0_words(t))) != Some(&&t[..]))
                .count()
        }
        // Every telegram the client got must be one the co-processor sent.
        Side::Host => got.iter().filter(|t| !clean.contains(&t[..])).count(),
    };
    let scans: Vec<usize> = (0..sent.len())
        .filter(|&i| sent[i].in_phase && sent[i].bytes[4] == 0xB0)
        .collect();
    let mut o = Outcome {
        sent: scans.len(),
        left_intact: scans.iter().filter(|&&i| !sent[i].modified).count(),
        delivered: scans.iter().filter(|&&i| delivered[i]).count(),
        wrongly_accepted,
        corrupted: sent.iter().filter(|t| t.modified).count(),
        intact_lost: (0..sent.len())
            .filter(|&i| !sent[i].modified && !delivered[i])
            .count(),
        resync_max: resync_max(&sent, &delivered),
        bursts,
        framer: *client.stats(),
        scans_in: after.scans_in - before.scans_in,
        feature_groups: groups,
        feature_errors,
        rejected: after.scans_rejected - before.scans_rejected,
        expected_false: {
            let lengths: Vec<usize> = sent
                .iter()
                .filter(|t| t.in_phase)
                .map(|t| t.bytes.len())
                .collect();
            expected_false_accepts(fault, &lengths, sent.iter().filter(|t| t.modified).count())
        },
    };
    if side == Side::Sensor {
        o.framer = FramerStats {
            crc_errors: after.sensor_crc_errors - before.sensor_crc_errors,
            resyncs: after.sensor_resyncs - before.sensor_resyncs,
            bytes_skipped: after.sensor_bytes_skipped - before.sensor_bytes_skipped,
            ..FramerStats::default()
        };
    }
    // The clean tail's scans (all delivered) are not part of the counts.
    let tail = sent
        .iter()
        .filter(|t| !t.in_phase && t.bytes[4] == 0xB0)
        .count();
    o.scans_in -= tail as u32;
    o.feature_groups -= tail;
    o
}

/// Undetectable bit pairs of a telegram of `len` bytes: pairs of bits
/// (after `STX ADDR LEN`, CRC field included) whose flips change the
/// checksum comparison identically, so that flipping both goes unnoticed.
/// The checksum is linear over GF(2) from 0, so a bit's effect does not
/// depend on the data.
fn undetectable_pairs(len: usize) -> u64 {
    let covered = len - 2;
    let mut effect: HashMap<u16, u64> = HashMap::new();
    let mut buf = vec![0u8; covered];
    for i in 4..covered {
        for k in 0..8 {
            buf[i] = 1 << k;
            *effect.entry(lms_core::telegram::crc16(&buf)).or_default() += 1;
            buf[i] = 0;
        }
    }
    // A flip in the received CRC field changes the comparison by that bit.
    for bit in 0..16 {
        *effect.entry(1 << bit).or_default() += 1;
    }
    effect.values().map(|n| n * (n - 1) / 2).sum()
}

/// Probability that a telegram of `len` bytes with bit error rate `p` is
/// damaged but passes the checksum: exactly two flips forming an
/// undetectable pair, or three and more flips passing at ≈ 2⁻¹⁶.
fn false_accept_probability(len: usize, p: f64, pairs: u64) -> f64 {
    let bits = 8.0 * (len - 4) as f64;
    let p0 = (1.0 - p).powf(bits);
    let p1 = bits * p * (1.0 - p).powf(bits - 1.0);
    let p2_pattern = p * p * (1.0 - p).powf(bits - 2.0);
    let p2 = bits * (bits - 1.0) / 2.0 * p2_pattern;
    pairs as f64 * p2_pattern + (1.0 - p0 - p1 - p2).max(0.0) / 65536.0
}

/// Expected false accepts of a run: the model above for bit errors,
/// 2⁻¹⁶ per damaged telegram for the other faults.
fn expected_false_accepts(fault: Fault, lengths: &[usize], corrupted: usize) -> f64 {
    match fault {
        Fault::BitErrors(p) => {
            let mut cache: HashMap<usize, u64> = HashMap::new();
            lengths
                .iter()
                .map(|&len| {
                    let pairs = *cache.entry(len).or_insert_with(|| undetectable_pairs(len));
                    false_accept_probability(len, p, pairs)
                })
                .sum()
        }
        _ => corrupted as f64 / 65536.0,
    }
}

fn print_table(title: &str, rows: &[(String, Outcome)]) {
    println!("\n{title}");
    println!(
        "| fault | scans sent | left intact | delivered intact | lost (detected) | wrongly accepted | telegrams corrupted (expected false accepts) | CRC errors | resyncs | bytes skipped | feature groups (errors) | intact lost | resync (telegrams) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, o) in rows {
        let name = if o.bursts > 0 {
            format!("{name} ({} bursts)", o.bursts)
        } else {
            name.clone()
        };
        println!(
            "| {name} | {} | {} | {} | {} | {} | {} ({:.2}) | {} | {} | {} | {} ({}) | {} | {} |",
            o.sent,
            o.left_intact,
            o.delivered,
            o.sent - o.delivered,
            o.wrongly_accepted,
            o.corrupted,
            o.expected_false,
            o.framer.crc_errors,
            o.framer.resyncs,
            o.framer.bytes_skipped,
            o.feature_groups,
            o.feature_errors,
            o.intact_lost,
            if o.corrupted == 0 {
                "-".to_string()
            } else {
                o.resync_max.to_string()
            },
        );
    }
}

fn faults() -> Vec<Fault> {
    vec![
        Fault::None,
        Fault::BitErrors(1e-5),
        Fault::BitErrors(1e-4),
        Fault::BitErrors(1e-3),
        Fault::Drop(1e-4),
        Fault::Duplicate(1e-4),
        Fault::Insert(1e-4),
        Fault::Burst { every: 6, max: 64 },
        Fault::Truncate { every: 8 },
        Fault::WrongBaud {
            period_us: 2_000_000,
            window_us: 150_000,
        },
    ]
}

fn check_row(side: Side, fault: Fault, o: &Outcome) {
    let what = format!("{side:?} line, {}", fault.name());
    // Poisson bound on the false accepts the checksum lets through.
    let allowed = if o.expected_false < 0.05 {
        0
    } else {
        (o.expected_false + 4.0 * o.expected_false.sqrt() + 1.0).ceil() as usize
    };
    assert!(
        o.wrongly_accepted <= allowed,
        "{what}: wrongly accepted {} (expected {:.3}) {o:?}",
        o.wrongly_accepted,
        o.expected_false
    );
    assert_eq!(o.intact_lost, 0, "{what}: intact telegrams lost {o:?}");
    assert!(o.sent >= SCANS as usize - 2, "{what}: {o:?}");
    assert!(o.left_intact <= o.delivered, "{what}: {o:?}");
    if o.corrupted > 0 {
        assert_eq!(o.resync_max, 1, "{what}: resync {o:?}");
    } else {
        assert_eq!(o.delivered, o.sent, "{what}: clean line {o:?}");
    }
    if side == Side::Host {
        // The co-processor's side is clean: it took every scan.
        assert_eq!(o.scans_in as usize, o.sent, "{what}: {o:?}");
    }
    if side == Side::Sensor {
        // Every scan taken was passed to the client, each with its features.
        let taken = o.delivered + o.wrongly_accepted;
        assert_eq!(o.scans_in as usize, taken, "{what}: {o:?}");
        assert_eq!(o.feature_groups, taken, "{what}: {o:?}");
        assert_eq!(o.rejected, 0, "{what}: {o:?}");
        if o.corrupted > 0 && !matches!(fault, Fault::WrongBaud { .. }) {
            assert!(o.framer.resyncs > 0, "{what}: damage went unnoticed {o:?}");
        }
    }
}

#[test]
fn sensor_line_faults() {
    let mut rows = Vec::new();
    for (i, fault) in faults().into_iter().enumerate() {
        let o = run(Side::Sensor, fault, 0x5EED_0000 + i as u64);
        check_row(Side::Sensor, fault, &o);
        rows.push((fault.name(), o));
    }
    print_table(
        "Sensor line (LMS → co-processor), 300 scans per fault, 500 kBd; CRC errors, resyncs and bytes skipped are the co-processor's counters:",
        &rows,
    );
}

#[test]
fn host_line_faults() {
    let mut rows = Vec::new();
    for (i, fault) in faults().into_iter().enumerate() {
        let o = run(Side::Host, fault, 0x0057_0000 + i as u64);
        check_row(Side::Host, fault, &o);
        rows.push((fault.name(), o));
    }
    print_table(
        "Host line (co-processor → client), 300 scans per fault; scans are B0s, telegrams also D0–D4; CRC errors, resyncs and bytes skipped are the client framer's:",
        &rows,
    );
}

/// Requests with one bit flipped: refused with NAK (counted) or ignored
/// (a damaged header), never executed as something else; the next intact
/// request is answered.
#[test]
fn damaged_requests_are_refused() {
    let mut bench = Bench::new();
    let mut client = Vec::new();
    bring_up(&mut bench, &mut client);
    let mut counters = [0u8; 16];
    let n = emit_telegram(&mut counters, Head::to_sensor(REQ_COUNTERS), &[], None).unwrap();
    let counters = counters[..n].to_vec();
    let stop = request(Request::OnRequest);
    let mut pass = |_: u64, t: Option<&[u8]>, out: &mut Vec<u8>| out.extend(t.unwrap_or(&[]));
    let mut pass2 = |_: u64, t: Option<&[u8]>, out: &mut Vec<u8>| out.extend(t.unwrap_or(&[]));
    // Stop the stream first, so that the replies are easy to see.
    bench.send_host(&stop);
    for _ in 0..100 {
        bench.step(&mut pass, &mut pass2, &mut client);
    }
    let (mut naks, mut ignored) = (0, 0);
    for bit in 0..8 * counters.len() {
        client.clear();
        let before = bench.cop.counters().host_crc_errors;
        let mut bad = counters.clone();
        bad[bit / 8] ^= 1 << (bit % 8);
        bench.send_host(&bad);
        // Longer than the emulator's 50 ms receive time-out.
        for _ in 0..80 {
            bench.step(&mut pass, &mut pass2, &mut client);
        }
        let replies: Vec<u8> = client.clone();
        assert!(
            !replies
                .windows(5)
                .any(|w| w[0] == 0x02 && w[4] != 0x00 && w[1] == 0x80),
            "bit {bit}: a damaged request was answered with a telegram: {replies:02X?}"
        );
        if replies == [NAK] {
            naks += 1;
            assert_eq!(bench.cop.counters().host_crc_errors, before + 1);
        } else {
            assert!(replies.is_empty(), "bit {bit}: {replies:02X?}");
            ignored += 1;
        }
        // The intact request is answered: ACK + D5.
        client.clear();
        bench.send_host(&counters);
        for _ in 0..10 {
            bench.step(&mut pass, &mut pass2, &mut client);
        }
        assert_eq!(client.first(), Some(&ACK), "bit {bit}: {client:02X?}");
        assert_eq!(
            client.get(5),
            Some(&CMD_COUNTERS),
            "bit {bit}: {client:02X?}"
        );
    }
    println!(
        "\ndamaged 55 requests (every single-bit error of 7 bytes): {naks} NAK, {ignored} ignored (damaged STX/LEN), 0 executed"
    );
    assert_eq!(naks + ignored, 8 * counters.len());
}

/// The LMS checksum's blind spot, counted exhaustively: pairs of bit flips
/// it cannot see, in a 732-byte `B0` and in the co-processor's 58-byte
/// summary `D0`. They are the "diagonal" pairs — bit `k` of byte `i` with
/// bit `k + d` of byte `i + d` — and no single-bit error.
#[test]
fn lms_checksum_misses_diagonal_double_bit_errors() {
    // Diagonal pairs are undetectable.
    let mut t = [0u8; 64];
    let (i, k, d) = (10, 1, 3);
    t[i] ^= 1 << k;
    t[i + d] ^= 1 << (k + d);
    assert_eq!(lms_core::telegram::crc16(&t), 0, "diagonal pair unseen");
    // Single bits are always seen.
    for i in 0..64 {
        for k in 0..8 {
            let mut t = [0u8; 64];
            t[i] = 1 << k;
            assert_ne!(lms_core::telegram::crc16(&t), 0);
        }
    }
    let b0 = undetectable_pairs(732);
    let d0 = undetectable_pairs(58);
    let all = |len: usize| {
        let bits = 8 * (len - 4) as u64;
        bits * (bits - 1) / 2
    };
    println!(
        "\nLMS checksum: undetectable double-bit errors: B0 (732 B) {b0} of {} pairs ({:.2e}); D0 (58 B) {d0} of {} ({:.2e})",
        all(732),
        b0 as f64 / all(732) as f64,
        all(58),
        d0 as f64 / all(58) as f64
    );
    for p in [1e-5, 1e-4, 1e-3] {
        println!(
            "  bit error rate {p:.0e}: a B0 passes damaged with p = {:.1e}, a D0 with {:.1e} (2^-16 = 1.5e-5)",
            false_accept_probability(732, p, b0),
            false_accept_probability(58, p, d0)
        );
    }
    // About 28 pairs per byte (d = 1..7, 8 - d bits each).
    assert!(b0 > 25 * 720 && b0 < 40 * 732, "{b0}");
}
