//! Ground truth per scan, matching of extracted features to it, and the
//! accumulated figures (Nguyen et al., IROS 2005, plus Cramér–Rao and NEES).
//!
//! # True lines ([`TruePiece`])
//! A *piece* is a maximal run of consecutive beams whose noise-free hits lie
//! on one infinite line (one wall, or collinear walls meeting between two
//! beams). Two pieces of one line with at most `merge_gap_beams` (3) beams
//! between them are one piece, as ALGORITHM.md §7.6 merges them. A piece is
//! **detectable** with at least `min_points` (5) beams and an extent (first
//! to last hit) of at least `min_length` (0.1 m); it is **resolvable** if it
//! is detectable and an efficient estimator fitting all its beams would meet
//! the matching gates at three standard deviations (3·√CRB below both
//! gates) — a 0.2 m box face 3 m away at σ = 20 mm has a CRB of ~7° on α, so
//! no extractor can be held to a 5° gate on it.
//!
//! # Matching
//! An extracted line and a piece are a candidate pair if at least half of
//! the line's beam range lies on the piece's, `|Δα| ≤ 5°` and
//! `|Δr| ≤ 0.10 m` ([`Gates`]) — a line is a (α, r) feature, so a correct
//! line on part of a wall counts; how much of the piece it covers is
//! reported as *coverage*. Pairs are taken one-to-one, greedily by
//! `(Δα/5°)² + (Δr/0.1 m)²`. TruePos = matched resolvable pieces / resolvable
//! pieces. An unmatched line with half of its beams or more on arcs (curved
//! walls, pillars) is **neutral** — neither true nor false — if the
//! noise-free curve over its beams lies within χ²₁ 95 % of a straight line:
//! with the orthogonal least-squares line (α, r) through the noise-free hits
//! of its valid beams, every beam's range deviation `d_j − r / cos(φ_j − α)`
//! satisfies `(deviation / σ_j)² ≤ 3.841` ([`NEUTRAL_CHI2`]), σ_j the range
//! noise of the beam (σ, or with [`Gates::kappa`] > 0 the realistic model's
//! `√(σ² + (κ·d_j·tan θ_j)²)`, θ_j the incidence on the true surface): no
//! test on the beams can tell such a line from a wall. Beyond that it is
//! false. FalsePos = (extracted − matched − neutral) / (extracted −
//! neutral), where a line matched to any piece (resolvable or not) is not
//! false. Unmatched lines are classified ([`LineScore`]): neutral on an
//! arc, false on an arc, a split/duplicate of a matched piece, off (on a
//! piece but outside the gates), or mixed (no piece holds half of its
//! beams).
//!
//! # Errors against the Cramér–Rao bound
//! For each matched pair the CRB is `σ²(JᵀJ)⁻¹` of the *true* line over the
//! valid beams the extracted line used (its `first..=last`), with the range
//! model of §7 (with [`Gates::kappa`] > 0, the realistic sensor model's
//! per-beam noise `σ_j² = σ² + (κ·d_j·tan θ_j)²` instead: the information
//! `Σ J_j J_jᵀ / σ_j²`, [`crb_footprint`]). The figures are the sample standard deviations of Δα and Δr
//! (as Nguyen et al.) and the RMS of the normalised errors
//! `√mean(Δα²/CRB_αα)` and `√mean(Δr²/CRB_rr)` — 1 for an efficient,
//! unbiased extractor. NEES is `eᵀΣ⁻¹e` with the covariance the extractor
//! reports (χ²₂: mean 2, median 1.39, 99 % below 9.21).
//!
//! # Corners
//! True corners: visible vertices between two walls each hit by at least
//! `min_points` beams, with a folded angle of at least `min_corner_angle`
//! (30°). An extracted corner (any) within 0.10 m matches, one-to-one by
//! distance. Corner FalsePos counts unmatched well-conditioned corners.

use lms_core::Corner;
use lms_core::Line;
use lms_core::{Beam, Params};
use lms_scene::{wrap_angle, PolarLine, Scene, Surface, TrueScan};

/// Matching gates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gates {
    /// Largest |Δα| (rad).
    pub alpha: f64,
    /// Largest |Δr| (m).
    pub r: f64,
    /// Smallest fraction of the extracted line's beam range on the piece.
    pub overlap: f64,
    /// Largest distance of a matched corner (m).
    pub corner: f64,
    /// Footprint term of the CRB's per-beam noise (rad; the realistic
    /// model's κ): `σ_j² = σ² + (κ·d·tan θ)²`, θ the incidence (at most
    /// 85°). 0: σ for every beam.
    pub kappa: f64,
}

impl Default for Gates {
    fn default() -> Self {
        Gates {
            alpha: 5f64.to_radians(),
            r: 0.10,
            overlap: 0.5,
            corner: 0.10,
            kappa: 0.0,
        }
    }
}

/// A true line as the evaluation counts it (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruePiece {
    /// Normal direction (rad).
    pub alpha: f64,
    /// Distance from the sensor (m).
    pub r: f64,
    /// First beam.
    pub first: usize,
    /// Last beam (inclusive).
    pub last: usize,
    /// Beams hitting the line.
    pub beams: usize,
    /// Distance between the first and last hit (m).
    pub length: f64,
    /// At least `min_points` beams and `min_length`.
    pub detectable: bool,
    /// Detectable, and an efficient fit would meet the gates at 3σ.
    pub resolvable: bool,
}

/// A true corner as the evaluation counts it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerTruth {
    /// x (m), sensor frame.
    pub x: f64,
    /// y (m), sensor frame.
    pub y: f64,
    /// Folded angle (degrees).
    pub angle_deg: f64,
    /// Fractional beam index of the vertex.
    pub beam: f64,
}

/// The truth of one scan in the form the scoring needs.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanTruth {
    /// True lines.
    pub pieces: Vec<TruePiece>,
    /// True corners.
    pub corners: Vec<CornerTruth>,
    /// Per beam: the noise-free hit is on an arc.
    pub on_arc: Vec<bool>,
    /// Beam bearings (rad).
    pub bearings: Vec<f64>,
    /// Per beam: the noise-free range (m), `None` without a hit.
    pub ranges: Vec<Option<f64>>,
    /// Per beam: the incidence on the surface hit (rad, from its normal;
    /// 0 without a hit).
    pub incidence: Vec<f64>,
}

/// χ²₁ 95 %: an unmatched line on arcs whose noise-free hits lie within
/// this of a straight line (each beam's squared range deviation over its
/// σ²) is neutral.
pub const NEUTRAL_CHI2: f64 = 3.841;

/// `σ²(JᵀJ)⁻¹` of the line `(alpha, r)` seen at `bearings` with the range
/// model `d = r / cos(φ − α)`, as `[αα, αr, rr]`; `None` if singular.
pub fn crb(
    alpha: f64,
    r: f64,
    bearings: impl Iterator<Item = f64>,
    sigma: f64,
) -> Option<[f64; 3]> {
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for phi in bearings {
        let (s, co) = (phi - alpha).sin_cos();
        if co <= 1e-6 {
            continue;
        }
        let ja = -r * s / (co * co);
        let jr = 1.0 / co;
        a += ja * ja;
        b += ja * jr;
        c += jr * jr;
    }
    let det = a * c - b * b;
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    let v = sigma * sigma;
    Some([v * c / det, -v * b / det, v * a / det])
}

/// [`crb`] with the per-beam noise `σ_j² = σ² + (κ·d_j·tan θ_j)²` of a
/// footprint term `kappa` (rad): `(Σ J_j J_jᵀ / σ_j²)⁻¹`, θ_j = φ_j − α
/// capped at 85° (as `lms_scene::LmsModel`), d_j = r / cos θ_j. At
/// `kappa = 0` exactly [`crb`].
pub fn crb_footprint(
    alpha: f64,
    r: f64,
    bearings: impl Iterator<Item = f64>,
    sigma: f64,
    kappa: f64,
) -> Option<[f64; 3]> {
    if kappa == 0.0 {
        return crb(alpha, r, bearings, sigma);
    }
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for phi in bearings {
        let (s, co) = (phi - alpha).sin_cos();
        if co <= 1e-6 {
            continue;
        }
        let theta = (phi - alpha).abs().min(lms_scene::lms::MAX_INCIDENCE);
        let v = sigma * sigma + (kappa * (r / co) * theta.tan()).powi(2);
        let ja = -r * s / (co * co);
        let jr = 1.0 / co;
        a += ja * ja / v;
        b += ja * jr / v;
        c += jr * jr / v;
    }
    let det = a * c - b * b;
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    Some([c / det, -b / det, a / det])
}

/// `eᵀΣ⁻¹e` for `Σ = [[a, b], [b, c]]`; `None` unless Σ is positive definite.
pub fn nees2(e: [f64; 2], a: f64, b: f64, c: f64) -> Option<f64> {
    let det = a * c - b * b;
    if !(a > 0.0 && det > 0.0) {
        return None;
    }
    Some((c * e[0] * e[0] - 2.0 * b * e[0] * e[1] + a * e[1] * e[1]) / det)
}

/// The truth of a cast scan for the evaluation.
pub fn scan_truth(
    truth: &TrueScan,
    scene: &Scene,
    params: &Params,
    sigma: f64,
    gates: &Gates,
) -> ScanTruth {
    let bearings: Vec<f64> = truth.bearings.iter().collect();
    let on_arc: Vec<bool> = truth
        .hits
        .iter()
        .map(|h| h.is_some_and(|h| matches!(scene.surface(h.surface), Some(Surface::Arc(_)))))
        .collect();
    let ranges = truth.hits.iter().map(|h| h.map(|h| h.range)).collect();
    let incidence = truth
        .hits
        .iter()
        .zip(&bearings)
        .map(|(h, &phi)| h.map_or(0.0, |h| hit_incidence(truth, scene, &h, phi)))
        .collect();
    let pieces = true_pieces(truth, scene, params, &bearings, sigma, gates);
    ScanTruth {
        pieces,
        corners: true_corners(truth, params),
        on_arc,
        bearings,
        ranges,
        incidence,
    }
}

/// The incidence of the beam at bearing `phi` on the surface of its
/// noise-free `hit` (rad, between the beam and the surface normal).
fn hit_incidence(truth: &TrueScan, scene: &Scene, hit: &lms_scene::Hit, phi: f64) -> f64 {
    let normal = match scene.surface(hit.surface) {
        Some(Surface::Wall(w)) => {
            let e = truth.pose.to_sensor(w.b) - truth.pose.to_sensor(w.a);
            lms_scene::Point::new(-e.y, e.x)
        }
        Some(Surface::Arc(a)) => hit.point - truth.pose.to_sensor(a.center),
        None => return 0.0,
    };
    let n = normal.norm().max(1e-12);
    let dir = lms_scene::Point::polar(1.0, phi);
    (dir.dot(normal) / n).abs().min(1.0).acos()
}

/// The true lines: runs of consecutive beams on one wall's line, pieces of
/// one line at most `merge_gap_beams` apart merged (§7.6).
fn true_pieces(
    truth: &TrueScan,
    scene: &Scene,
    params: &Params,
    bearings: &[f64],
    sigma: f64,
    gates: &Gates,
) -> Vec<TruePiece> {
    let line_of = |id| match scene.surface(id) {
        Some(Surface::Wall(w)) => {
            PolarLine::through(truth.pose.to_sensor(w.a), truth.pose.to_sensor(w.b))
        }
        _ => None,
    };
    let same = |a: &PolarLine, b: &PolarLine| {
        wrap_angle(a.alpha - b.alpha).abs() < 1e-9 && (a.r - b.r).abs() < 1e-9
    };

    // Runs of consecutive beams on one line: (line, beams hitting it).
    let mut runs: Vec<(PolarLine, Vec<usize>)> = Vec::new();
    let mut open = false;
    for (j, h) in truth.hits.iter().enumerate() {
        let line = h.and_then(|h| line_of(h.surface));
        match line {
            Some(l) => {
                let extend = open
                    && runs
                        .last()
                        .is_some_and(|(rl, b)| same(rl, &l) && b.last() == Some(&(j - 1)));
                if extend {
                    if let Some(run) = runs.last_mut() {
                        run.1.push(j);
                    }
                } else {
                    runs.push((l, vec![j]));
                }
                open = true;
            }
            None => open = false,
        }
    }
    // Pieces of one line at most merge_gap_beams apart are one (§7.6).
    let gap = params.merge_gap_beams as usize;
    let mut merged: Vec<(PolarLine, Vec<usize>)> = Vec::new();
    for (l, beams) in runs {
        let first = beams[0];
        if let Some(prev) = merged
            .iter_mut()
            .rev()
            .find(|(pl, pb)| same(pl, &l) && pb.last().is_some_and(|&e| first <= e + 1 + gap))
        {
            prev.1.extend(beams);
        } else {
            merged.push((l, beams));
        }
    }
    merged
        .into_iter()
        .map(|(l, beams)| piece_of(truth, params, bearings, sigma, gates, l, &beams))
        .collect()
}

/// The piece of line `l` hit by `beams`.
fn piece_of(
    truth: &TrueScan,
    params: &Params,
    bearings: &[f64],
    sigma: f64,
    gates: &Gates,
    l: PolarLine,
    beams: &[usize],
) -> TruePiece {
    let (first, last) = (beams[0], beams[beams.len() - 1]);
    let point = |j: usize| truth.hits[j].map(|h| h.point).unwrap_or_default();
    let length = point(first).distance(point(last));
    let detectable =
        beams.len() >= params.min_points as usize && length >= params.min_length as f64;
    let resolvable = detectable
        && crb_footprint(
            l.alpha,
            l.r,
            beams.iter().map(|&j| bearings[j]),
            sigma,
            gates.kappa,
        )
        .is_some_and(|c| 3.0 * c[0].sqrt() < gates.alpha && 3.0 * c[2].sqrt() < gates.r);
    TruePiece {
        alpha: l.alpha,
        r: l.r,
        first,
        last,
        beams: beams.len(),
        length,
        detectable,
        resolvable,
    }
}

/// The true corners counted: visible, at least `min_corner_angle`, both
/// walls hit by at least `min_points` beams.
fn true_corners(truth: &TrueScan, params: &Params) -> Vec<CornerTruth> {
    let min_points = params.min_points as usize;
    truth
        .corners
        .iter()
        .filter(|c| {
            c.visible
                && c.angle_deg >= params.min_corner_angle_deg as f64
                && c.walls
                    .iter()
                    .all(|&w| truth.line(w).is_some_and(|l| l.beams >= min_points))
        })
        .map(|c| CornerTruth {
            x: c.point.x,
            y: c.point.y,
            angle_deg: c.angle_deg,
            beam: c.beam,
        })
        .collect()
}

/// The corner evidence of a scan: for each true corner, the largest `D`
/// of the windows around it on the **noise-free** ranges at noise `sigma`
/// (first pass, the core's window filter; `D ∝ 1/σ²` for q = 0). A corner
/// the first pass cannot break has a value well below τ.
pub fn corner_evidence(
    truth: &TrueScan,
    corners: &[CornerTruth],
    frame: &lms_core::Frame,
    sigma: f64,
) -> Vec<f64> {
    let filter =
        lms_core::pipeline::ekf::WindowFilter::new(frame.geometry().step, sigma as f32, 0.0);
    let r: Vec<Option<f32>> = truth
        .hits
        .iter()
        .map(|h| h.map(|h| h.range as f32))
        .collect();
    corners
        .iter()
        .map(|c| {
            let b = c.beam.floor() as isize;
            (b - 2..=b + 1)
                .filter_map(|i| {
                    let i = usize::try_from(i).ok()?;
                    let z = [*r.get(i)?, *r.get(i + 1)?, *r.get(i + 2)?];
                    let z = lms_core::maths::Vec3([z[0]?, z[1]?, z[2]?]);
                    filter.update(z).map(|e| e.mahalanobis as f64)
                })
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Errors of one matched line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairError {
    /// α̂ − α (rad, wrapped).
    pub d_alpha: f64,
    /// r̂ − r (m).
    pub d_r: f64,
    /// CRB of α over the beams used (rad²).
    pub crb_aa: f64,
    /// CRB of r over the beams used (m²).
    pub crb_rr: f64,
    /// NEES with the reported covariance (`NaN` if it is not positive definite).
    pub nees: f64,
    /// The piece is resolvable.
    pub resolvable: bool,
    /// Fraction of the piece's beam range covered by the line.
    pub coverage: f64,
    /// Index of the line among the extracted lines.
    pub line: usize,
    /// Index of the piece in [`ScanTruth::pieces`].
    pub piece: usize,
}

/// The lines of one scan against its truth.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LineScore {
    /// Detectable pieces.
    pub true_detectable: usize,
    /// Resolvable pieces.
    pub true_resolvable: usize,
    /// Detectable pieces matched.
    pub matched_detectable: usize,
    /// Resolvable pieces matched.
    pub matched_resolvable: usize,
    /// Extracted lines.
    pub extracted: usize,
    /// Extracted lines matched to any piece.
    pub matched: usize,
    /// Unmatched lines with half their beams or more on arcs whose
    /// noise-free hits lie within χ²₁ 95 % of a straight line (neutral:
    /// neither true nor false; left out of FalsePos).
    pub neutral_arc: usize,
    /// Unmatched lines with half their beams or more on arcs, not neutral
    /// (false).
    pub fp_arc: usize,
    /// Unmatched lines on a piece matched to another line (over-segmentation).
    pub fp_split: usize,
    /// Unmatched lines on an unmatched resolvable piece (outside the gates).
    pub fp_off: usize,
    /// Unmatched lines on a piece that is not resolvable (too short or too
    /// uncertain for the gates; clutter).
    pub fp_unresolvable: usize,
    /// Unmatched lines with no piece holding half of their beams.
    pub fp_mixed: usize,
    /// Missed resolvable pieces half or more of which lie in one segment that
    /// also holds 5 or more beams of another surface (a corner or jump that
    /// did not break; the segment's line is then rejected by χ² or wrong).
    pub missed_merged: usize,
    /// Missed resolvable pieces cut into segments each shorter than half of it.
    pub missed_fragmented: usize,
    /// Other missed resolvable pieces (a segment on it, but no line within the gates).
    pub missed_other: usize,
    /// Errors of the matched pairs.
    pub pairs: Vec<PairError>,
    /// Per piece: matched.
    pub piece_matched: Vec<bool>,
}

fn overlap(a: (usize, usize), b: (usize, usize)) -> usize {
    let lo = a.0.max(b.0);
    let hi = a.1.min(b.1);
    (hi + 1).saturating_sub(lo)
}

fn span(a: (usize, usize)) -> usize {
    a.1 + 1 - a.0
}

/// Match `lines` (extracted from a frame with these `beams`) to `truth`.
pub fn score_lines(
    truth: &ScanTruth,
    lines: &[Line],
    beams: &[Beam],
    sigma: f64,
    gates: &Gates,
) -> LineScore {
    let mut s = LineScore {
        true_detectable: truth.pieces.iter().filter(|p| p.detectable).count(),
        true_resolvable: truth.pieces.iter().filter(|p| p.resolvable).count(),
        extracted: lines.len(),
        ..LineScore::default()
    };
    let mut line_taken = vec![false; lines.len()];
    let mut piece_taken = vec![false; truth.pieces.len()];
    for (_, e, t) in candidates(truth, lines, gates) {
        if line_taken[e] || piece_taken[t] {
            continue;
        }
        line_taken[e] = true;
        piece_taken[t] = true;
        let (l, p) = (&lines[e], &truth.pieces[t]);
        s.matched += 1;
        s.matched_detectable += usize::from(p.detectable);
        s.matched_resolvable += usize::from(p.resolvable);
        let used = (l.first as usize..=l.last as usize)
            .filter(|&j| beams.get(j).is_some_and(|b| b.is_valid()))
            .filter_map(|j| truth.bearings.get(j).copied());
        let sigma_crb =
            crb_footprint(p.alpha, p.r, used, sigma, gates.kappa).unwrap_or([f64::NAN; 3]);
        let e2 = [wrap_angle(l.alpha as f64 - p.alpha), l.r as f64 - p.r];
        let nees = nees2(e2, l.cov.a as f64, l.cov.b as f64, l.cov.c as f64).unwrap_or(f64::NAN);
        let coverage = overlap((l.first as usize, l.last as usize), (p.first, p.last)) as f64
            / span((p.first, p.last)) as f64;
        s.pairs.push(PairError {
            coverage,
            line: e,
            piece: t,
            d_alpha: e2[0],
            d_r: e2[1],
            crb_aa: sigma_crb[0],
            crb_rr: sigma_crb[2],
            nees,
            resolvable: p.resolvable,
        });
    }
    for (e, l) in lines.iter().enumerate() {
        if !line_taken[e] {
            let c = classify_unmatched(truth, l, beams, &piece_taken, sigma, gates);
            *s.count_of(c) += 1;
        }
    }
    s.piece_matched = piece_taken;
    s
}

/// The candidate pairs `(cost, line, piece)` within the gates, cheapest first.
fn candidates(truth: &ScanTruth, lines: &[Line], gates: &Gates) -> Vec<(f64, usize, usize)> {
    let mut out: Vec<(f64, usize, usize)> = Vec::new();
    for (e, l) in lines.iter().enumerate() {
        let le = (l.first as usize, l.last as usize);
        for (t, p) in truth.pieces.iter().enumerate() {
            let o = overlap(le, (p.first, p.last)) as f64;
            if o < gates.overlap * span(le) as f64 {
                continue;
            }
            let da = wrap_angle(l.alpha as f64 - p.alpha);
            let dr = l.r as f64 - p.r;
            if da.abs() <= gates.alpha && dr.abs() <= gates.r {
                out.push(((da / gates.alpha).powi(2) + (dr / gates.r).powi(2), e, t));
            }
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// What an unmatched line is (see [`LineScore`]'s counts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unmatched {
    /// On arcs, within χ²₁ 95 % of a straight line: neutral.
    NeutralArc,
    /// On arcs, beyond it: false.
    Arc,
    /// On a piece matched to another line.
    Split,
    /// On an unmatched resolvable piece, outside the gates.
    Off,
    /// On a piece that is not resolvable.
    Unresolvable,
    /// No piece holds half of its beams.
    Mixed,
}

impl LineScore {
    /// The count of unmatched lines of class `c`.
    pub fn count_of(&mut self, c: Unmatched) -> &mut usize {
        match c {
            Unmatched::NeutralArc => &mut self.neutral_arc,
            Unmatched::Arc => &mut self.fp_arc,
            Unmatched::Split => &mut self.fp_split,
            Unmatched::Off => &mut self.fp_off,
            Unmatched::Unresolvable => &mut self.fp_unresolvable,
            Unmatched::Mixed => &mut self.fp_mixed,
        }
    }
}

/// Classify the unmatched line `l` (`piece_taken`: the pieces matched).
pub fn classify_unmatched(
    truth: &ScanTruth,
    l: &Line,
    beams: &[Beam],
    piece_taken: &[bool],
    sigma: f64,
    gates: &Gates,
) -> Unmatched {
    let le = (l.first as usize, l.last as usize);
    let n = span(le) as f64;
    let arc = truth
        .on_arc
        .get(le.0..=le.1)
        .map_or(0, |a| a.iter().filter(|&&x| x).count());
    if arc as f64 >= 0.5 * n {
        let used = (le.0..=le.1).filter(|&j| beams.get(j).is_some_and(|b| b.is_valid()));
        let chi2 = straightness_chi2(truth, used, sigma, gates.kappa);
        return if chi2.is_some_and(|c| c <= NEUTRAL_CHI2) {
            Unmatched::NeutralArc
        } else {
            Unmatched::Arc
        };
    }
    let holder = truth
        .pieces
        .iter()
        .enumerate()
        .find(|(_, p)| overlap(le, (p.first, p.last)) as f64 >= 0.5 * n);
    match holder {
        Some((t, _)) if piece_taken.get(t).copied().unwrap_or(false) => Unmatched::Split,
        Some((_, p)) if p.resolvable => Unmatched::Off,
        Some(_) => Unmatched::Unresolvable,
        None => Unmatched::Mixed,
    }
}

/// How far the noise-free hits of `beams` are from a straight line: the
/// largest `(d_j − r / cos(φ_j − α))² / σ_j²` over the beams with a hit,
/// (α, r) the orthogonal least-squares line through the hits, σ_j² =
/// `σ² + (κ·d_j·tan θ_j)²` (θ_j the incidence, at most 85°; κ = `kappa`).
/// `None` with fewer than two hits; infinite if a beam runs parallel to
/// the line.
pub fn straightness_chi2(
    truth: &ScanTruth,
    beams: impl Iterator<Item = usize>,
    sigma: f64,
    kappa: f64,
) -> Option<f64> {
    let hits: Vec<(usize, f64, f64)> = beams
        .filter_map(|j| Some((j, *truth.bearings.get(j)?, (*truth.ranges.get(j)?)?)))
        .collect();
    if hits.len() < 2 {
        return None;
    }
    let (alpha, r) = orthogonal_fit(
        hits.iter()
            .map(|&(_, phi, d)| (d * phi.cos(), d * phi.sin())),
    );
    let mut worst: f64 = 0.0;
    for &(j, phi, d) in &hits {
        let c = (phi - alpha).cos();
        if c <= 1e-6 {
            return Some(f64::INFINITY);
        }
        let theta = truth
            .incidence
            .get(j)
            .map_or(0.0, |t| t.abs().min(lms_scene::lms::MAX_INCIDENCE));
        let var = sigma * sigma + (kappa * d * theta.tan()).powi(2);
        worst = worst.max((d - r / c).powi(2) / var);
    }
    Some(worst)
}

/// Mean of the points `pts` (the origin for none).
pub fn centroid(pts: &[[f64; 2]]) -> [f64; 2] {
    let n = pts.len().max(1) as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p[0] / n, b + p[1] / n));
    [mx, my]
}

/// Total-least-squares line `(α, ρ)` through `pts`.
pub fn tls(pts: &[[f64; 2]]) -> (f64, f64) {
    let [mx, my] = centroid(pts);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in pts {
        let (dx, dy) = (p[0] - mx, p[1] - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    // Normal = eigenvector of the smaller eigenvalue of the scatter matrix.
    let alpha = 0.5 * (-2.0 * sxy).atan2(syy - sxx);
    let rho = mx * alpha.cos() + my * alpha.sin();
    (alpha, rho)
}

/// [`tls`] through `points` (at least two) as `x·cos α + y·sin α = r`
/// with r ≥ 0.
pub fn orthogonal_fit(points: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    let p: Vec<[f64; 2]> = points.map(|(x, y)| [x, y]).collect();
    let (alpha, r) = tls(&p);
    if r < 0.0 {
        (wrap_angle(alpha + std::f64::consts::PI), -r)
    } else {
        (alpha, r)
    }
}

/// Classify the resolvable pieces no line matched, from the `segments`
/// (beam ranges) the extractor fitted; adds to `score`'s `missed_*`.
pub fn classify_misses(
    truth: &ScanTruth,
    matched: &[bool],
    segments: &[(usize, usize)],
    score: &mut LineScore,
) {
    for (t, p) in truth.pieces.iter().enumerate() {
        if !p.resolvable || matched.get(t).copied().unwrap_or(false) {
            continue;
        }
        let lt = (p.first, p.last);
        let half = 0.5 * span(lt) as f64;
        let holder = segments.iter().find(|&&sg| overlap(sg, lt) as f64 >= half);
        match holder {
            Some(&sg) => {
                let others = span(sg) - overlap(sg, lt);
                if others >= 5 {
                    score.missed_merged += 1;
                } else {
                    score.missed_other += 1;
                }
            }
            None => score.missed_fragmented += 1,
        }
    }
}

/// Errors of one matched corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerError {
    /// Distance from the true corner (m).
    pub dist: f64,
    /// NEES with the reported covariance (`NaN` if not positive definite).
    pub nees: f64,
    /// The extracted corner is flagged well-conditioned.
    pub well_conditioned: bool,
}

/// The corners of one scan against its truth.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerScore {
    /// True corners counted.
    pub true_corners: usize,
    /// True corners matched.
    pub matched: usize,
    /// Extracted well-conditioned corners.
    pub extracted_wc: usize,
    /// Extracted well-conditioned corners matched.
    pub matched_wc: usize,
    /// Errors of the matched corners.
    pub pairs: Vec<CornerError>,
}

/// Match extracted `corners` to the true ones, one-to-one by distance.
pub fn score_corners(truth: &ScanTruth, corners: &[Corner], gates: &Gates) -> CornerScore {
    let mut s = CornerScore {
        true_corners: truth.corners.len(),
        extracted_wc: corners.iter().filter(|c| c.well_conditioned).count(),
        ..CornerScore::default()
    };
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for (e, c) in corners.iter().enumerate() {
        for (t, tc) in truth.corners.iter().enumerate() {
            let d = (c.x as f64 - tc.x).hypot(c.y as f64 - tc.y);
            if d <= gates.corner {
                candidates.push((d, e, t));
            }
        }
    }
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut ct = vec![false; corners.len()];
    let mut tt = vec![false; truth.corners.len()];
    for &(d, e, t) in &candidates {
        if ct[e] || tt[t] {
            continue;
        }
        ct[e] = true;
        tt[t] = true;
        let c = &corners[e];
        let tc = &truth.corners[t];
        let err = [c.x as f64 - tc.x, c.y as f64 - tc.y];
        s.matched += 1;
        s.matched_wc += usize::from(c.well_conditioned);
        s.pairs.push(CornerError {
            dist: d,
            nees: nees2(err, c.cov.a as f64, c.cov.b as f64, c.cov.c as f64).unwrap_or(f64::NAN),
            well_conditioned: c.well_conditioned,
        });
    }
    s
}

/// The synthetic goal on TruePos (σ = 10 and 20 mm).
pub const TRUE_POS_GOAL: f64 = 0.95;
/// The synthetic goal on σΔα / CRB and σΔr / CRB.
pub const CRB_GOAL: f64 = 1.2;

/// The synthetic goal on FalsePos at range noise `sigma` (m): 0.02 up to
/// σ = 10 mm (below 15 mm), 0.05 from σ = 20 mm (15 mm and above).
pub fn false_pos_goal(sigma: f64) -> f64 {
    if sigma < 0.015 {
        0.02
    } else {
        0.05
    }
}

/// A normalised squared error above this (χ²₁ 99.9 %) is a gross error.
pub const OUTLIER: f64 = 10.83;

/// Scores accumulated over many scans.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tally {
    /// Scans.
    pub scans: usize,
    /// Line counts and errors, summed.
    pub lines: LineScore,
    /// Corner counts and errors, summed.
    pub corners: CornerScore,
    /// Segments before line fitting, summed.
    pub segments: usize,
    /// Extraction time, summed (s).
    pub seconds: f64,
}

impl Tally {
    /// Add one scan.
    pub fn add(&mut self, l: &LineScore, c: &CornerScore, segments: usize, seconds: f64) {
        self.scans += 1;
        self.add_counts(l, c, segments, seconds);
    }

    /// Add everything of `o`.
    pub fn merge(&mut self, o: &Tally) {
        self.scans += o.scans;
        self.add_counts(&o.lines, &o.corners, o.segments, o.seconds);
    }

    fn add_counts(&mut self, l: &LineScore, c: &CornerScore, segments: usize, seconds: f64) {
        let t = &mut self.lines;
        t.true_detectable += l.true_detectable;
        t.true_resolvable += l.true_resolvable;
        t.matched_detectable += l.matched_detectable;
        t.matched_resolvable += l.matched_resolvable;
        t.extracted += l.extracted;
        t.matched += l.matched;
        t.neutral_arc += l.neutral_arc;
        t.fp_arc += l.fp_arc;
        t.fp_split += l.fp_split;
        t.fp_off += l.fp_off;
        t.fp_unresolvable += l.fp_unresolvable;
        t.missed_merged += l.missed_merged;
        t.missed_fragmented += l.missed_fragmented;
        t.missed_other += l.missed_other;
        t.fp_mixed += l.fp_mixed;
        t.pairs.extend_from_slice(&l.pairs);
        let k = &mut self.corners;
        k.true_corners += c.true_corners;
        k.matched += c.matched;
        k.extracted_wc += c.extracted_wc;
        k.matched_wc += c.matched_wc;
        k.pairs.extend_from_slice(&c.pairs);
        self.segments += segments;
        self.seconds += seconds;
    }

    /// The figures.
    pub fn summary(&self) -> Summary {
        let l = &self.lines;
        let pairs: Vec<&PairError> = l.pairs.iter().filter(|p| p.resolvable).collect();
        let da: Vec<f64> = pairs.iter().map(|p| p.d_alpha).collect();
        let dr: Vec<f64> = pairs.iter().map(|p| p.d_r).collect();
        let na: Vec<f64> = pairs
            .iter()
            .map(|p| p.d_alpha * p.d_alpha / p.crb_aa)
            .collect();
        let nr: Vec<f64> = pairs.iter().map(|p| p.d_r * p.d_r / p.crb_rr).collect();
        let nees: Vec<f64> = pairs.iter().map(|p| p.nees).collect();
        let gross = |a: &f64, r: &f64| *a > OUTLIER || *r > OUTLIER;
        let outliers = na.iter().zip(&nr).filter(|(a, r)| gross(a, r)).count();
        let na_in: Vec<f64> = na
            .iter()
            .zip(&nr)
            .filter(|(a, r)| !gross(a, r))
            .map(|(a, _)| *a)
            .collect();
        let nr_in: Vec<f64> = na
            .iter()
            .zip(&nr)
            .filter(|(a, r)| !gross(a, r))
            .map(|(_, r)| *r)
            .collect();
        let cover: Vec<f64> = pairs.iter().map(|p| p.coverage).collect();
        let k = &self.corners;
        let cd: Vec<f64> = k.pairs.iter().map(|p| p.dist * p.dist).collect();
        let cn: Vec<f64> = k.pairs.iter().map(|p| p.nees).collect();
        let scans = self.scans.max(1) as f64;
        Summary {
            scans: self.scans,
            true_pos: ratio(l.matched_resolvable, l.true_resolvable),
            true_pos_detectable: ratio(l.matched_detectable, l.true_detectable),
            false_pos: ratio(
                l.extracted - l.matched - l.neutral_arc,
                l.extracted - l.neutral_arc,
            ),
            neutral: ratio(l.neutral_arc, l.extracted),
            false_pos_no_arc: ratio(
                l.extracted - l.matched - l.neutral_arc - l.fp_arc,
                l.extracted - l.neutral_arc - l.fp_arc,
            ),
            sd_alpha: std_dev(&da),
            sd_r: std_dev(&dr),
            crb_alpha: mean(&na).sqrt(),
            crb_r: mean(&nr).sqrt(),
            outliers: ratio(outliers, na.len()),
            crb_alpha_inliers: mean(&na_in).sqrt(),
            crb_r_inliers: mean(&nr_in).sqrt(),
            matched_pairs: pairs.len(),
            nees_line: mean(&nees),
            nees_line_median: median(&nees),
            nees_line_inside: inside(&nees, 9.21),
            coverage: mean(&cover),
            corner_rate: ratio(k.matched, k.true_corners),
            corner_rms: mean(&cd).sqrt(),
            corner_nees: mean(&cn),
            corner_nees_median: median(&cn),
            corner_nees_inside: inside(&cn, 9.21),
            corner_false_pos: ratio(k.extracted_wc - k.matched_wc, k.extracted_wc),
            true_per_scan: l.true_resolvable as f64 / scans,
            lines_per_scan: l.extracted as f64 / scans,
            segments_per_scan: self.segments as f64 / scans,
            ms_per_scan: 1e3 * self.seconds / scans,
        }
    }
}

/// The figures of a [`Tally`] (NaN where undefined).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    /// Scans.
    pub scans: usize,
    /// Matched resolvable / resolvable pieces.
    pub true_pos: f64,
    /// Matched detectable / detectable pieces.
    pub true_pos_detectable: f64,
    /// False / (extracted − neutral) lines: unmatched lines are false
    /// unless neutral (on arcs within χ²₁ 95 % of a straight line).
    pub false_pos: f64,
    /// Neutral lines / extracted lines.
    pub neutral: f64,
    /// A diagnostic: as `false_pos` with every line on arcs (neutral or
    /// false) left out of both counts — FalsePos off curved walls.
    pub false_pos_no_arc: f64,
    /// Standard deviation of Δα over matched resolvable pairs (rad).
    pub sd_alpha: f64,
    /// Standard deviation of Δr (m).
    pub sd_r: f64,
    /// `√mean(Δα²/CRB_αα)`.
    pub crb_alpha: f64,
    /// `√mean(Δr²/CRB_rr)`.
    pub crb_r: f64,
    /// Fraction of matched resolvable pairs with `Δα²/CRB_αα` or
    /// `Δr²/CRB_rr` above 10.83 (χ²₁, 99.9 %): gross errors.
    pub outliers: f64,
    /// `√mean(Δα²/CRB_αα)` without the gross errors.
    pub crb_alpha_inliers: f64,
    /// `√mean(Δr²/CRB_rr)` without the gross errors.
    pub crb_r_inliers: f64,
    /// Matched resolvable pairs.
    pub matched_pairs: usize,
    /// Mean NEES of matched lines.
    pub nees_line: f64,
    /// Median NEES of matched lines.
    pub nees_line_median: f64,
    /// Fraction of line NEES ≤ 9.21.
    pub nees_line_inside: f64,
    /// Mean fraction of a matched resolvable piece's beams covered by its line.
    pub coverage: f64,
    /// Matched / true corners.
    pub corner_rate: f64,
    /// RMS distance of matched corners (m).
    pub corner_rms: f64,
    /// Mean corner NEES.
    pub corner_nees: f64,
    /// Median corner NEES.
    pub corner_nees_median: f64,
    /// Fraction of corner NEES ≤ 9.21.
    pub corner_nees_inside: f64,
    /// Unmatched / extracted well-conditioned corners.
    pub corner_false_pos: f64,
    /// Resolvable pieces per scan.
    pub true_per_scan: f64,
    /// Extracted lines per scan.
    pub lines_per_scan: f64,
    /// Segments per scan.
    pub segments_per_scan: f64,
    /// Extraction time per scan (ms).
    pub ms_per_scan: f64,
}

/// `a / b`, NaN for `b = 0`.
pub fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

/// Mean of the finite values (NaN if none).
pub fn mean(v: &[f64]) -> f64 {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        f64::NAN
    } else {
        f.iter().sum::<f64>() / f.len() as f64
    }
}

/// Sample standard deviation of the finite values (NaN if fewer than two).
pub fn std_dev(v: &[f64]) -> f64 {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.len() < 2 {
        return f64::NAN;
    }
    let m = f.iter().sum::<f64>() / f.len() as f64;
    (f.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (f.len() - 1) as f64).sqrt()
}

/// Median of the finite values (NaN if none).
pub fn median(v: &[f64]) -> f64 {
    let mut f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        return f64::NAN;
    }
    f.sort_by(f64::total_cmp);
    let n = f.len();
    if n % 2 == 1 {
        f[n / 2]
    } else {
        0.5 * (f[n / 2 - 1] + f[n / 2])
    }
}

/// Fraction of the values (NaN counted as outside) at or below `limit`.
pub fn inside(v: &[f64], limit: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.iter().filter(|&&x| x <= limit).count() as f64 / v.len() as f64
}
