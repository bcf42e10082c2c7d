//! Small fixed-size numerics used by the stages: 3-vectors, symmetric 3×3 and
//! 2×2 matrices with closed-form inverses, and angle wrapping.
//!
//! Every operation is written out term by term in `f32` with a fixed order of
//! evaluation, so the same inputs give the same bits on every target
//! (ALGORITHM.md §9). No fused multiply-add is used.

use core::num::{NonZeroU32, NonZeroU64};

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

/// Wrap an angle in radians into (−π, π] (`π` the f32 constant; a
/// non-finite angle is returned as it is).
///
/// The result is the one value in (−π, π] that differs from `a` by an
/// integer multiple of `2π` (f32), computed exactly: `|a|` is reduced by
/// `2π·2^e`, largest `e` first (each subtraction exact by Sterbenz's
/// lemma, as in `fmod`), then moved into (−π, π] by one more `2π` (exact:
/// both operands and the result are multiples of 2⁻²² below 8). So it is
/// bit for bit what `remainderf(a, 2π)` and the same move give, without
/// libm's `remainderf` (368 B of flash on the M4F).
pub fn wrap_angle(a: f32) -> f32 {
    use core::f32::consts::PI;
    const TWO_PI: f32 = 2.0 * PI;
    if !a.is_finite() {
        return a;
    }
    let mut r = if a < 0.0 { -a } else { a };
    if r >= TWO_PI {
        // m = 2π·2^e ≤ r < 2m (2m overflows to +inf only beyond f32::MAX / 2).
        let mut m = TWO_PI;
        while m * 2.0 <= r {
            m *= 2.0;
        }
        while m >= TWO_PI {
            if r >= m {
                r -= m; // r < 2m: exact
            }
            m *= 0.5;
        }
    }
    let mut w = if a < 0.0 { -r } else { r };
    if w <= -PI {
        w += 2.0 * PI;
    } else if w > PI {
        w -= 2.0 * PI;
    }
    w
}

/// Largest error of [`atan2`] against `atan2` in f64 of the f32 arguments,
/// absolute (rad): six units of 2⁻²⁴ (3.6·10⁻⁷). Measured 4.8 units over
/// the unit circle at radii 10⁻³⁰…10³⁰, libm's `atan2f` 4.2 on the same
/// points (unit test `atan2_is_within_tolerance_of_f64`): near ±π the
/// result's own rounding is half an ulp of π, 2 units.
pub const ATAN2_TOLERANCE: f64 = 6.0 / 16_777_216.0;

/// `atan2(y, x)` in [−π, π] (rad) in f32 arithmetic only, as libm's
/// `atan2f` with the same special values for zeros and signs (NaN in, NaN
/// out; both infinite: the angle of the diagonal). libm's `atan2f` and
/// `atanf` take 600 B of flash on the M4F; this is about a third.
///
/// Method: the ratio `t = min/max ∈ [0, 1]` of `|y|`, `|x|`; above
/// `tan(π/8)`, `atan t = π/4 + atan((t − 1)/(t + 1))`; then the Taylor
/// series of `atan u` to `u¹⁷` for `|u| ≤ tan(π/8)` (truncation below
/// 3·10⁻⁹), and the octant put back (`π/2 − a`, `π − a`, the sign of `y`).
/// Fixed order, no FMA (§9). With the `libm-trig` feature: libm's `atan2f`.
pub fn atan2(y: f32, x: f32) -> f32 {
    use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    if cfg!(feature = "libm-trig") {
        return libm::atan2f(y, x); // ALGORITHM.md §9 as written
    }
    /// tan(π/8).
    const TAN_PI_8: f32 = 0.414_213_57;
    // π, π/2, π/4 minus their f32 values (the f32 values are above).
    const PI_LO: f32 = -8.742_278e-8;
    const FRAC_PI_2_LO: f32 = -4.371_139e-8;
    const FRAC_PI_4_LO: f32 = -2.185_569_4e-8;
    let (ax, ay) = (libm::fabsf(x), libm::fabsf(y));
    let swap = ay > ax;
    let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
    // NaN in either goes through every step below (0·NaN, NaN/…).
    let t = if den == 0.0 {
        num * 0.0
    } else if den == f32::INFINITY && num == f32::INFINITY {
        1.0 // both infinite
    } else {
        num / den
    };
    let (base, base_lo, u) = if t > TAN_PI_8 {
        (FRAC_PI_4, FRAC_PI_4_LO, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, 0.0, t)
    };
    let z = u * u;
    // atan u = u − u³/3 + u⁵/5 − … + u¹⁷/17.
    let p = -1.0 / 3.0
        + z * (1.0 / 5.0
            + z * (-1.0 / 7.0
                + z * (1.0 / 9.0
                    + z * (-1.0 / 11.0
                        + z * (1.0 / 13.0 + z * (-1.0 / 15.0 + z * (1.0 / 17.0)))))));
    // The constants' low parts added first, the rounding of each step once.
    let mut a = base + (base_lo + (u + u * (z * p)));
    if swap {
        a = FRAC_PI_2 - (a - FRAC_PI_2_LO);
    }
    if x.is_sign_negative() {
        a = PI - (a - PI_LO);
    }
    libm::copysignf(a, y)
}

/// Largest `|x|` (rad) for which [`cos_sin`] keeps its accuracy: the
/// quadrant count `k` stays below 2¹², so `k·P1` and `k·P2` of the
/// three-part `π/2` are exact. Beyond it the result is still finite for a
/// finite `x` and never panics, but inaccurate (no bearing, line angle or
/// beam step of the pipeline comes near it).
pub const COS_SIN_MAX_ARG: f32 = 6_000.0;

/// Largest error of [`cos_sin`] against `cos`/`sin` in f64 of the f32
/// argument, absolute: one unit of 2⁻²⁴ (half an ulp of 1). Measured:
/// 0.87 units over `|x| ≤ 4` (unit test `cos_sin_is_within_tolerance_of_f64`;
/// libm's `cosf`/`sinf`, which evaluate in f64, stay within 0.5).
pub const COS_SIN_TOLERANCE: f64 = 1.0 / 16_777_216.0;

/// `(cos x, sin x)` in f32 arithmetic only (x in rad).
///
/// libm's `cosf`/`sinf` evaluate in f64, which the M4F has no hardware
/// for: they pull in about 5.6 KB of software f64 and the large-argument
/// reduction. Here: `x = k·π/2 + r` by Cody–Waite with `π/2` in three parts
/// (`P1`, `P2` of 12 bits, `P3` the f32 rest; `r` kept as `r + t`, `t` the
/// rounding of the last step), then the Taylor series of `sin r` to `r¹¹`
/// and `cos r` to `r¹²` (truncation below 10⁻¹¹ for `|r| ≤ π/4`), the tail
/// `t` added to first order, and the quadrant from `k mod 4`. Fixed order,
/// no FMA (§9). Within [`COS_SIN_TOLERANCE`] for `|x| ≤` [`COS_SIN_MAX_ARG`].
/// With the `libm-trig` feature: libm's `cosf`/`sinf` (§9's wording).
pub fn cos_sin(x: f32) -> (f32, f32) {
    if cfg!(feature = "libm-trig") {
        return (libm::cosf(x), libm::sinf(x)); // ALGORITHM.md §9 as written
    }
    // π/2 = P1 + P2 + P3 (P1, P2 with 12 significant bits each).
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_513e-4;
    const P3: f32 = 7.549_79e-8;
    const TWO_OVER_PI: f32 = core::f32::consts::FRAC_2_PI;
    let q = x * TWO_OVER_PI;
    // Round to nearest; `as` saturates (NaN gives 0, r stays NaN).
    let k = if q < 0.0 { q - 0.5 } else { q + 0.5 } as i32;
    let kf = k as f32;
    let r1 = (x - kf * P1) - kf * P2;
    let p3 = kf * P3;
    let r = r1 - p3;
    let t = (r1 - r) - p3;
    let z = r * r;
    // sin r = r − r³/3! + … − r¹¹/11!, cos r = 1 − r²/2! + … + r¹²/12!.
    let sp = -1.0 / 6.0
        + z * (1.0 / 120.0
            + z * (-1.0 / 5_040.0 + z * (1.0 / 362_880.0 + z * (-1.0 / 39_916_800.0))));
    let cp = 1.0 / 24.0
        + z * (-1.0 / 720.0
            + z * (1.0 / 40_320.0 + z * (-1.0 / 3_628_800.0 + z * (1.0 / 479_001_600.0))));
    // sin(r + t) ≈ sin r + t·cos r, cos(r + t) ≈ cos r − t·sin r (|t| tiny).
    let s = r + (t + r * (z * sp));
    // 1 − z/2 rounded, and its rounding error added back with the rest.
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    let c = w + (((1.0 - w) - hz) + (z * (z * cp) - t * r));
    match k & 3 {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

/// `(n / d, n % d)` for 64-bit integers without the compiler's 64-bit
/// division routine (`__aeabi_uldivmod`, 0.9 KB of flash on the
/// Cortex-M4, which divides only 32-bit numbers in hardware): one hardware
/// division when `n` fits 32 bits; three when `d` fits 16 bits (schoolbook
/// division in 16-bit digits, each partial dividend below 2³²); else binary
/// long division over the quotient's bits only (≤ 64 − 16 steps). Exact:
/// the same results as `/` and `%` on every target. The divisor is never
/// zero ([`NonZeroU64`]; [`divisor`] for constants), so there is no panic
/// path.
///
/// The device layer's timekeeping (µs since boot, line times) and the
/// firmware's decimal output use it; the pipeline has no integer division.
pub const fn div_rem_u64(n: u64, d: NonZeroU64) -> (u64, u64) {
    let d = d.get();
    if n < d {
        return (0, n);
    }
    // `d` as a 32-bit divisor when it fits (it is not zero).
    let d32 = match NonZeroU32::new(d as u32) {
        Some(d32) if d <= u32::MAX as u64 => Some(d32),
        _ => None,
    };
    if let (true, Some(d)) = (n <= u32::MAX as u64, d32) {
        // d ≤ n: both fit 32 bits.
        let (q, r) = div_rem_u32(n as u32, d);
        return (q as u64, r as u64);
    }
    if let (true, Some(d)) = (d <= u16::MAX as u64, d32) {
        // n = hi·2³² + mid·2¹⁶ + lo; each remainder is below d < 2¹⁶, so
        // every partial dividend (r << 16 | digit) fits 32 bits.
        let (q_hi, r) = div_rem_u32((n >> 32) as u32, d);
        let (q_mid, r) = div_rem_u32((r << 16) | ((n >> 16) as u32 & 0xFFFF), d);
        let (q_lo, r) = div_rem_u32((r << 16) | (n as u32 & 0xFFFF), d);
        return (
            ((q_hi as u64) << 32) | ((q_mid as u64) << 16) | q_lo as u64,
            r as u64,
        );
    }
    if d > u64::MAX >> 1 {
        // n ≥ d > 2⁶³: the quotient is 1.
        return (1, n - d);
    }
    // The quotient has at most `shift + 1` bits: start with the dividend's
    // top bits that are as long as d.
    let shift = d.leading_zeros() - n.leading_zeros();
    let mut r = n >> shift;
    let mut q = 0u64;
    if r >= d {
        r -= d;
        q = 1;
    }
    let mut bit = shift;
    while bit > 0 {
        bit -= 1;
        // r < d ≤ 2⁶³, so the shift cannot overflow.
        r = (r << 1) | ((n >> bit) & 1);
        q <<= 1;
        if r >= d {
            r -= d;
            q |= 1;
        }
    }
    (q, r)
}

/// `(n / d, n % d)` in 32 bits (one hardware division on the Cortex-M4);
/// `checked_`: no panic path for the firmware's link-time check.
const fn div_rem_u32(n: u32, d: NonZeroU32) -> (u32, u32) {
    let d = d.get();
    match (n.checked_div(d), n.checked_rem(d)) {
        (Some(q), Some(r)) => (q, r),
        _ => (0, n),
    }
}

/// `n / d` rounded down, as [`div_rem_u64`].
#[inline]
pub const fn div_u64(n: u64, d: NonZeroU64) -> u64 {
    div_rem_u64(n, d).0
}

/// `n / d` rounded up, as [`div_rem_u64`].
#[inline]
pub const fn div_ceil_u64(n: u64, d: NonZeroU64) -> u64 {
    let (q, r) = div_rem_u64(n, d);
    if r != 0 {
        q + 1
    } else {
        q
    }
}

/// `d` as a divisor, for constants and values that are at least 1 by
/// construction: 0 becomes 1 (as `d.max(1)`), so no caller needs a panic
/// path.
#[inline]
pub const fn divisor(d: u64) -> NonZeroU64 {
    match NonZeroU64::new(d) {
        Some(d) => d,
        None => NonZeroU64::MIN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_is_remainderf_bit_for_bit() {
        use core::f32::consts::PI;
        let by_remainder = |a: f32| {
            let mut w = libm::remainderf(a, 2.0 * PI);
            if w <= -PI {
                w += 2.0 * PI;
            } else if w > PI {
                w -= 2.0 * PI;
            }
            w
        };
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut checked = 0;
        for _ in 0..400_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // Every exponent (random bits), and angles near the multiples of π.
            let a = if state & 1 == 0 {
                f32::from_bits((state >> 32) as u32)
            } else {
                let k = ((state >> 8) % 41) as f32 - 20.0;
                k * PI + ((state >> 16) % 2001) as f32 * 1e-6 - 1e-3
            };
            if !a.is_finite() {
                continue;
            }
            let (w, want) = (wrap_angle(a), by_remainder(a));
            assert_eq!(w.to_bits(), want.to_bits(), "{a:e}: {w} vs {want}");
            assert!(w > -PI && w <= PI);
            checked += 1;
        }
        assert!(checked > 300_000);
        for a in [
            PI,
            -PI,
            2.0 * PI,
            -2.0 * PI,
            3.0 * PI,
            f32::MAX,
            -f32::MAX,
            0.0,
            -0.0,
        ] {
            assert_eq!(wrap_angle(a).to_bits(), by_remainder(a).to_bits(), "{a:e}");
        }
        assert!(wrap_angle(f32::NAN).is_nan());
        assert_eq!(wrap_angle(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn atan2_is_within_tolerance_of_f64() {
        const UNIT: f64 = 1.0 / 16_777_216.0;
        let (mut worst, mut libm_worst) = (0.0f64, 0.0f64);
        let mut k = 0u32;
        while k < 2_000_000 {
            // The unit circle densely, and radii from 1e-30 to 1e30.
            let phi = -3.2 + 6.4 * f64::from(k) / 2_000_000.0;
            let radius = 10f64.powi((k % 61) as i32 - 30);
            let (y, x) = ((radius * phi.sin()) as f32, (radius * phi.cos()) as f32);
            let exact = f64::from(y).atan2(f64::from(x));
            worst = worst.max((f64::from(atan2(y, x)) - exact).abs());
            libm_worst = libm_worst.max((f64::from(libm::atan2f(y, x)) - exact).abs());
            k += 1;
        }
        println!(
            "atan2: {:.3} units of 2^-24 (libm atan2f {:.3})",
            worst / UNIT,
            libm_worst / UNIT
        );
        assert!(worst <= ATAN2_TOLERANCE, "{}", worst / UNIT);
        // The special values of atan2 (C99 / libm), bit for bit.
        let specials = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-45,
            f32::MAX,
        ];
        for &y in &specials {
            for &x in &specials {
                let (got, want) = (atan2(y, x), libm::atan2f(y, x));
                assert!(
                    (f64::from(got) - f64::from(want)).abs() <= ATAN2_TOLERANCE,
                    "atan2({y}, {x}) = {got}, libm {want}"
                );
                assert_eq!(
                    got.is_sign_negative(),
                    want.is_sign_negative(),
                    "({y}, {x})"
                );
            }
        }
        for (y, x) in [
            (f32::NAN, 1.0),
            (1.0, f32::NAN),
            (f32::NAN, 0.0),
            (0.0, f32::NAN),
        ] {
            assert!(atan2(y, x).is_nan(), "({y}, {x})");
        }
        for (y, x) in [(f32::NAN, f32::INFINITY), (f32::INFINITY, f32::NAN)] {
            assert!(atan2(y, x).is_nan(), "({y}, {x})");
        }
        assert_eq!(atan2(0.0, -1.0), core::f32::consts::PI);
        assert_eq!(atan2(-0.0, -1.0), -core::f32::consts::PI);
    }

    #[test]
    fn cos_sin_is_within_tolerance_of_f64() {
        const UNIT: f64 = 1.0 / 16_777_216.0;
        let mut worst = 0.0f64;
        let mut x = -4.0f32;
        while x <= 4.0 {
            // A dense sweep plus the neighbours of each point (every ulp pattern).
            for bits in [x.to_bits(), x.to_bits() ^ 1, x.to_bits() ^ 0x55] {
                let x = f32::from_bits(bits);
                let (c, s) = cos_sin(x);
                let xd = f64::from(x);
                worst = worst
                    .max((f64::from(c) - xd.cos()).abs())
                    .max((f64::from(s) - xd.sin()).abs());
            }
            x += 1.0e-4;
        }
        for x in [
            0.0f32,
            1e-30,
            -1e-20,
            1e-4,
            core::f32::consts::FRAC_PI_2,
            100.0,
            -1_000.0,
            5_999.0,
        ] {
            let (c, s) = cos_sin(x);
            let xd = f64::from(x);
            worst = worst
                .max((f64::from(c) - xd.cos()).abs())
                .max((f64::from(s) - xd.sin()).abs());
        }
        println!("cos_sin: {:.3} units of 2^-24", worst / UNIT);
        assert!(worst <= COS_SIN_TOLERANCE, "{}", worst / UNIT);
        // Exact where it must be: cos 0 = 1, sin 0 = 0, sin of a tiny x is x.
        assert_eq!(cos_sin(0.0), (1.0, 0.0));
        assert_eq!(cos_sin(1e-20).1, 1e-20);
        // No panic on nonsense; NaN stays NaN.
        let (c, s) = cos_sin(f32::NAN);
        assert!(c.is_nan() && s.is_nan());
        let (c, s) = cos_sin(f32::MAX);
        let _ = (c, s);
        let (c, s) = cos_sin(f32::INFINITY);
        assert!(c.is_nan() && s.is_nan());
    }

    #[test]
    fn a_wrong_cos_sin_fails_the_tolerance() {
        // The check can fail: an angle four ulps off (4.8e-7 rad) at 1.5 rad.
        let x = 1.5f32;
        let (c, _) = cos_sin(x + 5.0e-7);
        assert!((f64::from(c) - f64::from(x).cos()).abs() > 4.0 * COS_SIN_TOLERANCE);
    }

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
