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
//! Bearings enter through a [`BearingTable`] (`cos phi_j`, `sin phi_j` per
//! beam: a caller's [`Bearings`] slices, or the extractor's two-level table
//! of [`crate::pipeline::bearings`]), and the line's direction is carried as the unit normal `(cos α, sin α)`:
//! the start's normal comes from the scatter matrix by half-angle formulas,
//! each Gauss–Newton step rotates it by `Δα` with a short Taylor series of
//! `cos Δα`, `sin Δα` (exact to f32 for `|Δα| ≤ 0.25`; a larger step falls
//! back to [`crate::maths::cos_sin`]), and `α = atan2(sin α, cos α)` once at the end.
//! So a fit needs no libm `sinf`/`cosf`, which on the M4F run in software
//! f64 (docs/DESIGN.md, "Sine, cosine and `atan2` of the core's own").

use crate::features::{Line, Segment};
use crate::frame::Beam;
use crate::maths::{atan2, cos_sin, wrap_angle, Sym2};
pub use crate::pipeline::bearings::{BearingTable, Bearings, Sweep};

/// Most Gauss–Newton steps per fit (§7.2).
pub const MAX_GN_STEPS: usize = 5;
/// A Gauss–Newton step below this in α (rad) and in r (m) ends the iteration.
pub const GN_STEP_TOLERANCE: f32 = 1e-6;
/// Most interleaved mirror turns of a scan (the 0.25° modes: four).
pub const MAX_TURNS: usize = 4;

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

/// The raw ranges of a frame with its bearing table and beam status: what
/// the fits of §7 (and split before reject) read. §7 fits the raw, not the
/// smoothed, ranges.
#[derive(Clone, Copy, Debug)]
pub struct RawScan<'a, B: BearingTable = Bearings<'a>> {
    /// `cos phi_j`, `sin phi_j` per beam.
    pub bearings: B,
    /// Raw ranges (m).
    pub ranges: &'a [f32],
    /// Status per beam (invalid beams are skipped).
    pub beams: &'a [Beam],
    /// Beams at or beyond this range (m) are skipped too (§1 v2).
    pub max_range: f32,
    /// Footprint term κ (rad) of the range noise, [`crate::Params::footprint`]:
    /// beam `j` has `σ_j² = σ² + (κ·d_j·tan θ_j)²` at incidence `θ_j`
    /// (`θ_j = phi_j − α`), and the fits weight it by `σ²/σ_j²`. `0`: every
    /// beam `σ` (§7 as written).
    pub footprint: f32,
    /// Interleaved mirror turns whose offsets the fits' χ² allows
    /// ([`crate::Params::turn_offsets`], docs/ALGORITHM.md, turns'
    /// offsets): beam `j` belongs to turn `j mod turns`, each turn's weighted
    /// mean residual is taken out of `Σe²` and the χ² has `turns − 1` fewer
    /// degrees of freedom ([`residual_dof`]). The line `(α, r)` and its
    /// covariance are the fit of all beams, as before. `1`: §7 as written;
    /// only 2 and 4 (the LMS's interleaves) take effect, any other count
    /// is 1.
    pub turns: u8,
}

/// The degrees of freedom of a line fit's χ² over `points` beams of
/// `turns` interleaved turns (see [`RawScan::turns`]): `m − 2`, and
/// `m − 1 − turns` when the turns' offsets are taken out (`turns` of 2 or
/// 4, and more than two beams per turn); at least 1.
pub fn residual_dof(points: u16, turns: u8) -> f32 {
    let (m, k) = (u32::from(points), u32::from(turns));
    let dof = if offsets_apply(points, turns) {
        m - 1 - k
    } else {
        m.saturating_sub(2)
    };
    dof.max(1) as f32
}

/// A line's own weighted residual sum in units of σ², `χ²·dof` (its
/// `chi2` is `Σe²/(σ²·dof)`, [`residual_dof`], with the turns' offsets out
/// where they apply): what the merges' per-part χ² and F test and the arcs'
/// pair test compare.
#[inline]
pub fn residual_sum(line: &Line, turns: u8) -> f32 {
    line.chi2 * residual_dof(line.points, turns)
}

/// Whether the turns' offsets are taken out of a fit of `points` beams.
#[inline]
fn offsets_apply(points: u16, turns: u8) -> bool {
    matches!(turns, 2 | 4) && u32::from(points) > 2 * u32::from(turns)
}

/// The turns a fit of `points` beams takes offsets for: `turns` where
/// they apply ([`residual_dof`]), else 1.
#[inline]
pub(crate) fn offset_turns(points: u16, turns: u8) -> u8 {
    if offsets_apply(points, turns) {
        turns
    } else {
        1
    }
}

/// Fit a line to the valid beams `span.first..=span.last` of `ranges` (m), with
/// range noise `sigma` (m). Beams outside the slices are ignored. With the
/// extractor's own table (`&TwoLevelBearings`) the result is the
/// extractor's bit for bit; with full tables (`Bearings`) it may differ in
/// the last bits (another order of the angle sums). For the evaluation and
/// the workspace tests: `lms_core::unstable::fit_line`.
#[cfg(any(test, feature = "unstable-lab"))]
pub fn fit_line<B: BearingTable>(
    bearings: B,
    ranges: &[f32],
    beams: &[Beam],
    span: Segment,
    sigma: f32,
) -> Result<Line, FitError> {
    let scan = RawScan {
        bearings,
        ranges,
        beams,
        max_range: f32::INFINITY,
        footprint: 0.0,
        turns: 1,
    };
    fit_piece(&scan, span, sigma)
}

/// Fit a line to the beams `piece.first..=piece.last` of `scan` that are
/// valid and below its `max_range`, with range noise `sigma` (m).
pub fn fit_piece<B: BearingTable>(
    scan: &RawScan<'_, B>,
    piece: Segment,
    sigma: f32,
) -> Result<Line, FitError> {
    fit_piece_without(scan, piece, &Holes::NONE, sigma)
}

/// Most runs of beams a fit leaves out ([`Holes`]).
pub const MAX_HOLES: usize = 4;

/// Runs of beams a fit leaves out: the gaps between the lines a merged
/// line is made of ([`crate::Params::merge_own_beams`]), at most
/// [`MAX_HOLES`], each a half-open range `from..to` of beam indices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Holes {
    runs: [(u16, u16); MAX_HOLES],
    len: u8,
}

impl Holes {
    /// No beam left out.
    pub const NONE: Holes = Holes {
        runs: [(0, 0); MAX_HOLES],
        len: 0,
    };

    /// Leave out the beams of `gap` too; `false` (nothing changed) if
    /// [`MAX_HOLES`] runs are left out already.
    pub fn push(&mut self, gap: core::ops::Range<u16>) -> bool {
        match self.runs.get_mut(usize::from(self.len)) {
            Some(slot) => {
                *slot = (gap.start, gap.end);
                self.len += 1;
                true
            }
            None => false,
        }
    }

    /// The runs left out, in the order pushed (a merge's gaps, in beam
    /// order).
    #[inline(always)]
    fn runs(&self) -> &[(u16, u16)] {
        self.runs.get(..usize::from(self.len)).unwrap_or_default()
    }
}

/// [`fit_piece`] without the beams of `holes`: the merges' refit of the
/// lines' own beams, the beams between them left out
/// ([`crate::Params::merge_own_beams`]). The line still spans
/// `piece.first..=piece.last`; its `points`, covariance and χ² are those
/// of the beams fitted. A hole must lie inside the piece, not at its ends.
pub fn fit_piece_without<B: BearingTable>(
    scan: &RawScan<'_, B>,
    piece: Segment,
    holes: &Holes,
    sigma: f32,
) -> Result<Line, FitError> {
    let first = piece.first;
    let mut span = Span::new(scan, piece).ok_or(FitError::TooFewPoints)?;
    span.holes = *holes;
    span.set_footprint(scan.footprint, sigma);
    // 1. Total least squares start.
    let (m, start) = span.total_least_squares()?;
    // 2. Gauss–Newton in the range direction.
    let solution = span.gauss_newton(start)?.facing_sensor();
    let (Normal { ca, sa, r }, alpha) = (solution, solution.alpha());
    // 3.–4. Covariance and chi2 at the solution (the turns' offsets taken
    // out of Σe² where `scan.turns` asks for it).
    let points = m.min(u16::MAX as u32) as u16;
    let turns = offset_turns(points, scan.turns);
    let (jtj, sum_e2) = span.normal_matrix_and_residual(ca, sa, r, turns)?;
    let var = sigma * sigma;
    let cov = jtj.inverse_spd().ok_or(FitError::Degenerate)?.scale(var);
    let chi2 = sum_e2 / (var * residual_dof(points, turns));
    // 5. Endpoints: first and last valid points projected onto the line.
    Ok(Line {
        alpha,
        r,
        cov,
        first,
        last: (first as usize + span.ranges.len() - 1) as u16,
        points,
        chi2,
        endpoints: span.endpoints(ca, sa, r),
    })
}

/// ALGORITHM.md §7.9: `line` refitted to every usable beam of its span
/// with every beam at `sigma` (no footprint term, every weight 1) by one
/// Gauss–Newton step from `line`'s own solution (a one-step estimator:
/// the two solutions lie well within one step of each other), its
/// covariance `σ²(JᵀJ)⁻¹` at `line`'s solution and its χ² from the
/// residual sum the linearised model predicts; with it `Λ = ln Π(1 +
/// t_j²)`, `t_j = (κ/σ)·d_j·tan θ_j` (κ = `scan.footprint`) over those
/// beams at `line`'s normal, the log of the footprint model's range
/// variances over σ², summed. One pass over the beams.
pub fn refit_without_footprint<B: BearingTable>(
    scan: &RawScan<'_, B>,
    line: &Line,
    sigma: f32,
) -> Result<(Line, f32), FitError> {
    let piece = Segment {
        first: line.first,
        last: line.last,
    };
    // Unweighted: `Span::new` leaves the footprint term off.
    let span = Span::new(scan, piece).ok_or(FitError::TooFewPoints)?;
    let (ca, sa) = cos_sin(line.alpha);
    let start = Normal { ca, sa, r: line.r };
    let step = span.footprint_free_step(start, scan.footprint / sigma, scan.turns)?;
    let solution = step.solution.facing_sensor();
    let (Normal { ca, sa, r }, alpha) = (solution, solution.alpha());
    let var = sigma * sigma;
    let cov = step.inverse.scale(var);
    let chi2 = step.residual / (var * residual_dof(step.points, step.turns));
    let refit = Line {
        alpha,
        r,
        cov,
        first: line.first,
        last: (span.lo + span.ranges.len() - 1) as u16,
        points: step.points,
        chi2,
        endpoints: span.endpoints(ca, sa, r),
    };
    Ok((refit, step.log_variances))
}

/// What [`Span::footprint_free_step`] finds in its one pass.
struct FootprintFreeStep {
    /// The normal after the step (`r` not yet made ≥ 0).
    solution: Normal,
    /// `(JᵀJ)⁻¹` at the start.
    inverse: Sym2,
    /// The residual sum after the step (m², the turns' offsets out).
    residual: f32,
    /// Usable beams.
    points: u16,
    /// The turns whose offsets are taken out (1: none).
    turns: u8,
    /// `Λ` of §7.9.
    log_variances: f32,
}

/// The natural log of a product of factors ≥ 1, taken without overflow:
/// the running product is kept as `mantissa · 2^exponent` with the mantissa
/// in `[1, 2)`, its binary exponent moved out after each factor
/// (ALGORITHM.md §7.9). One `logf` for the whole product.
#[derive(Clone, Copy, Debug)]
struct LogProduct {
    mantissa: f32,
    exponent: i32,
}

impl LogProduct {
    /// The empty product, 1.
    const ONE: LogProduct = LogProduct {
        mantissa: 1.0,
        exponent: 0,
    };

    /// Multiply by `x` (finite, ≥ 1).
    #[inline(always)]
    fn times(&mut self, x: f32) {
        let bits = (self.mantissa * x).to_bits();
        self.exponent += ((bits >> 23) & 0xff) as i32 - 127;
        self.mantissa = f32::from_bits((bits & 0x007f_ffff) | (127 << 23));
    }

    /// `ln` of the product: `exponent·ln 2 + ln(mantissa)`.
    fn ln(self) -> f32 {
        self.exponent as f32 * core::f32::consts::LN_2 + libm::logf(self.mantissa)
    }
}

/// The beams `first..=last` of a segment as two slices of one length,
/// indexed from 0 (beam `lo + i` of the bearing table): no index below can
/// be out of bounds.
struct Span<'a, B> {
    ranges: &'a [f32],
    beams: &'a [Beam],
    bearings: B,
    lo: usize,
    max_range: f32,
    /// `κ/σ` of the footprint weights (1/m·rad; 0: unweighted).
    kappa_per_sigma: f32,
    /// Beams left out of the fit.
    holes: Holes,
}

impl<B: BearingTable> RawScan<'_, B> {
    /// `f(j, d_j, cos(phi_j − α), sin(phi_j − α))` for the valid beams `j`
    /// of `piece` below `max_range`, in beam order, with `(ca, sa) =
    /// (cos α, sin α)` (`(1, 0)`: the bearings themselves).
    #[inline]
    pub(crate) fn each_valid(
        &self,
        piece: Segment,
        ca: f32,
        sa: f32,
        f: impl FnMut(usize, f32, f32, f32),
    ) {
        if let Some(span) = Span::new(self, piece) {
            span.each_valid_beam(ca, sa, f);
        }
    }
}

impl<'a, B: BearingTable> Span<'a, B> {
    /// Weight the beams by the footprint term `footprint` (κ ≥ 0, rad) at
    /// range noise `sigma` (m); κ = 0: off.
    #[inline(always)]
    fn set_footprint(&mut self, footprint: f32, sigma: f32) {
        if footprint > 0.0 {
            self.kappa_per_sigma = footprint / sigma;
        }
    }

    /// `σ²/σ_j²` of a beam at range `d` whose incidence on the line has
    /// cosine `cd > 0` and sine `sd`: `1 / (1 + (κ·d·tan θ / σ)²)`; exactly
    /// 1 when the footprint term is off (`κ/σ = 0`), so that every product
    /// with it is the unweighted §7 value bit for bit.
    #[inline(always)]
    fn weight(&self, d: f32, cd: f32, sd: f32) -> f32 {
        let t = self.kappa_per_sigma * d * (sd / cd);
        1.0 / (1.0 + t * t)
    }

    /// The span of `piece`'s beams, or `None` if it holds no beam.
    fn new(scan: &RawScan<'a, B>, piece: Segment) -> Option<Self> {
        let (bearings, ranges, beams) = (scan.bearings, scan.ranges, scan.beams);
        let n = ranges.len().min(beams.len()).min(bearings.beams());
        let lo = piece.first as usize;
        let hi = (piece.last as usize + 1).min(n);
        if lo >= hi {
            return None;
        }
        Some(Span {
            ranges: ranges.get(lo..hi)?,
            beams: beams.get(lo..hi)?,
            bearings,
            lo,
            max_range: scan.max_range,
            kappa_per_sigma: 0.0,
            holes: Holes::NONE,
        })
    }

    /// `f(d_j, cos(phi_j − α), sin(phi_j − α))` for every valid beam, in
    /// order, with `(ca, sa) = (cos α, sin α)` (`(1, 0)`: the bearings).
    #[inline]
    fn each_valid(&self, ca: f32, sa: f32, mut f: impl FnMut(f32, f32, f32)) {
        self.each_valid_beam(ca, sa, |_, d, c, s| f(d, c, s));
    }

    /// [`Self::each_valid`] with the beam's index `j` in the scan first.
    /// The beams between the holes are swept run by run, so a fit without
    /// holes is one sweep with no test of its own per beam.
    #[inline]
    fn each_valid_beam(&self, ca: f32, sa: f32, mut f: impl FnMut(usize, f32, f32, f32)) {
        let (max_range, lo) = (self.max_range, self.lo);
        let n = self.ranges.len().min(self.beams.len());
        let runs = self.holes.runs();
        // Beams `start..end` (from `lo`) lie between two holes.
        let mut start = 0usize;
        for k in 0..=runs.len() {
            let (end, next) = match runs.get(k) {
                Some(&(from, to)) => (usize::from(from), usize::from(to)),
                None => (lo + n, lo + n),
            };
            let end = end.saturating_sub(lo).min(n);
            if let (Some(ranges), Some(beams)) =
                (self.ranges.get(start..end), self.beams.get(start..end))
            {
                let first = lo + start;
                self.bearings.sweep(
                    Sweep {
                        lo: first,
                        ranges,
                        beams,
                        normal: (ca, sa),
                    },
                    |i, d, b, c, s| {
                        if b.is_valid() && d < max_range {
                            f(first + i, d, c, s);
                        }
                    },
                );
            }
            start = start.max(next.saturating_sub(lo).min(n));
        }
    }

    /// §7.1: the total-least-squares line through the valid points
    /// (centroid and central second moments): `(m, line)` with `r ≥ 0`.
    fn total_least_squares(&self) -> Result<(u32, Normal), FitError> {
        let mut m = 0u32;
        let (mut sx, mut sy) = (0.0f32, 0.0f32);
        self.each_valid(1.0, 0.0, |d, c, s| {
            sx += d * c;
            sy += d * s;
            m += 1;
        });
        if m < 3 {
            return Err(FitError::TooFewPoints);
        }
        let mf = m as f32;
        let (xm, ym) = (sx / mf, sy / mf);
        let (mut sxx, mut syy, mut sxy) = (0.0f32, 0.0f32, 0.0f32);
        self.each_valid(1.0, 0.0, |d, c, s| {
            let (dx, dy) = (d * c - xm, d * s - ym);
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        });
        // α = ½·atan2(−2·Sxy, Syy − Sxx) ∈ (−π/2, π/2], by half angles:
        // cos 2α = (Syy − Sxx)/h, sin 2α = −2·Sxy/h.
        let (c2, s2) = (syy - sxx, -2.0 * sxy);
        let h = libm::sqrtf(c2 * c2 + s2 * s2);
        let (ca, sa) = if !(h > 0.0) {
            (1.0, 0.0) // no preferred direction (atan2(0, 0) = 0)
        } else if c2 >= 0.0 {
            let ca = libm::sqrtf(0.5 * (1.0 + c2 / h));
            (ca, s2 / h / (2.0 * ca))
        } else {
            let sa = libm::sqrtf(0.5 * (1.0 - c2 / h));
            let sa = if s2 < 0.0 { -sa } else { sa };
            (s2 / h / (2.0 * sa), sa)
        };
        let line = Normal {
            ca,
            sa,
            r: xm * ca + ym * sa,
        };
        Ok((m, line.facing_sensor()))
    }

    /// §7.2: at most [`MAX_GN_STEPS`] Gauss–Newton steps on the range model
    /// `d_j = r / cos(phi_j − α)`, from `start`.
    fn gauss_newton(&self, start: Normal) -> Result<Normal, FitError> {
        let Normal {
            mut ca,
            mut sa,
            mut r,
        } = start;
        for _ in 0..MAX_GN_STEPS {
            let mut jte = [0.0f32; 2];
            let mut jtj = Sym2::default();
            let mut edge_on = false;
            self.each_valid(ca, sa, |d, cd, sd| {
                // The beam must meet the line from the front.
                edge_on |= !(cd > MIN_INCIDENCE_COS);
                let inv_c = 1.0 / cd;
                let e = d - r * inv_c;
                let ja = -r * sd * inv_c * inv_c;
                let jr = inv_c;
                // §10 (f): weighted by σ²/σ_j² at this step's α (1: §7).
                let w = self.weight(d, cd, sd);
                jtj.a += w * (ja * ja);
                jtj.b += w * (ja * jr);
                jtj.c += w * (jr * jr);
                jte[0] += w * (ja * e);
                jte[1] += w * (jr * e);
            });
            if edge_on {
                return Err(FitError::Degenerate);
            }
            let inv = jtj.inverse_spd().ok_or(FitError::Degenerate)?;
            let d_alpha = inv.a * jte[0] + inv.b * jte[1];
            let d_r = inv.b * jte[0] + inv.c * jte[1];
            (ca, sa) = rotate(ca, sa, d_alpha);
            r += d_r;
            if libm::fabsf(d_alpha) < GN_STEP_TOLERANCE && libm::fabsf(d_r) < GN_STEP_TOLERANCE {
                break;
            }
        }
        Ok(Normal { ca, sa, r })
    }

    /// §7.9: one unweighted Gauss–Newton step from `(ca, sa, r)` over the
    /// usable beams, with what the refit needs from the same pass:
    /// `(JᵀJ)⁻¹` at `(ca, sa, r)`, the residual sum after the step as the linearised
    /// model predicts it (`Σe² − δᵀJᵀe`, the turns' offsets taken out of it
    /// where `turns` asks for it, at most `m` beams), the number `m` of
    /// usable beams and `Λ = ln Π(1 + t²)`, `t = k·d·(sin θ·(1/cos θ))`.
    fn footprint_free_step(
        &self,
        Normal { ca, sa, r }: Normal,
        k: f32,
        turns: u8,
    ) -> Result<FootprintFreeStep, FitError> {
        let mut jte = [0.0f32; 2];
        let mut jtj = Sym2::default();
        let mut sum_e2 = 0.0f32;
        let mut edge_on = false;
        let mut m = 0u32;
        let mut variances = LogProduct::ONE;
        // Per turn: Σe, Σ∂e/∂α, Σ∂e/∂r (as Σja, Σjr) and the beams.
        let mask = TurnSums::new(turns).mask;
        let (mut te, mut ta, mut tr, mut tw) = (
            [0.0f32; MAX_TURNS],
            [0.0f32; MAX_TURNS],
            [0.0f32; MAX_TURNS],
            [0.0f32; MAX_TURNS],
        );
        self.each_valid_beam(ca, sa, |j, d, cd, sd| {
            edge_on |= !(cd > MIN_INCIDENCE_COS);
            let inv_c = 1.0 / cd;
            let e = d - r * inv_c;
            let ja = -r * sd * inv_c * inv_c;
            let jr = inv_c;
            jtj.a += ja * ja;
            jtj.b += ja * jr;
            jtj.c += jr * jr;
            jte[0] += ja * e;
            jte[1] += jr * e;
            sum_e2 += e * e;
            let t = j & mask & (MAX_TURNS - 1);
            te[t] += e;
            ta[t] += ja;
            tr[t] += jr;
            tw[t] += 1.0;
            let f = k * d * (sd * inv_c);
            variances.times(1.0 + f * f);
            m += 1;
        });
        if edge_on {
            return Err(FitError::Degenerate);
        }
        if m < 3 {
            return Err(FitError::TooFewPoints);
        }
        let inv = jtj.inverse_spd().ok_or(FitError::Degenerate)?;
        let d_alpha = inv.a * jte[0] + inv.b * jte[1];
        let d_r = inv.b * jte[0] + inv.c * jte[1];
        let after = sum_e2 - (d_alpha * jte[0] + d_r * jte[1]);
        let points = m.min(u16::MAX as u32) as u16;
        let turns = offset_turns(points, turns);
        let mut per_turn = TurnSums::new(turns);
        if per_turn.mask != 0 {
            for t in 0..MAX_TURNS {
                per_turn.e[t] = te[t] - (d_alpha * ta[t] + d_r * tr[t]);
                per_turn.w[t] = tw[t];
            }
        }
        let (ca, sa) = rotate(ca, sa, d_alpha);
        Ok(FootprintFreeStep {
            solution: Normal { ca, sa, r: r + d_r },
            inverse: inv,
            residual: per_turn.take_out_of(after.max(0.0)),
            points,
            turns,
            log_variances: variances.ln(),
        })
    }

    /// §7.3–7.4: `JᵀJ` and `Σ e²` at the solution `(cos α, sin α, r)`;
    /// with `turns` > 1 `Σ e²` less what each turn's weighted mean
    /// residual `ē_t` explains beyond the common one,
    /// `Σ_t W_t ē_t² − W ē²` (`W_t = Σ_t w_j`; never below 0).
    fn normal_matrix_and_residual(
        &self,
        ca: f32,
        sa: f32,
        r: f32,
        turns: u8,
    ) -> Result<(Sym2, f32), FitError> {
        let mut jtj = Sym2::default();
        let mut sum_e2 = 0.0f32;
        let mut edge_on = false;
        let mut per_turn = TurnSums::new(turns);
        self.each_valid_beam(ca, sa, |j, d, cd, sd| {
            edge_on |= !(cd > MIN_INCIDENCE_COS);
            let inv_c = 1.0 / cd;
            let e = d - r * inv_c;
            let ja = -r * sd * inv_c * inv_c;
            let w = self.weight(d, cd, sd); // §10 (f); 1: §7
            jtj.a += w * (ja * ja);
            jtj.b += w * (ja * inv_c);
            jtj.c += w * (inv_c * inv_c);
            sum_e2 += w * (e * e);
            per_turn.add(j, w, e);
        });
        if edge_on {
            return Err(FitError::Degenerate);
        }
        Ok((jtj, per_turn.take_out_of(sum_e2)))
    }

    /// §7.5: the first and last valid points projected onto the line
    /// (the first beam's point if none is valid).
    fn endpoints(&self, ca: f32, sa: f32, r: f32) -> [[f32; 2]; 2] {
        let project = |i: usize| {
            let d = self.ranges.get(i).copied().unwrap_or(0.0);
            let (c, s) = self.bearings.cos_sin(self.lo + i);
            let (x, y) = (d * c, d * s);
            let dist = x * ca + y * sa - r;
            [x - dist * ca, y - dist * sa]
        };
        let valid = |(_, (&d, b)): &(usize, (&f32, &Beam))| b.is_valid() && d < self.max_range;
        let mut beams = self.ranges.iter().zip(self.beams).enumerate();
        let first = beams.clone().find(valid).map_or(0, |(i, _)| i);
        let last = beams.rfind(valid).map_or(0, |(i, _)| i);
        [project(first), project(last)]
    }
}

/// Per-turn sums of a weighted residual (the turns' offsets): for turn
/// `t = j mod turns` of beam `j`, `S_t = Σ w_j e_j` and `W_t = Σ w_j`. With
/// one turn nothing is summed and nothing taken out.
pub(crate) struct TurnSums {
    e: [f32; MAX_TURNS],
    w: [f32; MAX_TURNS],
    /// `turns − 1` for 2 or 4 turns; 0: off.
    mask: usize,
}

impl TurnSums {
    /// Sums for `turns` interleaved turns (2 or 4; anything else: off).
    #[inline]
    pub(crate) fn new(turns: u8) -> Self {
        TurnSums {
            e: [0.0; MAX_TURNS],
            w: [0.0; MAX_TURNS],
            mask: if matches!(turns, 2 | 4) {
                usize::from(turns) - 1
            } else {
                0
            },
        }
    }

    /// Add beam `j`'s weighted residual `w·e` and weight `w`.
    #[inline(always)]
    pub(crate) fn add(&mut self, j: usize, w: f32, e: f32) {
        if self.mask != 0 {
            let t = j & self.mask & (MAX_TURNS - 1);
            self.e[t] += w * e;
            self.w[t] += w;
        }
    }

    /// `sum` (a weighted residual sum over the same beams) less what the
    /// turns' offsets explain, `Σ_t S_t²/W_t − S²/W` over the turns with
    /// weight (never below 0); `sum` itself when off.
    #[inline(never)] // one copy for the fits and the straightness bound
    pub(crate) fn take_out_of(&self, sum: f32) -> f32 {
        if self.mask == 0 {
            return sum;
        }
        let (mut within, mut s, mut w) = (0.0f32, 0.0f32, 0.0f32);
        for (&se, &sw) in self.e.iter().zip(&self.w) {
            if sw > 0.0 {
                within += se * se / sw;
                s += se;
                w += sw;
            }
        }
        let between = if w > 0.0 { within - s * s / w } else { 0.0 };
        (sum - between).max(0.0)
    }
}

/// A line `x·ca + y·sa = r` by its unit normal `(cos α, sin α)`.
#[derive(Clone, Copy, Debug)]
struct Normal {
    ca: f32,
    sa: f32,
    r: f32,
}

impl Normal {
    /// The same line with `r ≥ 0`: a negative `r` flips the normal by π.
    #[inline]
    fn facing_sensor(self) -> Normal {
        if self.r < 0.0 {
            Normal {
                ca: -self.ca,
                sa: -self.sa,
                r: -self.r,
            }
        } else {
            self
        }
    }

    /// The normal's angle α = atan2(sin α, cos α) in (−π, π] (atan2
    /// gives [−π, π]; −π is taken as π).
    #[inline]
    fn alpha(self) -> f32 {
        match atan2(self.sa, self.ca) {
            a if a <= -core::f32::consts::PI => core::f32::consts::PI,
            a => a,
        }
    }
}

/// Largest Gauss–Newton angle step (rad) rotated by the Taylor series of
/// [`rotate`]; its truncation error is below `0.25⁸/8! ≈ 4e-10`.
const TAYLOR_STEP: f32 = 0.25;

/// The unit normal `(ca, sa)` rotated by `delta` (rad), with `cos δ`,
/// `sin δ` from their Taylor series to the δ⁶ and δ⁷ terms for
/// `|δ| ≤` [`TAYLOR_STEP`], else from [`cos_sin`].
#[inline]
fn rotate(ca: f32, sa: f32, delta: f32) -> (f32, f32) {
    let (cd, sd) = if libm::fabsf(delta) <= TAYLOR_STEP {
        let d2 = delta * delta;
        let cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)));
        let sd = delta * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))));
        (cd, sd)
    } else {
        cos_sin(delta)
    };
    (ca * cd - sa * sd, sa * cd + ca * sd)
}

/// The Mahalanobis distance between two lines' parameters,
/// `Δᵀ(Σ₁ + Σ₂)⁻¹Δ` with `Δ = (α₂ − α₁ wrapped, r₂ − r₁)` (§7.6).
/// `None` if the summed covariance is not positive definite.
pub fn parameter_distance(l1: &Line, l2: &Line) -> Option<f32> {
    mahalanobis(&l1.cov.add(&l2.cov), l1, l2)
}

/// `Δᵀ cov⁻¹ Δ` with `Δ = (α₂ − α₁ wrapped, r₂ − r₁)`; `None` if `cov` is
/// not positive definite.
#[inline(never)] // one copy for §7.6 and §10 (e)
pub fn mahalanobis(cov: &Sym2, l1: &Line, l2: &Line) -> Option<f32> {
    let inv = cov.inverse_spd()?;
    let da = wrap_angle(l2.alpha - l1.alpha);
    let dr = l2.r - l1.r;
    Some(inv.quad(da, dr))
}
