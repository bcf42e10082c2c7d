//! Corners: intersections of consecutive lines (ALGORITHM.md §8, paper Fig. 11–12).
//!
//! For two lines `nᵢ·p = rᵢ` with `nᵢ = (cos αᵢ, sin αᵢ)`, the corner is
//! `p = N⁻¹·r` with `N = [n₁ᵀ; n₂ᵀ]`, `det N = sin(α₂ − α₁)`. Its covariance
//! is propagated from both lines' (α, r) covariances (independent fits):
//! with `g₁ = (sin α₂, −cos α₂)/det`, `g₂ = (−sin α₁, cos α₁)/det` (the
//! columns of `N⁻¹`) and `hᵢ = −sin αᵢ·x + cos αᵢ·y`,
//!
//! ```text
//! ∂p/∂rᵢ = gᵢ,  ∂p/∂αᵢ = −hᵢ·gᵢ   ⇒   Σ_p = s₁·g₁g₁ᵀ + s₂·g₂g₂ᵀ,
//! sᵢ = [−hᵢ, 1]·Σᵢ·[−hᵢ, 1]ᵀ
//! ```
//!
//! The angle between the lines is folded into [0°, 90°]; a corner below
//! `min_corner_angle_deg` is reported with `well_conditioned = false`.

use crate::features::{Corner, Line};
use crate::maths::{wrap_angle, Sym2};

/// Intersect lines number `a` and `b` of a frame. `None` if they are parallel
/// or the point is not finite; the caller counts such a pair.
pub fn intersect(a: u8, l1: &Line, b: u8, l2: &Line, min_corner_angle_deg: f32) -> Option<Corner> {
    let (c1, s1) = (libm::cosf(l1.alpha), libm::sinf(l1.alpha));
    let (c2, s2) = (libm::cosf(l2.alpha), libm::sinf(l2.alpha));
    let det = c1 * s2 - s1 * c2;
    if det == 0.0 {
        return None;
    }
    let x = (l1.r * s2 - l2.r * s1) / det;
    let y = (l2.r * c1 - l1.r * c2) / det;
    let g1 = [s2 / det, -c2 / det];
    let g2 = [-s1 / det, c1 / det];
    let h1 = -s1 * x + c1 * y;
    let h2 = -s2 * x + c2 * y;
    let v1 = l1.cov.quad(-h1, 1.0);
    let v2 = l2.cov.quad(-h2, 1.0);
    let cov = Sym2 {
        a: v1 * g1[0] * g1[0] + v2 * g2[0] * g2[0],
        b: v1 * g1[0] * g1[1] + v2 * g2[0] * g2[1],
        c: v1 * g1[1] * g1[1] + v2 * g2[1] * g2[1],
    };
    let delta = libm::fabsf(wrap_angle(l2.alpha - l1.alpha)); // [0, π]
    let folded = if delta > core::f32::consts::FRAC_PI_2 {
        core::f32::consts::PI - delta
    } else {
        delta
    };
    let angle_deg = folded * (180.0 / core::f32::consts::PI);
    let finite = x.is_finite()
        && y.is_finite()
        && cov.a.is_finite()
        && cov.b.is_finite()
        && cov.c.is_finite();
    if !finite {
        return None;
    }
    Some(Corner {
        x,
        y,
        cov,
        angle_deg,
        well_conditioned: angle_deg >= min_corner_angle_deg,
        line_a: a,
        line_b: b,
    })
}
