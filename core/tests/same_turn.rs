//! `Params::same_turn_windows` (ALGORITHM.md §10 (a), on by default,
//! docs/DESIGN.md, windows and split before reject): in a 0.5° mode the two
//! mirror turns are offset (platform motion in 13.3 ms); windows of one
//! turn do not break on the offset, windows of §2 do. In 1° modes nothing
//! changes.

use lms_core::test_support::CONSECUTIVE_WINDOWS;
use lms_core::{Extractor, Params, Trace};

mod common;
use common::{interleaved_wall, one_degree_room};

fn breaking_windows(trace: &Trace, tau: f32) -> usize {
    trace
        .mahalanobis()
        .iter()
        .filter(|d| d.is_finite() && **d >= tau)
        .count()
}

#[test]
fn a_turn_offset_breaks_spec_windows_but_not_same_turn_windows() {
    // Offset 2 cm between turns, σ = 1 cm, ripple ±5 mm, incidences up to 75°.
    let frame = interleaved_wall(0.2, 2.0, 0.02, 0.005);
    // No split before reject: the segments are the windows' (§6).
    let spec = CONSECUTIVE_WINDOWS.with_sigma(0.01).with_split_depth(0);
    let turn = spec.with_same_turn_windows(true);
    let mut ex = Extractor::new();
    let mut trace = Trace::new();
    ex.run_traced(&frame, &spec.validate().unwrap(), &mut trace);
    let spec_breaks = breaking_windows(&trace, spec.tau);
    ex.run_traced(&frame, &turn.validate().unwrap(), &mut trace);
    let turn_breaks = breaking_windows(&trace, turn.tau);
    assert!(spec_breaks > 50, "§2 windows broke {spec_breaks} times");
    assert_eq!(
        turn_breaks, 0,
        "same-turn windows broke {turn_breaks} times"
    );
    // One segment over the whole wall, every beam of its windows.
    let segs = ex.features().segments();
    let longest = segs.iter().map(|s| s.points()).max().unwrap_or(0);
    let valid = frame.beams().iter().filter(|b| b.is_valid()).count();
    assert_eq!(longest, valid, "longest segment {longest} of {valid} beams");
}

#[test]
fn one_degree_modes_are_unchanged() {
    let frame = one_degree_room();
    // At the defaults' scale and lines (CONSECUTIVE_WINDOWS has preset
    // v3.1's).
    let spec = CONSECUTIVE_WINDOWS
        .with_iterations(Params::DEFAULT.iterations)
        .with_tau(Params::DEFAULT.tau)
        .with_footprint_choice(Params::DEFAULT.footprint_choice)
        .validate()
        .unwrap();
    let turn = Params::DEFAULT.validate().unwrap();
    assert!(turn.same_turn_windows);
    let mut a = Extractor::new();
    let mut b = Extractor::new();
    let (mut ta, mut tb) = (Trace::new(), Trace::new());
    let fa = a.run_traced(&frame, &spec, &mut ta).clone();
    let fb = b.run_traced(&frame, &turn, &mut tb).clone();
    assert_eq!(fa.lines(), fb.lines());
    assert_eq!(fa.corners(), fb.corners());
    assert_eq!(fa.segments(), fb.segments());
    assert_eq!(fa.edges(), fb.edges());
    assert!(!fa.lines().is_empty());
    let bits = |e: &Trace| {
        e.mahalanobis()
            .iter()
            .map(|d| d.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&ta), bits(&tb));
}
