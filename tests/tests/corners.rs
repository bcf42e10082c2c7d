//! Corners (ALGORITHM.md §8): a right-angle corner is found where it is, with
//! an honest covariance; a shallow bend is reported, but flagged
//! ill-conditioned.

use lms_core::frame::{Frame, Variant};
use lms_core::pipeline::corners::intersect;
use lms_core::pipeline::line_fit::Bearings;
use lms_core::unstable::fit_line;
use lms_core::{Extractor, Params, Segment};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use workspace_tests::synth::{self, Wall};

const SIGMA: f64 = 0.005;

fn rotate(p: [f64; 2], a: f64) -> [f64; 2] {
    let (c, s) = (a.cos(), a.sin());
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

/// A concave right-angle corner at (3, 1) (bearing 18.4°, 3.16 m) between
/// the wall x = 3 (from y = −4) and the wall y = 1 (to x = −2), the scene
/// turned by `turn` rad about the sensor.
fn right_corner(turn: f64) -> (Vec<Wall>, [f64; 2]) {
    let corner = [3.0, 1.0];
    let walls = vec![
        Wall {
            p: rotate([3.0, -4.0], turn),
            q: rotate(corner, turn),
        },
        Wall {
            p: rotate(corner, turn),
            q: rotate([-2.0, 1.0], turn),
        },
    ];
    (walls, rotate(corner, turn))
}

fn scan(walls: &[Wall], sigma: f64, rng: &mut ChaCha8Rng) -> Frame {
    let variant = Variant::Fov180Res50;
    let g = variant.geometry();
    let truth = synth::true_ranges(
        walls,
        g.first_bearing as f64,
        g.step as f64,
        variant.beams(),
    );
    let (ranges, _) = synth::noisy_scan(&truth, sigma, 0.0, rng);
    Frame::from_metres(g, &ranges).unwrap()
}

/// `eᵀ Σ⁻¹ e` for a 2-vector and a symmetric 2×2 covariance `(a, b, c)`.
fn nees(e: [f64; 2], cov: &lms_core::maths::Sym2) -> f64 {
    let (a, b, c) = (cov.a as f64, cov.b as f64, cov.c as f64);
    let det = a * c - b * b;
    assert!(
        a > 0.0 && det > 0.0,
        "covariance not positive definite: {cov:?}"
    );
    (c * e[0] * e[0] - 2.0 * b * e[0] * e[1] + a * e[1] * e[1]) / det
}

/// The core's bearing tables for a frame.
fn tables(frame: &Frame) -> (Vec<f32>, Vec<f32>) {
    let g = frame.geometry();
    (
        (0..frame.len()).map(|j| g.bearing(j).cos()).collect(),
        (0..frame.len()).map(|j| g.bearing(j).sin()).collect(),
    )
}

/// Mean NEES and the fraction inside the χ²₂ = 9.21 (99 %) ellipse.
fn summary(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let inside = v.iter().filter(|&&x| x <= 9.21).count() as f64 / v.len() as f64;
    (mean, inside)
}

/// A right-angle corner at 3.16 m, 400 draws with noise sigma = 5 mm, the
/// scene turned by a random angle in ±0.3 rad so that the corner falls
/// anywhere between two beams.
///
/// 1. At `Params::PAPER` and `Params::V2` (30 passes) every draw has exactly
///    one well-conditioned corner; at the defaults (5 passes) at most 2 of
///    the 400 have none (measured 1: fewer passes leave a few beams at the
///    corner breaking, and the lines' ends fall more than `corner_gap` apart
///    on the grazing wall). The corner found is within 1 cm of the
///    truth (measured worst: a few mm), at 90° within 1° or 4 standard
///    deviations of the lines' angles (a false break can leave a short piece
///    of wall next to the corner, whose angle is uncertain by ~0.5°). A rare false break
///    can split a wall into two lines that the merge gate keeps
///    apart; the corner between them is then near 0° and must be flagged
///    ill-conditioned (counted and printed).
/// 2. **The §8 covariance is honest**: the NEES `eᵀ Σ⁻¹ e` of the true corner
///    is χ²₂ for a correct covariance of independent line fits — mean 2
///    (standard error √(4/400) = 0.1: accepted [1.6, 2.4], ±4 standard
///    errors) and 99 % of draws inside the χ²₂ = 9.21 ellipse (accepted
///    ≥ 95 %). This holds for the corner of the two lines refitted without
///    the beam the two segments share (see 3), at `Params::V2`: this
///    scene's noise is the range noise σ alone, with no footprint term.
///    With the default footprint weights (ALGORITHM.md §10 (f), κ = 3 mrad)
///    the covariance allows for a footprint this sensor has not, so it
///    may only be conservative: mean NEES in [0.8, 2.4] (measured 1.02),
///    ≥ 95 % inside.
/// 3. **As extracted** (lines fitted on the segments exactly as §6–§7 define
///    them), the corner is measurably over-confident: §6 makes the beam
///    nearest to the corner a member of *both* segments, and when the true
///    corner falls between beams that beam lies on one wall up to half a
///    beam spacing (~1.4 cm here) from the corner, i.e. up to ~1 cm off the
///    other wall's line — too little for `D` to break the window, enough to
///    pull the end of that line. Measured: mean NEES 2.73, 95.5 % inside the
///    99 % ellipse (vs. 1.90 and 99.0 % without the shared beam). Asserted as
///    measured with a margin (mean ≤ 3.3, ≥ 90 % inside) so a regression
///    shows; this is a property of the spec (ALGORITHM.md §6/§7), not of
///    the core's arithmetic.
#[test]
fn a_right_angle_corner_is_found_with_an_honest_covariance() {
    const DRAWS: usize = 400;
    // "As extracted" is ALGORITHM.md v1 (the shared beam in both fits, no
    // split before reject); the v2 default is the refit below.
    let params = Params::PAPER;
    let mut rng = ChaCha8Rng::seed_from_u64(90);
    let mut ex = Extractor::new();
    let mut ex_excluding = Extractor::new();
    let (mut as_extracted, mut refitted, mut weighted) = (Vec::new(), Vec::new(), Vec::new());
    let (mut worst_dist, mut split_walls, mut missed_at_defaults) = (0.0f64, 0, 0);
    for draw in 0..DRAWS {
        let turn = rng.random_range(-0.3..0.3);
        let (walls, truth) = right_corner(turn);
        let frame = scan(&walls, SIGMA, &mut rng);
        let f = ex.run(&frame, &params.validate().unwrap());
        let good: Vec<_> = f.corners().iter().filter(|c| c.well_conditioned).collect();
        assert_eq!(good.len(), 1, "draw {draw}: corners {:?}", f.corners());
        let c = *good[0];
        for other in f.corners().iter().filter(|c| !c.well_conditioned) {
            assert!(
                other.angle_deg < 5.0,
                "draw {draw}: unexpected corner {other:?}"
            );
            split_walls += 1;
        }
        // Within 4 standard deviations of the lines' angles (and 1°).
        let (la, lb) = (f.lines()[c.line_a as usize], f.lines()[c.line_b as usize]);
        let sd_deg = ((la.cov.a + lb.cov.a) as f64).sqrt().to_degrees();
        assert!(
            (c.angle_deg as f64 - 90.0).abs() < (4.0 * sd_deg).max(1.0),
            "draw {draw}: angle {} (sd {sd_deg})",
            c.angle_deg
        );
        let e = [c.x as f64 - truth[0], c.y as f64 - truth[1]];
        worst_dist = worst_dist.max(e[0].hypot(e[1]));
        assert!(
            e[0].hypot(e[1]) < 0.01,
            "draw {draw}: corner {c:?}, truth {truth:?}"
        );
        as_extracted.push(nees(e, &c.cov));

        // The v2 defaults: the shared beam out of both fits (and split
        // before reject); then the defaults with the footprint weights.
        for (params, out) in [
            (Params::V2, &mut refitted),
            (Params::default(), &mut weighted),
        ] {
            let f2 = ex_excluding.run(&frame, &params.validate().unwrap());
            let good2: Vec<_> = f2.corners().iter().filter(|c| c.well_conditioned).collect();
            if good2.is_empty() && params == Params::default() {
                missed_at_defaults += 1;
                continue;
            }
            assert_eq!(good2.len(), 1, "draw {draw}: corners {:?}", f2.corners());
            out.push(nees(
                [good2[0].x as f64 - truth[0], good2[0].y as f64 - truth[1]],
                &good2[0].cov,
            ));
        }
    }
    assert!(
        missed_at_defaults <= 2,
        "defaults: no corner in {missed_at_defaults} of {DRAWS} draws"
    );
    let (mean_x, inside_x) = summary(&as_extracted);
    let (mean_r, inside_r) = summary(&refitted);
    let (mean_w, inside_w) = summary(&weighted);
    eprintln!(
        "with the footprint weights (defaults): mean NEES {mean_w:.3}, {:.1} % inside",
        100.0 * inside_w
    );
    assert!(
        (0.8..=2.4).contains(&mean_w) && inside_w >= 0.95,
        "defaults: mean corner NEES {mean_w}, {:.1} % inside",
        100.0 * inside_w
    );
    eprintln!("defaults: no corner in {missed_at_defaults} of {DRAWS} draws");
    eprintln!(
        "90° corner, {DRAWS} draws: as extracted mean NEES {mean_x:.3}, {:.1} % inside the 99 % ellipse; \
         with fit_shared_points = false mean NEES {mean_r:.3}, {:.1} % inside; worst distance {:.2} mm; \
         {split_walls} ill-conditioned corners from split walls",
        100.0 * inside_x,
        100.0 * inside_r,
        1e3 * worst_dist
    );
    assert!(
        (1.6..=2.4).contains(&mean_r),
        "mean corner NEES {mean_r}, want 2 ± 0.4"
    );
    assert!(
        inside_r >= 0.95,
        "only {:.1} % inside the 99 % ellipse",
        100.0 * inside_r
    );
    assert!(
        mean_x <= 3.3,
        "as extracted: mean corner NEES {mean_x} (measured 2.7)"
    );
    assert!(
        inside_x >= 0.90,
        "as extracted: {:.1} % inside the 99 % ellipse",
        100.0 * inside_x
    );
}

/// Two walls meeting at 10° (a shallow bend at 3 m): the intersection of
/// their lines is reported with `angle_deg` ≈ 10 and
/// `well_conditioned == false` (default `min_corner_angle_deg` = 30).
///
/// End to end, the extractor resolves such a bend only when the noise is low
/// against the bend's offset between beams (a few mm at 0.5°, 3 m): measured
/// over 20 seeds at 0.5° and 30 passes, it finds the corner 20/20 times at
/// sigma = 0.5 mm, 3/20 at 1 mm and 1/20 at 2 mm; at sigma = 5 mm the passes
/// round the bend off, the whole bent wall stays one segment and its line
/// fails `chi2`, so the frame has no line there at all (printed). The end to
/// end check runs at sigma = 0.5 mm (five seeds). The conditioning flag is then checked at 5 mm on the
/// two walls' lines fitted on their true beams and intersected by
/// `lms_core::pipeline::corners::intersect`.
#[test]
fn a_ten_degree_bend_is_an_ill_conditioned_corner() {
    let bend = 10f64.to_radians();
    let corner = [3.0, 0.5];
    let dir = [-bend.sin(), bend.cos()]; // the first wall runs along +y
    let walls = [
        Wall {
            p: [3.0, -3.0],
            q: corner,
        },
        Wall {
            p: corner,
            q: [corner[0] + 3.0 * dir[0], corner[1] + 3.0 * dir[1]],
        },
    ];
    let mut ex = Extractor::new();

    // End to end at 0.5°, sigma = 0.5 mm.
    let params = Params::default().with_sigma(0.0005);
    for seed in 0..5 {
        let mut rng = ChaCha8Rng::seed_from_u64(10 + seed);
        let frame = scan(&walls, 0.0005, &mut rng);
        let f = ex.run(&frame, &params.validate().unwrap());
        assert_eq!(
            f.corners().len(),
            1,
            "seed {seed}: lines {:?} corners {:?}",
            f.lines(),
            f.corners()
        );
        let c = f.corners()[0];
        eprintln!("10° bend, sigma 0.5 mm, seed {seed}: {c:?}");
        assert!((c.angle_deg - 10.0).abs() < 0.5, "angle {}", c.angle_deg);
        assert!(
            !c.well_conditioned,
            "a 10° corner flagged well-conditioned: {c:?}"
        );
        let e = [c.x as f64 - corner[0], c.y as f64 - corner[1]];
        assert!(e[0].hypot(e[1]) < 0.01, "corner {c:?}");
    }

    // sigma = 5 mm, 0.5°: what the extractor makes of it (printed only).
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let frame = scan(&walls, SIGMA, &mut rng);
    let f = ex.run(&frame, &lms_core::ValidParams::DEFAULT);
    eprintln!(
        "10° bend, 0.5°, sigma 5 mm: segments {:?}, lines {}, rejected by chi2 {}, corners {}",
        f.segments(),
        f.lines().len(),
        f.stats().rejected_chi2,
        f.corners().len()
    );

    // The two walls' true beams at 5 mm, fitted and intersected.
    let g = frame.geometry();
    let split = (corner[1].atan2(corner[0]) - g.first_bearing as f64) / g.step as f64;
    let (cos, sin) = tables(&frame);
    let bearings = Bearings {
        cos: &cos,
        sin: &sin,
    };
    let valid: Vec<u16> = (0..frame.len() as u16)
        .filter(|&j| frame.beams()[j as usize].is_valid())
        .collect();
    let (lo, hi) = (valid[0], *valid.last().unwrap());
    let l1 = fit_line(
        bearings,
        frame.ranges(),
        frame.beams(),
        Segment {
            first: lo,
            last: split.floor() as u16,
        },
        SIGMA as f32,
    )
    .unwrap();
    let l2 = fit_line(
        bearings,
        frame.ranges(),
        frame.beams(),
        Segment {
            first: split.floor() as u16 + 1,
            last: hi,
        },
        SIGMA as f32,
    )
    .unwrap();
    let c = intersect(0, &l1, 1, &l2, Params::default().min_corner_angle_deg).expect("a corner");
    eprintln!("10° bend, true split at 5 mm: {c:?}");
    assert!((c.angle_deg - 10.0).abs() < 1.0, "angle {}", c.angle_deg);
    assert!(
        !c.well_conditioned,
        "a 10° corner flagged well-conditioned: {c:?}"
    );
    let e = [c.x as f64 - corner[0], c.y as f64 - corner[1]];
    assert!(
        nees(e, &c.cov) < 13.8,
        "true corner outside the 99.9 % ellipse: {c:?}"
    );
    // Folding: the same lines in the other order, and a 90° pair, fold into [0°, 90°].
    let back = intersect(1, &l2, 0, &l1, 30.0).expect("a corner");
    assert!((back.angle_deg - c.angle_deg).abs() < 1e-4 && !back.well_conditioned);
}
