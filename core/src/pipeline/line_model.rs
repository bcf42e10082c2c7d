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
/// (a predicted point behind the sensor). The caller has checked that all
/// three beams are valid (finite, > 0); a non-finite result from a
/// vanishing denominator is caught by the filter's final check.
#[inline]
pub fn predict(z: Vec3, k: f32) -> Option<Prediction> {
    match predict_unchecked(z, k) {
        (p, true) => Some(p),
        _ => None,
    }
}

/// [`predict`] without the branch: always computes, and returns whether
/// both denominators `k·c − b` and `k·a − b` are positive.
#[inline(always)]
pub fn predict_unchecked(z: Vec3, k: f32) -> (Prediction, bool) {
    let (p, [den1, den3]) = predict_with_denominators(z, k);
    (p, (den1 > 0.0) & (den3 > 0.0))
}

/// [`predict`] with no check: the prediction and the denominators
/// `[k·c − b, k·a − b]`, for the caller to judge.
#[inline(always)]
pub fn predict_with_denominators(z: Vec3, k: f32) -> (Prediction, [f32; 2]) {
    let [a, b, c] = z.0;
    let den1 = k * c - b; // eq. 6 denominator
    let den3 = k * a - b; // eq. 8 denominator
    let den2 = a + c; // corrected eq. 7 denominator
                      // One division per denominator; the Jacobian reuses the ratios:
                      // f1 = b·(c/den1), ∂f1/∂b = k·(c/den1)², ∂f1/∂c = −(b/den1)², etc.
    let inv1 = 1.0 / den1;
    let inv2 = 1.0 / den2;
    let inv3 = 1.0 / den3;
    let c1 = c * inv1;
    let b1 = b * inv1;
    let c2 = c * inv2;
    let a2 = a * inv2;
    let a3 = a * inv3;
    let b3 = b * inv3;
    (
        Prediction {
            f: Vec3([b * c1, k * a * c2, b * a3]),
            f12: k * c1 * c1,
            f13: -(b1 * b1),
            f21: k * c2 * c2,
            f23: k * a2 * a2,
            f31: -(b3 * b3),
            f32_: k * a3 * a3,
        },
        [den1, den3],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const GAMMA: f32 = 0.5 * core::f32::consts::PI / 180.0;

    /// Ranges of three beams at `phi − γ, phi, phi + γ` on the line `x cos α + y sin α = r`.
    fn on_line(alpha: f64, r: f64, phi: f64) -> Vec3 {
        let g = GAMMA as f64;
        let d = |p: f64| (r / (p - alpha).cos()) as f32;
        Vec3([d(phi - g), d(phi), d(phi + g)])
    }

    #[test]
    fn points_on_a_line_are_predicted_exactly() {
        let k = 2.0 * libm::cosf(GAMMA);
        for (alpha, r, phi) in [(0.3, 2.0, 0.1), (-1.2, 0.7, -0.9), (1.5, 5.0, 1.2)] {
            let z = on_line(alpha, r, phi);
            let p = predict(z, k).expect("valid window");
            for i in 0..3 {
                let rel = ((p.f.0[i] - z.0[i]) / z.0[i]).abs();
                assert!(rel < 2e-4, "component {i}: {} vs {}", p.f.0[i], z.0[i]);
            }
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let k = 2.0 * libm::cosf(GAMMA);
        let z = Vec3([2.00, 2.05, 2.12]);
        let p = predict(z, k).unwrap();
        // Central differences in f64 of the same formulas.
        let kd = k as f64;
        let f = |a: f64, b: f64, c: f64| {
            [
                b * c / (kd * c - b),
                kd * a * c / (a + c),
                a * b / (kd * a - b),
            ]
        };
        let (a, b, c) = (z.0[0] as f64, z.0[1] as f64, z.0[2] as f64);
        let h = 1e-6;
        let d = |i: usize, j: usize| {
            let mut lo = [a, b, c];
            let mut hi = [a, b, c];
            lo[j] -= h;
            hi[j] += h;
            (f(hi[0], hi[1], hi[2])[i] - f(lo[0], lo[1], lo[2])[i]) / (2.0 * h)
        };
        let pairs = [
            (p.f12, d(0, 1)),
            (p.f13, d(0, 2)),
            (p.f21, d(1, 0)),
            (p.f23, d(1, 2)),
            (p.f31, d(2, 0)),
            (p.f32_, d(2, 1)),
        ];
        for (got, want) in pairs {
            assert!(((got as f64 - want) / want).abs() < 1e-3, "{got} vs {want}");
        }
        for i in 0..3 {
            assert!(d(i, i).abs() < 1e-6, "diagonal of F must vanish");
        }
    }

    #[test]
    fn prediction_behind_the_sensor_invalidates_the_window() {
        let k = 2.0 * libm::cosf(GAMMA);
        // k·c − b <= 0: a middle range twice the outer one.
        assert!(predict(Vec3([1.0, 2.5, 1.0]), k).is_none());
    }
}
