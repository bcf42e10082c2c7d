//! Polar line fitting in the range direction (ALGORITHM.md §7, paper §V).
//!
//! A segment's valid **raw** ranges are fitted with the line
//! `x·cos α + y·sin α = r` (`r ≥ 0`, `α ∈ (−π, π]`):
//!
//! 1. total least squares through the points as the start;
//! 2. Gauss–Newton on the range model `d_j = r / cos(phi_j − α)` (at most
//!    [`MAX_GN_STEPS`] steps, stopping early when a step is negligible);
//! 3. covariance `Σ(α, r) = sigma²·(JᵀJ)⁻¹` at the solution (the Cramér–Rao
//!    bound for Gaussian range noise);
//! 4. quality `chi2 = Σ e² / (sigma²·(m − 2))`;
//! 5. endpoints: the first and last points projected onto the line.
//!
//! Bearings enter through per-beam tables of `cos phi_j` and `sin phi_j`, so
//! the only transcendentals per fit are one `atan2`, and one `cos`/`sin` of
//! `α` per Gauss–Newton step.

use crate::features::Line;
use crate::frame::Beam;
use crate::maths::{wrap_angle, Sym2};

/// Most Gauss–Newton steps per fit (§7.2).
pub const MAX_GN_STEPS: usize = 5;
/// A Gauss–Newton step below this in α (rad) and in r (m) ends the iteration.
pub const GN_STEP_TOLERANCE: f32 = 1e-6;
/// Lines whose every beam must satisfy `cos(phi_j − α) > MIN_INCIDENCE_COS`
/// (the line must be seen from the front, not grazing); otherwise the fit fails.
pub const MIN_INCIDENCE_COS: f32 = 1e-3;

/// Why a segment gave no line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum FitError {
    /// Fewer than three valid points.
    TooFewPoints,
    /// The line is seen edge-on from some beam or the normal equations are singular.
    Degenerate,
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FitError::TooFewPoints => "fewer than three valid points",
            FitError::Degenerate => "line seen edge-on or normal equations singular",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FitError {}

/// The bearing tables of a frame: `cos phi_j`, `sin phi_j`.
#[derive(Clone, Copy, Debug)]
pub struct Bearings<'a> {
    /// `cos phi_j` for every beam.
    pub cos: &'a [f32],
    /// `sin phi_j` for every beam.
    pub sin: &'a [f32],
}

/// The raw ranges of a frame with its bearing tables and beam status: what
/// the fits of §7 (and split before reject) read. §7 fits the raw, not the
/// smoothed, ranges.
#[derive(Clone, Copy, Debug)]
pub struct RawScan<'a> {
    /// `cos phi_j`, `sin phi_j` per beam.
    pub bearings: Bearings<'a>,
    /// Raw ranges (m).
    pub ranges: &'a [f32],
    /// Status per beam (invalid beams are skipped).
    pub beams: &'a [Beam],
}

/// Fit a line to the valid beams of `first..=last` of `ranges` (m), with
/// range noise `sigma` (m). Beams outside the slices are ignored.
pub fn fit_line(
    bearings: Bearings<'_>,
    ranges: &[f32],
    beams: &[Beam],
    first: u16,
    last: u16,
    sigma: f32,
) -> Result<Line, FitError> {
    let span = Span::new(bearings, ranges, beams, first, last).ok_or(FitError::TooFewPoints)?;
    // 1. Total least squares start.
    let (m, alpha, r) = span.total_least_squares()?;
    // 2. Gauss–Newton in the range direction.
    let (alpha, r) = span.gauss_newton(alpha, r)?;
    let (alpha, r) = facing_sensor(alpha, r);
    // 3.–4. Covariance and chi2 at the solution.
    let (ca, sa) = (libm::cosf(alpha), libm::sinf(alpha));
    let (jtj, sum_e2) = span.normal_matrix_and_residual(ca, sa, r)?;
    let var = sigma * sigma;
    let cov = jtj.inverse_spd().ok_or(FitError::Degenerate)?.scale(var);
    let chi2 = sum_e2 / (var * (m as f32 - 2.0));
    // 5. Endpoints: first and last valid points projected onto the line.
    Ok(Line {
        alpha,
        r,
        cov,
        first,
        last: (first as usize + span.ranges.len() - 1) as u16,
        points: m.min(u16::MAX as u32) as u16,
        chi2,
        endpoints: span.endpoints(ca, sa, r),
    })
}

/// The beams `first..=last` of a segment as four slices of one length,
/// indexed from 0: no index below can be out of bounds.
struct Span<'a> {
    ranges: &'a [f32],
    beams: &'a [Beam],
    cos: &'a [f32],
    sin: &'a [f32],
}

impl<'a> Span<'a> {
    /// The span, or `None` if it holds no beam.
    fn new(
        bearings: Bearings<'a>,
        ranges: &'a [f32],
        beams: &'a [Beam],
        first: u16,
        last: u16,
    ) -> Option<Self> {
        let n = ranges
            .len()
            .min(beams.len())
            .min(bearings.cos.len())
            .min(bearings.sin.len());
        let lo = first as usize;
        let hi = (last as usize + 1).min(n);
        if lo >= hi {
            return None;
        }
        Some(Span {
            ranges: ranges.get(lo..hi)?,
            beams: beams.get(lo..hi)?,
            cos: bearings.cos.get(lo..hi)?,
            sin: bearings.sin.get(lo..hi)?,
        })
    }

    /// `(d_j, cos phi_j, sin phi_j)` of every valid beam, in order.
    fn valid(&self) -> impl DoubleEndedIterator<Item = (f32, f32, f32)> + '_ {
        self.ranges
            .iter()
            .zip(self.beams)
            .zip(self.cos.iter().zip(self.sin))
            .filter(|((_, b), _)| b.is_valid())
            .map(|((&d, _), (&c, &s))| (d, c, s))
    }

    /// §7.1: the total-least-squares line through the valid points
    /// (centroid and central second moments): `(m, α, r)` with `r ≥ 0`.
    fn total_least_squares(&self) -> Result<(u32, f32, f32), FitError> {
        let mut m = 0u32;
        let (mut sx, mut sy) = (0.0f32, 0.0f32);
        for (d, c, s) in self.valid() {
            sx += d * c;
            sy += d * s;
            m += 1;
        }
        if m < 3 {
            return Err(FitError::TooFewPoints);
        }
        let mf = m as f32;
        let (xm, ym) = (sx / mf, sy / mf);
        let (mut sxx, mut syy, mut sxy) = (0.0f32, 0.0f32, 0.0f32);
        for (d, c, s) in self.valid() {
            let (dx, dy) = (d * c - xm, d * s - ym);
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
        let alpha = 0.5 * libm::atan2f(-2.0 * sxy, syy - sxx);
        let r = xm * libm::cosf(alpha) + ym * libm::sinf(alpha);
        let (alpha, r) = facing_sensor(alpha, r);
        Ok((m, alpha, r))
    }

    /// §7.2: at most [`MAX_GN_STEPS`] Gauss–Newton steps on the range model
    /// `d_j = r / cos(phi_j − α)`, from `(alpha, r)`.
    fn gauss_newton(&self, mut alpha: f32, mut r: f32) -> Result<(f32, f32), FitError> {
        for _ in 0..MAX_GN_STEPS {
            let (ca, sa) = (libm::cosf(alpha), libm::sinf(alpha));
            let mut jte = [0.0f32; 2];
            let mut jtj = Sym2::default();
            for (d, c, s) in self.valid() {
                let (cd, sd) = incidence(c, s, ca, sa).ok_or(FitError::Degenerate)?;
                let inv_c = 1.0 / cd;
                let e = d - r * inv_c;
                let ja = -r * sd * inv_c * inv_c;
                let jr = inv_c;
                jtj.a += ja * ja;
                jtj.b += ja * jr;
                jtj.c += jr * jr;
                jte[0] += ja * e;
                jte[1] += jr * e;
            }
            let inv = jtj.inverse_spd().ok_or(FitError::Degenerate)?;
            let d_alpha = inv.a * jte[0] + inv.b * jte[1];
            let d_r = inv.b * jte[0] + inv.c * jte[1];
            alpha = wrap_angle(alpha + d_alpha);
            r += d_r;
            if libm::fabsf(d_alpha) < GN_STEP_TOLERANCE && libm::fabsf(d_r) < GN_STEP_TOLERANCE {
                break;
            }
        }
        Ok((alpha, r))
    }

    /// §7.3–7.4: `JᵀJ` and `Σ e²` at the solution `(cos α, sin α, r)`.
    fn normal_matrix_and_residual(
        &self,
        ca: f32,
        sa: f32,
        r: f32,
    ) -> Result<(Sym2, f32), FitError> {
        let mut jtj = Sym2::default();
        let mut sum_e2 = 0.0f32;
        for (d, c, s) in self.valid() {
            let (cd, sd) = incidence(c, s, ca, sa).ok_or(FitError::Degenerate)?;
            let inv_c = 1.0 / cd;
            let e = d - r * inv_c;
            let ja = -r * sd * inv_c * inv_c;
            jtj.a += ja * ja;
            jtj.b += ja * inv_c;
            jtj.c += inv_c * inv_c;
            sum_e2 += e * e;
        }
        Ok((jtj, sum_e2))
    }

    /// §7.5: the first and last valid points projected onto the line
    /// (the first beam's point if none is valid).
    fn endpoints(&self, ca: f32, sa: f32, r: f32) -> [[f32; 2]; 2] {
        let project = |(d, c, s): (f32, f32, f32)| {
            let (x, y) = (d * c, d * s);
            let dist = x * ca + y * sa - r;
            [x - dist * ca, y - dist * sa]
        };
        let fallback = || {
            let first = (self.ranges.first(), self.cos.first(), self.sin.first());
            match first {
                (Some(&d), Some(&c), Some(&s)) => project((d, c, s)),
                _ => [0.0; 2],
            }
        };
        let first = self.valid().next().map_or_else(fallback, project);
        let last = self.valid().next_back().map_or_else(fallback, project);
        [first, last]
    }
}

/// The same line with `r ≥ 0`: a negative `r` flips the normal by π.
#[inline]
fn facing_sensor(alpha: f32, r: f32) -> (f32, f32) {
    if r < 0.0 {
        (wrap_angle(alpha + core::f32::consts::PI), -r)
    } else {
        (alpha, r)
    }
}

/// `(cos(phi_j − α), sin(phi_j − α))` from a beam's `cos phi_j`, `sin phi_j`,
/// if the beam meets the line from the front (`cos > MIN_INCIDENCE_COS`).
#[inline]
fn incidence(cos_phi: f32, sin_phi: f32, ca: f32, sa: f32) -> Option<(f32, f32)> {
    let cd = cos_phi * ca + sin_phi * sa;
    let sd = sin_phi * ca - cos_phi * sa;
    if cd > MIN_INCIDENCE_COS {
        Some((cd, sd))
    } else {
        None
    }
}

/// The Mahalanobis distance between two lines' parameters,
/// `Δᵀ(Σ₁ + Σ₂)⁻¹Δ` with `Δ = (α₂ − α₁ wrapped, r₂ − r₁)` (§7.6).
/// `None` if the summed covariance is not positive definite.
pub fn parameter_distance(l1: &Line, l2: &Line) -> Option<f32> {
    let inv = l1.cov.add(&l2.cov).inverse_spd()?;
    let da = wrap_angle(l2.alpha - l1.alpha);
    let dr = l2.r - l1.r;
    Some(inv.quad(da, dr))
}
