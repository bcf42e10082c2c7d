//! The feature telegrams (`D0`–`D4`): the assembler fed arbitrary
//! telegrams (mode 0), and any `Features` value emitted and reassembled
//! (mode 1).
//!
//! Checks: no panic; in mode 1 the assembler gives back exactly the
//! features, bit for bit, with the summary's counter, beams and parameters.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lms_core::telegram::features::{emit_features, Assembled, EchoedParams, FeatureAssembler};
use lms_core::telegram::{emit_telegram, Direction, Head, Telegram, MAX_TELEGRAM_LEN};
use lms_fuzz::{decode_features, feature_bits, Input};

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let mut asm = FeatureAssembler::new();
    if input.u8() & 1 == 0 {
        // Arbitrary telegrams: `cmd | len (u16 % 820) | data`.
        while !input.is_empty() {
            let command = input.u8();
            let len = usize::from(input.u16()) % 820;
            let body = input.bytes(len);
            let mut buf = [0u8; MAX_TELEGRAM_LEN];
            if let Ok(n) = emit_telegram(&mut buf, Head::from_sensor(command), body, Some(0x10)) {
                let t = Telegram::new_checked(&buf[..n], Direction::SensorToHost).unwrap();
                if let Ok(Assembled::Complete(summary, f)) = asm.push(&t) {
                    let _ = (summary.counts, f.lines().len());
                }
            }
            // The same bytes as an unchecked view of any length.
            let t = Telegram::new_unchecked(body, Direction::SensorToHost);
            let _ = asm.push(&t);
        }
        let _ = asm.discarded();
        return;
    }
    // Round trip of any features.
    let (counter, beams, features) = decode_features(&mut input);
    let params = EchoedParams {
        iterations: input.u16(),
        sigma: input.f32(),
        q: input.f32(),
        tau: input.f32(),
    };
    let mut telegrams: Vec<Vec<u8>> = Vec::new();
    let sent = emit_features(counter, beams, &params, &features, 0, |t| {
        telegrams.push(t.to_vec());
        Ok::<(), ()>(())
    })
    .unwrap();
    assert_eq!(sent as usize, telegrams.len());
    let mut complete = 0;
    for (i, bytes) in telegrams.iter().enumerate() {
        let t = Telegram::new_checked(&bytes[..], Direction::SensorToHost)
            .expect("emitted telegram checks");
        match asm.push(&t).expect("our own telegrams assemble") {
            Assembled::Complete(summary, got) => {
                assert_eq!(i + 1, telegrams.len(), "the summary comes last");
                assert_eq!(summary.scan_counter, counter);
                assert_eq!(summary.beams, beams);
                assert_eq!(summary.params.iterations, params.iterations);
                assert_eq!(summary.params.sigma.to_bits(), params.sigma.to_bits());
                assert_eq!(summary.params.q.to_bits(), params.q.to_bits());
                assert_eq!(summary.params.tau.to_bits(), params.tau.to_bits());
                assert_eq!(feature_bits(got), feature_bits(&features));
                complete += 1;
            }
            Assembled::Partial => {}
            Assembled::NotFeatures => panic!("a feature telegram not recognised"),
        }
    }
    assert_eq!(complete, 1);
});
