//! The one owner of all working buffers: runs the whole pipeline on a frame.
//!
//! [`Extractor`] holds the smoothed ranges, `D` of the last pass, the bearing
//! tables and the output [`Features`] in fixed arrays, so it can live in a
//! `static` on the MCU. [`Extractor::run`] takes a [`Frame`] and validated
//! [`Params`] and fills the features; [`Extractor::run_observed`] also hands
//! `D` and the ranges to a callback after every pass (the scale-space plots of
//! paper Fig. 10).

use heapless::Vec;

use crate::corners::{intersect, Corner};
use crate::ekf::WindowFilter;
use crate::frame::{Beam, Frame, Geometry, MAX_BEAMS};
use crate::line_fit::{fit_line, parameter_distance, Bearings, Line};
use crate::params::{ParamError, Params};
use crate::segmentation::{segment, Segment};
use crate::smoothing::{smoothing_pass, valid_windows};
use crate::split::split_before_reject;

/// Most windows in a frame (`MAX_BEAMS − 2`).
pub const MAX_WINDOWS: usize = MAX_BEAMS - 2;
/// Most segments kept per frame.
pub const MAX_SEGMENTS: usize = 64;
/// Most lines kept per frame.
pub const MAX_LINES: usize = 64;
/// Most corners kept per frame.
pub const MAX_CORNERS: usize = 63;

/// What a frame's run dropped, rejected or could not store. Nothing is lost
/// silently: every item that is not in [`Features`] is counted here.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Valid beams in the frame.
    pub valid_beams: u16,
    /// Windows that are invalid (an invalid beam or a prediction behind the sensor).
    pub invalid_windows: u16,
    /// Segments shorter than `min_points`.
    pub short_segments: u16,
    /// Segments beyond [`MAX_SEGMENTS`].
    pub segment_overflow: u16,
    /// Edge points beyond capacity (cannot happen with [`MAX_BEAMS`] slots; counted anyway).
    pub edge_overflow: u16,
    /// Segments whose fit failed (grazing incidence, singular).
    pub degenerate_fits: u16,
    /// Lines rejected for `chi2 > max_chi2`.
    pub rejected_chi2: u16,
    /// Lines rejected for `length < min_length`.
    pub rejected_short: u16,
    /// Pairs of lines merged into one.
    pub merges: u16,
    /// Lines beyond [`MAX_LINES`].
    pub line_overflow: u16,
    /// Close line pairs that are parallel (no finite intersection).
    pub degenerate_corners: u16,
    /// Corners beyond [`MAX_CORNERS`].
    pub corner_overflow: u16,
    /// Split before reject ([`crate::split`], off by default): segments
    /// split in two. Not carried by the `D0` telegram.
    pub splits: u16,
    /// Split before reject: halves dropped for fewer than `min_points` beams.
    pub split_short: u16,
    /// Split before reject: pieces dropped because they are still not one
    /// straight line (a circle explains them, or the depth is reached).
    pub split_rejected: u16,
}

/// The features of one frame.
#[derive(Clone, Debug, Default)]
pub struct Features {
    /// Segments that passed `min_points`, in scan order.
    pub segments: Vec<Segment, MAX_SEGMENTS>,
    /// Edge points: middle beams of breaking valid windows, ascending.
    pub edges: Vec<u16, MAX_BEAMS>,
    /// Accepted lines, in scan order.
    pub lines: Vec<Line, MAX_LINES>,
    /// Corners between consecutive lines, in scan order.
    pub corners: Vec<Corner, MAX_CORNERS>,
    /// Counters of everything dropped or rejected.
    pub stats: Stats,
}

/// All working memory of the pipeline, reused frame after frame.
pub struct Extractor {
    geometry: Option<Geometry>,
    len: usize,
    cos_phi: [f32; MAX_BEAMS],
    sin_phi: [f32; MAX_BEAMS],
    smoothed: [f32; MAX_BEAMS],
    window_ok: [bool; MAX_WINDOWS],
    mahalanobis: [f32; MAX_WINDOWS],
    features: Features,
}

impl Default for Extractor {
    fn default() -> Self {
        Self::new()
    }
}

impl Extractor {
    /// An extractor with empty buffers. `const`, so it can initialise a `static`.
    pub const fn new() -> Self {
        Extractor {
            geometry: None,
            len: 0,
            cos_phi: [0.0; MAX_BEAMS],
            sin_phi: [0.0; MAX_BEAMS],
            smoothed: [0.0; MAX_BEAMS],
            window_ok: [false; MAX_WINDOWS],
            mahalanobis: [0.0; MAX_WINDOWS],
            features: Features {
                segments: Vec::new(),
                edges: Vec::new(),
                lines: Vec::new(),
                corners: Vec::new(),
                stats: Stats {
                    valid_beams: 0,
                    invalid_windows: 0,
                    short_segments: 0,
                    segment_overflow: 0,
                    edge_overflow: 0,
                    degenerate_fits: 0,
                    rejected_chi2: 0,
                    rejected_short: 0,
                    merges: 0,
                    line_overflow: 0,
                    degenerate_corners: 0,
                    corner_overflow: 0,
                    splits: 0,
                    split_short: 0,
                    split_rejected: 0,
                },
            },
        }
    }

    /// Run the whole pipeline on `frame`; see [`Extractor::run_observed`].
    pub fn run(&mut self, frame: &Frame, params: &Params) -> Result<&Features, ParamError> {
        self.run_observed(frame, params, |_, _, _| {})
    }

    /// Run the pipeline, calling `after_pass(pass, d, ranges)` after every
    /// smoothing pass (`pass` counts from 1; `d` holds `D` of the `n − 2`
    /// windows of that pass, `+inf` where invalid; `ranges` the smoothed
    /// ranges after it, metres).
    pub fn run_observed<F>(
        &mut self,
        frame: &Frame,
        params: &Params,
        mut after_pass: F,
    ) -> Result<&Features, ParamError>
    where
        F: FnMut(u16, &[f32], &[f32]),
    {
        params.validate()?;
        // A frame never holds more than MAX_BEAMS beams; the `min`s make
        // that visible to the optimiser, so no slice below can panic.
        let n = frame.len().min(MAX_BEAMS);
        self.len = n;
        self.prepare_bearings(frame.geometry(), n);
        let windows = n.saturating_sub(2).min(MAX_WINDOWS);
        let beams = frame.beams();

        // §4–5: the scale space.
        for (s, &r) in self.smoothed.iter_mut().zip(frame.ranges()) {
            *s = r;
        }
        valid_windows(beams, &mut self.window_ok[..windows]);
        let filter = WindowFilter::new(frame.geometry().step, params.sigma, params.q);
        for pass in 1..=params.iterations {
            smoothing_pass(
                &filter,
                &self.window_ok[..windows],
                &mut self.smoothed[..n],
                &mut self.mahalanobis[..windows],
            );
            after_pass(pass, &self.mahalanobis[..windows], &self.smoothed[..n]);
        }

        // §6: segmentation on D of the last pass.
        let f = &mut self.features;
        f.lines.clear();
        f.corners.clear();
        let counts = segment(
            &self.mahalanobis[..windows],
            params.tau,
            params.min_points,
            &mut f.segments,
            &mut f.edges,
        );
        let mut stats = Stats {
            valid_beams: frame.valid_count() as u16,
            invalid_windows: self.mahalanobis[..windows]
                .iter()
                .filter(|d| !d.is_finite())
                .count() as u16,
            short_segments: counts.short_segments,
            segment_overflow: counts.segment_overflow,
            edge_overflow: counts.edge_overflow,
            ..Stats::default()
        };

        // §7: lines on the raw ranges.
        let bearings = Bearings {
            cos: &self.cos_phi[..n],
            sin: &self.sin_phi[..n],
        };
        let raw = frame.ranges();
        if params.split_depth > 0 {
            split_before_reject(bearings, raw, beams, params, &mut f.segments, &mut stats);
        }
        for k in 0..f.segments.len() {
            let (first, last) = fit_span(&f.segments, k, params.fit_shared_points);
            let line = match fit_line(bearings, raw, beams, first, last, params.sigma) {
                Ok(line) => line,
                Err(_) => {
                    stats.degenerate_fits = stats.degenerate_fits.saturating_add(1);
                    continue;
                }
            };
            if !(line.chi2 <= params.max_chi2) {
                stats.rejected_chi2 = stats.rejected_chi2.saturating_add(1);
                continue;
            }
            // Merge with the previous candidate where §7.6 allows it.
            if params.merge {
                if let Some(prev) = f.lines.last() {
                    if let Some(merged) = try_merge(bearings, raw, beams, prev, &line, params) {
                        stats.merges = stats.merges.saturating_add(1);
                        if let Some(slot) = f.lines.last_mut() {
                            *slot = merged;
                        }
                        continue;
                    }
                }
            }
            if f.lines.push(line).is_err() {
                stats.line_overflow = stats.line_overflow.saturating_add(1);
            }
        }
        // Length is judged after merging, so that a wall cut by a no-echo
        // beam is judged whole.
        let before = f.lines.len();
        f.lines.retain(|l| l.length() >= params.min_length);
        stats.rejected_short = (before - f.lines.len()) as u16;

        // §8: corners between consecutive lines with close facing endpoints.
        for (i, pair) in f.lines.windows(2).enumerate() {
            let (l1, l2) = (&pair[0], &pair[1]);
            let gap_x = l2.endpoints[0][0] - l1.endpoints[1][0];
            let gap_y = l2.endpoints[0][1] - l1.endpoints[1][1];
            if !(libm::sqrtf(gap_x * gap_x + gap_y * gap_y) < params.corner_gap) {
                continue;
            }
            match intersect(i as u8, l1, (i + 1) as u8, l2, params.min_corner_angle_deg) {
                Some(c) => {
                    if f.corners.push(c).is_err() {
                        stats.corner_overflow = stats.corner_overflow.saturating_add(1);
                    }
                }
                None => stats.degenerate_corners = stats.degenerate_corners.saturating_add(1),
            }
        }
        f.stats = stats;
        Ok(&self.features)
    }

    /// The features of the last run.
    pub fn features(&self) -> &Features {
        &self.features
    }

    /// Smoothed ranges of the last run (m; invalid beams keep their 0).
    pub fn smoothed(&self) -> &[f32] {
        self.smoothed.get(..self.len).unwrap_or_default()
    }

    /// `D` per window of the last pass of the last run (`+inf` where invalid).
    pub fn mahalanobis(&self) -> &[f32] {
        self.mahalanobis
            .get(..self.len.saturating_sub(2))
            .unwrap_or_default()
    }

    /// Fill the `cos phi_j`, `sin phi_j` tables if the geometry changed.
    fn prepare_bearings(&mut self, geometry: Geometry, n: usize) {
        if self.geometry == Some(geometry) {
            return;
        }
        for j in 0..MAX_BEAMS {
            let phi = geometry.bearing(j);
            self.cos_phi[j] = libm::cosf(phi);
            self.sin_phi[j] = libm::sinf(phi);
        }
        let _ = n;
        self.geometry = Some(geometry);
    }
}

/// The beams fitted for segment `k`: the whole segment (§7), or, with
/// `fit_shared_points == false`, without a first/last point it shares with
/// the neighbouring segment (a corner point lies on neither line exactly).
pub fn fit_span(segments: &[Segment], k: usize, fit_shared_points: bool) -> (u16, u16) {
    let Some(seg) = segments.get(k) else {
        return (0, 0);
    };
    if fit_shared_points {
        return (seg.first, seg.last);
    }
    let shares_first = k > 0 && segments.get(k - 1).is_some_and(|p| p.last == seg.first);
    let shares_last = segments.get(k + 1).is_some_and(|n| n.first == seg.last);
    (
        seg.first.saturating_add(u16::from(shares_first)),
        seg.last.saturating_sub(u16::from(shares_last)),
    )
}

/// §7.6: merge `prev` and `next` if only invalid beams (or at most
/// `merge_gap_beams` valid ones) lie between them, their parameters agree
/// within `merge_gate`, and the refit of the union passes `max_chi2`.
pub fn try_merge(
    bearings: Bearings<'_>,
    raw: &[f32],
    beams: &[Beam],
    prev: &Line,
    next: &Line,
    params: &Params,
) -> Option<Line> {
    let gap_start = prev.last as usize + 1;
    let gap_end = next.first as usize; // exclusive
    let valid_between = beams
        .get(gap_start..gap_end.max(gap_start))
        .map_or(0, |b| b.iter().filter(|b| b.is_valid()).count());
    if valid_between > params.merge_gap_beams as usize {
        return None;
    }
    if !(parameter_distance(prev, next)? < params.merge_gate) {
        return None;
    }
    let merged = fit_line(bearings, raw, beams, prev.first, next.last, params.sigma).ok()?;
    if merged.chi2 <= params.max_chi2 {
        Some(merged)
    } else {
        None
    }
}
