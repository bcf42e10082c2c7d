//! The footprint-weighted fits (`Params::footprint`, ALGORITHM.md §10 (f))
//! and the merge across rejected segments (`Params::bridge_merge`, §10 (e)),
//! both on by default (docs/ALGORITHM.md §7.2, §7.6).

use lms_core::pipeline::line_fit::{fit_line, fit_piece, Bearings, RawScan};
use lms_core::test_support::Rng;
use lms_core::{Extractor, Frame, Line, Params, Segment, Variant};

/// κ of the tests (rad): the default.
const KAPPA: f32 = lms_core::params::DEFAULT_FOOTPRINT;
/// Range noise σ (m).
const SIGMA: f32 = 0.01;
/// The wall `x·cos α + y·sin α = r` of the fit tests.
const WALL: (f64, f64) = (0.3, 2.0);
/// Its beams: 0.5° steps from −75° to +75° of incidence.
const INCIDENCE_DEG: f64 = 75.0;

/// Bearings (rad) of the wall's beams and their true ranges (m).
fn wall_beams() -> (Vec<f64>, Vec<f64>) {
    let (alpha, r) = WALL;
    let half = (INCIDENCE_DEG / 0.5) as i32;
    let phi: Vec<f64> = (-half..=half)
        .map(|k| alpha + f64::from(k) * 0.5f64.to_radians())
        .collect();
    let d = phi.iter().map(|p| r / (p - alpha).cos()).collect();
    (phi, d)
}

/// The ranges with the footprint model's noise, `σ_j² = σ² + (κ·d·tan θ)²`.
fn noisy(d: &[f64], phi: &[f64], rng: &mut Rng) -> Vec<f32> {
    d.iter()
        .zip(phi)
        .map(|(&d, &p)| {
            let t = f64::from(KAPPA) * d * (p - WALL.0).tan();
            let sd = (f64::from(SIGMA).powi(2) + t * t).sqrt();
            (d + sd * rng.normal()) as f32
        })
        .collect()
}

/// The weighted fit of §10 (f) on `ranges` at `phi`.
fn weighted(phi: &[f64], ranges: &[f32], kappa: f32) -> Line {
    let cos: Vec<f32> = phi.iter().map(|p| p.cos() as f32).collect();
    let sin: Vec<f32> = phi.iter().map(|p| p.sin() as f32).collect();
    let beams = vec![lms_core::Beam::Valid; ranges.len()];
    let scan = RawScan {
        bearings: Bearings {
            cos: &cos,
            sin: &sin,
        },
        ranges,
        beams: &beams,
        max_range: f32::INFINITY,
        footprint: kappa,
        turns: 1,
    };
    fit_piece(
        &scan,
        Segment {
            first: 0,
            last: (ranges.len() - 1) as u16,
        },
        SIGMA,
    )
    .unwrap()
}

/// Independent f64 reference: iteratively reweighted Gauss–Newton on
/// `d_j = r / cos(φ_j − α)` with weights `σ²/σ_j²` at the current α, to
/// convergence; `(α, r, [cov αα, αr, rr], chi2)`.
fn reference(phi: &[f64], ranges: &[f32]) -> (f64, f64, [f64; 3], f64) {
    let (mut alpha, mut r) = (WALL.0 + 0.01, WALL.1 + 0.01);
    let (k, s2) = (
        f64::from(KAPPA) / f64::from(SIGMA),
        f64::from(SIGMA).powi(2),
    );
    let normal_eq = |alpha: f64, r: f64| {
        let (mut a, mut b, mut c, mut g0, mut g1, mut e2) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (&p, &d) in phi.iter().zip(ranges) {
            let d = f64::from(d);
            let (cd, sd) = ((p - alpha).cos(), (p - alpha).sin());
            let w = 1.0 / (1.0 + (k * d * sd / cd).powi(2));
            let e = d - r / cd;
            let (ja, jr) = (-r * sd / (cd * cd), 1.0 / cd);
            a += w * ja * ja;
            b += w * ja * jr;
            c += w * jr * jr;
            g0 += w * ja * e;
            g1 += w * jr * e;
            e2 += w * e * e;
        }
        (a, b, c, g0, g1, e2)
    };
    for _ in 0..100 {
        let (a, b, c, g0, g1, _) = normal_eq(alpha, r);
        let det = a * c - b * b;
        alpha += (c * g0 - b * g1) / det;
        r += (a * g1 - b * g0) / det;
    }
    let (a, b, c, _, _, e2) = normal_eq(alpha, r);
    let det = a * c - b * b;
    let cov = [s2 * c / det, -s2 * b / det, s2 * a / det];
    (alpha, r, cov, e2 / (s2 * (phi.len() as f64 - 2.0)))
}

#[test]
fn the_weighted_fit_agrees_with_an_f64_reference() {
    let (phi, d) = wall_beams();
    let mut rng = Rng(0x5eed_f007);
    for draw in 0..20 {
        let ranges = noisy(&d, &phi, &mut rng);
        let line = weighted(&phi, &ranges, KAPPA);
        let (alpha, r, cov, chi2) = reference(&phi, &ranges);
        let rel = |x: f32, y: f64| (f64::from(x) - y).abs() / y.abs();
        assert!(
            (f64::from(line.alpha) - alpha).abs() < 2e-6,
            "draw {draw}: α {} vs {alpha}",
            line.alpha
        );
        assert!(
            (f64::from(line.r) - r).abs() < 2e-6,
            "draw {draw}: r {} vs {r}",
            line.r
        );
        // The off-diagonal term relative to √(αα·rr): it nearly cancels.
        let scale = [cov[0], (cov[0] * cov[2]).sqrt(), cov[2]];
        for (k, (&x, &y)) in [line.cov.a, line.cov.b, line.cov.c]
            .iter()
            .zip(&cov)
            .enumerate()
        {
            let err = (f64::from(x) - y).abs() / scale[k];
            assert!(err < 1e-3, "draw {draw}: cov[{k}] {x} vs {y}");
        }
        assert!(
            rel(line.chi2, chi2) < 1e-3,
            "draw {draw}: chi2 {} vs {chi2}",
            line.chi2
        );
    }
}

#[test]
fn without_the_footprint_the_fit_is_section_7_bit_for_bit() {
    let (phi, d) = wall_beams();
    let mut rng = Rng(7);
    let ranges = noisy(&d, &phi, &mut rng);
    let cos: Vec<f32> = phi.iter().map(|p| p.cos() as f32).collect();
    let sin: Vec<f32> = phi.iter().map(|p| p.sin() as f32).collect();
    let beams = vec![lms_core::Beam::Valid; ranges.len()];
    let bearings = Bearings {
        cos: &cos,
        sin: &sin,
    };
    let plain = fit_line(
        bearings,
        &ranges,
        &beams,
        Segment {
            first: 0,
            last: (ranges.len() - 1) as u16,
        },
        SIGMA,
    )
    .unwrap();
    assert_eq!(weighted(&phi, &ranges, 0.0), plain);
    assert_ne!(weighted(&phi, &ranges, KAPPA), plain);
}

/// On walls with the footprint noise the weighted covariance is honest
/// (NEES of (α, r) near its χ²₂ mean 2) and α is at least as precise;
/// every beam at σ is over-confident.
#[test]
fn the_weighted_covariance_is_honest_under_footprint_noise() {
    const DRAWS: usize = 400;
    let (phi, d) = wall_beams();
    let mut rng = Rng(0xf00_7f00);
    let nees = |l: &Line| {
        let (ea, er) = (f64::from(l.alpha) - WALL.0, f64::from(l.r) - WALL.1);
        let (a, b, c) = (f64::from(l.cov.a), f64::from(l.cov.b), f64::from(l.cov.c));
        (c * ea * ea - 2.0 * b * ea * er + a * er * er) / (a * c - b * b)
    };
    let (mut nees_w, mut nees_u, mut sa_w, mut sa_u) = (0.0, 0.0, 0.0, 0.0);
    for _ in 0..DRAWS {
        let ranges = noisy(&d, &phi, &mut rng);
        let (w, u) = (weighted(&phi, &ranges, KAPPA), weighted(&phi, &ranges, 0.0));
        nees_w += nees(&w) / DRAWS as f64;
        nees_u += nees(&u) / DRAWS as f64;
        sa_w += (f64::from(w.alpha) - WALL.0).powi(2) / DRAWS as f64;
        sa_u += (f64::from(u.alpha) - WALL.0).powi(2) / DRAWS as f64;
    }
    eprintln!(
        "mean NEES weighted {nees_w:.2}, unweighted {nees_u:.2}; rms Δα weighted {:.4}°, unweighted {:.4}°",
        sa_w.sqrt().to_degrees(),
        sa_u.sqrt().to_degrees()
    );
    // Standard error of the mean of χ²₂ over 400 draws: 0.1.
    assert!((1.6..=2.4).contains(&nees_w), "weighted NEES {nees_w}");
    assert!(
        nees_u > 4.0,
        "unweighted NEES {nees_u}: the footprint should show"
    );
    assert!(sa_w <= sa_u, "weighted rms Δα above the unweighted one");
}

/// A 0.5° scan of a wall `r` m ahead (normal along the middle beam), its
/// beams within ±60° of incidence; `patch` adds ±`zigzag` m to alternate
/// beams of a run (a stair-stepped stretch whose segment is rejected).
fn wall_scan(r: [f32; 2], split_at: usize, patch: std::ops::Range<usize>, zigzag: f32) -> Frame {
    let mut frame = Frame::for_variant(Variant::Fov180Res50);
    let mut rng = Rng(99);
    for j in 0..frame.len() {
        let phi = frame.geometry().bearing(j);
        let c = libm::cosf(phi);
        if c < 0.5 {
            frame.set_metres(j, 0.0);
            continue;
        }
        let wall = if j < split_at { r[0] } else { r[1] };
        let mut d = wall / c + 0.004 * rng.normal() as f32;
        if patch.contains(&j) {
            d += if j % 2 == 0 { zigzag } else { -zigzag };
        }
        frame.set_metres(j, d);
    }
    frame
}

fn lines(frame: &Frame, params: Params) -> Vec<Line> {
    let params = params.with_sigma(0.005).validate().unwrap();
    Extractor::new().run(frame, &params).lines().to_vec()
}

#[test]
fn a_wall_is_one_line_across_a_rejected_stretch() {
    let frame = wall_scan([2.0, 2.0], 0, 170..190, 0.02);
    let v2 = lines(&frame, Params::V2);
    let bridged = lines(&frame, Params::default());
    assert_eq!(v2.len(), 2, "v2: {v2:?}");
    assert!(v2[0].last <= 171 && v2[1].first >= 188, "v2: {v2:?}");
    assert_eq!(bridged.len(), 1, "defaults: {bridged:?}");
    let l = bridged[0];
    assert!(l.first <= v2[0].first && l.last >= v2[1].last, "{l:?}");
    assert!((l.r - 2.0).abs() < 0.005 && l.alpha.abs() < 0.005, "{l:?}");
}

#[test]
fn a_step_in_a_wall_is_not_bridged() {
    // Two parallel walls 0.1 m apart, the far one behind a jump: two lines.
    let frame = wall_scan([2.0, 2.1], 181, 0..0, 0.0);
    for params in [Params::V2, Params::default()] {
        let ls = lines(&frame, params);
        assert_eq!(ls.len(), 2, "{ls:?}");
        assert!(
            (ls[0].r - 2.0).abs() < 0.01 && (ls[1].r - 2.1).abs() < 0.01,
            "{ls:?}"
        );
    }
}
