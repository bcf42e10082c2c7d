//! Property tests of the telegram layer:
//!
//! - the framer, fed any mix of intact telegrams, truncated ones, garbage
//!   and ACK/NAK bytes in any chunks, delivers exactly the intact telegrams
//!   in order (after the caller's idle time-out, `abandon`), never a
//!   truncated one, and accounts for every byte;
//! - every request and reply the codec can represent emits to bytes that
//!   parse back to it;
//! - a `B0` of any variant, units, range bits and value words decodes to
//!   the frame its words describe, and back to the words;
//! - any feature set goes through its telegrams and the assembler bit for
//!   bit.
//!
//! Cases: `PROPTEST_CASES` (default 256).

use lms_core::telegram::features::{emit_features, Assembled, EchoedParams, FeatureAssembler};
use lms_core::telegram::{
    emit_telegram, Baud, Config, Direction, Event, Framer, Handshake, Head, MeasuredValues,
    MeasuredView, ModeResult, RangeBits, Reply, Request, SensorStatus, StatusBlock, Telegram,
    VariantReply, ACK, MAX_TELEGRAM_LEN, NAK,
};
use lms_core::Unit;
use lms_core::{Beam, FovRes, Stats, Variant};
use proptest::prelude::*;

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(256),
        // Next to this file: props_telegram.proptest-regressions.
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::WithSource("proptest-regressions"),
        )),
        ..ProptestConfig::default()
    }
}

/// A piece of a sensor → host byte stream.
#[derive(Clone, Debug)]
enum Piece {
    /// An intact telegram (command, data).
    Telegram(u8, Vec<u8>),
    /// The first `cut` bytes of a telegram.
    Truncated(u8, Vec<u8>, usize),
    /// Bytes that are no telegram.
    Garbage(Vec<u8>),
    /// A handshake byte.
    Handshake(bool),
}

fn telegram_bytes(command: u8, data: &[u8]) -> Vec<u8> {
    let mut buf = vec![0u8; MAX_TELEGRAM_LEN];
    let n = emit_telegram(&mut buf, Head::from_sensor(command), data, Some(0x10)).expect("fits");
    buf.truncate(n);
    buf
}

fn piece() -> impl Strategy<Value = Piece> {
    let body = || {
        prop_oneof![
            3 => prop::collection::vec(any::<u8>(), 0..40),
            1 => prop::collection::vec(any::<u8>(), 700..=810),
        ]
    };
    prop_oneof![
        4 => (any::<u8>(), body()).prop_map(|(c, d)| Piece::Telegram(c, d)),
        2 => (any::<u8>(), body(), 1usize..820).prop_map(|(c, d, cut)| Piece::Truncated(c, d, cut)),
        2 => prop::collection::vec(any::<u8>(), 1..60).prop_map(Piece::Garbage),
        1 => any::<bool>().prop_map(Piece::Handshake),
    ]
}

/// Feed all of `input`, then time out until nothing is held back.
fn run_framer(framer: &mut Framer, chunks: &[&[u8]]) -> (Vec<Vec<u8>>, usize) {
    let mut telegrams = Vec::new();
    let mut handshakes = 0;
    let mut take = |framer: &mut Framer, chunk: &[u8]| {
        let mut input = chunk;
        loop {
            let fed = framer.feed(input);
            input = fed.remaining;
            match fed.event {
                Some(Event::Telegram(t)) => telegrams.push(t.as_bytes().to_vec()),
                Some(Event::Ack | Event::Nak) => handshakes += 1,
                Some(Event::Long { .. }) => panic!("a full-size framer holds every telegram"),
                None => break,
            }
        }
    };
    for c in chunks {
        take(framer, c);
    }
    while framer.abandon() {
        take(framer, &[]);
    }
    (telegrams, handshakes)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn framer_finds_every_intact_telegram(
        pieces in prop::collection::vec(piece(), 1..12),
        splits in prop::collection::vec(any::<prop::sample::Index>(), 0..8),
        handshake in any::<bool>(),
    ) {
        let mut stream = Vec::new();
        // (start, telegram) of every telegram put on the line, truncated or not.
        let mut sent = Vec::new();
        for p in &pieces {
            match p {
                Piece::Telegram(c, d) => {
                    let t = telegram_bytes(*c, d);
                    sent.push((stream.len(), t.clone()));
                    stream.extend(&t);
                }
                Piece::Truncated(c, d, cut) => {
                    let t = telegram_bytes(*c, d);
                    sent.push((stream.len(), t.clone()));
                    stream.extend(&t[..(*cut).min(t.len() - 1)]);
                }
                Piece::Garbage(g) => stream.extend(g),
                Piece::Handshake(ack) => stream.push(if *ack { ACK } else { NAK }),
            }
        }
        // The intact ones: complete on the line. A truncated telegram can be
        // complete after all when the bytes after it happen to be its
        // missing tail (e.g. its last CRC byte is 02, the next STX); it then
        // swallows the start of the next one.
        let mut intact: Vec<Vec<u8>> = Vec::new();
        let mut end = 0;
        for (start, t) in sent {
            if start >= end && stream.get(start..start + t.len()) == Some(&t[..]) {
                end = start + t.len();
                intact.push(t);
            }
        }
        let mut cuts: Vec<usize> = splits.iter().map(|i| i.index(stream.len() + 1)).collect();
        cuts.push(0);
        cuts.push(stream.len());
        cuts.sort_unstable();
        let chunks: Vec<&[u8]> = cuts.windows(2).map(|w| &stream[w[0]..w[1]]).collect();
        let mut framer = Framer::new(
            Direction::SensorToHost,
            if handshake { Handshake::Expected } else { Handshake::Ignored },
        );
        let (got, handshakes) = run_framer(&mut framer, &chunks);
        prop_assert_eq!(&got, &intact, "the intact telegrams, in order, and nothing else");
        let s = *framer.stats();
        let delivered: usize = got.iter().map(Vec::len).sum();
        prop_assert_eq!(
            delivered + handshakes + s.bytes_skipped as usize + framer.buffered(),
            stream.len()
        );
        prop_assert_eq!(framer.buffered(), 0);
        prop_assert_eq!(s.resyncs, s.crc_errors + s.oversize + s.bad_headers + s.abandoned);
    }

    #[test]
    fn requests_round_trip(
        kind in 0u8..12,
        password in any::<[u8; 8]>(),
        baud in 0usize..4,
        angle in any::<u16>(),
        resolution in any::<u16>(),
        config in any::<[u8; 34]>(),
        command in any::<u8>(),
        data in prop::collection::vec(any::<u8>(), 0..64),
    ) {
        let request = match kind {
            0 => Request::InstallationMode { password },
            1 => Request::Continuous,
            2 => Request::OnRequest,
            3 => Request::SetBaud(Baud::ALL[baud]),
            4 => Request::OneScan,
            5 => Request::Status,
            6 => Request::SensorType,
            7 => Request::SetVariant(FovRes { fov_deg: angle, res_centideg: resolution }),
            8 => Request::ReadConfig,
            9 => Request::WriteConfig(Config::from_bytes(config)),
            10 => Request::Reset,
            _ => Request::from_parts(command, &data),
        };
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        let n = request.emit(0, &mut buf).unwrap();
        prop_assert_eq!(n, request.buffer_len());
        let t = Telegram::new_checked(&buf[..n], Direction::HostToSensor).unwrap();
        prop_assert_eq!(Request::parse(&t).unwrap(), request);
        // And through the framer.
        let mut framer = Framer::new(Direction::HostToSensor, Handshake::Ignored);
        let (got, _) = run_framer(&mut framer, &[&buf[..n]]);
        prop_assert_eq!(got, vec![buf[..n].to_vec()]);
    }

    #[test]
    fn replies_round_trip(
        kind in 0u8..10,
        byte in any::<u8>(),
        flag in any::<bool>(),
        angle in any::<u16>(),
        resolution in any::<u16>(),
        block in prop::collection::vec(any::<u8>(), 152),
        config in any::<[u8; 34]>(),
        power_on in any::<[u8; 21]>(),
        text in prop::collection::vec(any::<u8>(), 0..40),
        status in any::<u8>(),
    ) {
        let reply = match kind {
            0 => Reply::ModeChanged(ModeResult::from_byte(byte)),
            1 => Reply::Status(StatusBlock::from_slice(&block).unwrap()),
            2 => Reply::SensorType(&text),
            3 => Reply::Variant(VariantReply { accepted: flag, angle_deg: angle, resolution_centideg: resolution }),
            4 => Reply::Config(Config::from_bytes(config)),
            5 => Reply::ConfigWritten { accepted: flag, config: Config::from_bytes(config) },
            6 => Reply::PowerOn(power_on),
            7 => Reply::ResetAck,
            8 => Reply::UnknownCommand,
            _ => Reply::ModeChanged(ModeResult::Ok),
        };
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        let n = reply.emit(byte & 0x7F, SensorStatus(status), &mut buf).unwrap();
        prop_assert_eq!(n, reply.buffer_len());
        let t = Telegram::new_checked(&buf[..n], Direction::SensorToHost).unwrap();
        prop_assert_eq!(t.status(), Some(status));
        prop_assert_eq!(t.sensor_address(), byte & 0x7F);
        prop_assert_eq!(Reply::parse(&t).unwrap(), reply);
    }

    #[test]
    fn b0_decodes_to_its_words(
        variant in (0usize..5).prop_map(|i| Variant::ALL[i]),
        units in prop_oneof![Just(Unit::Centimetre), Just(Unit::Millimetre), Just(Unit::Decimetre)],
        bits in prop_oneof![Just(RangeBits::Bits13), Just(RangeBits::Bits14), Just(RangeBits::Bits15)],
        words in prop::collection::vec(
            prop_oneof![
                4 => any::<u16>(),
                2 => 8183u16..=8191,
                1 => Just(0u16),
                1 => (0u16..=8).prop_map(|o| 0x7FFF - o),
                1 => (0u16..=8).prop_map(|o| 0x3FFF - o),
            ],
            401,
        ),
        flags in 0u16..16,
    ) {
        let n = variant.beams();
        let mut v = MeasuredValues::from_raw(&words[..n], units, 0x10).unwrap();
        v.set_scan_flags(flags << 10);
        let mut buf = [0u8; MAX_TELEGRAM_LEN];
        let len = v.emit(0, &mut buf).unwrap();
        prop_assert_eq!(len, 6 + 2 + 2 * n + 2);
        let mut framer = Framer::default();
        let (got, _) = run_framer(&mut framer, &[&buf[..len]]);
        prop_assert_eq!(got.len(), 1);
        let t = Telegram::new_checked(&got[0][..], Direction::SensorToHost).unwrap();
        let view = MeasuredView::parse(&t).unwrap();
        prop_assert_eq!(view.scan_flags(), (flags << 10) & 0x3C00);
        let frame = view.to_frame(bits).unwrap();
        prop_assert_eq!(frame.len(), n);
        prop_assert_eq!(frame.geometry(), variant.geometry());
        for (j, &w) in words[..n].iter().enumerate() {
            match bits.decode(w) {
                Ok(r) => {
                    prop_assert_eq!(frame.beams()[j], Beam::Valid);
                    prop_assert_eq!(frame.ranges()[j], f32::from(r) / units.per_metre());
                }
                Err(why) => {
                    prop_assert_eq!(frame.beams()[j], Beam::Invalid(why));
                    prop_assert_eq!(frame.ranges()[j], 0.0);
                }
            }
        }
        let back = MeasuredValues::from_frame(&frame, units, bits, 0x10);
        let masked: Vec<u16> = words[..n].iter().map(|&w| bits.range(w)).collect();
        prop_assert_eq!(back.values(), &masked[..]);
    }

    #[test]
    fn features_round_trip(
        counter in any::<u32>(),
        beams in any::<u16>(),
        segments in prop::collection::vec((any::<u16>(), any::<u16>()), 0..=64),
        edges in prop::collection::btree_set(0u16..401, 0..=401),
        lines in prop::collection::vec((any::<[u32; 10]>(), any::<[u16; 3]>()), 0..=64),
        corners in prop::collection::vec((any::<[u32; 6]>(), any::<[u8; 3]>()), 0..=63),
        stats in any::<[u16; 12]>(),
        params in any::<(u16, u32, u32, u32)>(),
    ) {
        use lms_core::Corner;
        use lms_core::Line;
        use lms_core::maths::Sym2;
        use lms_core::Segment;
        let mut f = lms_core::Features::default();
        for (first, last) in segments {
            f.push_segment(Segment { first, last }).unwrap();
        }
        for e in edges {
            f.push_edge(e).unwrap();
        }
        for (v, i) in lines {
            let v = v.map(f32::from_bits);
            f.push_line(Line {
                alpha: v[0], r: v[1], cov: Sym2 { a: v[2], b: v[3], c: v[4] }, chi2: v[5],
                endpoints: [[v[6], v[7]], [v[8], v[9]]], first: i[0], last: i[1], points: i[2],
            }).unwrap();
        }
        for (v, b) in corners {
            let v = v.map(f32::from_bits);
            f.push_corner(Corner {
                x: v[0], y: v[1], cov: Sym2 { a: v[2], b: v[3], c: v[4] }, angle_deg: v[5],
                well_conditioned: b[0] & 1 == 1, line_a: b[1], line_b: b[2],
            }).unwrap();
        }
        *f.stats_mut() = Stats::from_fields(&stats);
        let echoed = EchoedParams {
            iterations: params.0,
            sigma: f32::from_bits(params.1),
            q: f32::from_bits(params.2),
            tau: f32::from_bits(params.3),
        };
        let mut wire = Vec::new();
        emit_features(counter, beams, &echoed, &f, 0, |t| {
            wire.extend_from_slice(t);
            Ok::<(), ()>(())
        }).unwrap();
        let mut framer = Framer::default();
        let (telegrams, _) = run_framer(&mut framer, &[&wire]);
        let mut asm = FeatureAssembler::new();
        let mut complete = 0;
        for t in &telegrams {
            let t = Telegram::new_checked(&t[..], Direction::SensorToHost).unwrap();
            if let Assembled::Complete(summary, got) = asm.push(&t).unwrap() {
                complete += 1;
                prop_assert_eq!(summary.scan_counter, counter);
                prop_assert_eq!(summary.beams, beams);
                prop_assert_eq!(summary.params.sigma.to_bits(), echoed.sigma.to_bits());
                prop_assert_eq!(got.segments(), f.segments());
                prop_assert_eq!(got.edges(), f.edges());
                prop_assert_eq!(got.stats(), f.stats());
                let bits = |l: &Line| [l.alpha, l.r, l.cov.a, l.cov.b, l.cov.c, l.chi2,
                    l.endpoints[0][0], l.endpoints[0][1], l.endpoints[1][0], l.endpoints[1][1]]
                    .map(f32::to_bits);
                prop_assert!(got.lines().iter().map(bits).eq(f.lines().iter().map(bits)));
                prop_assert!(got.lines().iter().map(|l| (l.first, l.last, l.points))
                    .eq(f.lines().iter().map(|l| (l.first, l.last, l.points))));
                let cbits = |c: &Corner| ([c.x, c.y, c.cov.a, c.cov.b, c.cov.c, c.angle_deg].map(f32::to_bits),
                    c.well_conditioned, c.line_a, c.line_b);
                prop_assert!(got.corners().iter().map(cbits).eq(f.corners().iter().map(cbits)));
            }
        }
        prop_assert_eq!(complete, 1);
    }
}
