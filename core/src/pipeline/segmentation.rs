//! Segmentation and edge points from the last pass's `D` (ALGORITHM.md §6).
//!
//! A window breaks if it is invalid or `D >= tau`. A segment is a maximal run
//! of non-breaking windows `i..=k`; it covers the points `i..=k+2`, so the
//! point where two lines meet belongs to both segments, while a jump leaves no
//! shared point. Edge points are the middle points of breaking *valid* windows.

use core::ops::Range;

use heapless::Vec;

use crate::features::{Edges, Segment};

/// Where segmentation puts edge points (ascending beam indices): the
/// features' bitset [`Edges`] or a list.
pub trait EdgeList {
    /// Remove every edge point.
    fn clear(&mut self);
    /// Append `beam`; hands it back if it cannot be stored.
    fn push(&mut self, beam: u16) -> Result<(), u16>;
}

impl EdgeList for Edges {
    fn clear(&mut self) {
        Edges::clear(self);
    }
    fn push(&mut self, beam: u16) -> Result<(), u16> {
        Edges::push(self, beam)
    }
}

impl<const E: usize> EdgeList for Vec<u16, E> {
    fn clear(&mut self) {
        Vec::clear(self);
    }
    fn push(&mut self, beam: u16) -> Result<(), u16> {
        Vec::push(self, beam)
    }
}

/// What segmentation dropped or could not store.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SegmentationCounts {
    /// Segments shorter than `min_points`, dropped.
    pub short_segments: u16,
    /// Segments that did not fit the output's capacity.
    pub segment_overflow: u16,
    /// Edge points that did not fit the output's capacity.
    pub edge_overflow: u16,
}

/// Split the windows into segments and edge points.
///
/// `mahalanobis[i]` is `D` of window `i` (`+inf` if invalid; NaN is treated
/// as breaking). Outputs are cleared first; overflow is counted, never a panic.
/// The extractor segments as the last pass runs ([`Segmenter`]); this whole-
/// array form is for the evaluation and the workspace tests
/// (`lms_core::unstable::segment`).
#[cfg(any(test, feature = "unstable-lab"))]
pub fn segment<const S: usize, L: EdgeList>(
    mahalanobis: &[f32],
    tau: f32,
    min_points: u16,
    segments: &mut Vec<Segment, S>,
    edges: &mut L,
) -> SegmentationCounts {
    // Stride 1 is §6 exactly: first point `i`, last `k + 2`, edge `i + 1`.
    segment_strided(mahalanobis, 1, tau, min_points, segments, edges)
}

/// [`segment`] for windows of stride `stride` (§10 proposal): window `i`
/// is beams `i, i + stride, i + 2·stride` with middle beam `i + stride`. A
/// run of windows `i..=k` is kept if it holds at least `min_points − 3`
/// windows (at stride 1: `min_points − 2`, §6) and covers the beams of its
/// windows, `i ..= k + 2·stride`, except where that reaches into a
/// neighbour: its first beam is at least the previous kept segment's last
/// (the two share at most one point, as in §6) and its last at most
/// `j + stride − 1` for a next run from window `j` (the first beam of that
/// run's middle beams). So a corner point is shared as in §6 and a jump
/// leaves none. The edge point of a breaking window is its middle beam.
/// `stride = 1` is §6.
// Never inlined: the slice form is for tools and tests; the extractor feeds
// a `Segmenter` window by window.
#[cfg(any(test, feature = "unstable-lab"))]
#[inline(never)]
pub fn segment_strided<const S: usize, L: EdgeList>(
    mahalanobis: &[f32],
    stride: usize,
    tau: f32,
    min_points: u16,
    segments: &mut Vec<Segment, S>,
    edges: &mut L,
) -> SegmentationCounts {
    let mut seg = Segmenter::new(stride, tau, min_points, segments, edges);
    let windows = mahalanobis.len().min(u16::MAX as usize - 2 * seg.stride);
    for (i, &d) in mahalanobis.iter().take(windows).enumerate() {
        seg.window(i, d);
    }
    seg.finish(windows)
}

/// §6 fed window by window, in order (the extractor feeds it the last
/// pass's `D` as the pass computes it, so no `D` of the whole scan is
/// kept): `segment_strided` is this over a slice.
pub struct Segmenter<'a, const S: usize, L: EdgeList> {
    stride: usize,
    tau: f32,
    min_points: u16,
    run_start: Option<usize>,
    /// The last closed run, its last beam not yet bounded by the next run.
    pending: Option<Segment>,
    /// Last beam of the last kept segment.
    kept_last: Option<u16>,
    counts: SegmentationCounts,
    invalid: u16,
    segments: &'a mut Vec<Segment, S>,
    edges: &'a mut L,
}

impl<'a, const S: usize, L: EdgeList> Segmenter<'a, S, L> {
    /// A segmenter for windows of `stride` (clamped to 1..=8) writing into
    /// `segments` and `edges`, which it clears.
    pub fn new(
        stride: usize,
        tau: f32,
        min_points: u16,
        segments: &'a mut Vec<Segment, S>,
        edges: &'a mut L,
    ) -> Self {
        segments.clear();
        edges.clear();
        Segmenter {
            stride: stride.clamp(1, 8),
            tau,
            min_points,
            run_start: None,
            pending: None,
            kept_last: None,
            counts: SegmentationCounts::default(),
            invalid: 0,
            segments,
            edges,
        }
    }

    /// Window `i` (the next one, `i` counting from 0) has `D = d` (`+inf`
    /// if invalid; NaN breaks).
    #[inline]
    pub fn window(&mut self, i: usize, d: f32) {
        let breaks = !(d < self.tau); // NaN breaks too
        if !d.is_finite() {
            self.invalid = self.invalid.saturating_add(1);
        } else if breaks && self.edges.push((i + self.stride) as u16).is_err() {
            self.counts.edge_overflow = self.counts.edge_overflow.saturating_add(1);
        }
        match (breaks, self.run_start) {
            (false, None) => {
                // The closed run ends before this run's middle beams.
                self.emit_pending((i + self.stride - 1) as u16);
                self.run_start = Some(i);
            }
            (true, Some(start)) => self.close(start..i),
            _ => {}
        }
    }

    /// Windows that were not finite so far (invalid windows, §2).
    pub fn invalid_windows(&self) -> u16 {
        self.invalid
    }

    /// Close the last run after `windows` windows; what was dropped.
    pub fn finish(&mut self, windows: usize) -> SegmentationCounts {
        if let Some(start) = self.run_start.take() {
            self.close(start..windows);
        }
        self.emit_pending(u16::MAX);
        self.counts
    }

    /// The run of windows `run` (`start..end`): every beam of its windows,
    /// from the last kept segment's last beam on; kept back until the next
    /// run bounds its end.
    fn close(&mut self, run: Range<usize>) {
        let Range { start, end } = run;
        self.run_start = None;
        if end - start < self.windows_needed() {
            self.counts.short_segments = self.counts.short_segments.saturating_add(1);
            return;
        }
        let first = start as u16;
        self.pending = Some(Segment {
            first: self.kept_last.map_or(first, |last| first.max(last)),
            last: (end + 2 * self.stride - 1) as u16,
        });
    }

    /// Fewest windows a kept run holds: `min_points − 2` at stride 1 (§6:
    /// `min_points` beams); `min_points − 3` at a larger stride, whose run
    /// covers `2·stride` beams more than it has windows (at the default 5:
    /// two windows, one of each turn at stride 2, six beams; three lost 3×
    /// more clean corners, docs/DESIGN.md, same-turn windows).
    fn windows_needed(&self) -> usize {
        let spare = if self.stride > 1 { 3 } else { 2 };
        (self.min_points as usize).saturating_sub(spare).max(1)
    }

    /// Keep or drop the closed run, its last beam at most `bound`.
    fn emit_pending(&mut self, bound: u16) {
        let Some(mut seg) = self.pending.take() else {
            return;
        };
        seg.last = seg.last.min(bound);
        if seg.points() < self.min_points as usize {
            self.counts.short_segments = self.counts.short_segments.saturating_add(1);
        } else if self.segments.push(seg).is_err() {
            self.counts.segment_overflow = self.counts.segment_overflow.saturating_add(1);
        } else {
            self.kept_last = Some(seg.last);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const INF: f32 = f32::INFINITY;

    fn run(
        d: &[f32],
        min_points: u16,
    ) -> (
        std::vec::Vec<(u16, u16)>,
        std::vec::Vec<u16>,
        SegmentationCounts,
    ) {
        let mut segs: Vec<Segment, 8> = Vec::new();
        let mut edges: Vec<u16, 16> = Vec::new();
        let c = segment(d, 9.0, min_points, &mut segs, &mut edges);
        (
            segs.iter().map(|s| (s.first, s.last)).collect(),
            edges.iter().copied().collect(),
            c,
        )
    }

    #[test]
    fn a_corner_point_is_shared_and_a_jump_is_not() {
        // windows 0..=9 (12 points); window 4 breaks (corner at point 5),
        // window 7 is invalid (a no-echo beam at point 9... windows 7 only here).
        let d = [1.0, 1.0, 1.0, 1.0, 50.0, 1.0, 1.0, INF, 1.0, 1.0];
        let (segs, edges, c) = run(&d, 3);
        assert_eq!(segs, vec![(0, 5), (5, 8), (8, 11)]);
        assert_eq!(edges, vec![5]);
        assert_eq!(c, SegmentationCounts::default());
    }

    #[test]
    fn short_segments_are_dropped_and_counted() {
        let d = [1.0, 20.0, 1.0, 1.0, 1.0, 1.0];
        let (segs, edges, c) = run(&d, 5);
        assert_eq!(segs, vec![(2, 7)]);
        assert_eq!(edges, vec![2]);
        assert_eq!(c.short_segments, 1);
    }

    #[test]
    fn the_gate_is_inclusive_and_nan_breaks() {
        let d = [9.0, 1.0, f32::NAN, 1.0];
        let (segs, edges, _) = run(&d, 3);
        assert_eq!(segs, vec![(1, 3), (3, 5)]);
        assert_eq!(edges, vec![1]);
    }

    #[test]
    fn overflow_is_counted() {
        let mut d = [1.0f32; 40];
        for i in (3..40).step_by(4) {
            d[i] = 100.0;
        }
        let mut segs: Vec<Segment, 4> = Vec::new();
        let mut edges: Vec<u16, 3> = Vec::new();
        let c = segment(&d, 9.0, 3, &mut segs, &mut edges);
        assert_eq!(segs.len(), 4);
        assert_eq!(c.segment_overflow, 6);
        assert_eq!(c.edge_overflow, 7); // 10 breaking windows, 3 slots
    }

    #[test]
    fn strided_runs_cover_their_windows_up_to_their_neighbours() {
        let mut segs: Vec<Segment, 8> = Vec::new();
        let mut edges: Vec<u16, 16> = Vec::new();
        // Stride 2: windows span 5 beams. A jump between beams 9 and 10
        // breaks the windows 6..=9 (those holding both beams).
        let mut d = [0.0f32; 20];
        for x in &mut d[6..=9] {
            *x = 50.0;
        }
        let c = segment_strided(&d, 2, 9.0, 5, &mut segs, &mut edges);
        assert_eq!(c, SegmentationCounts::default());
        // Runs 0..=5 and 10..=19: every beam of their windows, 0..=9 and
        // 10..=23; the jump between beams 9 and 10 is in neither.
        assert_eq!(
            segs.as_slice(),
            &[
                Segment { first: 0, last: 9 },
                Segment {
                    first: 10,
                    last: 23
                }
            ]
        );
        // Edge points: the middle beams i + 2 of the breaking windows.
        assert_eq!(edges.as_slice(), &[8, 9, 10, 11]);
        // One breaking window: the neighbours share exactly one point.
        let mut d1 = [0.0f32; 20];
        d1[7] = 50.0;
        segment_strided(&d1, 2, 9.0, 5, &mut segs, &mut edges);
        assert_eq!(segs[0].last, segs[1].first);
        // A corner at beam 10 breaks the windows 7..=9 (beam 10 strictly
        // inside): both segments end on it, as at stride 1.
        let mut dc = [0.0f32; 20];
        for x in &mut dc[7..=9] {
            *x = 50.0;
        }
        segment_strided(&dc, 2, 9.0, 5, &mut segs, &mut edges);
        assert_eq!((segs[0].last, segs[1].first), (10, 10));
        // Two breaking windows 8 and 9: the runs' windows reach over each
        // other (beams 8..=11); the earlier run keeps them up to the later
        // run's first middle beam, 11, and the two share that one point.
        let mut d2 = [0.0f32; 20];
        d2[8] = 50.0;
        d2[9] = 50.0;
        segment_strided(&d2, 2, 9.0, 5, &mut segs, &mut edges);
        assert_eq!((segs[0].last, segs[1].first), (11, 11));
        // A run of one window (7) is too short (min_points 5 asks for two
        // at stride 2) and dropped; the run before it still ends before
        // its middle beams, at 8.
        let mut d3 = [0.0f32; 20];
        for i in [6, 8] {
            d3[i] = 50.0;
        }
        let c = segment_strided(&d3, 2, 9.0, 5, &mut segs, &mut edges);
        assert_eq!(c.short_segments, 1);
        assert_eq!(
            segs.as_slice(),
            &[
                Segment { first: 0, last: 8 },
                Segment { first: 9, last: 23 }
            ]
        );
        // A run of two windows (6..=7) between two double breaks is kept:
        // beams 7..=11, one shared with each neighbour.
        let mut d4 = [0.0f32; 20];
        for i in [4, 5, 8, 9] {
            d4[i] = 50.0;
        }
        segment_strided(&d4, 2, 9.0, 5, &mut segs, &mut edges);
        assert_eq!(
            segs.as_slice(),
            &[
                Segment { first: 0, last: 7 },
                Segment { first: 7, last: 11 },
                Segment {
                    first: 11,
                    last: 23
                }
            ]
        );
        // Stride 1 is §6.
        let mut s1: Vec<Segment, 8> = Vec::new();
        let mut e1: Vec<u16, 16> = Vec::new();
        let mut s2: Vec<Segment, 8> = Vec::new();
        let mut e2: Vec<u16, 16> = Vec::new();
        segment(&d, 9.0, 5, &mut s1, &mut e1);
        segment_strided(&d, 1, 9.0, 5, &mut s2, &mut e2);
        assert_eq!((s1, e1), (s2, e2));
    }
}
