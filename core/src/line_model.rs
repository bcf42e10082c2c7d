//! The three-point line model (ALGORITHM.md §2, paper eq. 6–8).
//!
//! Three rays at `phi − gamma`, `phi`, `phi + gamma` hit one straight line iff
//! `2·cos(gamma)/d_mid = 1/d_first + 1/d_last`. Each range of a window
//! `(a, b, c)` is predicted from the other two; with `k = 2·cos(gamma)`:
//!
//! ```text
//! f1 = b·c / (k·c − b)      f2 = k·a·c / (a + c)      f3 = a·b / (k·a − b)
//! ```
//!
//! (`f2` uses `a + c`: the paper's eq. 7 prints `a·c`, which is wrong.)

use crate::maths::Vec3;

/// The prediction `f(z)` of a window and its Jacobian `F = ∂f/∂(a, b, c)`.
///
/// `F` has a zero diagonal; its six other entries are stored by name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction {
    /// `(f1, f2, f3)` in metres.
    pub f: Vec3,
    /// `∂f1/∂b = k·c²/(k·c − b)²`.
    pub f12: f32,
    /// `∂f1/∂c = −b²/(k·c − b)²`.
    pub f13: f32,
    /// `∂f2/∂a = k·c²/(a + c)²`.
    pub f21: f32,
    /// `∂f2/∂c = k·a²/(a + c)²`.
    pub f23: f32,
    /// `∂f3/∂a = −b²/(k·a − b)²`.
    pub f31: f32,
    /// `∂f3/∂b = k·a²/(k·a − b)²`.
    pub f32_: f32,
}

/// Predict each range of the window `z = (a, b, c)` (metres) from the other
/// two, with `k = 2·cos(gamma)`.
///
/// Returns `None` for an invalid window: `k·c − b <= 0` or `k·a − b <= 0`
/// (a predicted point behind the sensor) or a result that is not finite.
/// The caller has already checked that all three beams are valid (> 0).
#[inline]
pub fn predict(z: Vec3, k: f32) -> Option<Prediction> {
    let [a, b, c] = z.0;
    let den1 = k * c - b; // eq. 6 denominator
    let den3 = k * a - b; // eq. 8 denominator
    if !(den1 > 0.0 && den3 > 0.0) {
        return None;
    }
    let den2 = a + c; // corrected eq. 7 denominator
    let f1 = b * c / den1;
    let f2 = k * a * c / den2;
    let f3 = a * b / den3;

    let den1_sq = den1 * den1;
    let den2_sq = den2 * den2;
    let den3_sq = den3 * den3;
    let p = Prediction {
        f: Vec3([f1, f2, f3]),
        f12: k * c * c / den1_sq,
        f13: -(b * b) / den1_sq,
        f21: k * c * c / den2_sq,
        f23: k * a * a / den2_sq,
        f31: -(b * b) / den3_sq,
        f32_: k * a * a / den3_sq,
    };
    let all_finite = f1.is_finite()
        && f2.is_finite()
        && f3.is_finite()
        && p.f12.is_finite()
        && p.f13.is_finite()
        && p.f21.is_finite()
        && p.f23.is_finite()
        && p.f31.is_finite()
        && p.f32_.is_finite();
    if all_finite {
        Some(p)
    } else {
        None
    }
}
