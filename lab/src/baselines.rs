//! The extractors compared: the core as specified, and two baselines that
//! share its back end.
//!
//! All of them end in [`features_from_segments`], a replica of the core's
//! ALGORITHM.md §7–8 stage (`Extractor::run` after segmentation: the fit
//! span of `fit_shared_points`, `fit_line` on the **raw** ranges, the
//! `max_chi2` gate, the §7.6 merge, `min_length` after merging, corners by
//! `lms_core::pipeline::corners::intersect` within `corner_gap`, the same capacities).
//! A test checks that it gives the core's lines and corners bit for bit on
//! the core's own segments. So the baselines differ from the core only in
//! how a scan is cut into segments:
//!
//! * [`split_and_merge`] — iterative end-point fit (IEPF): clusters broken at
//!   invalid beams and at jumps (adaptive breakpoint detector, λ = 10°, plus
//!   3σ), each split recursively at the point farthest from the chord of
//!   its end points while that distance exceeds `k·σ` (the split point
//!   belongs to both halves, like the core's corner point); the *merge* is
//!   the back end's §7.6 merge of agreeing neighbours.
//! * [`gaussian_mask`] — the paper's strawman: ranges smoothed with a
//!   normalised Gaussian kernel of `s` beams (over the valid beams within
//!   ±3s, across edges), then the core's window filter
//!   (`WindowFilter::update`) gives `D` on the smoothed ranges, segmented
//!   with the same τ by the core's `segmentation::segment`.

// `!(x < limit)` is deliberate, as in the core: NaN fails the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use heapless::Vec as HVec;
use lms_core::frame::MAX_BEAMS;
use lms_core::maths::Vec3;
use lms_core::pipeline::bearings::TwoLevelBearings;
use lms_core::pipeline::corners::intersect;
use lms_core::pipeline::ekf::WindowFilter;
use lms_core::pipeline::line_fit::{Bearings, Holes, RawScan};
use lms_core::unstable::fit_line;
use lms_core::unstable::segment;
use lms_core::unstable::{fit_span, try_merge};
use lms_core::Corner;
use lms_core::Line;
use lms_core::Segment;
use lms_core::{Extractor, Frame, Params};
use lms_core::{MAX_CORNERS, MAX_LINES, MAX_SEGMENTS};

/// The bearing tables of a frame, as the extractor computes them (its
/// two-level table, filled with `libm`).
#[derive(Clone, Debug, PartialEq)]
pub struct Tables {
    /// `cos φ_j`.
    pub cos: Vec<f32>,
    /// `sin φ_j`.
    pub sin: Vec<f32>,
    /// The extractor's two-level table of the same bearings.
    pub core: TwoLevelBearings,
}

impl Tables {
    /// The tables of `frame`'s geometry: the core's bearings, from its
    /// two-level table (the extractor's own values, bit for bit).
    pub fn for_frame(frame: &Frame) -> Self {
        let core = TwoLevelBearings::of(frame.geometry());
        let (cos, sin) = (0..frame.len()).map(|j| core.cos_sin(j)).unzip();
        Tables { cos, sin, core }
    }

    /// The extractor's own table: fits and merges through it give the
    /// extractor's bits (its angle sums run in another order than the full
    /// tables').
    pub fn core(&self) -> &TwoLevelBearings {
        &self.core
    }

    /// As the core's [`Bearings`].
    pub fn bearings(&self) -> Bearings<'_> {
        Bearings {
            cos: &self.cos,
            sin: &self.sin,
        }
    }
}

/// What an extractor found in one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Extraction {
    /// Segments before line fitting.
    pub segments: Vec<Segment>,
    /// Accepted lines in scan order.
    pub lines: Vec<Line>,
    /// Corners.
    pub corners: Vec<Corner>,
}

/// The core's result for `frame`.
pub fn run_core(ex: &mut Extractor, frame: &Frame, params: &Params) -> Extraction {
    let Ok(params) = params.validate() else {
        return Extraction::default();
    };
    let f = ex.run(frame, &params);
    Extraction {
        segments: f.segments().to_vec(),
        lines: f.lines().to_vec(),
        corners: f.corners().to_vec(),
    }
}

/// ALGORITHM.md §7–8 on `segments`, fitting `ranges` (the frame's raw ranges
/// for the specified behaviour).
pub fn features_from_segments(
    frame: &Frame,
    tables: &Tables,
    ranges: &[f32],
    segments: &[Segment],
    params: &Params,
) -> (Vec<Line>, Vec<Corner>) {
    let bearings = tables.core();
    let beams = frame.beams();
    // The merges' refits: the baselines' fits have one turn (§7 as written).
    let scan = RawScan {
        bearings,
        ranges,
        beams,
        max_range: params.max_range,
        footprint: params.footprint,
        turns: 1,
    };
    let mut lines: Vec<Line> = Vec::new();
    let mut holes = Holes::NONE;
    for k in 0..segments.len() {
        let span = fit_span(segments, k, params.fit_shared_points);
        let Ok(line) = fit_line(bearings, ranges, beams, span, params.sigma) else {
            continue;
        };
        if !(line.chi2 <= params.max_chi2) {
            continue;
        }
        if params.merge {
            if let Some(prev) = lines.last() {
                if let Some(merged) = try_merge(&scan, prev, &line, params, &mut holes) {
                    if let Some(slot) = lines.last_mut() {
                        *slot = merged;
                    }
                    continue;
                }
            }
        }
        if lines.len() < MAX_LINES {
            lines.push(line);
            holes = Holes::NONE;
        }
    }
    lines.retain(|l| l.length() >= params.min_length);
    let corners = corners_of(&lines, params);
    (lines, corners)
}

/// §8: corners between consecutive `lines` with close facing endpoints.
pub fn corners_of(lines: &[Line], params: &Params) -> Vec<Corner> {
    let mut corners = Vec::new();
    for (i, pair) in lines.windows(2).enumerate() {
        let (l1, l2) = (&pair[0], &pair[1]);
        let gap_x = l2.endpoints[0][0] - l1.endpoints[1][0];
        let gap_y = l2.endpoints[0][1] - l1.endpoints[1][1];
        if !(libm::sqrtf(gap_x * gap_x + gap_y * gap_y) < params.corner_gap) {
            continue;
        }
        if let Some(c) = intersect(i as u8, l1, (i + 1) as u8, l2, params.min_corner_angle_deg) {
            if corners.len() < MAX_CORNERS {
                corners.push(c);
            }
        }
    }
    corners
}

/// Segments of `D` per window with the core's segmentation (§6).
pub fn segments_of(d: &[f32], params: &Params) -> Vec<Segment> {
    let mut segs: HVec<Segment, MAX_SEGMENTS> = HVec::new();
    let mut edges: HVec<u16, MAX_BEAMS> = HVec::new();
    segment(d, params.tau, params.min_points, &mut segs, &mut edges);
    segs.to_vec()
}

/// The whole back end on `D` per window: segments, lines, corners.
pub fn extraction_from_d(frame: &Frame, tables: &Tables, d: &[f32], params: &Params) -> Extraction {
    let segments = segments_of(d, params);
    let (lines, corners) = features_from_segments(frame, tables, frame.ranges(), &segments, params);
    Extraction {
        segments,
        lines,
        corners,
    }
}

/// The adaptive breakpoint detector's angle λ (rad).
const ABD_LAMBDA: f32 = 10.0 * core::f32::consts::PI / 180.0;

/// Split-and-merge (IEPF) with split threshold `k_sigma·σ` (see the module docs).
pub fn split_and_merge(
    frame: &Frame,
    tables: &Tables,
    params: &Params,
    k_sigma: f32,
) -> Extraction {
    let n = frame.len();
    let r = frame.ranges();
    let beams = frame.beams();
    let gamma = frame.geometry().step;
    let sigma = params.sigma;
    let point = |j: usize| (r[j] * tables.cos[j], r[j] * tables.sin[j]);
    let jump_limit =
        |j: usize| r[j] * libm::sinf(gamma) / libm::sinf(ABD_LAMBDA - gamma) + 3.0 * sigma;

    // Clusters of consecutive valid beams without a jump.
    let mut clusters: Vec<(usize, usize)> = Vec::new();
    let mut start: Option<usize> = None;
    for (j, beam) in beams.iter().enumerate().take(n) {
        if !beam.is_valid() {
            if let Some(s) = start.take() {
                clusters.push((s, j - 1));
            }
            continue;
        }
        match start {
            None => start = Some(j),
            Some(s) => {
                let (a, b) = (point(j - 1), point(j));
                let d = libm::sqrtf((a.0 - b.0) * (a.0 - b.0) + (a.1 - b.1) * (a.1 - b.1));
                if d > jump_limit(j - 1) {
                    clusters.push((s, j - 1));
                    start = Some(j);
                }
            }
        }
    }
    if let Some(s) = start {
        clusters.push((s, n - 1));
    }

    // Recursive split, depth first, left half first.
    let threshold = k_sigma * sigma;
    let mut segments = Vec::new();
    for (a, b) in clusters {
        let mut stack = vec![(a, b)];
        while let Some((lo, hi)) = stack.pop() {
            let (pa, pb) = (point(lo), point(hi));
            let (ex, ey) = (pb.0 - pa.0, pb.1 - pa.1);
            let len = libm::sqrtf(ex * ex + ey * ey);
            let mut worst = (0.0f32, lo);
            if hi >= lo + 2 && len > 0.0 {
                for j in lo + 1..hi {
                    let p = point(j);
                    let d = (ex * (p.1 - pa.1) - ey * (p.0 - pa.0)).abs() / len;
                    if d > worst.0 {
                        worst = (d, j);
                    }
                }
            }
            if worst.0 > threshold {
                // Right half pushed first so the left half is taken first.
                stack.push((worst.1, hi));
                stack.push((lo, worst.1));
            } else if hi + 1 - lo >= params.min_points as usize && segments.len() < MAX_SEGMENTS {
                segments.push(Segment {
                    first: lo as u16,
                    last: hi as u16,
                });
            }
        }
    }
    // The peer's merge has no anchor gate (the core's defaults have one):
    // it is the textbook split-and-merge.
    let peer = (*params).with_merge_anchor_gate(f32::INFINITY);
    let (lines, corners) = features_from_segments(frame, tables, r, &segments, &peer);
    Extraction {
        segments,
        lines,
        corners,
    }
}

/// Ranges smoothed by a normalised Gaussian kernel of `s` beams over the
/// valid beams within ±⌈3s⌉ (invalid beams keep their value).
pub fn gaussian_smooth(frame: &Frame, s: f64) -> Vec<f32> {
    let r = frame.ranges();
    let beams = frame.beams();
    let half = (3.0 * s).ceil() as isize;
    let w: Vec<f64> = (-half..=half)
        .map(|k| (-(k * k) as f64 / (2.0 * s * s)).exp())
        .collect();
    let n = r.len() as isize;
    (0..n)
        .map(|j| {
            if !beams[j as usize].is_valid() {
                return r[j as usize];
            }
            let (mut num, mut den) = (0.0f64, 0.0f64);
            for k in -half..=half {
                let i = j + k;
                if i >= 0 && i < n && beams[i as usize].is_valid() {
                    let wk = w[(k + half) as usize];
                    num += wk * r[i as usize] as f64;
                    den += wk;
                }
            }
            (num / den) as f32
        })
        .collect()
}

/// `D` of every window of `ranges` by the core's window filter (`+inf`
/// where a beam is invalid or the filter refuses the window).
pub fn window_d(frame: &Frame, ranges: &[f32], params: &Params) -> Vec<f32> {
    let filter = WindowFilter::new(frame.geometry().step, params.sigma, params.q);
    let beams = frame.beams();
    (0..ranges.len().saturating_sub(2))
        .map(|i| {
            if !(beams[i].is_valid() && beams[i + 1].is_valid() && beams[i + 2].is_valid()) {
                return f32::INFINITY;
            }
            filter
                .update(Vec3([ranges[i], ranges[i + 1], ranges[i + 2]]))
                .map_or(f32::INFINITY, |e| e.mahalanobis)
        })
        .collect()
}

/// The Gaussian-mask baseline with a kernel of `s` beams.
pub fn gaussian_mask(frame: &Frame, tables: &Tables, params: &Params, s: f64) -> Extraction {
    let smoothed = gaussian_smooth(frame, s);
    let d = window_d(frame, &smoothed, params);
    extraction_from_d(frame, tables, &d, params)
}
