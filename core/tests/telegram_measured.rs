//! `B0` measured values (PROTOCOL.md §3): the 361-value telegram in cm and
//! mm byte for byte, every variant, and the conversion to a frame.

use lms_core::telegram::{
    Direction, Head, MeasuredError, MeasuredValues, MeasuredView, RangeBits, Reply, ReplyError,
    SensorStatus, Telegram, MAX_VALUES,
};
use lms_core::Unit;
use lms_core::{Beam, Invalid, Variant};

/// The value pattern the CRCs below were computed for (independently, with
/// a Python transcription of PROTOCOL.md §1).
fn pattern(n: usize) -> Vec<u16> {
    (0..n).map(|j| ((j * 37 + 100) % 8000) as u16).collect()
}

fn emit(values: &MeasuredValues) -> Vec<u8> {
    let mut buf = vec![0u8; values.buffer_len()];
    let n = values.emit(0, &mut buf).unwrap();
    assert_eq!(n, buf.len());
    buf
}

#[test]
fn telegram_b0_361_cm_and_mm_bytes() {
    let raw = pattern(361);
    for (units, count_word, crc) in [
        (Unit::Centimetre, [0x69, 0x01], [0x3F, 0xA8]),
        (Unit::Millimetre, [0x69, 0x41], [0x46, 0xFF]),
    ] {
        let v = MeasuredValues::from_raw(&raw, units, 0x10).unwrap();
        assert_eq!(v.buffer_len(), 732);
        let bytes = emit(&v);
        assert_eq!(bytes.len(), 732);
        assert_eq!(&bytes[..5], &[0x02, 0x80, 0xD6, 0x02, 0xB0]);
        assert_eq!(&bytes[5..7], &count_word);
        for (j, &w) in raw.iter().enumerate() {
            assert_eq!(&bytes[7 + 2 * j..9 + 2 * j], &w.to_le_bytes(), "value {j}");
        }
        assert_eq!(bytes[729], 0x10);
        assert_eq!(&bytes[730..], &crc);

        // Parse back: the view, the owned copy, the reply.
        let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
        assert_eq!(t.length(), 726);
        let view = MeasuredView::parse(&t).unwrap();
        assert_eq!(view.count(), 361);
        assert_eq!(view.units(), units);
        assert!(view.words().eq(raw.iter().copied()));
        let back = MeasuredValues::parse(&t).unwrap();
        assert_eq!(back, v);
        assert_eq!(back.status(), 0x10);
        assert_eq!(emit(&back), bytes);
        match Reply::parse(&t).unwrap() {
            Reply::Measured(m) => assert_eq!(m, view),
            other => panic!("not B0: {other:?}"),
        }
        // The reply emits the same telegram.
        let mut again = vec![0u8; 732];
        Reply::Measured(view)
            .emit(0, SensorStatus(0x10), &mut again)
            .unwrap();
        assert_eq!(again, bytes);
    }
}

#[test]
fn telegram_b0_361_to_frame() {
    let mut raw = pattern(361);
    raw[0] = 8191; // not valid
    raw[1] = 8190 | 0x2000; // dazzling, one flag bit
    raw[2] = 0; // zero
    raw[3] = 8183; // above max
    raw[4] = 8184; // unnamed code, offset 7
    raw[5] = 8182 | 0xE000; // largest range, all flags
    for (units, scale) in [(Unit::Centimetre, 100.0f32), (Unit::Millimetre, 1000.0)] {
        let v = MeasuredValues::from_raw(&raw, units, 0x10).unwrap();
        let bytes = emit(&v);
        let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
        let view = MeasuredView::parse(&t).unwrap();
        let frame = view.to_frame(RangeBits::Bits13).unwrap();
        assert_eq!(frame.len(), 361);
        assert_eq!(frame.geometry(), Variant::Fov180Res50.geometry());
        assert_eq!(frame.beams()[0], Beam::Invalid(Invalid::NoEcho));
        assert_eq!(frame.beams()[1], Beam::Invalid(Invalid::Dazzle));
        assert_eq!(frame.beams()[2], Beam::Invalid(Invalid::Zero));
        assert_eq!(frame.beams()[3], Beam::Invalid(Invalid::AboveMax));
        assert_eq!(frame.beams()[4], Beam::Invalid(Invalid::OtherCode(7)));
        assert_eq!(frame.ranges()[5], 8182.0 / scale);
        for (j, &w) in raw.iter().enumerate().skip(6) {
            assert_eq!(frame.beams()[j], Beam::Valid, "beam {j}");
            assert_eq!(frame.ranges()[j], f32::from(w) / scale, "beam {j}");
        }
        assert_eq!(frame.valid_count(), 361 - 5);
        // The owned copy converts the same way.
        let owned = v.to_frame(RangeBits::Bits13).unwrap();
        assert_eq!(owned.ranges(), frame.ranges());
        assert_eq!(owned.beams(), frame.beams());
    }
}

#[test]
fn telegram_b0_all_variants() {
    for variant in Variant::ALL {
        let n = variant.beams();
        let raw = pattern(n);
        let v = MeasuredValues::from_raw(&raw, Unit::Centimetre, 0x10).unwrap();
        assert_eq!(v.variant(), Some(variant));
        let bytes = emit(&v);
        assert_eq!(bytes.len(), 4 + 1 + 2 + 2 * n + 1 + 2);
        let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
        let frame = MeasuredView::parse(&t)
            .unwrap()
            .to_frame(RangeBits::Bits13)
            .unwrap();
        assert_eq!(frame.len(), n);
        assert_eq!(frame.geometry(), variant.geometry());
    }
    // 401 values: LEN 806, still within MAX_LEN.
    let v = MeasuredValues::from_raw(&pattern(MAX_VALUES), Unit::Millimetre, 0).unwrap();
    assert_eq!(&emit(&v)[2..4], &806u16.to_le_bytes());
}

#[test]
fn telegram_b0_range_bits_modes() {
    let mut raw = vec![0u16; 181];
    raw[0] = 0x3FFF; // 14-bit "not valid", 13-bit: 8191 with flag bit 13
    raw[1] = 0x2000 | 100; // 13-bit: 100 + flag; 14-bit: 8292
    raw[2] = 0x7FF7; // 15-bit: above max
    let v = MeasuredValues::from_raw(&raw, Unit::Millimetre, 0).unwrap();
    let f13 = v.to_frame(RangeBits::Bits13).unwrap();
    let f14 = v.to_frame(RangeBits::Bits14).unwrap();
    let f15 = v.to_frame(RangeBits::Bits15).unwrap();
    assert_eq!(f13.beams()[0], Beam::Invalid(Invalid::NoEcho));
    assert_eq!(f14.beams()[0], Beam::Invalid(Invalid::NoEcho));
    assert_eq!(f15.ranges()[0], 16.383);
    assert_eq!(f13.ranges()[1], 0.1);
    assert_eq!(f14.ranges()[1], 8.292);
    assert_eq!(f15.beams()[2], Beam::Invalid(Invalid::AboveMax));
    assert_eq!(f13.beams()[3], Beam::Invalid(Invalid::Zero));
}

#[test]
fn telegram_b0_errors() {
    // Too many values for the buffer.
    assert_eq!(
        MeasuredValues::from_raw(&[1; 402], Unit::Centimetre, 0),
        Err(MeasuredError::TooManyValues { count: 402 })
    );
    // A count no variant sends.
    let v = MeasuredValues::from_raw(&[1; 360], Unit::Centimetre, 0).unwrap();
    assert_eq!(
        v.to_frame(RangeBits::Bits13).err(),
        Some(MeasuredError::UnsupportedCount { count: 360 })
    );
    // ... but it still makes a valid telegram and parses back.
    let bytes = emit(&v);
    let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
    assert_eq!(MeasuredValues::parse(&t), Ok(v));

    // Count word disagreeing with LEN: 361 announced, 360 sent.
    let mut data = vec![0x69, 0x01];
    data.extend(std::iter::repeat_n(0x10, 720));
    let mut buf = vec![0u8; 800];
    let n = lms_core::telegram::emit_telegram(&mut buf, Head::from_sensor(0xB0), &data, Some(0x10))
        .unwrap();
    let t = Telegram::new_checked(&buf[..n], Direction::SensorToHost).unwrap();
    let mismatch = MeasuredError::LengthMismatch {
        count: 361,
        data_len: 722,
    };
    assert_eq!(MeasuredView::parse(&t), Err(mismatch));
    assert_eq!(Reply::parse(&t), Err(ReplyError::Measured(mismatch)));

    // Not a B0.
    let a0 = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
    let t = Telegram::new_checked(&a0[..], Direction::SensorToHost).unwrap();
    assert_eq!(
        MeasuredView::parse(&t),
        Err(MeasuredError::NotMeasured { command: 0xA0 })
    );
    let t = Telegram::new_checked(&a0[..], Direction::HostToSensor).unwrap();
    assert_eq!(
        MeasuredValues::parse(&t),
        Err(MeasuredError::WrongDirection)
    );
}

#[test]
fn telegram_b0_from_frame_for_simulator() {
    // A simulator's scan in metres → B0 in mm → frame: same ranges to 0.5 mm.
    let variant = Variant::Fov180Res50;
    let ranges: Vec<f32> = (0..361).map(|j| 0.5 + j as f32 * 0.0123).collect();
    let mut frame = lms_core::Frame::from_metres(variant.geometry(), &ranges).unwrap();
    frame.set_invalid(10, Invalid::Dazzle);
    let v = MeasuredValues::from_frame(&frame, Unit::Millimetre, RangeBits::Bits13, 0x10);
    assert_eq!(v.count(), 361);
    assert_eq!(v.values()[0], 500);
    assert_eq!(v.values()[10], 8190);
    assert_eq!(v.values()[100], 1730);
    let bytes = emit(&v);
    assert_eq!(&bytes[5..7], &[0x69, 0x41]);
    let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost).unwrap();
    let back = MeasuredView::parse(&t)
        .unwrap()
        .to_frame(RangeBits::Bits13)
        .unwrap();
    assert_eq!(back.len(), 361);
    for (j, &r) in ranges.iter().enumerate() {
        if j == 10 {
            assert_eq!(back.beams()[j], Beam::Invalid(Invalid::Dazzle));
        } else {
            assert!((back.ranges()[j] - r).abs() <= 0.0005 + 1e-6, "beam {j}");
        }
    }
}
