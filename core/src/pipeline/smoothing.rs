//! Smoothing passes in the modified scale space (ALGORITHM.md §4–5, paper eq. 11–12).
//!
//! One pass runs the window filter of [`crate::pipeline::ekf`] on every window
//! `i = 0 … n−3` (beams `i, i+1, i+2`) of the current ranges, weighs each
//! estimate by `w_i = exp(−D_i/2)`, and moves every valid point `j` to
//!
//! ```text
//! d'_j = (1 − Σ w_i/3)·d_j + Σ (w_i/3)·x⁺_i[j − i]      over i = j, j−1, j−2
//! ```
//!
//! The pass is Jacobi (every window sees the ranges of the previous pass),
//! computed in place: point `j` is written as soon as its last window `j`
//! is done, and no later window reads it. Only the three most recent window
//! estimates are kept, so a pass needs no storage beyond the ranges and `D`.

use crate::frame::Beam;
use crate::maths::Vec3;
use crate::pipeline::ekf::WindowFilter;

/// The smoothing weight `w = exp(−D/2)` of eq. 11 (0 for `D = +inf`).
#[inline]
pub fn weight(mahalanobis: f32) -> f32 {
    let x = -0.5 * mahalanobis;
    #[cfg(feature = "fast-math")]
    {
        if x == f32::NEG_INFINITY {
            return 0.0;
        }
        micromath::F32(x).exp().0
    }
    #[cfg(not(feature = "fast-math"))]
    {
        libm::expf(x)
    }
}

/// Whether each window `i` (beams `i, i+1, i+2`) has three valid beams
/// (§1); writes `beams.len() − 2` flags into `window_ok` (as many as fit).
pub fn valid_windows(beams: &[Beam], window_ok: &mut [bool]) {
    for (ok, b) in window_ok.iter_mut().zip(beams.windows(3)) {
        *ok = b[0].is_valid() && b[1].is_valid() && b[2].is_valid();
    }
}

/// Whether beam `beam` with range `d` (m) takes part in the pipeline: valid
/// and below `max_range` (ALGORITHM.md v2 §1; a range at or beyond it is a
/// fill value or an error code of another mode).
#[inline]
pub fn usable(beam: Beam, d: f32, max_range: f32) -> bool {
    beam.is_valid() && d < max_range
}

/// [`valid_windows`] with the range limit: a window needs three
/// [`usable`] beams.
pub fn usable_windows(beams: &[Beam], ranges: &[f32], max_range: f32, window_ok: &mut [bool]) {
    let ok = |j: usize| match (beams.get(j), ranges.get(j)) {
        (Some(&b), Some(&d)) => usable(b, d, max_range),
        _ => false,
    };
    for (i, w) in window_ok.iter_mut().enumerate() {
        *w = ok(i) && ok(i + 1) && ok(i + 2);
    }
}

/// Windows processed together: the filter runs branch-free over a block
/// (so a host CPU can vectorise it, with the same per-window IEEE
/// operations), then the block's points are blended. Stack use is a few
/// hundred bytes whatever the frame size.
const BLOCK: usize = 32;

/// Per-block working storage. Slots `0` and `1` of `third_weight` and
/// `posterior` carry the last two windows of the previous block.
struct Block {
    third_weight: [f32; BLOCK + 2],
    posterior: [[f32; BLOCK + 2]; 3],
}

/// Run one Jacobi smoothing pass in place.
///
/// - `window_ok`: for each of the `n − 2` windows, whether its three beams
///   are valid ([`valid_windows`]); invalid beams never take part in a window.
/// - `ranges`: the ranges of the previous pass (m), replaced by the new ones.
///   A point all of whose windows are invalid (in particular an invalid
///   beam) gets weight 0 from each and so keeps its value exactly.
/// - `mahalanobis`: receives `D_i` for the `n − 2` windows (`+inf` for
///   invalid windows).
///
/// Slices shorter than expected are handled by processing only the common
/// length; nothing panics.
///
/// In place is Jacobi here: the windows of a block read points `≥` the
/// block's first window, and only points of earlier windows have been written.
pub fn smoothing_pass(
    filter: &WindowFilter,
    window_ok: &[bool],
    ranges: &mut [f32],
    mahalanobis: &mut [f32],
) {
    let windows = window_ok
        .len()
        .min(mahalanobis.len())
        .min(ranges.len().saturating_sub(2));
    if windows == 0 {
        return;
    }
    let n = windows + 2;
    let mut block = Block {
        third_weight: [0.0; BLOCK + 2],
        posterior: [[0.0; BLOCK + 2]; 3],
    };
    let mut start = 0;
    while start < windows {
        let m = BLOCK.min(windows - start);
        let (Some(points), Some(ok), Some(d)) = (
            ranges.get(start..start + m + 2),
            window_ok.get(start..start + m),
            mahalanobis.get_mut(start..start + m),
        ) else {
            break; // not reached: `windows` fits all three slices
        };
        // The filter on every window of the block (§2–3).
        filter_block(filter, points, ok, &mut block, d);
        // Weights w/3 (eq. 11), in a separate loop: exp is not vectorisable.
        for (w, &d) in block.third_weight[2..].iter_mut().zip(d.iter()) {
            *w = if d < f32::INFINITY {
                weight(d) / 3.0
            } else {
                0.0
            };
        }
        // Blend the block's points (eq. 12): windows j, j−1, j−2 in that order.
        let Some(points) = ranges.get_mut(start..start + m) else {
            break; // not reached, as above
        };
        for (t, point) in points.iter_mut().enumerate() {
            *point = blend(&block, *point, t + 2);
        }
        // Carry the last two windows into slots 0 and 1.
        for slot in 0..2 {
            block.third_weight[slot] = block.third_weight[m + slot];
            for k in 0..3 {
                block.posterior[k][slot] = block.posterior[k][m + slot];
            }
        }
        start += m;
    }
    // Points n−2 and n−1 have no window starting at them. Slots 0 and 1
    // hold windows n−4 and n−3; slots 2 and 3 stand for absent windows.
    block.third_weight[2] = 0.0;
    block.third_weight[3] = 0.0;
    if let Some(point) = ranges.get_mut(n - 2) {
        *point = blend(&block, *point, 2);
    }
    if let Some(point) = ranges.get_mut(n - 1) {
        *point = blend(&block, *point, 3);
    }
}

/// Eq. 12 for one point whose window `j` sits in `slot` (`≥ 2`):
/// `(1 − Σ w/3)·d_j + Σ (w/3)·x⁺[j − i]` over windows `j`, `j − 1`, `j − 2`,
/// added in that order. Absent or invalid windows have weight 0 and estimate 0.
#[inline]
fn blend(block: &Block, d: f32, slot: usize) -> f32 {
    let w = &block.third_weight;
    let x = &block.posterior;
    let weight_sum = w[slot] + w[slot - 1] + w[slot - 2];
    let estimate_sum =
        w[slot] * x[0][slot] + w[slot - 1] * x[1][slot - 1] + w[slot - 2] * x[2][slot - 2];
    (1.0 - weight_sum) * d + estimate_sum
}

/// The window filter on `m` consecutive windows, `ranges` holding their
/// `m + 2` points. Writes `D` (or `+inf`) and the estimates (or 0) of
/// window `t` into `d[t]` and slot `t + 2` of the block.
///
/// Branch-free over the windows: every window is computed, invalid ones are
/// masked afterwards. The arithmetic per window is exactly that of
/// [`WindowFilter::update`].
#[inline]
fn filter_block(
    filter: &WindowFilter,
    ranges: &[f32],
    ok: &[bool],
    block: &mut Block,
    d: &mut [f32],
) {
    let m = d
        .len()
        .min(ok.len())
        .min(ranges.len().saturating_sub(2))
        .min(BLOCK);
    // Exactly the block's points: `t + 2 < m + 2` below needs no check.
    let Some(ranges) = ranges.get(..m + 2) else {
        return;
    };
    // A fixed-size copy of the flags keeps the loop free of bounds checks.
    let mut window_ok = [false; BLOCK];
    window_ok[..m].copy_from_slice(&ok[..m]);
    let post = &mut block.posterior;
    for t in 0..m {
        let z = Vec3([ranges[t], ranges[t + 1], ranges[t + 2]]);
        let (est, valid) = filter.update_unchecked(z);
        let keep = valid & window_ok[t];
        d[t] = if keep { est.mahalanobis } else { f32::INFINITY };
        post[0][t + 2] = if keep { est.posterior.0[0] } else { 0.0 };
        post[1][t + 2] = if keep { est.posterior.0[1] } else { 0.0 };
        post[2][t + 2] = if keep { est.posterior.0[2] } else { 0.0 };
    }
}
