//! Why a wall is reported twice on the settled truth (docs/DESIGN.md,
//! "Parameters"): for every false line that is a fragment of a counted
//! piece another line matches (the truth's "on a matched piece"), the pair
//! — the fragment and the matched line — with what lies between them and
//! which condition of the merge (§7.6, `try_merge`) keeps them apart.
//!
//! The extraction of §7 is replayed on the extractor's own segments (after
//! split before reject): each segment fitted, χ²-gated and merged with the
//! previous candidate as the extractor does, then dropped as too short,
//! too uncertain (σ_α) or on an arc; the replay is checked against the
//! extractor's lines. Between the two lines of a pair lies one of: another
//! kept line, a candidate line dropped afterwards (short, σ_α, arc), a
//! segment rejected by the χ² gate, beams in no segment (a segment
//! shorter than `min_points`, or invalid beams), or nothing (the segments
//! touch: a break where `D` crossed τ). The merge conditions are then
//! evaluated on the two final lines: valid beams between against
//! `merge_gap_beams`, parameter distance against `merge_gate`, the
//! collinear test, the union's χ², each part's χ² about the union (the
//! bridge) and the anchor gate; and whether `try_merge` would join them
//! now.
//!
//! `cargo run --release -p lms-lab --example duplicates -- [EVERY] [--list] [--set=NAME=VALUE]…`
//! (`--set`: a parameter changed from the no-flag parameters per data).

// `!(x <= limit)` is deliberate, as in the core: NaN fails the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use lms_core::pipeline::bearings::TwoLevelBearings;
use lms_core::pipeline::line_fit::{
    fit_piece, fit_piece_without, mahalanobis, parameter_distance, residual_sum, BearingTable,
    Holes, RawScan,
};
use lms_core::pipeline::smoothing::{interleaved_turns, usable};
use lms_core::unstable::{fit_span, try_merge};
use lms_core::{Extractor, Line, Params, Segment};
use lms_lab::baselines::{run_core, Tables};
use lms_lab::maptruth::{FrameTruth, TruthConfig};
use lms_lab::realtruth::{load_with_map, ScoredLine};
use lms_lab::sweep::count_and_flags;

/// What became of one segment in the replay of §7.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fate {
    /// Fit failed.
    Degenerate,
    /// χ² above `max_chi2`.
    Chi2,
    /// A candidate line (the index in the candidates).
    Candidate(usize),
}

/// Why a candidate line is not in the output.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Dropped {
    Kept,
    Short,
    Wide,
    Arc,
}

/// The replay of §7 on a frame: the candidates (before the length, σ_α
/// and arc drops) with their fate, and each segment's fate.
struct Replay {
    candidates: Vec<(Line, Dropped)>,
    segments: Vec<(Segment, Fate)>,
}

fn replay(
    scan: &RawScan<'_, &TwoLevelBearings>,
    segs: &[Segment],
    out: &[Line],
    p: &Params,
) -> Replay {
    let mut candidates: Vec<Line> = Vec::new();
    let mut segments = Vec::new();
    let mut holes = Holes::NONE;
    for k in 0..segs.len() {
        let span = fit_span(segs, k, p.fit_shared_points);
        let fate = match fit_piece(scan, span, p.line_sigma()) {
            Err(_) => Fate::Degenerate,
            Ok(l) if !(l.chi2 <= p.max_chi2) => Fate::Chi2,
            Ok(l) => {
                let merged = candidates
                    .last()
                    .filter(|_| p.merge)
                    .and_then(|prev| try_merge(scan, prev, &l, p, &mut holes));
                match (merged, candidates.last_mut()) {
                    (Some(m), Some(slot)) => *slot = m,
                    _ => {
                        candidates.push(l);
                        holes = Holes::NONE;
                    }
                }
                Fate::Candidate(candidates.len() - 1)
            }
        };
        segments.push((segs[k], fate));
    }
    let max_var = (p.max_alpha_sd_deg.to_radians()).powi(2);
    let candidates = candidates
        .into_iter()
        .map(|l| {
            let why = if !(l.length() >= p.min_length) {
                Dropped::Short
            } else if !(l.cov.a <= max_var) {
                Dropped::Wide
            } else if out.iter().any(|o| o.first == l.first && o.last == l.last) {
                Dropped::Kept
            } else {
                Dropped::Arc
            };
            (l, why)
        })
        .collect();
    Replay {
        candidates,
        segments,
    }
}

/// The line each piece is matched to, as `score_frame` matches them.
fn matches(truth: &FrameTruth, lines: &[ScoredLine]) -> Vec<Option<usize>> {
    let (line_of, _) = lms_lab::realtruth::match_pieces(truth, lines);
    line_of.into_iter().map(|m| m.map(|(i, _, _)| i)).collect()
}

/// For each unmatched line that is not unexplained: the counted piece it
/// is a fragment of (at least half of its range's beams valid and on the
/// piece's line within the piece), as `classify_lines` counts them.
fn fragment_of(truth: &FrameTruth, l: &ScoredLine, valid: &[bool]) -> Option<usize> {
    let n = valid.len().min(truth.on_wall.len());
    let range = l.first.min(n)..(l.last + 1).min(n);
    let beams = range.len().max(1);
    let ambiguous = |j: usize| truth.ambiguous.get(j).copied().unwrap_or(false);
    let off = range
        .clone()
        .filter(|&j| !valid[j] || (truth.on_wall[j].is_none() && !ambiguous(j)))
        .count();
    if 2 * off >= beams {
        return None;
    }
    truth.pieces.iter().enumerate().find_map(|(k, p)| {
        let on = range
            .clone()
            .filter(|&j| valid[j] && (p.first..=p.last).contains(&j))
            .filter(|&j| truth.on_wall[j] == Some(p.line))
            .count();
        (p.counted && 2 * on >= beams).then_some(k)
    })
}

/// Counts by key, printed as a table with shares.
#[derive(Default)]
struct Counts(BTreeMap<String, usize>);

impl Counts {
    fn add(&mut self, key: impl Into<String>) {
        *self.0.entry(key.into()).or_default() += 1;
    }
    fn print(&self, title: &str, total: usize) {
        println!("\n| {title} | pairs | share |\n|:---|---:|---:|");
        for (k, v) in &self.0 {
            println!("| {k} | {v} | {:.3} |", *v as f64 / total.max(1) as f64);
        }
    }
}

/// What lies between beams `a.last` and `b.first` in the replay.
fn between(r: &Replay, a: &Line, b: &Line, scan: &RawScan<'_, impl BearingTable>) -> String {
    if b.first <= a.last {
        return "overlapping lines".into();
    }
    let mut kinds = Vec::new();
    // A segment between: after `a`'s last fitted beam and before `b`'s
    // first (a corner beam shared with either counts as between).
    for (s, fate) in &r.segments {
        if !(s.first >= a.last && s.last <= b.first) {
            continue;
        }
        kinds.push(match fate {
            Fate::Degenerate => "degenerate segment",
            Fate::Chi2 => "χ²-rejected segment",
            Fate::Candidate(c) => match r.candidates[*c].1 {
                Dropped::Kept => "another kept line",
                Dropped::Short => "line dropped: short",
                Dropped::Wide => "line dropped: σ_α",
                Dropped::Arc => "line dropped: arc",
            },
        });
    }
    // Beams in no segment between the two lines.
    let covered = |j: u16| r.segments.iter().any(|(s, _)| s.first <= j && j <= s.last);
    let (mut loose_valid, mut invalid) = (0, 0);
    for j in a.last + 1..b.first {
        if covered(j) {
            continue;
        }
        let ok = match (
            scan.beams.get(usize::from(j)),
            scan.ranges.get(usize::from(j)),
        ) {
            (Some(&bm), Some(&d)) => usable(bm, d, scan.max_range),
            _ => false,
        };
        if ok {
            loose_valid += 1;
        } else {
            invalid += 1;
        }
    }
    kinds.sort_unstable();
    kinds.dedup();
    // The most telling kind first: a kept line, a dropped line, a rejected
    // segment, loose beams, nothing.
    let order = [
        "another kept line",
        "line dropped: σ_α",
        "line dropped: short",
        "line dropped: arc",
        "χ²-rejected segment",
        "degenerate segment",
    ];
    if let Some(k) = order.iter().find(|k| kinds.contains(k)) {
        return (*k).into();
    }
    match (loose_valid, invalid) {
        (0, 0) => "nothing (segments touch: break at a D spike)".into(),
        (0, _) => "invalid beams only".into(),
        (v, _) if v < 5 => "valid beams in no segment (< min_points)".into(),
        _ => "valid beams in no segment (≥ 5)".into(),
    }
}

/// The breakdowns over all pairs.
#[derive(Default)]
struct Tallies {
    pairs: usize,
    mismatched: usize,
    between: Counts,
    first_fail: Counts,
    fails: Counts,
    by_between_merge: Counts,
}

/// The parameters of a log: the no-flag ones with each `--set=NAME=VALUE`.
fn params_of(no_flags: Params, flags: &[String]) -> Result<Params> {
    let mut p = no_flags;
    for set in flags.iter().filter_map(|f| f.strip_prefix("--set=")) {
        let (name, value) = set.split_once('=').unwrap_or((set, ""));
        p.set(name, value)
            .map_err(|e| anyhow::anyhow!("--set={set}: {e}"))?;
    }
    Ok(p)
}

/// The scan the extractor fits `frame` on with `p`.
fn raw_scan<'a>(
    frame: &'a lms_core::Frame,
    tables: &'a Tables,
    p: &Params,
) -> RawScan<'a, &'a TwoLevelBearings> {
    RawScan {
        bearings: tables.core(),
        ranges: frame.ranges(),
        beams: frame.beams(),
        max_range: p.max_range,
        footprint: p.footprint,
        turns: if p.turn_offsets {
            interleaved_turns(frame.geometry().step) as u8
        } else {
            1
        },
    }
}

/// One frame: every false line on a piece another line matches, paired
/// with that line, into `t` (and printed with `list`, prefixed by `label`).
fn frame_pairs(
    ex: &mut Extractor,
    scan: &host_bridge::carmen::Scan,
    truth: &FrameTruth,
    p: &Params,
    t: &mut Tallies,
    list: Option<&str>,
) {
    let frame = &scan.frame;
    let x = run_core(ex, frame, p);
    let tables = Tables::for_frame(frame);
    let raw = raw_scan(frame, &tables, p);
    let r = replay(&raw, &x.segments, &x.lines, p);
    let kept: Vec<&Line> = r
        .candidates
        .iter()
        .filter(|c| c.1 == Dropped::Kept)
        .map(|c| &c.0)
        .collect();
    if kept.len() != x.lines.len() || kept.iter().zip(&x.lines).any(|(a, b)| **a != *b) {
        t.mismatched += 1;
    }
    let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
    let valid: Vec<bool> = frame.beams().iter().map(|b| b.is_valid()).collect();
    let line_of = matches(truth, &lines);
    for (i, l) in lines.iter().enumerate() {
        if line_of.contains(&Some(i)) {
            continue;
        }
        let Some(k) = fragment_of(truth, l, &valid) else {
            continue;
        };
        let Some(m) = line_of[k] else {
            continue;
        };
        let (a, b) = if x.lines[i].first < x.lines[m].first {
            (&x.lines[i], &x.lines[m])
        } else {
            (&x.lines[m], &x.lines[i])
        };
        t.pairs += 1;
        let what = between(&r, a, b, &raw);
        t.between.add(what.clone());
        let verdict = diagnose(&raw, a, b, p, &mut t.fails);
        t.first_fail.add(verdict.clone());
        let merges = if verdict == "merges now" {
            "merges now"
        } else {
            "does not merge"
        };
        t.by_between_merge.add(format!("{what} / {merges}"));
        if let Some(label) = list {
            let piece = &truth.pieces[k];
            println!(
                "{label} piece {}..{} lines {}..{} ({} pts) + {}..{} ({} pts), {} between: {what}; {verdict}",
                piece.first, piece.last, a.first, a.last, a.points, b.first, b.last, b.points,
                i.abs_diff(m) - 1
            );
        }
    }
}

fn main() -> Result<()> {
    let (every, flags) = count_and_flags(1)?;
    let list = flags.iter().any(|f| f == "--list");
    let cfg = TruthConfig::settled();
    let mut ex = Extractor::new();
    let mut t = Tallies::default();
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let loaded = load_with_map(&path, &cfg)?;
        let p = params_of(loaded.no_flags, &flags)?;
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        for (index, scan) in loaded.log.scans.iter().enumerate().step_by(every.max(1)) {
            let truth = loaded.truth(index);
            let label = format!("{name} #{index}");
            frame_pairs(
                &mut ex,
                scan,
                &truth,
                &p,
                &mut t,
                list.then_some(label.as_str()),
            );
        }
        eprintln!("{name} done");
    }
    println!(
        "Settled truth, every {every}. frame: {} false lines on a matched piece (pairs), \
         replay ≠ extractor in {} frames.",
        t.pairs, t.mismatched
    );
    let n = t.pairs;
    t.between
        .print("between the fragment and the matched line", n);
    t.first_fail
        .print("first merge condition that fails (in try_merge's order)", n);
    t.fails
        .print("each merge condition failing (a pair may fail several)", n);
    t.by_between_merge
        .print("between / does try_merge join the final pair", n);
    Ok(())
}

/// The merge conditions of a pair, as `try_merge` tests them.
struct Checks {
    gap_ok: bool,
    gate_ok: bool,
    collinear: bool,
    vouched: bool,
    union_ok: bool,
    parts_ok: bool,
    anchor_ok: bool,
}

/// Which merge condition keeps `a` and `b` (in beam order) apart, the
/// first in `try_merge`'s order; every failing one added to `fails`.
fn diagnose<B: BearingTable>(
    scan: &RawScan<'_, B>,
    a: &Line,
    b: &Line,
    p: &Params,
    fails: &mut Counts,
) -> String {
    if try_merge(scan, a, b, p, &mut Holes::default()).is_some() {
        fails.add("none (merges now)");
        return "merges now".into();
    }
    let valid_between = (usize::from(a.last) + 1..usize::from(b.first))
        .filter(|&j| match (scan.beams.get(j), scan.ranges.get(j)) {
            (Some(&bm), Some(&d)) => usable(bm, d, scan.max_range),
            _ => false,
        })
        .count();
    let gap_ok = valid_between <= usize::from(p.merge_gap_beams);
    let gate_ok = parameter_distance(a, b).is_some_and(|d| d < p.merge_gate);
    let collinear = {
        let close = a.gap_to(b) < p.corner_gap;
        let apart = lms_scene::wrap_angle(f64::from(b.alpha - a.alpha)).abs();
        close && apart < f64::from(p.min_corner_angle_deg).to_radians()
    };
    let vouched = (gap_ok && gate_ok) || (p.merge_collinear && collinear);
    let union = Segment {
        first: a.first,
        last: b.last,
    };
    // The union as `try_merge` fits it: without the beams between with
    // `merge_own_beams` where §7.6's gates vouch (the final pair's own
    // holes, if merged lines, are not known here: their beams are fitted).
    let mut hole = Holes::NONE;
    if p.merge_own_beams && gap_ok && gate_ok {
        hole.push(a.last + 1..b.first);
    }
    let Ok(merged) = fit_piece_without(scan, union, &hole, p.line_sigma()) else {
        fails.add("union fit degenerate");
        return "union fit degenerate".into();
    };
    let part = |l: &Line| {
        mahalanobis(&l.cov, l, &merged)
            .map(|rise| (residual_sum(l, scan.turns) + rise) / f32::from(l.points))
            .is_some_and(|c| c <= p.max_chi2)
    };
    let larger = if b.points > a.points { b } else { a };
    let checks = Checks {
        gap_ok,
        gate_ok,
        collinear,
        vouched,
        union_ok: merged.chi2 <= p.max_chi2,
        parts_ok: part(a) && part(b),
        anchor_ok: anchored(larger, &merged, p),
    };
    if !checks.union_ok {
        own_beams_evidence(scan, (a, b), &merged, p, fails);
    }
    verdict(&checks, p, fails)
}

/// `try_merge`'s anchor gate of `merged` on `larger`.
fn anchored(larger: &Line, merged: &Line, p: &Params) -> bool {
    p.merge_anchor_gate == f32::INFINITY
        || mahalanobis(&larger.cov, larger, merged)
            .is_some_and(|d| d <= p.merge_anchor_gate * larger.chi2.max(1.0))
}

/// For a pair whose union fails χ²: whether the union of the two lines'
/// own beams (the beams between left out) passes χ² and the anchor gate,
/// how much the beams between raise the union's χ², and whether both
/// parts fit well on their own.
fn own_beams_evidence<B: BearingTable>(
    scan: &RawScan<'_, B>,
    (a, b): (&Line, &Line),
    merged: &Line,
    p: &Params,
    fails: &mut Counts,
) {
    let mut masked: Vec<lms_core::Beam> = scan.beams.to_vec();
    for m in masked
        .iter_mut()
        .take(usize::from(b.first))
        .skip(usize::from(a.last) + 1)
    {
        *m = lms_core::Beam::Invalid(lms_core::Invalid::NoEcho);
    }
    let holed = RawScan {
        beams: &masked,
        ..*scan
    };
    let union = Segment {
        first: a.first,
        last: b.last,
    };
    let Ok(own) = fit_piece(&holed, union, p.line_sigma()) else {
        return;
    };
    let larger = if b.points > a.points { b } else { a };
    let ok = |x: bool| if x { "ok" } else { "fails" };
    fails.add(format!(
        "union χ² fails; own beams' union: χ² {}, anchor {}",
        ok(own.chi2 <= p.max_chi2),
        ok(anchored(larger, &own, p))
    ));
    let ratio = merged.chi2 / own.chi2.max(1e-6);
    let band = if ratio > 2.0 {
        "> 2"
    } else if ratio > 1.2 {
        "1.2–2"
    } else {
        "≤ 1.2"
    };
    fails.add(format!(
        "union χ² fails; union χ² / own beams' union χ² {band}"
    ));
    fails.add(format!(
        "union χ² fails; parts' own χ² both ≤ max_chi2/2: {}",
        a.chi2 <= p.max_chi2 / 2.0 && b.chi2 <= p.max_chi2 / 2.0
    ));
}

/// Every failing condition of `c` into `fails`; the first in `try_merge`'s
/// order, with whether the pair is vouched for and its gap.
fn verdict(c: &Checks, p: &Params, fails: &mut Counts) -> String {
    for (failed, name) in [
        (!c.gap_ok, "gap > merge_gap_beams"),
        (!c.gate_ok, "parameter distance ≥ merge_gate"),
        (!c.collinear, "not collinear-and-touching"),
        (!c.union_ok, "union χ² > max_chi2"),
        (
            !c.vouched && !c.parts_ok,
            "bridge: a part's χ² about the union > max_chi2",
        ),
        (!c.anchor_ok, "anchor gate"),
    ] {
        if failed {
            fails.add(name);
        }
    }
    let reason = if !(c.vouched || p.bridge_merge) {
        "not vouched, no bridge"
    } else if !c.union_ok {
        "union χ² > max_chi2"
    } else if !(c.vouched || c.parts_ok) {
        "bridge: a part's χ² about the union > max_chi2"
    } else if !c.anchor_ok {
        "anchor gate"
    } else {
        "the F test, or the holes of a merged line"
    };
    let how = if c.vouched { "vouched" } else { "not vouched" };
    let gap = if c.gap_ok {
        "≤ merge_gap_beams"
    } else {
        "> merge_gap_beams"
    };
    format!("{reason} ({how}, gap {gap})")
}
