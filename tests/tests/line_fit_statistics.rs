//! The line fit's reported covariance is honest (ALGORITHM.md §7.3), and its
//! `chi2` rejects a curved surface (§7.4).
//!
//! # Statistics of N = 500 seeded draws of one wall
//!
//! The wall `x·cos α + y·sin α = r` with α = 0.4 rad, r = 2.5 m is seen by
//! the 101 beams 200..=300 of a 361-beam scan (bearings 10°…60°, incidence
//! −13°…37°) with Gaussian range noise sigma = 5 mm, fitted by
//! `lms_core::unstable::fit_line` on the raw ranges.
//!
//! * **NEES** `eᵀ Σ⁻¹ e` with `e = (α̂ − α, r̂ − r)` and Σ the covariance the
//!   fit reports is χ²₂ if Σ is right: mean 2, variance 4. The mean of
//!   N = 500 has standard deviation √(4/500) = 0.089, so [1.7, 2.3] is ±3.4
//!   standard deviations — a draw outside it has probability < 1e-3 for a
//!   correct covariance, while a covariance off by 20 % in scale (mean 1.67
//!   or 2.4) falls outside. The seed is fixed, so the test is deterministic.
//! * **Cramér–Rao**: the empirical standard deviations of α̂ and r̂ against
//!   the bound `sigma²·(JᵀJ)⁻¹` evaluated on the noise-free geometry (by the
//!   independent `f64` reference, `reference::line_crlb`). A sample standard
//!   deviation of N = 500 has a relative standard error of 1/√(2N) = 3.2 %,
//!   so 10 % is ±3 standard errors; the reported covariance is checked
//!   against the same bound within 2 % (it is evaluated at the noisy
//!   solution, a second-order effect here).
//!
//! Measured (printed with `-- --nocapture`): mean NEES 2.020; std α / CRLB
//! = 1.022, std r / CRLB = 0.970; reported / CRLB = 1.000 for both; mean
//! chi2 1.001. The arc: one segment over its ~120 beams, chi2 ≈ 370.

use lms_core::frame::{Frame, Variant};
use lms_core::pipeline::line_fit::Bearings;
use lms_core::unstable::fit_line;
use lms_core::{Extractor, Params, Segment};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use workspace_tests::{reference, synth};

const DRAWS: usize = 500;
const SIGMA: f64 = 0.005;
const ALPHA: f64 = 0.4;
const R: f64 = 2.5;
const FIRST: usize = 200;
const LAST: usize = 300;

/// The core's bearing tables for a variant (as the extractor builds them).
fn tables(variant: Variant) -> (Vec<f32>, Vec<f32>, Vec<f64>) {
    let g = variant.geometry();
    let phi: Vec<f32> = (0..variant.beams()).map(|j| g.bearing(j)).collect();
    let cos = phi.iter().map(|&p| p.cos()).collect();
    let sin = phi.iter().map(|&p| p.sin()).collect();
    (cos, sin, phi.iter().map(|&p| p as f64).collect())
}

#[test]
fn wall_fit_spread_matches_the_reported_covariance_and_the_cramer_rao_bound() {
    let variant = Variant::Fov180Res50;
    let (cos, sin, phi) = tables(variant);
    let bearings = Bearings {
        cos: &cos,
        sin: &sin,
    };
    let truth: Vec<f64> = phi.iter().map(|&p| R / (p - ALPHA).cos()).collect();
    let noise = Normal::new(0.0, SIGMA).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);

    let crlb = reference::line_crlb(ALPHA, R, &phi[FIRST..=LAST], SIGMA);
    let (crlb_sa, crlb_sr) = (crlb[0][0].sqrt(), crlb[1][1].sqrt());

    let mut nees_sum = 0.0;
    let (mut ea, mut er) = (Vec::new(), Vec::new());
    let mut reported_sa = 0.0;
    let mut reported_sr = 0.0;
    let mut chi2_sum = 0.0;
    for _ in 0..DRAWS {
        let ranges: Vec<f32> = truth
            .iter()
            .enumerate()
            .map(|(j, &d)| {
                if (FIRST..=LAST).contains(&j) {
                    (d + noise.sample(&mut rng)) as f32
                } else {
                    0.0
                }
            })
            .collect();
        let frame = Frame::from_metres(variant.geometry(), &ranges).unwrap();
        let line = fit_line(
            bearings,
            frame.ranges(),
            frame.beams(),
            Segment {
                first: FIRST as u16,
                last: LAST as u16,
            },
            SIGMA as f32,
        )
        .expect("a wall fits");
        assert_eq!(line.points as usize, LAST - FIRST + 1);
        let da = line.alpha as f64 - ALPHA;
        let dr = line.r as f64 - R;
        let (a, b, c) = (line.cov.a as f64, line.cov.b as f64, line.cov.c as f64);
        let det = a * c - b * b;
        assert!(
            a > 0.0 && det > 0.0,
            "reported covariance not positive definite: {:?}",
            line.cov
        );
        nees_sum += (c * da * da - 2.0 * b * da * dr + a * dr * dr) / det;
        ea.push(da);
        er.push(dr);
        reported_sa += a.sqrt();
        reported_sr += c.sqrt();
        chi2_sum += line.chi2 as f64;
    }
    let n = DRAWS as f64;
    let nees = nees_sum / n;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let std = |v: &[f64]| {
        let m = mean(v);
        (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() as f64 - 1.0)).sqrt()
    };
    let (sa, sr) = (std(&ea), std(&er));
    let (rep_sa, rep_sr) = (reported_sa / n, reported_sr / n);
    eprintln!(
        "wall: mean NEES {nees:.3}; std alpha {sa:.3e} rad (CRLB {crlb_sa:.3e}, ratio {:.3}; reported {rep_sa:.3e}); \
         std r {sr:.3e} m (CRLB {crlb_sr:.3e}, ratio {:.3}; reported {rep_sr:.3e}); mean chi2 {:.3}; \
         bias alpha {:.2e} r {:.2e}",
        sa / crlb_sa,
        sr / crlb_sr,
        chi2_sum / n,
        mean(&ea),
        mean(&er)
    );
    assert!(
        (1.7..=2.3).contains(&nees),
        "mean NEES {nees}, want 2 ± 0.3"
    );
    assert!(
        (sa / crlb_sa - 1.0).abs() <= 0.10,
        "std alpha {sa} vs CRLB {crlb_sa}"
    );
    assert!(
        (sr / crlb_sr - 1.0).abs() <= 0.10,
        "std r {sr} vs CRLB {crlb_sr}"
    );
    assert!(
        (rep_sa / crlb_sa - 1.0).abs() <= 0.02,
        "reported std alpha {rep_sa} vs CRLB {crlb_sa}"
    );
    assert!(
        (rep_sr / crlb_sr - 1.0).abs() <= 0.02,
        "reported std r {rep_sr} vs CRLB {crlb_sr}"
    );
    // chi2 per draw is χ²₉₉/99: its mean over 500 draws is 1 ± 0.0064.
    assert!(
        (chi2_sum / n - 1.0).abs() < 0.03,
        "mean chi2 {}",
        chi2_sum / n
    );
    // Unbiased within 4 standard errors of the mean.
    assert!(
        mean(&ea).abs() < 4.0 * crlb_sa / n.sqrt(),
        "alpha bias {}",
        mean(&ea)
    );
    assert!(
        mean(&er).abs() < 4.0 * crlb_sr / n.sqrt(),
        "r bias {}",
        mean(&er)
    );
}

/// The arc of radius 1 m, centre 2 m ahead, at 180°/0.5° with range noise
/// `SIGMA` drawn from `seed`.
fn arc_frame(seed: u64) -> Frame {
    let g = Variant::Fov180Res50.geometry();
    let noise = Normal::new(0.0, SIGMA).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let ranges: Vec<f32> = (0..Variant::Fov180Res50.beams())
        .map(|j| {
            synth::cast_circle([2.0, 0.0], 1.0, g.bearing(j) as f64)
                .map_or(0.0, |d| (d + noise.sample(&mut rng)) as f32)
        })
        .collect();
    Frame::from_metres(g, &ranges).unwrap()
}

/// An arc of radius 1 m whose centre is 2 m straight ahead: a strongly curved
/// surface seen over ±30°. Whatever the segmentation makes of it, no line
/// may be accepted across it: a straight fit to the arc's segment has a
/// huge `chi2` (§7.4), and the extractor's accepted lines include none that
/// covers the arc (a short one at a tangent end at most).
#[test]
fn an_arc_is_not_accepted_as_a_line() {
    let variant = Variant::Fov180Res50;
    let params = Params::default();
    let mut arc_beams = 0;
    for seed in 0..5u64 {
        let frame = arc_frame(77 + seed);
        let valid: Vec<usize> = (0..frame.len())
            .filter(|&j| frame.beams()[j].is_valid())
            .collect();
        arc_beams = valid.len();
        let (lo, hi) = (valid[0], *valid.last().unwrap());

        // The whole arc fitted as one line is rejected by chi2.
        let (cos, sin, _) = tables(variant);
        let bearings = Bearings {
            cos: &cos,
            sin: &sin,
        };
        let whole = fit_line(
            bearings,
            frame.ranges(),
            frame.beams(),
            Segment {
                first: lo as u16,
                last: hi as u16,
            },
            SIGMA as f32,
        )
        .expect("the arc's beams can be fitted");
        assert!(
            whole.chi2 > params.max_chi2,
            "arc fitted as a line with chi2 {}",
            whole.chi2
        );

        // The extractor accepts no line on it, and every segment it found
        // there fails chi2 when fitted on its own.
        let mut ex = Extractor::new();
        let f = ex.run(&frame, &params.validate().unwrap());
        let mut seg_chi2 = Vec::new();
        for s in f.segments().iter() {
            let line = fit_line(bearings, frame.ranges(), frame.beams(), *s, SIGMA as f32);
            seg_chi2.push((s.first, s.last, line.map(|l| l.chi2).ok()));
        }
        eprintln!(
            "arc seed {seed}: beams {lo}..={hi}, whole-arc chi2 {:.0}, segments (first, last, chi2) {seg_chi2:?}, \
             lines {}, rejected by chi2 {}",
            whole.chi2,
            f.lines().len(),
            f.stats().rejected_chi2
        );
        // It is the straightness test that rejects it: the smoothing alone
        // does not break the arc into lines (measured: one segment over the
        // whole arc, with same-turn windows up to two 5-beam pieces at its
        // tangent ends beside it); v2's split before reject finds a circle
        // explains it and drops it (`split_rejected`), v1 rejects its line
        // by chi2.
        let s = f.stats();
        assert!(
            s.rejected_chi2 + s.split_rejected >= 1,
            "no line rejected: {s:?}"
        );
        assert_eq!(s.splits, 0, "an arc cut into a polyline: {s:?}");
        // No line across the arc. Same-turn windows (the default since stop
        // 23) may leave a few beams at a tangent end, where the arc meets
        // the beams at grazing incidence, as a segment of their own, and
        // its line can pass: allowed there only, and short (the frequency
        // is bounded by `arcs_leave_lines_at_their_tangent_ends_rarely`).
        for l in f.lines() {
            let at_an_end = usize::from(l.first) <= lo + 10 || usize::from(l.last) + 10 >= hi;
            assert!(
                at_an_end && l.length() < 0.5,
                "line {}..={} ({} m, chi2 {}) across the arc {lo}..={hi}",
                l.first,
                l.last,
                l.length(),
                l.chi2
            );
        }
        // A segment's own line fails chi2, or (a few beams at a tangent end
        // of the arc, which same-turn windows leave as segments of their
        // own) its line is dropped by a counted gate: too uncertain to use
        // (`max_alpha_sd_deg`, with the footprint weights at near-grazing
        // incidence), too short, or part of an arc.
        let passing = seg_chi2
            .iter()
            .filter(|(_, _, fit)| fit.is_some_and(|c| c <= params.max_chi2))
            .count();
        let gated = usize::from(s.rejected_wide + s.rejected_short + s.rejected_arc);
        assert!(
            passing <= gated + f.lines().len(),
            "{passing} segments pass chi2, {gated} lines dropped by the gates: {seg_chi2:?}"
        );
    }
    // ±30° at 0.5°: about 120 beams see the arc.
    assert!(
        (115..=121).contains(&arc_beams),
        "{arc_beams} beams on the arc"
    );
}

/// The arc of [`an_arc_is_not_accepted_as_a_line`] over 200 noise draws: how
/// often a short line at a tangent end is accepted. Measured: 38 of these 200
/// frames at the defaults (the tangent end cut off as a segment of its own;
/// longest 0.38 m), 22 with 30 passes (preset `v3.1`); at 30 passes on
/// another 200 draws 15, against 2 with windows of consecutive beams
/// (`same_turn_windows: false`). On the realistic synthetic scenes the false
/// lines on arcs still fell with same-turn windows (docs/DESIGN.md, windows
/// and split before reject). Asserted: at most 45 of 200 frames, every such
/// line under 0.5 m.
#[test]
fn arcs_leave_lines_at_their_tangent_ends_rarely() {
    let params = Params::default().validate().unwrap();
    let mut ex = Extractor::new();
    let (mut frames_with_lines, mut longest) = (0, 0.0f32);
    for seed in 0..200u64 {
        let f = ex.run(&arc_frame(1000 + seed), &params);
        frames_with_lines += usize::from(!f.lines().is_empty());
        longest = f.lines().iter().map(|l| l.length()).fold(longest, f32::max);
    }
    eprintln!("arc: lines in {frames_with_lines} of 200 frames, longest {longest} m");
    assert!(
        frames_with_lines <= 45,
        "lines on the arc in {frames_with_lines} of 200 frames"
    );
    assert!(longest < 0.5, "a line of {longest} m on the arc");
}
