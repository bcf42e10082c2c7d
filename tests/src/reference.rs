//! An independent `f64` reference of ALGORITHM.md §2–§6, written from the
//! specification alone: it shares no code with `lms-core`.
//!
//! Where the core works with a closed-form symmetric 3×3 inverse and the
//! zero-diagonal structure of the Jacobian written out term by term, this
//! reference builds the full 3×3 matrices (`F`, `P̂ = F·P⁻·Fᵀ + Q`,
//! `S = P̂ + R`), solves `S·u = v` and `S·X = P̂` by Gaussian elimination with
//! partial pivoting, and forms the gain `K = P̂·S⁻¹ = Xᵀ` explicitly. The two
//! formulations are algebraically equal, so any disagreement beyond rounding
//! is a bug in one of them.
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

/// The filter's parameters (§3, §5).
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
}

impl Default for RefParams {
    /// The defaults of ALGORITHM.md §5–§6.
    fn default() -> Self {
        RefParams {
            sigma: 0.005,
            q: 0.0,
            tau: 9.0,
            min_points: 5,
        }
    }
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

/// §4: one Jacobi pass. Returns the new ranges and `D` of the `n − 2`
/// windows (`+inf` where invalid). Invalid beams are never modified.
pub fn smoothing_pass(
    ranges: &[f64],
    valid: &[bool],
    step: f64,
    params: &RefParams,
) -> (Vec<f64>, Vec<f64>) {
    let n = ranges.len();
    let k = k_of(step);
    let windows = n.saturating_sub(2);
    // Each window once per pass, all from the previous pass's ranges.
    let est: Vec<Option<RefWindow>> = (0..windows)
        .map(|i| {
            if valid[i] && valid[i + 1] && valid[i + 2] {
                ekf_window(
                    [ranges[i], ranges[i + 1], ranges[i + 2]],
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
        if !valid[j] {
            continue;
        }
        // Windows i = j, j−1, j−2, in that order; point j is member j − i.
        let mut wsum = 0.0;
        let mut xsum = 0.0;
        for back in 0..3 {
            if back > j {
                break;
            }
            let i = j - back;
            if let Some(Some(e)) = est.get(i) {
                let w3 = weight(e.d) / 3.0;
                wsum += w3;
                xsum += w3 * e.posterior[back];
            }
        }
        out[j] = (1.0 - wsum) * ranges[j] + xsum;
    }
    (out, d)
}

/// §5: `passes` Jacobi passes from `ranges`; returns, per pass, the ranges
/// after it and `D` of that pass (index 0 = pass 1).
pub fn smooth(
    ranges: &[f64],
    valid: &[bool],
    step: f64,
    params: &RefParams,
    passes: usize,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut out = Vec::with_capacity(passes);
    let mut current = ranges.to_vec();
    for _ in 0..passes {
        let (next, d) = smoothing_pass(&current, valid, step, params);
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

/// §6: segments (maximal runs of non-breaking windows `i..=k` covering points
/// `i..=k+2`, dropping those with fewer than `min_points` points) and edge
/// points (middle points of breaking valid windows).
pub fn segment(d: &[f64], tau: f64, min_points: usize) -> (Vec<RefSegment>, Vec<usize>) {
    let edges: Vec<usize> = d
        .iter()
        .enumerate()
        .filter(|(_, &x)| x.is_finite() && x >= tau)
        .map(|(i, _)| i + 1)
        .collect();
    let mut segments = Vec::new();
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
        let seg = RefSegment {
            first: start,
            last: i - 1 + 2,
        };
        if seg.last + 1 - seg.first >= min_points {
            segments.push(seg);
        }
    }
    (segments, edges)
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
        let (out, d) = smoothing_pass(&ranges, &valid, GAMMA, &RefParams::default());
        assert_eq!(out[2], 0.0);
        assert!(d.iter().all(|x| x.is_infinite()));
        assert_eq!(out, ranges.to_vec());
        let d = [1.0, 1.0, 1.0, 1.0, 50.0, 1.0, 1.0, f64::INFINITY, 1.0, 1.0];
        let (segs, edges) = segment(&d, 9.0, 3);
        let segs: Vec<_> = segs.iter().map(|s| (s.first, s.last)).collect();
        assert_eq!(segs, vec![(0, 5), (5, 8), (8, 11)]);
        assert_eq!(edges, vec![5]);
    }
}
