//! The figures' geometry: covariance ellipses, equal axis scales, nice
//! enlargement factors, polygon clipping.

use super::style::ELLIPSE_VERTICES;

/// The 2σ ellipse of covariance `cov` around `(x, y)`, enlarged `scale`
/// times, as [`ELLIPSE_VERTICES`] points. `None` if `cov` is not a finite
/// positive semi-definite matrix.
pub fn ellipse(x: f64, y: f64, cov: [[f32; 2]; 2], scale: f64) -> Option<Vec<(f64, f64)>> {
    let (a, b, c) = (
        f64::from(cov[0][0]),
        f64::from(cov[0][1]),
        f64::from(cov[1][1]),
    );
    let (l1, l2, theta) = eigen_sym2(a, b, c)?;
    let (s1, s2) = (2.0 * scale * l1.sqrt(), 2.0 * scale * l2.sqrt());
    let (ct, st) = (theta.cos(), theta.sin());
    Some(
        (0..ELLIPSE_VERTICES)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / ELLIPSE_VERTICES as f64;
                let (u, v) = (s1 * t.cos(), s2 * t.sin());
                (x + ct * u - st * v, y + st * u + ct * v)
            })
            .collect(),
    )
}

/// Eigenvalues (larger first, clamped at 0) and the angle of the first
/// eigenvector of `[[a, b], [b, c]]`.
pub(super) fn eigen_sym2(a: f64, b: f64, c: f64) -> Option<(f64, f64, f64)> {
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    let mean = 0.5 * (a + c);
    let diff = 0.5 * (a - c);
    let rad = diff.hypot(b);
    let (l1, l2) = (mean + rad, mean - rad);
    if l1 < 0.0 {
        return None;
    }
    Some((l1, l2.max(0.0), 0.5 * (2.0 * b).atan2(a - c)))
}

/// Largest 2σ semi-axis (m) of a covariance.
pub(super) fn semi_major(cov: [[f32; 2]; 2]) -> Option<f64> {
    let (l1, _, _) = eigen_sym2(
        f64::from(cov[0][0]),
        f64::from(cov[0][1]),
        f64::from(cov[1][1]),
    )?;
    Some(2.0 * l1.sqrt())
}

/// An ellipse enlargement from 1, 2, 5 × 10^k that makes a typical semi-axis
/// of `median_px` pixels at least `target_px` long (1 if it already is).
pub fn nice_scale(median_px: f64, target_px: f64) -> f64 {
    if median_px.is_nan() || median_px <= 0.0 || median_px >= target_px {
        return 1.0;
    }
    let need = target_px / median_px;
    let mut decade = 1.0;
    loop {
        for m in [1.0, 2.0, 5.0] {
            let s = m * decade;
            if s >= need {
                return s;
            }
        }
        decade *= 10.0;
        if decade > 1e9 {
            return decade;
        }
    }
}

/// Ranges `(h0..h1, v0..v1)` with the same metres per pixel on both axes,
/// holding the box `[h_min, h_max] × [v_min, v_max]` centred, for a plotting
/// area of `w × h` pixels. Returns the ranges and the metres per pixel.
pub fn equal_scale(
    (h_min, h_max): (f64, f64),
    (v_min, v_max): (f64, f64),
    (w, h): (u32, u32),
) -> ((f64, f64), (f64, f64), f64) {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let span_h = (h_max - h_min).max(1e-3);
    let span_v = (v_max - v_min).max(1e-3);
    let mpp = (span_h / w).max(span_v / h);
    let (ch, cv) = (0.5 * (h_min + h_max), 0.5 * (v_min + v_max));
    (
        (ch - 0.5 * mpp * w, ch + 0.5 * mpp * w),
        (cv - 0.5 * mpp * h, cv + 0.5 * mpp * h),
        mpp,
    )
}

/// Clip a polygon to the rectangle `[h0, h1] × [v0, v1]` (Sutherland–Hodgman).
pub(super) fn clip_polygon(
    poly: &[(f64, f64)],
    (h0, h1): (f64, f64),
    (v0, v1): (f64, f64),
) -> Vec<(f64, f64)> {
    type Edge = (fn(&(f64, f64), f64) -> bool, usize, f64);
    let edges: [Edge; 4] = [
        (|p, e| p.0 >= e, 0, h0),
        (|p, e| p.0 <= e, 0, h1),
        (|p, e| p.1 >= e, 1, v0),
        (|p, e| p.1 <= e, 1, v1),
    ];
    let mut out = poly.to_vec();
    for (inside, axis, e) in edges {
        let input = std::mem::take(&mut out);
        let Some(&last) = input.last() else {
            return out;
        };
        let mut prev = last;
        for &p in &input {
            let cross = |a: (f64, f64), b: (f64, f64)| {
                let (ca, cb) = if axis == 0 { (a.0, b.0) } else { (a.1, b.1) };
                let t = (e - ca) / (cb - ca);
                (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
            };
            match (inside(&p, e), inside(&prev, e)) {
                (true, true) => out.push(p),
                (true, false) => {
                    out.push(cross(prev, p));
                    out.push(p);
                }
                (false, true) => out.push(cross(prev, p)),
                (false, false) => {}
            }
            prev = p;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_scale_is_equal() {
        let ((u0, u1), (v0, v1), mpp) = equal_scale((-10.0, 10.0), (0.0, 5.0), (1000, 700));
        assert!(((u1 - u0) / 1000.0 - mpp).abs() < 1e-12);
        assert!(((v1 - v0) / 700.0 - mpp).abs() < 1e-12);
        assert!(u0 <= -10.0 && u1 >= 10.0 && v0 <= 0.0 && v1 >= 5.0);
        assert!((mpp - 0.02).abs() < 1e-12);
    }

    #[test]
    fn ellipse_axes() {
        // σx = 0.1, σy = 0.02, rotated 30°.
        let t = 30f64.to_radians();
        let (c, s) = (t.cos(), t.sin());
        let (l1, l2) = (0.01, 0.0004);
        let cov = [
            [(l1 * c * c + l2 * s * s) as f32, ((l1 - l2) * c * s) as f32],
            [((l1 - l2) * c * s) as f32, (l1 * s * s + l2 * c * c) as f32],
        ];
        let e = ellipse(1.0, 2.0, cov, 1.0).unwrap();
        assert_eq!(e.len(), ELLIPSE_VERTICES);
        let far = e
            .iter()
            .map(|&(x, y)| ((x - 1.0).hypot(y - 2.0), (y - 2.0).atan2(x - 1.0)))
            .fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a });
        assert!((far.0 - 0.2).abs() < 1e-6, "{far:?}");
        let dir = far.1.rem_euclid(std::f64::consts::PI);
        assert!((dir - t).abs() < 1e-3, "{dir}");
        let near = e
            .iter()
            .map(|&(x, y)| (x - 1.0).hypot(y - 2.0))
            .fold(f64::INFINITY, f64::min);
        assert!((near - 0.04).abs() < 1e-3, "{near}");
        assert!(ellipse(0.0, 0.0, [[f32::NAN, 0.0], [0.0, 1.0]], 1.0).is_none());
    }

    #[test]
    fn scales_and_clipping() {
        assert_eq!(nice_scale(20.0, 12.0), 1.0);
        assert_eq!(nice_scale(0.5, 12.0), 50.0);
        assert_eq!(nice_scale(0.1, 12.0), 200.0);
        let square = [(-2.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)];
        let c = clip_polygon(&square, (-1.0, 1.0), (0.0, 1.0));
        assert!(c
            .iter()
            .all(|p| (-1.0..=1.0).contains(&p.0) && (0.0..=1.0).contains(&p.1)));
        assert_eq!(c.len(), 4);
        assert!(clip_polygon(&square, (5.0, 6.0), (5.0, 6.0)).is_empty());
    }
}
