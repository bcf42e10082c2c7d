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
//!
//! `S` is solved scaled by `1/sigma²`: `M = S/sigma² = F·Fᵀ + (1 + q/sigma²)·I`
//! and `w = M⁻¹·v = sigma²·u`, so `x⁺ = z − w` and `D = vᵀ·w / sigma²`. The
//! same quantities without the nine products by `sigma²` a window.

use crate::maths::{cos_sin, Sym3, Vec3};
#[cfg(feature = "section10")]
use crate::pipeline::line_model::predict_unchecked;
use crate::pipeline::line_model::{predict_with_denominators, Prediction};

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
    /// `ρ²` of the grazing term (`Params::grazing_noise`; 0: off).
    #[cfg(feature = "section10")]
    pub grazing: f32,
    /// `(t·γ)²`, `t` the tangent of the largest incidence the grazing
    /// term follows (`params::GRAZING_MAX_INCIDENCE_DEG`).
    #[cfg(feature = "section10")]
    pub grazing_cap: f32,
    /// `1 + q/sigma²`: the diagonal added to `F·Fᵀ` in `S/sigma²`.
    diagonal: f32,
}

impl WindowFilter {
    /// The filter for beam step `gamma` (radians), range noise `sigma` (m)
    /// and process noise `q` (m²).
    pub fn new(gamma: f32, sigma: f32, q: f32) -> Self {
        let r = sigma * sigma;
        WindowFilter {
            k: 2.0 * cos_sin(gamma).0,
            r,
            q,
            #[cfg(feature = "section10")]
            grazing: 0.0,
            #[cfg(feature = "section10")]
            grazing_cap: 0.0,
            diagonal: 1.0 + q / r,
        }
    }

    #[cfg(feature = "section10")]
    /// This filter with the grazing-incidence term (ALGORITHM.md §10
    /// proposal): `rho` dimensionless, `max_incidence` (rad) the largest
    /// incidence it follows, `gamma` the beam step (rad).
    pub fn with_grazing(self, rho: f32, max_incidence: f32, gamma: f32) -> Self {
        let t = libm::tanf(max_incidence) * gamma;
        WindowFilter {
            grazing: rho * rho,
            grazing_cap: t * t,
            ..self
        }
    }

    #[cfg(feature = "section10")]
    /// Whether the grazing term is on.
    #[inline]
    pub fn grazing_on(&self) -> bool {
        self.grazing > 0.0
    }

    #[cfg(feature = "section10")]
    /// The window's measurement variance with the grazing term (m²):
    /// `sigma² + ρ²·min(h², (t·γ·b)²)`, `h = (c − a)/2` the range step per
    /// beam (`b·γ·tan β` on a wall at incidence `β`).
    #[inline(always)]
    pub fn grazing_variance(&self, z: Vec3) -> f32 {
        let [a, b, c] = z.0;
        let h = 0.5 * (c - a);
        let h2 = h * h;
        let cap = self.grazing_cap * (b * b);
        let e = if h2 < cap { h2 } else { cap };
        self.r + self.grazing * e
    }

    /// `P̂ = sigma²·F·Fᵀ + q·I` for the zero-diagonal Jacobian of §2.
    ///
    /// With rows `(0, f12, f13)`, `(f21, 0, f23)`, `(f31, f32, 0)`:
    /// `(FFᵀ)11 = f12² + f13²`, `(FFᵀ)12 = f13·f23`, `(FFᵀ)13 = f12·f32`,
    /// `(FFᵀ)22 = f21² + f23²`, `(FFᵀ)23 = f21·f31`, `(FFᵀ)33 = f31² + f32²`.
    #[inline]
    pub fn predicted_covariance(&self, p: &Prediction) -> Sym3 {
        self.predicted_covariance_with(p, self.r)
    }

    /// [`WindowFilter::predicted_covariance`] with the window's own
    /// measurement variance `r` (m²).
    #[inline(always)]
    fn predicted_covariance_with(&self, p: &Prediction, r: f32) -> Sym3 {
        Sym3 {
            s11: r * (p.f12 * p.f12 + p.f13 * p.f13) + self.q,
            s12: r * (p.f13 * p.f23),
            s13: r * (p.f12 * p.f32_),
            s22: r * (p.f21 * p.f21 + p.f23 * p.f23) + self.q,
            s23: r * (p.f21 * p.f31),
            s33: r * (p.f31 * p.f31 + p.f32_ * p.f32_) + self.q,
        }
    }

    /// `M = S/sigma² = F·Fᵀ + (1 + q/sigma²)·I` (the products of
    /// [`WindowFilter::predicted_covariance`] without the factor `sigma²`).
    #[inline]
    pub fn scaled_innovation_covariance(&self, p: &Prediction) -> Sym3 {
        let c = self.diagonal;
        Sym3 {
            s11: (p.f12 * p.f12 + p.f13 * p.f13) + c,
            s12: p.f13 * p.f23,
            s13: p.f12 * p.f32_,
            s22: (p.f21 * p.f21 + p.f23 * p.f23) + c,
            s23: p.f21 * p.f31,
            s33: (p.f31 * p.f31 + p.f32_ * p.f32_) + c,
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
        let (pred, [den1, den3]) = predict_with_denominators(z, self.k);
        let m = self.scaled_innovation_covariance(&pred); // S/sigma²
        let v = z - pred.f;
        let (w, det) = m.solve_adjugate(v); // sigma²·S⁻¹·v and det(S/sigma²)
        let d = v.dot(w) / self.r;
        // x⁺ = x̂ + K·v with K·v = P̂·S⁻¹·v = (S − R)·S⁻¹·v = v − sigma²·S⁻¹·v,
        // so x⁺ = z − w: the same quantity without the 3×3 product.
        let posterior = z - w;
        let [x0, x1, x2] = posterior.0;
        // Valid iff `k·c − b > 0`, `k·a − b > 0` (§2), `det > 0` and all
        // finite. The three signs are tested at once on their sign bits
        // (set for a negative value, −0 or a negative NaN); a `+0` left
        // through makes an infinite or NaN term (1/0 in the prediction or
        // the solve, with ranges > 0), and so does a NaN, so the finite
        // test below rejects it. Overflow or NaN anywhere upstream
        // propagates into the sum, `det` included (a sum that overflows
        // marks the window invalid too: D or a range near f32::MAX is no
        // estimate).
        let positive = (den1.to_bits() | den3.to_bits() | det.to_bits()) >> 31 == 0;
        let finite = (d + x0 + x1 + x2 + det).is_finite();
        // D is a quadratic form with S⁻¹ positive definite: clamp the
        // rounding of a near-zero result to 0.
        let mahalanobis = if d < 0.0 { 0.0 } else { d };
        (
            WindowEstimate {
                mahalanobis,
                posterior,
            },
            positive & finite,
        )
    }

    #[cfg(feature = "section10")]
    /// [`WindowFilter::update_unchecked`] with the grazing term: the
    /// window's `R = sigma_w²·I` from [`WindowFilter::grazing_variance`]
    /// (the same operations as `update_unchecked` with `sigma²` replaced).
    #[inline(always)]
    pub fn update_grazing_unchecked(&self, z: Vec3) -> (WindowEstimate, bool) {
        self.update_with(z, self.grazing_variance(z))
    }

    #[cfg(feature = "section10")]
    /// The filter with `R = r·I` (m²); `x⁺ = z − r·u`.
    #[inline(always)]
    fn update_with(&self, z: Vec3, r: f32) -> (WindowEstimate, bool) {
        let (pred, in_front) = predict_unchecked(z, self.k);
        let p_hat = self.predicted_covariance_with(&pred, r);
        let s = p_hat.add_diagonal(r);
        let v = z - pred.f;
        let (u, solvable) = s.solve_spd_unchecked(v); // S⁻¹·v
        let d = v.dot(u);
        // x⁺ = x̂ + K·v with K·v = P̂·S⁻¹·v = (S − R)·S⁻¹·v = v − sigma²·u,
        // so x⁺ = z − sigma²·u: the same quantity without the 3×3 product.
        let posterior = z - Vec3([r * u.0[0], r * u.0[1], r * u.0[2]]);
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
    use crate::pipeline::line_model::{predict, predict_unchecked};

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

    /// The validity of [`WindowFilter::update_unchecked`] is the explicit
    /// one of §2–3: both denominators > 0, `det S > 0` and finite, `D` and
    /// `x⁺` finite, on windows of valid (finite, positive) ranges,
    /// including zero denominators and extreme ranges.
    #[test]
    fn validity_by_sign_bits_is_the_explicit_test() {
        let filter = WindowFilter::new(GAMMA, 0.005, 0.0);
        let k = filter.k;
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let scales = [
            1e-30f32,
            1e-6,
            1e-3,
            0.5,
            2.0,
            80.0,
            1e6,
            1e19,
            1e30,
            f32::MAX,
        ];
        let (mut checked, mut invalid) = (0, 0);
        for _ in 0..200_000 {
            let mut pick = || {
                let s = scales[(next() % scales.len() as u64) as usize];
                s * (0.5 + (next() % 1000) as f32 / 1000.0)
            };
            let (a, mut b, c) = (pick(), pick(), pick());
            match next() % 4 {
                0 => b = k * c,                                       // k·c − b = 0 exactly
                1 => b = k * a,                                       // k·a − b = 0 exactly
                2 => b = c * (0.999 + (next() % 3000) as f32 * 1e-6), // near-degenerate
                _ => {}
            }
            if !(b > 0.0 && b.is_finite()) {
                continue;
            }
            let z = Vec3([a, b, c]);
            let (p, in_front) = predict_unchecked(z, k);
            let m = filter.scaled_innovation_covariance(&p);
            let v = z - p.f;
            let (_, solvable) = m.solve_spd_unchecked(v);
            let (est, valid) = filter.update_unchecked(z);
            let (w, _) = m.solve_adjugate(v);
            let finite = (v.dot(w) / filter.r + (z - w).0.iter().sum::<f32>()).is_finite();
            assert_eq!(valid, in_front & solvable & finite, "{z:?} {est:?}");
            checked += 1;
            invalid += usize::from(!valid);
        }
        // Both outcomes are exercised.
        assert!(checked > 100_000 && invalid > 10_000 && checked - invalid > 10_000);
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
