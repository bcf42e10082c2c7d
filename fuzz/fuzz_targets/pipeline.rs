//! The whole pipeline (`Extractor::run`) on arbitrary frames — 3..=401
//! beams, any geometry, ranges as value words (error codes, flags), as any
//! `f32` (NaN, ±inf, huge, negative, subnormal) or as millimetres — and
//! arbitrary parameters (raw bits, mapped into range, or the defaults).
//! `Params::validate` errors are fine; panics are not.
//!
//! Checks: no panic; invalid beams are never modified; segments, edge
//! points, lines and corners are well formed (indices in range, in scan
//! order, consecutive segments share at most one point — with
//! `Params::per_turn` on an interleaved frame the turns' segments
//! interleave by design, so only their order is checked); a second run on
//! the same input gives the same bits (no state leaks between frames).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lms_core::pipeline::turns::interleaved_turns;
use lms_core::{Extractor, Trace};
use lms_fuzz::{decode_pipeline, feature_bits};

fn digest(e: &Extractor, trace: &Trace) -> Vec<u32> {
    let mut v = feature_bits(e.features());
    v.extend(e.smoothed().iter().map(|x| x.to_bits()));
    v.extend(trace.mahalanobis().iter().map(|x| x.to_bits()));
    v
}

fuzz_target!(|data: &[u8]| {
    let input = decode_pipeline(data);
    let (frame, params) = (&input.frame, &input.params);
    let mut extractor = Extractor::new();
    let Ok(valid) = params.validate() else {
        return;
    };
    let mut trace = Trace::new();
    let f = extractor.run_traced(frame, &valid, &mut trace);
    let n = frame.len();
    let per_turn = params.per_turn && interleaved_turns(frame.geometry().step) > 1;
    // Structure.
    let mut prev: Option<(u16, u16)> = None;
    for s in f.segments() {
        assert!(s.first <= s.last && usize::from(s.last) < n, "{s:?}");
        if let Some(p) = prev {
            let in_order = if per_turn {
                (s.first, s.last) >= p
            } else {
                s.first >= p.1
            };
            assert!(
                in_order,
                "segments out of order or overlapping: {:?}",
                f.segments()
            );
        }
        prev = Some((s.first, s.last));
    }
    let edges: Vec<u16> = f.edges().iter().collect();
    assert_eq!(edges.len(), f.edges().len());
    assert!(edges.windows(2).all(|w| w[0] < w[1]));
    assert!(edges.iter().all(|&e| usize::from(e) < n));
    for l in f.lines() {
        assert!(
            l.first <= l.last && usize::from(l.last) < n && l.points >= 3,
            "{l:?}"
        );
    }
    for c in f.corners() {
        assert!(c.line_a < c.line_b && usize::from(c.line_b) < f.lines().len());
    }
    // Invalid beams untouched.
    for ((s, r), b) in extractor
        .smoothed()
        .iter()
        .zip(frame.ranges())
        .zip(frame.beams())
    {
        if !b.is_valid() {
            assert_eq!(s.to_bits(), r.to_bits());
        }
    }
    assert_eq!(extractor.smoothed().len(), n);
    assert_eq!(trace.mahalanobis().len(), n - 2);
    // Deterministic, nothing carried over.
    let first = digest(&extractor, &trace);
    let mut again = Extractor::new();
    again.run(
        &lms_core::Frame::for_variant(lms_core::Variant::Fov100Res25),
        &lms_core::ValidParams::DEFAULT,
    );
    let mut trace_again = Trace::new();
    again.run_traced(frame, &valid, &mut trace_again);
    assert_eq!(
        digest(&again, &trace_again),
        first,
        "a previous frame changed the result"
    );
});
