use super::*;
use crate::telegram::{crc16, Telegram};
use std::vec::Vec;

/// Value `1000 + j` on beam `j`; counts the scans drawn.
#[derive(Default)]
struct Ramp {
    drawn: usize,
}

impl ScanSource for Ramp {
    fn next_scan(&mut self, _: Variant, _: Unit, out: &mut [u16]) -> usize {
        self.drawn += 1;
        for (j, v) in out.iter_mut().enumerate() {
            *v = 1000 + j as u16;
        }
        out.len()
    }
}

const STATUS: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12];
const ONE_SCAN: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x30, 0x01, 0x31, 0x18];
const START: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08];
const STOP: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x25, 0x35, 0x08];
const BAUD_9600: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x42, 0x52, 0x08];
const BAUD_38400: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x40, 0x50, 0x08];
const BAUD_500K: [u8; 8] = [0x02, 0x00, 0x02, 0x00, 0x20, 0x48, 0x58, 0x08];
const INSTALL: [u8; 16] = [
    0x02, 0x00, 0x0A, 0x00, 0x20, 0x00, 0x53, 0x49, 0x43, 0x4B, 0x5F, 0x4C, 0x4D, 0x53, 0xBE, 0xC5,
];
const VARIANT_180_050: [u8; 11] = [
    0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00, 0x3B, 0x1F,
];
const VARIANT_100_025: [u8; 11] = [
    0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xE7, 0x72,
];
const READ_CONFIG: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x74, 0x50, 0x12];
const SENSOR_TYPE: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x3A, 0x1E, 0x12];
const RESET: [u8; 7] = [0x02, 0x00, 0x01, 0x00, 0x10, 0x34, 0x12];

const A0_OK: [u8; 9] = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
const BB_180_050: [u8; 13] = [
    0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10, 0x03, 0x9D,
];
const REPLY_92: [u8; 8] = [0x02, 0x80, 0x02, 0x00, 0x92, 0x10, 0x7F, 0x33];

/// ACK followed by `telegram`.
fn acked(telegram: &[u8]) -> Vec<u8> {
    let mut v = std::vec![ACK];
    v.extend_from_slice(telegram);
    v
}

/// A host telegram with a correct CRC (built here from §1, not with the
/// crate's emitter).
fn request(payload: &[u8]) -> Vec<u8> {
    let len = payload.len() as u16;
    let mut v = std::vec![0x02, 0x00, len as u8, (len >> 8) as u8];
    v.extend_from_slice(payload);
    let crc = crc16(&v);
    v.extend_from_slice(&crc.to_le_bytes());
    v
}

/// A sensor telegram with a correct CRC.
fn sensor(payload: &[u8]) -> Vec<u8> {
    let mut v = request(payload);
    v[1] = 0x80;
    let n = v.len() - 2;
    let crc = crc16(&v[..n]);
    v[n..].copy_from_slice(&crc.to_le_bytes());
    v
}

fn lms() -> Emulator<Ramp> {
    let mut e = Emulator::new(Ramp::default(), Settings::default(), 0);
    // Let the power-on telegram go out.
    let got = drain(&mut e, 1_000_000);
    assert_eq!(got.len(), 29);
    while e.next_event().is_some() {}
    e
}

/// Everything sent up to `until_us`.
fn drain<S: ScanSource, const TX: usize>(e: &mut Emulator<S, TX>, until_us: u64) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf = [0u8; 256];
    loop {
        let rate = e.baud();
        let n = e.transmit(until_us, &mut buf);
        if n == 0 && e.baud() == rate {
            break;
        }
        out.extend_from_slice(&buf[..n]);
    }
    out
}

fn events<S: ScanSource>(e: &mut Emulator<S>) -> Vec<Event> {
    core::iter::from_fn(|| e.next_event()).collect()
}

/// Split a sensor byte stream into ACK/NAK bytes and checked telegrams.
fn split(bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == ACK || bytes[i] == NAK {
            parts.push(std::vec![bytes[i]]);
            i += 1;
            continue;
        }
        let t = match Telegram::new_checked(&bytes[i..], Direction::SensorToHost) {
            Ok(t) => t,
            // A telegram still on the line at the end.
            Err(crate::telegram::TelegramError::Truncated { .. }) => break,
            Err(e) => panic!("no telegram at {i}: {e}"),
        };
        parts.push(t.as_bytes().to_vec());
        i += t.total_len();
    }
    parts
}

#[test]
fn emulator_power_on_telegram() {
    let mut e = Emulator::new(Ramp::default(), Settings::default(), 5_000);
    assert_eq!(e.baud(), Baud::B9600);
    assert_eq!(e.operating_mode().code(), 0x25);
    // 29 bytes × 10 bits at 9600 Bd = 30208.3 µs: not all out before.
    let mut got = drain(&mut e, 5_000 + 30_208);
    assert_eq!(got.len(), 28);
    got.extend(drain(&mut e, 5_000 + 30_209));
    let expected = sensor(&[&[0x90][..], &POWER_ON_DATA[..], &[0x10][..]].concat());
    assert_eq!(&expected[..5], &[0x02, 0x80, 0x17, 0x00, 0x90]);
    assert_eq!(got, expected);
    assert_eq!(events(&mut e), [Event::PowerOnSent]);
    assert_eq!(e.next_wakeup_us(), None);
}

#[test]
fn emulator_a0_bb_92_byte_exact() {
    let mut e = lms();
    e.receive(2_000_000, &STOP);
    assert_eq!(drain(&mut e, 3_000_000), acked(&A0_OK));
    e.receive(3_000_000, &VARIANT_180_050);
    assert_eq!(drain(&mut e, 4_000_000), acked(&BB_180_050));
    assert_eq!(e.variant(), Variant::Fov180Res50);
    // Unknown command `55`, and `31` with a data byte (malformed).
    e.receive(4_000_000, &request(&[0x55]));
    e.receive(4_000_000, &request(&[0x31, 0x00]));
    let mut expected = acked(&REPLY_92);
    expected.extend(acked(&REPLY_92));
    assert_eq!(drain(&mut e, 5_000_000), expected);
    assert_eq!(
        events(&mut e)[2..],
        [
            Event::Request(Handled::Unknown {
                command: 0x55,
                data_len: 0
            }),
            Event::Request(Handled::Unknown {
                command: 0x31,
                data_len: 1
            }),
        ]
    );
}

#[test]
fn emulator_nak_on_bad_checksum_then_resend() {
    let mut e = lms();
    let mut bad = STATUS;
    bad[6] ^= 0x01;
    e.receive(2_000_000, &bad);
    assert_eq!(drain(&mut e, 3_000_000), [NAK]);
    assert_eq!(events(&mut e), [Event::BadChecksum]);
    e.receive(3_000_000, &STATUS);
    let parts = split(&drain(&mut e, 4_000_000));
    assert_eq!(parts.len(), 2);
    assert_eq!(parts[1][4], 0xB1);
}

#[test]
fn emulator_status_in_any_chunks_reflects_state() {
    let mut e = lms();
    // Byte by byte, with garbage before.
    e.receive(2_000_000, &[0xFF, 0x00]);
    for (k, b) in STATUS.iter().enumerate() {
        e.receive(2_000_000 + k as u64, core::slice::from_ref(b));
    }
    let parts = split(&drain(&mut e, 3_000_000));
    assert_eq!(parts[0], [ACK]);
    let b1 = &parts[1];
    assert_eq!(&b1[..5], &[0x02, 0x80, 0x9A, 0x00, 0xB1]); // LEN 154
    let p = &b1[4..b1.len() - 2]; // payload: B1 … status
    assert_eq!(p[8], 0x25);
    assert_eq!(&p[107..=108], &[180, 0]);
    assert_eq!(&p[109..=110], &[100, 0]);
    assert_eq!(&p[116..=117], &[103, 0]); // 10⁶/9600 − 1
    assert_eq!(p[120], 0);
    assert_eq!(p[122], 0); // cm
    assert_eq!(p[153], 0x10);

    // After installation mode, mm, 100°/0.25° and 500 kBd.
    e.receive(3_000_000, &INSTALL);
    e.receive(3_000_000, &READ_CONFIG);
    let parts = split(&drain(&mut e, 4_000_000));
    assert_eq!(parts[1], A0_OK);
    let f4 = &parts[3];
    assert_eq!(&f4[..5], &[0x02, 0x80, 0x24, 0x00, 0xF4]); // LEN 36
    let mut config = f4[5..39].to_vec();
    config[6] = 1;
    e.receive(4_000_000, &request(&[&[0x77][..], &config].concat()));
    e.receive(4_000_000, &VARIANT_100_025);
    e.receive(4_000_000, &BAUD_500K);
    let parts = split(&drain(&mut e, 5_000_000));
    assert_eq!(&parts[1][..7], &[0x02, 0x80, 0x25, 0x00, 0xF7, 0x01, 0x00]);
    assert_eq!(parts[1][5 + 1 + 6], 1);
    assert_eq!(
        parts[3],
        sensor(&[0xBB, 0x01, 0x64, 0x00, 0x19, 0x00, 0x10])
    );
    assert_eq!(parts[5], A0_OK);
    assert_eq!(e.baud(), Baud::B500000);
    e.receive(5_000_000, &STATUS);
    let parts = split(&drain(&mut e, 6_000_000));
    let p = &parts[1][4..];
    assert_eq!(p[8], 0x00);
    assert_eq!(&p[107..=108], &[100, 0]);
    assert_eq!(&p[109..=110], &[25, 0]);
    assert_eq!(&p[116..=117], &[1, 0]);
    assert_eq!(p[122], 1);
    assert_eq!(e.units(), Unit::Millimetre);
}

#[test]
fn emulator_installation_password_and_config_write() {
    let mut e = lms();
    let mut config = [0u8; 34];
    config[6] = 1;
    let write = request(&[&[0x77][..], &config].concat());
    // Not in installation mode: refused, configuration kept.
    e.receive(2_000_000, &write);
    let parts = split(&drain(&mut e, 3_000_000));
    assert_eq!(&parts[1][4..6], &[0xF7, 0x00]);
    assert_eq!(parts[1][5 + 1 + 6], 0);
    // Bad password: A0 01, mode kept.
    e.receive(3_000_000, &request(b"\x20\x00SICK_LMX"));
    let parts = split(&drain(&mut e, 4_000_000));
    assert_eq!(parts[1], sensor(&[0xA0, 0x01, 0x10]));
    assert_eq!(e.operating_mode(), OperatingMode::OnRequest);
    // Right password; an undefined units code is refused.
    e.receive(4_000_000, &INSTALL);
    config[6] = 2;
    e.receive(4_000_000, &request(&[&[0x77][..], &config].concat()));
    e.receive(4_000_000, &write);
    let parts = split(&drain(&mut e, 5_000_000));
    assert_eq!(parts[1], A0_OK);
    assert_eq!(&parts[3][4..6], &[0xF7, 0x00]);
    assert_eq!(&parts[5][4..6], &[0xF7, 0x01]);
    assert_eq!(e.units(), Unit::Millimetre);
    // 30 01: ACK and 181 values in mm: count word B5 40.
    e.receive(5_000_000, &ONE_SCAN);
    let parts = split(&drain(&mut e, 6_000_000));
    assert_eq!(parts[0], [ACK]);
    assert_eq!(&parts[1][4..7], &[0xB0, 0xB5, 0x40]);
    assert_eq!(&parts[1][7..9], &1000u16.to_le_bytes());
}

#[test]
fn emulator_variant_refusals_keep_the_variant() {
    let mut e = lms();
    for (angle, res) in [(180u16, 25u16), (90, 50), (100, 10)] {
        let [a0, a1] = angle.to_le_bytes();
        let [r0, r1] = res.to_le_bytes();
        e.receive(2_000_000, &request(&[0x3B, a0, a1, r0, r1]));
        let parts = split(&drain(&mut e, 3_000_000));
        assert_eq!(
            parts[1],
            sensor(&[0xBB, 0x00, 180, 0, 100, 0, 0x10]),
            "{angle}/{res}"
        );
    }
    // A source that cannot do 0.25° refuses 100°/0.25°.
    struct Coarse;
    impl ScanSource for Coarse {
        fn next_scan(&mut self, _: Variant, _: Unit, out: &mut [u16]) -> usize {
            out.len()
        }
        fn supports(&self, v: Variant) -> bool {
            v != Variant::Fov100Res25
        }
    }
    let mut e = Emulator::new(Coarse, Settings::default(), 0);
    drain(&mut e, 1_000_000);
    e.receive(1_000_000, &VARIANT_100_025);
    e.receive(1_000_000, &VARIANT_180_050);
    let parts = split(&drain(&mut e, 2_000_000));
    assert_eq!(parts[1], sensor(&[0xBB, 0x00, 180, 0, 100, 0, 0x10]));
    assert_eq!(parts[3], BB_180_050);
}

#[test]
fn emulator_sensor_type() {
    let mut e = lms();
    e.receive(2_000_000, &SENSOR_TYPE);
    let parts = split(&drain(&mut e, 3_000_000));
    assert_eq!(parts[1], sensor(b"\xBALMS200;30106x;V02.10\x10"));
}

#[test]
fn emulator_baud_switch_after_the_reply() {
    let mut e = lms();
    let t0 = 2_000_000;
    e.receive(t0, &BAUD_38400);
    // ACK + A0 = 10 bytes at 9600 Bd: 10416.7 µs.
    let mut out = [0u8; 64];
    assert_eq!(e.transmit(t0 + 10_416, &mut out), 9);
    assert_eq!(e.baud(), Baud::B9600);
    assert_eq!(e.transmit(t0 + 10_417, &mut out), 1);
    assert_eq!(out[0], A0_OK[8]);
    assert_eq!(e.baud(), Baud::B38400);
    assert_eq!(
        events(&mut e),
        [
            Event::Request(Handled::SetBaud(Baud::B38400)),
            Event::BaudSwitched {
                from: Baud::B9600,
                to: Baud::B38400
            }
        ]
    );
    // The next reply goes at 38400 Bd: 10 bytes in 2604.2 µs.
    let t1 = t0 + 20_000;
    e.receive(t1, &BAUD_9600);
    assert_eq!(e.transmit(t1 + 2_604, &mut out), 9);
    assert_eq!(e.transmit(t1 + 2_605, &mut out), 1);
    assert_eq!(e.baud(), Baud::B9600);
}

#[test]
fn emulator_transmit_stops_at_the_switch() {
    // Two requests at once: the second reply must not be handed out in
    // the same call as the first, since it goes at the new rate.
    let mut e = lms();
    e.receive(2_000_000, &[&BAUD_500K[..], &STATUS[..]].concat());
    let mut out = [0u8; 512];
    assert_eq!(e.transmit(3_000_000, &mut out), 10);
    assert_eq!(e.baud(), Baud::B500000);
    assert_eq!(e.transmit(3_000_000, &mut out), 1 + 160);
}

/// Scans in `bytes` and the count word of the first.
fn scans(bytes: &[u8]) -> (usize, u16) {
    let parts = split(bytes);
    let b0: Vec<_> = parts
        .iter()
        .filter(|p| p.len() > 4 && p[4] == 0xB0)
        .collect();
    let w = b0.first().map_or(0, |p| u16::from_le_bytes([p[5], p[6]]));
    (b0.len(), w)
}

#[test]
fn emulator_stream_paced_by_mirror_and_line() {
    let mut e = lms();
    e.receive(2_000_000, &VARIANT_180_050);
    e.receive(2_000_000, &BAUD_500K);
    drain(&mut e, 2_100_000);
    e.receive(2_100_000, &START);
    // A0 at 500 kBd: 10 bytes, 200 µs; then one scan per 26.67 ms.
    let got = drain(&mut e, 2_100_200);
    assert_eq!(got, acked(&A0_OK));
    assert!(e.streaming());
    let got = drain(&mut e, 3_100_200);
    let (n, w) = scans(&got);
    // 1 s: scans at 0, 26.67, … 986.7 ms = 38 complete by 1 s + 14.6 ms
    // for the last one still on the line.
    assert_eq!(n, 37);
    assert_eq!(w, 0x0169);
    assert_eq!(e.stats().scans_skipped, 0);
    assert_eq!(
        got.len(),
        37 * 732 + (1_000_000 - 37 * 80_000 / 3) as usize / 20
    );

    // At 9600 Bd a 732-byte B0 takes 762.5 ms: the line limits the rate.
    let mut e = lms();
    e.receive(2_000_000, &VARIANT_180_050);
    e.receive(2_000_000, &START);
    let got = drain(&mut e, 12_000_000);
    let (n, _) = scans(&got);
    assert_eq!(n, 13);
    assert!(e.stats().scans_skipped > 300);
}

#[test]
fn emulator_stop_comes_after_the_stream() {
    let mut e = lms();
    e.receive(2_000_000, &VARIANT_180_050);
    e.receive(2_000_000, &BAUD_38400);
    e.receive(2_000_000, &START);
    let mut got = drain(&mut e, 2_500_000);
    // Stop while a B0 (190.6 ms at 38400 Bd) is on the line.
    assert!(!e.line_idle());
    e.receive(2_500_000, &STOP);
    got.extend(drain(&mut e, 4_000_000));
    let parts = split(&got);
    let n = parts.len();
    // ACK BB, ACK A0 (baud), ACK A0 (start), B0 …, ACK A0 (stop).
    assert_eq!(parts[n - 1], A0_OK);
    assert_eq!(parts[n - 2], [ACK]);
    assert_eq!(parts[n - 3][4], 0xB0);
    assert_eq!(parts[n - 3].len(), 732);
    assert!(!e.streaming());
    assert!(drain(&mut e, 10_000_000).is_empty());
    let ev = events(&mut e);
    let stopped = ev.iter().position(|x| *x == Event::StreamStopped).unwrap();
    let req = ev
        .iter()
        .position(|x| *x == Event::Request(Handled::OnRequest))
        .unwrap();
    assert!(stopped < req);
    // The B0 in flight was finished after the request, no other.
    let after: Vec<_> = ev[req..]
        .iter()
        .filter(|x| matches!(x, Event::ScanSent { .. }))
        .collect();
    assert_eq!(after.len(), 1);
}

#[test]
fn emulator_reset_restarts_at_9600() {
    let mut e = lms();
    e.receive(2_000_000, &VARIANT_180_050);
    e.receive(2_000_000, &BAUD_38400);
    e.receive(2_000_000, &START);
    drain(&mut e, 2_050_000);
    e.receive(2_050_000, &RESET);
    let got = drain(&mut e, 2_500_000);
    let tail = &got[got.len() - 9..];
    assert_eq!(tail, acked(&sensor(&[0x91, 0x10])));
    assert!(e.restarting());
    // Input during the restart is ignored.
    e.receive(2_600_000, &STATUS);
    assert!(drain(&mut e, 3_000_000).is_empty());
    assert_eq!(e.baud(), Baud::B38400);
    // About 1 s after the 91: back at 9600 Bd, default state, and 90. The
    // call that powers on returns before the 90's first byte, so that the
    // caller sends it at the rate it reads next, 9600 Bd (independent
    // client's reset test saw the first bytes go at the old rate).
    let mut buf = [0u8; 256];
    assert_eq!(e.transmit(4_000_000, &mut buf), 0);
    assert_eq!(e.baud(), Baud::B9600);
    let got = drain(&mut e, 4_000_000);
    assert_eq!(got.len(), 29);
    assert_eq!(got[4], 0x90);
    assert_eq!(e.baud(), Baud::B9600);
    assert_eq!(e.variant(), Variant::Fov180Res100);
    assert_eq!(e.operating_mode(), OperatingMode::OnRequest);
    assert!(!e.streaming() && !e.restarting());
    let ev = events(&mut e);
    assert!(ev.contains(&Event::Restarting));
    assert!(ev.contains(&Event::BaudSwitched {
        from: Baud::B38400,
        to: Baud::B9600
    }));
    assert_eq!(ev.last(), Some(&Event::PowerOnSent));
}

#[test]
fn emulator_ignores_requests_after_a_reset_in_the_same_burst() {
    // Found by the `emulator` fuzz target: a second `10` behind the first
    // was answered too, and the restart cut that second `91` short.
    let mut e = lms();
    drain(&mut e, 2_000_000);
    let burst: Vec<u8> = [RESET.as_slice(), &RESET, &STATUS].concat();
    e.receive(2_000_000, &burst);
    let got = drain(&mut e, 2_500_000);
    assert_eq!(got, acked(&sensor(&[0x91, 0x10])));
    assert_eq!(e.stats().ignored_bytes, (RESET.len() + STATUS.len()) as u32);
    // Much later, in one read: the 90, nothing cut, nothing more.
    let got = drain(&mut e, 60_000_000);
    assert_eq!(got.len(), 29);
    assert_eq!(got[4], 0x90);
}

#[test]
fn emulator_false_stx_given_up_after_idle() {
    let mut e = lms();
    // `02 00 FF 01`: a plausible header announcing 511 bytes, then a
    // real request that it hides until the line has been idle.
    e.receive(2_000_000, &[0x02, 0x00, 0xFF, 0x01]);
    e.receive(2_000_001, &STATUS);
    assert!(drain(&mut e, 2_040_000).is_empty());
    assert_eq!(e.next_wakeup_us(), Some(2_000_001 + RX_IDLE_TIMEOUT_US));
    let parts = split(&drain(&mut e, 2_300_000));
    assert_eq!(parts[0], [ACK]);
    assert_eq!(parts[1][4], 0xB1);
    assert!(e.stats().abandoned >= 1);
}

#[test]
fn emulator_over_long_requests_are_answered_counted_and_resynchronised() {
    // Longer than the request buffer (REQUEST_CAPACITY): a `77` with 60
    // data bytes (malformed: ACK, 92) and an unknown 200-byte command.
    let mut e = lms();
    let long_77 = request(&[&[0x77][..], &[0x11; 60][..]].concat());
    let long_unknown = request(&[&[0x68][..], &[0x33; 199][..]].concat());
    assert!(long_77.len() > REQUEST_CAPACITY);
    e.receive(2_000_000, &long_77);
    e.receive(2_000_001, &long_unknown);
    let mut expected = acked(&REPLY_92);
    expected.extend(acked(&REPLY_92));
    assert_eq!(drain(&mut e, 3_000_000), expected);
    assert_eq!(
        events(&mut e),
        [
            Event::Request(Handled::Unknown {
                command: 0x77,
                data_len: 60
            }),
            Event::Request(Handled::Unknown {
                command: 0x68,
                data_len: 199
            }),
        ]
    );
    assert_eq!(e.stats().requests, 2);
    // Corrupted beyond what the buffer keeps: NAK, counted; the status
    // request right behind it (same chunk) is answered.
    let mut bad = long_unknown.clone();
    bad[150] ^= 0x40;
    e.receive(3_000_000, &[&bad[..], &STATUS[..]].concat());
    let parts = split(&drain(&mut e, 4_000_000));
    assert_eq!(parts[0], [NAK]);
    assert_eq!(parts[1], [ACK]);
    assert_eq!(parts[2][4], 0xB1);
    assert_eq!(events(&mut e)[0], Event::BadChecksum);
    assert_eq!(e.stats().naks, 1);
    assert_eq!(e.framer_stats().crc_errors, 1);
    assert_eq!(e.framer_stats().bytes_skipped as usize, bad.len());
    // Byte by byte: the same answers.
    let mut e = lms();
    for (k, b) in long_77.iter().chain(&STATUS).enumerate() {
        e.receive(2_000_000 + k as u64, core::slice::from_ref(b));
    }
    let parts = split(&drain(&mut e, 3_000_000));
    assert_eq!(parts.len(), 4);
    assert_eq!((parts[1][4], parts[3][4]), (0x92, 0xB1));
}

#[test]
fn emulator_other_address_ignored_and_short_scans_padded() {
    let mut e = lms();
    let mut other = request(&[0x31]);
    other[1] = 0x05;
    let n = other.len() - 2;
    let crc = crc16(&other[..n]);
    other[n..].copy_from_slice(&crc.to_le_bytes());
    e.receive(2_000_000, &other);
    assert!(drain(&mut e, 3_000_000).is_empty());
    assert_eq!(events(&mut e), [Event::IgnoredAddress { address: 5 }]);

    let source = FnSource::new(|_, _, out| {
        out[0] = 77;
        1
    });
    let mut e = Emulator::new(source, Settings::default(), 0);
    e.receive(0, &ONE_SCAN);
    let parts = split(&drain(&mut e, 2_000_000));
    let b0 = &parts[2];
    assert_eq!(&b0[5..11], &[0xB5, 0x00, 77, 0, 0xFF, 0x1F]);
}

#[test]
fn emulator_random_input_never_outruns_the_line() {
    // Garbage, valid requests (no baud change, no reset) and corrupted
    // ones in random chunks at random times, read out with random
    // buffer sizes: nothing panics, and at 9600 Bd no more than
    // 960 bytes per second ever leave.
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut rnd = move |n: u64| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x % n
    };
    let requests: [&[u8]; 7] = [
        &STATUS,
        &ONE_SCAN,
        &START,
        &STOP,
        &VARIANT_100_025,
        &READ_CONFIG,
        &SENSOR_TYPE,
    ];
    let mut e = Emulator::new(Ramp::default(), Settings::default(), 0);
    let mut now = 0u64;
    let mut sent = 0u64;
    let mut buf = [0u8; 1024];
    for _ in 0..20_000 {
        now += rnd(5_000);
        let mut input: Vec<u8> = match rnd(4) {
            0 => (0..rnd(40)).map(|_| rnd(256) as u8).collect(),
            1 => {
                let mut r = requests[rnd(7) as usize].to_vec();
                let at = rnd(r.len() as u64) as usize;
                r[at] ^= 1 << rnd(8);
                r
            }
            _ => requests[rnd(7) as usize].to_vec(),
        };
        while !input.is_empty() {
            let k = (1 + rnd(input.len() as u64)) as usize;
            e.receive(now, &input[..k]);
            input.drain(..k);
        }
        let cap = 1 + rnd(buf.len() as u64) as usize;
        sent += e.transmit(now, &mut buf[..cap]) as u64;
        assert!(
            sent <= now * 960 / 1_000_000 + 1,
            "{sent} bytes by {now} µs"
        );
        while e.next_event().is_some() {}
    }
    assert_eq!(e.baud(), Baud::B9600);
    assert!(e.stats().naks > 0 && e.stats().scans_sent > 0);
}

#[test]
fn emulator_scan_timing_constants() {
    assert_eq!(line_time_us(732, Baud::B500000), 14_640);
    assert_eq!(line_time_us(732, Baud::B38400), 190_625);
    assert_eq!(scan_period_us(Variant::Fov180Res100), 13_333);
    assert_eq!(scan_period_us(Variant::Fov180Res50), 26_667);
    assert_eq!(scan_period_us(Variant::Fov100Res25), 53_333);
}

#[test]
fn emulator_value_modes_mean_subrange_and_mean_subrange() {
    // 180°/1° power-on, 9600 Bd: switch to 500 kBd so the line is no limit.
    let mut e = lms();
    e.receive(0, &BAUD_500K);
    drain(&mut e, 20_000);
    // Subrange: values 1..=22 of each scan: A0 00, then a B7 per scan.
    e.receive(20_000, &request(&[0x20, 0x27, 1, 0, 22, 0]));
    let got = split(&drain(&mut e, 20_000 + 13_333 * 5));
    assert_eq!(got[0], std::vec![ACK]);
    assert_eq!(got[1], A0_OK);
    let b7: Vec<_> = got[2..]
        .iter()
        .filter(|t| t.len() > 4 && t[4] == 0xB7)
        .collect();
    assert!(b7.len() >= 4, "{} B7", b7.len());
    // B7 | 01 00 16 00 | W = 22, cm | 1000, 1001, … | status.
    assert_eq!(&b7[0][5..11], &[1, 0, 22, 0, 22, 0]);
    assert_eq!(&b7[0][11..15], &[0xE8, 0x03, 0xE9, 0x03]);
    assert_eq!(e.status_fields().operating_mode, 0x27);
    // Mean of 5 scans: one B6 per 5 scans (66.7 ms at 1°).
    e.receive(200_000, &request(&[0x20, 0x26, 5]));
    let got = split(&drain(&mut e, 200_000 + 180_000));
    let b6: Vec<_> = got.iter().filter(|t| t.len() > 4 && t[4] == 0xB6).collect();
    assert_eq!(b6.len(), 3, "one B6 per 5 scans: at 0, 66.7 and 133.3 ms");
    assert_eq!(&b6[0][5..8], &[5, 181, 0], "n = 5, W = 181 values in cm");
    assert_eq!(&b6[0][8..10], &[0xE8, 0x03], "the mean of a constant ramp");
    // Mean subrange 10..=20 over 3 scans: BF | 03 | 0A 00 | 14 00 | W = 11.
    e.receive(400_000, &request(&[0x20, 0x28, 3, 10, 0, 20, 0]));
    let got = split(&drain(&mut e, 600_000));
    let bf = got.iter().find(|t| t.len() > 4 && t[4] == 0xBF).unwrap();
    assert_eq!(&bf[5..12], &[3, 10, 0, 20, 0, 11, 0]);
    assert_eq!(&bf[12..14], &(1009u16).to_le_bytes());
    // Bad parameters: A0 02, mode kept.
    e.receive(600_000, &request(&[0x20, 0x26, 1]));
    let got = split(&drain(&mut e, 700_000));
    assert!(got
        .iter()
        .any(|t| t.len() > 5 && t[4] == 0xA0 && t[5] == 0x02));
    assert_eq!(e.status_fields().operating_mode, 0x28);
}

#[test]
fn emulator_value_modes_are_unknown_on_the_coprocessor_face() {
    let settings = Settings {
        external_scans: true,
        ..Settings::default()
    };
    let mut e = Emulator::new(Ramp::default(), settings, 0);
    drain(&mut e, 1_000_000);
    e.receive(1_000_000, &request(&[0x20, 0x26, 5]));
    assert_eq!(drain(&mut e, 1_100_000), acked(&REPLY_92));
}

/// A scan kept by the source (like the co-processor's latest), served both
/// ways: whole (`next_scan`) and word by word (`word`); `count` of them,
/// the rest "not valid".
struct Kept {
    count: usize,
}

impl Kept {
    fn at(j: usize) -> u16 {
        // Flags in the top bits and error codes among the values.
        (j as u16).wrapping_mul(7919) & 0x9FFF
    }
}

impl ScanSource for Kept {
    fn next_scan(&mut self, _: Variant, _: Unit, out: &mut [u16]) -> usize {
        let n = self.count.min(out.len());
        for (j, v) in out.iter_mut().take(n).enumerate() {
            *v = Self::at(j);
        }
        n
    }

    fn word(&self, _: Variant, _: Unit, index: usize) -> Option<u16> {
        (index < self.count).then(|| Self::at(index))
    }
}

/// Requests and the sensor's bytes at each step, read in odd chunks at odd
/// times (frames cut anywhere), for a default and a small transmit buffer.
fn script<const TX: usize>(mut e: Emulator<Kept, TX>) -> (Vec<u8>, EmulatorStats) {
    let steps: [(u64, &[u8]); 7] = [
        (1_000_000, &ONE_SCAN),
        (2_500_000, &STATUS),
        (3_000_000, &VARIANT_180_050),
        (3_500_000, &ONE_SCAN),
        (5_000_000, &START),
        (5_400_000, &STOP),
        (6_000_000, &ONE_SCAN),
    ];
    let mut out = Vec::new();
    let mut buf = [0u8; 37];
    let mut now = 0;
    for (at, req) in steps {
        while now < at {
            now += 3_331;
            loop {
                let n = e.transmit(now, &mut buf);
                if n == 0 {
                    break;
                }
                out.extend_from_slice(&buf[..n]);
            }
        }
        e.receive(now, req);
    }
    out.extend(drain(&mut e, 9_000_000));
    (out, *e.stats())
}

#[test]
fn emulator_streamed_b0_is_byte_identical() {
    for count in [0, 100, 181, 361, 401] {
        let big = Emulator::new(Kept { count }, Settings::default(), 0);
        let small: Emulator<Kept, MIN_TX_CAPACITY> =
            Emulator::off_sized(Kept { count }, Settings::default());
        let mut small = small;
        small.power_on(0);
        let (a, stats_a) = script(big);
        let (b, stats_b) = script(small);
        assert_eq!(a, b, "count {count}");
        assert_eq!(stats_a, stats_b);
        let parts = split(&a);
        let b0s: Vec<_> = parts
            .iter()
            .filter(|p| p.len() > 5 && p[4] == 0xB0)
            .collect();
        // Two 30 01 at 181 beams, one at 361, and the stream's (9600 Bd).
        assert!(b0s.len() >= 4, "{} B0s", b0s.len());
        assert!(b0s.iter().any(|t| t.len() == 732) && b0s.iter().any(|t| t.len() == 372));
        assert!(stats_b.emit_errors == 0 && stats_b.scans_sent as usize == b0s.len());
    }
}

#[test]
fn emulator_small_buffer_sends_no_value_telegrams() {
    let mut e: Emulator<Kept, MIN_TX_CAPACITY> =
        Emulator::off_sized(Kept { count: 181 }, Settings::default());
    e.power_on(0);
    drain(&mut e, 1_000_000);
    // 20 27 1 181: subrange, A0 00, then B7s (none fit this buffer).
    e.receive(1_000_000, &request(&[0x20, 0x27, 1, 0, 181, 0]));
    let got = drain(&mut e, 2_000_000);
    assert_eq!(split(&got), std::vec![std::vec![ACK], A0_OK.to_vec()]);
    assert!(e.stats().emit_errors > 0 && e.stats().scans_sent == 0);
}

#[test]
fn emulator_partial_scans_interlace_at_a_quarter_degree() {
    let mut e = lms();
    e.receive(T0, &BAUD_500K);
    drain(&mut e, T0 + 20_000);
    e.receive(T0 + 20_000, &VARIANT_100_025);
    drain(&mut e, T0 + 40_000);
    // 20 2A: A0 00, then one B0 per mirror turn (13.3 ms), offsets 0…3.
    e.receive(T0 + 40_000, &request(&[0x20, 0x2A]));
    let got = split(&drain(&mut e, T0 + 40_000 + 13_334 * 8));
    assert_eq!(got[1], A0_OK);
    let b0: Vec<_> = got.iter().filter(|t| t.len() > 4 && t[4] == 0xB0).collect();
    assert!(b0.len() >= 7, "{}", b0.len());
    assert_eq!(e.status_fields().operating_mode, 0x2A);
    for (k, t) in b0.iter().enumerate() {
        let w = u16::from_le_bytes([t[5], t[6]]);
        let part = (k % 4) as u16;
        // Bit 13 partial scan, bits 11–12 the offset in 0.25°, cm.
        let count = if part == 0 { 101 } else { 100 };
        assert_eq!(w, 0x2000 | part << 11 | count, "partial {k}");
        // Value i of partial p is beam p + 4i of the ramp (1000 + beam).
        let first = u16::from_le_bytes([t[7], t[8]]);
        let second = u16::from_le_bytes([t[9], t[10]]);
        assert_eq!((first, second), (1000 + part, 1004 + part));
        assert_eq!(t.len(), 4 + 1 + 2 + 2 * count as usize + 1 + 2);
    }
}

#[test]
fn emulator_partial_scans_at_half_a_degree_and_one_degree() {
    for (variant_request, counts, offsets) in [
        (&VARIANT_180_050[..], [181u16, 180], [0u16, 2]),
        (
            &request(&[0x3B, 0xB4, 0x00, 0x64, 0x00])[..],
            [181, 181],
            [0, 0],
        ),
    ] {
        let mut e = lms();
        e.receive(T0, &BAUD_500K);
        drain(&mut e, T0 + 20_000);
        e.receive(T0 + 20_000, variant_request);
        drain(&mut e, T0 + 40_000);
        e.receive(T0 + 40_000, &request(&[0x20, 0x2A]));
        let got = split(&drain(&mut e, T0 + 40_000 + 13_334 * 4));
        let b0: Vec<_> = got.iter().filter(|t| t.len() > 4 && t[4] == 0xB0).collect();
        assert!(b0.len() >= 3);
        for (k, t) in b0.iter().enumerate() {
            let w = u16::from_le_bytes([t[5], t[6]]);
            assert_eq!(w, 0x2000 | offsets[k % 2] << 11 | counts[k % 2]);
        }
    }
}

#[test]
fn emulator_sends_real_time_indices_when_the_configuration_asks() {
    let mut e = lms();
    e.receive(T0, &BAUD_500K);
    drain(&mut e, T0 + 20_000);
    e.receive(T0 + 20_000, &INSTALL);
    drain(&mut e, T0 + 30_000);
    let mut config = Config::ZERO;
    config.set_availability(0x02);
    let mut write = std::vec![0x77];
    write.extend_from_slice(config.as_bytes());
    e.receive(T0 + 30_000, &request(&write));
    drain(&mut e, T0 + 40_000);
    assert!(e.config().real_time_indices());
    // 30 01: B0 | W | 181 values | index | status.
    e.receive(T0 + 40_000, &ONE_SCAN);
    let got = split(&drain(&mut e, T0 + 60_000));
    let b0 = &got[1];
    assert_eq!(u16::from_le_bytes([b0[2], b0[3]]), 1 + 2 + 362 + 1 + 1);
    assert_eq!(b0[5 + 2 + 362 + 1], 0x10, "the status after the index");
    // The stream: each B0 carries its mirror scan's number.
    e.receive(T0 + 60_000, &START);
    let got = split(&drain(&mut e, T0 + 60_000 + 13_334 * 6));
    let indices: Vec<u8> = got
        .iter()
        .filter(|t| t.len() > 4 && t[4] == 0xB0)
        .map(|t| t[5 + 2 + 362])
        .collect();
    assert!(indices.len() >= 4);
    assert!(
        indices.windows(2).all(|w| w[1] == w[0].wrapping_add(1)),
        "{indices:?}"
    );
    // Value telegrams too: B7 | a b | W | values | index | status.
    e.receive(T0 + 200_000, &request(&[0x20, 0x27, 1, 0, 2, 0]));
    let got = split(&drain(&mut e, T0 + 260_000));
    let b7 = got.iter().find(|t| t.len() > 4 && t[4] == 0xB7).unwrap();
    assert_eq!(u16::from_le_bytes([b7[2], b7[3]]), 1 + 4 + 2 + 4 + 1 + 1);
}

/// After the power-on telegram of [`lms`] (its line is free by then).
const T0: u64 = 1_000_000;
