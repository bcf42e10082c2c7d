//! The one owner of all working buffers: runs the whole pipeline on a frame.
//!
//! [`Extractor`] holds the smoothed ranges, the bearing tables, the
//! usable-window bitset and the output [`Features`] in fixed arrays, so it
//! can live in a `static` on the MCU. It keeps no `D`: the last pass hands
//! `D` of each block of windows to §6 segmentation as it computes it
//! ([`Segmenter`]). [`Extractor::run`] takes a [`Frame`] and validated
//! [`Params`] and fills the features; [`Extractor::run_traced`] also keeps
//! `D` of the last pass in a caller's [`Trace`], and
//! [`Extractor::run_observed`] hands `D` and the ranges to a callback after
//! every pass (the scale-space plots of paper Fig. 10).

use crate::features::{Features, Line, Stats, MAX_LINES, MAX_WINDOWS};
use crate::frame::{Frame, Geometry, MAX_BEAMS};
#[cfg(feature = "section10")]
use crate::params::GRAZING_MAX_INCIDENCE_DEG;
use crate::params::{Params, ValidParams};
use crate::pipeline::arcs::mark_arcs;
use crate::pipeline::bearings::TwoLevelBearings;
use crate::pipeline::corners::intersect;
use crate::pipeline::ekf::WindowFilter;
use crate::pipeline::line_fit::{
    fit_piece, refit_without_footprint, residual_sum, BearingTable, Holes, RawScan,
};
use crate::pipeline::merge::{fit_span, try_merge};
use crate::pipeline::segmentation::{EdgeList, Segmenter};
use crate::pipeline::smoothing::{
    interleaved_turns, smoothing_pass, usable, usable_windows, WindowSink, Windows, WINDOW_WORDS,
};
use crate::pipeline::split::split_before_reject;

/// All working memory of the pipeline, reused frame after frame.
pub struct Extractor {
    geometry: Option<Geometry>,
    len: usize,
    bearings: TwoLevelBearings,
    smoothed: [f32; MAX_BEAMS],
    /// Usable windows, a bitset ([`usable_windows`]).
    window_ok: [u32; WINDOW_WORDS],
    features: Features,
}

/// `D` per window kept by a caller ([`Extractor::run_traced`],
/// [`Extractor::run_observed`]): the extractor keeps no `D` of its own
/// (it segments the last pass's `D` as the pass computes it, §6), so the
/// plots and tools that show `D` (paper Fig. 10) hold it here.
#[derive(Clone, Debug)]
pub struct Trace {
    d: [f32; MAX_WINDOWS],
    len: usize,
}

impl Default for Trace {
    fn default() -> Self {
        Self::new()
    }
}

impl Trace {
    /// An empty trace.
    pub const fn new() -> Self {
        Trace {
            d: [0.0; MAX_WINDOWS],
            len: 0,
        }
    }

    /// `D` of the `n − 2` windows of the last pass traced (`+inf` where invalid).
    pub fn mahalanobis(&self) -> &[f32] {
        self.d.get(..self.len).unwrap_or_default()
    }
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
            bearings: TwoLevelBearings::new(),
            smoothed: [0.0; MAX_BEAMS],
            window_ok: [0; WINDOW_WORDS],
            features: Features::EMPTY,
        }
    }

    /// Run the whole pipeline on `frame`; see [`Extractor::run_observed`].
    ///
    /// Never inlined: its entry and return are where an instruction
    /// counter (tools/qemu-icount) measures exactly one frame's pipeline.
    #[inline(never)]
    pub fn run(&mut self, frame: &Frame, params: &ValidParams) -> &Features {
        self.run_with(frame, params, &mut [], |_, _, _| {})
    }

    /// [`Extractor::run`], keeping `D` of the last pass in `trace`.
    pub fn run_traced(
        &mut self,
        frame: &Frame,
        params: &ValidParams,
        trace: &mut Trace,
    ) -> &Features {
        self.run_observed(frame, params, trace, |_, _, _| {})
    }

    /// Run the pipeline, calling `after_pass(pass, d, ranges)` after every
    /// smoothing pass (`pass` counts from 1; `d` holds `D` of the `n − 2`
    /// windows of that pass, `+inf` where invalid, kept in `trace`;
    /// `ranges` the smoothed ranges after it, metres). `trace` holds `D`
    /// of the last pass afterwards.
    pub fn run_observed<F>(
        &mut self,
        frame: &Frame,
        params: &ValidParams,
        trace: &mut Trace,
        after_pass: F,
    ) -> &Features
    where
        F: FnMut(u16, &[f32], &[f32]),
    {
        trace.len = frame
            .len()
            .min(MAX_BEAMS)
            .saturating_sub(2)
            .min(MAX_WINDOWS);
        self.run_with(frame, params, &mut trace.d, after_pass)
    }

    /// The pipeline with `D` of every pass written into `trace` (as much
    /// of it as fits; `&mut []` keeps none).
    fn run_with<F>(
        &mut self,
        frame: &Frame,
        params: &ValidParams,
        trace: &mut [f32],
        mut after_pass: F,
    ) -> &Features
    where
        F: FnMut(u16, &[f32], &[f32]),
    {
        #[cfg(feature = "section10")]
        if self.run_interleaved(frame, params, trace, &mut after_pass) {
            return &self.features;
        }
        let params: &Params = params;
        // A frame never holds more than MAX_BEAMS beams; the `min`s make
        // that visible to the optimiser, so no slice below can panic.
        let n = frame.len().min(MAX_BEAMS);
        self.len = n;
        self.prepare_bearings(frame.geometry());
        let windows = n.saturating_sub(2).min(MAX_WINDOWS);
        let trace = trace.get_mut(..windows).unwrap_or_default();

        // §4–6: the passes, and segmentation on D of the last pass.
        let f = &mut self.features;
        f.lines.clear();
        f.corners.clear();
        let stride = window_stride(params, frame.geometry());
        let mut seg = Segmenter::new(
            stride,
            params.tau,
            params.min_points,
            &mut f.segments,
            &mut f.edges,
        );
        let space = ScaleSpace {
            smoothed: &mut self.smoothed[..n],
            window_ok: &mut self.window_ok,
        };
        space.run(frame, params, stride, trace, &mut seg, &mut after_pass);
        let counts = seg.finish(windows);
        let invalid_windows = seg.invalid_windows();
        let f = &mut self.features;
        let (usable_beams, beyond) = count_usable(frame, params.max_range);
        let mut stats = Stats {
            valid_beams: usable_beams,
            beyond_max_range: beyond,
            invalid_windows,
            short_segments: counts.short_segments,
            segment_overflow: counts.segment_overflow,
            edge_overflow: counts.edge_overflow,
            ..Stats::default()
        };

        // §7: lines on the raw ranges.
        let scan = RawScan {
            bearings: &self.bearings,
            ranges: frame.ranges(),
            beams: frame.beams(),
            max_range: params.max_range,
            footprint: params.footprint,
            turns: fit_turns(params, frame.geometry()),
        };
        if params.split_depth > 0 {
            split_before_reject(&scan, params, &mut f.segments, &mut stats);
        }
        fit_lines(f, &scan, params, &mut stats);

        // §8: corners between consecutive lines with close facing endpoints.
        find_corners(f, params, &mut stats);
        f.stats = stats;
        &self.features
    }

    /// [`Params::per_turn`] on a frame of interleaved mirror turns: §2–8 on
    /// each turn as a frame of its own, the turns' lines fused, corners (§8)
    /// on the fused lines ([`crate::pipeline::turns`]); `D` of each turn's
    /// last pass in `trace` at the whole scan's window of the same middle
    /// beam, `after_pass` once, after the last pass. `false` (nothing done)
    /// unless the option is on and the frame interleaves turns.
    #[cfg(feature = "section10")]
    fn run_interleaved<F>(
        &mut self,
        frame: &Frame,
        params: &ValidParams,
        trace: &mut [f32],
        after_pass: &mut F,
    ) -> bool
    where
        F: FnMut(u16, &[f32], &[f32]),
    {
        use crate::pipeline::turns::{turn_frame, Turn, TurnsMerged};
        if !params.per_turn {
            return false;
        }
        let k = interleaved_turns(frame.geometry().step);
        let inner = Params {
            per_turn: false,
            ..**params
        }
        .validate();
        let (true, Ok(inner)) = (k > 1, inner) else {
            return false;
        };
        let n = frame.len().min(MAX_BEAMS);
        let trace = trace.get_mut(..n.saturating_sub(2)).unwrap_or_default();
        trace.fill(f32::INFINITY);
        let mut merged = TurnsMerged::new(k);
        for t in 0..k {
            let Some(turn) = turn_frame(frame, Turn { index: t, of: k }) else {
                continue;
            };
            let mut turn_d = [f32::INFINITY; MAX_WINDOWS];
            let keep = if trace.is_empty() { 0 } else { MAX_WINDOWS };
            self.run_with(&turn, &inner, &mut turn_d[..keep], no_observer);
            merged.add_turn(t, &self.features, self.smoothed());
            merged.trace_turn(t, &turn_d[..keep.min(turn.len().saturating_sub(2))], trace);
        }
        let mut stats = merged.finish(&mut self.features, &mut self.smoothed[..n]);
        find_corners(&mut self.features, params, &mut stats);
        self.features.stats = stats;
        self.len = n;
        after_pass(params.iterations, trace, self.smoothed());
        true
    }

    /// The features of the last run.
    pub fn features(&self) -> &Features {
        &self.features
    }

    /// Smoothed ranges of the last run (m; invalid beams keep their 0).
    pub fn smoothed(&self) -> &[f32] {
        self.smoothed.get(..self.len).unwrap_or_default()
    }

    /// Fill the bearing table if the geometry changed.
    fn prepare_bearings(&mut self, geometry: Geometry) {
        if self.geometry == Some(geometry) {
            return;
        }
        self.bearings.fill(geometry);
        self.geometry = Some(geometry);
    }
}

/// An `after_pass` that observes nothing: one type, whatever the caller's
/// observer (a closure here would be a new type per instantiation, and
/// the per-turn run's recursion would never end).
#[cfg(feature = "section10")]
fn no_observer(_: u16, _: &[f32], _: &[f32]) {}

/// The buffers the smoothing passes work on (§4–5).
struct ScaleSpace<'a> {
    /// The frame's ranges, smoothed in place (`n` of them).
    smoothed: &'a mut [f32],
    /// Usable windows, a bitset ([`usable_windows`]).
    window_ok: &'a mut [u32; WINDOW_WORDS],
}

/// Where a pass's `D` goes: into the caller's trace (if any) and, on the
/// last pass, into §6 segmentation.
struct PassSink<'t, 's, 'a, const S: usize, L: EdgeList> {
    trace: &'t mut [f32],
    segmenter: Option<&'s mut Segmenter<'a, S, L>>,
}

impl<const S: usize, L: EdgeList> WindowSink for PassSink<'_, '_, '_, S, L> {
    fn windows(&mut self, first: usize, d: &[f32]) {
        (&mut *self.trace).windows(first, d);
        if let Some(seg) = self.segmenter.as_mut() {
            for (i, &x) in d.iter().enumerate() {
                seg.window(first + i, x);
            }
        }
    }
}

impl ScaleSpace<'_> {
    /// §4–5: `params.iterations` smoothing passes over the frame's ranges
    /// with windows of `stride`, `D` of each pass into `trace`, the last
    /// pass's into `seg` (§6), `after_pass` after each.
    fn run<F, const S: usize, L: EdgeList>(
        self,
        frame: &Frame,
        params: &Params,
        stride: usize,
        trace: &mut [f32],
        seg: &mut Segmenter<'_, S, L>,
        after_pass: &mut F,
    ) where
        F: FnMut(u16, &[f32], &[f32]),
    {
        for (s, &r) in self.smoothed.iter_mut().zip(frame.ranges()) {
            *s = r;
        }
        let windows = self.smoothed.len().saturating_sub(2);
        // Windows n − 2k … n − 3 do not exist at stride k (`+inf`).
        let computed = windows.saturating_sub(2 * stride - 2);
        for x in trace.iter_mut().skip(computed) {
            *x = f32::INFINITY;
        }
        usable_windows(
            frame.beams(),
            frame.ranges(),
            params.max_range,
            Windows {
                stride,
                count: windows,
            },
            &mut self.window_ok[..],
        );
        let filter = window_filter(params, stride as f32 * frame.geometry().step);
        for pass in 1..=params.iterations {
            let last = pass == params.iterations;
            let mut sink = PassSink {
                trace: &mut *trace,
                segmenter: if last { Some(&mut *seg) } else { None },
            };
            smoothing_pass(&filter, stride, self.window_ok, self.smoothed, &mut sink);
            after_pass(pass, trace, self.smoothed);
        }
        for i in computed..windows {
            seg.window(i, f32::INFINITY);
        }
    }
}

/// The window stride: the number of interleaved mirror turns (`1°/step`:
/// 2 at 0.5°, 4 at 0.25°, the LMS's interleaved modes) with
/// `Params::same_turn_windows` (the default), else 1. Other steps have no
/// interleave to follow.
fn window_stride(params: &Params, geometry: Geometry) -> usize {
    if !params.same_turn_windows {
        return 1;
    }
    interleaved_turns(geometry.step)
}

/// The window filter for windows `step` apart (rad): §3, with the §10
/// grazing term where `params` asks for it.
fn window_filter(params: &Params, step: f32) -> WindowFilter {
    let filter = WindowFilter::new(step, params.sigma, params.q);
    #[cfg(feature = "section10")]
    if params.grazing_noise > 0.0 {
        let t = GRAZING_MAX_INCIDENCE_DEG * (core::f32::consts::PI / 180.0);
        return filter.with_grazing(params.grazing_noise, t, step);
    }
    filter
}

/// Beams of `frame` that are valid and below `max_range`, and valid beams
/// at or beyond it (§1 v2), saturated to `u16`.
fn count_usable(frame: &Frame, max_range: f32) -> (u16, u16) {
    let (mut ok, mut beyond) = (0u16, 0u16);
    for (&b, &d) in frame.beams().iter().zip(frame.ranges()) {
        if usable(b, d, max_range) {
            ok = ok.saturating_add(1);
        } else if b.is_valid() {
            beyond = beyond.saturating_add(1);
        }
    }
    (ok, beyond)
}

/// The interleaved turns whose offsets the fits' χ² allows
/// ([`Params::turn_offsets`]): the scan's mirror turns (2 at 0.5°,
/// 4 at 0.25°), or 1 (§7 as written).
fn fit_turns(params: &Params, geometry: Geometry) -> u8 {
    if params.turn_offsets {
        interleaved_turns(geometry.step) as u8
    } else {
        1
    }
}

/// §7: a line per segment, χ²-gated, merged with its predecessor where §7.6
/// allows it, then judged on length (after merging, so that a wall cut by a
/// no-echo beam is judged whole).
fn fit_lines<B: BearingTable>(
    f: &mut Features,
    scan: &RawScan<'_, B>,
    params: &Params,
    stats: &mut Stats,
) {
    // The gaps the last line's merges left out of its fit (a few words).
    let mut holes = Holes::NONE;
    for k in 0..f.segments.len() {
        let span = fit_span(&f.segments, k, params.fit_shared_points);
        let line = match fit_piece(scan, span, params.line_sigma()) {
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
                if let Some(merged) = try_merge(scan, prev, &line, params, &mut holes) {
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
        } else {
            holes = Holes::NONE;
        }
    }
    // Too short, then (beyond ALGORITHM.md) too uncertain to be useful:
    // σ_α above the limit. One pass; a line counts for the first it fails.
    // Then the lines of arcs among those kept ([`crate::pipeline::arcs`]).
    let max_var = {
        let sd = params.max_alpha_sd_deg * (core::f32::consts::PI / 180.0);
        sd * sd
    };
    let (mut short, mut wide) = (0u16, 0u16);
    f.lines.retain(|l| {
        if !(l.length() >= params.min_length) {
            short += 1;
            false
        } else if !(l.cov.a <= max_var) {
            wide += 1;
            false
        } else {
            true
        }
    });
    stats.rejected_short = short;
    stats.rejected_wide = wide;
    // Beyond ALGORITHM.md too: the polylines of curves are no walls.
    let mut on_arc = [false; MAX_LINES];
    let arcs = mark_arcs(scan, &f.lines, params, &mut on_arc);
    if arcs > 0 {
        let mut on_arc = on_arc.iter();
        f.lines.retain(|_| !on_arc.next().copied().unwrap_or(false));
    }
    stats.rejected_arc = arcs;
    // Beyond ALGORITHM.md v2 too: each line's noise model (§7.9).
    if params.footprint_choice && scan.footprint > 0.0 {
        choose_noise_models(&mut f.lines, scan, params.line_sigma(), params.max_chi2);
    }
}

/// §7.9: each line refitted with every beam at `sigma` (no footprint
/// term, [`refit_without_footprint`]); the refit replaces it where it
/// passes `max_chi2` and the beams are likelier under that model:
/// `S_plain ≤ S + Λ`, `S` the [`residual_sum`]s, `Λ` the log of the
/// footprint model's variances over σ².
fn choose_noise_models<B: BearingTable>(
    lines: &mut [Line],
    scan: &RawScan<'_, B>,
    sigma: f32,
    max_chi2: f32,
) {
    for line in lines.iter_mut() {
        let Ok((plain, log_variances)) = refit_without_footprint(scan, line, sigma) else {
            continue;
        };
        if plain.chi2 <= max_chi2
            && residual_sum(&plain, scan.turns) <= residual_sum(line, scan.turns) + log_variances
        {
            *line = plain;
        }
    }
}

/// §8: a corner for each pair of consecutive lines whose facing endpoints are
/// closer than `corner_gap`; parallel pairs are counted, not reported.
fn find_corners(f: &mut Features, params: &Params, stats: &mut Stats) {
    for (i, pair) in f.lines.windows(2).enumerate() {
        let (l1, l2) = (&pair[0], &pair[1]);
        if !(l1.gap_to(l2) < params.corner_gap) {
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
}
