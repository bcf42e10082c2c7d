//! The co-processor between a simulated LMS 2xx (the emulator) and a
//! client in memory: every mode relayed, nothing wedged, every drop
//! counted, the feature opt-in ending with its client's session.

use std::vec::Vec;

use proptest::prelude::*;

use super::*;
use crate::device::emulator::{partial_values, FnSource};
use crate::telegram::features::{Assembled, FeatureAssembler};
use crate::telegram::{
    emit_telegram, Event as FramerEvent, Framer, Handshake, Head, DEFAULT_PASSWORD,
};
use crate::test_support::Port;

type Source = FnSource<std::boxed::Box<dyn FnMut(Variant, Unit, &mut [u16]) -> usize>>;

/// A sensor that sees a room with a little deterministic noise.
fn room_source() -> Source {
    let mut seed = 7u64;
    FnSource(std::boxed::Box::new(
        move |variant: Variant, units, out: &mut [u16]| {
            let g = variant.geometry();
            let scale = if units == Unit::Millimetre {
                1000.0
            } else {
                100.0
            };
            for (j, v) in out.iter_mut().enumerate() {
                let phi = f64::from(g.first_bearing) + j as f64 * f64::from(g.step);
                // A wall 3 m ahead, side walls 2 m away.
                let (s, c) = (phi.sin().abs(), phi.cos().abs());
                let d = (3.0 / s.max(1e-3)).min(2.0 / c.max(1e-3)).min(8.0);
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.01;
                *v = (((d + noise) * scale).round() as u32).min(8000) as u16;
            }
            out.len()
        },
    ))
}

struct Bench {
    lms: Emulator<Source>,
    cop: std::boxed::Box<CoProcessor>,
    sensor: Port,
    host: Port,
    now: u64,
}

impl Bench {
    /// Sensor and co-processor powered on, the sensor streaming.
    fn up() -> Self {
        let mut cop = std::boxed::Box::new(CoProcessor::new(
            crate::ValidParams::DEFAULT,
            SensorSetup::DEFAULT,
        ));
        cop.start(0);
        let mut bench = Bench {
            lms: Emulator::new(room_source(), Settings::default(), 0),
            cop,
            sensor: Port::default(),
            host: Port::default(),
            now: 0,
        };
        bench.run(2_000_000);
        assert_eq!(bench.cop.link().step(), Step::Streaming);
        bench.host.tx.clear();
        bench
    }

    fn run(&mut self, us: u64) {
        let end = self.now + us;
        let mut buf = [0u8; 4096];
        while self.now < end {
            self.now += 200;
            let to_sensor = core::mem::take(&mut self.sensor.tx);
            self.lms.receive(self.now, &to_sensor);
            loop {
                let n = self.lms.transmit(self.now, &mut buf);
                if n == 0 {
                    break;
                }
                self.sensor.rx.extend(&buf[..n]);
            }
            while self.lms.next_event().is_some() {}
            self.cop
                .poll(&mut self.sensor, &mut self.host, self.now)
                .unwrap();
        }
    }

    /// `payload` (command + data) as a host telegram.
    fn telegram(payload: &[u8]) -> Vec<u8> {
        let mut buf = [0u8; 64];
        let n = emit_telegram(&mut buf, Head::to_sensor(payload[0]), &payload[1..], None).unwrap();
        buf[..n].to_vec()
    }

    /// Send `payload` as one request, run `us`, return what came back.
    fn ask(&mut self, payload: &[u8], us: u64) -> Vec<u8> {
        self.host.tx.clear();
        self.host.rx.extend(Self::telegram(payload));
        self.run(us);
        core::mem::take(&mut self.host.tx)
    }
}

/// The telegrams on `wire` (whole), the ACKs and NAKs.
fn telegrams(wire: &[u8]) -> (Vec<Vec<u8>>, usize, usize) {
    let mut framer: Framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let (mut out, mut acks, mut naks) = (Vec::new(), 0, 0);
    let mut input = wire;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(FramerEvent::Ack) => acks += 1,
            Some(FramerEvent::Nak) => naks += 1,
            Some(FramerEvent::Telegram(t)) => out.push(t.as_bytes().to_vec()),
            Some(FramerEvent::Long { .. }) => {}
            None if input.is_empty() => break,
            None => {}
        }
    }
    (out, acks, naks)
}

/// The reply code (byte 4) of each telegram.
fn codes(ts: &[Vec<u8>]) -> Vec<u8> {
    ts.iter().map(|t| t[4]).collect()
}

/// A relayed `3A` is answered by the sensor (`BA`) and a relayed value mode
/// `20 26 05` is taken (`A0 00`): the relay works.
fn assert_relay_works(bench: &mut Bench) {
    let before = bench.lms.stats().requests;
    let (ts, acks, _) = telegrams(&bench.ask(&[0x3A], 400_000));
    assert_eq!((codes(&ts), acks), (vec![0xBA], 1), "3A answered");
    assert_eq!(bench.lms.stats().requests, before + 1, "3A relayed");
    let (ts, _, _) = telegrams(&bench.ask(&[0x20, 0x26, 0x05], 400_000));
    assert_eq!(
        ts.first().map(|t| (t[4], t[5])),
        Some((0xA0, 0x00)),
        "{ts:02X?}"
    );
    let (ts, _, _) = telegrams(&bench.ask(&[0x20, 0x25], 400_000));
    assert!(codes(&ts).contains(&0xA0), "{ts:02X?}");
    bench.run(300_000);
}

#[test]
fn eight_status_requests_and_a_relayed_one_in_one_write_do_not_wedge_the_relay() {
    let mut bench = Bench::up();
    let mut burst = Vec::new();
    for _ in 0..8 {
        burst.extend(Bench::telegram(&[0x31]));
    }
    burst.extend(Bench::telegram(&[0x36]));
    bench.host.rx.extend(burst);
    bench.run(1_000_000);
    let (ts, acks, _) = telegrams(&core::mem::take(&mut bench.host.tx));
    // The queue holds eight replies: the ninth request is dropped whole (no
    // ACK, no reply) and counted, not left claimed.
    assert_eq!((codes(&ts), acks), (vec![0xB1; 8], 8));
    let c = bench.cop.counters();
    assert_eq!(c.host_requests_dropped, 1, "{c:?}");
    assert_relay_works(&mut bench);
    // The same request sent again on its own is relayed: the sensor's 92.
    let (ts, acks, _) = telegrams(&bench.ask(&[0x36], 400_000));
    assert_eq!((codes(&ts), acks), (vec![0x92], 1));
}

#[test]
fn a_relayed_request_behind_a_busy_relay_is_refused_at_once_and_counted() {
    let mut bench = Bench::up();
    let mut two = Bench::telegram(&[0x3A]);
    two.extend(Bench::telegram(&[0x20, 0x26, 0x05]));
    bench.host.rx.extend(two);
    bench.run(600_000);
    let (ts, acks, _) = telegrams(&core::mem::take(&mut bench.host.tx));
    // The 3A relayed (BA); the value mode refused (92) while it was in flight.
    assert_eq!(acks, 2);
    assert_eq!(codes(&ts), vec![0xBA, 0x92], "{ts:02X?}");
    assert_eq!(bench.cop.counters().relays_refused, 1);
    assert_relay_works(&mut bench);
}

#[test]
fn a_reset_lets_a_relayed_request_in_flight_go() {
    let mut bench = Bench::up();
    // 3A relayed, then a reset in the same write: nothing stays claimed.
    let mut two = Bench::telegram(&[0x3A]);
    two.extend(Bench::telegram(&[0x10]));
    bench.host.rx.extend(two);
    bench.run(3_000_000);
    bench.host.tx.clear();
    assert_relay_works(&mut bench);
}

#[test]
fn a_hundred_bad_telegrams_in_one_write_get_a_hundred_naks_all_counted() {
    let mut bench = Bench::up();
    let mut bad = Vec::new();
    for _ in 0..100 {
        let mut t = Bench::telegram(&[0x31]);
        let last = t.len() - 1;
        t[last] ^= 0x55;
        bad.extend(t);
    }
    bench.host.rx.extend(bad);
    bench.run(500_000);
    let wire = core::mem::take(&mut bench.host.tx);
    assert_eq!(wire, vec![0x15; 100]);
    assert_eq!(bench.cop.counters().host_crc_errors, 100);
    // And the line is usable after them.
    let (ts, _, _) = telegrams(&bench.ask(&[0x31], 300_000));
    assert_eq!(codes(&ts), vec![0xB1]);
}

/// A stream's telegrams (codes) after `20 24`, read for `us`.
fn stream(bench: &mut Bench, us: u64) -> Vec<Vec<u8>> {
    let (ts, _, _) = telegrams(&bench.ask(&[0x20, 0x24], us));
    ts
}

#[test]
fn an_unmodified_client_after_an_opted_in_one_gets_only_scans() {
    let mut bench = Bench::up();
    // The opted-in client: 500 kBd, 56 01, stream; it leaves without a word.
    let (ts, _, _) = telegrams(&bench.ask(&[0x20, 0x48], 50_000));
    assert_eq!(codes(&ts), vec![0xA0]);
    let (ts, _, _) = telegrams(&bench.ask(&[0x56, 0x01], 50_000));
    assert_eq!(codes(&ts), vec![0xD6]);
    let ts = stream(&mut bench, 500_000);
    assert!(codes(&ts).contains(&0xD0), "features on");
    // The next client starts as LMS drivers do: the rate (20 4x), 20 25,
    // 3A, 31, 74, the stream. From its rate request on it gets no feature
    // telegram (the stream it finds running goes on until its 20 25).
    let mut found = bench.ask(&[0x20, 0x48], 300_000);
    assert!(
        !bench.cop.features_on(),
        "the opt-in ended with its session"
    );
    found.extend(bench.ask(&[0x20, 0x25], 300_000));
    let (ts, _, _) = telegrams(&found);
    assert!(
        codes(&ts).iter().all(|&c| c == 0xA0 || c == 0xB0),
        "{:02X?}",
        codes(&ts)
    );
    for payload in [&[0x3A][..], &[0x31], &[0x74]] {
        bench.ask(payload, 300_000);
    }
    let ts = stream(&mut bench, 1_000_000);
    let scans = codes(&ts).iter().filter(|&&c| c == 0xB0).count();
    assert!(scans >= 10, "{scans}");
    assert!(
        codes(&ts).iter().all(|&c| c == 0xA0 || c == 0xB0),
        "{:02X?}",
        codes(&ts)
    );
}

#[test]
fn a_reset_ends_the_opt_in_and_the_feature_pump() {
    let mut bench = Bench::up();
    bench.ask(&[0x20, 0x48], 50_000);
    bench.ask(&[0x56, 0x01], 50_000);
    stream(&mut bench, 300_000);
    bench.ask(&[0x10], 3_000_000);
    assert!(!bench.cop.features_on());
    assert!(!bench.cop.features_pending());
}

/// Write the configuration with real-time indices on (installation mode,
/// `74`, `77`).
fn real_time_indices_on(bench: &mut Bench) {
    let mut install = std::vec![0x20, 0x00];
    install.extend_from_slice(&DEFAULT_PASSWORD);
    bench.ask(&install, 50_000);
    let (ts, _, _) = telegrams(&bench.ask(&[0x74], 50_000));
    let mut config = ts[0][5..39].to_vec();
    config[4] |= crate::telegram::config::REAL_TIME_INDICES_BIT;
    let mut write = std::vec![0x77];
    write.extend_from_slice(&config);
    let (ts, _, _) = telegrams(&bench.ask(&write, 50_000));
    assert_eq!((ts[0][4], ts[0][5]), (0xF7, 0x01));
    // The sensor is brought up again with the client's configuration.
    bench.run(3_000_000);
    assert!(bench.lms.config().real_time_indices());
}

/// The features of the client's scans, recomputed by the std build, equal
/// the co-processor's (every group checked); returns the groups checked.
fn check_features(wire: &[u8], whole: impl Fn(&[Vec<u8>]) -> Option<Vec<u16>>) -> usize {
    let (ts, _, _) = telegrams(wire);
    let mut asm = FeatureAssembler::new();
    let mut extractor = crate::Extractor::new();
    let mut scans: Vec<Vec<u8>> = Vec::new();
    let mut want = None;
    let mut checked = 0;
    for t in &ts {
        match t[4] {
            0xB0 => {
                scans.push(t.clone());
                if let Some(words) = whole(&scans) {
                    let units = MeasuredView::parse(
                        &Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap(),
                    )
                    .unwrap()
                    .units();
                    let mut frame = Frame::empty();
                    crate::telegram::measured::frame_from_words(
                        &words,
                        units,
                        RangeBits::Bits13,
                        &mut frame,
                    )
                    .unwrap();
                    extractor.run(&frame, &crate::ValidParams::DEFAULT);
                    want = Some(extractor.features().clone());
                    scans.clear();
                }
            }
            0xD0..=0xD4 => {
                let tel = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
                if let Ok(Assembled::Complete(_, got)) = asm.push(&tel) {
                    let want = want.take().expect("features follow a whole scan");
                    assert_eq!(got.lines(), want.lines());
                    assert_eq!(got.corners(), want.corners());
                    checked += 1;
                }
            }
            _ => {}
        }
    }
    checked
}

#[test]
fn scans_with_real_time_indices_pass_through_whole_with_bit_identical_features() {
    let mut bench = Bench::up();
    bench.ask(&[0x20, 0x48], 50_000);
    real_time_indices_on(&mut bench);
    bench.ask(&[0x56, 0x01], 50_000);
    let wire = bench.ask(&[0x20, 0x24], 1_000_000);
    let (ts, _, _) = telegrams(&wire);
    let scans: Vec<_> = ts.iter().filter(|t| t[4] == 0xB0).collect();
    assert!(scans.len() >= 10, "{}", scans.len());
    let mut indices = Vec::new();
    for t in &scans {
        let tel = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
        let m = MeasuredView::parse(&tel).unwrap();
        // 361 values, then the index: LEN = 1 + 2 + 722 + 1 + 1.
        assert_eq!((m.count(), tel.data().len()), (361, 2 + 722 + 1));
        indices.push(m.real_time_index().unwrap());
    }
    // The sensor's indices, as it sent them: they count up.
    assert!(indices.windows(2).all(|w| w[1] != w[0]), "{indices:?}");
    let checked = check_features(&wire, |s| {
        let t = Telegram::new_checked(&s[0][..], Direction::SensorToHost).unwrap();
        Some(MeasuredView::parse(&t).unwrap().words().collect())
    });
    assert!(checked >= 10, "{checked}");
    // A 30 01 B0 of the face carries the latest scan's index.
    bench.ask(&[0x20, 0x25], 300_000);
    let (ts, _, _) = telegrams(&bench.ask(&[0x30, 0x01], 300_000));
    let tel = Telegram::new_checked(&ts[0][..], Direction::SensorToHost).unwrap();
    assert!(MeasuredView::parse(&tel)
        .unwrap()
        .real_time_index()
        .is_some());
}

/// Join partial scans `s` (in order from partial 0) of `variant` into a
/// whole scan's words, if they are all there.
fn join(variant: Variant, s: &[Vec<u8>]) -> Option<Vec<u16>> {
    let turns = turns_per_scan(variant) as usize;
    if s.len() < turns {
        return None;
    }
    let s = &s[s.len() - turns..];
    let mut words = std::vec![0u16; variant.beams()];
    for (part, t) in s.iter().enumerate() {
        let tel = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
        let m = MeasuredView::parse(&tel).unwrap();
        let step = (variant.resolution_centideg() / 25) as usize;
        if usize::from(m.partial_offset()?) != part * step {
            return None;
        }
        let (first, stride, count) = partial_values(variant, part as u8);
        assert_eq!(m.count(), count);
        for (k, w) in m.words().enumerate() {
            words[first + k * stride] = w;
        }
    }
    Some(words)
}

fn partial_scans_through(variant: Variant) {
    let mut bench = Bench::up();
    bench.ask(&[0x20, 0x48], 50_000);
    let mut req = std::vec![0x3B];
    req.extend_from_slice(&variant.fov_deg().to_le_bytes());
    req.extend_from_slice(&variant.resolution_centideg().to_le_bytes());
    let (ts, _, _) = telegrams(&bench.ask(&req, 50_000));
    assert_eq!(ts[0][5], 1, "variant taken");
    bench.run(3_000_000);
    bench.ask(&[0x56, 0x01], 50_000);
    let wire = bench.ask(&[0x20, 0x2A], 2_000_000);
    let (ts, _, _) = telegrams(&wire);
    assert_eq!((ts[0][4], ts[0][5]), (0xA0, 0x00), "20 2A taken");
    let partials: Vec<_> = ts.iter().filter(|t| t[4] == 0xB0).collect();
    assert!(partials.len() >= 20, "{}", partials.len());
    let turns = turns_per_scan(variant) as u8;
    let step = (variant.resolution_centideg() / 25) as u8;
    for t in &partials {
        let tel = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
        let m = MeasuredView::parse(&tel).unwrap();
        let offset = m.partial_offset().expect("bit 13 set");
        assert!(offset % step == 0 && offset / step < turns);
        assert_eq!(m.count(), partial_values(variant, offset / step).2);
    }
    // Whole scans joined from the partial scans the client got: their
    // features are the co-processor's, bit for bit.
    let checked = check_features(&wire, |s| join(variant, s));
    assert!(checked >= 3, "{checked}");
    assert_eq!(bench.cop.counters().partial_scans_unassembled, 0);
    // Back to whole scans.
    let ts = stream(&mut bench, 1_000_000);
    let last = ts.iter().rev().find(|t| t[4] == 0xB0).unwrap();
    let tel = Telegram::new_checked(&last[..], Direction::SensorToHost).unwrap();
    let m = MeasuredView::parse(&tel).unwrap();
    assert_eq!((m.partial_offset(), m.count()), (None, variant.beams()));
}

#[test]
fn partial_scans_at_a_quarter_degree_are_relayed_and_joined() {
    partial_scans_through(Variant::Fov100Res25);
}

#[test]
fn partial_scans_at_half_a_degree_are_relayed_and_joined() {
    partial_scans_through(Variant::Fov180Res50);
}

#[test]
fn partial_scans_at_one_degree_are_whole_scans() {
    partial_scans_through(Variant::Fov180Res100);
}

/// Valid-CRC requests of every kind a client may send, the co-processor's
/// own, the relayed ones and the modes included (no reset: it restarts the
/// face for 1 s; no rate: both ends of a line switch).
fn any_request() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        8 => Just(std::vec![0x31]),
        1 => Just(std::vec![0x3A]),
        1 => Just(std::vec![0x74]),
        1 => Just(std::vec![0x36]),
        1 => Just(std::vec![0x55]),
        1 => Just(std::vec![0x56, 0x01]),
        1 => Just(std::vec![0x56, 0x00]),
        1 => Just(std::vec![0x30, 0x01]),
        1 => Just(std::vec![0x20, 0x24]),
        1 => Just(std::vec![0x20, 0x25]),
        1 => Just(std::vec![0x20, 0x2A]),
        1 => Just(std::vec![0x20, 0x26, 0x03]),
        1 => Just(std::vec![0x20, 0x27, 0x01, 0x00, 0x0A, 0x00]),
        1 => Just(std::vec![0x20, 0x28, 0x02, 0x01, 0x00, 0x0A, 0x00]),
        1 => Just(std::vec![0x3B, 0xB4, 0x00, 0x64, 0x00]),
        1 => Just(std::vec![0x3B, 0xB4, 0x00, 0x32, 0x00]),
        1 => Just(std::vec![0x44, 0x01, 0x02]),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn after_any_burst_of_requests_a_plain_request_is_relayed(
        fill in 0usize..12,
        filler in prop_oneof![Just(std::vec![0x31]), Just(std::vec![0x74]), Just(std::vec![0x55])],
        relayed in prop_oneof![
            Just(std::vec![0x3A]),
            Just(std::vec![0x36]),
            Just(std::vec![0x20, 0x2A]),
            Just(std::vec![0x20, 0x26, 0x03]),
        ],
        rest in proptest::collection::vec(any_request(), 0..24),
        chunks in 1usize..4,
    ) {
        let mut bench = Bench::up();
        // Requests that fill the face's queue (up to and past it), a relayed
        // one, any others.
        let burst = core::iter::repeat_n(filler, fill)
            .chain(core::iter::once(relayed))
            .chain(rest);
        let wire: Vec<u8> = burst.flat_map(|p| Bench::telegram(&p)).collect();
        // In one write, or a few.
        let size = wire.len().div_ceil(chunks);
        for part in wire.chunks(size) {
            bench.host.rx.extend(part);
            bench.run(2_000);
        }
        // Whatever it was, the client stops the stream and waits.
        bench.run(3_000_000);
        bench.ask(&[0x20, 0x25], 500_000);
        bench.run(1_000_000);
        bench.host.tx.clear();
        let before = bench.lms.stats().requests;
        let (ts, acks, _) = telegrams(&bench.ask(&[0x3A], 500_000));
        prop_assert_eq!(acks, 1);
        prop_assert_eq!(codes(&ts), std::vec![0xBA]);
        prop_assert_eq!(bench.lms.stats().requests, before + 1, "relayed to the sensor");
        prop_assert!(bench.cop.host_face().source().relay == Relay::Idle);
    }
}

/// The co-processor's state is typed: no field of `CoProcessor`,
/// `LatestScan` or `Pump` is a bare `bool` (each state is an enum that
/// names what it describes).
#[test]
fn no_state_is_a_bare_bool() {
    let source = include_str!("mod.rs");
    for name in [
        "pub struct CoProcessor {",
        "pub struct LatestScan {",
        "struct Pump {",
    ] {
        let start = source.find(name).expect(name);
        let body = &source[start..];
        let body = &body[..body.find("\n}").expect("the struct's end")];
        let fields = body.lines().filter(|l| !l.trim_start().starts_with("//"));
        let bools: Vec<&str> = fields.filter(|l| l.contains(": bool")).collect();
        assert!(bools.is_empty(), "{name} {bools:?}");
    }
}
