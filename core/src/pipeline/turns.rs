//! Per-turn extraction (ALGORITHM.md §10 proposal (d), [`Params::per_turn`];
//! feature `section10`, not in the firmware).
//!
//! In the LMS's interleaved modes (0.5°: two mirror turns, 0.25°: four) the
//! turns of one scan are 13.3 ms apart, so on a moving platform their hits
//! on one wall are parallel point sets a few mm to cm apart
//! (`docs/DESIGN.md`). The three-point windows of §2
//! mix the turns and break along such walls; within one turn they do not.
//! So each turn `t` of `k` — beams `t, t+k, t+2k, …` — runs through §2–8
//! as a scan of its own at bearing step `k·γ` ([`turn_frame`]), and the
//! turns' lines of one wall are fused into one ([`fuse_into`]):
//!
//! * **Pairing.** Turn by turn, in scan order, a line pairs with the fused
//!   line whose beam range overlaps its own most, among those whose beam
//!   ranges meet and whose `(α, r)` agree within [`TURN_FUSE_ALPHA_DEG`]
//!   and [`TURN_FUSE_R`]; a line no fused line takes is added as it is.
//! * **Fusion** (information form, fixed order, f32):
//!   `Σ = (Σ₁⁻¹ + Σ₂⁻¹)⁻¹`, `(α, r) = Σ·(Σ₁⁻¹·x₁ + Σ₂⁻¹·x₂)` with `α₂`
//!   unwrapped to `α₁`; beam range the union, points the sum, χ² the larger,
//!   endpoints the outer two projected onto the fused line.
//!
//! [`Params::per_turn`]: crate::Params::per_turn
//! [`TURN_FUSE_ALPHA_DEG`]: crate::params::TURN_FUSE_ALPHA_DEG
//! [`TURN_FUSE_R`]: crate::params::TURN_FUSE_R

use heapless::Vec;

use crate::features::{Features, Line, Segment, Stats, MAX_LINES, MAX_SEGMENTS};
use crate::frame::{Beam, Frame, Geometry, MAX_BEAMS};
use crate::maths::{cos_sin, wrap_angle};
use crate::params::{TURN_FUSE_ALPHA_DEG, TURN_FUSE_R};
pub use crate::pipeline::smoothing::interleaved_turns;

/// One mirror turn of an interleaved scan: turn `index` of `of` (`0..of`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Turn {
    /// Which turn, from 0.
    pub index: usize,
    /// Turns per scan.
    pub of: usize,
}

/// Turn `t` of `k` of `frame` as a frame of its own: its beam `i` is the
/// frame's beam `k·i + t`, at bearing step `k·γ`. `None` if that leaves
/// too few beams for a frame.
pub fn turn_frame(frame: &Frame, turn: Turn) -> Option<Frame> {
    let Turn { index: t, of: k } = turn;
    let g = frame.geometry();
    let n = frame.len().saturating_sub(t).div_ceil(k.max(1));
    let geometry = Geometry {
        first_bearing: g.first_bearing + t as f32 * g.step,
        step: k as f32 * g.step,
    };
    let mut turn = Frame::new(geometry, n).ok()?;
    let (ranges, beams) = (frame.ranges(), frame.beams());
    for i in 0..n {
        let j = k * i + t;
        match (beams.get(j), ranges.get(j)) {
            (Some(Beam::Valid), Some(&d)) => turn.set_metres(i, d),
            (Some(&Beam::Invalid(why)), _) => turn.set_invalid(i, why),
            _ => {}
        }
    }
    Some(turn)
}

/// Beam ranges of `a` and `b` overlap by this many beams minus one
/// (negative: a gap).
fn overlap(a: &Line, b: &Line) -> i32 {
    i32::from(a.last.min(b.last)) - i32::from(a.first.max(b.first))
}

/// Add `line` (beam indices of the whole frame) to `fused`: fused with its
/// partner if it has one (see the module docs), else appended; a full list
/// counts it in `stats.line_overflow`.
pub fn fuse_into(fused: &mut Vec<Line, MAX_LINES>, line: &Line, stats: &mut Stats) {
    let gate_alpha = TURN_FUSE_ALPHA_DEG * (core::f32::consts::PI / 180.0);
    let mut best: Option<(usize, i32)> = None;
    for (i, f) in fused.iter().enumerate() {
        let o = overlap(f, line);
        let agree = libm::fabsf(wrap_angle(line.alpha - f.alpha)) < gate_alpha
            && libm::fabsf(line.r - f.r) < TURN_FUSE_R;
        if o >= 0 && agree && best.is_none_or(|(_, bo)| o > bo) {
            best = Some((i, o));
        }
    }
    if let Some((i, _)) = best {
        if let Some(slot) = fused.get_mut(i) {
            if let Some(both) = fuse(slot, line) {
                *slot = both;
                stats.merges = stats.merges.saturating_add(1);
                return;
            }
        }
    }
    if fused.push(*line).is_err() {
        stats.line_overflow = stats.line_overflow.saturating_add(1);
    }
}

/// Two turns' lines of one wall as one (module docs); `None` if a
/// covariance is not positive definite.
pub fn fuse(p: &Line, q: &Line) -> Option<Line> {
    let ip = p.cov.inverse_spd()?;
    let iq = q.cov.inverse_spd()?;
    let cov = ip.add(&iq).inverse_spd()?;
    let qa = p.alpha + wrap_angle(q.alpha - p.alpha);
    let v0 = ip.a * p.alpha + ip.b * p.r + iq.a * qa + iq.b * q.r;
    let v1 = ip.b * p.alpha + ip.c * p.r + iq.b * qa + iq.c * q.r;
    let mut alpha = wrap_angle(cov.a * v0 + cov.b * v1);
    let mut r = cov.b * v0 + cov.c * v1;
    if r < 0.0 {
        r = -r;
        alpha = wrap_angle(alpha + core::f32::consts::PI);
    }
    let (c, s) = cos_sin(alpha);
    let project = |e: [f32; 2]| {
        let d = e[0] * c + e[1] * s - r;
        [e[0] - d * c, e[1] - d * s]
    };
    let first = if p.first <= q.first { p } else { q }.endpoints[0];
    let last = if p.last >= q.last { p } else { q }.endpoints[1];
    Some(Line {
        alpha,
        r,
        cov,
        first: p.first.min(q.first),
        last: p.last.max(q.last),
        points: p.points.saturating_add(q.points),
        chi2: p.chi2.max(q.chi2),
        endpoints: [project(first), project(last)],
    })
}

/// What the turns of one frame add up to, turn by turn, in the whole
/// frame's beam indices: fused lines, segments, edge points, smoothed
/// ranges, counters (summed; a fusion counts as a merge).
pub struct TurnsMerged {
    k: usize,
    lines: Vec<Line, MAX_LINES>,
    segments: Vec<Segment, MAX_SEGMENTS>,
    edges: [bool; MAX_BEAMS],
    smoothed: [f32; MAX_BEAMS],
    stats: Stats,
}

impl TurnsMerged {
    /// Nothing yet, for a frame of `k` turns.
    pub fn new(k: usize) -> Self {
        TurnsMerged {
            k,
            lines: Vec::new(),
            segments: Vec::new(),
            edges: [false; MAX_BEAMS],
            smoothed: [0.0; MAX_BEAMS],
            stats: Stats::ZERO,
        }
    }

    /// The frame's beam of turn `t`'s beam `i`.
    fn whole(&self, t: usize, i: u16) -> u16 {
        (self.k * usize::from(i) + t) as u16
    }

    /// Add turn `t`'s features `f` and smoothed ranges (its own indices).
    pub fn add_turn(&mut self, t: usize, f: &Features, smoothed: &[f32]) {
        self.stats.saturating_add(f.stats());
        for s in f.segments() {
            let s = Segment {
                first: self.whole(t, s.first),
                last: self.whole(t, s.last),
            };
            if self.segments.push(s).is_err() {
                self.stats.segment_overflow = self.stats.segment_overflow.saturating_add(1);
            }
        }
        for e in f.edges() {
            let j = usize::from(self.whole(t, e));
            if let Some(x) = self.edges.get_mut(j) {
                *x = true;
            }
        }
        let k = self.k;
        for (i, &x) in smoothed.iter().enumerate() {
            if let Some(s) = self.smoothed.get_mut(k * i + t) {
                *s = x;
            }
        }
        for l in f.lines() {
            let l = Line {
                first: self.whole(t, l.first),
                last: self.whole(t, l.last),
                ..*l
            };
            fuse_into(&mut self.lines, &l, &mut self.stats);
        }
    }

    /// `D` of turn `t`'s windows into `trace` (the whole frame's windows):
    /// turn window `i` has the middle beam `k·(i + 1) + t`, the frame's
    /// window `k·i + k + t − 1`.
    pub fn trace_turn(&self, t: usize, turn_d: &[f32], trace: &mut [f32]) {
        for (i, &d) in turn_d.iter().enumerate() {
            if let Some(x) = trace.get_mut(self.k * i + self.k + t - 1) {
                *x = d;
            }
        }
    }

    /// Into `features` (segments and lines in scan order, edge points,
    /// no corners yet) and `smoothed` (the frame's beams); the counters,
    /// without the turns' corner counts (corners are the fused lines').
    pub fn finish(self, features: &mut Features, smoothed: &mut [f32]) -> Stats {
        let TurnsMerged {
            mut lines,
            mut segments,
            edges,
            smoothed: turns_smoothed,
            mut stats,
            ..
        } = self;
        segments.sort_unstable_by_key(|s| (s.first, s.last));
        lines.sort_unstable_by_key(|l| (l.first, l.last));
        features.segments = segments;
        features.edges.clear();
        for (j, _) in edges.iter().enumerate().filter(|(_, &e)| e) {
            let _ = features.edges.push(j as u16); // ascending, below MAX_BEAMS
        }
        features.lines = lines;
        features.corners.clear();
        for (s, &x) in smoothed.iter_mut().zip(turns_smoothed.iter()) {
            *s = x;
        }
        stats.degenerate_corners = 0;
        stats.corner_overflow = 0;
        stats
    }
}
