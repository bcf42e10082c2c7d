//! The evaluation's metric code on small hand-made cases: a perfect
//! extraction, a spurious line, a duplicate, a line outside the gates, the
//! NEES and CRB ratio of a known Gaussian case, corner matching, the truth
//! of a built-in scene, and the baselines on a noise-free corner.

use lms_core::maths::Sym2;
use lms_core::unstable::fit_line;
use lms_core::Corner;
use lms_core::Line;
use lms_core::{Beam, Frame, Params, Segment, Variant};
use lms_lab::baselines::{gaussian_mask, split_and_merge, Tables};
use lms_lab::metrics::{
    crb, scan_truth, score_corners, score_lines, CornerTruth, Gates, ScanTruth, Tally, TruePiece,
};
use lms_lab::variants::chi2_quantile_999;
use lms_scene::{Bearings, Pose, Scene};
use rand::Rng;

const SIGMA: f64 = 0.01;

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

/// A line with the given parameters over `first..=last` and the CRB of
/// that span as its covariance.
fn line(alpha: f64, r: f64, first: u16, last: u16) -> Line {
    let b = bearings();
    let c = crb(
        alpha,
        r,
        (first as usize..=last as usize).map(|j| b[j]),
        SIGMA,
    )
    .expect("a line seen from the front");
    Line {
        alpha: alpha as f32,
        r: r as f32,
        cov: Sym2 {
            a: c[0] as f32,
            b: c[1] as f32,
            c: c[2] as f32,
        },
        first,
        last,
        points: last - first + 1,
        chi2: 1.0,
        endpoints: [[0.0; 2]; 2],
    }
}

/// Three walls of a room: right, front, left (beams 0..=99, 100..=259, 260..=360).
fn room() -> ScanTruth {
    ScanTruth {
        pieces: vec![
            piece(-1.5, 2.0, 0, 99),
            piece(0.1, 3.0, 100, 259),
            piece(1.6, 2.5, 260, 360),
        ],
        corners: vec![],
        on_arc: vec![false; 361],
        bearings: bearings(),
        ranges: vec![None; 361],
        incidence: vec![0.0; 361],
    }
}

fn valid() -> Vec<Beam> {
    vec![Beam::Valid; 361]
}

fn summary_of(truth: &ScanTruth, lines: &[Line]) -> (lms_lab::metrics::LineScore, Tally) {
    let s = score_lines(truth, lines, &valid(), SIGMA, &Gates::default());
    let mut t = Tally::default();
    t.add(&s, &Default::default(), 0, 0.0);
    (s, t)
}

#[test]
fn evaluate_a_perfect_extraction_has_true_pos_1_and_false_pos_0() {
    let truth = room();
    let lines: Vec<Line> = truth
        .pieces
        .iter()
        .map(|p| line(p.alpha, p.r, p.first as u16, p.last as u16))
        .collect();
    let (s, t) = summary_of(&truth, &lines);
    let sum = t.summary();
    assert_eq!((s.matched, s.matched_resolvable), (3, 3));
    assert_eq!(sum.true_pos, 1.0);
    assert_eq!(sum.false_pos, 0.0);
    assert!((sum.coverage - 1.0).abs() < 1e-12);
    // Exact parameters: zero errors and zero NEES.
    assert!(s
        .pairs
        .iter()
        .all(|p| p.d_alpha.abs() < 1e-6 && p.nees < 1e-6));
}

#[test]
fn evaluate_one_spurious_line_gives_the_right_false_pos() {
    let mut truth = room();
    // Beams 300..=330 of the left wall are hidden by a pillar (an arc).
    truth.pieces[2].last = 299;
    truth.pieces.push(piece(1.6, 2.5, 331, 360));
    for a in &mut truth.on_arc[300..=330] {
        *a = true;
    }
    let mut lines: Vec<Line> = truth
        .pieces
        .iter()
        .map(|p| line(p.alpha, p.r, p.first as u16, p.last as u16))
        .collect();
    lines.insert(3, line(1.2, 1.5, 300, 330)); // on the pillar
    let (s, t) = summary_of(&truth, &lines);
    assert_eq!(s.extracted, 5);
    assert_eq!(s.matched, 4);
    assert_eq!(s.fp_arc, 1);
    let sum = t.summary();
    assert_eq!(sum.true_pos, 1.0);
    assert!((sum.false_pos - 0.2).abs() < 1e-12, "{}", sum.false_pos);
    assert!(sum.false_pos_no_arc.abs() < 1e-12);
}

#[test]
fn evaluate_a_duplicate_and_a_line_outside_the_gates_are_false() {
    let truth = room();
    let lines = vec![
        line(-1.5, 2.0, 0, 99),
        // The front wall in two halves: one matches, the other duplicates it.
        line(0.1, 3.0, 100, 179),
        line(0.1, 3.0, 180, 259),
        // The left wall 6° off: outside the 5° gate.
        line(1.6 + 6f64.to_radians(), 2.5, 260, 360),
    ];
    let (s, t) = summary_of(&truth, &lines);
    assert_eq!((s.matched, s.fp_split, s.fp_off), (2, 1, 1));
    let sum = t.summary();
    assert!((sum.true_pos - 2.0 / 3.0).abs() < 1e-12);
    assert!((sum.false_pos - 0.5).abs() < 1e-12);
    // The matched half covers half of the front wall.
    let cover: Vec<f64> = s.pairs.iter().map(|p| p.coverage).collect();
    assert!(cover.iter().any(|&c| (c - 0.5).abs() < 1e-12), "{cover:?}");
    // A line over a wall and a stretch without returns (no piece holds
    // half of it) is "mixed".
    let mut gap = room();
    gap.pieces[1].first = 130;
    let (s, _) = summary_of(&gap, &[line(-1.2, 2.4, 90, 120)]);
    assert_eq!((s.matched, s.fp_mixed), (0, 1));
}

#[test]
fn evaluate_nees_and_crb_ratio_of_a_known_gaussian_case() {
    // Errors drawn from N(0, Σ) with Σ the CRB of the line: mean NEES 2 and
    // RMS normalised errors 1; reporting Σ/2 doubles the NEES.
    let truth = ScanTruth {
        pieces: vec![piece(0.3, 2.5, 120, 260)],
        ..room()
    };
    let exact = line(0.3, 2.5, 120, 260);
    let (a, b, c) = (exact.cov.a as f64, exact.cov.b as f64, exact.cov.c as f64);
    // Cholesky of Σ.
    let l11 = a.sqrt();
    let l21 = b / l11;
    let l22 = (c - l21 * l21).sqrt();
    let mut rng = lms_scene::seeded_rng(5);
    // Box–Muller: two independent standard normal draws.
    let mut normals = move || {
        let u1: f64 = 1.0 - rng.random::<f64>();
        let u2: f64 = rng.random();
        let rho = (-2.0 * u1.ln()).sqrt();
        let t = std::f64::consts::TAU * u2;
        (rho * t.cos(), rho * t.sin())
    };
    let (mut t, mut half) = (Tally::default(), Tally::default());
    const N: usize = 4000;
    for _ in 0..N {
        let (z1, z2) = normals();
        let (ea, er) = (l11 * z1, l21 * z1 + l22 * z2);
        let mut l = exact;
        l.alpha = (0.3 + ea) as f32;
        l.r = (2.5 + er) as f32;
        let s = score_lines(&truth, &[l], &valid(), SIGMA, &Gates::default());
        t.add(&s, &Default::default(), 0, 0.0);
        l.cov = l.cov.scale(0.5);
        let s = score_lines(&truth, &[l], &valid(), SIGMA, &Gates::default());
        half.add(&s, &Default::default(), 0, 0.0);
    }
    let s = t.summary();
    // Mean of N χ²₂ draws: 2 ± 2/√N = 2 ± 0.032; f32 rounding of the
    // parameters adds a little.
    assert!(
        (s.nees_line - 2.0).abs() < 0.13,
        "mean NEES {}",
        s.nees_line
    );
    assert!(
        (s.nees_line_median - 1.386).abs() < 0.12,
        "median {}",
        s.nees_line_median
    );
    assert!((s.crb_alpha - 1.0).abs() < 0.05, "α ratio {}", s.crb_alpha);
    assert!((s.crb_r - 1.0).abs() < 0.05, "r ratio {}", s.crb_r);
    assert!((s.nees_line_inside - 0.99).abs() < 0.01);
    let h = half.summary();
    assert!((h.nees_line - 2.0 * s.nees_line).abs() < 1e-2 * s.nees_line);
}

#[test]
fn evaluate_the_crb_is_the_core_fit_covariance_on_a_noise_free_wall() {
    let variant = Variant::Fov180Res50;
    let g = variant.geometry();
    let (alpha, r) = (0.4f64, 2.5f64);
    let ranges: Vec<f32> = (0..variant.beams())
        .map(|j| {
            let phi = g.bearing(j) as f64;
            if (200..=300).contains(&j) {
                (r / (phi - alpha).cos()) as f32
            } else {
                0.0
            }
        })
        .collect();
    let frame = Frame::from_metres(g, &ranges).unwrap();
    let tables = Tables::for_frame(&frame);
    let l = fit_line(
        tables.bearings(),
        frame.ranges(),
        frame.beams(),
        Segment {
            first: 200,
            last: 300,
        },
        0.005,
    )
    .unwrap();
    let c = crb(alpha, r, (200..=300).map(|j| g.bearing(j) as f64), 0.005).unwrap();
    for (got, want) in [(l.cov.a, c[0]), (l.cov.b, c[1]), (l.cov.c, c[2])] {
        assert!(((got as f64 - want) / want).abs() < 1e-3, "{got} vs {want}");
    }
}

#[test]
fn the_footprint_crb_weights_grazing_beams_down() {
    use lms_lab::metrics::crb_footprint;
    let bearings = || (0..40).map(|j| (-10.0 + j as f64 * 0.5).to_radians());
    let (alpha, r, sigma) = (0.0, 3.0, 0.01);
    let plain = crb(alpha, r, bearings(), sigma).unwrap();
    assert_eq!(crb_footprint(alpha, r, bearings(), sigma, 0.0), Some(plain));
    // Near normal incidence (|θ| ≤ 10°) the footprint adds little ...
    let near = crb_footprint(alpha, r, bearings(), sigma, 0.0038).unwrap();
    assert!(
        near[2] > plain[2] && near[2] < 1.05 * plain[2],
        "{near:?} {plain:?}"
    );
    // ... along a wall at 60–80°, κ·d·tan θ is several σ: the bound is wider.
    let grazing = || (0..40).map(|j| (60.0 + j as f64 * 0.5).to_radians());
    let p = crb(alpha, r, grazing(), sigma).unwrap();
    let g = crb_footprint(alpha, r, grazing(), sigma, 0.0038).unwrap();
    assert!(g[0] > 4.0 * p[0] && g[2] > 4.0 * p[2], "{g:?} {p:?}");
    // Against an f64 sum written out: (Σ J Jᵀ / σ_j²)⁻¹.
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for phi in grazing() {
        let t = phi - alpha;
        let v = sigma * sigma + (0.0038 * r / t.cos() * t.tan()).powi(2);
        let (ja, jr) = (-r * t.sin() / t.cos().powi(2), 1.0 / t.cos());
        (a, b, c) = (a + ja * ja / v, b + ja * jr / v, c + jr * jr / v);
    }
    let det = a * c - b * b;
    assert!((g[0] - c / det).abs() < 1e-9 * g[0].max(1e-12));
    assert!((g[2] - a / det).abs() < 1e-9 * g[2].max(1e-12));
}

#[test]
fn evaluate_corners_match_within_the_gate_one_to_one() {
    let truth = ScanTruth {
        corners: vec![
            CornerTruth {
                x: 3.0,
                y: 1.0,
                angle_deg: 90.0,
                beam: 216.9,
            },
            CornerTruth {
                x: 2.0,
                y: -2.0,
                angle_deg: 60.0,
                beam: 90.0,
            },
        ],
        ..room()
    };
    let corner = |x: f32, y: f32, well: bool| Corner {
        x,
        y,
        cov: Sym2 {
            a: 1e-4,
            b: 0.0,
            c: 1e-4,
        },
        angle_deg: 90.0,
        well_conditioned: well,
        line_a: 0,
        line_b: 1,
    };
    // 1 cm off (NEES 1), a second candidate for the same corner, one far away.
    let found = [
        corner(3.01, 1.0, true),
        corner(3.03, 1.0, true),
        corner(0.0, 0.0, true),
    ];
    let s = score_corners(&truth, &found, &Gates::default());
    assert_eq!(
        (s.true_corners, s.matched, s.extracted_wc, s.matched_wc),
        (2, 1, 3, 1)
    );
    assert!((s.pairs[0].dist - 0.01).abs() < 1e-6);
    assert!((s.pairs[0].nees - 1.0).abs() < 1e-3);
    let mut t = Tally::default();
    t.add(&Default::default(), &s, 0, 0.0);
    let sum = t.summary();
    assert_eq!(sum.corner_rate, 0.5);
    assert!((sum.corner_false_pos - 2.0 / 3.0).abs() < 1e-12);
}

#[test]
fn evaluate_truth_of_a_built_in_corner_scene() {
    let scene = Scene::two_walls_corner(90.0);
    let truth = scene.cast(&Bearings::lms_180_half_deg(), Pose::IDENTITY);
    let params = Params::PAPER;
    let t = scan_truth(&truth, &scene, &params, 0.005, &Gates::default());
    assert_eq!(t.pieces.len(), 2);
    assert!(t.pieces.iter().all(|p| p.resolvable));
    assert_eq!(t.pieces[0].last + 1, t.pieces[1].first);
    assert_eq!(t.corners.len(), 1);
    assert!((t.corners[0].angle_deg - 90.0).abs() < 1e-9);
    assert!(t.on_arc.iter().all(|&a| !a));
}

/// Split-and-merge finds both walls of a noise-free right-angle corner and
/// their corner; the Gaussian mask blurs the corner so that no window's `D`
/// reaches τ: one segment over both walls, rejected by χ² — the paper's
/// argument against a fixed mask.
#[test]
fn evaluate_baselines_on_a_noise_free_corner() {
    let scene = Scene::two_walls_corner(90.0);
    let truth = scene.cast(&Bearings::lms_180_half_deg(), Pose::IDENTITY);
    let readings = truth.noise_free();
    let frame = host_bridge::synthetic::frame_from_readings(&readings).unwrap();
    let tables = Tables::for_frame(&frame);
    let params = Params::PAPER;
    let t = scan_truth(&truth, &scene, &params, 0.005, &Gates::default());
    let x = split_and_merge(&frame, &tables, &params, 4.0);
    let s = score_lines(&t, &x.lines, frame.beams(), 0.005, &Gates::default());
    assert_eq!(s.matched_resolvable, 2, "{:?}", x.lines);
    assert_eq!((x.lines.len(), x.corners.len()), (2, 1));
    let x = gaussian_mask(&frame, &tables, &params, 1.35);
    assert_eq!(x.segments.len(), 1, "{:?}", x.segments);
    assert!(x.lines.is_empty());
}

#[test]
fn evaluate_chi2_quantile() {
    // Exact 99.9 % quantiles: ν = 10 → 29.588, ν = 100 → 149.449.
    assert!((chi2_quantile_999(10.0) - 29.588).abs() < 0.3);
    assert!((chi2_quantile_999(100.0) - 149.449).abs() < 0.5);
}
