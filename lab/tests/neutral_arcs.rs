//! Lines on curved walls: an unmatched line with half of its beams or more
//! on arcs is neutral (left out of FalsePos) if the noise-free curve over
//! its beams lies within χ²₁ 95 % of a straight line, false beyond.
//!
//! The geometry is a circle centred on the sensor over the beams 100..=140
//! (bearings −40° … −20°, half-width w = 10° about −30°): every noise-free
//! range is the radius R. By symmetry the orthogonal least-squares line is
//! normal to the middle bearing at r = R·mean(cos ψ_j) (ψ_j the bearing
//! from the middle), and the largest range deviation is at the ends:
//! `r / cos w − R`. The sagitta of the arc is `R·(1 − cos w)`; the line
//! through the hits lies between chord and tangent, about 2/3 of the
//! sagitta from the ends.

use lms_core::maths::Sym2;
use lms_core::{Beam, Line};
use lms_lab::metrics::{
    classify_unmatched, orthogonal_fit, scan_truth, score_lines, straightness_chi2, Gates,
    ScanTruth, Tally, TruePiece, Unmatched, NEUTRAL_CHI2,
};
use lms_scene::{Bearings, Point, Pose, Scene};

const SIGMA: f64 = 0.01;
const FIRST: usize = 100;
const LAST: usize = 140;
/// Half-width of the arc's beams (rad).
const W: f64 = 10.0 * std::f64::consts::PI / 180.0;

fn bearings() -> Vec<f64> {
    Bearings::lms_180_half_deg().iter().collect()
}

fn piece(alpha: f64, r: f64, first: usize, last: usize) -> TruePiece {
    TruePiece {
        alpha,
        r,
        first,
        last,
        beams: last + 1 - first,
        length: 1.0,
        detectable: true,
        resolvable: true,
    }
}

/// A wall over beams 0..=99, a circle of `radius` about the sensor over
/// FIRST..=LAST, a wall over 141..=360.
fn truth_with_arc(radius: f64) -> ScanTruth {
    let b = bearings();
    let right = (-1.5, 2.0);
    let left = (0.6, 2.5);
    let wall = |(a, r): (f64, f64), phi: f64| r / (phi - a).cos();
    let ranges = (0..361)
        .map(|j| {
            Some(match j {
                0..=99 => wall(right, b[j]),
                FIRST..=LAST => radius,
                _ => wall(left, b[j]),
            })
        })
        .collect();
    ScanTruth {
        pieces: vec![
            piece(right.0, right.1, 0, 99),
            piece(left.0, left.1, 141, 360),
        ],
        corners: vec![],
        on_arc: (0..361).map(|j| (FIRST..=LAST).contains(&j)).collect(),
        bearings: b,
        ranges,
        incidence: vec![0.0; 361],
    }
}

fn line(alpha: f64, r: f64, first: u16, last: u16) -> Line {
    Line {
        alpha: alpha as f32,
        r: r as f32,
        cov: Sym2 {
            a: 1e-4,
            b: 0.0,
            c: 1e-4,
        },
        first,
        last,
        points: last - first + 1,
        chi2: 1.0,
        endpoints: [[0.0; 2]; 2],
    }
}

/// The line the extractor would fit to the arc's beams (normal along −30°).
fn arc_line(radius: f64) -> Line {
    line(-30f64.to_radians(), radius, FIRST as u16, LAST as u16)
}

/// The largest (deviation / σ)² by the symmetry argument of the module docs.
fn by_hand(radius: f64, sigma: f64) -> f64 {
    let n = LAST - FIRST + 1;
    let mean_cos = (0..n)
        .map(|k| ((k as f64 - 20.0) * 0.5f64.to_radians()).cos())
        .sum::<f64>()
        / n as f64;
    let r = radius * mean_cos;
    let ends = r / W.cos() - radius;
    let middle = radius - r;
    (ends.abs().max(middle.abs()) / sigma).powi(2)
}

fn sagitta(radius: f64) -> f64 {
    radius * (1.0 - W.cos())
}

fn valid() -> Vec<Beam> {
    vec![Beam::Valid; 361]
}

/// The room's two walls matched exactly, and `extra`.
fn scored(truth: &ScanTruth, extra: Line, gates: &Gates) -> (lms_lab::metrics::LineScore, Tally) {
    let lines = vec![line(-1.5, 2.0, 0, 99), extra, line(0.6, 2.5, 141, 360)];
    let s = score_lines(truth, &lines, &valid(), SIGMA, gates);
    let mut t = Tally::default();
    t.add(&s, &Default::default(), 0, 0.0);
    (s, t)
}

#[test]
fn the_orthogonal_fit_of_points_on_a_line_is_that_line() {
    let (alpha, r) = (0.7f64, 2.3);
    let pts = (0..10).map(|k| {
        let t = k as f64 - 4.0;
        (
            r * alpha.cos() - t * alpha.sin(),
            r * alpha.sin() + t * alpha.cos(),
        )
    });
    let (a, d) = orthogonal_fit(pts);
    assert!(
        (a - alpha).abs() < 1e-12 && (d - r).abs() < 1e-12,
        "{a} {d}"
    );
}

#[test]
fn the_deviation_from_the_fitted_line_is_the_hand_computed_one() {
    for radius in [1.0, 1.646, 2.172, 3.0] {
        let truth = truth_with_arc(radius);
        let chi2 = straightness_chi2(&truth, FIRST..=LAST, SIGMA, 0.0).unwrap();
        let want = by_hand(radius, SIGMA);
        assert!(
            (chi2 - want).abs() < 1e-6 * want,
            "R {radius}: {chi2} vs {want}"
        );
        // About (2/3 of the sagitta / σ)².
        let approx = (2.0 / 3.0 * sagitta(radius) / SIGMA).powi(2);
        assert!((chi2 / approx - 1.0).abs() < 0.05, "{chi2} vs {approx}");
    }
}

#[test]
fn a_line_on_a_gentle_arc_is_neutral() {
    // R = 1 m: sagitta 15.2 mm = 1.52σ < 1.96σ; largest deviation ≈ 1.0σ.
    let radius = 1.0;
    assert!(sagitta(radius) < 1.96 * SIGMA);
    let truth = truth_with_arc(radius);
    let (s, t) = scored(&truth, arc_line(radius), &Gates::default());
    assert_eq!((s.matched, s.neutral_arc, s.fp_arc), (2, 1, 0));
    let sum = t.summary();
    // Neutral lines leave both counts: 0 false of 2.
    assert_eq!(sum.false_pos, 0.0);
    assert!((sum.neutral - 1.0 / 3.0).abs() < 1e-12);
}

#[test]
fn a_line_on_a_strongly_curved_arc_is_false() {
    // R = 3 m: sagitta 45.6 mm = 4.6σ; largest deviation ≈ 3.0σ, χ² ≈ 9.2.
    let radius = 3.0;
    let truth = truth_with_arc(radius);
    let (s, t) = scored(&truth, arc_line(radius), &Gates::default());
    assert_eq!((s.matched, s.neutral_arc, s.fp_arc), (2, 0, 1));
    let sum = t.summary();
    assert!(
        (sum.false_pos - 1.0 / 3.0).abs() < 1e-12,
        "{}",
        sum.false_pos
    );
    assert_eq!(sum.neutral, 0.0);
}

#[test]
fn the_rule_is_the_deviation_from_the_line_not_the_sagitta() {
    let classify = |radius: f64, kappa: f64, incidence: f64| {
        let mut truth = truth_with_arc(radius);
        truth.incidence[FIRST..=LAST].fill(incidence);
        let gates = Gates {
            kappa,
            ..Gates::default()
        };
        let taken = vec![true; truth.pieces.len()];
        classify_unmatched(&truth, &arc_line(radius), &valid(), &taken, SIGMA, &gates)
    };
    // Sagitta 2.5σ (beyond 1.96σ), largest deviation ≈ 1.67σ: χ² ≈ 2.8.
    assert!(sagitta(1.646) > 1.96 * SIGMA && by_hand(1.646, SIGMA) < NEUTRAL_CHI2);
    assert_eq!(classify(1.646, 0.0, 0.0), Unmatched::NeutralArc);
    // Sagitta 3.3σ, largest deviation ≈ 2.2σ: χ² ≈ 4.8.
    assert!(by_hand(2.172, SIGMA) > NEUTRAL_CHI2);
    assert_eq!(classify(2.172, 0.0, 0.0), Unmatched::Arc);
    // The realistic model's per-beam noise: at 60° incidence and κ =
    // 3.8 mrad, σ_j² = σ² + (κ·3 m·tan 60°)² = 4.9e-4 m², so R = 3 m
    // (χ² ≈ 9.2 at σ) falls to χ² ≈ 1.9: neutral.
    let theta = 60f64.to_radians();
    let sigma_j = (SIGMA * SIGMA + (0.0038 * 3.0 * theta.tan()).powi(2)).sqrt();
    assert!(by_hand(3.0, sigma_j) < NEUTRAL_CHI2);
    assert_eq!(classify(3.0, 0.0, theta), Unmatched::Arc);
    assert_eq!(classify(3.0, 0.0038, theta), Unmatched::NeutralArc);
}

#[test]
fn a_line_on_a_straight_wall_is_unaffected() {
    // The left wall's line 6° off: outside the gate, false though its
    // noise-free hits lie exactly on a straight line.
    let truth = truth_with_arc(1.0);
    let chi2 = straightness_chi2(&truth, 141..=360, SIGMA, 0.0).unwrap();
    assert!(chi2 < 1e-9, "{chi2}");
    let lines = vec![
        line(-1.5, 2.0, 0, 99),
        line(0.6 + 6f64.to_radians(), 2.5, 141, 360),
    ];
    let s = score_lines(&truth, &lines, &valid(), SIGMA, &Gates::default());
    assert_eq!((s.matched, s.fp_off, s.neutral_arc), (1, 1, 0));
    let mut t = Tally::default();
    t.add(&s, &Default::default(), 0, 0.0);
    assert!((t.summary().false_pos - 0.5).abs() < 1e-12);
}

#[test]
fn the_truth_holds_the_noise_free_ranges_and_incidences() {
    // A circle of 3 m about the sensor and a wall x = 2 m in front of it.
    let mut scene = Scene::new();
    scene.add_arc(
        Point::new(0.0, 0.0),
        3.0,
        -100f64.to_radians(),
        60f64.to_radians(),
    );
    scene.add_wall(Point::new(2.0, -0.5), Point::new(2.0, 1.5));
    let cast = scene.cast(&Bearings::lms_180_half_deg(), Pose::IDENTITY);
    let t = scan_truth(
        &cast,
        &scene,
        &lms_core::Params::PAPER,
        SIGMA,
        &Gates::default(),
    );
    let b = bearings();
    let (mut arcs, mut walls) = (0, 0);
    for (j, &phi) in b.iter().enumerate() {
        let Some(d) = t.ranges[j] else { continue };
        if t.on_arc[j] {
            arcs += 1;
            assert!((d - 3.0).abs() < 1e-9 && t.incidence[j].abs() < 1e-6);
        } else {
            walls += 1;
            assert!((d - 2.0 / phi.cos()).abs() < 1e-9);
            assert!((t.incidence[j] - phi.abs()).abs() < 1e-6);
        }
    }
    assert!(arcs > 100 && walls > 50, "{arcs} {walls}");
}
