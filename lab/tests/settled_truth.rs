//! The settled truth (`TruthConfig::settled`): its scoring rules on
//! hand-made frames (true, false, unexplained and neutral lines), beams on
//! two parallel map walls close together, leave-one-wall-out registration
//! on a synthetic log with one wall moved in one frame, and the whole truth
//! on a noise-free synthetic log.

use host_bridge::carmen::{parse_log, Scan, UnitMode};
use lms_lab::maptruth::{
    build_map, candidates_at, frame_truth, frame_truth_registered, register, register_log,
    FrameTruth, Map, MapWall, Piece, TruthConfig,
};
use lms_lab::realtruth::{oracle_lines, score_frame, RealTally, ScoredLine};
use lms_scene::{wrap_angle, Bearings, Pose, Scene};

/// A cm CARMEN log of `ranges` per frame (m; `None`: no return) at `poses`.
fn log_of(frames: &[(Vec<Option<f64>>, Pose)]) -> Vec<Scan> {
    let mut text = String::new();
    for (k, (ranges, pose)) in frames.iter().enumerate() {
        let r: Vec<String> = ranges
            .iter()
            .map(|r| format!("{:.2}", r.unwrap_or(81.91)))
            .collect();
        text.push_str(&format!(
            "FLASER {} {} {} {} {} 0 0 0 {k}.0 host {k}.0\n",
            r.len(),
            r.join(" "),
            pose.x,
            pose.y,
            pose.theta
        ));
    }
    parse_log(text.as_bytes(), UnitMode::Auto).unwrap().1
}

fn ranges(scene: &Scene, pose: Pose) -> Vec<Option<f64>> {
    scene.cast(&Bearings::default(), pose).ranges()
}

fn piece(first: usize, last: usize, alpha: f64, r: f64, counted: bool) -> Piece {
    Piece {
        counted,
        ..Piece::hand_made(first..=last, (alpha, r), 1.5)
    }
}

fn line(first: usize, last: usize, alpha: f64, r: f64) -> ScoredLine {
    ScoredLine {
        alpha,
        r,
        first,
        last,
        middle: [r * alpha.cos(), r * alpha.sin()],
    }
}

/// Beams 10–39 a counted piece (A); 50–56 a piece of 7 beams; 60–79 on no
/// wall; 85–99 ambiguous; 100–117 and 120–139 counted pieces (C, D) with
/// two beams on no wall between them.
fn hand_made(rules: bool) -> FrameTruth {
    let mut on_wall = vec![None; 140];
    let mut ambiguous = vec![false; 140];
    let pieces = vec![
        piece(10, 39, 0.3, 2.0, true),
        piece(50, 56, -0.5, 3.0, false),
        piece(100, 117, 1.0, 2.5, true),
        piece(120, 139, 2.0, 2.5, true),
    ];
    for p in &pieces {
        for w in &mut on_wall[p.first..=p.last] {
            *w = Some(p.line);
        }
    }
    for a in &mut ambiguous[85..=99] {
        *a = true;
    }
    FrameTruth {
        on_wall,
        pieces,
        ambiguous,
        neutral_and_unexplained: rules,
        overlap_without_ambiguous: false,
    }
}

#[test]
fn unexplained_and_neutral_lines_are_not_false_and_fragments_are() {
    let off = 20f64.to_radians();
    let lines = [
        // Matches A: true.
        line(10, 24, 0.3 + 0.01, 2.01),
        // The rest of A, A taken: a fragment, false.
        line(25, 39, 0.3 - 0.02, 1.98),
        // Matches the 7-beam piece: neutral.
        line(50, 56, -0.5, 3.0),
        // On no wall: unexplained.
        line(60, 79, 0.0, 1.0),
        // On the ambiguous beams: neutral.
        line(85, 99, 0.2, 1.0),
        // Across the corner of C and D, four beams on each: false.
        line(114, 123, 1.0 + off, 2.5),
    ];
    let valid = vec![true; 140];
    let mut t = RealTally::default();
    let (_, matched) = score_frame(&hand_made(true), &lines, &valid, &mut t);
    assert_eq!(matched, vec![true, false, true, false, false, false]);
    assert_eq!((t.pieces, t.matched), (3, 1));
    assert_eq!(
        (
            t.lines_true,
            t.lines_false,
            t.lines_unexplained,
            t.lines_neutral
        ),
        (1, 2, 1, 2)
    );
    assert_eq!(t.lines_fragment, 1);
    let s = t.summary();
    assert_eq!(s.false_pos, 2.0 / 3.0);
    assert_eq!(s.unexplained, 1.0 / 6.0);
    // Invalid beams count as on no wall: the across-corner line with its
    // wall beams invalid is unexplained.
    let mut invalid = valid.clone();
    for v in &mut invalid[114..=123] {
        *v = false;
    }
    let mut t = RealTally::default();
    score_frame(&hand_made(true), &lines, &invalid, &mut t);
    assert_eq!((t.lines_false, t.lines_unexplained), (1, 2));
    // Without the rules every unmatched line is false, every matched one true.
    let mut t = RealTally::default();
    score_frame(&hand_made(false), &lines, &valid, &mut t);
    assert_eq!((t.lines_true, t.lines_false, t.lines_neutral), (2, 4, 0));
    assert_eq!(t.summary().false_pos, 4.0 / 6.0);
}

#[test]
fn a_seven_beam_piece_is_neither_found_nor_missed() {
    let truth = hand_made(true);
    let valid = vec![true; 140];
    // A line on the 7-beam piece, matched or not: no TruePos, no FalsePos.
    for l in [line(50, 56, -0.5, 3.0), line(50, 56, 0.5, 3.0)] {
        let mut t = RealTally::default();
        score_frame(&truth, &[l], &valid, &mut t);
        assert_eq!((t.lines_true, t.lines_false, t.lines_neutral), (0, 0, 1));
        assert_eq!(t.pieces, 3, "the 7-beam piece is not counted");
    }
}

#[test]
fn ambiguous_beams_count_against_the_overlap_unless_the_truth_leaves_them_out() {
    // A line along C (beams 100–117) from beam 80: 18 of its 38 beams on C
    // (0.47), 15 of the rest ambiguous (85–99).
    let along_c = line(80, 117, 1.0, 2.5);
    let valid = vec![true; 140];
    let matched = |without: bool| {
        let truth = FrameTruth {
            overlap_without_ambiguous: without,
            ..hand_made(true)
        };
        let mut t = RealTally::default();
        score_frame(&truth, &[along_c], &valid, &mut t);
        t.matched
    };
    assert_eq!(matched(false), 0);
    // Left out, 18 of 23 beams (0.78): C is found.
    assert_eq!(matched(true), 1);
    // A line that is mostly on no wall stays unmatched either way.
    let mostly_off = FrameTruth {
        overlap_without_ambiguous: true,
        ..hand_made(true)
    };
    let mut t = RealTally::default();
    score_frame(&mostly_off, &[line(60, 117, 1.0, 2.5)], &valid, &mut t);
    assert_eq!(t.matched, 0);
}

fn wall(x: f64, line: usize) -> MapWall {
    MapWall {
        a: [x, -2.0],
        b: [x, 2.0],
        alpha: 0.0,
        rho: x,
        cells: 80,
        line,
    }
}

#[test]
fn beams_on_two_parallel_map_walls_within_15_cm_are_ambiguous() {
    let mut scene = Scene::new();
    scene.add_wall(
        lms_scene::Point::new(2.0, -1.0),
        lms_scene::Point::new(2.0, 1.0),
    );
    let pose = Pose::new(0.0, 0.0, 0.0);
    let scans = log_of(&[(ranges(&scene, pose), pose)]);
    let cfg = TruthConfig::settled().for_data(81.83);
    let truth_with = |second: f64| {
        let map = Map {
            cells: Vec::new(),
            walls: vec![wall(2.0, 0), wall(second, 1)],
        };
        frame_truth(&scans[0], &map, &cfg)
    };
    // The map holds the wall twice, 10 cm apart: its beams are on neither.
    let double = truth_with(2.1);
    let ambiguous = double.ambiguous.iter().filter(|&&a| a).count();
    assert!(ambiguous > 50, "{ambiguous} ambiguous beams");
    assert!(double.pieces.iter().all(|p| !p.counted));
    // 30 cm apart they are two walls: the beams are on the nearer one.
    let apart = truth_with(2.3);
    assert!(apart.ambiguous.is_empty());
    let counted: Vec<&Piece> = apart.pieces.iter().filter(|p| p.counted).collect();
    assert_eq!(counted.len(), 1);
    assert_eq!(counted[0].line, 0);
    assert!(counted[0].beams > 50);
}

/// A log's frames: each pose's ranges (`None`: no return) and the pose.
type Frames = Vec<(Vec<Option<f64>>, Pose)>;

/// The room with a box seen from 24 poses on an ellipse: the scene, the
/// poses and each pose's noise-free ranges.
fn room_on_a_circle() -> (Scene, Vec<Pose>, Frames) {
    let scene = Scene::room_with_box();
    let poses: Vec<Pose> = (0..24)
        .map(|k| {
            let t = k as f64 / 24.0 * std::f64::consts::TAU;
            Pose::new(0.3 + 0.4 * t.cos(), 0.1 + 0.3 * t.sin(), t)
        })
        .collect();
    let frames = poses.iter().map(|p| (ranges(&scene, *p), *p)).collect();
    (scene, poses, frames)
}

#[test]
fn leave_one_wall_out_does_not_absorb_an_offset_of_the_wall_it_judges() {
    // The room with a box from 24 poses; in frame 5 the hits on the wall
    // with the most beams lie 3 cm behind it.
    let (scene, poses, frames) = room_on_a_circle();
    let clean = log_of(&frames);
    let cfg = TruthConfig::settled().for_data(81.83);
    let map = build_map(&clean, &cfg);
    let k = 5;
    let cast = scene.cast(&Bearings::default(), poses[k]);
    let moved = cast.lines.iter().max_by_key(|l| l.beams).unwrap();
    let offset = 0.03;
    let mut shifted = frames[k].0.clone();
    for (j, hit) in cast.hits.iter().enumerate() {
        if let (Some(h), Some(r)) = (hit, shifted[j].as_mut()) {
            if h.surface == moved.surface {
                *r += offset * h.range / moved.r;
            }
        }
    }
    let scan = &log_of(&[(shifted, poses[k])])[0];
    // The frame registered with every wall: the offset pulls its pose.
    let cands = candidates_at(scan, &map.walls, scan.meta.pose, &cfg);
    let pose = register(
        scan,
        &map.walls,
        &cands,
        &cfg,
        (scan.meta.pose, scan.meta.pose),
        None,
    );
    let pulled = (pose[0] - poses[k].x).hypot(pose[1] - poses[k].y);
    let dr = |cfg: &TruthConfig| {
        let t = frame_truth_registered(scan, &map, pose, cfg);
        let p = t
            .pieces
            .iter()
            .filter(|p| p.counted)
            .max_by_key(|p| p.beams)
            .unwrap();
        assert!(p.first <= moved.first_beam + 4 && p.last + 4 >= moved.last_beam);
        p.own_r - p.r
    };
    let without = dr(&TruthConfig {
        leave_one_wall_out: false,
        ..cfg
    });
    let with = dr(&cfg);
    eprintln!(
        "pose pulled {:.1} mm; the wall's offset {:.1} mm through it, {:.1} mm left out",
        pulled * 1e3,
        without * 1e3,
        with * 1e3
    );
    assert!(pulled > 0.003, "{pulled}");
    assert!(without < offset - 0.004, "{without}");
    assert!((with - offset).abs() < 0.004, "{with}");
}

#[test]
fn on_a_noise_free_log_registration_keeps_the_poses_and_the_oracle_finds_every_piece() {
    let (_, poses, frames) = room_on_a_circle();
    let scans = log_of(&frames);
    let cfg = TruthConfig::settled().for_data(81.83);
    let (map, registered) = register_log(&scans, build_map(&scans, &cfg), &cfg);
    assert!(map.walls.len() >= 5, "{} walls", map.walls.len());
    let (mut pieces, mut frames_with) = (0, 0);
    for ((scan, pose), truth_pose) in scans.iter().zip(&registered).zip(&poses) {
        let dxy = (pose[0] - truth_pose.x).hypot(pose[1] - truth_pose.y);
        let dth = wrap_angle(pose[2] - truth_pose.theta).abs().to_degrees();
        assert!(dxy < 0.005 && dth < 0.1, "{dxy} m, {dth}°");
        let t = frame_truth_registered(scan, &map, *pose, &cfg);
        let mut tally = RealTally::default();
        let valid = vec![true; scan.frame.len()];
        score_frame(&t, &oracle_lines(&t), &valid, &mut tally);
        assert_eq!(tally.matched, tally.pieces);
        assert_eq!(tally.lines_false, 0);
        pieces += tally.pieces;
        frames_with += usize::from(tally.pieces > 0);
    }
    assert!(pieces > 60 && frames_with == 24, "{pieces} pieces");
}
