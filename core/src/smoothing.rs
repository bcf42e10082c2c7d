//! Smoothing passes in the modified scale space (ALGORITHM.md §4–5, paper eq. 11–12).
//!
//! One pass runs the window filter of [`crate::ekf`] on every window
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

use crate::ekf::WindowFilter;
use crate::frame::Beam;
use crate::maths::Vec3;

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

/// A window's contribution to its points: weight `w/3` and its estimates.
#[derive(Clone, Copy, Debug, Default)]
struct Contribution {
    /// `w_i/3`, 0 for an invalid window.
    third_weight: f32,
    /// `x⁺_i`, meaningful only when `third_weight > 0` or the window is valid.
    posterior: Vec3,
    /// Whether the window is valid (has an estimate).
    valid: bool,
}

/// Run one Jacobi smoothing pass in place.
///
/// - `beams`: status of every beam (`len = n`); invalid beams are never
///   modified and never take part in a window.
/// - `ranges`: the ranges of the previous pass (m), replaced by the new ones.
/// - `mahalanobis`: receives `D_i` for the `n − 2` windows (`+inf` for
///   invalid windows); must hold at least `n − 2` values.
///
/// Slices shorter than expected are handled by processing only the common
/// length; nothing panics.
pub fn smoothing_pass(
    filter: &WindowFilter,
    beams: &[Beam],
    ranges: &mut [f32],
    mahalanobis: &mut [f32],
) {
    let n = beams
        .len()
        .min(ranges.len())
        .min(mahalanobis.len().saturating_add(2));
    if n < 3 {
        return;
    }
    let windows = n - 2;
    // Contributions of windows i−2, i−1, i (index by i mod 3).
    let mut ring = [Contribution::default(); 3];
    for i in 0..windows {
        let contribution = match (beams[i], beams[i + 1], beams[i + 2]) {
            (Beam::Valid, Beam::Valid, Beam::Valid) => {
                let z = Vec3([ranges[i], ranges[i + 1], ranges[i + 2]]);
                match filter.update(z) {
                    Some(est) => {
                        mahalanobis[i] = est.mahalanobis;
                        Contribution {
                            third_weight: weight(est.mahalanobis) / 3.0,
                            posterior: est.posterior,
                            valid: true,
                        }
                    }
                    None => {
                        mahalanobis[i] = f32::INFINITY;
                        Contribution::default()
                    }
                }
            }
            _ => {
                mahalanobis[i] = f32::INFINITY;
                Contribution::default()
            }
        };
        ring[i % 3] = contribution;
        // Point i now has all its windows (i, i−1, i−2): finalise it.
        blend_point(beams, ranges, &ring, i, windows);
    }
    // The last two points have no window starting at them.
    for j in windows..n {
        blend_point(beams, ranges, &ring, j, windows);
    }
}

/// Write the new range of point `j` from the windows `j, j−1, j−2` held in
/// the ring (eq. 12), in that order of addition.
#[inline]
fn blend_point(
    beams: &[Beam],
    ranges: &mut [f32],
    ring: &[Contribution; 3],
    j: usize,
    windows: usize,
) {
    if !beams[j].is_valid() {
        return;
    }
    let mut weight_sum = 0.0f32;
    let mut estimate_sum = 0.0f32;
    for back in 0..3usize {
        // Window i = j − back; its estimate of point j is component `back`.
        if back > j {
            break;
        }
        let i = j - back;
        if i >= windows {
            continue;
        }
        let c = &ring[i % 3];
        if c.valid {
            weight_sum += c.third_weight;
            estimate_sum += c.third_weight * c.posterior.0[back];
        }
    }
    ranges[j] = (1.0 - weight_sum) * ranges[j] + estimate_sum;
}
