//! Where the defaults' errors on the real logs come from (the settled map truth,
//! `lab/src/maptruth.rs`; matching, `lab/src/realtruth.rs`).
//!
//! - **Unmatched lines**, by cause (the settled truth's FalsePos counts
//!   the ones on a wall; those on no wall are unexplained, and neutral ones
//!   are among them too): on no map wall — on static structure (its
//!   hits in or next to occupied map cells) that the map's wall extraction
//!   did not make a wall, or on things seen in too few frames to be in the
//!   map — or on a wall: a second line on a piece (a fragment), a line
//!   on a piece that misses the Δα or Δr gate, a line over several pieces.
//!   Gate misses are also given as |z| = |Δ| / the line's own σ, and as
//!   the share whose beams lie (≥ 95 %) on the piece's wall: a line that
//!   follows the wall's surface inside the truth's 0.1 m band, not one that
//!   runs off it.
//! - **Missed pieces** (counted, matched by no line), by cause: no line on
//!   any of its beams, lines on it off the gates, or only lines that lie
//!   mostly elsewhere (over a missed corner, across a gap); for the pieces
//!   without a line, the share of their beams in segments (§6), the rms of
//!   their hits about their own fit, incidence and range; and those a line
//!   within both gates covers that fails only the overlap, with how many of
//!   its beams beyond the piece are ambiguous or on the piece's line.
//!
//! `cargo run --release -p lms-lab --example real_errors -- [EVERY]`

use std::collections::HashSet;
use std::path::Path;

use anyhow::Result;
use host_bridge::carmen::Scan;
use lms_core::Extractor;
use lms_lab::baselines::{run_core, Extraction};
use lms_lab::maptruth::{world_hit, FrameTruth, Piece, TruthConfig};
use lms_lab::realtruth::{
    candidate, gate_offsets, overlap, score_frame, within_gates, RealTally, ScoredLine,
    GATE_ALPHA_DEG, GATE_OVERLAP,
};

/// Causes of false lines, in the order printed.
const FALSE_CAUSES: [&str; 6] = [
    "no wall, static",
    "no wall, seen in few frames",
    "fragment",
    "off Δα",
    "off Δr only",
    "over several pieces",
];

/// A piece no line touches.
struct Unlined {
    /// Share of its on-wall beams inside segments.
    in_segments: f64,
    /// Rms of its on-wall hits about their own fit (mm).
    rms_mm: f64,
    /// Angle between the middle beam and the wall's normal (degrees).
    incidence_deg: f64,
    /// Range of the middle beam (m).
    range: f64,
}

/// One log's (or all logs') errors.
#[derive(Default)]
struct Errors {
    lines: usize,
    false_by_cause: [usize; 6],
    false_short: usize,
    static_along: usize,
    /// Lines over several pieces whose on-wall beams all lie on one map
    /// line, and that line within the gates: one wall seen past an occluder.
    several_one_wall: usize,
    /// Missed pieces with an unmatched line within both gates that
    /// covers ≥ 80 % of their on-wall beams but fails the overlap.
    overlap_only: usize,
    /// The beams of those lines outside their piece, those ambiguous and
    /// those within 5 cm of the piece's line.
    overlap_only_beams: [usize; 3],
    /// Lines on no wall: share of their valid beams on a map wall.
    no_wall_on: Vec<f64>,
    gate_z: Vec<f64>,
    gate_inside: Vec<f64>,
    pieces: usize,
    missed: [usize; 3],
    unlined: Vec<Unlined>,
    /// Per pair of consecutive lines on one counted piece (a fragment):
    /// χ² per point of a TLS fit to the pair's union at σ, and whether
    /// their parameters agree within `merge_gate` (§7.6).
    fragment_pairs: Vec<(f64, bool)>,
}

impl Errors {
    fn add(&mut self, o: Errors) {
        self.lines += o.lines;
        for (a, b) in self.false_by_cause.iter_mut().zip(o.false_by_cause) {
            *a += b;
        }
        self.false_short += o.false_short;
        self.static_along += o.static_along;
        self.several_one_wall += o.several_one_wall;
        self.overlap_only += o.overlap_only;
        for (a, b) in self.overlap_only_beams.iter_mut().zip(o.overlap_only_beams) {
            *a += b;
        }
        self.no_wall_on.extend(o.no_wall_on);
        self.gate_z.extend(o.gate_z);
        self.gate_inside.extend(o.gate_inside);
        self.pieces += o.pieces;
        for (a, b) in self.missed.iter_mut().zip(o.missed) {
            *a += b;
        }
        self.unlined.extend(o.unlined);
        self.fragment_pairs.extend(o.fragment_pairs);
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn on_wall_beams(truth: &FrameTruth, p: &Piece) -> Vec<usize> {
    (p.first..=p.last)
        .filter(|&j| truth.on_wall[j] == Some(p.line))
        .collect()
}

/// Share of 5 cm steps along `line`'s segment (world frame) next to an
/// occupied map cell: near 1 where the map holds a straight structure all
/// along the line.
fn along_map(scan: &Scan, line: &lms_core::Line, on_static: &dyn Fn([f64; 2]) -> bool) -> f64 {
    let [x, y, th] = scan.meta.pose;
    let w = |p: [f32; 2]| {
        let (px, py) = (f64::from(p[0]), f64::from(p[1]));
        [
            x + th.cos() * px - th.sin() * py,
            y + th.sin() * px + th.cos() * py,
        ]
    };
    let (a, b) = (w(line.endpoints[0]), w(line.endpoints[1]));
    let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.05).ceil().max(1.0) as usize;
    let on = (0..=n)
        .filter(|&i| {
            let t = i as f64 / n as f64;
            on_static([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
        })
        .count();
    on as f64 / (n + 1) as f64
}

/// Whether the on-wall beams of `l` (of `beams`) all lie on one map line
/// and `l` is within the gates of a piece of it.
fn one_wall(truth: &FrameTruth, l: &ScoredLine, beams: &[usize]) -> bool {
    let mut ids = beams.iter().filter_map(|&j| truth.on_wall[j]);
    let Some(id) = ids.next() else {
        return false;
    };
    ids.all(|k| k == id)
        && truth
            .pieces
            .iter()
            .any(|p| p.line == id && within_gates(gate_offsets(l, p.reference(), p.gate_at_middle)))
}

/// Counts `p` in [`Errors::overlap_only`] if an unmatched line of `on_it`
/// lies within both gates of it and covers ≥ 80 % of its on-wall beams,
/// but fails the overlap; with that line's beams outside the piece.
fn overlap_only(
    scan: &Scan,
    truth: &FrameTruth,
    p: &Piece,
    on_it: &[(&ScoredLine, bool)],
    e: &mut Errors,
) {
    let on = on_wall_beams(truth, p);
    let covers = |l: &ScoredLine| {
        let inside = on
            .iter()
            .filter(|&&j| (l.first..=l.last).contains(&j))
            .count();
        5 * inside >= 4 * on.len()
    };
    let Some((l, _)) = on_it.iter().find(|(l, u)| {
        !*u && covers(l) && within_gates(gate_offsets(l, p.reference(), p.gate_at_middle))
    }) else {
        return;
    };
    e.overlap_only += 1;
    let (g, rg) = (scan.frame.geometry(), scan.frame.ranges());
    let (alpha, r) = p.reference();
    for j in (l.first..=l.last).filter(|&j| !(p.first..=p.last).contains(&j)) {
        let b = &mut e.overlap_only_beams;
        b[0] += 1;
        b[1] += usize::from(truth.ambiguous.get(j) == Some(&true));
        let off = f64::from(rg[j]) * (f64::from(g.bearing(j)) - alpha).cos() - r;
        b[2] += usize::from(scan.frame.beams()[j].is_valid() && off.abs() < 0.05);
    }
}

/// The false lines of one frame.
fn false_lines(
    scan: &Scan,
    truth: &FrameTruth,
    x: &Extraction,
    used: &[bool],
    on_static: &dyn Fn([f64; 2]) -> bool,
    e: &mut Errors,
) {
    let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
    for (line, _) in x.lines.iter().zip(used).filter(|(_, &u)| !u) {
        let l = ScoredLine::from(line);
        let beams: Vec<usize> = (l.first..=l.last).filter(|&j| valid[j]).collect();
        let half = |n: usize| 2 * n >= beams.len().max(1);
        let on = beams
            .iter()
            .filter(|&&j| truth.on_wall[j].is_some())
            .count();
        let piece = truth
            .pieces
            .iter()
            .find(|p| overlap(l.first, l.last, p.first, p.last) >= GATE_OVERLAP);
        let cause = match piece {
            _ if !half(on) => {
                e.no_wall_on.push(on as f64 / beams.len().max(1) as f64);
                let st = beams
                    .iter()
                    .filter(|&&j| on_static(world_hit(scan, j)))
                    .count();
                if half(st) {
                    e.static_along += usize::from(along_map(scan, line, on_static) >= 0.9);
                    0
                } else {
                    1
                }
            }
            None => {
                e.several_one_wall += usize::from(one_wall(truth, &l, &beams));
                5
            }
            Some(p) => {
                let (da, dr) = gate_offsets(&l, p.reference(), p.gate_at_middle);
                let off_alpha = da.abs() >= GATE_ALPHA_DEG.to_radians();
                if candidate(truth, &l, p).is_some() {
                    2
                } else {
                    let inside = (l.first..=l.last)
                        .filter(|&j| valid[j] && truth.on_wall[j] == Some(p.line))
                        .count();
                    e.gate_inside
                        .push(inside as f64 / beams.len().max(1) as f64);
                    e.gate_z.push(if off_alpha {
                        da.abs() / f64::from(line.cov.a).sqrt()
                    } else {
                        dr.abs() / f64::from(line.cov.c).sqrt()
                    });
                    if off_alpha {
                        3
                    } else {
                        4
                    }
                }
            }
        };
        e.false_by_cause[cause] += 1;
        e.false_short += usize::from(beams.len() < 10);
    }
}

/// The counted pieces of one frame that no line matches.
fn missed_pieces(scan: &Scan, truth: &FrameTruth, x: &Extraction, used: &[bool], e: &mut Errors) {
    let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
    let (g, rg) = (scan.frame.geometry(), scan.frame.ranges());
    for p in truth.pieces.iter().filter(|p| p.counted) {
        e.pieces += 1;
        let on_it: Vec<(&ScoredLine, bool)> = lines
            .iter()
            .zip(used)
            .filter(|(l, _)| l.first <= p.last && p.first <= l.last)
            .map(|(l, &u)| (l, u))
            .collect();
        if on_it
            .iter()
            .any(|(l, u)| *u && candidate(truth, l, p).is_some())
        {
            continue;
        }
        if !on_it.is_empty() {
            let mostly_on = on_it
                .iter()
                .any(|(l, _)| overlap(l.first, l.last, p.first, p.last) >= GATE_OVERLAP);
            e.missed[if mostly_on { 1 } else { 2 }] += 1;
            overlap_only(scan, truth, p, &on_it, e);
            continue;
        }
        e.missed[0] += 1;
        let on = on_wall_beams(truth, p);
        let in_segments = on
            .iter()
            .filter(|&&j| {
                x.segments
                    .iter()
                    .any(|s| (usize::from(s.first)..=usize::from(s.last)).contains(&j))
            })
            .count();
        let e2: f64 = on
            .iter()
            .map(|&j| {
                let d = f64::from(rg[j]) * (f64::from(g.bearing(j)) - p.own_alpha).cos() - p.own_r;
                d * d
            })
            .sum();
        let mid = on[on.len() / 2];
        e.unlined.push(Unlined {
            in_segments: in_segments as f64 / on.len().max(1) as f64,
            rms_mm: (e2 / on.len().max(1) as f64).sqrt() * 1e3,
            incidence_deg: lms_scene::wrap_angle(f64::from(g.bearing(mid)) - p.alpha)
                .abs()
                .to_degrees(),
            range: f64::from(rg[mid]),
        });
    }
}

const OWN: bool = true;
/// The pairs of consecutive lines that both match one counted piece.
fn fragment_pairs(
    scan: &Scan,
    truth: &FrameTruth,
    x: &Extraction,
    params: &lms_core::Params,
    e: &mut Errors,
) {
    let (g, rg, b) = (
        scan.frame.geometry(),
        scan.frame.ranges(),
        scan.frame.beams(),
    );
    let sigma = f64::from(params.sigma);
    for p in truth.pieces.iter().filter(|p| p.counted) {
        let on: Vec<&lms_core::Line> = x
            .lines
            .iter()
            .filter(|l| candidate(truth, &ScoredLine::from(*l), p).is_some())
            .collect();
        for w in on.windows(2) {
            let (l1, l2) = (w[0], w[1]);
            let da = lms_scene::wrap_angle(f64::from(l2.alpha) - f64::from(l1.alpha));
            let dr = f64::from(l2.r) - f64::from(l1.r);
            let (a, c, o) = (
                f64::from(l1.cov.a) + f64::from(l2.cov.a),
                f64::from(l1.cov.c) + f64::from(l2.cov.c),
                f64::from(l1.cov.b) + f64::from(l2.cov.b),
            );
            let d2 = (c * da * da - 2.0 * o * da * dr + a * dr * dr) / (a * c - o * o);
            let own = |j: usize| {
                (usize::from(l1.first)..=usize::from(l1.last)).contains(&j)
                    || (usize::from(l2.first)..=usize::from(l2.last)).contains(&j)
            };
            let pts: Vec<[f64; 2]> = (usize::from(l1.first)..=usize::from(l2.last))
                .filter(|&j| b[j].is_valid() && rg[j] < params.max_range && (!OWN || own(j)))
                .map(|j| {
                    let (d, phi) = (f64::from(rg[j]), f64::from(g.bearing(j)));
                    [d * phi.cos(), d * phi.sin()]
                })
                .collect();
            let (alpha, r) = lms_lab::metrics::tls(&pts);
            let rss: f64 = pts
                .iter()
                .map(|q| (q[0] * alpha.cos() + q[1] * alpha.sin() - r).powi(2))
                .sum();
            let chi2 = rss / (sigma * sigma) / (pts.len() as f64 - 2.0).max(1.0);
            e.fragment_pairs
                .push((chi2, d2 < f64::from(params.merge_gate)));
        }
    }
}

fn log_errors(path: &Path, every: usize, cfg: &TruthConfig) -> Result<Errors> {
    let loaded = lms_lab::realtruth::load_with_map(path, cfg)?;
    let lms_lab::realtruth::LogWithMap {
        log,
        no_flags: params,
        cfg,
        map,
        ..
    } = &loaded;
    let params = *params;
    let cell = |p: [f64; 2]| {
        (
            (p[0] / cfg.cell).floor() as i64,
            (p[1] / cfg.cell).floor() as i64,
        )
    };
    let occupied: HashSet<(i64, i64)> = map.cells.iter().map(|c| cell(c.p)).collect();
    // A hit is on static structure if its cell or a neighbour is occupied.
    let on_static = |p: [f64; 2]| {
        let (cx, cy) = cell(p);
        (-1..=1).any(|dx| (-1..=1).any(|dy| occupied.contains(&(cx + dx, cy + dy))))
    };
    let mut ex = Extractor::new();
    let mut e = Errors::default();
    for (index, scan) in log.scans.iter().enumerate().step_by(every) {
        let truth = loaded.truth(index);
        let x = run_core(&mut ex, &scan.frame, &params);
        let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
        let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
        let (_, used) = score_frame(&truth, &lines, &valid, &mut RealTally::default());
        e.lines += lines.len();
        false_lines(scan, &truth, &x, &used, &on_static, &mut e);
        missed_pieces(scan, &truth, &x, &used, &mut e);
        fragment_pairs(scan, &truth, &x, &params, &mut e);
    }
    Ok(e)
}

fn fragment_row(name: &str, e: &Errors) -> String {
    let f = &e.fragment_pairs;
    let n = f.len().max(1) as f64;
    let mut chi: Vec<f64> = f.iter().map(|p| p.0).collect();
    chi.sort_by(f64::total_cmp);
    let q = |k: usize| chi.get(k * chi.len() / 4).copied().unwrap_or(f64::NAN);
    format!(
        "| {name} | {} | {:.3} | {:.3} | {:.1}, {:.1}, {:.1} |",
        f.len(),
        f.iter().filter(|p| p.0 > 4.0).count() as f64 / n,
        f.iter().filter(|p| p.1).count() as f64 / n,
        q(1),
        q(2),
        q(3)
    )
}

fn rows(name: &str, e: &Errors) -> (String, String) {
    let nf: usize = e.false_by_cause.iter().sum();
    let share = |n: usize, d: usize| format!("{:.3}", n as f64 / d.max(1) as f64);
    let causes: Vec<String> = e.false_by_cause.iter().map(|&c| share(c, nf)).collect();
    let false_row = format!(
        "| {name} | {} | {} | {} | {} | {} | {:.1} | {} |",
        e.lines,
        share(nf, e.lines),
        causes.join(" | "),
        share(e.static_along, e.false_by_cause[0]),
        share(e.false_short, nf),
        median(e.gate_z.clone()),
        share(
            e.gate_inside.iter().filter(|&&f| f >= 0.95).count(),
            e.gate_inside.len()
        ),
    );
    let nm: usize = e.missed.iter().sum();
    let u = &e.unlined;
    let missed_row = format!(
        "| {name} | {} | {} | {} | {} | {} | {} | {:.0} | {:.0} | {:.1} |",
        e.pieces,
        share(nm, e.pieces),
        share(e.missed[0], nm),
        share(e.missed[1], nm),
        share(e.missed[2], nm),
        share(u.iter().filter(|u| u.in_segments < 0.25).count(), u.len()),
        median(u.iter().map(|u| u.rms_mm).collect()),
        median(u.iter().map(|u| u.incidence_deg).collect()),
        median(u.iter().map(|u| u.range).collect()),
    );
    (false_row, missed_row)
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let cfg = TruthConfig::settled();
    let (mut false_md, mut missed_md, mut frag_md) = (Vec::new(), Vec::new(), Vec::new());
    let mut all = Errors::default();
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let e = log_errors(&path, every, &cfg)?;
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let (f, m) = rows(&name, &e);
        frag_md.push(fragment_row(&name, &e));
        false_md.push(f);
        missed_md.push(m);
        all.add(e);
    }
    let (f, m) = rows("all", &all);
    frag_md.push(fragment_row("all", &all));
    false_md.push(f);
    missed_md.push(m);
    println!(
        "Unmatched lines of the defaults (every {every}th frame), shares of the unmatched lines:\n\n\
         | log | lines | unmatched | {} | of the static: map structure all along | < 10 beams | \
         median \\|z\\| off the gates | off the gates, ≥ 95 % on the wall |\n\
         |:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n{}\n",
        FALSE_CAUSES.join(" | "),
        false_md.join("\n")
    );
    println!(
        "Missed counted pieces, shares of the missed; the last four columns are the pieces \
         no line touches:\n\n\
         | log | counted pieces | missed | no line | lines off the gates | lines mostly elsewhere | \
         < ¼ of beams in segments | median rms about own fit (mm) | median incidence (°) | \
         median range (m) |\n\
         |:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n{}",
        missed_md.join("\n")
    );
    println!(
        "\nFragments: pairs of consecutive lines that both match one counted piece; χ² per \
         point of a TLS fit to their union's hits at σ (the merge's refit needs ≤ 4):\n\n\
         | log | pairs | union χ² > 4 | parameters within the merge gate | union χ² quartiles |\n\
         |:---|---:|---:|---:|---:|\n{}",
        frag_md.join("\n")
    );
    println!(
        "\nOf the {} lines over several pieces, {} lie on one map line within the gates \
         (one wall past an occluder).",
        all.false_by_cause[5], all.several_one_wall
    );
    let b = all.overlap_only_beams;
    println!(
        "Of the {} missed counted pieces, {} have an unmatched line within both gates that covers \
         ≥ 80 % of their on-wall beams and fails only the overlap; of its {} beams outside the \
         piece, {:.2} are ambiguous and {:.2} within 5 cm of the piece's line.",
        all.missed.iter().sum::<usize>(),
        all.overlap_only,
        b[0],
        b[1] as f64 / b[0].max(1) as f64,
        b[2] as f64 / b[0].max(1) as f64,
    );
    let h = &all.no_wall_on;
    let at = |lo: f64, hi: f64| h.iter().filter(|&&x| x >= lo && x < hi).count();
    println!(
        "Of the {} lines on no wall, share of their beams on a map wall: 0: {}, (0, ¼): {}, [¼, ½): {}.",
        h.len(),
        at(0.0, 1e-9),
        at(1e-9, 0.25),
        at(0.25, 0.5)
    );
    Ok(())
}
