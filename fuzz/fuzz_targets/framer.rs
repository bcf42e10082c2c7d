//! The framer fed a byte stream in arbitrary chunks (split points from the
//! input), either direction, with or without the ACK/NAK handshake, with
//! time-outs (`abandon`) and `discard` at split points.
//!
//! Checks: no panic; every telegram it hands out passes
//! `Telegram::new_checked`; every byte is accounted for (telegrams + ACKs +
//! NAKs + skipped + buffered = fed); and without `abandon`/`discard` the
//! events do not depend on the chunking (whole stream, split points, one
//! byte at a time).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lms_core::telegram::{Framer, Handshake, Telegram};
use lms_fuzz::{drain, Ev, FramerInput, FRAMER_ABANDON, FRAMER_DISCARD, FRAMER_HANDSHAKE};

fuzz_target!(|data: &[u8]| {
    let input = FramerInput::decode(data);
    let direction = input.direction();
    let handshake = if input.flags & FRAMER_HANDSHAKE != 0 {
        Handshake::Expected
    } else {
        Handshake::Ignored
    };
    let timeouts = input.flags & (FRAMER_ABANDON | FRAMER_DISCARD) != 0;

    let mut framer = Framer::new(direction, handshake);
    let mut events = Vec::new();
    let mut start = 0;
    for (i, &end) in input
        .splits
        .iter()
        .chain([input.stream.len()].iter())
        .enumerate()
    {
        drain(&mut framer, &input.stream[start..end], &mut events);
        start = end;
        if input.flags & FRAMER_ABANDON != 0 {
            framer.abandon();
            drain(&mut framer, &[], &mut events);
        }
        if input.flags & FRAMER_DISCARD != 0 && i + 1 == input.splits.len() {
            framer.discard();
        }
    }

    // Every telegram is a checked telegram.
    let mut in_telegrams = 0usize;
    for e in &events {
        if let Ev::Telegram(bytes) = e {
            let t = Telegram::new_checked(&bytes[..], direction).expect("framer output checks");
            assert_eq!(t.total_len(), bytes.len());
            in_telegrams += bytes.len();
        }
    }
    // Every byte is accounted for.
    let s = *framer.stats();
    let accounted = in_telegrams
        + s.acks as usize
        + s.naks as usize
        + s.bytes_skipped as usize
        + framer.buffered();
    assert_eq!(
        accounted,
        input.stream.len(),
        "bytes lost or invented: {s:?}"
    );
    assert_eq!(
        s.resyncs,
        s.crc_errors + s.oversize + s.bad_headers + s.abandoned
    );

    // Chunking does not matter (without time-outs).
    if !timeouts {
        let mut whole = Framer::new(direction, handshake);
        let mut all = Vec::new();
        drain(&mut whole, input.stream, &mut all);
        assert_eq!(all, events, "split points changed the events");
        assert_eq!(*whole.stats(), s);
        if input.stream.len() <= 4096 {
            let mut bytewise = Framer::new(direction, handshake);
            let mut one = Vec::new();
            for b in input.stream.chunks(1) {
                drain(&mut bytewise, b, &mut one);
            }
            assert_eq!(one, events, "byte-at-a-time changed the events");
            assert_eq!(*bytewise.stats(), s);
        }
    }
});
