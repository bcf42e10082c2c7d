//! An independent `f64` reference of `docs/ALGORITHM.md` v3, written from
//! the specification alone: it shares no code with `lms-core`.
//!
//! It covers §1's usable beams (the range limit), §2–§6 (the windows of
//! consecutive beams or, in the interleaved modes, of one mirror turn; the
//! filter; the Jacobi smoothing passes; the segmentation with its segment
//! ends at every stride), the line fit of §7.1–7.5 (footprint weights, the
//! turns' offsets in χ², covariance, endpoints) and the intersection of §8.
//! It does not decide which segments are split, merged or dropped (§7
//! split before reject, the gates, the merges, the arcs): the agreement
//! tests take those decisions from the core and check the fit of every line
//! and the corner of every pair the core reports.
//!
//! Where the core works with a closed-form symmetric 3×3 inverse and the
//! zero-diagonal structure of the Jacobian written out term by term, this
//! reference builds the full 3×3 matrices (`F`, `P̂ = F·P⁻·Fᵀ + Q`,
//! `S = P̂ + R`), solves `S·u = v` and `S·X = P̂` by Gaussian elimination with
//! partial pivoting, and forms the gain `K = P̂·S⁻¹ = Xᵀ` explicitly. Its fit
//! updates the angle α itself where the core rotates a unit normal, takes
//! the total-least-squares start from `atan2` where the core uses half-angle
//! formulas, and removes the turns' offsets as `Σ_t W_t·(ē_t − ē)²`; its
//! corner covariance is a matrix product `J·Σ·Jᵀ` where the core sums two
//! rank-one terms. The formulations are algebraically equal, so any
//! disagreement beyond rounding is a bug in one of them.
//!
//! Everything here is plain `f64` with the standard library's
//! transcendentals; speed and bit-reproducibility are not goals.

/// A 3×3 matrix, row-major.
pub type Mat3 = [[f64; 3]; 3];

/// Bearing geometry: `phi_j = first + j·step` (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefGeometry {
    /// Bearing of beam 0 (rad).
    pub first: f64,
    /// Angle between beams, `gamma` (rad).
    pub step: f64,
}

impl RefGeometry {
    /// Bearing of beam `j` (rad).
    pub fn bearing(&self, j: usize) -> f64 {
        self.first + j as f64 * self.step
    }
}

/// The parameters the reference follows: the defaults of
/// `docs/ALGORITHM.md` v3 (§3–§7) and the switches of the parts it covers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefParams {
    /// Range noise standard deviation (m).
    pub sigma: f64,
    /// Process noise (m²).
    pub q: f64,
    /// Segmentation gate on `D`.
    pub tau: f64,
    /// Smallest segment kept (points).
    pub min_points: usize,
    /// A beam whose range is at or beyond this (m) takes part in nothing.
    pub max_range: f64,
    /// Footprint term κ of the fits' range noise (rad; 0: every beam `sigma`).
    pub footprint: f64,
    /// Windows of one mirror turn in the interleaved modes (v3 §2);
    /// `false`: windows of consecutive beams in every mode.
    pub same_turn_windows: bool,
    /// The fits' χ² allows one offset per interleaved turn (v3 §7.3).
    pub turn_offsets: bool,
}

impl Default for RefParams {
    /// The defaults of `docs/ALGORITHM.md` v3.
    fn default() -> Self {
        RefParams {
            sigma: 0.005,
            q: 0.0,
            tau: 9.0,
            min_points: 5,
            max_range: 81.83,
            footprint: 0.003,
            same_turn_windows: true,
            turn_offsets: true,
        }
    }
}

/// Mirror turns a scan of bearing step `step` (rad) interleaves: 2 at 0.5°,
/// 4 at 0.25°, else 1 (v3 §1).
pub fn interleaved_turns(step: f64) -> usize {
    let turns = (std::f64::consts::PI / 180.0 / step).round();
    if turns == 2.0 || turns == 4.0 {
        turns as usize
    } else {
        1
    }
}

/// The window stride of v3 §2: the interleaved turns with same-turn
/// windows, else 1.
pub fn window_stride(step: f64, params: &RefParams) -> usize {
    if params.same_turn_windows {
        interleaved_turns(step)
    } else {
        1
    }
}

/// Usable beams (v3 §1): valid and below `max_range`.
pub fn usable(ranges: &[f64], valid: &[bool], max_range: f64) -> Vec<bool> {
    ranges
        .iter()
        .zip(valid)
        .map(|(&d, &v)| v && d < max_range)
        .collect()
}

/// `k = 2·cos(gamma)`.
pub fn k_of(step: f64) -> f64 {
    2.0 * step.cos()
}

/// §2: predictions `f(z)` and the full Jacobian `F = ∂f/∂z` for a window
/// `z = (a, b, c)`; `None` when the window is invalid (a prediction behind
/// the sensor: `k·c − b <= 0` or `k·a − b <= 0`).
pub fn predict(z: [f64; 3], k: f64) -> Option<([f64; 3], Mat3)> {
    let [a, b, c] = z;
    let e1 = k * c - b;
    let e3 = k * a - b;
    if e1 <= 0.0 || e3 <= 0.0 {
        return None;
    }
    let s = a + c; // corrected eq. 7
    let f = [b * c / e1, k * a * c / s, a * b / e3];
    let jac = [
        [0.0, k * c * c / (e1 * e1), -(b * b) / (e1 * e1)],
        [k * c * c / (s * s), 0.0, k * a * a / (s * s)],
        [-(b * b) / (e3 * e3), k * a * a / (e3 * e3), 0.0],
    ];
    Some((f, jac))
}

fn mat_mul(x: &Mat3, y: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|m| x[i][m] * y[m][j]).sum();
        }
    }
    out
}

fn transpose(x: &Mat3) -> Mat3 {
    let mut t = [[0.0; 3]; 3];
    for (i, row) in x.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            t[j][i] = v;
        }
    }
    t
}

/// Solve `A·X = B` for `X` (3×3 `A`, `cols` right-hand sides stored as the
/// columns of `B`) by Gaussian elimination with partial pivoting. `None` if
/// `A` is singular (a zero pivot) or the result is not finite.
pub fn solve3(a: &Mat3, b: &[[f64; 3]]) -> Option<Vec<[f64; 3]>> {
    // Augmented rows: [A | b_0 ... b_{m-1}], the right-hand sides as columns.
    let m = b.len();
    let mut rows: Vec<Vec<f64>> = (0..3)
        .map(|i| {
            let mut r = a[i].to_vec();
            r.extend(b.iter().map(|col| col[i]));
            r
        })
        .collect();
    for p in 0..3 {
        let pivot = (p..3).max_by(|&x, &y| rows[x][p].abs().total_cmp(&rows[y][p].abs()))?;
        if rows[pivot][p] == 0.0 || !rows[pivot][p].is_finite() {
            return None;
        }
        rows.swap(p, pivot);
        let pivot_row = rows[p].clone();
        for row in rows.iter_mut().skip(p + 1) {
            let factor = row[p] / pivot_row[p];
            for (x, &y) in row.iter_mut().zip(&pivot_row).skip(p) {
                *x -= factor * y;
            }
        }
    }
    let mut out = vec![[0.0; 3]; m];
    for (col, x) in out.iter_mut().enumerate() {
        for i in (0..3).rev() {
            let mut acc = rows[i][3 + col];
            for j in i + 1..3 {
                acc -= rows[i][j] * x[j];
            }
            x[i] = acc / rows[i][i];
        }
        if x.iter().any(|v| !v.is_finite()) {
            return None;
        }
    }
    Some(out)
}

/// Result of the per-window filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefWindow {
    /// Mahalanobis distance `D = vᵀ·S⁻¹·v`.
    pub d: f64,
    /// Updated estimates `x⁺` of the window's three ranges (m).
    pub posterior: [f64; 3],
}

/// §3: the per-window EKF on a window of valid ranges. `None` for an
/// invalid window (§2) or a singular `S`.
pub fn ekf_window(z: [f64; 3], k: f64, sigma: f64, q: f64) -> Option<RefWindow> {
    let (x_hat, f) = predict(z, k)?;
    let var = sigma * sigma;
    let p_minus: Mat3 = [[var, 0.0, 0.0], [0.0, var, 0.0], [0.0, 0.0, var]];
    let mut p_hat = mat_mul(&mat_mul(&f, &p_minus), &transpose(&f));
    for (i, row) in p_hat.iter_mut().enumerate() {
        row[i] += q;
    }
    let mut s = p_hat;
    for (i, row) in s.iter_mut().enumerate() {
        row[i] += var; // + R
    }
    let v = [z[0] - x_hat[0], z[1] - x_hat[1], z[2] - x_hat[2]];
    // One elimination for S⁻¹·v and S⁻¹·P̂ (the columns of P̂).
    let p_cols = transpose(&p_hat);
    let rhs = [v, p_cols[0], p_cols[1], p_cols[2]];
    let sol = solve3(&s, &rhs)?;
    let u = sol[0];
    let d: f64 = (0..3).map(|i| v[i] * u[i]).sum();
    // X = S⁻¹·P̂ has columns sol[1..4]; K = P̂·S⁻¹ = (S⁻¹·P̂)ᵀ = Xᵀ, so row i
    // of K is column i of X.
    let k_gain: Mat3 = [sol[1], sol[2], sol[3]];
    let mut posterior = x_hat;
    for (i, x) in posterior.iter_mut().enumerate() {
        *x += (0..3).map(|j| k_gain[i][j] * v[j]).sum::<f64>();
    }
    if !d.is_finite() || posterior.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some(RefWindow { d, posterior })
}

/// The smoothing weight of eq. 11, `w = exp(−D/2)`.
pub fn weight(d: f64) -> f64 {
    (-0.5 * d).exp()
}

/// §2–4: one Jacobi pass with windows of stride `stride` (window `i` is
/// beams `i, i + stride, i + 2·stride`, its filter built for the angle
/// `stride·step`). `usable` says which beams take part (v3 §1); a window
/// takes part only if every beam from its first to its last does. Returns
/// the new ranges and `D` of the `n − 2` windows (`+inf` where invalid, and
/// for the windows `n − 2·stride … n − 3`, which do not exist). Beams that
/// are not usable are never modified.
pub fn smoothing_pass(
    ranges: &[f64],
    usable: &[bool],
    step: f64,
    stride: usize,
    params: &RefParams,
) -> (Vec<f64>, Vec<f64>) {
    let n = ranges.len();
    let s = stride.max(1);
    let k = k_of(s as f64 * step);
    let windows = n.saturating_sub(2);
    // Each window once per pass, all from the previous pass's ranges.
    let est: Vec<Option<RefWindow>> = (0..windows)
        .map(|i| {
            let last = i + 2 * s;
            if last < n && usable[i..=last].iter().all(|&u| u) {
                ekf_window(
                    [ranges[i], ranges[i + s], ranges[last]],
                    k,
                    params.sigma,
                    params.q,
                )
            } else {
                None
            }
        })
        .collect();
    let d: Vec<f64> = est
        .iter()
        .map(|e| e.map_or(f64::INFINITY, |e| e.d))
        .collect();
    let mut out = ranges.to_vec();
    for j in 0..n {
        if !usable[j] {
            continue;
        }
        // Windows i = j, j − s, j − 2s, in that order; point j is member
        // (j − i)/s of window i.
        let mut wsum = 0.0;
        let mut xsum = 0.0;
        for member in 0..3 {
            let Some(i) = j.checked_sub(member * s) else {
                break;
            };
            if let Some(Some(e)) = est.get(i) {
                let w3 = weight(e.d) / 3.0;
                wsum += w3;
                xsum += w3 * e.posterior[member];
            }
        }
        out[j] = (1.0 - wsum) * ranges[j] + xsum;
    }
    (out, d)
}

/// §5: `passes` Jacobi passes from the raw `ranges` (beams usable by
/// [`usable`] on the raw ranges, windows of [`window_stride`]); returns, per
/// pass, the ranges after it and `D` of that pass (index 0 = pass 1).
pub fn smooth(
    ranges: &[f64],
    valid: &[bool],
    step: f64,
    params: &RefParams,
    passes: usize,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let ok = usable(ranges, valid, params.max_range);
    let stride = window_stride(step, params);
    let mut out = Vec::with_capacity(passes);
    let mut current = ranges.to_vec();
    for _ in 0..passes {
        let (next, d) = smoothing_pass(&current, &ok, step, stride, params);
        out.push((next.clone(), d));
        current = next;
    }
    out
}

/// A segment: points `first..=last`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RefSegment {
    /// First beam.
    pub first: usize,
    /// Last beam (inclusive).
    pub last: usize,
}

/// Does window `i` with distance `d` break (§6)? Invalid (`+inf`) or `D >= tau`.
pub fn breaks(d: f64, tau: f64) -> bool {
    !d.is_finite() || d >= tau
}

/// §6 with windows of stride 1: segments (maximal runs of non-breaking
/// windows `i..=k` covering points `i..=k+2`, dropping those with fewer than
/// `min_points` points) and edge points (middle points of breaking valid
/// windows).
pub fn segment(d: &[f64], tau: f64, min_points: usize) -> (Vec<RefSegment>, Vec<usize>) {
    segment_strided(d, 1, tau, min_points)
}

/// v3 §6 for windows of stride `s` (window `i`: beams `i, i+s, i+2s`):
/// the maximal runs of non-breaking windows are found first; a run of
/// windows `a..=b` needs `max(1, min_points − 2)` windows at `s = 1` and
/// `max(1, min_points − 3)` at `s > 1`; a run that has them covers the
/// beams `a ..= b + 2s`, its first beam raised to the last beam of the
/// previous segment kept, its last lowered to `a' + s − 1` for the next
/// run `a'..` (kept or not); it is kept if it then holds `min_points`
/// beams. Edge points: the middle beams `i + s` of breaking valid windows.
pub fn segment_strided(
    d: &[f64],
    s: usize,
    tau: f64,
    min_points: usize,
) -> (Vec<RefSegment>, Vec<usize>) {
    let s = s.max(1);
    let edges: Vec<usize> = d
        .iter()
        .enumerate()
        .filter(|(_, &x)| x.is_finite() && x >= tau)
        .map(|(i, _)| i + s)
        .collect();
    // Runs of non-breaking windows, inclusive.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut i = 0;
    while i < d.len() {
        if breaks(d[i], tau) {
            i += 1;
            continue;
        }
        let start = i;
        while i < d.len() && !breaks(d[i], tau) {
            i += 1;
        }
        runs.push((start, i - 1));
    }
    let spare = if s > 1 { 3 } else { 2 };
    let needed = min_points.saturating_sub(spare).max(1);
    let mut segments: Vec<RefSegment> = Vec::new();
    for (r, &(a, b)) in runs.iter().enumerate() {
        if b + 1 - a < needed {
            continue;
        }
        let mut first = a;
        if let Some(prev) = segments.last() {
            first = first.max(prev.last);
        }
        let mut last = b + 2 * s;
        if let Some(&(next, _)) = runs.get(r + 1) {
            last = last.min(next + s - 1);
        }
        if last + 1 >= first + min_points {
            segments.push(RefSegment { first, last });
        }
    }
    (segments, edges)
}

/// A line fitted by [`fit_line`] (v3 §7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefLine {
    /// Normal direction α (rad), in (−π, π].
    pub alpha: f64,
    /// Distance from the sensor (m), ≥ 0.
    pub r: f64,
    /// Covariance of (α, r), `[[αα, αr], [αr, rr]]`.
    pub cov: [[f64; 2]; 2],
    /// Usable beams fitted.
    pub points: usize,
    /// `Σ w e²` (less the turns' offsets) over `sigma²·dof`.
    pub chi2: f64,
    /// The first and the last usable beam's point projected onto the line.
    pub endpoints: [[f64; 2]; 2],
}

/// `a` wrapped into (−π, π].
pub fn wrap(a: f64) -> f64 {
    use std::f64::consts::PI;
    let mut w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w -= 2.0 * PI;
    }
    w
}

/// The fit's settings of v3 §7 for one scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitSettings {
    /// Range noise σ of the fit (m).
    pub sigma: f64,
    /// Footprint term κ (rad).
    pub footprint: f64,
    /// Interleaved turns whose offsets the χ² allows (1: none).
    pub turns: usize,
}

impl FitSettings {
    /// The settings of `params` for a scan of bearing step `step` (rad).
    pub fn of(params: &RefParams, step: f64) -> Self {
        FitSettings {
            sigma: params.sigma,
            footprint: params.footprint,
            turns: if params.turn_offsets {
                interleaved_turns(step)
            } else {
                1
            },
        }
    }
}

/// Most Gauss–Newton steps of a fit (v3 §7.2).
pub const GN_STEPS: usize = 5;
/// A step below this in α (rad) and in r (m) ends the iteration.
pub const GN_STOP: f64 = 1e-6;
/// A beam meeting the line at `cos(φ − α)` at or below this fails the fit.
pub const MIN_INCIDENCE_COS: f64 = 1e-3;

/// v3 §7.1–7.5: the line through the usable beams `first..=last` of
/// `ranges` at bearings `geometry.bearing(j)`, written from the text:
/// the total-least-squares start `α = ½·atan2(−2·Sxy, Syy − Sxx)`, at most
/// [`GN_STEPS`] Gauss–Newton steps on `d_j = r / cos(φ_j − α)` with each
/// beam weighted by `1 / (1 + (κ/σ · d_j · tan(φ_j − α))²)` at the step's α
/// (the angle updated as a number, not as a rotated normal), then at the
/// solution the covariance `σ²·(JᵀWJ)⁻¹` and the χ² per degree of freedom,
/// with `Σ_t W_t·(ē_t − ē)²` (the turns' weighted mean residuals about
/// their common mean) taken out of `Σ w e²` where the turns' offsets apply.
/// `None` for fewer than three beams, a beam seen edge-on or a singular
/// system.
pub fn fit_line(
    ranges: &[f64],
    usable: &[bool],
    geometry: RefGeometry,
    first: usize,
    last: usize,
    fit: FitSettings,
) -> Option<RefLine> {
    use std::f64::consts::PI;
    let beams = fit_beams(ranges, usable, first, last)?;
    let m = beams.len();
    let point = |j: usize| {
        let phi = geometry.bearing(j);
        [ranges[j] * phi.cos(), ranges[j] * phi.sin()]
    };
    // 1. Total least squares.
    let (mut xm, mut ym) = (0.0, 0.0);
    for &j in &beams {
        let [x, y] = point(j);
        xm += x / m as f64;
        ym += y / m as f64;
    }
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &j in &beams {
        let [x, y] = point(j);
        sxx += (x - xm) * (x - xm);
        syy += (y - ym) * (y - ym);
        sxy += (x - xm) * (y - ym);
    }
    let mut alpha = 0.5 * (-2.0 * sxy).atan2(syy - sxx);
    let mut r = xm * alpha.cos() + ym * alpha.sin();
    if r < 0.0 {
        (alpha, r) = (alpha + PI, -r);
    }
    let k = fit.footprint / fit.sigma;
    let rows = |alpha: f64, r: f64| -> Option<Vec<Row>> {
        beams
            .iter()
            .map(|&j| {
                let delta = geometry.bearing(j) - alpha;
                let (c, s) = (delta.cos(), delta.sin());
                if c <= MIN_INCIDENCE_COS {
                    return None;
                }
                let d = ranges[j];
                let w = 1.0 / (1.0 + (k * d * s / c).powi(2));
                Some((j, w, d - r / c, -r * s / (c * c), 1.0 / c))
            })
            .collect()
    };
    // 2. Gauss–Newton.
    for _ in 0..GN_STEPS {
        let (n, g) = normal(&rows(alpha, r)?);
        let inv = inverse(n)?;
        let da = inv[0][0] * g[0] + inv[0][1] * g[1];
        let dr = inv[1][0] * g[0] + inv[1][1] * g[1];
        alpha += da;
        r += dr;
        if da.abs() < GN_STOP && dr.abs() < GN_STOP {
            break;
        }
    }
    if r < 0.0 {
        (alpha, r) = (alpha + PI, -r);
    }
    let alpha = wrap(alpha);
    // 3.–4. Covariance and χ² at the solution.
    let at = rows(alpha, r)?;
    let (n, _) = normal(&at);
    let inv = inverse(n)?;
    let var = fit.sigma * fit.sigma;
    let mut sum: f64 = at.iter().map(|&(_, w, e, _, _)| w * e * e).sum();
    if turn_offsets_apply(m, fit.turns) {
        let t = fit.turns;
        let (mut we, mut ww) = (vec![0.0; t], vec![0.0; t]);
        for &(j, w, e, _, _) in &at {
            we[j % t] += w * e;
            ww[j % t] += w;
        }
        sum = (sum - between_turns(&we, &ww)).max(0.0);
    }
    let chi2 = sum / (var * residual_dof(m, fit.turns) as f64);
    Some(RefLine {
        alpha,
        r,
        cov: scaled(inv, var),
        points: m,
        chi2,
        // 5. Endpoints: the first and the last usable point, projected.
        endpoints: endpoints(ranges, geometry, &beams, (alpha, r)),
    })
}

/// Per usable beam at (α, r): beam, weight, residual, Jacobian row (α, r).
type Row = (usize, f64, f64, f64, f64);

/// The normal equations of `rows`: `JᵀWJ` and `JᵀWe`.
fn normal(rows: &[Row]) -> ([[f64; 2]; 2], [f64; 2]) {
    let mut n = [[0.0f64; 2]; 2];
    let mut g = [0.0f64; 2];
    for &(_, w, e, ja, jr) in rows {
        n[0][0] += w * ja * ja;
        n[0][1] += w * ja * jr;
        n[1][1] += w * jr * jr;
        g[0] += w * ja * e;
        g[1] += w * jr * e;
    }
    n[1][0] = n[0][1];
    (n, g)
}

/// The inverse of a symmetric positive definite 2×2 matrix; `None` if it
/// is not.
fn inverse(n: [[f64; 2]; 2]) -> Option<[[f64; 2]; 2]> {
    let det = n[0][0] * n[1][1] - n[0][1] * n[1][0];
    (n[0][0] > 0.0 && det > 0.0 && det.is_finite()).then(|| {
        [
            [n[1][1] / det, -n[0][1] / det],
            [-n[1][0] / det, n[0][0] / det],
        ]
    })
}

/// `var · inv`: a covariance from `(JᵀJ)⁻¹`.
fn scaled(inv: [[f64; 2]; 2], var: f64) -> [[f64; 2]; 2] {
    [
        [var * inv[0][0], var * inv[0][1]],
        [var * inv[1][0], var * inv[1][1]],
    ]
}

/// The first and the last of `beams`' points projected onto the line
/// `(alpha, r)` (v3 §7.5).
fn endpoints(
    ranges: &[f64],
    geometry: RefGeometry,
    beams: &[usize],
    (alpha, r): (f64, f64),
) -> [[f64; 2]; 2] {
    let project = |j: usize| {
        let phi = geometry.bearing(j);
        let (x, y) = (ranges[j] * phi.cos(), ranges[j] * phi.sin());
        let dist = x * alpha.cos() + y * alpha.sin() - r;
        [x - dist * alpha.cos(), y - dist * alpha.sin()]
    };
    [project(beams[0]), project(beams[beams.len() - 1])]
}

/// Whether the turns' offsets come out of χ² (v3 §7.3): 2 or 4 turns and
/// more than two beams per turn.
fn turn_offsets_apply(m: usize, turns: usize) -> bool {
    matches!(turns, 2 | 4) && m > 2 * turns
}

/// The degrees of freedom of a fit of `m` beams (v3 §7.3): `m − 1 − turns`
/// where the turns' offsets apply, else `m − 2`; at least 1.
fn residual_dof(m: usize, turns: usize) -> usize {
    let dof = if turn_offsets_apply(m, turns) {
        m - 1 - turns
    } else {
        m.saturating_sub(2)
    };
    dof.max(1)
}

/// The usable beams of `first..=last` a fit takes (v3 §7.1); `None` for
/// fewer than three.
fn fit_beams(ranges: &[f64], usable: &[bool], first: usize, last: usize) -> Option<Vec<usize>> {
    let beams: Vec<usize> = (first..=last.min(ranges.len().saturating_sub(1)))
        .filter(|&j| usable[j])
        .collect();
    (beams.len() >= 3).then_some(beams)
}

/// What the turns' offsets explain (v3 §7.3): `Σ_t W_t·(ē_t − ē)²`, the
/// turns' weighted mean residuals `ē_t = sums[t]/weights[t]` about their
/// common mean, over the turns with weight.
fn between_turns(sums: &[f64], weights: &[f64]) -> f64 {
    let mean = sums.iter().sum::<f64>() / weights.iter().sum::<f64>();
    (0..sums.len())
        .filter(|&u| weights[u] > 0.0)
        .map(|u| weights[u] * (sums[u] / weights[u] - mean).powi(2))
        .sum()
}

/// v3.3 §7.9: the refit of a footprint-weighted line `(alpha, r)` over the
/// usable beams `first..=last` with every beam at σ, written from the text:
/// one Gauss–Newton step of the unweighted range model from `(alpha, r)`,
/// the covariance `σ²·(JᵀJ)⁻¹` at `(alpha, r)`, the χ² of the residual sum
/// the linearised model predicts after the step (`Σe² − δᵀJᵀe`, the turns'
/// offsets taken out of it with each turn's residuals moved by the step),
/// the endpoints at the new line; and `Λ = Σ ln(1 + (κ/σ·d·tan θ)²)` at
/// `(alpha, r)`, summed directly. `None` for fewer than three beams, a beam
/// seen edge-on or a singular system.
pub fn refit_without_footprint(
    ranges: &[f64],
    usable: &[bool],
    geometry: RefGeometry,
    (first, last): (usize, usize),
    (alpha, r): (f64, f64),
    fit: FitSettings,
) -> Option<(RefLine, f64)> {
    use std::f64::consts::PI;
    let beams = fit_beams(ranges, usable, first, last)?;
    let m = beams.len();
    let k = fit.footprint / fit.sigma;
    let (mut sum, mut lambda) = (0.0, 0.0);
    // Every weight 1 (no footprint term).
    let mut rows: Vec<Row> = Vec::with_capacity(m);
    for &j in &beams {
        let delta = geometry.bearing(j) - alpha;
        let (c, s) = (delta.cos(), delta.sin());
        if c <= MIN_INCIDENCE_COS {
            return None;
        }
        let d = ranges[j];
        let e = d - r / c;
        sum += e * e;
        lambda += (k * d * s / c).powi(2).ln_1p();
        rows.push((j, 1.0, e, -r * s / (c * c), 1.0 / c));
    }
    let (n, g) = normal(&rows);
    let inv = inverse(n)?;
    let da = inv[0][0] * g[0] + inv[0][1] * g[1];
    let dr = inv[1][0] * g[0] + inv[1][1] * g[1];
    let mut after = (sum - (da * g[0] + dr * g[1])).max(0.0);
    if turn_offsets_apply(m, fit.turns) {
        let t = fit.turns;
        let (mut se, mut sw) = (vec![0.0; t], vec![0.0; t]);
        for &(j, _, e, ja, jr) in &rows {
            se[j % t] += e - (ja * da + jr * dr);
            sw[j % t] += 1.0;
        }
        after = (after - between_turns(&se, &sw)).max(0.0);
    }
    let (mut alpha, mut r) = (alpha + da, r + dr);
    if r < 0.0 {
        (alpha, r) = (alpha + PI, -r);
    }
    let alpha = wrap(alpha);
    let var = fit.sigma * fit.sigma;
    let line = RefLine {
        alpha,
        r,
        cov: scaled(inv, var),
        points: m,
        chi2: after / (var * residual_dof(m, fit.turns) as f64),
        endpoints: endpoints(ranges, geometry, &beams, (alpha, r)),
    };
    Some((line, lambda))
}

/// A line's residual sum `χ²·dof` (v3 §7.3), `dof` = `m − 1 − turns` where
/// the turns' offsets apply (2 or 4 turns, more than two beams per turn),
/// else `m − 2`, at least 1.
pub fn residual_sum(line: &RefLine, turns: usize) -> f64 {
    line.chi2 * residual_dof(line.points, turns) as f64
}

/// A corner by [`corner`] (v3 §8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefCorner {
    /// Position (m).
    pub x: f64,
    /// Position (m).
    pub y: f64,
    /// Covariance of (x, y) with the floor of v3 §8, `[[xx, xy], [xy, yy]]`.
    pub cov: [[f64; 2]; 2],
    /// Angle between the lines folded into [0°, 90°].
    pub angle_deg: f64,
}

/// Relative floor v3 §8 adds to the diagonal of a corner's covariance.
pub const CORNER_COV_FLOOR: f64 = 1e-6;

/// v3 §8: the intersection `p = N⁻¹·r` of the lines `(α₁, r₁, Σ₁)` and
/// `(α₂, r₂, Σ₂)` (`N` the rows `(cos αᵢ, sin αᵢ)`), its covariance
/// `J·diag(Σ₁, Σ₂)·Jᵀ` with the 2×4 Jacobian `J = ∂p/∂(α₁, r₁, α₂, r₂)` from
/// `N·dp = dr − dN·p` (a matrix product, where the core sums two rank-one
/// terms), plus [`CORNER_COV_FLOOR`] times its trace on the diagonal, and
/// the folded angle. `None` for parallel lines.
pub fn corner(l1: (f64, f64, [[f64; 2]; 2]), l2: (f64, f64, [[f64; 2]; 2])) -> Option<RefCorner> {
    let (a1, r1, s1) = l1;
    let (a2, r2, s2) = l2;
    let n = [[a1.cos(), a1.sin()], [a2.cos(), a2.sin()]];
    let det = n[0][0] * n[1][1] - n[0][1] * n[1][0];
    if det == 0.0 {
        return None;
    }
    let inv = [
        [n[1][1] / det, -n[0][1] / det],
        [-n[1][0] / det, n[0][0] / det],
    ];
    let p = [
        inv[0][0] * r1 + inv[0][1] * r2,
        inv[1][0] * r1 + inv[1][1] * r2,
    ];
    // dN·p for dα_i: row i of N differentiated, (−sin αᵢ, cos αᵢ)·p.
    let h = [
        -a1.sin() * p[0] + a1.cos() * p[1],
        -a2.sin() * p[0] + a2.cos() * p[1],
    ];
    // Columns of J: ∂p/∂α₁ = −h₁·N⁻¹e₁, ∂p/∂r₁ = N⁻¹e₁, likewise for line 2.
    let mut jac = [[0.0f64; 4]; 2];
    for row in 0..2 {
        jac[row] = [
            -h[0] * inv[row][0],
            inv[row][0],
            -h[1] * inv[row][1],
            inv[row][1],
        ];
    }
    let mut sigma = [[0.0f64; 4]; 4];
    for a in 0..2 {
        for b in 0..2 {
            sigma[a][b] = s1[a][b];
            sigma[2 + a][2 + b] = s2[a][b];
        }
    }
    let mut cov = [[0.0f64; 2]; 2];
    for (u, row) in cov.iter_mut().enumerate() {
        for (v, cell) in row.iter_mut().enumerate() {
            for a in 0..4 {
                for b in 0..4 {
                    *cell += jac[u][a] * sigma[a][b] * jac[v][b];
                }
            }
        }
    }
    let floor = CORNER_COV_FLOOR * (cov[0][0] + cov[1][1]);
    cov[0][0] += floor;
    cov[1][1] += floor;
    let delta = wrap(a2 - a1).abs();
    let folded = delta.min(std::f64::consts::PI - delta);
    if !(p[0].is_finite() && p[1].is_finite()) {
        return None;
    }
    Some(RefCorner {
        x: p[0],
        y: p[1],
        cov,
        angle_deg: folded.to_degrees(),
    })
}

/// The Cramér–Rao bound of a polar line `x·cos α + y·sin α = r` measured in
/// the range direction by the beams at `bearings` with noise `sigma`:
/// `σ²·(JᵀJ)⁻¹` with rows `[−r·sin δ/cos² δ, 1/cos δ]`, `δ = phi − α`,
/// evaluated at the true line (noise-free geometry). Returns
/// `[[αα, αr], [αr, rr]]`.
pub fn line_crlb(alpha: f64, r: f64, bearings: &[f64], sigma: f64) -> [[f64; 2]; 2] {
    let (mut saa, mut sar, mut srr) = (0.0, 0.0, 0.0);
    for &phi in bearings {
        let dl = phi - alpha;
        let ja = -r * dl.sin() / (dl.cos() * dl.cos());
        let jr = 1.0 / dl.cos();
        saa += ja * ja;
        sar += ja * jr;
        srr += jr * jr;
    }
    let det = saa * srr - sar * sar;
    let v = sigma * sigma;
    [
        [v * srr / det, -v * sar / det],
        [-v * sar / det, v * saa / det],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const GAMMA: f64 = 0.5 * std::f64::consts::PI / 180.0;

    fn on_line(alpha: f64, r: f64, phis: [f64; 3]) -> [f64; 3] {
        phis.map(|p| r / (p - alpha).cos())
    }

    #[test]
    fn collinear_points_satisfy_the_model_and_give_zero_distance() {
        let k = k_of(GAMMA);
        for (alpha, r, phi) in [(0.3, 2.0, 0.1), (-1.2, 0.7, -0.9), (1.5, 5.0, 1.2)] {
            let z = on_line(alpha, r, [phi - GAMMA, phi, phi + GAMMA]);
            let (f, _) = predict(z, k).unwrap();
            for i in 0..3 {
                assert!(((f[i] - z[i]) / z[i]).abs() < 1e-12, "{f:?} vs {z:?}");
            }
            let w = ekf_window(z, k, 0.005, 0.0).unwrap();
            assert!(w.d < 1e-12, "D = {}", w.d);
        }
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let k = k_of(GAMMA);
        let z = [2.0, 2.05, 2.12];
        let (_, jac) = predict(z, k).unwrap();
        let h = 1e-6;
        for j in 0..3 {
            let (mut lo, mut hi) = (z, z);
            lo[j] -= h;
            hi[j] += h;
            let (fl, _) = predict(lo, k).unwrap();
            let (fh, _) = predict(hi, k).unwrap();
            for i in 0..3 {
                let num = (fh[i] - fl[i]) / (2.0 * h);
                assert!((num - jac[i][j]).abs() < 1e-6 * (1.0 + num.abs()));
            }
        }
    }

    #[test]
    fn the_gain_equals_the_textbook_form() {
        // x⁺ − x̂ = K·v with K = P̂·S⁻¹, so S·P̂⁻¹·(x⁺ − x̂) = v.
        let k = k_of(GAMMA);
        let z = [3.0, 3.02, 3.01];
        let w = ekf_window(z, k, 0.01, 1e-4).unwrap();
        let (x_hat, f) = predict(z, k).unwrap();
        let mut p = mat_mul(&f, &transpose(&f));
        for (i, row) in p.iter_mut().enumerate() {
            for x in row.iter_mut() {
                *x *= 1e-4;
            }
            row[i] += 1e-4;
        }
        let mut s = p;
        for (i, row) in s.iter_mut().enumerate() {
            row[i] += 1e-4;
        }
        let v = [z[0] - x_hat[0], z[1] - x_hat[1], z[2] - x_hat[2]];
        let dx = [
            w.posterior[0] - x_hat[0],
            w.posterior[1] - x_hat[1],
            w.posterior[2] - x_hat[2],
        ];
        let y = solve3(&p, &[dx]).unwrap()[0];
        for i in 0..3 {
            let sv: f64 = (0..3).map(|j| s[i][j] * y[j]).sum();
            assert!((sv - v[i]).abs() < 1e-12, "{sv} vs {}", v[i]);
        }
    }

    #[test]
    fn a_pass_keeps_invalid_beams_and_segmentation_shares_corner_points() {
        let ranges = [2.0, 2.0, 0.0, 2.0, 2.0];
        let valid = [true, true, false, true, true];
        let (out, d) = smoothing_pass(&ranges, &valid, GAMMA, 1, &RefParams::default());
        assert_eq!(out[2], 0.0);
        assert!(d.iter().all(|x| x.is_infinite()));
        assert_eq!(out, ranges.to_vec());
        let d = [1.0, 1.0, 1.0, 1.0, 50.0, 1.0, 1.0, f64::INFINITY, 1.0, 1.0];
        let (segs, edges) = segment(&d, 9.0, 3);
        let segs: Vec<_> = segs.iter().map(|s| (s.first, s.last)).collect();
        assert_eq!(segs, vec![(0, 5), (5, 8), (8, 11)]);
        assert_eq!(edges, vec![5]);
    }

    #[test]
    fn the_interleaved_modes_have_their_turns() {
        let deg = std::f64::consts::PI / 180.0;
        assert_eq!(interleaved_turns(deg), 1);
        assert_eq!(interleaved_turns(0.5 * deg), 2);
        assert_eq!(interleaved_turns(0.25 * deg), 4);
        assert_eq!(interleaved_turns(0.3 * deg), 1);
        let consecutive = RefParams {
            same_turn_windows: false,
            ..RefParams::default()
        };
        assert_eq!(window_stride(0.5 * deg, &consecutive), 1);
        assert_eq!(window_stride(0.5 * deg, &RefParams::default()), 2);
    }

    #[test]
    fn a_stride_two_pass_is_two_passes_over_the_turns() {
        // A rippled wall: windows of stride 2 see the even and the odd
        // beams as two scans of their own at twice the step.
        let n = 41;
        let ranges: Vec<f64> = (0..n)
            .map(|j| {
                let phi = (j as f64 - 20.0) * GAMMA;
                1.5 / (phi - 0.35).cos() + 0.01 * (((j * 7919) % 13) as f64 / 6.0 - 1.0)
            })
            .collect();
        let ok = vec![true; n];
        let p = RefParams {
            sigma: 0.01,
            ..RefParams::default()
        };
        let (all, d) = smoothing_pass(&ranges, &ok, GAMMA, 2, &p);
        for parity in 0..2 {
            let sub: Vec<f64> = ranges.iter().skip(parity).step_by(2).copied().collect();
            let (out, sub_d) = smoothing_pass(&sub, &vec![true; sub.len()], 2.0 * GAMMA, 1, &p);
            for (k, x) in out.iter().enumerate() {
                assert_eq!(*x, all[parity + 2 * k]);
            }
            for (k, x) in sub_d.iter().enumerate() {
                assert_eq!(*x, d[parity + 2 * k]);
            }
        }
        // Windows 37 and 38 (n − 4, n − 3) do not exist at stride 2.
        assert!(d[37].is_infinite() && d[38].is_infinite());
        // A window needs every beam of its span: beam 10 out breaks 6..=10.
        let mut ok = vec![true; n];
        ok[10] = false;
        let (_, d) = smoothing_pass(&ranges, &ok, GAMMA, 2, &p);
        for (i, x) in d.iter().enumerate() {
            assert_eq!(x.is_infinite(), (6..=10).contains(&i) || i >= 37, "{i}");
        }
    }

    #[test]
    fn strided_segments_cover_their_windows_up_to_their_neighbours() {
        let run = |breaking: &[usize]| {
            let mut d = vec![0.0f64; 20];
            for &i in breaking {
                d[i] = 50.0;
            }
            let (segs, edges) = segment_strided(&d, 2, 9.0, 5);
            let segs: Vec<_> = segs.iter().map(|s| (s.first, s.last)).collect();
            (segs, edges)
        };
        // A jump between beams 9 and 10 breaks windows 6..=9: no shared beam.
        assert_eq!(
            run(&[6, 7, 8, 9]),
            (vec![(0, 9), (10, 23)], vec![8, 9, 10, 11])
        );
        // A corner at beam 10 breaks windows 7..=9: both segments end on it.
        assert_eq!(run(&[7, 8, 9]).0, vec![(0, 10), (10, 23)]);
        // Two breaking windows: the earlier run ends at the later run's
        // first middle beam, shared.
        assert_eq!(run(&[8, 9]).0, vec![(0, 11), (11, 23)]);
        // A run of one window is too short; the run before it still ends
        // before that run's middle beams.
        assert_eq!(run(&[6, 8]).0, vec![(0, 8), (9, 23)]);
        // A run of two windows between two double breaks is kept.
        assert_eq!(run(&[4, 5, 8, 9]).0, vec![(0, 7), (7, 11), (11, 23)]);
    }

    fn wall(alpha: f64, r: f64, n: usize, step: f64) -> (RefGeometry, Vec<f64>) {
        let g = RefGeometry {
            first: alpha - step * (n as f64 - 1.0) / 2.0,
            step,
        };
        let d = (0..n).map(|j| r / (g.bearing(j) - alpha).cos()).collect();
        (g, d)
    }

    #[test]
    fn a_noise_free_wall_is_fitted_exactly() {
        let (g, d) = wall(0.4, 3.0, 81, GAMMA);
        let ok = vec![true; d.len()];
        let fit = FitSettings {
            sigma: 0.005,
            footprint: 0.003,
            turns: 2,
        };
        let l = fit_line(&d, &ok, g, 3, 70, fit).unwrap();
        assert!((l.alpha - 0.4).abs() < 1e-12 && (l.r - 3.0).abs() < 1e-12);
        assert!(l.chi2 < 1e-20 && l.points == 68);
        assert!(l.cov[0][0] > 0.0 && (l.cov[0][1] - l.cov[1][0]).abs() == 0.0);
        // The endpoints are beams 3 and 70 on the wall.
        let end = |j: usize| [d[j] * g.bearing(j).cos(), d[j] * g.bearing(j).sin()];
        for (got, want) in l.endpoints.iter().zip([end(3), end(70)]) {
            assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
        }
    }

    #[test]
    fn the_turns_offset_is_taken_out_of_chi2_only() {
        // The odd beams 1 cm behind the even ones: two parallel point sets.
        let (g, mut d) = wall(0.2, 2.0, 61, GAMMA);
        for (j, x) in d.iter_mut().enumerate() {
            if j % 2 == 1 {
                *x += 0.01 / (g.bearing(j) - 0.2).cos();
            }
        }
        let ok = vec![true; d.len()];
        let with = FitSettings {
            sigma: 0.005,
            footprint: 0.0,
            turns: 2,
        };
        let without = FitSettings { turns: 1, ..with };
        let (a, b) = (
            fit_line(&d, &ok, g, 0, 60, with).unwrap(),
            fit_line(&d, &ok, g, 0, 60, without).unwrap(),
        );
        // Without offsets each beam is 5 mm (σ) off the line between the
        // turns (a little more in the range direction): χ² ≈ 61/59; with them, only what the offset's change
        // with incidence leaves (δ/cos θ, θ within ±15°).
        assert!(a.chi2 < 1e-3, "{}", a.chi2);
        assert!((b.chi2 - 61.0 / 59.0).abs() < 0.05, "{}", b.chi2);
        // The line is the one between the turns either way.
        assert_eq!((a.alpha, a.r), (b.alpha, b.r));
        assert!((a.r - 2.005).abs() < 1e-4);
    }

    #[test]
    fn a_right_angle_corner() {
        let cov = [[1e-6, 0.0], [0.0, 1e-4]];
        let c = corner((0.0, 2.0, cov), (std::f64::consts::FRAC_PI_2, 3.0, cov)).unwrap();
        assert!((c.x - 2.0).abs() < 1e-12 && (c.y - 3.0).abs() < 1e-12);
        assert!((c.angle_deg - 90.0).abs() < 1e-9);
        // x moves with r₁ and with α₁ (lever y = 3), y with r₂ and α₂
        // (lever x = 2): var r + 9·var α and var r + 4·var α.
        let floor = CORNER_COV_FLOOR * (1e-4 + 9e-6 + 1e-4 + 4e-6);
        assert!((c.cov[0][0] - (1e-4 + 9e-6 + floor)).abs() < 1e-15);
        assert!((c.cov[1][1] - (1e-4 + 4e-6 + floor)).abs() < 1e-15);
        assert!(corner((0.3, 2.0, cov), (0.3, 3.0, cov)).is_none());
    }
}
