//! The map-derived truth (`lms_lab::maptruth`) and its scoring
//! (`lms_lab::realtruth`): on a synthetic log with known walls the map
//! finds the scene's walls and each frame's true lines; the scoring counts
//! hand-made cases as defined; on a real log the truth is what an
//! extractor that knew the walls scores well against.

use std::path::Path;

use host_bridge::carmen::{parse_log, Scan, UnitMode};
use lms_lab::maptruth::{build_map, frame_truth, refine_pose, FrameTruth, Piece, TruthConfig};
use lms_lab::realtruth::{
    candidate, methods, oracle_lines, run_log, score_frame, RealTally, ScoredLine, ORACLE,
};
use lms_scene::{wrap_angle, Bearings, Pose, Scene, Surface};

/// A CARMEN log (cm) of `scene` seen noise-free from `poses`.
fn synthetic_log(scene: &Scene, poses: &[Pose]) -> Vec<Scan> {
    synthetic_log_to(scene, poses, lms_scene::DEFAULT_MAX_RANGE)
}

/// [`synthetic_log`] with returns up to `max_range` (m).
fn synthetic_log_to(scene: &Scene, poses: &[Pose], max_range: f64) -> Vec<Scan> {
    let mut text = String::new();
    for (k, pose) in poses.iter().enumerate() {
        let truth = scene.cast_with_max_range(&Bearings::default(), *pose, max_range);
        let ranges: Vec<String> = truth
            .ranges()
            .iter()
            .map(|r| format!("{:.2}", r.unwrap_or(81.91)))
            .collect();
        text.push_str(&format!(
            "FLASER 361 {} {} {} {} 0 0 0 {k}.0 host {k}.0\n",
            ranges.join(" "),
            pose.x,
            pose.y,
            pose.theta
        ));
    }
    parse_log(text.as_bytes(), UnitMode::Auto).unwrap().1
}

fn room() -> (Scene, Vec<Pose>) {
    let scene = Scene::room_with_box();
    let poses = (0..24)
        .map(|k| {
            let t = k as f64 / 24.0 * std::f64::consts::TAU;
            Pose::new(0.3 + 0.4 * t.cos(), 0.1 + 0.3 * t.sin(), t)
        })
        .collect();
    (scene, poses)
}

#[test]
fn the_map_of_a_known_room_holds_its_walls_and_each_frames_lines() {
    let (scene, poses) = room();
    let scans = synthetic_log(&scene, &poses);
    let cfg = TruthConfig::default();
    let map = build_map(&scans, &cfg);
    // Every wall of at least `min_wall` seen with ≥ 10 beams in ≥ 3 frames
    // is a map wall (cm ranges, 5 cm cells).
    let mut walls = 0;
    for id in 0..scene.next_id() {
        let Some(Surface::Wall(w)) = scene.surface(id) else {
            continue;
        };
        let seen = poses
            .iter()
            .filter(|p| {
                let t = scene.cast(&Bearings::default(), **p);
                t.line(id).is_some_and(|l| l.beams >= 10)
            })
            .count();
        if seen < 3 || w.length() < cfg.min_wall + 0.05 {
            continue;
        }
        walls += 1;
        let line = lms_scene::PolarLine::through(w.a, w.b).unwrap();
        let found = map.walls.iter().any(|m| {
            let da = wrap_angle(m.alpha - line.alpha);
            let (da, dr) = if da.abs() > std::f64::consts::FRAC_PI_2 {
                (wrap_angle(da + std::f64::consts::PI), m.rho + line.r)
            } else {
                (da, m.rho - line.r)
            };
            da.abs() < 0.5f64.to_radians() && dr.abs() < 0.02
        });
        assert!(found, "wall {id} ({:.2} m) not in the map", w.length());
    }
    assert!(walls >= 5, "{walls} walls seen");
    assert!(map.walls.len() <= 10, "{} map walls", map.walls.len());
    // Each frame's true lines (≥ 10 beams, ≥ 0.3 m) are counted pieces.
    let (mut expected, mut found) = (0, 0);
    for (scan, pose) in scans.iter().zip(&poses) {
        let t = scene.cast(&Bearings::default(), *pose);
        let ft = frame_truth(scan, &map, &cfg);
        for l in &t.lines {
            // Unoccluded lines of walls the map can hold.
            let wall_len = match scene.surface(l.surface) {
                Some(Surface::Wall(w)) => w.length(),
                _ => 0.0,
            };
            if l.beams < 10
                || l.beams != l.last_beam - l.first_beam + 1
                || l.first_point.distance(l.last_point) < 0.35
                || wall_len < cfg.min_wall + 0.05
            {
                continue;
            }
            expected += 1;
            let ok = ft.pieces.iter().any(|p| {
                p.counted
                    && wrap_angle(p.alpha - l.alpha).abs() < 0.5f64.to_radians()
                    && (p.r - l.r).abs() < 0.02
                    // Beams within 4 of a corner may go to the other wall.
                    && p.first <= l.first_beam + 4
                    && p.last + 4 >= l.last_beam
            });
            found += usize::from(ok);
        }
        // The oracle matches every counted piece of a noise-free frame.
        let mut tally = RealTally::default();
        let valid = vec![true; scan.frame.len()];
        score_frame(&ft, &oracle_lines(&ft), &valid, &mut tally);
        assert_eq!(tally.matched, tally.pieces);
    }
    eprintln!("{found} of {expected} true lines found as counted pieces");
    assert!(expected > 60, "{expected}");
    assert_eq!(found, expected);
}

fn piece(first: usize, last: usize, alpha: f64, r: f64) -> Piece {
    Piece::hand_made(first..=last, (alpha, r), 2.0)
}

/// A wall seen at grazing incidence, far from the foot of its normal: a
/// line 1° off that crosses it at its middle misses the default Δr gate at
/// the foot (by 0.14 m) and passes it where the line is.
#[test]
fn the_range_gate_at_the_middle_keeps_a_line_on_a_far_grazing_wall() {
    // The wall x·cos 0 + y·sin 0 = 1 (α = 0, r = 1), seen from y = 7 to 9.
    let middle = [1.0, 8.0];
    let tilt = 1.0_f64.to_radians();
    // The line through the middle with α = 1°: r = middle·n.
    let r = middle[0] * tilt.cos() + middle[1] * tilt.sin();
    let line = ScoredLine {
        alpha: tilt,
        r,
        first: 10,
        last: 39,
        middle,
    };
    let at_foot = piece(10, 39, 0.0, 1.0);
    assert!((r - 1.0) > 0.13, "{r}");
    assert!(candidate(&FrameTruth::default(), &line, &at_foot).is_none());
    let at_middle = Piece {
        gate_at_middle: true,
        ..at_foot
    };
    let (da, dr) = candidate(&FrameTruth::default(), &line, &at_middle)
        .expect("on the wall where the line is");
    assert!((da - tilt).abs() < 1e-12 && dr.abs() < 1e-12, "{da} {dr}");
    // A line parallel to the wall 0.15 m off fails both.
    let off = ScoredLine {
        alpha: 0.0,
        r: 1.15,
        middle: [1.15, 8.0],
        ..line
    };
    assert!(
        candidate(&FrameTruth::default(), &off, &at_foot).is_none()
            && candidate(&FrameTruth::default(), &off, &at_middle).is_none()
    );
}

#[test]
fn scoring_counts_matches_fragments_and_lines_on_no_wall() {
    let mut on_wall = vec![None; 100];
    for w in on_wall.iter_mut().take(40).skip(10) {
        *w = Some(10);
    }
    for w in on_wall.iter_mut().take(80).skip(50) {
        *w = Some(50);
    }
    let truth = FrameTruth {
        on_wall,
        pieces: vec![piece(10, 39, 0.3, 2.0), piece(50, 79, -1.0, 3.0)],
        ..FrameTruth::default()
    };
    let line = |first, last, alpha, r| ScoredLine {
        alpha,
        r,
        first,
        last,
        middle: [0.0; 2],
    };
    let lines = [
        // Two lines on the first piece: one match, one fragment.
        line(10, 24, 0.3 + 0.01, 2.01),
        line(25, 39, 0.3 - 0.02, 1.98),
        // Outside the gates on the second piece (4°).
        line(50, 79, -1.0 + 4f64.to_radians(), 3.0),
        // On no wall.
        line(85, 99, 0.0, 1.0),
    ];
    let valid = vec![true; 100];
    let mut t = RealTally::default();
    let (walls, matched) = score_frame(&truth, &lines, &valid, &mut t);
    assert_eq!(matched, vec![true, false, false, false]);
    assert_eq!(walls.len(), 1);
    assert_eq!(
        (t.pieces, t.matched, t.lines, t.lines_matched),
        (2, 1, 4, 1)
    );
    assert_eq!((t.fragmented, t.lines_no_wall, t.lines_on_piece), (1, 1, 2));
    // Coverage: 15 of the 60 on-wall beams are inside the matched line.
    assert_eq!((t.covered_beams, t.wall_beams), (15, 60));
    let s = t.summary();
    assert_eq!(s.true_pos, 0.5);
    assert_eq!(s.false_pos, 0.75);
}

#[test]
fn a_frame_whose_pose_is_off_is_registered_back_onto_the_map() {
    let (scene, poses) = room();
    let scans = synthetic_log(&scene, &poses);
    let cfg = TruthConfig {
        refine_pose: true,
        ..TruthConfig::default()
    };
    let map = build_map(&scans, &cfg);
    let all: Vec<usize> = (0..map.walls.len()).collect();
    for k in [0, 7, 15] {
        let mut scan = scans[k].clone();
        let truth = scan.meta.pose;
        scan.meta.pose = [
            truth[0] + 0.03,
            truth[1] - 0.02,
            truth[2] + 0.6f64.to_radians(),
        ];
        let p = refine_pose(&scan, &map.walls, &all, &cfg);
        let (dxy, dth) = (
            (p[0] - truth[0]).hypot(p[1] - truth[1]),
            wrap_angle(p[2] - truth[2]).abs().to_degrees(),
        );
        assert!(dxy < 0.005 && dth < 0.05, "frame {k}: {dxy} m, {dth}°");
        // The registered truth's lines are the walls' from the true pose.
        let registered = frame_truth(&scan, &map, &cfg);
        let slam = frame_truth(&scan, &map, &TruthConfig::default());
        let worst = |t: &FrameTruth| {
            t.pieces
                .iter()
                .filter(|p| p.counted)
                .map(|p| wrap_angle(p.own_alpha - p.alpha).abs())
                .fold(0.0, f64::max)
                .to_degrees()
        };
        let (r, s) = (worst(&registered), worst(&slam));
        eprintln!("frame {k}: worst |own α − map α| {r:.3}° registered, {s:.3}° at the SLAM pose");
        assert!(r < 0.3 && s > 0.5, "{r}°, {s}°");
    }
}

#[test]
fn the_truth_covers_every_range_the_data_allows() {
    // A 20 m wall 45 m ahead, seen from 24 poses 1 cm apart (so that the
    // map's 5 cm cells fill in between beams 0.4 m apart).
    let mut scene = Scene::new();
    let wall = scene.add_wall(
        lms_scene::Point::new(45.0, -10.0),
        lms_scene::Point::new(45.0, 10.0),
    );
    let poses: Vec<Pose> = (0..24)
        .map(|k| Pose::new(0.0, k as f64 * 0.01, 0.0))
        .collect();
    let scans = synthetic_log_to(&scene, &poses, 80.0);
    let on_wall = |cfg: &TruthConfig| {
        let map = build_map(&scans, cfg);
        let t = frame_truth(&scans[12], &map, cfg);
        t.pieces
            .iter()
            .filter(|p| p.counted)
            .map(|p| p.beams)
            .sum::<usize>()
    };
    // The default truth stops at 40 m: the wall is in no frame's truth ...
    let cfg = TruthConfig::default();
    assert_eq!(on_wall(&cfg), 0);
    // ... over a cm log's 81.83 m it is, with the beams that see it.
    let seen = scene
        .cast_with_max_range(&Bearings::default(), poses[12], 80.0)
        .line(wall)
        .map_or(0, |l| l.beams);
    let counted = on_wall(&cfg.for_data(81.83));
    assert!(
        seen > 40 && counted + 2 >= seen,
        "{counted} of {seen} beams"
    );
}

#[test]
fn on_a_real_log_the_truth_is_found_by_an_extractor_that_knows_the_walls() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/carmen/orebro-corrected.log.gz");
    let all = methods();
    let oracle: Vec<_> = all.iter().copied().filter(|m| m.name == ORACLE).collect();
    let unverified = TruthConfig {
        verify: false,
        ..TruthConfig::default()
    };
    let r = run_log(&path, &oracle, 4, &unverified, None).unwrap();
    let s = r.tallies[0].summary();
    eprintln!(
        "orebro, every 4th frame: {} walls, {:.1} pieces/frame, oracle TruePos {:.3}",
        r.walls, r.pieces_per_frame, s.true_pos
    );
    assert!(r.walls > 40, "{} map walls", r.walls);
    assert!(r.pieces_per_frame > 2.0);
    // The oracle's misses are where the map and the frame disagree (pose,
    // curved walls, clutter against a wall, short pieces) ...
    assert!(s.true_pos > 0.8 && s.true_pos < 1.0, "{}", s.true_pos);
    assert!(s.coverage > 0.85);
    // ... which the verified truth leaves uncounted: the oracle finds all of
    // it, and fewer pieces are counted.
    let v = run_log(&path, &oracle, 4, &TruthConfig::default(), None).unwrap();
    let sv = v.tallies[0].summary();
    assert_eq!(sv.true_pos, 1.0);
    assert_eq!(sv.false_pos, 0.0);
    assert!(v.pieces_per_frame < r.pieces_per_frame);
    assert!(v.pieces_per_frame > 0.75 * r.pieces_per_frame);
}

#[test]
fn an_unverified_piece_is_not_counted_and_its_own_fit_is_not_false() {
    let mut on_wall = vec![None; 100];
    for w in on_wall.iter_mut().take(40).skip(10) {
        *w = Some(10);
    }
    // The map says α = 0.3; the frame's hits say α = 0.4 (5.7° off).
    let p = Piece {
        own_alpha: 0.4,
        own_r: 2.0,
        verified: false,
        counted: false,
        ..piece(10, 39, 0.3, 2.0)
    };
    let truth = FrameTruth {
        on_wall,
        pieces: vec![p],
        ..FrameTruth::default()
    };
    let valid = vec![true; 100];
    let on_map = ScoredLine {
        alpha: 0.3,
        r: 2.0,
        first: 10,
        last: 39,
        middle: [0.0; 2],
    };
    let on_frame = ScoredLine {
        alpha: 0.4,
        r: 2.0,
        first: 10,
        last: 39,
        middle: [0.0; 2],
    };
    let mut t = RealTally::default();
    score_frame(&truth, &[on_frame], &valid, &mut t);
    assert_eq!((t.pieces, t.lines, t.lines_matched), (0, 1, 1));
    let mut t = RealTally::default();
    score_frame(&truth, &[on_map], &valid, &mut t);
    assert_eq!((t.pieces, t.lines, t.lines_matched), (0, 1, 0));
}

#[test]
fn the_sensor_fit_recovers_a_known_model() {
    use lms_lab::sensorfit::{bins, fit, model_for, model_triples};
    use lms_scene::LogMode;
    // σ₀ = 8 mm, κ = 3 mrad, mm ranges, 1° (no interleave), no motion.
    let model = model_for(LogMode::Mm32, 0.001, 0.008, 0.003);
    let b = bins(&model_triples(&model, 0.0, &Bearings::lms_180_1deg(), 60));
    let (s0, k, _) = fit(&b, 0.001, false);
    eprintln!("fitted σ₀ {:.2} mm, κ {:.2} mrad", s0 * 1e3, k * 1e3);
    assert!((s0 - 0.008).abs() < 0.0015, "σ₀ {s0}");
    assert!((k - 0.003).abs() < 0.001, "κ {k}");
}
