//! Segmentation and edge points from the last pass's `D` (ALGORITHM.md §6).
//!
//! A window breaks if it is invalid or `D >= tau`. A segment is a maximal run
//! of non-breaking windows `i..=k`; it covers the points `i..=k+2`, so the
//! point where two lines meet belongs to both segments, while a jump leaves no
//! shared point. Edge points are the middle points of breaking *valid* windows.

use heapless::Vec;

/// A run of points `first..=last` (beam indices) explained by one line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Segment {
    /// First beam index.
    pub first: u16,
    /// Last beam index (inclusive).
    pub last: u16,
}

impl Segment {
    /// Number of points covered.
    #[inline]
    pub fn points(&self) -> usize {
        (self.last as usize + 1).saturating_sub(self.first as usize)
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
pub fn segment<const S: usize, const E: usize>(
    mahalanobis: &[f32],
    tau: f32,
    min_points: u16,
    segments: &mut Vec<Segment, S>,
    edges: &mut Vec<u16, E>,
) -> SegmentationCounts {
    segments.clear();
    edges.clear();
    let mut counts = SegmentationCounts::default();
    let mut run_start: Option<usize> = None;
    let windows = mahalanobis.len().min(u16::MAX as usize - 2);
    for i in 0..=windows {
        // `i == windows` closes the last run.
        let breaks = match mahalanobis.get(i) {
            Some(&d) => {
                let breaks = !(d < tau); // NaN breaks too
                if breaks && d.is_finite() && edges.push((i + 1) as u16).is_err() {
                    counts.edge_overflow = counts.edge_overflow.saturating_add(1);
                }
                breaks
            }
            None => true,
        };
        match (breaks, run_start) {
            (false, None) => run_start = Some(i),
            (true, Some(start)) => {
                run_start = None;
                let seg = Segment {
                    first: start as u16,
                    last: (i - 1 + 2) as u16,
                };
                if seg.points() < min_points as usize {
                    counts.short_segments = counts.short_segments.saturating_add(1);
                } else if segments.push(seg).is_err() {
                    counts.segment_overflow = counts.segment_overflow.saturating_add(1);
                }
            }
            _ => {}
        }
    }
    counts
}
