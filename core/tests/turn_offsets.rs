//! The turns' offsets in the fits' χ² (`Params::turn_offsets`, on by
//! default, docs/ALGORITHM.md): the two mirror turns of a 0.5° scan see a
//! wall a little apart (the platform moves in 13.3 ms); each turn's mean
//! residual is taken out of `Σe²`, with one degree of freedom less. Checked
//! against an independent f64 computation, and on a whole scan.

use lms_core::pipeline::line_fit::{fit_piece, residual_dof, Bearings, RawScan};
use lms_core::test_support::Rng;
use lms_core::{Beam, Extractor, Params, Segment};

mod common;
use common::interleaved_wall;

/// Range noise σ (m).
const SIGMA: f32 = 0.01;

#[test]
fn degrees_of_freedom() {
    assert_eq!(residual_dof(100, 1), 98.0);
    assert_eq!(residual_dof(100, 2), 97.0);
    assert_eq!(residual_dof(100, 4), 95.0);
    // Too few beams per turn, or no interleave: §7's m − 2.
    assert_eq!(residual_dof(4, 2), 2.0);
    assert_eq!(residual_dof(5, 2), 2.0);
    assert_eq!(residual_dof(100, 5), 98.0);
    assert_eq!(residual_dof(3, 1), 1.0);
}

#[test]
fn chi2_without_the_turns_offset_matches_an_f64_reference() {
    // The wall x·cos α + y·sin α = r seen at 0.5°, odd beams 15 mm nearer.
    let (alpha, r, offset) = (0.3f64, 2.5f64, 0.015f64);
    let phi: Vec<f64> = (0..121)
        .map(|k| -0.5 + f64::from(k) * 0.5f64.to_radians())
        .collect();
    let mut rng = Rng(7);
    let ranges: Vec<f32> = phi
        .iter()
        .enumerate()
        .map(|(j, p)| {
            let shift = if j % 2 == 1 { offset } else { 0.0 };
            ((r - shift) / (p - alpha).cos() + f64::from(SIGMA) * rng.normal()) as f32
        })
        .collect();
    let cos: Vec<f32> = phi.iter().map(|p| p.cos() as f32).collect();
    let sin: Vec<f32> = phi.iter().map(|p| p.sin() as f32).collect();
    let beams = vec![Beam::Valid; ranges.len()];
    let scan = |turns| RawScan {
        bearings: Bearings {
            cos: &cos,
            sin: &sin,
        },
        ranges: &ranges,
        beams: &beams,
        max_range: f32::INFINITY,
        footprint: 0.0,
        turns,
    };
    let last = (ranges.len() - 1) as u16;
    let one = fit_piece(&scan(1), Segment { first: 0, last }, SIGMA).unwrap();
    let two = fit_piece(&scan(2), Segment { first: 0, last }, SIGMA).unwrap();
    // The line and its covariance are the same fit.
    assert_eq!((one.alpha, one.r, one.cov), (two.alpha, two.r, two.cov));
    // f64: residuals about the fitted line, each turn's mean taken out.
    let e: Vec<f64> = phi
        .iter()
        .zip(&ranges)
        .map(|(p, &d)| f64::from(d) - f64::from(one.r) / (p - f64::from(one.alpha)).cos())
        .collect();
    let mean = |t: usize| {
        let v: Vec<f64> = e.iter().skip(t).step_by(2).copied().collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (m0, m1) = (mean(0), mean(1));
    let within: f64 = e
        .iter()
        .enumerate()
        .map(|(j, &x)| (x - if j % 2 == 0 { m0 } else { m1 }).powi(2))
        .sum();
    let m = e.len() as f64;
    let s2 = f64::from(SIGMA).powi(2);
    let reference = within / (s2 * (m - 3.0));
    let all = e.iter().map(|x| x * x).sum::<f64>() / (s2 * (m - 2.0));
    println!(
        "χ² per dof: one turn {} (f64 {all:.4}), turns apart {} (f64 {reference:.4})",
        one.chi2, two.chi2
    );
    assert!((f64::from(one.chi2) - all).abs() < 1e-3 * all);
    assert!((f64::from(two.chi2) - reference).abs() < 1e-3 * reference);
    // 7.5 mm either side of the mean line is (0.75 σ)² per beam more.
    assert!(all > 1.3 && reference < 1.3, "{all} {reference}");
}

#[test]
fn a_wall_two_turns_apart_stays_one_line() {
    // Offset 2 cm between the turns, ±5 mm ripple, incidences up to 75°.
    let frame = interleaved_wall(0.2, 2.0, 0.02, 0.005);
    let run = |turn_offsets| {
        // Every line keeps its footprint-weighted fit (§7.9 off): the χ²
        // the straightness test, the gate and the merges see.
        let params = Params::DEFAULT
            .with_sigma(SIGMA)
            .with_turn_offsets(turn_offsets)
            .with_footprint_choice(false);
        let mut ex = Extractor::new();
        let f = ex.run(&frame, &params.validate().unwrap());
        f.lines()
            .iter()
            .map(|l| (l.points, l.chi2))
            .collect::<Vec<_>>()
    };
    let (apart, spec) = (run(true), run(false));
    println!("turns' offsets out: {apart:?}\n§7 as written: {spec:?}");
    let valid = frame.beams().iter().filter(|b| b.is_valid()).count() as u16;
    assert_eq!(apart.len(), 1, "{apart:?}");
    assert_eq!(apart[0].0, valid);
    assert!(apart[0].1 < 0.5, "χ² per dof {}", apart[0].1);
    // §7 as written: the offset's (1 σ)² per beam stays in χ² (here the
    // wall still passes the straightness test, at 1.0 per dof).
    let worst = spec.iter().map(|l| l.1).fold(0.0f32, f32::max);
    assert!(worst > 5.0 * apart[0].1, "{spec:?}");
}
