//! The core (`f32`, closed-form symmetric solve) agrees with the independent
//! `f64` reference (`workspace_tests::reference`, written from
//! `docs/ALGORITHM.md` v3) on random polygon scenes and on real CARMEN
//! scans:
//!
//! * §1–6 — the smoothed ranges and `D` after 1 and after 30 passes, and the
//!   segmentation wherever `D` is not within a hair of `tau`, in the v3
//!   default windows (one mirror turn: stride 2 at 0.5°, 4 at 0.25°, 1 at 1°)
//!   and, in the interleaved modes, also in the windows of consecutive
//!   beams (`same_turn_windows = false`, ALGORITHM.md v2 §2); beams at or
//!   beyond `max_range` take part in nothing;
//! * §7.1–7.5 — every line the core reports (in those runs, and in a run of
//!   the whole default pipeline: split before reject, merges, arcs) against
//!   the reference's footprint-weighted fit of the same usable beams, with
//!   the turns' offsets out of χ²: the number of points exactly, α, r, the
//!   covariance, χ² and the endpoints within named tolerances;
//! * §7.9 — where the core's line took the refit without the footprint
//!   term, that line against the reference's refit (one unweighted
//!   Gauss–Newton step from the reference's weighted fit); and the core's
//!   choice against the reference's likelihood ratio wherever that is not
//!   a near tie;
//! * §8 — a corner for exactly the consecutive pairs whose facing endpoints
//!   are closer than `corner_gap`, and each corner's position, covariance,
//!   angle and conditioning against the reference's intersection of the same
//!   two lines.
//!
//! Which segments split before reject cuts, which lines merge, which gaps
//! between merged lines their fit leaves out (`merge_own_beams`) and which
//! lines are dropped (χ², length, σ_α, arcs) the reference does not decide:
//! those decisions are the core's, and the lines they leave are checked
//! (a merged line against the reference's fit of its usable beams less the
//! gaps no piece covers that give the core's number of points).
//!
//! # Tolerances (measured first, then set with a margin of about 2–3)
//!
//! Both sides start from the same `f32` ranges (the reference widens them to
//! `f64` exactly), so the deviations measure only the core's `f32` rounding
//! (unit roundoff `ε ≈ 6e-8`), its own trigonometry and bearing table
//! (within 3 units of 2⁻²⁴), and how they accumulate over passes. The
//! measured maxima below are from 12 random scenes (6 780 windows,
//! 181/361/401 beams, noise 2–20 mm, 1 % no-echo beams, two with
//! `q = 1e-4`), 4 random scenes with the range limit at 9 m, 50 CSAIL frames
//! (35 900 windows in both window modes) and 50 Intel frames (8 900
//! windows); the test prints them (`cargo test -p workspace-tests --test
//! reference_agreement -- --nocapture`).
//!
//! * **Ranges**: `|d_core − d_ref| ≤ range_tol(passes) · max(1 m, d_ref)`,
//!   `range_tol(passes) = 4e-7 · passes`. A pass computes each new range as a
//!   weighted sum of the old range and three posteriors of the same size, so
//!   it adds a few `ε` of relative error; the pass is an averaging map, so
//!   earlier errors are not amplified, but they accumulate: between a random
//!   walk (√passes, 1.7e-7 → 8e-7 on a plain noisy wall) and linear growth
//!   (where the roundings keep their sign, e.g. near jumps of real scans), so
//!   the tolerance grows linearly with the passes.
//!   Measured: 2.0e-7 after 1 pass (≈ 3 ε; tolerance 4e-7), 3.6e-6 after 30
//!   passes (CSAIL frame 7; tolerance 1.2e-5), i.e. tens of µm at indoor
//!   ranges (the tolerance allows 1 mm at 82 m) — negligible against
//!   sigma = 5 mm. A genuine formula error fails by orders of magnitude:
//!   changing the weight to `exp(−0.45·D)` gives 7e-5 after one pass and
//!   6e-3 after 30.
//! * **D**: `|D_core − D_ref| ≤ d_tol(passes) · max(1, D_ref)` with
//!   `d_tol = 1e-3` after 1 pass and `1.5e-2` after 30. `D = vᵀS⁻¹v` depends on
//!   the innovation `v = z − f(z)`, a difference of ranges of size `d` that is
//!   itself only of size `sigma·√D`: a range error `δ` becomes an error of about
//!   `2√D·δ/sigma` in `D`, an amplification of `d/sigma` (400 at 2 m, 1.6e4 at
//!   80 m) of the relative range error. Measured: 4.5e-4 after 1 pass (at
//!   `D ≈ 1`) and 7.0e-3 after 30 passes (at `D ≈ 1.8`, where the 30-pass
//!   range drift above feeds the same amplification). Large `D` (corners,
//!   jumps) agree far better in the relative sense. The weight mutation above
//!   changes `D` by a factor of up to 5.
//! * **Segmentation**: a window may break on one side and not on the other
//!   only where `D_ref` lies within the `D` tolerance of `tau`,
//!   `|D_ref − tau| ≤ d_tol(passes) · tau` (9e-3 absolute after one pass,
//!   0.135 after 30): outside that band the `D` check above already decides
//!   both sides alike, and inside it `f32` rounding may legitimately decide
//!   either way. (Measured: 14 windows had `D_ref` within 1e-3 relative of
//!   `tau`; none broke differently.) Segments and edge points must then be
//!   equal exactly to the reference's v3 §6 segmentation of `D_ref` at the
//!   run's stride, with the core's decision taken for those borderline
//!   windows.
//! * Invalid windows (`+inf`) must be invalid on both sides; a window that
//!   is `+inf` on one side only fails.
//! * **Lines** (2 629): the points
//!   exactly; `|Δα| ≤ 1e-5` rad (measured 3.0e-6, a 6-beam CSAIL line);
//!   `|Δr| ≤ 1e-5 · max(1 m, r)` (4.0e-6); each covariance entry within
//!   5e-4 of `[αα, √(αα·rr), rr]` (the off-diagonal nearly cancels;
//!   measured 1.9e-4); `|Δχ²| ≤ 1e-3 · max(1, χ²)` (2.8e-4); endpoints
//!   within 1e-6 · max(1 m, |p|) (3.1e-7). The `f32` fit sums residuals of
//!   size σ computed from ranges of size `d`, and the bearing table is within
//!   3 units of 2⁻²⁴: short lines seen at an angle are the worst. A genuine
//!   error fails by orders of magnitude: the reference without the
//!   footprint weights is 1.1e-2 rad off in α and 110 off in the
//!   covariance; without the turns' offsets 0.98 off in χ².
//! * **Corners** (381): position within 5e-5 · max(1 m, |p|) (measured
//!   2.5e-5 on an Intel frame: the lines' own rounding, amplified by
//!   1/sin of the angle between them); each covariance
//!   entry within 3e-4 of `[xx, √(xx·yy), yy]` (1.1e-4); the angle within
//!   5e-5° (1.2e-5°); `well_conditioned` as the reference's angle says
//!   unless that angle is within the angle tolerance of the gate. The pairs
//!   with a corner: those whose facing endpoints (the core's, in `f64`) are
//!   closer than `corner_gap`, unless within 1e-6 of it.

use lms_core::test_support;
use lms_core::{Extractor, Features, Frame, Geometry, Invalid, Params};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use workspace_tests::reference::{self, FitSettings, RefGeometry, RefParams};
use workspace_tests::synth;

/// Relative tolerance on smoothed ranges after `passes` passes (see the module docs).
fn range_tol(passes: u16) -> f64 {
    4e-7 * passes as f64
}
/// Relative tolerance on `D` after `passes` passes (see the module docs).
fn d_tol(passes: u16) -> f64 {
    if passes <= 1 {
        1e-3
    } else {
        1.5e-2
    }
}

/// Line fits (§7.1–7.5; see the module docs): α (rad, absolute).
const LINE_ALPHA_TOL: f64 = 1e-5;
/// r (relative to max(1 m, r)).
const LINE_R_TOL: f64 = 1e-5;
/// Covariance, each entry relative to `[αα, √(αα·rr), rr]`.
const LINE_COV_TOL: f64 = 5e-4;
/// χ² per degree of freedom, relative to max(1, χ²).
const LINE_CHI2_TOL: f64 = 1e-3;
/// Endpoints (relative to max(1 m, |p|)).
const LINE_END_TOL: f64 = 1e-6;
/// Corners (§8; see the module docs): position (relative to max(1 m, |p|)).
const CORNER_POS_TOL: f64 = 5e-5;
/// Corner covariance, each entry relative to `[xx, √(xx·yy), yy]`.
const CORNER_COV_TOL: f64 = 3e-4;
/// Corner angle (degrees, absolute).
const CORNER_ANGLE_TOL: f64 = 5e-5;

/// Relative band about `tau` counted in the report (how often `D` comes
/// close to the gate at all).
const NEAR_TAU_REPORT: f64 = 1e-3;

/// One frame to compare.
struct Case {
    label: String,
    ranges: Vec<f32>,
    valid: Vec<bool>,
    first: f32,
    step: f32,
    params: Params,
}

/// Worst deviations of §2–6 seen, for the report.
#[derive(Default, Debug)]
struct WorstAt {
    range_rel: f64,
    range_where: String,
    d_rel: f64,
    d_where: String,
    windows: usize,
    near_tau: usize,
    differing_breaks: usize,
}

/// Worst deviations of §7–8 seen, for the report.
#[derive(Default, Debug)]
struct WorstFit {
    lines: usize,
    alpha: (f64, String),
    r: (f64, String),
    cov: (f64, String),
    chi2: (f64, String),
    end: (f64, String),
    corners: usize,
    corner_pos: (f64, String),
    corner_cov: (f64, String),
    corner_angle: (f64, String),
}

/// `x ≤ tol`, and false for NaN.
fn within(x: f64, tol: f64) -> bool {
    x <= tol
}

/// Keep the larger deviation `x` (seen at `at`) in `slot`.
fn note(slot: &mut (f64, String), x: f64, at: impl FnOnce() -> String) {
    if x > slot.0 || x.is_nan() {
        *slot = (x, at());
    }
}

/// Everything the comparisons of one test gathered.
#[derive(Default)]
struct Report {
    /// §2–6 after 1 and after 30 passes.
    passes: [WorstAt; 2],
    fits: WorstFit,
    failures: Vec<String>,
}

fn frame_of(case: &Case) -> Frame {
    let geometry = Geometry {
        first_bearing: case.first,
        step: case.step,
    };
    let mut frame = Frame::from_metres(geometry, &case.ranges).expect("frame");
    for (j, &v) in case.valid.iter().enumerate() {
        if !v {
            frame.set_invalid(j, Invalid::NoEcho);
        }
    }
    frame
}

fn ref_params(p: &Params) -> RefParams {
    RefParams {
        sigma: p.sigma as f64,
        q: p.q as f64,
        tau: p.tau as f64,
        min_points: p.min_points as usize,
        max_range: p.max_range as f64,
        footprint: p.footprint as f64,
        same_turn_windows: p.same_turn_windows,
        turn_offsets: p.turn_offsets,
    }
}

/// The window modes to compare a case in: the v3 default (windows of one
/// mirror turn in the interleaved modes) and, where that differs, the
/// windows of consecutive beams of ALGORITHM.md v2 §2.
fn window_modes(case: &Case) -> Vec<bool> {
    if reference::interleaved_turns(case.step as f64) > 1 {
        vec![true, false]
    } else {
        vec![true]
    }
}

/// Compare one frame: §2–6 at 1 and 30 passes in every window mode (with
/// the fits and corners of those runs), then the whole default pipeline.
fn compare(case: &Case, report: &mut Report) {
    let frame = frame_of(case);
    let raw: Vec<f64> = frame.ranges().iter().map(|&r| r as f64).collect();
    let valid: Vec<bool> = frame.beams().iter().map(|b| b.is_valid()).collect();
    for same_turn in window_modes(case) {
        let params = case.params.with_same_turn_windows(same_turn);
        let label = if same_turn {
            case.label.clone()
        } else {
            format!("{} (consecutive windows)", case.label)
        };
        compare_windows(case, &label, &frame, &raw, &valid, &params, report);
    }
    // The whole default pipeline (split before reject, merges, arcs): the
    // fit of every line it reports and the corner of every pair.
    let params = case.params.validate().expect("valid params");
    let mut ex = Extractor::new();
    ex.run(&frame, &params);
    let label = format!("{} defaults", case.label);
    check_fits(
        case,
        &label,
        (&frame, &raw, &valid),
        &case.params,
        ex.features(),
        report,
    );
}

/// §2–6 with the windows of `params` at 1 and 30 passes, and §7–8 of those
/// runs' lines.
fn compare_windows(
    case: &Case,
    label: &str,
    frame: &Frame,
    raw: &[f64],
    valid: &[bool],
    params: &Params,
    report: &mut Report,
) {
    let rp = ref_params(params);
    let usable = reference::usable(raw, valid, rp.max_range);
    let stride = reference::window_stride(case.step as f64, &rp);
    let ref_passes = reference::smooth(raw, valid, case.step as f64, &rp, 30);

    for (slot, passes) in [1u16, 30].into_iter().enumerate() {
        let range_tol = range_tol(passes);
        let d_tol = d_tol(passes);
        // §2–6 only: with split before reject (§7) the core's `segments()`
        // are the pieces it fits, not §6's segments; the split is checked
        // against the evaluation's f64 prototype instead
        // (lab/tests/split_before_reject.rs).
        let run = (*params).with_iterations(passes).with_split_depth(0);
        let mut ex = Extractor::new();
        let mut trace = lms_core::Trace::new();
        ex.run_traced(frame, &run.validate().expect("valid params"), &mut trace);
        let worst = &mut report.passes[slot];
        let failures = &mut report.failures;
        let (ref_ranges, ref_d) = &ref_passes[passes as usize - 1];
        let core_ranges = ex.smoothed();
        let core_d = trace.mahalanobis();
        let at = |what: &str, i: usize| format!("{label} pass {passes} {what} {i}");

        // Ranges: beams that take part in nothing untouched, the others
        // within range_tol.
        for j in 0..raw.len() {
            if !usable[j] {
                if core_ranges[j] != frame.ranges()[j] {
                    failures.push(format!("{}: unusable beam modified", at("beam", j)));
                }
                continue;
            }
            let rel = (core_ranges[j] as f64 - ref_ranges[j]).abs() / ref_ranges[j].abs().max(1.0);
            if rel > worst.range_rel {
                worst.range_rel = rel;
                worst.range_where = at("beam", j);
            }
            if rel.is_nan() || rel > range_tol {
                failures.push(format!(
                    "{}: range core {} ref {} (rel {rel:.2e})",
                    at("beam", j),
                    core_ranges[j],
                    ref_ranges[j]
                ));
            }
        }

        // D: both +inf, or close in the relative sense.
        if core_d.len() != ref_d.len() {
            failures.push(format!(
                "{label}: {} windows vs {}",
                core_d.len(),
                ref_d.len()
            ));
            continue;
        }
        let mut mixed_d = ref_d.clone();
        for (i, (&dc, &dr)) in core_d.iter().zip(ref_d).enumerate() {
            worst.windows += 1;
            let dc = dc as f64;
            match (dc.is_finite(), dr.is_finite()) {
                (false, false) => {
                    if !(dc == f64::INFINITY && dr == f64::INFINITY) {
                        failures.push(format!("{}: D core {dc} ref {dr}", at("window", i)));
                    }
                    continue;
                }
                (true, true) => {}
                _ => {
                    failures.push(format!(
                        "{}: D core {dc} ref {dr} (one invalid)",
                        at("window", i)
                    ));
                    continue;
                }
            }
            let rel = (dc - dr).abs() / dr.max(1.0);
            if rel > worst.d_rel {
                worst.d_rel = rel;
                worst.d_where = format!("{} (D_ref = {dr:.4})", at("window", i));
            }
            if rel.is_nan() || rel > d_tol {
                failures.push(format!(
                    "{}: D core {dc} ref {dr} (rel {rel:.2e})",
                    at("window", i)
                ));
            }
            if (dr - rp.tau).abs() <= NEAR_TAU_REPORT * rp.tau {
                worst.near_tau += 1;
            }
            if reference::breaks(dc, rp.tau) != reference::breaks(dr, rp.tau) {
                worst.differing_breaks += 1;
                // Take the core's decision for this borderline window.
                mixed_d[i] = dc;
                if (dr - rp.tau).abs().is_nan() || (dr - rp.tau).abs() > d_tol * rp.tau {
                    failures.push(format!(
                        "{}: breaks differ away from tau: D core {dc} ref {dr}",
                        at("window", i)
                    ));
                }
            }
        }

        // Segments and edges equal to the reference's, borderline windows
        // decided as the core decided them.
        {
            let (segs, edges) = reference::segment_strided(&mixed_d, stride, rp.tau, rp.min_points);
            let f = ex.features();
            let core_segs: Vec<(usize, usize)> = f
                .segments()
                .iter()
                .map(|s| (s.first as usize, s.last as usize))
                .collect();
            let ref_segs: Vec<(usize, usize)> = segs.iter().map(|s| (s.first, s.last)).collect();
            let core_edges: Vec<usize> = f.edges().iter().map(|e| e as usize).collect();
            if core_segs != ref_segs {
                failures.push(format!(
                    "{label} pass {passes}: segments core {core_segs:?} ref {ref_segs:?}"
                ));
            }
            if core_edges != edges {
                failures.push(format!(
                    "{label} pass {passes}: edges core {core_edges:?} ref {edges:?}"
                ));
            }
        }
        let fits_label = format!("{label} pass {passes}");
        check_fits(
            case,
            &fits_label,
            (frame, raw, valid),
            &run,
            ex.features(),
            report,
        );
    }
}

/// The reference's fit of the beams of `l`: its usable beams, less the
/// runs a merge left out (ALGORITHM.md §7.6 step 3, `merge_own_beams`).
/// Which runs a merge leaves out is the core's decision, like which lines
/// merge: the candidates are the runs of beams inside `l` that no fitted
/// piece covers ([`uncovered_runs`]), and the reference fits every subset
/// of at most `MAX_HOLES` of them that leaves the core's number of points, keeping the fit
/// nearest the core's line in units of the tolerances (the lines without
/// holes: the usable beams).
fn reference_fit(
    f: &Features,
    l: &lms_core::Line,
    raw: &[f64],
    usable: &[bool],
    geometry: RefGeometry,
    fit: FitSettings,
) -> Option<reference::RefLine> {
    let (first, last) = (l.first as usize, l.last as usize);
    let whole = reference::fit_line(raw, usable, geometry, first, last, fit);
    if whole
        .as_ref()
        .is_some_and(|rl| rl.points == l.points as usize)
    {
        return whole;
    }
    let runs = uncovered_runs(f, first, last);
    let mut best: Option<reference::RefLine> = None;
    // A merged line leaves out at most MAX_HOLES runs.
    let max_holes = lms_core::pipeline::line_fit::MAX_HOLES as u32;
    for subset in 1u32..(1 << runs.len().min(16)) {
        if subset.count_ones() > max_holes {
            continue;
        }
        let mut own = usable.to_vec();
        for (k, &(from, to)) in runs.iter().enumerate() {
            if subset & (1 << k) != 0 {
                own[from..=to].iter_mut().for_each(|u| *u = false);
            }
        }
        let Some(rl) = reference::fit_line(raw, &own, geometry, first, last, fit) else {
            continue;
        };
        // The deviation from the core's line in units of the tolerances.
        let off = |x: &reference::RefLine| {
            reference::wrap(l.alpha as f64 - x.alpha).abs() / LINE_ALPHA_TOL
                + (l.r as f64 - x.r).abs() / (LINE_R_TOL * x.r.max(1.0))
                + (l.chi2 as f64 - x.chi2).abs() / (LINE_CHI2_TOL * x.chi2.max(1.0))
        };
        if rl.points == l.points as usize && best.as_ref().is_none_or(|b| off(&rl) < off(b)) {
            best = Some(rl);
        }
    }
    best.or(whole)
}

/// The runs of beams strictly inside `first..=last` that no piece's fit
/// covers (a piece's fit leaves out a beam it shares with a neighbour):
/// where `D` broke a segment, or a corner beam.
fn uncovered_runs(f: &Features, first: usize, last: usize) -> Vec<(usize, usize)> {
    let segs = f.segments();
    let covered = |j: usize| {
        segs.iter().enumerate().any(|(k, s)| {
            let shares_first = k > 0 && segs[k - 1].last == s.first;
            let shares_last = segs.get(k + 1).is_some_and(|n| n.first == s.last);
            let lo = s.first as usize + usize::from(shares_first);
            let hi = (s.last as usize).saturating_sub(usize::from(shares_last));
            (lo..=hi).contains(&j)
        })
    };
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for j in first + 1..last {
        if covered(j) {
            continue;
        }
        match runs.last_mut() {
            Some(run) if run.1 + 1 == j => run.1 = j,
            _ => runs.push((j, j)),
        }
    }
    runs
}

/// §7.9: the reference's line for the core's line `l`, whose fit before
/// §7.9 was `weighted` (the reference's `rw`): the reference's refit
/// without the footprint term where the core took its refit, else `rw`.
/// Which lines take the refit is the core's decision (its f32 residual
/// sums against the reference's f64 ones); it must agree with the
/// reference's likelihood ratio wherever that is not a near tie.
fn noise_model(
    (l, weighted): (&lms_core::Line, &lms_core::Line),
    rw: reference::RefLine,
    (raw, usable, geometry): (&[f64], &[bool], RefGeometry),
    fit: FitSettings,
    max_chi2: f64,
) -> Result<reference::RefLine, String> {
    let span = (weighted.first as usize, weighted.last as usize);
    let refit =
        reference::refit_without_footprint(raw, usable, geometry, span, (rw.alpha, rw.r), fit);
    let took = l != weighted;
    let Some((plain, lambda)) = refit else {
        return if took {
            Err("took a refit the reference cannot make".into())
        } else {
            Ok(rw)
        };
    };
    let weighted_sum = reference::residual_sum(&rw, fit.turns);
    let margin = weighted_sum + lambda - reference::residual_sum(&plain, fit.turns);
    let takes = plain.chi2 <= max_chi2 && margin >= 0.0;
    let clear = margin.abs() > 1e-3 * weighted_sum.max(1.0)
        && (plain.chi2 - max_chi2).abs() > 1e-4 * max_chi2;
    if clear && takes != took {
        return Err(format!(
            "core took the refit: {took}, reference: {takes} (margin {margin:.3e}, χ² {:.4})",
            plain.chi2
        ));
    }
    Ok(if took { plain } else { rw })
}

/// §7.1–7.5, §7.9 and §8 of the core's features: every line against the
/// reference's fit of the same beams (with §7.9 on, the lines of the same
/// run without it give each line's fit before §7.9), every corner against
/// the reference's intersection of the same two lines, and the corners
/// where §8 puts them.
fn check_fits(
    case: &Case,
    label: &str,
    (frame, raw, valid): (&Frame, &[f64], &[bool]),
    params: &Params,
    f: &Features,
    report: &mut Report,
) {
    let rp = ref_params(params);
    let usable = reference::usable(raw, valid, rp.max_range);
    let geometry = RefGeometry {
        first: case.first as f64,
        step: case.step as f64,
    };
    let fit = FitSettings::of(&rp, case.step as f64);
    let choice = params.footprint_choice && params.footprint > 0.0;
    let weighted_run = choice.then(|| {
        let without = params.with_footprint_choice(false);
        let mut ex = Extractor::new();
        ex.run(frame, &without.validate().expect("valid params"));
        ex.features().clone()
    });
    let before = weighted_run.as_ref().unwrap_or(f);
    let worst = &mut report.fits;
    let failures = &mut report.failures;
    if before.lines().len() != f.lines().len() {
        failures.push(format!(
            "{label}: {} lines, {} without §7.9",
            f.lines().len(),
            before.lines().len()
        ));
        return;
    }
    for (k, (l, w)) in f.lines().iter().zip(before.lines()).enumerate() {
        worst.lines += 1;
        let at = || format!("{label} line {k} ({}..={})", l.first, l.last);
        let Some(rw) = reference_fit(before, w, raw, &usable, geometry, fit) else {
            failures.push(format!("{}: no reference fit", at()));
            continue;
        };
        let rl = if choice {
            let scan = (raw, &usable[..], geometry);
            match noise_model((l, w), rw, scan, fit, params.max_chi2 as f64) {
                Ok(rl) => rl,
                Err(why) => {
                    failures.push(format!("{}: §7.9: {why}", at()));
                    continue;
                }
            }
        } else {
            rw
        };
        if rl.points != l.points as usize {
            failures.push(format!(
                "{}: points core {} ref {}",
                at(),
                l.points,
                rl.points
            ));
        }
        let da = reference::wrap(l.alpha as f64 - rl.alpha).abs();
        note(&mut worst.alpha, da, at);
        if !within(da, LINE_ALPHA_TOL) {
            failures.push(format!(
                "{}: α core {} ref {} ({da:.2e})",
                at(),
                l.alpha,
                rl.alpha
            ));
        }
        let dr = (l.r as f64 - rl.r).abs() / rl.r.max(1.0);
        note(&mut worst.r, dr, at);
        if !within(dr, LINE_R_TOL) {
            failures.push(format!("{}: r core {} ref {} ({dr:.2e})", at(), l.r, rl.r));
        }
        let c = &rl.cov;
        let scale = [c[0][0], (c[0][0] * c[1][1]).sqrt(), c[1][1]];
        for (e, (&x, &y)) in [l.cov.a, l.cov.b, l.cov.c]
            .iter()
            .zip(&[c[0][0], c[0][1], c[1][1]])
            .enumerate()
        {
            let err = (x as f64 - y).abs() / scale[e];
            note(&mut worst.cov, err, at);
            if !within(err, LINE_COV_TOL) {
                failures.push(format!("{}: cov[{e}] core {x} ref {y} ({err:.2e})", at()));
            }
        }
        let dc = (l.chi2 as f64 - rl.chi2).abs() / rl.chi2.max(1.0);
        note(&mut worst.chi2, dc, at);
        if !within(dc, LINE_CHI2_TOL) {
            failures.push(format!(
                "{}: χ² core {} ref {} ({dc:.2e})",
                at(),
                l.chi2,
                rl.chi2
            ));
        }
        for (e, (p, q)) in l.endpoints.iter().zip(&rl.endpoints).enumerate() {
            let dist = (p[0] as f64 - q[0]).hypot(p[1] as f64 - q[1]);
            let rel = dist / q[0].hypot(q[1]).max(1.0);
            note(&mut worst.end, rel, at);
            if !within(rel, LINE_END_TOL) {
                failures.push(format!("{}: endpoint {e} core {p:?} ref {q:?}", at()));
            }
        }
    }
    // §8: every pair of consecutive lines whose facing endpoints are closer
    // than corner_gap (away from the border, in f64) has its corner, and no
    // other pair has one.
    let lines = f.lines();
    let as_ref = |l: &lms_core::Line| {
        let c = l.cov;
        let (a, b, cc) = (c.a as f64, c.b as f64, c.c as f64);
        (l.alpha as f64, l.r as f64, [[a, b], [b, cc]])
    };
    for (i, pair) in lines.windows(2).enumerate() {
        let (p, q) = (pair[0].endpoints[1], pair[1].endpoints[0]);
        let gap = (q[0] as f64 - p[0] as f64).hypot(q[1] as f64 - p[1] as f64);
        let found = f
            .corners()
            .iter()
            .any(|c| usize::from(c.line_a) == i && usize::from(c.line_b) == i + 1);
        let gate = params.corner_gap as f64;
        let borderline = (gap - gate).abs() <= 1e-6 * gate.max(1.0);
        if !borderline && found != (gap < gate) {
            failures.push(format!(
                "{label} lines {i}, {}: gap {gap} (corner_gap {gate}), corner {found}",
                i + 1
            ));
        }
    }
    for c in f.corners() {
        worst.corners += 1;
        let (a, b) = (usize::from(c.line_a), usize::from(c.line_b));
        let at = || format!("{label} corner of lines {a}, {b}");
        if b != a + 1 || b >= lines.len() {
            failures.push(format!("{}: not two consecutive lines", at()));
            continue;
        }
        let Some(rc) = reference::corner(as_ref(&lines[a]), as_ref(&lines[b])) else {
            failures.push(format!("{}: parallel in the reference", at()));
            continue;
        };
        let dist = (c.x as f64 - rc.x).hypot(c.y as f64 - rc.y) / rc.x.hypot(rc.y).max(1.0);
        note(&mut worst.corner_pos, dist, at);
        if !within(dist, CORNER_POS_TOL) {
            failures.push(format!(
                "{}: core ({}, {}) ref ({}, {})",
                at(),
                c.x,
                c.y,
                rc.x,
                rc.y
            ));
        }
        let v = &rc.cov;
        let scale = [v[0][0], (v[0][0] * v[1][1]).sqrt(), v[1][1]];
        for (e, (&x, &y)) in [c.cov.a, c.cov.b, c.cov.c]
            .iter()
            .zip(&[v[0][0], v[0][1], v[1][1]])
            .enumerate()
        {
            let err = (x as f64 - y).abs() / scale[e];
            note(&mut worst.corner_cov, err, at);
            if !within(err, CORNER_COV_TOL) {
                failures.push(format!("{}: cov[{e}] core {x} ref {y} ({err:.2e})", at()));
            }
        }
        let da = (c.angle_deg as f64 - rc.angle_deg).abs();
        note(&mut worst.corner_angle, da, at);
        if !within(da, CORNER_ANGLE_TOL) {
            failures.push(format!(
                "{}: angle core {} ref {}",
                at(),
                c.angle_deg,
                rc.angle_deg
            ));
        }
        let gate = params.min_corner_angle_deg as f64;
        if (rc.angle_deg - gate).abs() > CORNER_ANGLE_TOL
            && c.well_conditioned != (rc.angle_deg >= gate)
        {
            failures.push(format!(
                "{}: well_conditioned {} at {}°",
                at(),
                c.well_conditioned,
                rc.angle_deg
            ));
        }
    }
}

fn check_all(name: &str, cases: &[Case]) {
    let mut report = Report::default();
    for case in cases {
        compare(case, &mut report);
    }
    for (w, passes) in report.passes.iter().zip([1, 30]) {
        eprintln!(
            "{name}, {passes} pass(es): {} frames, {} windows; max range deviation {:.3e} rel ({}); \
             max D deviation {:.3e} rel ({}); {} windows within {NEAR_TAU_REPORT} of tau, {} with differing breaks",
            cases.len(),
            w.windows,
            w.range_rel,
            w.range_where,
            w.d_rel,
            w.d_where,
            w.near_tau,
            w.differing_breaks
        );
    }
    let w = &report.fits;
    eprintln!(
        "{name}, fits: {} lines; max |Δα| {:.3e} rad ({}); Δr {:.3e} rel ({}); cov {:.3e} ({}); \
         χ² {:.3e} ({}); endpoints {:.3e} rel ({})",
        w.lines,
        w.alpha.0,
        w.alpha.1,
        w.r.0,
        w.r.1,
        w.cov.0,
        w.cov.1,
        w.chi2.0,
        w.chi2.1,
        w.end.0,
        w.end.1
    );
    eprintln!(
        "{name}, corners: {}; max position {:.3e} rel ({}); cov {:.3e} ({}); angle {:.3e}° ({})",
        w.corners,
        w.corner_pos.0,
        w.corner_pos.1,
        w.corner_cov.0,
        w.corner_cov.1,
        w.corner_angle.0,
        w.corner_angle.1
    );
    let failures = &report.failures;
    assert!(
        failures.is_empty(),
        "{} disagreements, first ones:\n{}",
        failures.len(),
        failures
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// A random room's scan: `variant`, true noise `sigma_true`, 1 % sporadic
/// no-echo beams.
fn random_case(seed: u64, variant: lms_core::Variant, sigma_true: f64, params: Params) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(0xA5E0 + seed);
    let walls = synth::random_room(&mut rng);
    let g = variant.geometry();
    let truth = synth::true_ranges(
        &walls,
        g.first_bearing as f64,
        g.step as f64,
        variant.beams(),
    );
    let (ranges, valid) = synth::noisy_scan(&truth, sigma_true, 0.01, &mut rng);
    Case {
        label: format!("seed {seed} ({variant:?}, noise {sigma_true})"),
        ranges,
        valid,
        first: g.first_bearing,
        step: g.step,
        params,
    }
}

/// Random rooms with a box, several LMS variants, noise levels and seeds,
/// 1 % sporadic no-echo beams; two of the parameter sets use `q > 0`.
#[test]
fn random_scenes_agree_with_the_f64_reference() {
    use lms_core::Variant;
    let variants = [
        Variant::Fov180Res50,
        Variant::Fov180Res100,
        Variant::Fov100Res25,
    ];
    let cases: Vec<Case> = (0..12u64)
        .map(|seed| {
            let variant = variants[seed as usize % variants.len()];
            // Noise at, below and above the filter's sigma.
            let sigma_true = [0.005, 0.002, 0.01, 0.02][seed as usize % 4];
            let params = Params::default().with_q(if seed % 6 == 5 { 1e-4 } else { 0.0 });
            random_case(seed, variant, sigma_true, params)
        })
        .collect();
    check_all("random scenes", &cases);
}

/// Random rooms (walls 1–15 m away) with the range limit at 9 m: the beams
/// beyond it take part in no window and no fit (v3 §1), in every mode.
#[test]
fn beams_beyond_the_range_limit_agree_with_the_f64_reference() {
    use lms_core::Variant;
    let variants = [
        Variant::Fov180Res50,
        Variant::Fov100Res25,
        Variant::Fov180Res100,
        Variant::Fov100Res50,
    ];
    let cases: Vec<Case> = (12..16u64)
        .map(|seed| {
            let params = Params::default().with_max_range(9.0).with_sigma(0.01);
            random_case(seed, variants[seed as usize % 4], 0.01, params)
        })
        .collect();
    let beyond: usize = cases
        .iter()
        .map(|c| {
            c.ranges
                .iter()
                .zip(&c.valid)
                .filter(|&(&d, &v)| v && d >= 9.0)
                .count()
        })
        .sum();
    assert!(beyond > 100, "only {beyond} beams beyond the limit");
    check_all("range limit", &cases);
}

fn real_cases(stem: &str, frames: usize) -> Vec<Case> {
    test_support::load_frames(stem, frames)
        .into_iter()
        .enumerate()
        .map(|(k, frame)| {
            let g = frame.geometry();
            Case {
                label: format!("{stem} frame {k}"),
                ranges: frame.ranges().to_vec(),
                valid: frame.beams().iter().map(|b| b.is_valid()).collect(),
                first: g.first_bearing,
                step: g.step,
                params: Params::default(),
            }
        })
        .collect()
}

/// The first 50 frames of the CSAIL log (361 beams, 0.5°).
#[test]
fn csail_frames_agree_with_the_f64_reference() {
    let cases = real_cases("csail-corrected", 50);
    assert_eq!(cases.len(), 50);
    assert!(cases.iter().all(|c| c.ranges.len() == 361));
    check_all("csail", &cases);
}

/// The first 50 frames of the Intel log (180 beams, 1°).
#[test]
fn intel_frames_agree_with_the_f64_reference() {
    let cases = real_cases("intel-corrected", 50);
    assert_eq!(cases.len(), 50);
    assert!(cases.iter().all(|c| c.ranges.len() == 180));
    check_all("intel", &cases);
}
