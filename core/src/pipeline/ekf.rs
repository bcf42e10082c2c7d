//! The per-window extended Kalman filter (ALGORITHM.md §3, paper eq. 5, 9, 10).
//!
//! State `x = (a, b, c)`, prior `x⁻ = z` with `P⁻ = R = sigma²·I`, process
//! noise `Q = q·I`, observation `H = I`:
//!
//! ```text
//! x̂ = f(z)             P̂ = sigma²·F·Fᵀ + q·I
//! v = z − x̂            S = P̂ + sigma²·I
//! D = vᵀ·S⁻¹·v         K = P̂·S⁻¹            x⁺ = x̂ + K·v
//! ```
//!
//! With `u = S⁻¹·v` (solved once, it serves `D = vᵀ·u` too), the update is
//! evaluated as `x⁺ = z − sigma²·u`, which equals `x̂ + K·v`:
//! `K·v = P̂·S⁻¹·v = (S − R)·S⁻¹·v = v − sigma²·u` and `x̂ + v = z`.

use crate::maths::{Sym3, Vec3};
use crate::pipeline::line_model::{predict_unchecked, Prediction};

/// Result of the filter on one valid window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowEstimate {
    /// Mahalanobis distance `D = vᵀ·S⁻¹·v` (dimensionless, ≥ 0).
    pub mahalanobis: f32,
    /// Updated estimates `x⁺` of the window's three ranges (metres).
    pub posterior: Vec3,
}

/// Constants of the filter for one frame and parameter set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowFilter {
    /// `k = 2·cos(gamma)`.
    pub k: f32,
    /// Measurement variance `sigma²` (m²).
    pub r: f32,
    /// Process noise `q` (m²).
    pub q: f32,
}

impl WindowFilter {
    /// The filter for beam step `gamma` (radians), range noise `sigma` (m)
    /// and process noise `q` (m²).
    pub fn new(gamma: f32, sigma: f32, q: f32) -> Self {
        WindowFilter {
            k: 2.0 * libm::cosf(gamma),
            r: sigma * sigma,
            q,
        }
    }

    /// `P̂ = sigma²·F·Fᵀ + q·I` for the zero-diagonal Jacobian of §2.
    ///
    /// With rows `(0, f12, f13)`, `(f21, 0, f23)`, `(f31, f32, 0)`:
    /// `(FFᵀ)11 = f12² + f13²`, `(FFᵀ)12 = f13·f23`, `(FFᵀ)13 = f12·f32`,
    /// `(FFᵀ)22 = f21² + f23²`, `(FFᵀ)23 = f21·f31`, `(FFᵀ)33 = f31² + f32²`.
    #[inline]
    pub fn predicted_covariance(&self, p: &Prediction) -> Sym3 {
        let r = self.r;
        Sym3 {
            s11: r * (p.f12 * p.f12 + p.f13 * p.f13) + self.q,
            s12: r * (p.f13 * p.f23),
            s13: r * (p.f12 * p.f32_),
            s22: r * (p.f21 * p.f21 + p.f23 * p.f23) + self.q,
            s23: r * (p.f21 * p.f31),
            s33: r * (p.f31 * p.f31 + p.f32_ * p.f32_) + self.q,
        }
    }

    /// Run the filter on the window `z = (a, b, c)` of valid ranges (metres).
    ///
    /// `None` means the window is invalid (§2: a prediction behind the
    /// sensor) or numerically degenerate; it then has `D = +inf`, weight 0.
    #[inline]
    pub fn update(&self, z: Vec3) -> Option<WindowEstimate> {
        match self.update_unchecked(z) {
            (est, true) => Some(est),
            _ => None,
        }
    }

    /// The filter without branches: always computes an estimate, and says
    /// whether it is valid (denominators of §2 positive, `det S > 0`, all
    /// results finite). Used by the smoothing pass so that a block of windows
    /// can be computed in lock-step; [`WindowFilter::update`] wraps it.
    #[inline(always)]
    pub fn update_unchecked(&self, z: Vec3) -> (WindowEstimate, bool) {
        let (pred, in_front) = predict_unchecked(z, self.k);
        let p_hat = self.predicted_covariance(&pred);
        let s = p_hat.add_diagonal(self.r);
        let v = z - pred.f;
        let (u, solvable) = s.solve_spd_unchecked(v); // S⁻¹·v
        let d = v.dot(u);
        // x⁺ = x̂ + K·v with K·v = P̂·S⁻¹·v = (S − R)·S⁻¹·v = v − sigma²·u,
        // so x⁺ = z − sigma²·u: the same quantity without the 3×3 product.
        let posterior = z - Vec3([self.r * u.0[0], self.r * u.0[1], self.r * u.0[2]]);
        let [x0, x1, x2] = posterior.0;
        // Overflow or NaN anywhere upstream propagates into the sum (a sum
        // that overflows marks the window invalid too: D or a range near
        // f32::MAX is no estimate).
        let finite = (d + x0 + x1 + x2).is_finite();
        // D is a quadratic form with S⁻¹ positive definite: clamp the
        // rounding of a near-zero result to 0.
        let mahalanobis = if d < 0.0 { 0.0 } else { d };
        (
            WindowEstimate {
                mahalanobis,
                posterior,
            },
            in_front & solvable & finite,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::line_model::predict;

    const GAMMA: f32 = 0.5 * core::f32::consts::PI / 180.0;

    #[test]
    fn collinear_window_has_tiny_distance_and_stays_put() {
        let filter = WindowFilter::new(GAMMA, 0.005, 0.0);
        let g = GAMMA as f64;
        let d = |p: f64| (2.0 / (p - 0.2f64).cos()) as f32;
        let z = Vec3([d(-g), d(0.0), d(g)]);
        let e = filter.update(z).unwrap();
        assert!(e.mahalanobis < 1e-3, "D = {}", e.mahalanobis);
        for i in 0..3 {
            assert!((e.posterior.0[i] - z.0[i]).abs() < 1e-5);
        }
    }

    #[test]
    fn corner_window_has_large_distance() {
        let filter = WindowFilter::new(GAMMA, 0.005, 0.0);
        // A 10 cm dent in the middle point.
        let e = filter.update(Vec3([2.0, 1.9, 2.0])).unwrap();
        assert!(e.mahalanobis > 100.0, "D = {}", e.mahalanobis);
    }

    #[test]
    fn distance_matches_the_textbook_formula() {
        // Independent check of D = vᵀ S⁻¹ v with S solved by Cramer's rule in f64.
        let (sigma, q) = (0.01f32, 1e-4f32);
        let filter = WindowFilter::new(GAMMA, sigma, q);
        let z = Vec3([3.0, 3.02, 3.01]);
        let p = predict(z, filter.k).unwrap();
        let fm = [
            [0.0, p.f12 as f64, p.f13 as f64],
            [p.f21 as f64, 0.0, p.f23 as f64],
            [p.f31 as f64, p.f32_ as f64, 0.0],
        ];
        let r = (sigma as f64).powi(2);
        let mut s = [[0.0f64; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] = r * (0..3).map(|k| fm[i][k] * fm[j][k]).sum::<f64>();
            }
            s[i][i] += q as f64 + r;
        }
        let v: Vec<f64> = (0..3).map(|i| (z.0[i] - p.f.0[i]) as f64).collect();
        let det3 = |m: [[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let det = det3(s);
        let mut u = [0.0; 3];
        for (col, ui) in u.iter_mut().enumerate() {
            let mut m = s;
            for row in 0..3 {
                m[row][col] = v[row];
            }
            *ui = det3(m) / det;
        }
        let d_ref: f64 = (0..3).map(|i| v[i] * u[i]).sum();
        let d = filter.update(z).unwrap().mahalanobis as f64;
        assert!(((d - d_ref) / d_ref).abs() < 1e-3, "{d} vs {d_ref}");
    }
}
