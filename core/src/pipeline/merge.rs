//! Which beams a segment's fit uses, and the merge of neighbouring lines
//! (ALGORITHM.md §7, §7.6). Private to the pipeline; the evaluation's
//! baselines reach it through the `unstable-lab` feature
//! (`lms_core::unstable`), which carries no stability promise.

use crate::features::{Line, Segment};
use crate::maths::wrap_angle;
use crate::params::Params;
use crate::pipeline::line_fit::{
    fit_piece_without, mahalanobis, parameter_distance, residual_sum, BearingTable, Holes, RawScan,
};
use crate::pipeline::smoothing::usable;

/// The beams fitted for segment `k`: the whole segment (§7), or, with
/// `fit_shared_points == false`, without a first/last point it shares with
/// the neighbouring segment (a corner point lies on neither line exactly).
pub fn fit_span(segments: &[Segment], k: usize, fit_shared_points: bool) -> Segment {
    let Some(&seg) = segments.get(k) else {
        return Segment { first: 0, last: 0 };
    };
    if fit_shared_points {
        return seg;
    }
    let shares_first = k > 0 && segments.get(k - 1).is_some_and(|p| p.last == seg.first);
    let shares_last = segments.get(k + 1).is_some_and(|n| n.first == seg.last);
    Segment {
        first: seg.first.saturating_add(u16::from(shares_first)),
        last: seg.last.saturating_sub(u16::from(shares_last)),
    }
}

/// §7.6: merge `prev` and `next` if only invalid beams (or at most
/// `merge_gap_beams` valid ones) lie between them, their parameters agree
/// within `merge_gate`, and the refit of the union passes `max_chi2` (and,
/// beyond §7.6, stays within `merge_anchor_gate` of the larger line's own
/// parameters: `anchored`). The union is refitted on `scan`, the scan
/// the two lines were fitted on (its range limit, footprint term and
/// turns), without the beams of `holes` (the gaps inside `prev`, a merged
/// line) and, with `merge_own_beams`, without the beams between the two
/// across a gap of at most `merge_gap_beams` valid beams; on a merge that
/// gap joins `holes` (if [`crate::pipeline::line_fit::MAX_HOLES`] allows).
pub fn try_merge<B: BearingTable>(
    scan: &RawScan<'_, B>,
    prev: &Line,
    next: &Line,
    params: &Params,
    holes: &mut Holes,
) -> Option<Line> {
    let gap_start = prev.last as usize + 1;
    let gap_end = next.first as usize; // exclusive
    let valid_between = (gap_start..gap_end.max(gap_start))
        .filter(|&j| match (scan.beams.get(j), scan.ranges.get(j)) {
            (Some(&b), Some(&d)) => usable(b, d, scan.max_range),
            _ => false,
        })
        .count();
    let short_gap = valid_between <= params.merge_gap_beams as usize;
    let gated = short_gap && parameter_distance(prev, next).is_some_and(|d| d < params.merge_gate);
    let vouched = gated || (params.merge_collinear && collinear_and_touching(prev, next, params));
    if !(vouched || params.bridge_merge) {
        return None;
    }
    let (sigma, turns) = (params.line_sigma(), scan.turns);
    let union = Segment {
        first: prev.first,
        last: next.last,
    };
    // Beyond §7.6: the union of the lines' own beams across a short gap.
    let mut own = *holes;
    if params.merge_own_beams && gated && gap_end > gap_start {
        own.push(prev.last.saturating_add(1)..next.first);
    }
    let merged = fit_piece_without(scan, union, &own, sigma).ok()?;
    // A bridge (§10 (e)): each line's own beams must fit the union line.
    let fits = |part: &Line| part_chi2(part, &merged, turns).is_some_and(|c| c <= params.max_chi2);
    let larger = if next.points > prev.points {
        next
    } else {
        prev
    };
    (merged.chi2 <= params.max_chi2
        && (vouched || (fits(prev) && fits(next)))
        && anchored(larger, &merged, params.merge_anchor_gate)
        && nested(prev, next, &merged, turns, params.merge_f_test))
    .then(|| {
        *holes = own;
        merged
    })
}

/// Whether the union line `merged` stays within `gate` (χ²₂) of `larger`'s
/// own parameters: `Δᵀ Σ⁻¹ Δ ≤ gate · max(1, χ²)` with `Σ`, `χ²` (per
/// point) those of `larger`'s own fit, so a part whose beams scatter more
/// than `σ` says has its covariance scaled up by that excess (beyond
/// ALGORITHM.md v2; docs/DESIGN.md, the merges' anchor gate). A merge
/// must not move the better-determined line off its own evidence: §7.6's
/// χ² per point of the union is an average, and a long line with a short
/// piece at a 5–25° bend passes it while its α moves many σ. `+inf`: no
/// test (§7.6 as written, ALGORITHM.md v2).
fn anchored(larger: &Line, merged: &Line, gate: f32) -> bool {
    gate == f32::INFINITY
        || mahalanobis(&larger.cov, larger, merged)
            .is_some_and(|d| d <= gate * larger.chi2.max(1.0))
}

/// Whether one line (`merged`) explains the beams of `prev` and `next`
/// not significantly worse than the two: `F = ((S₁ − S₂)/2) / (S₂/(m − 4))
/// ≤ threshold` ([`Params::merge_f_test`]; the F ratio of nested least
/// squares models, two more parameters in the pair), with `S` each fit's
/// [`residual_sum`] and `m` the two lines' points. 0: no test (and always without feature `section10`).
fn nested(prev: &Line, next: &Line, merged: &Line, turns: u8, threshold: f32) -> bool {
    // An ALGORITHM.md §10 option: out of builds without `section10`
    // (the firmware), whose validation keeps it at 0.
    if !cfg!(feature = "section10") || threshold == 0.0 {
        return true;
    }
    let two = residual_sum(prev, turns) + residual_sum(next, turns);
    let dof = f32::from(prev.points) + f32::from(next.points) - 4.0;
    if !(dof > 0.0 && two > 0.0) {
        return true;
    }
    let f = ((residual_sum(merged, turns) - two) / 2.0) / (two / dof);
    f <= threshold
}

/// χ² per point of the beams `part` was fitted to about `line` (§10 (e)),
/// from `part`'s own fit: its weighted residual sum ([`residual_sum`], in
/// units of σ²), plus what it rises by when the parameters move from
/// `part`'s to `line`'s, `Δᵀ Σ⁻¹ Δ` (`Σ = σ²(JᵀWJ)⁻¹`, so exact for the
/// range model linearised at `part`), over the `m` points. `None` if
/// `part`'s covariance is not positive definite.
fn part_chi2(part: &Line, line: &Line, turns: u8) -> Option<f32> {
    let rise = mahalanobis(&part.cov, part, line)?;
    let m = f32::from(part.points);
    Some((residual_sum(part, turns) + rise) / m)
}

/// Whether `next` continues `prev` nearly collinearly: facing endpoints
/// closer than `corner_gap` and normals less than `min_corner_angle_deg`
/// apart (the pair would give an ill-conditioned corner).
fn collinear_and_touching(prev: &Line, next: &Line, params: &Params) -> bool {
    let close = prev.gap_to(next) < params.corner_gap;
    let apart = libm::fabsf(wrap_angle(next.alpha - prev.alpha));
    close && apart < params.min_corner_angle_deg * (core::f32::consts::PI / 180.0)
}
