//! The framer on recorded streams: every chunking gives the same telegrams
//! and counters; garbage, corrupted, truncated and false telegrams are
//! skipped and counted and what follows is still found.

use lms_core::telegram::{
    Direction, Event, Framer, FramerStats, Handshake, MeasuredValues, Reply, Request, SensorStatus,
    Telegram, ACK, NAK,
};
use lms_core::test_support::Rng;
use lms_core::Unit;

/// What the framer handed out, owned.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Seen {
    Telegram(Vec<u8>),
    Ack,
    Nak,
}

/// Feed one chunk, draining every event (including those found in the
/// buffer after the input ran out).
fn feed_chunk(framer: &mut Framer, chunk: &[u8], seen: &mut Vec<Seen>) {
    let mut input = chunk;
    loop {
        let fed = framer.feed(input);
        input = fed.remaining;
        match fed.event {
            Some(Event::Telegram(t)) => {
                // What the framer delivers always passes the checked constructor.
                let checked = Telegram::new_checked(t.as_bytes(), t.direction()).unwrap();
                assert_eq!(checked.as_bytes(), t.as_bytes());
                seen.push(Seen::Telegram(t.as_bytes().to_vec()));
            }
            Some(Event::Ack) => seen.push(Seen::Ack),
            Some(Event::Nak) => seen.push(Seen::Nak),
            Some(Event::Long { .. }) => panic!("a full-size framer holds every telegram"),
            None => {
                assert!(input.is_empty(), "no event but input left");
                break;
            }
        }
    }
}

/// Feed `stream` split at `cuts` (sorted offsets); return events and stats,
/// after checking that every byte is accounted for.
fn run(
    direction: Direction,
    handshake: Handshake,
    stream: &[u8],
    cuts: &[usize],
    idle: bool,
) -> (Vec<Seen>, FramerStats, usize) {
    let mut framer = Framer::new(direction, handshake);
    let mut seen = Vec::new();
    let mut start = 0;
    for &cut in cuts.iter().chain(std::iter::once(&stream.len())) {
        feed_chunk(&mut framer, &stream[start..cut], &mut seen);
        start = cut;
    }
    // End of the recording: the line goes idle, give up whatever is being
    // collected until nothing is left.
    if idle {
        while framer.abandon() {
            feed_chunk(&mut framer, &[], &mut seen);
        }
        assert_eq!(framer.buffered(), 0);
    }
    let stats = *framer.stats();
    let delivered: usize = seen
        .iter()
        .map(|s| match s {
            Seen::Telegram(b) => b.len(),
            Seen::Ack | Seen::Nak => 1,
        })
        .sum();
    assert_eq!(
        delivered + stats.bytes_skipped as usize + framer.buffered(),
        stream.len(),
        "bytes not accounted for"
    );
    assert_eq!(
        stats.resyncs,
        stats.crc_errors + stats.oversize + stats.bad_headers + stats.abandoned
    );
    (seen, stats, framer.buffered())
}

/// Every chunk size 1..=len, then random split points: all runs must agree.
fn all_chunkings(
    direction: Direction,
    handshake: Handshake,
    stream: &[u8],
) -> (Vec<Seen>, FramerStats, usize) {
    let whole = run(direction, handshake, stream, &[], false);
    for size in 1..=stream.len() {
        let cuts: Vec<usize> = (size..stream.len()).step_by(size).collect();
        assert_eq!(
            run(direction, handshake, stream, &cuts, false),
            whole,
            "chunk size {size}"
        );
    }
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for round in 0..300 {
        let k = rng.below(40);
        let mut cuts: Vec<usize> = (0..k).map(|_| rng.below(stream.len() + 1)).collect();
        cuts.sort_unstable();
        assert_eq!(
            run(direction, handshake, stream, &cuts, false),
            whole,
            "random round {round}"
        );
    }
    whole
}

fn emit_reply(reply: Reply<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; reply.buffer_len()];
    reply.emit(0, SensorStatus(0x10), &mut buf).unwrap();
    buf
}

fn emit_request(request: Request<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; request.buffer_len()];
    request.emit(0, &mut buf).unwrap();
    buf
}

/// A 361-value B0 whose value bytes contain no STX/ACK/NAK (values
/// 0x07x1, low byte ≡ 1 mod 8), so a re-scan through it is predictable.
fn b0(units: Unit) -> Vec<u8> {
    let raw: Vec<u16> = (0..361).map(|j| 0x0701 + (j % 32) * 8).collect();
    let v = MeasuredValues::from_raw(&raw, units, 0x10).unwrap();
    let mut buf = vec![0u8; v.buffer_len()];
    v.emit(0, &mut buf).unwrap();
    buf
}

const A0: [u8; 9] = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
const BB: [u8; 13] = [
    0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D,
];
const R92: [u8; 8] = [0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33];

#[test]
fn telegram_framer_clean_host_stream() {
    let requests = [
        Request::OnRequest,
        Request::SensorType,
        Request::Status,
        Request::ReadConfig,
        Request::SetBaud(lms_core::telegram::Baud::B500000),
        Request::set_variant(lms_core::Variant::Fov180Res50),
        Request::Continuous,
        Request::Unknown {
            command: 0x02,
            data: &[0x02, 0x02, 0x80],
        },
    ];
    let telegrams: Vec<Vec<u8>> = requests.iter().map(|r| emit_request(*r)).collect();
    let stream = telegrams.concat();
    let (seen, stats, buffered) =
        all_chunkings(Direction::HostToSensor, Handshake::Ignored, &stream);
    let expected: Vec<Seen> = telegrams.iter().cloned().map(Seen::Telegram).collect();
    assert_eq!(seen, expected);
    assert_eq!(buffered, 0);
    assert_eq!(
        stats,
        FramerStats {
            telegrams: 8,
            ..FramerStats::default()
        }
    );
    // And they parse back to the requests.
    for (bytes, request) in telegrams.iter().zip(requests) {
        let t = Telegram::new_checked(&bytes[..], Direction::HostToSensor).unwrap();
        assert_eq!(Request::parse(&t), Ok(request));
    }
}

#[test]
fn telegram_framer_clean_sensor_stream() {
    // A start-up exchange as the host sees it, then two streamed scans.
    let b1 = emit_reply(Reply::Status(lms_core::telegram::StatusBlock::default()));
    let cm = b0(Unit::Centimetre);
    let mm = b0(Unit::Millimetre);
    let parts: Vec<(bool, Vec<u8>)> = vec![
        (true, A0.to_vec()),
        (true, b1.clone()),
        (true, BB.to_vec()),
        (false, cm.clone()),
        (false, mm.clone()),
        (true, R92.to_vec()),
    ];
    let mut stream = Vec::new();
    let mut expected = Vec::new();
    for (ack, t) in &parts {
        if *ack {
            stream.push(ACK);
            expected.push(Seen::Ack);
        }
        stream.extend_from_slice(t);
        expected.push(Seen::Telegram(t.clone()));
    }
    let (seen, stats, buffered) =
        all_chunkings(Direction::SensorToHost, Handshake::Expected, &stream);
    assert_eq!(seen, expected);
    assert_eq!(buffered, 0);
    assert_eq!(
        stats,
        FramerStats {
            telegrams: 6,
            acks: 4,
            ..FramerStats::default()
        }
    );
}

#[test]
fn telegram_framer_garbage_corruption_truncation() {
    let mut bb_bad = BB;
    bb_bad[6] = 0xB5; // one data byte changed: CRC no longer matches
    let cm = b0(Unit::Centimetre);
    let mm = b0(Unit::Millimetre);

    let mut stream = Vec::new();
    // Garbage, then an oversize header `02 80 FF FF`.
    stream.extend_from_slice(&[0xFF, 0x00, 0x55, 0x02, 0x80, 0xFF, 0xFF]);
    stream.push(ACK);
    stream.extend_from_slice(&A0);
    // Garbage with a header whose address lacks the 0x80 bit.
    stream.extend_from_slice(&[0x80, 0x03, 0x02, 0x00, 0x07, 0x00]);
    // A corrupted BB.
    stream.extend_from_slice(&bb_bad);
    stream.push(NAK);
    stream.push(ACK);
    stream.extend_from_slice(&R92);
    // A B0 cut after 100 bytes, then a complete one.
    stream.extend_from_slice(&cm[..100]);
    stream.extend_from_slice(&mm);
    // The start of a telegram that has not arrived yet.
    stream.extend_from_slice(&[0x02, 0x80]);

    let (seen, stats, buffered) =
        all_chunkings(Direction::SensorToHost, Handshake::Expected, &stream);
    assert_eq!(
        seen,
        vec![
            Seen::Ack,
            Seen::Telegram(A0.to_vec()),
            Seen::Nak,
            Seen::Ack,
            Seen::Telegram(R92.to_vec()),
            Seen::Telegram(mm.clone()),
        ]
    );
    assert_eq!(buffered, 2);
    // Skipped: 7 (garbage + oversize header) + 6 (garbage + bad header)
    // + 13 (corrupted BB) + 100 (the truncated B0).
    // CRC errors: the BB, the truncated B0 (which swallowed 632 bytes of the
    // next one), and the false candidate `02 B0 69 01` (LEN 361) found at
    // its LEN field `D6 02` during the re-scan.
    assert_eq!(
        stats,
        FramerStats {
            telegrams: 3,
            acks: 2,
            naks: 1,
            crc_errors: 3,
            oversize: 1,
            bad_headers: 1,
            abandoned: 0,
            resyncs: 5,
            bytes_skipped: 126,
        }
    );
}

#[test]
fn telegram_framer_false_stx_inside_corrupted_scan() {
    // A B0 full of `02 80 10 00` (plausible headers, LEN 16) whose CRC is
    // broken: every one is a false start, the telegrams behind are found.
    let raw: Vec<u16> = (0..361)
        .map(|j| if j % 2 == 0 { 0x8002 } else { 0x0010 })
        .collect();
    let v = MeasuredValues::from_raw(&raw, Unit::Centimetre, 0x10).unwrap();
    let mut bad = vec![0u8; v.buffer_len()];
    v.emit(0, &mut bad).unwrap();
    let last = bad.len() - 1;
    bad[last] ^= 0xFF;
    let good = b0(Unit::Millimetre);
    let mut stream = Vec::new();
    stream.extend_from_slice(&bad);
    stream.extend_from_slice(&A0);
    stream.extend_from_slice(&good);
    stream.push(ACK);
    stream.extend_from_slice(&R92);
    let (seen, stats, buffered) =
        all_chunkings(Direction::SensorToHost, Handshake::Expected, &stream);
    assert_eq!(
        seen,
        vec![
            Seen::Telegram(A0.to_vec()),
            Seen::Telegram(good),
            Seen::Ack,
            Seen::Telegram(R92.to_vec()),
        ]
    );
    assert_eq!(buffered, 0);
    assert_eq!(stats.telegrams, 3);
    assert_eq!(stats.bytes_skipped as usize, bad.len());
    // The corrupted scan itself, the false `02 B0 69 01` at its LEN field,
    // and one false start per embedded `02 80` (the last one, `02 80 10`
    // + CRC byte, may be oversize instead of a CRC error).
    assert_eq!(stats.crc_errors + stats.oversize, 1 + 1 + 181);
    assert_eq!(stats.bad_headers, 0);
}

#[test]
fn telegram_framer_random_damage_never_panics() {
    // Random edits of a recorded stream, fed in random chunks: no panic,
    // every byte accounted for (checked in `run`), every telegram valid,
    // and an undamaged telegram after the last edit is always found.
    let mut clean = Vec::new();
    clean.push(ACK);
    clean.extend_from_slice(&A0);
    clean.extend_from_slice(&b0(Unit::Centimetre));
    clean.extend_from_slice(&BB);
    let tail = R92;
    let mut rng = Rng(42);
    for round in 0..300 {
        let mut s = clean.clone();
        for _ in 0..1 + rng.below(6) {
            let at = rng.below(s.len());
            match rng.below(4) {
                0 => s[at] ^= 1 << rng.below(8),
                1 => {
                    s.remove(at);
                }
                2 => s.insert(at, rng.next_u64() as u8),
                _ => s.insert(at, 0x02),
            }
        }
        s.extend_from_slice(&tail);
        let k = rng.below(20);
        let mut cuts: Vec<usize> = (0..k).map(|_| rng.below(s.len() + 1)).collect();
        cuts.sort_unstable();
        for handshake in [Handshake::Ignored, Handshake::Expected] {
            for direction in [Direction::SensorToHost, Direction::HostToSensor] {
                let (seen, _, _) = run(direction, handshake, &s, &cuts, true);
                if direction == Direction::SensorToHost {
                    assert_eq!(
                        seen.last(),
                        Some(&Seen::Telegram(tail.to_vec())),
                        "round {round}"
                    );
                }
            }
        }
    }
    // Pure noise.
    let noise: Vec<u8> = (0..5000).map(|_| rng.next_u64() as u8).collect();
    for direction in [Direction::SensorToHost, Direction::HostToSensor] {
        run(
            direction,
            Handshake::Expected,
            &noise,
            &[17, 900, 4000],
            true,
        );
    }
}

#[test]
fn telegram_framer_abandon_on_idle_line() {
    // Noise `02 80 FF 02` looks like a header with LEN 767: the A0 reply
    // behind it is held until the host's timeout gives the candidate up.
    let mut stream = vec![0x02, 0x80, 0xFF, 0x02, ACK];
    stream.extend_from_slice(&A0);
    let mut framer = Framer::new(Direction::SensorToHost, Handshake::Expected);
    let mut seen = Vec::new();
    feed_chunk(&mut framer, &stream, &mut seen);
    assert!(seen.is_empty());
    assert_eq!(framer.buffered(), 14);
    assert!(framer.abandon());
    feed_chunk(&mut framer, &[], &mut seen);
    assert_eq!(seen, vec![Seen::Ack, Seen::Telegram(A0.to_vec())]);
    assert_eq!(framer.buffered(), 0);
    assert!(!framer.abandon());
    assert_eq!(
        *framer.stats(),
        FramerStats {
            telegrams: 1,
            acks: 1,
            // After the abandoned STX, `02 06 02 80` is the next false
            // header (LEN 0x8002).
            oversize: 1,
            abandoned: 1,
            resyncs: 2,
            bytes_skipped: 4,
            ..FramerStats::default()
        }
    );
}

#[test]
fn telegram_framer_sensor_side_nak_pattern() {
    // A simulator reading requests: a status request with a bad CRC, then
    // the host's resend. It answers NAK once, then ACK + reply.
    let mut stream = vec![0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x13];
    stream.extend_from_slice(&[0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12]);
    for chunk_len in 1..=stream.len() {
        let mut framer = Framer::new(Direction::HostToSensor, Handshake::Ignored);
        let mut answers = Vec::new();
        for chunk in stream.chunks(chunk_len) {
            let mut input = chunk;
            loop {
                let fed = framer.feed(input);
                input = fed.remaining;
                if fed.crc_errors > 0 {
                    answers.push(NAK);
                }
                match fed.event {
                    Some(Event::Telegram(t)) => {
                        assert_eq!(Request::parse(&t), Ok(Request::Status));
                        answers.push(ACK);
                    }
                    Some(_) => unreachable!("no handshake events host → sensor"),
                    None => break,
                }
            }
        }
        assert_eq!(answers, vec![NAK, ACK], "chunks of {chunk_len}");
        assert_eq!(framer.stats().bytes_skipped, 7);
    }
}
