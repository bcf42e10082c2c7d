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

use crate::features::MAX_WINDOWS;
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

/// Whether beam `beam` with range `d` (m) takes part in the pipeline: valid
/// and below `max_range` (ALGORITHM.md v2 §1; a range at or beyond it is a
/// fill value or an error code of another mode).
#[inline]
pub fn usable(beam: Beam, d: f32, max_range: f32) -> bool {
    beam.is_valid() && d < max_range
}

/// Words of a window bitset for [`MAX_WINDOWS`] windows: window `i` is bit
/// `i % 32` of word `i / 32` (one word per smoothing block).
pub const WINDOW_WORDS: usize = MAX_WINDOWS.div_ceil(BLOCK);

/// The windows of one smoothing pass: `count` windows of stride `stride`
/// (window `i` has beams `i, i+stride, i+2·stride`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Windows {
    /// Beams between a window's first and middle beam (1 or the turns).
    pub stride: usize,
    /// Number of windows.
    pub count: usize,
}

/// The usable windows of `windows` as a bitset: window `i` (beams
/// `i, i+stride, i+2·stride`) is set iff every beam of `i..=i + 2·stride`
/// is [`usable`], so that a segment (a run of windows) never spans an
/// unusable beam (§2; at stride 1, the window's three beams). Sets the bits
/// of the first `windows.count` windows (as many as `window_ok` holds) and
/// clears every other bit. One pass over the beams with the length of the
/// current run of usable beams.
pub fn usable_windows(
    beams: &[Beam],
    ranges: &[f32],
    max_range: f32,
    windows: Windows,
    window_ok: &mut [u32],
) {
    let Windows { stride, count } = windows;
    let windows = count.min(window_ok.len() * BLOCK);
    for w in window_ok.iter_mut() {
        *w = 0;
    }
    let ok = |j: usize| match (beams.get(j), ranges.get(j)) {
        (Some(&b), Some(&d)) => usable(b, d, max_range),
        _ => false,
    };
    // Beams from the last unusable one: a window is usable when the run of
    // usable beams ending at its last beam is 2·stride + 1 long.
    let span = 2 * stride + 1;
    let mut run = 0usize;
    for j in 0..windows + 2 * stride {
        run = if ok(j) { run + 1 } else { 0 };
        if let Some(i) = j.checked_sub(2 * stride) {
            if let Some(w) = window_ok.get_mut(i / BLOCK) {
                *w |= u32::from(run >= span) << (i % BLOCK);
            }
        }
    }
}

/// Where a pass puts `D` of its windows: block by block, in window order,
/// `d` holding `D` of windows `first..first + d.len()` (`+inf` where
/// invalid). The extractor segments the last pass's blocks as they come
/// (§6) and keeps no `D` of its own; a tool keeps them in a buffer (a
/// `&mut [f32]` is a sink that stores `D` of window `i` at index `i`).
pub trait WindowSink {
    /// `D` of windows `first..first + d.len()` of the pass.
    fn windows(&mut self, first: usize, d: &[f32]);
}

impl WindowSink for &mut [f32] {
    fn windows(&mut self, first: usize, d: &[f32]) {
        if let Some(out) = self.get_mut(first..) {
            for (x, &y) in out.iter_mut().zip(d) {
                *x = y;
            }
        }
    }
}

/// The sink that keeps nothing (every pass but the last).
impl WindowSink for () {
    fn windows(&mut self, _: usize, _: &[f32]) {}
}

/// Windows processed together: the filter runs branch-free over a block
/// (so a host CPU can vectorise it, with the same per-window IEEE
/// operations), then the block's points are blended. Stack use is a few
/// hundred bytes whatever the frame size.
const BLOCK: usize = 32;

/// The weights `w/3` (eq. 11) of windows with `D` in `d` (0 for `+inf`).
///
/// Kept out of line so that `expf` has a single call site, into which it is
/// inlined (docs/DESIGN.md, instructions per scan).
#[inline(never)]
fn third_weights(d: &[f32], third_weight: &mut [f32]) {
    for (w, &d) in third_weight.iter_mut().zip(d.iter()) {
        *w = if d < f32::INFINITY {
            weight(d) / 3.0
        } else {
            0.0
        };
    }
}

/// Largest window stride of [`smoothing_pass`] (the 0.25° modes'
/// four interleaved mirror turns).
pub const MAX_STRIDE: usize = 4;

/// Mirror turns interleaved at bearing step `step` (rad): 2 at 0.5°, 4 at
/// 0.25°, else 1 (no interleave to follow). The stride of same-turn windows
/// (`Params::same_turn_windows`) and the turns of `Params::per_turn`.
pub fn interleaved_turns(step: f32) -> usize {
    let turns = (core::f32::consts::PI / 180.0) / step + 0.5;
    if !(1.0..(MAX_STRIDE + 1) as f32).contains(&turns) {
        return 1;
    }
    match turns as usize {
        k @ (2 | 4) => k,
        _ => 1,
    }
}

/// Slots before a block's first window: the windows of the previous block
/// a point still needs (`2·stride` of them).
const CARRY: usize = 2 * MAX_STRIDE;

/// Per-block working storage. Slots `CARRY − 2·k .. CARRY` of
/// `third_weight` and `posterior` carry the last `2·k` windows of the
/// previous block.
struct Block {
    third_weight: [f32; BLOCK + CARRY],
    posterior: [[f32; BLOCK + CARRY]; 3],
}

/// Run one Jacobi smoothing pass in place, with windows of stride `k`.
///
/// Window `i` is beams `i, i+k, i+2k` (`filter` built for the angle `k·γ`);
/// point `j` is blended from windows `j, j−k, j−2k` in that order (eq. 12).
/// `k = 1` is §4's pass; `k = 2` and `4` are the same-turn windows of the
/// interleaved 0.5° and 0.25° modes (`Params::same_turn_windows`). `k` of 0
/// or above [`MAX_STRIDE`] does nothing.
///
/// - `window_ok`: the bitset of [`usable_windows`] for stride `k`; windows
///   whose beams are not all usable get `D = +inf` and weight 0, so a point
///   all of whose windows are unusable (an invalid beam in particular)
///   keeps its value exactly.
/// - `ranges`: the ranges of the previous pass (m), replaced by the new
///   ones; there are `n − 2k` windows.
/// - `sink`: receives `D_i` of the `n − 2k` windows block by block, in
///   order (`+inf` for unusable windows).
///
/// Slices shorter than expected are handled by processing only the common
/// length; nothing panics. In place is Jacobi here: the windows of a block
/// read points `≥` the block's first window, and only points of earlier
/// windows have been written.
// Never inlined, with `k` a run-time value: one copy for every stride in
// flash, and its block on the stack only while it runs.
#[inline(never)]
pub fn smoothing_pass(
    filter: &WindowFilter,
    k: usize,
    window_ok: &[u32],
    ranges: &mut [f32],
    sink: &mut dyn WindowSink,
) {
    if k == 0 || k > MAX_STRIDE {
        return;
    }
    let windows = (window_ok.len() * BLOCK).min(ranges.len().saturating_sub(2 * k));
    if windows == 0 {
        return;
    }
    let n = windows + 2 * k;
    let mut block = Block {
        third_weight: [0.0; BLOCK + CARRY],
        posterior: [[0.0; BLOCK + CARRY]; 3],
    };
    let mut d_block = [0.0f32; BLOCK];
    let mut start = 0;
    while start < windows {
        let m = BLOCK.min(windows - start);
        // `windows` is bounded by both slices, so every `get` below succeeds.
        debug_assert!(start + m + 2 * k <= ranges.len() && start / BLOCK < window_ok.len());
        let (Some(points), Some(&ok), Some(d)) = (
            ranges.get(start..start + m + 2 * k),
            window_ok.get(start / BLOCK),
            d_block.get_mut(..m),
        ) else {
            break;
        };
        // The filter on every window of the block (§2–3).
        filter_block(filter, k, points, ok, &mut block, d);
        // Weights w/3 (eq. 11), in a separate loop: exp is not vectorisable.
        third_weights(d, &mut block.third_weight[CARRY..]);
        sink.windows(start, d);
        // Blend the block's points (eq. 12): windows j, j−k, j−2k in that order.
        let Some(points) = ranges.get_mut(start..start + m) else {
            break;
        };
        for (t, point) in points.iter_mut().enumerate() {
            *point = blend(&block, k, *point, t + CARRY);
        }
        // Carry the last 2k windows into the slots before CARRY.
        for slot in CARRY - 2 * k..CARRY {
            block.third_weight[slot] = block.third_weight[m + slot];
            for row in &mut block.posterior {
                row[slot] = row[m + slot];
            }
        }
        start += m;
    }
    // Points n−2k … n−1 have no window starting at them. The slots before
    // CARRY hold windows n−4k … n−2k−1; the slots from CARRY on stand for
    // absent windows.
    for w in &mut block.third_weight[CARRY..CARRY + 2 * k] {
        *w = 0.0;
    }
    for t in 0..2 * k {
        if let Some(point) = ranges.get_mut(n - 2 * k + t) {
            *point = blend(&block, k, *point, CARRY + t);
        }
    }
}

/// Eq. 12 for one point whose window `j` sits in `slot` (`≥ 2k`):
/// `(1 − Σ w/3)·d_j + Σ (w/3)·x⁺[j − i]` over windows `j`, `j − k`,
/// `j − 2k`, added in that order. Absent or invalid windows have weight 0
/// and estimate 0.
#[inline]
fn blend(block: &Block, k: usize, d: f32, slot: usize) -> f32 {
    let w = &block.third_weight;
    let x = &block.posterior;
    let (s1, s2) = (slot - k, slot - 2 * k);
    let weight_sum = w[slot] + w[s1] + w[s2];
    let estimate_sum = w[slot] * x[0][slot] + w[s1] * x[1][s1] + w[s2] * x[2][s2];
    (1.0 - weight_sum) * d + estimate_sum
}

/// The window filter on `m` consecutive windows of stride `k`, `ranges`
/// holding their `m + 2k` points. Writes `D` (or `+inf`) and the estimates
/// (or 0) of window `t` into `d[t]` and slot `t + CARRY` of the block.
///
/// Branch-free over the windows: every window is computed, invalid ones are
/// masked afterwards. The arithmetic per window is exactly that of
/// [`WindowFilter::update`].
#[inline]
fn filter_block(
    filter: &WindowFilter,
    k: usize,
    ranges: &[f32],
    ok: u32,
    block: &mut Block,
    d: &mut [f32],
) {
    let m = d.len().min(ranges.len().saturating_sub(2 * k)).min(BLOCK);
    // Exactly the block's points: `t + 2k < m + 2k` below needs no check.
    let Some(ranges) = ranges.get(..m + 2 * k) else {
        return;
    };
    // The block's flags unpacked (bit t: window t): the loop stays free of
    // bounds checks.
    let mut window_ok = [false; BLOCK];
    for (t, w) in window_ok.iter_mut().enumerate() {
        *w = (ok >> t) & 1 != 0;
    }
    filter_windows(filter, k, ranges, &window_ok, block, d, m);
}

/// The loop of [`filter_block`]; the filter's grazing switch picks
/// the window's `R` (ALGORITHM.md §3, or with the grazing term of §10's
/// proposal, feature `section10`), a branch per window (only with the
/// grazing term built in, and
/// one loop instead of two keeps its flash small).
#[inline(always)]
fn filter_windows(
    filter: &WindowFilter,
    k: usize,
    ranges: &[f32],
    window_ok: &[bool; BLOCK],
    block: &mut Block,
    d: &mut [f32],
    m: usize,
) {
    let (Some(mids), Some(lasts), Some(d)) = (ranges.get(k..), ranges.get(2 * k..), d.get_mut(..m))
    else {
        return;
    };
    // Shifted iterators instead of indices: the loop has no bounds check
    // (the firmware's panic-proof build links only without one).
    let [post0, post1, post2] = &mut block.posterior;
    let posts = post0[CARRY..]
        .iter_mut()
        .zip(post1[CARRY..].iter_mut())
        .zip(post2[CARRY..].iter_mut());
    #[cfg(feature = "section10")]
    let grazing = filter.grazing_on();
    let windows = ranges.iter().zip(mids).zip(lasts).zip(window_ok);
    for ((((&a, &b), &c), &ok), (dt, ((p0, p1), p2))) in windows.zip(d.iter_mut().zip(posts)) {
        let z = Vec3([a, b, c]);
        #[cfg(feature = "section10")]
        let (est, valid) = if grazing {
            filter.update_grazing_unchecked(z)
        } else {
            filter.update_unchecked(z)
        };
        #[cfg(not(feature = "section10"))]
        let (est, valid) = filter.update_unchecked(z);
        let keep = valid & ok;
        *dt = if keep { est.mahalanobis } else { f32::INFINITY };
        *p0 = if keep { est.posterior.0[0] } else { 0.0 };
        *p1 = if keep { est.posterior.0[1] } else { 0.0 };
        *p2 = if keep { est.posterior.0[2] } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GAMMA: f32 = 0.5 * core::f32::consts::PI / 180.0;

    /// A wall at 1.5 m, normal at 20°, with a deterministic ±1 cm ripple.
    fn wall(n: usize) -> [f32; 41] {
        let mut r = [0.0f32; 41];
        for (j, x) in r.iter_mut().enumerate().take(n) {
            let phi = (j as f32 - 20.0) * GAMMA;
            let ripple = 0.01 * (((j * 7919) % 13) as f32 / 6.0 - 1.0);
            *x = 1.5 / libm::cosf(phi - 0.35) + ripple;
        }
        r
    }

    /// Eq. 11–12 written out window by window: every window of the
    /// previous ranges first (Jacobi), then each point blended from its
    /// windows `j, j−1, j−2` in that order, as §4 states it.
    fn spec_pass(filter: &WindowFilter, ranges: &mut [f32], d: &mut [f32]) {
        let n = ranges.len();
        let mut w3 = [0.0f32; 41];
        let mut x = [[0.0f32; 3]; 41];
        for i in 0..n - 2 {
            let z = Vec3([ranges[i], ranges[i + 1], ranges[i + 2]]);
            match filter.update(z) {
                Some(e) => {
                    d[i] = e.mahalanobis;
                    w3[i] = weight(e.mahalanobis) / 3.0;
                    x[i] = e.posterior.0;
                }
                None => d[i] = f32::INFINITY,
            }
        }
        for (j, point) in ranges.iter_mut().enumerate() {
            let window = |back: usize| match j.checked_sub(back) {
                Some(i) if i < n - 2 => (w3[i], x[i][back]),
                _ => (0.0, 0.0),
            };
            let ((w0, x0), (w1, x1), (w2, x2)) = (window(0), window(1), window(2));
            *point = (1.0 - (w0 + w1 + w2)) * *point + (w0 * x0 + w1 * x1 + w2 * x2);
        }
    }

    #[test]
    fn stride_one_is_the_spec_pass_bit_for_bit() {
        let n = 41;
        let filter = WindowFilter::new(GAMMA, 0.01, 0.0);
        let (mut a, mut b) = (wall(n), wall(n));
        let ok = [u32::MAX; 2]; // every window usable
        let (mut da, mut db) = ([0.0f32; 39], [0.0f32; 39]);
        spec_pass(&filter, &mut a[..n], &mut da);
        smoothing_pass(&filter, 1, &ok, &mut b[..n], &mut &mut db[..]);
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
        assert_eq!(da.map(f32::to_bits), db.map(f32::to_bits));
        assert!(
            a.iter().zip(&wall(n)).any(|(s, r)| s != r),
            "the pass moved no point"
        );
    }

    #[test]
    fn stride_two_is_two_independent_sub_scans_bit_for_bit() {
        let n = 41;
        let filter = WindowFilter::new(2.0 * GAMMA, 0.01, 0.0);
        let mut all = wall(n);
        let ok = [u32::MAX; 2]; // every window usable
        let mut d = [0.0f32; 39];
        smoothing_pass(&filter, 2, &ok, &mut all[..n], &mut &mut d[..]);
        // The same pass on the even and on the odd beams alone (stride 1).
        let raw = wall(n);
        for parity in 0..2 {
            let mut sub = [0.0f32; 21];
            let m = (n - parity).div_ceil(2);
            for (k, x) in sub.iter_mut().enumerate().take(m) {
                *x = raw[parity + 2 * k];
            }
            let mut sub_d = [0.0f32; 19];
            smoothing_pass(&filter, 1, &ok, &mut sub[..m], &mut &mut sub_d[..m - 2]);
            for k in 0..m {
                assert_eq!(
                    sub[k].to_bits(),
                    all[parity + 2 * k].to_bits(),
                    "beam {}",
                    parity + 2 * k
                );
            }
            for k in 0..m - 2 {
                assert_eq!(sub_d[k].to_bits(), d[parity + 2 * k].to_bits());
            }
        }
    }

    #[test]
    fn strided_windows_need_every_beam_of_their_span() {
        use crate::frame::{Frame, Invalid, Variant};
        let mut frame = Frame::for_variant(Variant::Fov180Res50);
        for j in 0..frame.len() {
            frame.set_metres(j, 2.0);
        }
        frame.set_invalid(10, Invalid::NoEcho);
        frame.set_metres(30, 90.0); // beyond max_range below
        let n = frame.len();
        let mut ok = [u32::MAX; WINDOW_WORDS];
        let windows = Windows {
            stride: 2,
            count: n - 2,
        };
        usable_windows(frame.beams(), frame.ranges(), 80.0, windows, &mut ok);
        for i in 0..WINDOW_WORDS * BLOCK {
            let w = (ok[i / BLOCK] >> (i % BLOCK)) & 1 != 0;
            let want = i + 4 < n && (i..=i + 4).all(|j| j != 10 && j != 30);
            assert_eq!(w, want, "window {i}");
        }
    }
}
