//! The short walls of the 1° logs (Acapulco, Intel, Örebro: 181 beams at
//! 1°) on the settled truth (`TruthConfig::settled`, the no-flag
//! parameters per log), every frame (`EVERY` = 1, the default); about a
//! minute.
//!
//! 1. **Diagnosis**: each counted piece the defaults miss on the 1° logs,
//!    by length (0.5–1 m first), classed by the first that applies: a
//!    default line on it (half its beam range inside the piece) but off the
//!    matching gates (|Δα| ≥ 3°, |Δr| ≥ 0.1 m, or taken by another piece;
//!    with, for the Δα ones, the line's points, σ_α and |Δα| and how far the
//!    piece's own hits' fit is from the map line); no kept segment on it
//!    (split into: a longer segment across it; a §6 segment held it but
//!    split before reject dropped it, and whether a circle explains that
//!    segment, `lms_core::pipeline::split::circle_explains`, the guard that
//!    stops the split; else the windows broke); else the one relaxation
//!    that alone recovers it — σ_α (`max_alpha_sd_deg=inf`), χ²
//!    (`max_chi2=1e6`), `min_length=0`, `min_points=3`, τ = 6 or 20,
//!    `merge=false`, `footprint=0` — the first in that order ("none": no
//!    single one). In brackets: how many of all misses each relaxation
//!    recovers.
//! 2. The lines the σ_α gate scaled by √2 (2.36°) adds on the 1° logs,
//!    by class (true, neutral, unexplained, false fragment of a matched /
//!    unmatched piece, across walls), with their medians.
//! 3. **Candidates**, applied to the 1° logs only (the 0.5° logs at the
//!    defaults) unless named "all": TruePos overall and by piece length,
//!    FalsePos, false lines (fragments, on a matched piece), true lines,
//!    per 1° log, then pooled over the 1° logs, the 0.5° logs and all logs.
//!    "band length ≥ L" keeps a line whose σ_α lies above the defaults'
//!    gate only if it is at least L long: a lab prototype applied to the
//!    final lines (the core has no such gate).
//! 4. The realistic synthetic scenes (0.5°, `SCANS` per family and σ₀,
//!    default 100) for the defaults and the candidates that change 0.5°
//!    scans (the 1°-only ones are the defaults there).
//!
//! `cargo run --release -p lms-lab --example short_walls_1deg -- [EVERY] [SCANS]`

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;
use host_bridge::carmen::{self, UnitMode};
use lms_core::pipeline::line_fit::RawScan;
use lms_core::pipeline::split::circle_explains;
use lms_core::{Extractor, Line, Params, Trace};
use lms_lab::baselines::{corners_of, run_core, segments_of, Tables};
use lms_lab::maptruth::{FrameTruth, TruthConfig};
use lms_lab::realtruth::{
    classify_lines, gate_offsets, load_with_map, overlap, score_frame, RealMethod, RealTally,
    ScoredLine, GATE_ALPHA_DEG, GATE_OVERLAP, GATE_R,
};
use lms_lab::sweep::{synthetic_table, Adjust};

/// Length bins of the pieces, in print order ([`bin`]).
const BINS: [&str; 3] = ["0.5–1 m", "< 0.5 m", "≥ 1 m"];

fn bin(length: f64) -> usize {
    if length < 0.5 {
        1
    } else if length < 1.0 {
        0
    } else {
        2
    }
}

/// The single relaxations of the diagnosis, in the order a miss is
/// attributed to the first that recovers it.
fn relaxations() -> Vec<(&'static str, Adjust)> {
    vec![
        ("σ_α gate", |p| p.with_max_alpha_sd_deg(f32::INFINITY)),
        ("χ² gate", |p| p.with_max_chi2(1e6)),
        ("min_length", |p| p.with_min_length(0.0)),
        ("min_points", |p| p.with_min_points(3)),
        ("τ = 6", |p| p.with_tau(6.0)),
        ("τ = 20", |p| p.with_tau(20.0)),
        ("no merges", |p| p.with_merge(false)),
        ("footprint=0", |p| p.with_footprint(0.0)),
    ]
}

/// Piece index → matched line index: the evaluation's one-to-one greedy
/// matching (`realtruth::score_frame`) by `(Δα/3°)² + (Δr/0.1 m)²`.
fn matching(truth: &FrameTruth, lines: &[ScoredLine]) -> Vec<Option<usize>> {
    let (line_of, _) = lms_lab::realtruth::match_pieces(truth, lines);
    line_of.into_iter().map(|m| m.map(|(i, _, _)| i)).collect()
}

fn is_coarse(path: &Path) -> Result<bool> {
    let beams = carmen::read_log(path, UnitMode::Auto)?
        .scans
        .first()
        .map_or(0, |s| s.frame.len());
    Ok(beams <= 181)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Misses of one length bin.
#[derive(Default)]
struct Misses {
    pieces: usize,
    missed: usize,
    off_gates: usize,
    /// Of those: the nearest line within the gates (taken by another
    /// piece), |Δα| ≥ 3°, else |Δr| ≥ 0.1 m; the line runs past the
    /// piece's ends by more than 2 beams.
    taken: usize,
    off_alpha: usize,
    off_r: usize,
    past_ends: usize,
    no_segment: usize,
    /// Per relaxation: first to recover (exclusive), recovers (any).
    first: Vec<usize>,
    any: Vec<usize>,
    none: usize,
    beams_missed: Vec<f64>,
    /// Lines off by Δα: their points / the piece's beams, σ_α (°), |Δα| (°),
    /// and whether the line stays inside the piece (± 1 beam).
    off_points: Vec<f64>,
    off_sd: Vec<f64>,
    off_da: Vec<f64>,
    off_inside: usize,
    off_own: Vec<f64>,
    off_map: Vec<f64>,
    /// No segment on it: one segment holds half its beams (a longer
    /// segment across it); else the share of its beams in any segment.
    seg_across: usize,
    seg_share: Vec<f64>,
    /// Of the others: a §6 segment held half its beams (split before
    /// reject dropped it); else the share of its beams that are valid.
    seg6: usize,
    /// Of those, a circle explains the §6 segment (split before reject's
    /// circle guard: not split, dropped whole).
    seg6_circle: usize,
    valid_share: Vec<f64>,
    off_signed: Vec<f64>,
    beams_alpha: Vec<f64>,
    range_alpha: Vec<f64>,
    sd_alpha: Vec<f64>,
}

fn diagnose(paths: &[PathBuf], every: usize, cfg: &TruthConfig) -> Result<String> {
    let relax = relaxations();
    let mut bins: Vec<Misses> = (0..BINS.len())
        .map(|_| Misses {
            first: vec![0; relax.len()],
            any: vec![0; relax.len()],
            ..Misses::default()
        })
        .collect();
    let mut ex = Extractor::new();
    let mut trace = Trace::new();
    for path in paths {
        let loaded = load_with_map(path, cfg)?;
        let base =
            RealMethod::no_flags_with("defaults", |p| p).params(loaded.log.unit, &loaded.no_flags);
        for (k, scan) in loaded.log.scans.iter().enumerate().step_by(every) {
            let truth = loaded.truth(k);
            let run = |ex: &mut Extractor, p: &Params| {
                let x = run_core(ex, &scan.frame, p);
                let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
                (x, lines)
            };
            let (x, lines) = run(&mut ex, &base);
            let of = matching(&truth, &lines);
            let missed: Vec<usize> = (0..truth.pieces.len())
                .filter(|&i| truth.pieces[i].counted)
                .inspect(|&i| {
                    bins[bin(truth.pieces[i].length)].pieces += 1;
                })
                .filter(|&i| of[i].is_none())
                .collect();
            if missed.is_empty() {
                continue;
            }
            let relaxed: Vec<_> = relax
                .iter()
                .map(|(_, a)| {
                    let (x, lines) = run(&mut ex, &a(base));
                    let of = matching(&truth, &lines);
                    (x, of)
                })
                .collect();
            for i in missed {
                let p = &truth.pieces[i];
                let m = &mut bins[bin(p.length)];
                m.missed += 1;
                m.beams_missed.push(p.beams as f64);
                let seg = x.segments.iter().any(|s| {
                    overlap(usize::from(s.first), usize::from(s.last), p.first, p.last)
                        >= GATE_OVERLAP
                });
                let mut first = None;
                for (r, (rx, rof)) in relaxed.iter().enumerate() {
                    if let Some(li) = rof[i] {
                        m.any[r] += 1;
                        if first.is_none() {
                            first = Some(r);
                        }
                        if r == 0 {
                            let l = &rx.lines[li];
                            m.beams_alpha.push(f64::from(l.points));
                            m.sd_alpha.push(f64::from(l.cov.a).sqrt().to_degrees());
                            let sl = ScoredLine::from(l);
                            m.range_alpha.push(sl.middle[0].hypot(sl.middle[1]));
                        }
                    }
                }
                let best = lines
                    .iter()
                    .filter(|l| overlap(l.first, l.last, p.first, p.last) >= GATE_OVERLAP)
                    .max_by(|a, b| {
                        overlap(a.first, a.last, p.first, p.last)
                            .total_cmp(&overlap(b.first, b.last, p.first, p.last))
                    });
                if let Some(l) = best {
                    m.off_gates += 1;
                    let (da, dr) = gate_offsets(l, p.reference(), p.gate_at_middle);
                    if da.to_degrees().abs() >= GATE_ALPHA_DEG {
                        m.off_alpha += 1;
                        if let Some(xl) = x.lines.iter().find(|x| {
                            usize::from(x.first) == l.first && usize::from(x.last) == l.last
                        }) {
                            m.off_points.push(f64::from(xl.points) / p.beams as f64);
                            m.off_sd.push(f64::from(sd_alpha_deg(xl)));
                        }
                        m.off_da.push(da.to_degrees().abs());
                        m.off_signed.push(da.to_degrees());
                        m.off_map.push(
                            lms_scene::wrap_angle(p.own_alpha - p.alpha)
                                .to_degrees()
                                .abs(),
                        );
                        m.off_own.push(
                            lms_scene::wrap_angle(l.alpha - p.own_alpha)
                                .to_degrees()
                                .abs(),
                        );
                        m.off_inside += usize::from(l.first + 1 >= p.first && l.last <= p.last + 1);
                    } else if dr.abs() >= GATE_R {
                        m.off_r += 1;
                    } else {
                        m.taken += 1;
                    }
                    m.past_ends += usize::from(l.first + 2 < p.first || l.last > p.last + 2);
                } else if !seg {
                    m.no_segment += 1;
                    let inside = |s: &lms_core::Segment| {
                        (p.first..=p.last)
                            .filter(|j| (usize::from(s.first)..=usize::from(s.last)).contains(j))
                            .count()
                    };
                    let n = p.last - p.first + 1;
                    if x.segments.iter().any(|s| 2 * inside(s) >= n) {
                        m.seg_across += 1;
                    } else {
                        let held: usize = x.segments.iter().map(inside).sum();
                        m.seg_share.push(held as f64 / n as f64);
                        let seg6 = base.validate().ok().and_then(|v| {
                            ex.run_traced(&scan.frame, &v, &mut trace);
                            segments_of(trace.mahalanobis(), &base)
                                .into_iter()
                                .find(|s| 2 * inside(s) >= n)
                        });
                        if let Some(seg) = seg6 {
                            m.seg6 += 1;
                            let tables = Tables::for_frame(&scan.frame);
                            let raw = RawScan {
                                bearings: tables.core(),
                                ranges: scan.frame.ranges(),
                                beams: scan.frame.beams(),
                                max_range: base.max_range,
                                footprint: base.footprint,
                                turns: 1,
                            };
                            m.seg6_circle +=
                                usize::from(circle_explains(&raw, seg, base.line_sigma()));
                        } else {
                            let valid = (p.first..=p.last)
                                .filter(|&j| scan.frame.beams()[j].is_valid())
                                .count();
                            m.valid_share.push(valid as f64 / n as f64);
                        }
                    }
                } else if let Some(r) = first {
                    m.first[r] += 1;
                } else {
                    m.none += 1;
                }
            }
        }
    }
    let mut md = String::from(
        "| piece length | counted | missed | a line on it, off the gates (Δα, Δr, taken; past the ends) | no segment on it | ",
    );
    for (n, _) in &relax {
        let _ = write!(md, "{n} | ");
    }
    md.push_str(
        "none alone | median beams on a missed piece | σ_α recovers: median points, range (m), σ_α (°) |\n|:---|",
    );
    md.push_str(&"---:|".repeat(relax.len() + 6));
    md.push('\n');
    for (b, name) in bins.iter_mut().zip(BINS) {
        let _ = write!(
            md,
            "| {name} | {} | {} ({:.3}) | {} ({}, {}, {}; {}) | {} | ",
            b.pieces,
            b.missed,
            b.missed as f64 / b.pieces.max(1) as f64,
            b.off_gates,
            b.off_alpha,
            b.off_r,
            b.taken,
            b.past_ends,
            b.no_segment
        );
        for (f, a) in b.first.iter().zip(&b.any) {
            let _ = write!(md, "{f} ({a}) | ");
        }
        let _ = writeln!(
            md,
            "{} | {:.0} | {:.0}, {:.2}, {:.2} |",
            b.none,
            median(&mut b.beams_missed),
            median(&mut b.beams_alpha),
            median(&mut b.range_alpha),
            median(&mut b.sd_alpha)
        );
    }
    md.push_str(
        "\nThe lines off by Δα ≥ 3°: | piece length | lines | inside the piece (± 1 beam) | \
         median points / piece beams | median σ_α (°) | median |Δα| (°) | Δα > 0 | median |α − own fit's α| (°) | median |own fit's α − map α| (°) |\n\
         |:---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for (b, name) in bins.iter_mut().zip(BINS) {
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {:.2} | {:.2} |",
            b.off_alpha,
            b.off_inside,
            median(&mut b.off_points),
            median(&mut b.off_sd),
            median(&mut b.off_da),
            b.off_signed.iter().filter(|&&d| d > 0.0).count(),
            median(&mut b.off_own),
            median(&mut b.off_map)
        );
    }
    md.push_str(
        "\nNo segment on it: | piece length | pieces | a longer segment holds half its beams | \
         else: a §6 segment held half of them (split before reject dropped it) | of those, a \
         circle explains that segment (the circle guard) | else: median share of its beams valid |\n\
         |:---|---:|---:|---:|---:|---:|\n",
    );
    for (b, name) in bins.iter_mut().zip(BINS) {
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {} | {} | {:.2} |",
            b.no_segment,
            b.seg_across,
            b.seg6,
            b.seg6_circle,
            median(&mut b.valid_share)
        );
    }
    Ok(md)
}

/// The lines a wider σ_α gate adds, by class.
#[derive(Default)]
struct Extra {
    n: usize,
    points: Vec<f64>,
    length: Vec<f64>,
    range: Vec<f64>,
    chi2: Vec<f64>,
    sd_alpha: Vec<f64>,
    /// A kept neighbour line within `corner_gap` of an end.
    touching: usize,
    /// Of those, within 10° of its direction.
    collinear: usize,
}

/// The lines `wide` keeps that the defaults drop (σ_α between the two
/// gates), on the 1° logs: true (matched to a counted piece), neutral,
/// unexplained, false (fragment of a counted piece, of one another line
/// matches, or across walls), with their medians.
fn extra_lines(paths: &[PathBuf], every: usize, cfg: &TruthConfig, wide: Adjust) -> Result<String> {
    let names = [
        "true",
        "neutral",
        "unexplained",
        "false: fragment, piece matched",
        "false: fragment, piece unmatched",
        "false: across walls",
    ];
    let mut cls: Vec<Extra> = (0..names.len()).map(|_| Extra::default()).collect();
    let mut ex = Extractor::new();
    for path in paths {
        let loaded = load_with_map(path, cfg)?;
        let base =
            RealMethod::no_flags_with("defaults", |p| p).params(loaded.log.unit, &loaded.no_flags);
        let w = wide(base);
        for (k, scan) in loaded.log.scans.iter().enumerate().step_by(every) {
            let truth = loaded.truth(k);
            let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
            let a = run_core(&mut ex, &scan.frame, &base).lines;
            let b = run_core(&mut ex, &scan.frame, &w).lines;
            let sb: Vec<ScoredLine> = b.iter().map(ScoredLine::from).collect();
            let of = matching(&truth, &sb);
            for (i, l) in b.iter().enumerate() {
                if a.iter().any(|x| x.first == l.first && x.last == l.last) {
                    continue;
                }
                let c = match of.iter().position(|&m| m == Some(i)) {
                    Some(k) if truth.pieces[k].counted => 0,
                    Some(_) => 1,
                    None => {
                        let mut t = RealTally::default();
                        let none = vec![None; truth.pieces.len()];
                        classify_lines(&truth, &sb[i..=i], &valid, &none, &mut t);
                        if t.lines_unexplained > 0 {
                            2
                        } else if t.lines_neutral > 0 {
                            1
                        } else if t.lines_fragment > 0 {
                            // A fragment of a piece: matched by another line?
                            let on = truth.pieces.iter().enumerate().find(|(_, p)| {
                                p.counted
                                    && overlap(l.first.into(), l.last.into(), p.first, p.last)
                                        >= GATE_OVERLAP
                            });
                            if on.is_some_and(|(k, _)| of[k].is_some()) {
                                3
                            } else {
                                4
                            }
                        } else {
                            5
                        }
                    }
                };
                let e = &mut cls[c];
                e.n += 1;
                e.points.push(f64::from(l.points));
                e.length.push(f64::from(l.length()));
                e.range.push(sb[i].middle[0].hypot(sb[i].middle[1]));
                e.chi2.push(f64::from(l.chi2));
                e.sd_alpha.push(f64::from(l.cov.a).sqrt().to_degrees());
                let near: Vec<&lms_core::Line> =
                    [i.checked_sub(1).and_then(|j| b.get(j)), b.get(i + 1)]
                        .into_iter()
                        .flatten()
                        .filter(|x| {
                            let gap = if x.first < l.first {
                                x.gap_to(l)
                            } else {
                                l.gap_to(x)
                            };
                            gap < w.corner_gap
                        })
                        .collect();
                e.touching += usize::from(!near.is_empty());
                e.collinear += usize::from(near.iter().any(|x| {
                    lms_scene::wrap_angle(f64::from(x.alpha - l.alpha)).abs() < 10f64.to_radians()
                }));
            }
        }
    }
    let mut md = String::from(
        "| class | lines | median points | length (m) | range (m) | χ² | σ_α (°) | a neighbour within corner_gap | of those within 10° |\n\
         |:---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for (e, name) in cls.iter_mut().zip(names) {
        let _ = writeln!(
            md,
            "| {name} | {} | {:.0} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} |",
            e.n,
            median(&mut e.points),
            median(&mut e.length),
            median(&mut e.range),
            median(&mut e.chi2),
            median(&mut e.sd_alpha),
            e.touching,
            e.collinear
        );
    }
    Ok(md)
}

/// The σ_α gate scaled by √2 (half the beams on a wall at 1°).
const ALPHA_1DEG: f32 = 2.357_023;

/// Which lines of an extraction a candidate keeps.
type Keep = fn(&Line) -> bool;

/// A candidate: its name, the change on 1° scans and on 0.5° scans, and
/// the lines it keeps of that extraction (a prototype of a gate the core
/// does not have: applied to the final lines, which on these logs is the
/// same as before the arcs, §7.8, since no line of them is an arc).
struct Candidate {
    name: &'static str,
    one: Adjust,
    half: Adjust,
    keep: Keep,
    /// Whether it changes 0.5° scans.
    all: bool,
}

/// σ_α of a line (degrees).
fn sd_alpha_deg(l: &Line) -> f32 {
    l.cov.a.sqrt().to_degrees()
}

/// The widened band's lines (σ_α above the defaults' gate) need this length.
fn band(l: &Line, min_len: f32) -> bool {
    sd_alpha_deg(l) <= Params::DEFAULT.max_alpha_sd_deg || l.length() >= min_len
}

fn candidates() -> Vec<Candidate> {
    let same: Adjust = |p| p;
    let all: Keep = |_| true;
    let c = |name, one, keep| Candidate {
        name,
        one,
        half: same,
        keep,
        all: false,
    };
    let wide: Adjust = |p| p.with_max_alpha_sd_deg(ALPHA_1DEG);
    vec![
        c("defaults", same, all),
        c("σ_α ×√2", wide, all),
        c("σ_α ×1.1 (1.83°)", |p| p.with_max_alpha_sd_deg(1.833), all),
        c("σ_α ×1.2 (2.0°)", |p| p.with_max_alpha_sd_deg(2.0), all),
        c("σ_α ×1.3 (2.17°)", |p| p.with_max_alpha_sd_deg(2.167), all),
        c("σ_α ×√2, band length ≥ 0.5 m", wide, |l| {
            band(l, 0.5)
        }),
        c("σ_α ×√2, band points ≥ 10", wide, |l| {
            sd_alpha_deg(l) <= Params::DEFAULT.max_alpha_sd_deg || l.points >= 10
        }),
        c(
            "σ_α ×√2, max_chi2=3",
            |p| p.with_max_alpha_sd_deg(ALPHA_1DEG).with_max_chi2(3.0),
            all,
        ),
        c(
            "σ_α ×√2, min_length=0.3",
            |p| p.with_max_alpha_sd_deg(ALPHA_1DEG).with_min_length(0.3),
            all,
        ),
        c(
            "σ_α ×√2, min_points=6",
            |p| p.with_max_alpha_sd_deg(ALPHA_1DEG).with_min_points(6),
            all,
        ),
        c(
            "σ_α ×√2, min_points=4",
            |p| p.with_max_alpha_sd_deg(ALPHA_1DEG).with_min_points(4),
            all,
        ),
        c("merge_gap_beams=1", |p| p.with_merge_gap_beams(1), all),
        c("merge_gap_beams=2", |p| p.with_merge_gap_beams(2), all),
        c("merge_gap_beams=5", |p| p.with_merge_gap_beams(5), all),
        c("merge_gate=13.8", |p| p.with_merge_gate(13.8), all),
        c(
            "σ_α ×√2, merge_gap_beams=5",
            |p| p.with_max_alpha_sd_deg(ALPHA_1DEG).with_merge_gap_beams(5),
            all,
        ),
        c(
            "σ_α ×√2, merge_gate=13.8",
            |p| p.with_max_alpha_sd_deg(ALPHA_1DEG).with_merge_gate(13.8),
            all,
        ),
        c(
            "σ_α ×√2, min_points=6, merge_gate=13.8",
            |p| {
                p.with_max_alpha_sd_deg(ALPHA_1DEG)
                    .with_min_points(6)
                    .with_merge_gate(13.8)
            },
            all,
        ),
        c(
            "σ_α ×√2, band length ≥ 0.5 m, merge_gate=13.8, merge_gap_beams=5",
            |p| {
                p.with_max_alpha_sd_deg(ALPHA_1DEG)
                    .with_merge_gate(13.8)
                    .with_merge_gap_beams(5)
            },
            |l| band(l, 0.5),
        ),
        c(
            "σ_α 1.25° (stricter)",
            |p| p.with_max_alpha_sd_deg(1.25),
            all,
        ),
        c("min_points=4", |p| p.with_min_points(4), all),
        c("min_points=6", |p| p.with_min_points(6), all),
        c("split_depth=12", |p| p.with_split_depth(12), all),
        c("tau=9", |p| p.with_tau(9.0), all),
        c("tau=16", |p| p.with_tau(16.0), all),
        Candidate {
            name: "all: σ_α 2.36, band length ≥ 0.5 m",
            one: wide,
            half: wide,
            keep: |l| band(l, 0.5),
            all: true,
        },
    ]
}

/// The candidates on one log (`one`: a 1° log): the evaluation's
/// `score_frame` on each frame's kept lines.
fn evaluate(
    path: &Path,
    cands: &[Candidate],
    one: bool,
    every: usize,
    cfg: &TruthConfig,
) -> Result<Vec<RealTally>> {
    let loaded = load_with_map(path, cfg)?;
    let mut ex = Extractor::new();
    let mut tallies = vec![RealTally::default(); cands.len()];
    let params: Vec<Params> = cands
        .iter()
        .map(|c| {
            RealMethod::no_flags_with(c.name, if one { c.one } else { c.half })
                .params(loaded.log.unit, &loaded.no_flags)
        })
        .collect();
    for (k, scan) in loaded.log.scans.iter().enumerate().step_by(every) {
        let truth = loaded.truth(k);
        let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
        for ((c, p), t) in cands.iter().zip(&params).zip(&mut tallies) {
            let lines: Vec<ScoredLine> = run_core(&mut ex, &scan.frame, p)
                .lines
                .iter()
                .filter(|l| one && (c.keep)(l) || !one && (!c.all || (c.keep)(l)))
                .map(ScoredLine::from)
                .collect();
            score_frame(&truth, &lines, &valid, t);
        }
    }
    Ok(tallies)
}

fn f(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3}")
    } else {
        "—".into()
    }
}

fn header(md: &mut String) {
    md.push_str(
        "| logs | setting | TruePos | ≥ 1 m | 0.5–1 m (pieces) | < 0.5 m | FalsePos | false lines \
         (fragments, on a matched piece) | true lines | coverage | walls fragmented | lines / frame |\n\
         |:---|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
}

fn row(md: &mut String, log: &str, name: &str, t: &RealTally) {
    let s = t.summary();
    let (bad, of) = s.walls_fragmented;
    let _ = writeln!(
        md,
        "| {log} | {name} | {} | {} | {} ({}) | {} | {} | {} ({}, {}) | {} | {} | {bad} of {of} | {:.2} |",
        f(s.true_pos),
        f(s.true_pos_1m),
        f(s.true_pos_mid),
        t.pieces_mid,
        f(s.true_pos_short),
        f(s.false_pos),
        t.lines_false,
        t.lines_fragment,
        t.lines_fragment_dup,
        t.lines_true,
        f(s.coverage),
        s.lines_per_frame,
    );
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let cfg = TruthConfig::settled();
    let logs = lms_lab::real::find_logs(Path::new("../shared/data/carmen"))?;
    let mut coarse = Vec::new();
    for p in &logs {
        if is_coarse(p)? {
            coarse.push(p.clone());
        }
    }
    println!(
        "Diagnosis, 1° logs, the defaults' misses (a relaxation's cell: first to recover it \
         (recovers it at all)):\n\n{}",
        diagnose(&coarse, every, &cfg)?
    );
    println!(
        "Lines the σ_α gate ×√2 adds on the 1° logs (σ_α in (5/3°, 2.36°]):\n\n{}",
        extra_lines(&coarse, every, &cfg, |p| p
            .with_max_alpha_sd_deg(ALPHA_1DEG))?
    );
    let cands = candidates();
    let mut md = String::new();
    header(&mut md);
    // Pooled: [0] 1° logs, [1] 0.5° logs, [2] all; per candidate.
    let mut pooled = vec![vec![RealTally::default(); cands.len()]; 3];
    for path in &logs {
        let one = coarse.contains(path);
        let tallies = evaluate(path, &cands, one, every, &cfg)?;
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let name = name.trim_end_matches("-corrected.log.gz");
        for (k, t) in tallies.iter().enumerate() {
            if one {
                row(&mut md, &format!("{name} (1°)"), cands[k].name, t);
            }
            pooled[usize::from(!one)][k].merge(t);
            pooled[2][k].merge(t);
        }
        eprintln!("{name}: {} frames", tallies[0].frames);
    }
    println!("Settled truth, every {every}. frame, the 1° logs:\n\n{md}");
    let mut md = String::new();
    header(&mut md);
    for (g, label) in [(0, "1° logs"), (1, "0.5° logs"), (2, "all logs")] {
        for (k, t) in pooled[g].iter().enumerate() {
            if g == 1 && k > 0 && !cands[k].all {
                continue;
            }
            row(&mut md, &format!("**{label}**"), cands[k].name, t);
        }
    }
    println!("Pooled (0.5° rows only where the setting changes 0.5° scans):\n\n{md}");
    let synth: Vec<&Candidate> = cands
        .iter()
        .enumerate()
        .filter(|&(k, c)| k == 0 || c.all)
        .map(|(_, c)| c)
        .collect();
    let names: Vec<&str> = synth.iter().map(|c| c.name).collect();
    println!(
        "Realistic synthetic scenes (0.5°; the 1°-only candidates are the defaults there), \
         {scans} scans per family and σ₀:\n\n{}",
        synthetic_table(&names, scans, &|k, ex, frame, base| {
            let p = (synth[k].half)(*base);
            let mut x = run_core(ex, frame, &p);
            x.lines.retain(|l| (synth[k].keep)(l));
            x.corners = corners_of(&x.lines, &p);
            x
        })?
    );
    Ok(())
}
