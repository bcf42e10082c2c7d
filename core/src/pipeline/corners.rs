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
//! `Σ_p` is the sum of two rank-one terms whose directions `g₁`, `g₂` are
//! nearly opposite at small angles: its determinant `s₁·s₂/det N²` is then
//! tiny against `a·c`, and when one line's term is much larger than the
//! other's (a long wall and a short piece at σ = 0.18 m, 1.14° apart: found
//! by a property test) the rounding of `a`, `b`, `c` in f32 made
//! `a·c − b² < 0`. [`COV_FLOOR`]·trace is added to the diagonal: it raises
//! the determinant by about `COV_FLOOR·(a + c)²`, above the rounding of
//! `a·c − b²` (a few ε·a·c, ε = 1.2e-7), so the covariance is positive
//! definite in f32 at every angle, and changes it by 1 ppm.
//!
//! The angle between the lines is folded into [0°, 90°]; a corner below
//! `min_corner_angle_deg` is reported with `well_conditioned = false`.

use crate::features::{Corner, Line};
use crate::maths::{cos_sin, wrap_angle, Sym2};

/// Relative floor added to the diagonal of a corner's covariance (1 ppm of
/// its trace; see the module docs).
pub const COV_FLOOR: f32 = 1e-6;

/// Intersect lines number `a` and `b` of a frame. `None` if they are parallel
/// or the point is not finite; the caller counts such a pair.
pub fn intersect(a: u8, l1: &Line, b: u8, l2: &Line, min_corner_angle_deg: f32) -> Option<Corner> {
    let (c1, s1) = cos_sin(l1.alpha);
    let (c2, s2) = cos_sin(l2.alpha);
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
    let (cxx, cyy) = (
        v1 * g1[0] * g1[0] + v2 * g2[0] * g2[0],
        v1 * g1[1] * g1[1] + v2 * g2[1] * g2[1],
    );
    // A floor at f32 resolution (see the module docs): PD in f32 whatever
    // the angle and the ratio of the two lines' terms.
    let floor = COV_FLOOR * (cxx + cyy);
    let cov = Sym2 {
        a: cxx + floor,
        b: v1 * g1[0] * g1[1] + v2 * g2[0] * g2[1],
        c: cyy + floor,
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

#[cfg(test)]
mod tests {
    use super::*;

    fn line(alpha: f32, r: f32, var_alpha: f32, var_r: f32) -> Line {
        Line {
            alpha,
            r,
            cov: Sym2 {
                a: var_alpha,
                b: 0.0,
                c: var_r,
            },
            first: 0,
            last: 0,
            points: 0,
            chi2: 1.0,
            endpoints: [[0.0; 2]; 2],
        }
    }

    #[test]
    fn nearly_parallel_unequal_lines_give_a_positive_definite_covariance() {
        // A long, sharp wall and a short piece at σ ≈ 0.18 m, 0.05°–5° apart.
        let mut worst = f32::INFINITY;
        for k in 1..=100 {
            let delta = (k as f32 * 0.05).to_radians();
            for ratio in [1e-2f32, 1e-4, 1e-6, 1e-8] {
                let l1 = line(0.3, 3.0, 1e-2, 0.03);
                let l2 = line(0.3 + delta, 3.05, 1e-2 * ratio, 0.03 * ratio);
                let c = intersect(0, &l1, 1, &l2, 30.0).expect("a corner");
                let det = c.cov.a * c.cov.c - c.cov.b * c.cov.b;
                assert!(
                    c.cov.a > 0.0 && det > 0.0,
                    "{delta} rad, ratio {ratio}: {c:?}"
                );
                worst = worst.min(det / (c.cov.a * c.cov.c));
            }
        }
        assert!(worst > 0.0);
    }
}
