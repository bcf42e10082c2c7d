//! Byte-exact vectors of the co-processor's feature telegrams: the worked
//! example of `docs/PROTOCOL.md` §3, emitted and parsed back.

use lms_core::maths::Sym2;
use lms_core::telegram::features::{
    emit_features, Assembled, Counters, EchoedParams, FeatureAssembler, CMD_FEATURES, REQ_COUNTERS,
    REQ_FEATURES,
};
use lms_core::telegram::{crc16, emit_telegram, Direction, Head, Telegram};
use lms_core::Corner;
use lms_core::Features;
use lms_core::Line;
use lms_core::Segment;

const SEGMENTS: &str = "02 80 0F 00 D4 2A 00 00 00 02 0A 00 3C 00 3C 00 78 00 10 4E 8C";
const EDGES: &str = "02 80 0A 00 D3 2A 00 00 00 01 00 3C 00 10 62 F6";
const LINES: &str = "02 80 65 00 D1 2A 00 00 00 00 01 02 00 00 00 00 00 00 00 40 BD 37 86 35 00 00 00 00 BD 37 86 36 00 00 80 3F 00 00 00 40 00 00 C0 BF 00 00 00 40 00 00 00 3F 0A 00 3C 00 33 00 DB 0F C9 3F 00 00 00 3F BD 37 86 35 00 00 00 00 BD 37 86 36 00 00 00 3F 00 00 00 40 00 00 00 3F 00 00 00 3F 00 00 00 3F 3C 00 78 00 3D 00 10 CC B0";
const CORNERS: &str = "02 80 24 00 D2 2A 00 00 00 00 01 01 00 00 00 40 00 00 00 3F BD 37 86 36 00 00 00 00 BD 37 86 36 00 00 B4 42 01 00 01 10 67 F6";
const SUMMARY: &str = "02 80 33 00 D0 2A 00 00 00 69 01 02 02 01 01 00 69 01 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 1E 00 0A D7 A3 3B 00 00 00 00 00 00 10 41 10 F8 F5";
const COUNTERS: &str = "02 80 52 00 D5 E8 03 00 00 E8 03 00 00 88 13 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 E8 03 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 10 DA 6C";
const FEATURES_ON: &str = "02 00 02 00 56 01 FD 7E";
const FEATURES_OFF: &str = "02 00 02 00 56 00 FC 7E";
const FEATURES_ON_REPLY: &str = "02 80 03 00 D6 01 10 CC E6";
const FEATURES_OFF_REPLY: &str = "02 80 03 00 D6 00 10 CE E7";
const COUNTERS_REQUEST: &str = "02 00 01 00 55 71 12";

fn bytes(hex: &str) -> Vec<u8> {
    hex.split(' ')
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// The worked example: an L-shaped corner seen at 2 m.
fn example() -> Features {
    let mut f = Features::default();
    f.push_segment(Segment {
        first: 10,
        last: 60,
    })
    .unwrap();
    f.push_segment(Segment {
        first: 60,
        last: 120,
    })
    .unwrap();
    f.push_edge(60).unwrap();
    let cov = Sym2 {
        a: 1.0e-6,
        b: 0.0,
        c: 4.0e-6,
    };
    f.push_line(Line {
        alpha: 0.0,
        r: 2.0,
        cov,
        first: 10,
        last: 60,
        points: 51,
        chi2: 1.0,
        endpoints: [[2.0, -1.5], [2.0, 0.5]],
    })
    .unwrap();
    f.push_line(Line {
        alpha: 1.5707964,
        r: 0.5,
        cov,
        first: 60,
        last: 120,
        points: 61,
        chi2: 0.5,
        endpoints: [[2.0, 0.5], [0.5, 0.5]],
    })
    .unwrap();
    f.push_corner(Corner {
        x: 2.0,
        y: 0.5,
        cov: Sym2 {
            a: 4.0e-6,
            b: 0.0,
            c: 4.0e-6,
        },
        angle_deg: 90.0,
        well_conditioned: true,
        line_a: 0,
        line_b: 1,
    })
    .unwrap();
    f.stats_mut().valid_beams = 361;
    f
}

const PARAMS: EchoedParams = EchoedParams {
    iterations: 30,
    sigma: 0.005,
    q: 0.0,
    tau: 9.0,
};

#[test]
fn the_worked_example_is_emitted_byte_for_byte() {
    let mut wire = Vec::new();
    emit_features(42, 361, &PARAMS, &example(), 0, |t| {
        wire.push(t.to_vec());
        Ok::<(), ()>(())
    })
    .unwrap();
    let want: Vec<Vec<u8>> = [SEGMENTS, EDGES, LINES, CORNERS, SUMMARY]
        .iter()
        .map(|h| bytes(h))
        .collect();
    assert_eq!(wire, want);
    for t in &wire {
        let n = t.len();
        assert_eq!(crc16(&t[..n - 2]).to_le_bytes(), [t[n - 2], t[n - 1]]);
    }
}

#[test]
fn the_worked_example_parses_back_to_the_same_bits() {
    let mut asm = FeatureAssembler::new();
    let mut complete = None;
    for h in [SEGMENTS, EDGES, LINES, CORNERS, SUMMARY] {
        let b = bytes(h);
        let t = Telegram::new_checked(&b[..], Direction::SensorToHost).unwrap();
        if let Assembled::Complete(s, f) = asm.push(&t).unwrap() {
            complete = Some((s, f.clone()));
        }
    }
    let (summary, f) = complete.expect("the summary closes the scan");
    let want = example();
    assert_eq!(summary.scan_counter, 42);
    assert_eq!(summary.params, PARAMS);
    assert_eq!(f.segments(), want.segments());
    assert_eq!(f.edges(), want.edges());
    assert_eq!(f.lines(), want.lines());
    assert_eq!(f.corners(), want.corners());
    assert_eq!(f.stats(), want.stats());
}

#[test]
fn counters_request_and_reply_are_byte_exact() {
    let mut buf = [0u8; 96];
    let n = emit_telegram(&mut buf, Head::to_sensor(REQ_COUNTERS), &[], None).unwrap();
    assert_eq!(buf[..n], bytes(COUNTERS_REQUEST)[..]);
    let c = Counters {
        scans_in: 1000,
        feature_scans_out: 1000,
        feature_telegrams_out: 5000,
        scans_out: 1000,
        ..Counters::default()
    };
    let n = c.emit(0, &mut buf).unwrap();
    assert_eq!(buf[..n], bytes(COUNTERS)[..]);
}

#[test]
fn counters_carry_the_boot_fields_and_still_read_the_old_length() {
    use lms_core::telegram::features::{COUNTERS_LEN, COUNTERS_LEN_V1};
    let c = Counters {
        scans_in: 7,
        scans_out: 5,
        reset_flags: 16,
        fault_cause: 2,
        fault_pc: 0x0800_1234,
        fault_lr: 0x0800_5679,
        ..Counters::default()
    };
    let mut data = [0u8; COUNTERS_LEN];
    c.encode(&mut data);
    assert_eq!(&data[48..52], &16u32.to_le_bytes());
    assert_eq!(&data[56..60], &0x0800_1234u32.to_le_bytes());
    assert_eq!(Counters::decode(&data), Some(c));
    // A co-processor without the boot fields sent the first 48 bytes.
    let old = Counters::decode(&data[..COUNTERS_LEN_V1]).unwrap();
    assert_eq!((old.scans_in, old.scans_out), (7, 5));
    assert_eq!(
        (old.reset_flags, old.fault_cause, old.fault_pc, old.fault_lr),
        (0, 0, 0, 0)
    );
    assert_eq!(Counters::decode(&data[..52]), None);
}

#[test]
fn feature_opt_in_request_and_reply_are_byte_exact() {
    let mut buf = [0u8; 16];
    for (state, request, reply) in [
        (1u8, FEATURES_ON, FEATURES_ON_REPLY),
        (0, FEATURES_OFF, FEATURES_OFF_REPLY),
    ] {
        let n = emit_telegram(&mut buf, Head::to_sensor(REQ_FEATURES), &[state], None).unwrap();
        assert_eq!(buf[..n], bytes(request)[..]);
        let n = emit_telegram(
            &mut buf,
            Head::from_sensor(CMD_FEATURES),
            &[state],
            Some(0x10),
        )
        .unwrap();
        assert_eq!(buf[..n], bytes(reply)[..]);
    }
}
