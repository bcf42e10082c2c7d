//! Pairs of lines on a curve (`Params::arc_pairs`, on by default,
//! docs/ALGORITHM.md §7.6, §7.8). A concave wall of 1.5 m
//! radius cut by a no-echo beam gives two short lines, each straight within
//! the noise, touching and turning ~15° at the gap: with pairs kept
//! ([`ARC_PAIRS_KEPT`]) both are reported (and they are no wall); the defaults drop them where a circle through
//! their beams explains them within the noise and better than the two
//! lines by χ²₁'s 95 % quantile. Two straight walls meeting at 6–30° stay
//! two lines.

use lms_core::test_support::Rng;
use lms_core::{Extractor, Frame, Params, Variant};

/// Range noise σ (m).
const SIGMA: f64 = 0.01;
/// Draws per case.
const DRAWS: usize = 200;
/// The bearings the surface covers (degrees), and the beam left without
/// an echo between the two lines.
const FROM_DEG: f64 = -10.0;
const TO_DEG: f64 = 10.0;
const GAP_DEG: f64 = 0.0;
/// Radius of the curved wall (m): its 0.8 m seen is a 31° arc, sagitta
/// 5 cm.
const RADIUS: f64 = 1.5;

/// A 0.5° scan (σ = 1 cm) of a surface given as the range along each
/// bearing (rad) between `FROM_DEG` and `TO_DEG`, no echo elsewhere and at
/// `GAP_DEG`.
fn scan(range: impl Fn(f64) -> f64, rng: &mut Rng) -> Frame {
    let mut frame = Frame::for_variant(Variant::Fov180Res50);
    for j in 0..frame.len() {
        let phi = f64::from(frame.geometry().bearing(j));
        let deg = phi.to_degrees();
        let on = (FROM_DEG..=TO_DEG).contains(&deg) && (deg - GAP_DEG).abs() > 0.25;
        if on {
            frame.set_metres(j, (range(phi) + SIGMA * rng.normal()) as f32);
        } else {
            frame.set_invalid(j, lms_core::Invalid::NoEcho);
        }
    }
    frame
}

/// The concave circle of radius [`RADIUS`] 2 m ahead of the origin, seen
/// from the origin: range along bearing `phi`.
fn arc(phi: f64) -> f64 {
    let (cx, cy, radius) = (2.0 - RADIUS, 0.0, RADIUS);
    let (ux, uy) = (phi.cos(), phi.sin());
    let b = ux * cx + uy * cy;
    let c = cx * cx + cy * cy - radius * radius;
    b + (b * b - c).sqrt()
}

/// Two straight walls meeting at bearing `GAP_DEG`, 2.5 m away, with the
/// turn `turn_deg` between their normals.
fn corner(turn_deg: f64) -> impl Fn(f64) -> f64 {
    let d = 2.5;
    let gap = GAP_DEG.to_radians();
    let apex = (d * gap.cos(), d * gap.sin());
    let half = (turn_deg / 2.0).to_radians();
    move |phi: f64| {
        // The wall on each side: through the apex, normal turned ±half
        // from the bearing of the apex.
        let alpha = if phi < gap { gap - half } else { gap + half };
        let r = apex.0 * alpha.cos() + apex.1 * alpha.sin();
        r / (phi - alpha).cos()
    }
}

/// Over `DRAWS` scans: how often `params` report two lines, and how
/// often none (with `rejected_arc` 2).
fn count(surface: &dyn Fn(f64) -> f64, params: &Params, seed: u64) -> (usize, usize) {
    let mut rng = Rng(seed);
    let mut ex = Extractor::new();
    let valid = params.validate().unwrap();
    let (mut two, mut dropped) = (0, 0);
    for _ in 0..DRAWS {
        let frame = scan(surface, &mut rng);
        let f = ex.run(&frame, &valid);
        two += usize::from(f.lines().len() == 2);
        dropped += usize::from(f.lines().is_empty() && f.stats().rejected_arc == 2);
    }
    (two, dropped)
}

/// The defaults with pairs of lines kept whatever a circle says of them.
const ARC_PAIRS_KEPT: Params = Params::DEFAULT.with_arc_pairs(false);

fn at(params: Params) -> Params {
    params.with_sigma(SIGMA as f32)
}

/// With pairs kept the curved wall is two lines in 189 of 200 draws; the
/// defaults drop the pair in 39 (a fifth: the circle must fit better than
/// the two chords by χ²₁'s 95 % quantile, which a 5 cm sagitta at σ = 1 cm
/// often does not show; longer arcs of the realistic synthetic scenes are
/// caught more often, §10.12).
#[test]
fn two_chords_of_a_curved_wall_are_dropped() {
    let (two, dropped_kept) = count(&arc, &at(ARC_PAIRS_KEPT), 1);
    let (_, dropped) = count(&arc, &at(Params::DEFAULT), 1);
    eprintln!("arc: pairs kept two lines {two}/{DRAWS}, defaults dropped {dropped}/{DRAWS}");
    assert!(two >= DRAWS * 9 / 10, "pairs kept: two lines in {two}");
    assert_eq!(dropped_kept, 0);
    assert!(dropped >= two / 8, "defaults dropped {dropped} of {two}");
}

/// Two straight 0.4 m walls meeting at 6–30° turns: the defaults keep
/// both lines wherever they are found with pairs kept, but for at most 1.5 % (one or
/// two draws in 200 at 12° and 15°).
#[test]
fn a_corner_at_the_same_turn_is_kept() {
    for turn in [6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 30.0] {
        let surface = corner(turn);
        let (two_kept, _) = count(&surface, &at(ARC_PAIRS_KEPT), 2);
        let (two, dropped) = count(&surface, &at(Params::DEFAULT), 2);
        eprintln!(
            "corner {turn}°: pairs kept two {two_kept}, defaults two {two}, dropped {dropped}"
        );
        assert!(
            two_kept >= DRAWS / 4,
            "{turn}°: pairs kept two lines in {two_kept}"
        );
        assert!(
            two * 1000 >= two_kept * 985,
            "{turn}°: the defaults kept {two} of {two_kept}"
        );
        assert!(dropped <= two_kept - two);
    }
}
