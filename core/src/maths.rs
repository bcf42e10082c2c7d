//! Small fixed-size numerics used by the stages: 3-vectors, symmetric 3×3 and
//! 2×2 matrices with closed-form inverses, and angle wrapping.
//!
//! Every operation is written out term by term in `f32` with a fixed order of
//! evaluation, so the same inputs give the same bits on every target
//! (ALGORITHM.md §9). No fused multiply-add is used.

/// A 3-vector (one window: first, middle, last beam).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Vec3(pub [f32; 3]);

impl core::ops::Sub for Vec3 {
    type Output = Vec3;
    /// Component-wise difference.
    #[inline]
    fn sub(self, o: Vec3) -> Vec3 {
        Vec3([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}

impl core::ops::Add for Vec3 {
    type Output = Vec3;
    /// Component-wise sum.
    #[inline]
    fn add(self, o: Vec3) -> Vec3 {
        Vec3([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}

impl Vec3 {
    /// Dot product `self·other`, summed in index order.
    #[inline]
    pub fn dot(self, o: Vec3) -> f32 {
        self.0[0] * o.0[0] + self.0[1] * o.0[1] + self.0[2] * o.0[2]
    }
}

/// A symmetric 3×3 matrix stored as its upper triangle.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sym3 {
    /// Element (1,1).
    pub s11: f32,
    /// Element (1,2) = (2,1).
    pub s12: f32,
    /// Element (1,3) = (3,1).
    pub s13: f32,
    /// Element (2,2).
    pub s22: f32,
    /// Element (2,3) = (3,2).
    pub s23: f32,
    /// Element (3,3).
    pub s33: f32,
}

impl Sym3 {
    /// `self + d·I`.
    #[inline]
    pub fn add_diagonal(self, d: f32) -> Sym3 {
        Sym3 {
            s11: self.s11 + d,
            s22: self.s22 + d,
            s33: self.s33 + d,
            ..self
        }
    }

    /// `self · v`.
    #[inline]
    pub fn mul_vec(&self, v: Vec3) -> Vec3 {
        let [a, b, c] = v.0;
        Vec3([
            self.s11 * a + self.s12 * b + self.s13 * c,
            self.s12 * a + self.s22 * b + self.s23 * c,
            self.s13 * a + self.s23 * b + self.s33 * c,
        ])
    }

    /// Solve `self · u = v` for a positive definite `self` by the adjugate:
    /// `u = adj(S)·v / det(S)` (cofactors of the symmetric matrix, eq. of §3).
    ///
    /// `None` unless `det > 0` and finite (for the innovation covariance of
    /// §3 this holds for finite inputs with `sigma > 0`).
    #[inline]
    pub fn solve_spd(&self, v: Vec3) -> Option<Vec3> {
        match self.solve_spd_unchecked(v) {
            (u, true) => Some(u),
            _ => None,
        }
    }

    /// The cofactors `c11, c12, c13, c22, c23, c33` of the adjugate and the
    /// determinant `s11·c11 + s12·c12 + s13·c13` (one evaluation order for
    /// every caller).
    #[inline(always)]
    fn cofactors(&self) -> ([f32; 6], f32) {
        let c11 = self.s22 * self.s33 - self.s23 * self.s23;
        let c12 = self.s13 * self.s23 - self.s12 * self.s33;
        let c13 = self.s12 * self.s23 - self.s13 * self.s22;
        let c22 = self.s11 * self.s33 - self.s13 * self.s13;
        let c23 = self.s12 * self.s13 - self.s11 * self.s23;
        let c33 = self.s11 * self.s22 - self.s12 * self.s12;
        let det = self.s11 * c11 + self.s12 * c12 + self.s13 * c13;
        ([c11, c12, c13, c22, c23, c33], det)
    }

    /// [`Sym3::solve_spd`] without the branch: always computes `u`, and
    /// returns whether `det > 0` and finite.
    #[inline(always)]
    pub fn solve_spd_unchecked(&self, v: Vec3) -> (Vec3, bool) {
        let (u, det) = self.solve_adjugate(v);
        (u, (det > 0.0) & (det < f32::INFINITY))
    }

    /// `u = adj(S)·v / det(S)` and `det(S)`, with no check at all: the
    /// caller decides from `det` (for a `det` of `+0` or `+inf`, `u` is
    /// non-finite or 0).
    #[inline(always)]
    pub fn solve_adjugate(&self, v: Vec3) -> (Vec3, f32) {
        let ([c11, c12, c13, c22, c23, c33], det) = self.cofactors();
        let inv_det = 1.0 / det;
        let [x, y, z] = v.0;
        (
            Vec3([
                (c11 * x + c12 * y + c13 * z) * inv_det,
                (c12 * x + c22 * y + c23 * z) * inv_det,
                (c13 * x + c23 * y + c33 * z) * inv_det,
            ]),
            det,
        )
    }

    /// Closed-form inverse by cofactors: `adj(S) / det(S)`.
    ///
    /// Returns `None` unless the matrix is positive definite by its leading
    /// minors (`s11 > 0`, `s11·s22 − s12² > 0`, `det > 0`) and the result is
    /// finite. For the innovation covariance of §3 this always holds for
    /// finite inputs with `sigma > 0`.
    pub fn inverse_spd(&self) -> Option<Sym3> {
        let ([c11, c12, c13, c22, c23, c33], det) = self.cofactors();
        if !(self.s11 > 0.0 && c33 > 0.0 && det > 0.0 && det.is_finite()) {
            return None;
        }
        let inv_det = 1.0 / det;
        let inv = Sym3 {
            s11: c11 * inv_det,
            s12: c12 * inv_det,
            s13: c13 * inv_det,
            s22: c22 * inv_det,
            s23: c23 * inv_det,
            s33: c33 * inv_det,
        };
        if inv.s11.is_finite()
            && inv.s12.is_finite()
            && inv.s13.is_finite()
            && inv.s22.is_finite()
            && inv.s23.is_finite()
            && inv.s33.is_finite()
        {
            Some(inv)
        } else {
            None
        }
    }
}

/// A symmetric 2×2 matrix `[[a, b], [b, c]]` (covariances of (α, r) and (x, y)).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sym2 {
    /// Element (1,1).
    pub a: f32,
    /// Element (1,2) = (2,1).
    pub b: f32,
    /// Element (2,2).
    pub c: f32,
}

impl Sym2 {
    /// Determinant `a·c − b²`.
    #[inline]
    pub fn det(&self) -> f32 {
        self.a * self.c - self.b * self.b
    }

    /// `self + other`.
    #[inline]
    pub fn add(&self, o: &Sym2) -> Sym2 {
        Sym2 {
            a: self.a + o.a,
            b: self.b + o.b,
            c: self.c + o.c,
        }
    }

    /// `s · self`.
    #[inline]
    pub fn scale(&self, s: f32) -> Sym2 {
        Sym2 {
            a: self.a * s,
            b: self.b * s,
            c: self.c * s,
        }
    }

    /// Closed-form inverse, `None` unless positive definite and finite.
    pub fn inverse_spd(&self) -> Option<Sym2> {
        let det = self.det();
        if !(self.a > 0.0 && det > 0.0 && det.is_finite()) {
            return None;
        }
        let inv = Sym2 {
            a: self.c / det,
            b: -self.b / det,
            c: self.a / det,
        };
        if inv.a.is_finite() && inv.b.is_finite() && inv.c.is_finite() {
            Some(inv)
        } else {
            None
        }
    }

    /// Quadratic form `[x, y]·self·[x, y]ᵀ`.
    #[inline]
    pub fn quad(&self, x: f32, y: f32) -> f32 {
        self.a * x * x + 2.0 * self.b * x * y + self.c * y * y
    }

    /// As a row-major array `[[a, b], [b, c]]`.
    #[inline]
    pub fn to_array(&self) -> [[f32; 2]; 2] {
        [[self.a, self.b], [self.b, self.c]]
    }
}

/// Wrap an angle in radians into (−π, π].
pub fn wrap_angle(a: f32) -> f32 {
    use core::f32::consts::PI;
    if !a.is_finite() {
        return a;
    }
    let mut w = libm::remainderf(a, 2.0 * PI);
    if w <= -PI {
        w += 2.0 * PI;
    } else if w > PI {
        w -= 2.0 * PI;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sym3_inverse_times_matrix_is_identity() {
        let s = Sym3 {
            s11: 4.0,
            s12: 1.0,
            s13: 0.5,
            s22: 3.0,
            s23: -0.25,
            s33: 2.0,
        };
        let inv = s.inverse_spd().unwrap();
        for (k, e) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .iter()
            .enumerate()
        {
            let col = inv.mul_vec(Vec3(*e));
            let back = s.mul_vec(col);
            for i in 0..3 {
                let want = if i == k { 1.0 } else { 0.0 };
                assert!((back.0[i] - want).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn indefinite_matrices_have_no_inverse() {
        let s = Sym3 {
            s11: 1.0,
            s12: 2.0,
            s13: 0.0,
            s22: 1.0,
            s23: 0.0,
            s33: 1.0,
        };
        assert!(s.inverse_spd().is_none());
        assert!(Sym2 {
            a: 1.0,
            b: 1.0,
            c: 1.0
        }
        .inverse_spd()
        .is_none());
        assert!(Sym2 {
            a: 2.0,
            b: 1.0,
            c: 1.0
        }
        .inverse_spd()
        .is_some());
    }

    #[test]
    fn angles_wrap_into_half_open_interval() {
        use core::f32::consts::PI;
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-6);
        assert_eq!(wrap_angle(PI), PI);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-6);
        assert!((wrap_angle(0.25) - 0.25).abs() < 1e-7);
    }
}
