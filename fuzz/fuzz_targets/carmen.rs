//! The CARMEN reader (`lms_core::carmen`, std side) on arbitrary bytes as a
//! log: the unit decision and the streaming `Reader`.
//!
//! Input: byte 0 picks the read buffer's capacity (1..=64 bytes), byte 1
//! the unit (auto, cm, mm) and where the log is cut (bytes 2..3, a
//! fraction); the rest is the log.
//!
//! Checks: no panic; the same scans, cut and error whatever the buffer
//! size (streaming does not depend on where reads end); indices count from
//! 0, line numbers increase, every frame has a supported beam count and its
//! variant's geometry; a log read without error and without a cut, cut at
//! any byte, reads without error and keeps every scan whose line is
//! complete before the cut, bit for bit.
#![no_main]

use std::io::BufReader;

use libfuzzer_sys::fuzz_target;
use lms_core::carmen::{decide, variant_for_beams, Reader, SUPPORTED_BEAMS};
use lms_core::{Beam, Frame, Unit};
use lms_fuzz::Input;

/// A frame's beam count, range bits and beam states (frames compare bit
/// for bit).
type Bits = (usize, Vec<u32>, Vec<Beam>);

/// (index, line, frame) of every scan, the error text, the cut line.
type Read = (Vec<(usize, usize, Bits)>, Option<String>, Option<usize>);

fn bits(frame: &Frame) -> Bits {
    (
        frame.len(),
        frame.ranges().iter().map(|r| r.to_bits()).collect(),
        frame.beams().to_vec(),
    )
}

fn read(text: &[u8], capacity: usize, unit: Unit) -> Read {
    let mut reader = Reader::new(BufReader::with_capacity(capacity, text), unit);
    let mut scans = Vec::new();
    let mut error = None;
    for scan in reader.by_ref() {
        match scan {
            Ok(s) => {
                let variant = variant_for_beams(s.frame.len()).expect("a supported count");
                assert_eq!(s.frame.geometry(), variant.geometry());
                scans.push((s.index, s.line, bits(&s.frame)));
            }
            Err(e) => error = Some(e.to_string()),
        }
    }
    (scans, error, reader.cut().map(|c| c.line))
}

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let capacity = usize::from(input.u8() % 64) + 1;
    let unit_pick = input.u8();
    let cut_at = input.u16();
    let text = input.rest();
    let vote = decide(BufReader::with_capacity(capacity, text));
    let unit = match unit_pick % 3 {
        0 => match &vote {
            Ok(v) => v.unit(),
            Err(_) => Unit::Centimetre,
        },
        1 => Unit::Centimetre,
        _ => Unit::Millimetre,
    };
    let whole = read(text, 1 << 16, unit);
    assert_eq!(
        read(text, capacity, unit),
        whole,
        "buffer size changed the result"
    );
    let (scans, error, cut) = &whole;
    let mut last_line = 0;
    for (k, (index, line, frame)) in scans.iter().enumerate() {
        assert_eq!(*index, k);
        assert!(*line > last_line);
        last_line = *line;
        assert!(SUPPORTED_BEAMS.contains(&frame.0));
    }
    if error.is_some() || cut.is_some() {
        return;
    }
    // Cut the good log at any byte: complete lines survive, bit for bit.
    let at = usize::from(cut_at) * text.len() / usize::from(u16::MAX).max(1);
    let prefix = &text[..at.min(text.len())];
    let complete_lines = prefix.iter().filter(|&&b| b == b'\n').count();
    let (part, part_error, _) = read(prefix, capacity, unit);
    assert_eq!(part_error, None, "a cut good log reads without error");
    let kept = scans
        .iter()
        .filter(|(_, line, _)| *line <= complete_lines)
        .count();
    assert!(part.len() >= kept && part.len() <= kept + 1);
    assert_eq!(part[..kept], scans[..kept]);
});
