//! Experimental variants of the smoothing, for the report's findings only
//! (the core is not changed): the §4 pass written out again so that the
//! observation-weight rule, the window stride and the noise used for `D`
//! can be changed one at a time.
//!
//! With [`Rule::Spec`], stride 1 and no σ schedule, [`smooth`] is the core's
//! pass operation for operation (`WindowFilter::update`, `libm::expf`, the
//! §4 order of additions); a test checks it bit for bit against
//! `Extractor::run_observed`.

// `!(x < limit)` is deliberate, as in the core: NaN fails the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use lms_core::maths::Vec3;
use lms_core::pipeline::ekf::WindowFilter;
use lms_core::pipeline::smoothing::weight;
use lms_core::{Frame, Params};

use lms_core::unstable::fit_line;
use lms_core::Segment;

use crate::baselines::{features_from_segments, segments_of, Extraction, Tables};

/// How a point blends its observation with the windows' estimates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// ALGORITHM.md §4: each estimate weighs `w/3`, the observation the rest.
    Spec,
    /// Normalised: `(d + Σ w·x) / (1 + Σ w)` — the observation keeps weight 1.
    Normalised,
}

/// A variant of §4–6.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Blend rule.
    pub rule: Rule,
    /// Window stride `k`: windows are beams `(i, i+k, i+2k)` with angle `k·γ`.
    pub stride: usize,
    /// Fit the lines to the smoothed ranges instead of the raw ones.
    pub fit_smoothed: bool,
    /// Split before reject ([`split_before_reject`]): most levels of
    /// splitting (0 = off, the spec).
    pub split_depth: u8,
    /// Do not split a segment that a circle explains ([`circle_explains`]).
    pub arc_guard: bool,
    /// Drop a segment that still fails the χ² quantile test after splitting
    /// (a curved surface held back by the arc guard, or the depth limit),
    /// instead of leaving it to the looser `max_chi2` gate.
    pub reject_failing: bool,
    /// Drop lines whose reported standard deviation of α exceeds this
    /// (rad; 0 = off).
    pub max_sd_alpha: f32,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            rule: Rule::Spec,
            stride: 1,
            fit_smoothed: false,
            split_depth: 0,
            arc_guard: false,
            reject_failing: false,
            max_sd_alpha: 0.0,
        }
    }
}

/// Upper 0.1 % quantile of χ² with `nu` degrees of freedom
/// (Wilson–Hilferty; 1.8 % above the exact value at ν = 3, 0.6 % at ν = 10).
pub fn chi2_quantile_999(nu: f64) -> f64 {
    const Z: f64 = 3.090_232; // standard normal 99.9 %
    let a = 2.0 / (9.0 * nu);
    nu * (1.0 - a + Z * a.sqrt()).powi(3)
}

/// Whether a circle explains the valid points of `seg` within noise: the
/// algebraic (Kåsa) circle fit's `Σ(‖p − c‖ − R)²/σ²` is below the 99.9 %
/// quantile of χ²ₘ₋₃. A corner between two walls is not a circle; a curved
/// wall or a pillar is.
pub fn circle_explains(frame: &Frame, tables: &Tables, seg: Segment, params: &Params) -> bool {
    let r = frame.ranges();
    let beams = frame.beams();
    let pts: Vec<(f64, f64)> = (seg.first as usize..=seg.last as usize)
        .filter(|&j| beams[j].is_valid())
        .map(|j| {
            (
                f64::from(r[j] * tables.cos[j]),
                f64::from(r[j] * tables.sin[j]),
            )
        })
        .collect();
    let m = pts.len();
    if m < 5 {
        return false;
    }
    // Centre the points for conditioning, then solve the 3×3 normal
    // equations of x² + y² + D·x + E·y + F = 0.
    let (cx, cy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (cx, cy) = (cx / m as f64, cy / m as f64);
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for &(x, y) in &pts {
        let (x, y) = (x - cx, y - cy);
        let row = [x, y, 1.0];
        let rhs = -(x * x + y * y);
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += row[i] * row[j];
            }
            b[i] += row[i] * rhs;
        }
    }
    let Some([d, e, f]) = solve3(a, b) else {
        return false;
    };
    let (ox, oy) = (-d / 2.0, -e / 2.0);
    let rr = ox * ox + oy * oy - f;
    if !(rr > 0.0) {
        return false;
    }
    let radius = rr.sqrt();
    let var = f64::from(params.sigma).powi(2);
    let sum: f64 = pts
        .iter()
        .map(|&(x, y)| {
            let e = ((x - cx - ox).hypot(y - cy - oy) - radius).powi(2);
            e / var
        })
        .sum();
    sum < chi2_quantile_999((m - 3) as f64)
}

/// Solve a 3×3 linear system by Cramer's rule (`None` if singular).
pub(crate) fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if !(d.abs() > 1e-300) {
        return None;
    }
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut m = a;
        for row in 0..3 {
            m[row][c] = b[row];
        }
        *xc = det(m) / d;
    }
    Some(x)
}

/// Split before reject: a segment whose line fit on the raw ranges has
/// `Σe²/σ²` above the 99.9 % quantile of χ²ₘ₋₂ (it is not one straight
/// line) is split at the valid beam farthest from the chord of its first
/// and last valid points (one step of iterative end-point fit; the split
/// beam belongs to both halves, like §6's corner point), and the halves are
/// treated the same way, up to `depth` levels. Halves shorter than
/// `min_points` are dropped. A segment that passes, or cannot be split, is
/// kept as it is (the §7 gates then decide).
pub fn split_before_reject(
    frame: &Frame,
    tables: &Tables,
    segments: &[Segment],
    params: &Params,
    depth: u8,
    arc_guard: bool,
    reject_failing: bool,
) -> Vec<Segment> {
    let r = frame.ranges();
    let beams = frame.beams();
    let point = |j: usize| (r[j] * tables.cos[j], r[j] * tables.sin[j]);
    let mut out = Vec::new();
    for &seg in segments {
        // Depth-first, left half first.
        let mut stack = vec![(seg, 0u8)];
        while let Some((sg, level)) = stack.pop() {
            let line = fit_line(tables.core(), r, beams, sg, params.sigma);
            let fails = match line {
                Ok(l) => {
                    let dof = f64::from(l.points.saturating_sub(2)).max(1.0);
                    f64::from(l.chi2) * dof > chi2_quantile_999(dof)
                }
                Err(_) => true,
            };
            if !fails {
                out.push(sg);
                continue;
            }
            // Kept for the §7 gates, or dropped.
            let keep = |out: &mut Vec<Segment>| {
                if !reject_failing {
                    out.push(sg);
                }
            };
            if level >= depth || (arc_guard && circle_explains(frame, tables, sg, params)) {
                keep(&mut out);
                continue;
            }
            let valid: Vec<usize> = (sg.first as usize..=sg.last as usize)
                .filter(|&j| beams[j].is_valid())
                .collect();
            let (Some(&a), Some(&b)) = (valid.first(), valid.last()) else {
                keep(&mut out);
                continue;
            };
            let (pa, pb) = (point(a), point(b));
            let (ex, ey) = (pb.0 - pa.0, pb.1 - pa.1);
            let len = (ex * ex + ey * ey).sqrt();
            let far = valid[1..valid.len().saturating_sub(1)]
                .iter()
                .map(|&j| {
                    let p = point(j);
                    ((ex * (p.1 - pa.1) - ey * (p.0 - pa.0)).abs() / len, j)
                })
                .fold((0.0f32, usize::MAX), |m, x| if x.0 > m.0 { x } else { m });
            if far.1 == usize::MAX || !(len > 0.0) {
                keep(&mut out);
                continue;
            }
            let m = far.1 as u16;
            let right = Segment {
                first: m,
                last: sg.last,
            };
            let left = Segment {
                first: sg.first,
                last: m,
            };
            for half in [right, left] {
                if half.points() >= params.min_points as usize {
                    stack.push((half, level + 1));
                }
            }
        }
    }
    out
}

/// `params.iterations` passes of the variant on `frame`: the smoothed
/// ranges and `D` per window of the last pass. With stride `k`, window `i`
/// holds beams `i, i+k, i+2k` and is invalid if any beam of `i..=i+2k` is;
/// there are `n − 2k` windows.
pub fn smooth(frame: &Frame, params: &Params, opts: &Options) -> (Vec<f32>, Vec<f32>) {
    let k = opts.stride.max(1);
    let n = frame.len();
    let beams = frame.beams();
    let mut r = frame.ranges().to_vec();
    let windows = n.saturating_sub(2 * k);
    let ok: Vec<bool> = (0..windows)
        .map(|i| beams[i..=i + 2 * k].iter().all(|b| b.is_valid()))
        .collect();
    let filter = WindowFilter::new(k as f32 * frame.geometry().step, params.sigma, params.q);
    let mut d = vec![f32::INFINITY; windows];
    let mut w3 = vec![0.0f32; windows];
    let mut post = vec![[0.0f32; 3]; windows];
    for _ in 0..params.iterations {
        for i in 0..windows {
            let est = if ok[i] {
                filter.update(Vec3([r[i], r[i + k], r[i + 2 * k]]))
            } else {
                None
            };
            match est {
                Some(e) => {
                    d[i] = e.mahalanobis;
                    w3[i] = weight(e.mahalanobis) / 3.0;
                    post[i] = e.posterior.0;
                }
                None => {
                    d[i] = f32::INFINITY;
                    w3[i] = 0.0;
                    post[i] = [0.0; 3];
                }
            }
        }
        for (j, rj) in r.iter_mut().enumerate() {
            // Windows j, j−k, j−2k, in that order (§4).
            let mut ws = [0.0f32; 3];
            let mut xs = [0.0f32; 3];
            for (m, (wm, xm)) in ws.iter_mut().zip(xs.iter_mut()).enumerate() {
                if let Some(i) = j.checked_sub(m * k).filter(|&i| i < windows) {
                    *wm = w3[i];
                    *xm = post[i][m];
                }
            }
            *rj = match opts.rule {
                Rule::Spec => {
                    let weight_sum = ws[0] + ws[1] + ws[2];
                    let estimate_sum = ws[0] * xs[0] + ws[1] * xs[1] + ws[2] * xs[2];
                    (1.0 - weight_sum) * *rj + estimate_sum
                }
                Rule::Normalised => {
                    let (a, b, c) = (3.0 * ws[0], 3.0 * ws[1], 3.0 * ws[2]);
                    (*rj + a * xs[0] + b * xs[1] + c * xs[2]) / (1.0 + a + b + c)
                }
            };
        }
    }
    (r, d)
}

/// Segments of a stride-`k` `D` (§6 generalised: a run of non-breaking
/// windows `i..=m` covers beams `i..=m+2k`).
pub fn segments_strided(d: &[f32], params: &Params, k: usize) -> Vec<lms_core::Segment> {
    // `segments_of` covers i..=m+2: judge min_points on the widened run.
    let extra = 2 * (k.max(1) - 1);
    let loose = (*params).with_min_points(params.min_points.saturating_sub(extra as u16).max(1));
    let mut segs = segments_of(d, &loose);
    for s in &mut segs {
        s.last = s.last.saturating_add(extra as u16);
    }
    segs
}

/// The whole variant pipeline.
pub fn extract(frame: &Frame, tables: &Tables, params: &Params, opts: &Options) -> Extraction {
    let (smoothed, d) = smooth(frame, params, opts);
    let mut segments = segments_strided(&d, params, opts.stride);
    if opts.split_depth > 0 {
        segments = split_before_reject(
            frame,
            tables,
            &segments,
            params,
            opts.split_depth,
            opts.arc_guard,
            opts.reject_failing,
        );
    }
    let ranges = if opts.fit_smoothed {
        &smoothed[..]
    } else {
        frame.ranges()
    };
    let (mut lines, mut corners) = features_from_segments(frame, tables, ranges, &segments, params);
    if opts.max_sd_alpha > 0.0 {
        let limit = opts.max_sd_alpha * opts.max_sd_alpha;
        if lines.iter().any(|l| !(l.cov.a <= limit)) {
            lines.retain(|l| l.cov.a <= limit);
            corners = crate::baselines::corners_of(&lines, params);
        }
    }
    Extraction {
        segments,
        lines,
        corners,
    }
}
