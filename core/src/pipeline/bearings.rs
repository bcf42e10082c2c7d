//! `cos phi_j` and `sin phi_j` of every beam (ALGORITHM.md §1), as the fits
//! of §7 and split before reject read them.
//!
//! [`BearingTable`] is what a fit needs: the cosine and sine of beam `j`.
//! Two sources implement it:
//!
//! - [`Bearings`]: a caller's own per-beam tables (two slices);
//! - [`TwoLevelBearings`]: what the [`Extractor`](crate::Extractor) keeps,
//!   336 B instead of 3 208 B of full tables. Beam `j = FINE·k + l` has the
//!   bearing `A_k + B_l` with `A_k = phi_{FINE·k}` (coarse) and
//!   `B_l = l·gamma` (fine); both tables are filled once per geometry with
//!   [`crate::maths::cos_sin`] (f32 only), and a lookup is the angle-sum formulas in f32,
//!   in this order: `cos = cosA·cosB − sinA·sinB`, `sin = sinA·cosB +
//!   cosA·sinB` (no FMA, §9). Against an f64 reference the result stays
//!   within [`TWO_LEVEL_TOLERANCE`] (a unit test checks every beam of every
//!   LMS geometry); it differs from `cosf(phi_j)` by an ulp or so.
//!
//! Why not full tables in RAM: 3.2 KB of the co-processor's static RAM. Why
//! not `cosf`/`sinf` per access: on the M4F they run in software f64, about
//! 1 200 instructions each, and a scan reads a few thousand bearings.

use crate::frame::{Beam, Geometry, MAX_BEAMS};
use crate::maths::cos_sin;

/// Beams per coarse step of [`TwoLevelBearings`] (a power of two: the split
/// of `j` is a shift and a mask).
pub const FINE: usize = 16;

/// Coarse entries of [`TwoLevelBearings`]: enough for [`MAX_BEAMS`] beams.
pub const COARSE: usize = MAX_BEAMS.div_ceil(FINE);

/// Largest error of [`TwoLevelBearings`] against `cos`/`sin` in f64 of the
/// frame's f32 bearing `first_bearing + j·step` (evaluated in f64), as an
/// absolute value: 3 units of 2⁻²⁴ (half an ulp of 1). Measured over the
/// five LMS geometries: full tables of `cosf(phi_j)` at most 1.9 units on
/// the same reference, the two-level table at most 2.6 (unit test
/// `two_level_table_is_within_tolerance_of_f64`, `--nocapture` prints them).
pub const TWO_LEVEL_TOLERANCE: f64 = 3.0 / 16_777_216.0;

/// The cosine and sine of each beam's bearing, for the fits.
pub trait BearingTable: Copy {
    /// How many beams the table covers (beams `0..beams()`).
    fn beams(&self) -> usize;
    /// `(cos phi_j, sin phi_j)` for `j < beams()` (`(0, 0)` beyond).
    fn cos_sin(&self, j: usize) -> (f32, f32);
    /// For each beam `j = lo + i` of the sweep (cut to the shorter slice
    /// and to `beams()`), in order, `f(i, d_j, beam_j, cos(phi_j − α),
    /// sin(phi_j − α))`; a normal of `(1, 0)` gives `cos_sin(j)` exactly.
    fn sweep(&self, sweep: Sweep<'_>, f: impl FnMut(usize, f32, Beam, f32, f32));
}

/// A run of beams seen against a line's unit normal: beam `j = lo + i` has
/// the range `ranges[i]` and the status `beams[i]`.
#[derive(Clone, Copy, Debug)]
pub struct Sweep<'a> {
    /// The first beam's index.
    pub lo: usize,
    /// The beams' ranges (m).
    pub ranges: &'a [f32],
    /// The beams' statuses.
    pub beams: &'a [Beam],
    /// `(cos α, sin α)`: the unit normal the bearings are taken against.
    pub normal: (f32, f32),
}

/// `(cos(phi − α), sin(phi − α))` from `(cos phi, sin phi)` and
/// `(cos α, sin α)`, in this order.
#[inline(always)]
pub fn relative(c: f32, s: f32, ca: f32, sa: f32) -> (f32, f32) {
    (c * ca + s * sa, s * ca - c * sa)
}

/// The bearing tables of a frame: `cos phi_j`, `sin phi_j`.
#[derive(Clone, Copy, Debug)]
pub struct Bearings<'a> {
    /// `cos phi_j` for every beam.
    pub cos: &'a [f32],
    /// `sin phi_j` for every beam.
    pub sin: &'a [f32],
}

impl BearingTable for Bearings<'_> {
    #[inline]
    fn beams(&self) -> usize {
        self.cos.len().min(self.sin.len())
    }

    #[inline]
    fn cos_sin(&self, j: usize) -> (f32, f32) {
        match (self.cos.get(j), self.sin.get(j)) {
            (Some(&c), Some(&s)) => (c, s),
            _ => (0.0, 0.0),
        }
    }

    #[inline]
    fn sweep(&self, sweep: Sweep<'_>, mut f: impl FnMut(usize, f32, Beam, f32, f32)) {
        let (ca, sa) = sweep.normal;
        let (cos, sin) = (
            self.cos.get(sweep.lo..).unwrap_or_default(),
            self.sin.get(sweep.lo..).unwrap_or_default(),
        );
        let beams_and_ranges = sweep.ranges.iter().zip(sweep.beams);
        for (i, ((&d, &b), (&c, &s))) in beams_and_ranges.zip(cos.iter().zip(sin)).enumerate() {
            let (cd, sd) = relative(c, s, ca, sa);
            f(i, d, b, cd, sd);
        }
    }
}

/// Two-level bearing table for one [`Geometry`] (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLevelBearings {
    /// `(cos A_k, sin A_k)`, `A_k = phi_{FINE·k}`.
    coarse: [[f32; 2]; COARSE],
    /// `(cos B_l, sin B_l)`, `B_l = l·gamma`.
    fine: [[f32; 2]; FINE],
}

impl Default for TwoLevelBearings {
    fn default() -> Self {
        Self::new()
    }
}

impl TwoLevelBearings {
    /// An empty table (all zeros; `const`, for statics). Fill it with
    /// [`TwoLevelBearings::fill`] before use.
    pub const fn new() -> Self {
        TwoLevelBearings {
            coarse: [[0.0; 2]; COARSE],
            fine: [[0.0; 2]; FINE],
        }
    }

    /// The table of `geometry`.
    pub fn of(geometry: Geometry) -> Self {
        let mut t = Self::new();
        t.fill(geometry);
        t
    }

    /// Fill the table for `geometry`: `COARSE + FINE` calls of
    /// [`cos_sin`].
    pub fn fill(&mut self, geometry: Geometry) {
        for (k, slot) in self.coarse.iter_mut().enumerate() {
            let (c, s) = cos_sin(geometry.bearing(k * FINE));
            *slot = [c, s];
        }
        for (l, slot) in self.fine.iter_mut().enumerate() {
            let (c, s) = cos_sin(l as f32 * geometry.step);
            *slot = [c, s];
        }
    }

    /// `(cos phi_j, sin phi_j)` by the angle-sum formulas (fixed order).
    #[inline]
    pub fn cos_sin(&self, j: usize) -> (f32, f32) {
        let [ca, sa] = self.coarse[(j / FINE).min(COARSE - 1)];
        let [cb, sb] = self.fine[j % FINE];
        (ca * cb - sa * sb, sa * cb + ca * sb)
    }
}

impl BearingTable for &TwoLevelBearings {
    #[inline]
    fn beams(&self) -> usize {
        MAX_BEAMS
    }

    #[inline]
    fn cos_sin(&self, j: usize) -> (f32, f32) {
        TwoLevelBearings::cos_sin(self, j)
    }

    /// Per coarse step, `A_k − α` once (`relative` of the coarse entry),
    /// then per beam the angle sum with the fine entry: four products a
    /// beam, as many as the full tables needed for `phi_j − α`.
    #[inline]
    fn sweep(&self, sweep: Sweep<'_>, mut f: impl FnMut(usize, f32, Beam, f32, f32)) {
        let Sweep {
            lo,
            ranges,
            beams,
            normal: (ca, sa),
        } = sweep;
        let n = ranges
            .len()
            .min(beams.len())
            .min(MAX_BEAMS.saturating_sub(lo));
        let mut i = 0;
        while i < n {
            let j = lo + i;
            let (Some(&[c, s]), Some(fine)) =
                (self.coarse.get(j / FINE), self.fine.get(j % FINE..))
            else {
                return;
            };
            let end = (i + fine.len()).min(n);
            let (Some(now_r), Some(now_b)) = (ranges.get(i..end), beams.get(i..end)) else {
                return;
            };
            let (ck, sk) = relative(c, s, ca, sa);
            for ((&d, &b), &[cb, sb]) in now_r.iter().zip(now_b).zip(fine) {
                f(i, d, b, ck * cb - sk * sb, sk * cb + ck * sb);
                i += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Frame, Variant};

    const UNIT: f64 = 1.0 / 16_777_216.0; // 2⁻²⁴

    /// Largest absolute error over the beams of `geometry` of `table`
    /// against cos/sin in f64 of the f32 bearing evaluated in f64.
    fn max_error(geometry: Geometry, n: usize, table: impl Fn(usize) -> (f32, f32)) -> f64 {
        let mut worst = 0.0f64;
        for j in 0..n {
            let phi = geometry.first_bearing as f64 + j as f64 * geometry.step as f64;
            let (c, s) = table(j);
            worst = worst
                .max((c as f64 - phi.cos()).abs())
                .max((s as f64 - phi.sin()).abs());
        }
        worst
    }

    #[test]
    fn two_level_table_is_within_tolerance_of_f64() {
        for variant in [
            Variant::Fov100Res25,
            Variant::Fov100Res50,
            Variant::Fov100Res100,
            Variant::Fov180Res50,
            Variant::Fov180Res100,
        ] {
            let frame = Frame::for_variant(variant);
            let (g, n) = (frame.geometry(), frame.len());
            let t = TwoLevelBearings::of(g);
            let two = max_error(g, n, |j| t.cos_sin(j));
            let full = max_error(g, n, |j| {
                let phi = g.bearing(j);
                (libm::cosf(phi), libm::sinf(phi))
            });
            println!(
                "{variant:?}: two-level {:.2}, cosf/sinf {:.2} units of 2^-24",
                two / UNIT,
                full / UNIT
            );
            assert!(two <= TWO_LEVEL_TOLERANCE, "{variant:?}: {}", two / UNIT);
        }
    }

    #[test]
    fn a_wrong_table_fails_the_tolerance() {
        // The check can fail: a fine step off by one ulp of gamma.
        let frame = Frame::for_variant(Variant::Fov180Res50);
        let mut g = frame.geometry();
        let t = TwoLevelBearings::of(g);
        g.step = f32::from_bits(g.step.to_bits() + 1);
        assert!(max_error(g, frame.len(), |j| t.cos_sin(j)) > TWO_LEVEL_TOLERANCE);
    }

    #[test]
    fn slices_and_two_level_agree_on_the_beams() {
        let frame = Frame::for_variant(Variant::Fov180Res100);
        let t = TwoLevelBearings::of(frame.geometry());
        let (mut cos, mut sin) = ([0.0f32; MAX_BEAMS], [0.0f32; MAX_BEAMS]);
        for j in 0..MAX_BEAMS {
            (cos[j], sin[j]) = t.cos_sin(j);
        }
        let b = Bearings {
            cos: &cos[..frame.len()],
            sin: &sin[..frame.len()],
        };
        assert_eq!(b.beams(), frame.len());
        assert_eq!(BearingTable::cos_sin(&b, 7), t.cos_sin(7));
        assert_eq!(BearingTable::cos_sin(&b, frame.len()), (0.0, 0.0));
        // The relative angles: α = 0 is the table itself, bit for bit, and
        // every beam of a span is visited once, in order.
        let (ranges, beams) = ([1.0f32; MAX_BEAMS], [Beam::Valid; MAX_BEAMS]);
        let span = |lo: usize, hi: usize, normal| Sweep {
            lo,
            ranges: &ranges[lo..hi],
            beams: &beams[lo..hi],
            normal,
        };
        for (lo, hi) in [(0, 181), (5, 6), (15, 33), (170, 400), (3, 3), (390, 401)] {
            let mut seen = 0;
            (&t).sweep(span(lo, hi, (1.0, 0.0)), |i, _, _, c, s| {
                assert_eq!(i, seen);
                assert_eq!((c, s), t.cos_sin(lo + i));
                seen += 1;
            });
            assert_eq!(seen, hi - lo);
            let mut seen = 0;
            b.sweep(span(lo, hi, (1.0, 0.0)), |i, _, _, c, s| {
                assert_eq!((c, s), BearingTable::cos_sin(&b, lo + i));
                seen += 1;
            });
            assert_eq!(seen, hi.min(frame.len()).saturating_sub(lo));
        }
        // A rotated normal: cos(phi − α) within the tolerance of f64.
        let alpha = 0.3f64;
        let g = frame.geometry();
        let normal = (alpha.cos() as f32, alpha.sin() as f32);
        (&t).sweep(span(0, 181, normal), |j, _, _, c, s| {
            let d = g.first_bearing as f64 + j as f64 * g.step as f64 - alpha;
            assert!((c as f64 - d.cos()).abs() <= 2.0 * TWO_LEVEL_TOLERANCE);
            assert!((s as f64 - d.sin()).abs() <= 2.0 * TWO_LEVEL_TOLERANCE);
        });
    }
}
