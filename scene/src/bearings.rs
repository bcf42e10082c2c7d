//! Beam bearings of the LMS 2xx scan variants (ALGORITHM.md §1).

use std::f64::consts::PI;

use crate::geometry::wrap_angle;

const DEG: f64 = PI / 180.0;

/// Beam bearings in the sensor frame: `phi_j = first + j·step` (radians,
/// counter-clockwise from straight ahead), `j = 0 … n−1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bearings {
    /// Bearing of beam 0 (rad).
    pub first: f64,
    /// Angle between consecutive beams (rad, > 0).
    pub step: f64,
    /// Number of beams.
    pub n: usize,
}

impl Bearings {
    /// `n` beams from `first` in steps of `step` (radians).
    pub const fn new(first: f64, step: f64, n: usize) -> Self {
        Self { first, step, n }
    }

    /// 180° at 1°: 181 beams from −90°.
    pub const fn lms_180_1deg() -> Self {
        Self::new(-90.0 * DEG, DEG, 181)
    }

    /// 180° at 0.5°: 361 beams from −90° (the main case, and the default).
    pub const fn lms_180_half_deg() -> Self {
        Self::new(-90.0 * DEG, 0.5 * DEG, 361)
    }

    /// 100° at 1°: 101 beams from −50°.
    pub const fn lms_100_1deg() -> Self {
        Self::new(-50.0 * DEG, DEG, 101)
    }

    /// 100° at 0.5°: 201 beams from −50°.
    pub const fn lms_100_half_deg() -> Self {
        Self::new(-50.0 * DEG, 0.5 * DEG, 201)
    }

    /// 100° at 0.25°: 401 beams from −50°.
    pub const fn lms_100_quarter_deg() -> Self {
        Self::new(-50.0 * DEG, 0.25 * DEG, 401)
    }

    /// The five LMS 2xx variants, in the order of ALGORITHM.md §1.
    pub const LMS_VARIANTS: [Bearings; 5] = [
        Self::lms_180_1deg(),
        Self::lms_180_half_deg(),
        Self::lms_100_1deg(),
        Self::lms_100_half_deg(),
        Self::lms_100_quarter_deg(),
    ];

    /// Bearing of beam `j` (rad).
    pub fn bearing(&self, j: usize) -> f64 {
        self.first + j as f64 * self.step
    }

    /// Bearing of the last beam (rad); `first` for an empty scan.
    pub fn last(&self) -> f64 {
        self.bearing(self.n.saturating_sub(1))
    }

    /// All bearings in beam order (rad).
    pub fn iter(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.n).map(|j| self.bearing(j))
    }

    /// Fractional beam index of a sensor-frame bearing (rad): `j` where
    /// `bearing = first + j·step`, with the angle difference wrapped into
    /// (−π, π]. Inside the field of view it lies in `[0, n−1]`.
    pub fn index_of(&self, bearing: f64) -> f64 {
        wrap_angle(bearing - self.first) / self.step
    }
}

impl Default for Bearings {
    /// 180° at 0.5° (361 beams).
    fn default() -> Self {
        Self::lms_180_half_deg()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variants_span_their_field_of_view() {
        for (b, fov) in Bearings::LMS_VARIANTS
            .iter()
            .zip([180.0, 180.0, 100.0, 100.0, 100.0])
        {
            assert!((b.first + fov / 2.0 * DEG).abs() < 1e-15);
            assert!((b.last() - fov / 2.0 * DEG).abs() < 1e-12, "{b:?}");
            assert_eq!(b.iter().count(), b.n);
        }
        assert_eq!(Bearings::default().n, 361);
        assert_eq!(
            Bearings::LMS_VARIANTS.map(|b| b.n),
            [181, 361, 101, 201, 401]
        );
    }

    #[test]
    fn index_of_inverts_bearing() {
        let b = Bearings::default();
        for j in [0, 1, 180, 359, 360] {
            assert!((b.index_of(b.bearing(j)) - j as f64).abs() < 1e-9);
        }
        assert!(b.index_of(PI) < 0.0 || b.index_of(PI) > 360.0);
    }
}
