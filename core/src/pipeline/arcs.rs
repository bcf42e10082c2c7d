//! Arcs are not walls (beyond ALGORITHM.md v2; `docs/DESIGN.md`, arcs):
//! drop the lines of a polyline that follows a curve.
//!
//! Split before reject leaves a curved wall or a pillar whole when a circle
//! explains its segment ([`crate::pipeline::split`]), but where §6 has
//! already cut the curve into several segments, each short piece passes
//! §7's χ² on its own: the frame then reports a chain of short lines, each
//! turning a little further the same way, and "corners" between them. None
//! of them is a wall a robot can map. Here a run of at least
//! [`Params::arc_chain`] consecutive lines, each one's facing end within
//! `corner_gap` of the next one's ([`Line::gap_to`]) and each turning from
//! the last by `arc_min_turn_deg ..= arc_max_turn_deg` in the same
//! direction, is dropped and counted (`Stats::rejected_arc`). Two lines
//! alone are no chain: an obtuse corner looks the same.
//!
//! Such a pair is dropped too when `curve_not_corner` tells it from a
//! corner with its beams (`Params::arc_pairs`, docs/DESIGN.md, pairs of
//! lines on a curve): a circle through the union
//! explains a curved wall within the noise and better than its two chords
//! do, but not the kink of a corner between two straight walls.
//!
//! Runs on the lines §7 kept (accepted, merged, long and certain enough)
//! and before §8 (no corner is reported on an arc). f32, fixed order, no
//! allocation.

use crate::features::{Line, Segment, MAX_LINES};
use crate::params::Params;
use crate::pipeline::line_fit::{residual_sum, BearingTable, RawScan};
use crate::pipeline::split::{chi2_quantile_999, circle_residuals};

/// Mark in `on_arc` (entry `k`: line `k`) the lines of `lines` (scan
/// order, fitted on `scan`) that belong to an arc; returns how many. A run
/// of exactly two linked lines is marked if `curve_not_corner` says so
/// (`Params::arc_pairs`).
#[inline(never)]
pub fn mark_arcs<B: BearingTable>(
    scan: &RawScan<'_, B>,
    lines: &[Line],
    params: &Params,
    on_arc: &mut [bool; MAX_LINES],
) -> u16 {
    let chain = usize::from(params.arc_chain);
    if chain < 2 {
        return 0;
    }
    // The run so far: lines `start..=k`, and its last turn (0: one line).
    let (mut start, mut last_turn) = (0usize, 0.0f32);
    let mut close = |start: usize, last: usize| {
        let pair = last == start + 1
            && params.arc_pairs
            && !on_arc.get(start).copied().unwrap_or(true)
            && lines
                .get(start..=last)
                .is_some_and(|pair| curve_not_corner(scan, pair, params));
        if pair || last + 1 >= start + chain {
            for flag in on_arc.get_mut(start..=last).into_iter().flatten() {
                *flag = true;
            }
        }
    };
    let deg = core::f32::consts::PI / 180.0;
    let (min_turn, max_turn) = (params.arc_min_turn_deg * deg, params.arc_max_turn_deg * deg);
    for (k, pair) in lines.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        let turn = turn(a.alpha, b.alpha);
        let size = libm::fabsf(turn);
        let linked = a.gap_to(b) < params.corner_gap && size >= min_turn && size <= max_turn;
        let same_way = last_turn == 0.0 || (turn > 0.0) == (last_turn > 0.0);
        if linked && same_way {
            last_turn = turn;
            continue;
        }
        // The run ends with line `k`; the next starts at `k` (turning the
        // other way) or at `k + 1`.
        close(start, k);
        (start, last_turn) = if linked { (k, turn) } else { (k + 1, 0.0) };
    }
    close(start, lines.len().saturating_sub(1));
    on_arc.iter().filter(|&&f| f).count() as u16
}

/// Gauss–Newton steps of the pair test's circle after the algebraic fit.
const ARC_PAIR_REFINE: u8 = 2;

/// How much better (in `Σe²/σ²`) the circle must fit than the two lines:
/// χ²₁ at 95 %. A bend of 10–15° between two 0.4 m walls at σ = 1 cm is
/// explained by a circle about as well as by its two lines; the margin
/// keeps 99 % of them (Akaike's criterion, a margin of −2, lost 9–14 %;
/// `core/tests/arc_pairs.rs`, docs/DESIGN.md).
const ARC_PAIR_MARGIN: f32 = 3.841_459;

/// Whether the two linked lines `pair` are two chords of a curve rather
/// than a corner: the circle through the valid beams `a.first..=b.last`
/// (the algebraic fit and [`ARC_PAIR_REFINE`] geometric steps) explains
/// them at σ (`Σ(‖p − c‖ − R)²/σ²` below χ²ₘ₋₃ at 99.9 %, as split before
/// reject's circle test) and fits them better than the two lines do by
/// [`ARC_PAIR_MARGIN`] (`Σ`: each line's own `residual_sum`, turn offsets out),
/// with one parameter fewer.
fn curve_not_corner<B: BearingTable>(
    scan: &RawScan<'_, B>,
    pair: &[Line],
    params: &Params,
) -> bool {
    let [a, b] = pair else {
        return false;
    };
    let own = |l: &Line| residual_sum(l, scan.turns);
    let union = Segment {
        first: a.first,
        last: b.last,
    };
    circle_residuals(scan, union, params.line_sigma(), ARC_PAIR_REFINE).is_some_and(|(sum, m)| {
        sum < chi2_quantile_999(m - 3.0) && sum + ARC_PAIR_MARGIN <= own(a) + own(b)
    })
}

/// `b − a` wrapped into (−π, π] for `a`, `b` in (−π, π] (a line's α):
/// one conditional step of 2π, not the general [`crate::maths::wrap_angle`].
#[inline(always)]
fn turn(a: f32, b: f32) -> f32 {
    use core::f32::consts::PI;
    let d = b - a;
    if d > PI {
        d - 2.0 * PI
    } else if d <= -PI {
        d + 2.0 * PI
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maths::Sym2;
    use heapless::Vec;

    /// Drop the arcs' lines as the extractor does; how many. The lines
    /// have no beams (a scan of none): a pair is never taken for a curve
    /// here (`core/tests/arc_pairs.rs` tests pairs on beams).
    fn drop_arcs(lines: &mut Vec<Line, MAX_LINES>, params: &Params) -> u16 {
        use crate::pipeline::line_fit::Bearings;
        let scan = RawScan {
            bearings: Bearings { cos: &[], sin: &[] },
            ranges: &[],
            beams: &[],
            max_range: f32::INFINITY,
            footprint: 0.0,
            turns: 1,
        };
        let mut on_arc = [false; MAX_LINES];
        let n = mark_arcs(&scan, lines, params, &mut on_arc);
        let mut flags = on_arc.iter();
        lines.retain(|_| !flags.next().copied().unwrap_or(false));
        n
    }

    /// A line from `(x0, y0)` to `(x1, y1)` (its α, r from the segment).
    fn line(x0: f32, y0: f32, x1: f32, y1: f32) -> Line {
        let (dx, dy) = (x1 - x0, y1 - y0);
        let len = libm::sqrtf(dx * dx + dy * dy);
        let (mut nx, mut ny) = (dy / len, -dx / len);
        let mut r = x0 * nx + y0 * ny;
        if r < 0.0 {
            (nx, ny, r) = (-nx, -ny, -r);
        }
        Line {
            alpha: libm::atan2f(ny, nx),
            r,
            cov: Sym2::default(),
            first: 0,
            last: 0,
            points: 10,
            chi2: 1.0,
            endpoints: [[x0, y0], [x1, y1]],
        }
    }

    /// Lines joining consecutive points.
    fn polyline(points: &[(f32, f32)]) -> Vec<Line, MAX_LINES> {
        points
            .windows(2)
            .map(|p| line(p[0].0, p[0].1, p[1].0, p[1].1))
            .collect()
    }

    /// `k + 1` points on a circle of radius `rad` around `(cx, cy)`, from
    /// angle `a0` by `step` (rad).
    fn arc(cx: f32, cy: f32, rad: f32, a0: f32, step: f32, k: usize) -> [(f32, f32); 8] {
        let mut p = [(0.0, 0.0); 8];
        for (i, slot) in p.iter_mut().enumerate().take(k + 1) {
            let a = a0 + step * i as f32;
            *slot = (cx + rad * libm::cosf(a), cy + rad * libm::sinf(a));
        }
        p
    }

    #[test]
    fn a_polyline_on_a_curved_wall_is_dropped() {
        // Four chords of a 3 m circle seen from inside, 15° each.
        let p = arc(0.0, 0.0, 3.0, -0.5, 15f32.to_radians(), 4);
        let mut lines = polyline(&p[..5]);
        assert_eq!(drop_arcs(&mut lines, &Params::DEFAULT), 4);
        assert!(lines.is_empty());
    }

    #[test]
    fn a_pillar_between_walls_loses_only_its_chords() {
        // Three chords of a 0.3 m pillar at 2.3 m (25° steps, the side
        // facing the sensor), between two walls that do not touch it.
        let p = arc(
            2.3,
            0.0,
            0.3,
            core::f32::consts::PI - 0.65,
            25f32.to_radians(),
            3,
        );
        let mut lines: Vec<Line, MAX_LINES> = Vec::new();
        let (left, right) = (line(1.0, -3.0, 1.0, -2.0), line(1.0, 2.0, 1.0, 3.0));
        lines.push(left).unwrap();
        for c in polyline(&p[..4]) {
            lines.push(c).unwrap();
        }
        lines.push(right).unwrap();
        assert_eq!(
            drop_arcs(&mut lines, &Params::DEFAULT),
            3,
            "the three chords"
        );
        assert_eq!(lines.as_slice(), &[left, right]);
    }

    #[test]
    fn corners_of_a_room_and_obtuse_pairs_are_kept() {
        // A rectangle's walls (90° turns) and a 150° bend (30° turn) alone.
        let room = [
            (3.0, -2.0),
            (3.0, 2.0),
            (-1.0, 2.0),
            (-1.0, -2.0),
            (3.0, -2.0),
        ];
        let mut lines = polyline(&room);
        assert_eq!(drop_arcs(&mut lines, &Params::DEFAULT), 0);
        assert_eq!(lines.len(), 4);
        let bend = [(3.0, -2.0), (3.0, 0.0), (2.0, 1.73)];
        let mut lines = polyline(&bend);
        assert_eq!(drop_arcs(&mut lines, &Params::DEFAULT), 0);
    }

    #[test]
    fn a_zigzag_is_no_arc_and_the_option_turns_off() {
        // Turns of ±20° alternate: no arc.
        let zigzag = [(3.0, -1.0), (3.0, -0.5), (3.1, 0.0), (3.0, 0.5), (3.1, 1.0)];
        let mut lines = polyline(&zigzag);
        assert_eq!(drop_arcs(&mut lines, &Params::DEFAULT), 0);
        let p = arc(0.0, 0.0, 3.0, -0.5, 15f32.to_radians(), 4);
        let mut lines = polyline(&p[..5]);
        let off = Params {
            arc_chain: 0,
            arc_pairs: false,
            ..Params::DEFAULT
        };
        assert_eq!(drop_arcs(&mut lines, &off), 0);
        assert_eq!(lines.len(), 4);
    }
}
