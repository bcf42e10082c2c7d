//! Tests of cast scans and their ground truth on the built-in scenes.

use std::f64::consts::PI;

use crate::*;

/// Geometric agreement expected of noise-free f64 computations (m or rad).
const EXACT: f64 = 1e-9;

/// Total-least-squares line through points (ALGORITHM.md §7.1), as (α, r).
fn tls_fit(points: &[Point]) -> (f64, f64) {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.x).sum::<f64>() / n;
    let my = points.iter().map(|p| p.y).sum::<f64>() / n;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in points {
        let (dx, dy) = (p.x - mx, p.y - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    let alpha = 0.5 * (-2.0 * sxy).atan2(syy - sxx);
    let r = mx * alpha.cos() + my * alpha.sin();
    if r < 0.0 {
        (wrap_angle(alpha + PI), -r)
    } else {
        (wrap_angle(alpha), r)
    }
}

fn scan(scene: &Scene) -> TrueScan {
    scene.cast(&Bearings::default(), Pose::IDENTITY)
}

#[test]
fn single_wall_gives_analytic_range() {
    let cases = [(2.0, 0.3), (1.0, -0.5), (6.0, 0.0), (3.5, 1.2), (2.5, -2.0)];
    for (d, alpha) in cases {
        let t = scan(&Scene::single_wall(d, alpha));
        let mut hits = 0;
        for (j, phi) in Bearings::default().iter().enumerate() {
            let c = (phi - alpha).cos();
            let expected = (c > 0.0).then(|| d / c).filter(|&e| e <= DEFAULT_MAX_RANGE);
            match (t.hits[j], expected) {
                (Some(h), Some(e)) => {
                    assert!(
                        (h.range - e).abs() <= 1e-12 * e,
                        "beam {j}: {} vs {e}",
                        h.range
                    );
                    assert_eq!(h.surface, 0);
                    assert!(h.point.distance(Point::polar(e, phi)) <= 1e-12 * e);
                    hits += 1;
                }
                (None, None) => {}
                (got, want) => panic!("d={d} α={alpha} beam {j}: {got:?} vs {want:?}"),
            }
        }
        assert!(hits >= 2, "d={d} α={alpha}");
        let line = t.line(0).unwrap();
        assert!(wrap_angle(line.alpha - alpha).abs() < EXACT && (line.r - d).abs() < EXACT);
        assert_eq!(line.beams, hits);
    }
}

#[test]
fn pose_moves_the_sensor() {
    // Seen from (0.5, −0.3) with heading 0.1 rad, the line x·cos 0.2 +
    // y·sin 0.2 = 3 has α' = 0.2 − 0.1 and r' = 3 − (0.5 cos 0.2 − 0.3 sin 0.2).
    let pose = Pose::new(0.5, -0.3, 0.1);
    let t = Scene::single_wall(3.0, 0.2).cast(&Bearings::default(), pose);
    let line = PolarLine {
        alpha: 0.1,
        r: 3.0 - (0.5 * 0.2f64.cos() - 0.3 * 0.2f64.sin()),
    };
    let l = t.line(0).unwrap();
    assert!((l.alpha - line.alpha).abs() < EXACT && (l.r - line.r).abs() < EXACT);
    for (j, phi) in Bearings::default().iter().enumerate() {
        let expected = line.range_at(phi).filter(|&e| e <= DEFAULT_MAX_RANGE);
        assert_eq!(t.hits[j].is_some(), expected.is_some(), "beam {j}");
        if let (Some(h), Some(e)) = (t.hits[j], expected) {
            assert!((h.range - e).abs() < EXACT);
        }
    }
}

#[test]
fn max_range_cuts_returns() {
    let wall = Scene::single_wall(5.0, 0.0);
    let b = Bearings::default();
    assert_eq!(
        wall.cast_with_max_range(&b, Pose::IDENTITY, 4.9).returns(),
        0
    );
    let t = wall.cast_with_max_range(&b, Pose::IDENTITY, LMS_MM_MAX_RANGE);
    assert!(t.hits.iter().flatten().all(|h| h.range <= LMS_MM_MAX_RANGE));
    // cos(φ) ≥ 5/8.182 ⇔ |φ| ≤ 52.33°: beams 76 … 284 at 0.5°.
    let returning: Vec<usize> = (0..b.n).filter(|&j| t.hits[j].is_some()).collect();
    assert_eq!(returning.first(), Some(&76));
    assert_eq!(returning.last(), Some(&284));
    assert_eq!(returning.len(), 284 - 76 + 1);
}

#[test]
fn room_with_box_truth() {
    let room = Scene::room_with_box();
    for b in Bearings::LMS_VARIANTS {
        let t = room.cast(&b, Pose::IDENTITY);
        assert_eq!(t.returns(), b.n, "every beam hits ({} beams)", b.n);
        // Right, front and left wall; two faces of the box, in front of the
        // front wall.
        let mut lines: Vec<SurfaceId> = t.lines.iter().map(|l| l.surface).collect();
        lines.sort_unstable();
        assert_eq!(lines.len(), 5, "{lines:?}");
        assert_eq!(lines[..3], [0, 1, 2]);
        let faces: Vec<&TrueLine> = t.lines.iter().filter(|l| l.surface >= 4).collect();
        let front = t.line(1).unwrap();
        assert!(front.first_beam < faces[0].first_beam && faces[1].last_beam < front.last_beam);
        // Room corner, box corner, room corner; all seen, all square, none
        // on a beam.
        assert_eq!(t.corners.len(), 3);
        for c in &t.corners {
            assert!(c.visible && (c.angle_deg - 90.0).abs() < EXACT, "{c:?}");
            assert!((c.beam - c.beam.round()).abs() > 0.15, "{c:?}");
        }
        let box_corner = t.corners[1];
        assert_eq!(t.corners[0].walls, [0, 1]);
        assert!(box_corner.walls.iter().all(|&w| w >= 4));
        assert_eq!(t.corners[2].walls, [1, 2]);
        // The box's silhouette: a jump on either side of its corner.
        assert_eq!(t.jumps, vec![faces[0].first_beam - 1, faces[1].last_beam]);
        assert!((t.jumps[0] as f64) < box_corner.beam && box_corner.beam < t.jumps[1] as f64);
        // Two edge points per corner and per jump.
        let edges = t.true_edge_points();
        assert_eq!(edges.len(), 10);
        for c in &t.corners {
            let j = c.beam.floor() as usize;
            assert!(edges.contains(&j) && edges.contains(&(j + 1)));
            assert_eq!(t.windows[j - 1], Some(WindowTruth::Corner));
            assert_eq!(t.windows[j], Some(WindowTruth::Corner));
        }
        for &j in &t.jumps {
            assert!(edges.contains(&j) && edges.contains(&(j + 1)));
            assert_eq!(t.windows[j - 1], Some(WindowTruth::Jump));
            assert_eq!(t.windows[j], Some(WindowTruth::Jump));
        }
    }
}

#[test]
fn truth_lines_match_a_fit_of_the_hit_points() {
    let mut scenes = vec![
        Scene::room_with_box(),
        Scene::corridor(),
        Scene::two_walls_corner(60.0),
    ];
    let mut rng = seeded_rng(11);
    scenes.extend((0..20).map(|_| Scene::random_room(&mut rng)));
    let mut checked = 0;
    for (k, scene) in scenes.iter().enumerate() {
        let t = scan(scene);
        for l in &t.lines {
            let on_wall: Vec<(usize, Point)> = t
                .hits
                .iter()
                .enumerate()
                .filter_map(|(j, h)| h.filter(|h| h.surface == l.surface).map(|h| (j, h.point)))
                .collect();
            let points: Vec<Point> = on_wall.iter().map(|&(_, p)| p).collect();
            let (alpha, r) = tls_fit(&points);
            assert!(
                wrap_angle(alpha - l.alpha).abs() < EXACT,
                "scene {k}: {l:?} vs α {alpha}"
            );
            assert!((r - l.r).abs() < EXACT, "scene {k}: {l:?} vs r {r}");
            assert_eq!(l.beams, on_wall.len());
            assert_eq!((l.first_beam, l.first_point), on_wall[0]);
            assert_eq!((l.last_beam, l.last_point), on_wall[on_wall.len() - 1]);
            checked += 1;
        }
        // Every wall hit twice or more is a line; nothing else is.
        let walls_hit_twice = scene
            .walls
            .iter()
            .filter(|w| t.surfaces().iter().filter(|&&s| s == Some(w.id)).count() >= 2)
            .count();
        assert_eq!(t.lines.len(), walls_hit_twice, "scene {k}");
        assert!(t
            .lines
            .windows(2)
            .all(|p| p[0].first_beam <= p[1].first_beam));
    }
    assert!(checked > 60, "only {checked} lines checked");
}

#[test]
fn corner_angles_and_edge_points() {
    for (between, folded) in [
        (20.0, 20.0),
        (45.0, 45.0),
        (60.0, 60.0),
        (90.0, 90.0),
        (120.0, 60.0),
        (150.0, 30.0),
        (170.0, 10.0),
    ] {
        let t = scan(&Scene::two_walls_corner(between));
        assert_eq!(t.lines.len(), 2, "{between}°");
        assert_eq!(t.corners.len(), 1, "{between}°");
        let c = t.corners[0];
        assert!(
            c.visible && (c.angle_deg - folded).abs() < EXACT,
            "{between}°: {c:?}"
        );
        assert!((c.point.norm() - 3.0).abs() < EXACT);
        assert!((c.point.angle() - 4.35f64.to_radians()).abs() < EXACT);
        assert!(t.jumps.is_empty());
        let j = c.beam.floor() as usize;
        assert_eq!(t.true_edge_points(), vec![j, j + 1], "{between}°");
        for (i, w) in t.windows.iter().enumerate() {
            let expected = if i + 1 == j || i == j {
                WindowTruth::Corner
            } else {
                WindowTruth::Straight
            };
            assert!(
                w.is_none() || *w == Some(expected),
                "{between}° window {i}: {w:?}"
            );
        }
    }
}

#[test]
fn corridor_truth() {
    let t = scan(&Scene::corridor());
    // Straight ahead nothing is within 8 m.
    assert!(t.hits[180].is_none());
    assert!(t.returns() < 361);
    let left_near = t.line(6).unwrap();
    let left_far = t.line(2).unwrap();
    assert!((left_near.alpha - left_far.alpha).abs() < EXACT);
    assert!((left_near.r - left_far.r).abs() < EXACT && (left_near.r - 1.1).abs() < EXACT);
    assert!((t.line(0).unwrap().r - 0.9).abs() < EXACT);
    // The niche: back and far side seen with their two corners; the near
    // side hidden behind the near wall, which ends in a jump.
    assert!(t.line(5).is_none());
    assert_eq!(t.corners.len(), 2);
    assert!(t
        .corners
        .iter()
        .all(|c| c.visible && (c.angle_deg - 90.0).abs() < EXACT));
    assert_eq!(t.jumps, vec![t.line(6).unwrap().first_beam - 1]);
    // Windows touching a beam without return are undefined.
    assert!(t.windows[179].is_none());
}

#[test]
fn collinear_walls_are_one_straight_surface() {
    // One line split at a shared vertex, and again with a 1 cm gap that lies
    // between two beams: neither a corner nor a jump.
    let b = Bearings::default();
    let gap_bearing = b.bearing(200) + b.step / 2.0;
    let on_line = |bearing: f64| Point::polar(3.0 / bearing.cos(), bearing);
    let mut s = Scene::new();
    let mid = on_line(b.bearing(150) + 0.3 * b.step);
    s.add_wall(Point::new(3.0, -20.0), mid);
    s.add_wall(mid, on_line(gap_bearing) - Point::new(0.0, 0.005));
    s.add_wall(
        on_line(gap_bearing) + Point::new(0.0, 0.005),
        Point::new(3.0, 20.0),
    );
    let t = s.cast(&b, Pose::IDENTITY);
    assert_eq!(t.lines.len(), 3);
    assert!(t.corners.is_empty());
    assert!(t.jumps.is_empty());
    assert!(t.true_edge_points().is_empty());
    assert!(t
        .windows
        .iter()
        .flatten()
        .all(|&w| w == WindowTruth::Straight));
    assert_eq!(
        (t.hits[200].unwrap().surface, t.hits[201].unwrap().surface),
        (1, 2)
    );
}

#[test]
fn hidden_corner_is_not_visible() {
    // A box in front of the room's front-right corner.
    let mut s = Scene::new();
    s.add_polygon(&scene::rectangle(Point::new(1.6, 0.3), 6.0, 4.0, 0.11));
    s.add_box(Point::new(2.1, -0.45), 0.6, 0.4, 0.5);
    let t = scan(&s);
    let hidden = t.corners.iter().find(|c| c.walls == [0, 1]).unwrap();
    assert!(!hidden.visible);
    assert!(t
        .corners
        .iter()
        .filter(|c| c.walls != [0, 1])
        .all(|c| c.visible));
}

#[test]
fn pillar_is_curved() {
    let center = Point::new(3.0, 0.2);
    let t = scan(&Scene::arc(0.5, center));
    assert!(t.lines.is_empty() && t.corners.is_empty() && t.jumps.is_empty());
    assert!(t.returns() > 10);
    for h in t.hits.iter().flatten() {
        assert!((h.point.distance(center) - 0.5).abs() < EXACT);
        assert!(h.point.distance(Point::ORIGIN) < center.norm());
    }
    let windows: Vec<WindowTruth> = t.windows.iter().flatten().copied().collect();
    assert_eq!(windows.len(), t.returns() - 2);
    assert!(windows.iter().all(|&w| w == WindowTruth::Curved));
    assert_eq!(t.true_edge_points().len(), windows.len());
    // Inside a round room every beam is at the radius.
    let t = Scene::arc(4.0, Point::new(0.5, -0.3))
        .cast(&Bearings::default(), Pose::new(0.5, -0.3, 1.0));
    assert!(t
        .hits
        .iter()
        .all(|h| h.is_some_and(|h| (h.range - 4.0).abs() < EXACT)));
}

#[test]
fn random_rooms_are_closed_and_reproducible() {
    for seed in 0..40 {
        let room = Scene::random_room(&mut seeded_rng(seed));
        assert_eq!(
            room,
            Scene::random_room(&mut seeded_rng(seed)),
            "seed {seed}"
        );
        assert!(room.walls.len() >= 4);
        let mut ids: Vec<SurfaceId> = room.walls.iter().map(|w| w.id).collect();
        ids.extend(room.arcs.iter().map(|a| a.id));
        let count = ids.len();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), count, "seed {seed}: ids unique");
        for b in Bearings::LMS_VARIANTS {
            let t = room.cast(&b, Pose::IDENTITY);
            assert_eq!(t.returns(), b.n, "seed {seed}: every beam hits");
            for &j in &t.jumps {
                assert!(j == 0 || t.windows[j - 1] == Some(WindowTruth::Jump));
                assert!(j + 1 >= t.windows.len() || t.windows[j] == Some(WindowTruth::Jump));
            }
        }
    }
    assert_ne!(
        Scene::random_room(&mut seeded_rng(1)),
        Scene::random_room(&mut seeded_rng(2))
    );
}

#[test]
fn noise_free_readings_are_the_true_ranges() {
    let t = scan(&Scene::corridor());
    let exact = t.noise_free();
    assert_eq!(t.noisy(&NoiseModel::NONE, &mut seeded_rng(5)), exact);
    for (r, h) in exact.iter().zip(&t.hits) {
        assert_eq!(r.metres(), h.map(|h| h.range));
    }
}

#[test]
fn noise_has_zero_mean_and_sigma_spread() {
    let t = scan(&Scene::room_with_box());
    let sigma = 0.01;
    let model = NoiseModel::gaussian(sigma);
    let mut rng = seeded_rng(2024);
    let (mut n, mut sum, mut sum2, mut within) = (0usize, 0.0, 0.0, 0usize);
    for _ in 0..400 {
        for (r, h) in t.noisy(&model, &mut rng).iter().zip(&t.hits) {
            let e = r.metres().unwrap() - h.unwrap().range;
            n += 1;
            sum += e;
            sum2 += e * e;
            within += usize::from(e.abs() <= sigma);
        }
    }
    let nf = n as f64;
    let mean = sum / nf;
    let std = (sum2 / nf - mean * mean).sqrt();
    // Five standard errors: 1.3e-4 m on the mean, 0.9 % on σ, 0.6 % on the
    // 1σ fraction (0.6827 for a Gaussian).
    assert!(mean.abs() < 5.0 * sigma / nf.sqrt(), "mean {mean}");
    assert!(
        (std / sigma - 1.0).abs() < 5.0 / (2.0 * nf).sqrt(),
        "std {std}"
    );
    let frac = within as f64 / nf;
    assert!(
        (frac - 0.6827).abs() < 5.0 * (0.6827 * 0.3173 / nf).sqrt(),
        "1σ fraction {frac}"
    );
}

#[test]
fn dropouts_at_their_rate() {
    let t = scan(&Scene::room_with_box());
    let p = 0.05;
    let model = NoiseModel::lms_mm().with_dropout(p);
    let mut rng = seeded_rng(9);
    let (mut dropped, mut total) = (0usize, 0usize);
    for _ in 0..100 {
        let readings = t.noisy(&model, &mut rng);
        dropped += readings.iter().filter(|r| !r.is_return()).count();
        total += readings.len();
        let raw = to_raw(&readings, Unit::Millimetre);
        for (v, r) in raw.iter().zip(&readings) {
            match r {
                Reading::Range(d) => assert_eq!(f64::from(*v), (d * 1000.0).round()),
                Reading::NoReturn => assert_eq!(*v, RAW_NO_ECHO),
            }
        }
    }
    let rate = dropped as f64 / total as f64;
    assert!(
        (rate - p).abs() < 5.0 * (p * (1.0 - p) / total as f64).sqrt(),
        "rate {rate}"
    );
}

#[test]
fn seeds_decide_the_readings() {
    let t = scan(&Scene::room_with_box());
    let model = NoiseModel::lms_mm().with_dropout(0.01);
    let a = t.noisy(&model, &mut seeded_rng(7));
    assert_eq!(a, t.noisy(&model, &mut seeded_rng(7)));
    let b = t.noisy(&model, &mut seeded_rng(8));
    assert_ne!(a, b);
    // Most beams differ between seeds (σ = 5 mm against 1 mm steps).
    let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert!(differ > 300, "{differ} of 361 differ");
}
