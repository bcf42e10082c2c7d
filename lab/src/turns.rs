//! Per-turn extraction (issue 14, item 3; a lab prototype, not in the
//! core): in a mode that interleaves `k = 1°/γ` mirror turns (0.5°: 2,
//! 0.25°: 4), each turn's beams are a scan of their own at `k·γ`, run
//! through the core (ALGORITHM.md §2–8) as such; then the turns' lines of
//! one wall are fused.
//!
//! Why: the two turns of a 0.5° scan are 13.3 ms apart, so on a moving
//! platform their hits on one wall are two parallel point sets, δ ≈ 7–13 mm
//! apart normal to the wall ([`crate::sensorfit`]). The three-point windows
//! of §2 mix the turns and break along such walls; within one turn they do
//! not. Measured on the map truth of the four 0.5° shared logs (every 5th
//! frame, verified truth): one turn alone already beats the whole scan,
//! both turns fused beat both (`cargo run --release -p lms-lab --example
//! one_turn`; the report's real-scan tables).
//!
//! **Fusion.** Turn by turn, a line is paired with the already fused line
//! of the most overlapping beam range that agrees within the matching
//! gates of the evaluation (|Δα| < 3°, |Δr| < 0.1 m, [`FUSE_ALPHA_DEG`],
//! [`FUSE_R`]); a pair becomes one line: information-weighted `(α, r)`
//! (`Σ = (Σ₁⁻¹ + Σ₂⁻¹)⁻¹`), the union of the beam ranges, the sum of the
//! points, the larger χ², endpoints the outermost hits projected onto it.
//! A line no other turn pairs is kept as it is. Corners are not formed
//! (the prototype scores lines).

use lms_core::{Extractor, Frame, Geometry, Line, Params, Segment};

use crate::baselines::{run_core, Extraction};

/// Pairing gate on |Δα| (degrees).
pub const FUSE_ALPHA_DEG: f64 = 3.0;
/// Pairing gate on |Δr| (m).
pub const FUSE_R: f64 = 0.1;

/// Mirror turns interleaved in a scan of bearing step `step` (rad): 1 for
/// 1°, 2 for 0.5°, 4 for 0.25°.
pub fn turns_of(step: f32) -> usize {
    let k = (1f64.to_radians() / f64::from(step)).round();
    if k >= 2.0 {
        k as usize
    } else {
        1
    }
}

/// Turn `t` of `k` as a frame of its own, and the whole frame's beam index
/// of its beam `i`: `k·i + t`.
fn turn_frame(frame: &Frame, t: usize, k: usize) -> Option<Frame> {
    let g = frame.geometry();
    let n = (frame.len().saturating_sub(t)).div_ceil(k);
    let geometry = Geometry {
        first_bearing: g.first_bearing + t as f32 * g.step,
        step: k as f32 * g.step,
    };
    let mut f = Frame::new(geometry, n).ok()?;
    for i in 0..n {
        let j = k * i + t;
        if frame.beams()[j].is_valid() {
            f.set_metres(i, frame.ranges()[j]);
        }
    }
    Some(f)
}

/// The core's features of each turn, fused (see the module docs). With one
/// turn (1° modes) this is the core's result.
pub fn per_turn(ex: &mut Extractor, frame: &Frame, params: &Params) -> Extraction {
    let k = turns_of(frame.geometry().step);
    if k == 1 {
        return run_core(ex, frame, params);
    }
    let mut fused: Vec<Line> = Vec::new();
    let mut segments = Vec::new();
    for t in 0..k {
        let Some(f) = turn_frame(frame, t, k) else {
            continue;
        };
        let x = run_core(ex, &f, params);
        let whole = |i: u16| (k * usize::from(i) + t) as u16;
        segments.extend(x.segments.iter().map(|s| Segment {
            first: whole(s.first),
            last: whole(s.last),
        }));
        for l in &x.lines {
            let l = Line {
                first: whole(l.first),
                last: whole(l.last),
                ..*l
            };
            match partner(&fused, &l) {
                Some(i) => fused[i] = fuse(&fused[i], &l),
                None => fused.push(l),
            }
        }
    }
    fused.sort_by_key(|l| (l.first, l.last));
    segments.sort_by_key(|s| (s.first, s.last));
    Extraction {
        segments,
        lines: fused,
        corners: Vec::new(),
    }
}

fn overlap(a: &Line, b: &Line) -> i32 {
    i32::from(a.last.min(b.last)) - i32::from(a.first.max(b.first))
}

/// The fused line `l` pairs with, if any.
fn partner(fused: &[Line], l: &Line) -> Option<usize> {
    fused
        .iter()
        .enumerate()
        .filter(|(_, f)| {
            overlap(f, l) >= 0
                && lms_scene::wrap_angle(f64::from(f.alpha) - f64::from(l.alpha)).abs()
                    < FUSE_ALPHA_DEG.to_radians()
                && (f64::from(f.r) - f64::from(l.r)).abs() < FUSE_R
        })
        .max_by_key(|(_, f)| overlap(f, l))
        .map(|(i, _)| i)
}

/// Inverse of a 2×2 symmetric `[[a, b], [b, c]]`.
fn inv(a: f64, b: f64, c: f64) -> [f64; 3] {
    let det = a * c - b * b;
    [c / det, -b / det, a / det]
}

/// Two lines of one wall from different turns as one.
fn fuse(p: &Line, q: &Line) -> Line {
    let (pa, pr) = (f64::from(p.alpha), f64::from(p.r));
    let qa = pa + lms_scene::wrap_angle(f64::from(q.alpha) - pa);
    let qr = f64::from(q.r);
    let ip = inv(f64::from(p.cov.a), f64::from(p.cov.b), f64::from(p.cov.c));
    let iq = inv(f64::from(q.cov.a), f64::from(q.cov.b), f64::from(q.cov.c));
    let s = [ip[0] + iq[0], ip[1] + iq[1], ip[2] + iq[2]];
    let cov = inv(s[0], s[1], s[2]);
    let v0 = ip[0] * pa + ip[1] * pr + iq[0] * qa + iq[1] * qr;
    let v1 = ip[1] * pa + ip[2] * pr + iq[1] * qa + iq[2] * qr;
    let alpha = lms_scene::wrap_angle(cov[0] * v0 + cov[1] * v1);
    let r = cov[1] * v0 + cov[2] * v1;
    let (c, sn) = (alpha.cos(), alpha.sin());
    // Endpoints: the outermost of the four, projected onto the fused line.
    let project = |e: [f32; 2]| {
        let (x, y) = (f64::from(e[0]), f64::from(e[1]));
        let d = x * c + y * sn - r;
        [(x - d * c) as f32, (y - d * sn) as f32]
    };
    let first = if p.first <= q.first {
        p.endpoints[0]
    } else {
        q.endpoints[0]
    };
    let last = if p.last >= q.last {
        p.endpoints[1]
    } else {
        q.endpoints[1]
    };
    let mut l = *p;
    l.alpha = alpha as f32;
    l.r = r as f32;
    l.cov.a = cov[0] as f32;
    l.cov.b = cov[1] as f32;
    l.cov.c = cov[2] as f32;
    l.first = p.first.min(q.first);
    l.last = p.last.max(q.last);
    l.points = p.points.saturating_add(q.points);
    l.chi2 = p.chi2.max(q.chi2);
    l.endpoints = [project(first), project(last)];
    l
}
