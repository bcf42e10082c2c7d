//! `B0` decoding: value words of any variant, units and range bits, with
//! error codes, zeros and flag bits, through emit → framer-checked telegram
//! → `MeasuredView` → `Frame`; and `MeasuredView` on arbitrary bytes.
//!
//! Checks: no panic; the frame has the telegram's beam count and geometry;
//! each beam is exactly what its word says (range/units in metres, or
//! invalid with the decoded reason); `to_frame_into` agrees with
//! `to_frame`; `MeasuredValues::from_frame` gives back the words without
//! their flag bits.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lms_core::telegram::{Direction, MeasuredValues, MeasuredView, Telegram, MAX_TELEGRAM_LEN};
use lms_core::{Beam, Frame, Variant};
use lms_fuzz::{bits_of, units_of, Input};

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let selector = input.u8();
    let units = units_of(input.u8());
    let bits = bits_of(input.u8());
    let status = input.u8();
    let variant = Variant::ALL[usize::from(selector % 5)];
    let rest = input.rest();

    // Arbitrary bytes as B0 data.
    if let Ok(v) = MeasuredView::new(rest) {
        let _ = (
            v.count(),
            v.units(),
            v.scan_flags(),
            v.word(0),
            v.to_values(status),
        );
        let _ = v.to_frame(bits);
    }

    // A well-formed B0 of the variant, the words from the input.
    let n = variant.beams();
    let mut words = vec![8191u16; n];
    for (w, c) in words.iter_mut().zip(rest.chunks_exact(2)) {
        *w = u16::from_le_bytes([c[0], c[1]]);
    }
    let values = MeasuredValues::from_raw(&words, units, status).expect("at most 401 values");
    let mut buf = [0u8; MAX_TELEGRAM_LEN];
    let len = values.emit(selector & 0x7F, &mut buf).expect("a B0 fits");
    let t = Telegram::new_checked(&buf[..len], Direction::SensorToHost).expect("emitted B0 checks");
    let view = MeasuredView::parse(&t).expect("emitted B0 parses");
    assert_eq!(view.count(), n);
    assert_eq!(view.units(), units);
    let frame = view.to_frame(bits).expect("a variant's count");
    assert_eq!(frame.len(), n);
    assert_eq!(frame.geometry(), variant.geometry());
    let mut into = Frame::empty();
    view.to_frame_into(bits, &mut into)
        .expect("same as to_frame");
    for (j, &word) in words.iter().enumerate() {
        let (r, b) = (frame.ranges()[j], frame.beams()[j]);
        assert_eq!(into.ranges()[j].to_bits(), r.to_bits());
        assert_eq!(into.beams()[j], b);
        match bits.decode(word) {
            Ok(raw) => {
                assert_eq!(b, Beam::Valid);
                assert_eq!(r, f32::from(raw) / units.per_metre());
                assert!(r.is_finite() && r > 0.0);
            }
            Err(why) => {
                assert_eq!(b, Beam::Invalid(why));
                assert_eq!(r, 0.0);
            }
        }
    }
    let back = MeasuredValues::from_frame(&frame, units, bits, status);
    let masked: Vec<u16> = words.iter().map(|&w| bits.range(w)).collect();
    assert_eq!(back.values(), &masked[..], "words -> frame -> words");
});
