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

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use lms_core::pipeline::line_fit::{
    fit_piece, fit_piece_without, mahalanobis, parameter_distance, residual_sum, Holes, RawScan,
};
use lms_core::pipeline::smoothing::{interleaved_turns, usable};
use lms_core::unstable::{fit_span, try_merge};
use lms_core::{Extractor, Line, Params, Segment};
use lms_lab::baselines::{run_core, Tables};
use lms_lab::maptruth::{FrameTruth, TruthConfig};
use lms_lab::realtruth::{candidate, load_with_map, ScoredLine, GATE_ALPHA_DEG, GATE_R};
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
    scan: &RawScan<'_, &lms_core::pipeline::bearings::TwoLevelBearings>,
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
    let mut pairs = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        for (k, p) in truth.pieces.iter().enumerate() {
            if let Some((da, dr)) = candidate(l, p) {
                let cost = (da / GATE_ALPHA_DEG.to_radians()).powi(2) + (dr / GATE_R).powi(2);
                pairs.push((cost, i, k));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut line_of = vec![None; truth.pieces.len()];
    let mut used = vec![false; lines.len()];
    for (_, i, k) in pairs {
        if !used[i] && line_of[k].is_none() {
            used[i] = true;
            line_of[k] = Some(i);
        }
    }
    line_of
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
fn between(
    r: &Replay,
    a: &Line,
    b: &Line,
    scan: &RawScan<'_, impl lms_core::pipeline::line_fit::BearingTable>,
) -> String {
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

fn main() -> Result<()> {
    let (every, flags) = count_and_flags(1)?;
    let list = flags.iter().any(|f| f == "--list");
    let cfg = TruthConfig::settled();
    let mut ex = Extractor::new();
    let (mut pairs, mut mismatched, mut dup_total) = (0usize, 0usize, 0usize);
    let mut lies = Counts::default();
    let mut first_fail = Counts::default();
    let mut fails = Counts::default();
    let mut by_between_merge = Counts::default();
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let loaded = load_with_map(&path, &cfg)?;
        let mut p = loaded.no_flags;
        for set in flags.iter().filter_map(|f| f.strip_prefix("--set=")) {
            let (name, value) = set.split_once('=').unwrap_or((set, ""));
            p.set(name, value)
                .map_err(|e| anyhow::anyhow!("--set={set}: {e}"))?;
        }
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        for (index, scan) in loaded.log.scans.iter().enumerate().step_by(every.max(1)) {
            let truth = loaded.truth(index);
            let frame = &scan.frame;
            let x = run_core(&mut ex, frame, &p);
            let tables = Tables::for_frame(frame);
            let raw = RawScan {
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
            };
            let r = replay(&raw, &x.segments, &x.lines, &p);
            let kept: Vec<&Line> = r
                .candidates
                .iter()
                .filter(|c| c.1 == Dropped::Kept)
                .map(|c| &c.0)
                .collect();
            if kept.len() != x.lines.len() || kept.iter().zip(&x.lines).any(|(a, b)| **a != *b) {
                mismatched += 1;
            }
            let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
            let valid: Vec<bool> = frame.beams().iter().map(|b| b.is_valid()).collect();
            let line_of = matches(&truth, &lines);
            for (i, l) in lines.iter().enumerate() {
                if line_of.contains(&Some(i)) {
                    continue;
                }
                let Some(k) = fragment_of(&truth, l, &valid) else {
                    continue;
                };
                let Some(m) = line_of[k] else {
                    continue;
                };
                dup_total += 1;
                let (a, b) = if x.lines[i].first < x.lines[m].first {
                    (&x.lines[i], &x.lines[m])
                } else {
                    (&x.lines[m], &x.lines[i])
                };
                pairs += 1;
                let lines_between = i.abs_diff(m) - 1;
                let what = between(&r, a, b, &raw);
                lies.add(what.clone());
                let verdict = diagnose(&raw, a, b, &p, &mut fails);
                first_fail.add(verdict.clone());
                by_between_merge.add(format!(
                    "{what} / {}",
                    if verdict == "merges now" {
                        "merges now"
                    } else {
                        "does not merge"
                    }
                ));
                if list {
                    println!(
                        "{name} #{index} piece {}..{} lines {}..{} ({} pts) + {}..{} ({} pts), {lines_between} between: {what}; {verdict}",
                        truth.pieces[k].first, truth.pieces[k].last, a.first, a.last, a.points, b.first, b.last, b.points
                    );
                }
            }
        }
        eprintln!("{name} done");
    }
    println!("Settled truth, every {every}. frame: {dup_total} false lines on a matched piece (pairs), replay ≠ extractor in {mismatched} frames.");
    lies.print("between the fragment and the matched line", pairs);
    first_fail.print(
        "first merge condition that fails (in try_merge's order)",
        pairs,
    );
    fails.print(
        "each merge condition failing (a pair may fail several)",
        pairs,
    );
    by_between_merge.print("between / does try_merge join the final pair", pairs);
    Ok(())
}

/// Which merge condition keeps `a` and `b` (in beam order) apart, the
/// first in `try_merge`'s order; every failing one added to `fails`.
fn diagnose<B: lms_core::pipeline::line_fit::BearingTable>(
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
    let dist = parameter_distance(a, b);
    let gate_ok = dist.is_some_and(|d| d < p.merge_gate);
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
        hole.push(a.last + 1, b.first);
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
    let parts_ok = part(a) && part(b);
    let larger = if b.points > a.points { b } else { a };
    let anchor_ok = p.merge_anchor_gate == f32::INFINITY
        || mahalanobis(&larger.cov, larger, &merged)
            .is_some_and(|d| d <= p.merge_anchor_gate * larger.chi2.max(1.0));
    let union_ok = merged.chi2 <= p.max_chi2;
    // The union of the two lines' own beams, the beams between left out.
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
    if let Ok(own) = fit_piece(&holed, union, p.line_sigma()) {
        let own_anchor = mahalanobis(&larger.cov, larger, &own)
            .is_some_and(|d| d <= p.merge_anchor_gate * larger.chi2.max(1.0));
        let own_ok = own.chi2 <= p.max_chi2;
        if !union_ok {
            fails.add(format!(
                "union χ² fails; own beams' union: χ² {}, anchor {}",
                if own_ok { "ok" } else { "fails" },
                if own_anchor { "ok" } else { "fails" }
            ));
            let ratio = merged.chi2 / own.chi2.max(1e-6);
            fails.add(format!(
                "union χ² fails; union χ² / own beams' union χ² {}",
                if ratio > 2.0 {
                    "> 2"
                } else if ratio > 1.2 {
                    "1.2–2"
                } else {
                    "≤ 1.2"
                }
            ));
            let (ca, cb) = (a.chi2, b.chi2);
            fails.add(format!(
                "union χ² fails; parts' own χ² both ≤ max_chi2/2: {}",
                ca <= p.max_chi2 / 2.0 && cb <= p.max_chi2 / 2.0
            ));
        }
    }
    if !gap_ok {
        fails.add("gap > merge_gap_beams");
    }
    if !gate_ok {
        fails.add("parameter distance ≥ merge_gate");
    }
    if !collinear {
        fails.add("not collinear-and-touching");
    }
    if !union_ok {
        fails.add("union χ² > max_chi2");
    }
    if !vouched && !parts_ok {
        fails.add("bridge: a part's χ² about the union > max_chi2");
    }
    if !anchor_ok {
        fails.add("anchor gate");
    }
    let reason = if !(vouched || p.bridge_merge) {
        "not vouched, no bridge"
    } else if !union_ok {
        "union χ² > max_chi2"
    } else if !(vouched || parts_ok) {
        "bridge: a part's χ² about the union > max_chi2"
    } else if !anchor_ok {
        "anchor gate"
    } else {
        "the F test, or the holes of a merged line"
    };
    let how = if vouched { "vouched" } else { "not vouched" };
    format!(
        "{reason} ({how}, gap {})",
        if gap_ok {
            "≤ merge_gap_beams"
        } else {
            "> merge_gap_beams"
        }
    )
}
