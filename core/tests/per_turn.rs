//! `Params::per_turn` (ALGORITHM.md §10 proposal (d),
//! docs/ALGORITHM.md Appendix A): in the interleaved modes each mirror
//! turn runs through §2–8 as a scan of its own and the turns' lines of one
//! wall are fused; 1° modes are unchanged bit for bit.

use lms_core::maths::Sym2;
use lms_core::pipeline::turns::{fuse, interleaved_turns, turn_frame, Turn};
use lms_core::test_support::CONSECUTIVE_WINDOWS;
use lms_core::{Extractor, Frame, Geometry, Invalid, Line, Params, Trace, Variant};
use proptest::prelude::*;

mod common;
use common::{interleaved_wall, one_degree_room};

fn per_turn(p: Params) -> Params {
    p.with_per_turn(true)
}

#[test]
fn interleaved_modes_have_their_turns() {
    let turns = |v: Variant| interleaved_turns(v.geometry().step);
    assert_eq!(turns(Variant::Fov180Res100), 1);
    assert_eq!(turns(Variant::Fov100Res100), 1);
    assert_eq!(turns(Variant::Fov180Res50), 2);
    assert_eq!(turns(Variant::Fov100Res50), 2);
    assert_eq!(turns(Variant::Fov100Res25), 4);
    assert_eq!(interleaved_turns(0.3f32.to_radians()), 1);
}

#[test]
fn a_turn_is_every_kth_beam_with_its_status() {
    let mut frame = Frame::for_variant(Variant::Fov180Res50);
    for j in 0..frame.len() {
        frame.set_metres(j, 1.0 + j as f32 * 0.01);
    }
    frame.set_invalid(7, Invalid::Dazzle);
    let odd = turn_frame(&frame, Turn { index: 1, of: 2 }).unwrap();
    assert_eq!(odd.len(), 180);
    let g = frame.geometry();
    assert_eq!(odd.geometry().step, 2.0 * g.step);
    assert_eq!(odd.geometry().first_bearing, g.first_bearing + g.step);
    assert_eq!(odd.ranges()[4], frame.ranges()[9]);
    assert_eq!(odd.beams()[3], frame.beams()[7]);
    assert_eq!(
        turn_frame(&frame, Turn { index: 0, of: 2 }).unwrap().len(),
        181
    );
}

#[test]
fn an_offset_wall_is_one_line_per_turn_and_broken_at_once() {
    // 2 cm between the turns, σ = 1 cm, ripple ±5 mm, incidences up to 75°.
    let frame = interleaved_wall(0.2, 2.0, 0.02, 0.005);
    // The windows of §2–6 over both turns.
    let spec = CONSECUTIVE_WINDOWS.with_sigma(0.01);
    let valid = frame.beams().iter().filter(|b| b.is_valid()).count();
    let mut ex = Extractor::new();
    let whole = ex.run(&frame, &spec.validate().unwrap()).clone();
    let covered = |l: &Line| usize::from(l.last - l.first) + 1;
    let longest = whole.lines().iter().map(covered).max().unwrap_or(0);
    assert!(
        longest + 50 < valid,
        "the whole scan at once: longest line {longest} of {valid} beams"
    );
    // Same-turn windows (the defaults) do not break it either.
    let same_turn = spec.with_same_turn_windows(true);
    let f = ex.run(&frame, &same_turn.validate().unwrap()).clone();
    assert_eq!(f.lines().len(), 1, "{:?}", f.lines());
    assert!(covered(&f.lines()[0]) + 8 >= valid);
    let f = ex.run(&frame, &per_turn(spec).validate().unwrap()).clone();
    assert_eq!(f.lines().len(), 1, "{:?}", f.lines());
    let l = f.lines()[0];
    assert!(covered(&l) + 8 >= valid, "{} of {valid} beams", covered(&l));
    // Both turns' lines fused: α of the wall, r midway between the turns.
    assert!((l.alpha - 0.2).abs() < 0.2f32.to_radians(), "α {}", l.alpha);
    assert!((l.r - 1.99).abs() < 0.004, "r {}", l.r);
    assert!(usize::from(l.points) + 8 >= valid);
    assert!(f.stats().merges >= 1);
    assert_eq!(ex.smoothed().len(), frame.len());
}

#[test]
fn d_is_traced_at_the_window_of_the_same_middle_beam() {
    let frame = interleaved_wall(0.2, 2.0, 0.02, 0.005);
    let params = per_turn(Params::DEFAULT.with_sigma(0.01))
        .validate()
        .unwrap();
    let mut ex = Extractor::new();
    let mut trace = Trace::new();
    let mut calls = Vec::new();
    ex.run_observed(&frame, &params, &mut trace, |pass, d, r| {
        calls.push((pass, d.len(), r.len()));
    });
    // Once, after the last pass, with the whole scan's windows and beams.
    assert_eq!(
        calls,
        vec![(params.iterations, frame.len() - 2, frame.len())]
    );
    // Windows whose three beams (of one turn: middle ± 2) are on the wall
    // have a finite D; windows touching the cleared beams +inf.
    let d = trace.mahalanobis();
    let valid = |j: usize| frame.beams()[j].is_valid();
    for (w, x) in d.iter().enumerate() {
        let mid = w + 1;
        let turn_ok =
            mid >= 2 && mid + 2 < frame.len() && valid(mid - 2) && valid(mid) && valid(mid + 2);
        assert_eq!(x.is_finite(), turn_ok, "window {w}: D {x}");
    }
    // The turns do not break on their own offset (σ = 1 cm, ripple ±5 mm).
    let breaks = d
        .iter()
        .filter(|x| x.is_finite() && **x >= params.tau)
        .count();
    assert!(breaks < 10, "{breaks} breaking windows");
}

#[test]
fn one_degree_modes_are_unchanged() {
    let frame = one_degree_room();
    let mut a = Extractor::new();
    let mut b = Extractor::new();
    let fa = a.run(&frame, &Params::DEFAULT.validate().unwrap()).clone();
    let fb = b
        .run(&frame, &per_turn(Params::DEFAULT).validate().unwrap())
        .clone();
    assert!(!fa.lines().is_empty());
    assert_eq!(fa.lines(), fb.lines());
    assert_eq!(fa.corners(), fb.corners());
    assert_eq!(fa.segments(), fb.segments());
    assert_eq!(fa.edges(), fb.edges());
    assert_eq!(fa.stats(), fb.stats());
}

fn line(alpha: f32, r: f32, cov: Sym2, first: u16, last: u16) -> Line {
    let (c, s) = (libm::cosf(alpha), libm::sinf(alpha));
    let point = |t: f32| [r * c - t * s, r * s + t * c];
    Line {
        alpha,
        r,
        cov,
        first,
        last,
        points: last - first + 1,
        chi2: 1.0,
        endpoints: [point(-1.0), point(1.0)],
    }
}

#[test]
fn fusion_is_the_information_weighted_mean() {
    let p = line(
        0.30,
        2.00,
        Sym2 {
            a: 4e-6,
            b: 1e-6,
            c: 9e-6,
        },
        10,
        40,
    );
    let q = line(
        0.31,
        2.02,
        Sym2 {
            a: 1e-6,
            b: -2e-7,
            c: 4e-6,
        },
        11,
        41,
    );
    let f = fuse(&p, &q).unwrap();
    // f64 reference of Σ = (Σp⁻¹ + Σq⁻¹)⁻¹, x = Σ(Σp⁻¹xp + Σq⁻¹xq).
    let inv = |a: f64, b: f64, c: f64| {
        let d = a * c - b * b;
        [c / d, -b / d, a / d]
    };
    let ip = inv(4e-6, 1e-6, 9e-6);
    let iq = inv(1e-6, -2e-7, 4e-6);
    let s = inv(ip[0] + iq[0], ip[1] + iq[1], ip[2] + iq[2]);
    let v0 = ip[0] * 0.30 + ip[1] * 2.00 + iq[0] * 0.31 + iq[1] * 2.02;
    let v1 = ip[1] * 0.30 + ip[2] * 2.00 + iq[1] * 0.31 + iq[2] * 2.02;
    let (alpha, r) = (s[0] * v0 + s[1] * v1, s[1] * v0 + s[2] * v1);
    // f32 of an information sum of ~1e6-sized terms: 1e-5 rad / m.
    assert!(
        (f64::from(f.alpha) - alpha).abs() < 1e-5,
        "{} {alpha}",
        f.alpha
    );
    assert!((f64::from(f.r) - r).abs() < 1e-5, "{} {r}", f.r);
    assert!((f64::from(f.cov.a) - s[0]).abs() < 1e-3 * s[0]);
    assert!((f64::from(f.cov.c) - s[2]).abs() < 1e-3 * s[2]);
    assert!(f.cov.a < q.cov.a && f.cov.c < q.cov.c);
    assert_eq!((f.first, f.last, f.points), (10, 41, 62));
    // The endpoints lie on the fused line.
    for e in f.endpoints {
        let d = e[0] * libm::cosf(f.alpha) + e[1] * libm::sinf(f.alpha) - f.r;
        assert!(d.abs() < 1e-5, "{d}");
    }
}

#[test]
fn fusion_unwraps_alpha_across_pi() {
    let cov = Sym2 {
        a: 1e-6,
        b: 0.0,
        c: 1e-6,
    };
    let p = line(std::f32::consts::PI - 0.001, 1.0, cov, 0, 10);
    let q = line(-std::f32::consts::PI + 0.001, 1.0, cov, 1, 11);
    let f = fuse(&p, &q).unwrap();
    assert!(f.alpha.abs() > std::f32::consts::PI - 1e-4, "{}", f.alpha);
    assert!(fuse(
        &p,
        &line(
            0.0,
            1.0,
            Sym2 {
                a: 0.0,
                b: 0.0,
                c: 0.0
            },
            0,
            1
        )
    )
    .is_none());
}

fn interleaved_geometry() -> impl Strategy<Value = Geometry> {
    prop_oneof![
        Just(Variant::Fov180Res50.geometry()),
        Just(Variant::Fov100Res50.geometry()),
        Just(Variant::Fov100Res25.geometry()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Whatever the ranges: no panic, lines in scan order inside the frame
    /// with positive definite covariances, edge points inside the frame,
    /// corners naming existing lines, invalid beams untouched.
    #[test]
    fn per_turn_keeps_the_features_well_formed(
        geometry in interleaved_geometry(),
        values in prop::collection::vec(prop_oneof![
            4 => 0.3f32..20.0,
            1 => Just(0.0f32),
            1 => Just(f32::NAN),
        ], 401),
        wall in (0.5f32..6.0, -3.0f32..3.0, 0.0f32..0.03, 0.0f32..0.03),
        sigma in 0.002f32..0.05,
    ) {
        let n = Variant::ALL
            .iter()
            .find(|v| v.geometry() == geometry)
            .map_or(361, |v| v.beams());
        let mut frame = Frame::new(geometry, n).unwrap();
        let (r, alpha, offset, ripple) = wall;
        for (j, &random) in values.iter().enumerate().take(n) {
            let c = libm::cosf(geometry.bearing(j) - alpha);
            // Half the scan on a wall with a turn offset, half random.
            let v = if j < n / 2 && c > 0.2 {
                (r - if j % 2 == 1 { offset } else { 0.0 }) / c
                    + ripple * (((j * 7919) % 11) as f32 / 5.0 - 1.0)
            } else {
                random
            };
            frame.set_metres(j, v);
        }
        let params = per_turn(Params::DEFAULT.with_sigma(sigma)).validate().unwrap();
        let mut ex = Extractor::new();
        let f = ex.run(&frame, &params).clone();
        for w in f.lines().windows(2) {
            prop_assert!((w[0].first, w[0].last) <= (w[1].first, w[1].last));
        }
        for l in f.lines() {
            prop_assert!(l.first <= l.last && usize::from(l.last) < n, "{:?}", l);
            prop_assert!(l.cov.a > 0.0 && l.cov.c > 0.0 && l.cov.det() > 0.0, "{:?}", l.cov);
            prop_assert!(l.r >= 0.0 && l.alpha.is_finite());
        }
        for e in f.edges() {
            prop_assert!(usize::from(e) < n);
        }
        for c in f.corners() {
            prop_assert!(usize::from(c.line_b) < f.lines().len());
        }
        let smoothed = ex.smoothed();
        prop_assert_eq!(smoothed.len(), n);
        for ((s, r), b) in smoothed.iter().zip(frame.ranges()).zip(frame.beams()) {
            if !b.is_valid() {
                prop_assert_eq!(s.to_bits(), r.to_bits());
            }
        }
    }
}
