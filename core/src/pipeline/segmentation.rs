//! Segmentation and edge points from the last pass's `D` (ALGORITHM.md §6).
//!
//! A window breaks if it is invalid or `D >= tau`. A segment is a maximal run
//! of non-breaking windows `i..=k`; it covers the points `i..=k+2`, so the
//! point where two lines meet belongs to both segments, while a jump leaves no
//! shared point. Edge points are the middle points of breaking *valid* windows.

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
/// run of windows `i..=k` covers the middle beams of its windows and one
/// beam either side, `i + stride − 1 ..= k + stride + 1` (so two segments
/// share at most one point, as in §6); the edge point of a breaking window
/// is its middle beam. `stride = 1` is §6.
// Never inlined: the §10 option must not grow the extractor's stack frame.
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
/// kept): [`segment_strided`] is this over a slice.
pub struct Segmenter<'a, const S: usize, L: EdgeList> {
    stride: usize,
    tau: f32,
    min_points: u16,
    run_start: Option<usize>,
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
            (false, None) => self.run_start = Some(i),
            (true, Some(start)) => self.close(start, i),
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
            self.close(start, windows);
        }
        self.counts
    }

    /// The run of windows `start..end` as a segment.
    fn close(&mut self, start: usize, end: usize) {
        self.run_start = None;
        let seg = Segment {
            first: (start + self.stride - 1) as u16,
            last: (end + self.stride) as u16,
        };
        if seg.points() < self.min_points as usize {
            self.counts.short_segments = self.counts.short_segments.saturating_add(1);
        } else if self.segments.push(seg).is_err() {
            self.counts.segment_overflow = self.counts.segment_overflow.saturating_add(1);
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
    fn strided_runs_cover_their_middle_beams_and_one_more() {
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
        // Runs 0..=5 and 10..=19: middles 2..=7 and 12..=21, one beam more
        // either side; beams 9 and 10 (the jump) in neither.
        assert_eq!(
            segs.as_slice(),
            &[
                Segment { first: 1, last: 8 },
                Segment {
                    first: 11,
                    last: 22
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
