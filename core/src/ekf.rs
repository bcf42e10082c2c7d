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
//! `K·v` is evaluated as `P̂·(S⁻¹·v)`, which is the same product associated
//! so that `S⁻¹·v` serves both `D` and the update.

use crate::line_model::{predict, Prediction};
use crate::maths::{Sym3, Vec3};

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
        let pred = predict(z, self.k)?;
        let p_hat = self.predicted_covariance(&pred);
        let s = p_hat.add_diagonal(self.r);
        let s_inv = s.inverse_spd()?;
        let v = z.sub(pred.f);
        let u = s_inv.mul_vec(v); // S⁻¹·v
        let d = v.dot(u);
        let posterior = pred.f.add(p_hat.mul_vec(u)); // x̂ + P̂·S⁻¹·v
        if !(d.is_finite() && posterior.0.iter().all(|x| x.is_finite())) {
            return None;
        }
        // D is a quadratic form with S⁻¹ positive definite: clamp the
        // rounding of a near-zero result to 0.
        let mahalanobis = if d < 0.0 { 0.0 } else { d };
        Some(WindowEstimate {
            mahalanobis,
            posterior,
        })
    }
}
