//! One `LaserScan` → one [`Frame`]: the LMS variant of its geometry, and
//! its ranges quantised to the unit codes an LMS 2xx sends, read the way
//! the CARMEN reader reads a log's ranges (see the [parent](super) docs).

use anyhow::{bail, Result};
use lms_core::carmen::variant_for_beams;
use lms_core::{Frame, Invalid, Unit, Variant};

use crate::ros2::laser_scan::LaserScan;

/// Largest difference between `angle_min` and the variant's first bearing
/// (rad, about 0.06°).
const ANGLE_MIN_TOLERANCE: f32 = 1e-3;

/// Largest relative difference between `angle_increment` and the
/// variant's step.
const STEP_TOLERANCE: f32 = 1e-3;

/// Why the beams of the scans read so far are invalid, counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InvalidCounts {
    /// Ranges below the message's `range_min` (negative ones included).
    pub below_min: u64,
    /// Ranges above the message's `range_max`.
    pub above_max: u64,
    /// NaN or infinite ranges.
    pub not_finite: u64,
    /// Ranges within `range_min ..= range_max` whose unit code is an LMS
    /// error code or beyond the unit's largest value.
    pub error_code: u64,
    /// Ranges within the limits that quantise to code 0.
    pub zero: u64,
}

impl InvalidCounts {
    /// Every invalid beam counted.
    pub fn total(&self) -> u64 {
        self.below_min + self.above_max + self.not_finite + self.error_code + self.zero
    }
}

impl std::fmt::Display for InvalidCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} below range_min, {} above range_max, {} not finite",
            self.below_min, self.above_max, self.not_finite
        )?;
        if self.error_code > 0 {
            write!(f, ", {} at an LMS error code", self.error_code)?;
        }
        if self.zero > 0 {
            write!(f, ", {} zero", self.zero)?;
        }
        Ok(())
    }
}

/// The LMS 2xx variant of a scan's geometry: `angle_min` the variant's
/// first bearing (−90° or −50°), `angle_increment` its step (1°, 0.5° or
/// 0.25°), and as many ranges as it sends (180 and 360 too: CARMEN's
/// 181 and 361 without the last beam). Anything else is an error that
/// says what the scan holds.
pub fn variant_of(scan: &LaserScan) -> Result<Variant> {
    let n = scan.ranges.len();
    let fits = |v: Variant| {
        let g = v.geometry();
        (scan.angle_min - g.first_bearing).abs() <= ANGLE_MIN_TOLERANCE
            && (scan.angle_increment - g.step).abs() <= g.step * STEP_TOLERANCE
    };
    match variant_for_beams(n) {
        Some(v) if fits(v) => Ok(v),
        _ => bail!(
            "unsupported scan geometry: angle_min {:.3}°, angle_increment {:.4}°, {n} ranges \
             (an LMS 2xx scans 180° from -90° or 100° from -50°, at 1°, 0.5° or 0.25°: \
             181, 361, 101, 201 or 401 ranges)",
            scan.angle_min.to_degrees(),
            scan.angle_increment.to_degrees()
        ),
    }
}

/// The unit a bag's ranges are quantised in when `--unit` is `auto`,
/// decided on its first scan: mm when `range_max` lies below the first mm
/// error code (32.759 m: the LMS sends no longer range in mm); also mm
/// when at least a quarter of the valid ranges are not whole centimetres
/// and none reaches 32.759 m (mm data written with a larger `range_max`);
/// else cm.
pub fn unit_for(scan: &LaserScan) -> Unit {
    let mm = Unit::Millimetre;
    let first_mm_code = f64::from(mm.first_error_code());
    let code = (f64::from(scan.range_max) * f64::from(mm.per_metre())).round();
    if code.is_finite() && code < first_mm_code {
        return mm;
    }
    let valid = scan
        .ranges
        .iter()
        .map(|&r| f64::from(r))
        .filter(|r| r.is_finite() && *r > 0.0)
        .filter(|&r| r >= f64::from(scan.range_min) && r <= f64::from(scan.range_max));
    let (mut n, mut fine, mut long) = (0u64, 0u64, false);
    for r in valid {
        n += 1;
        let cm = r * 100.0;
        fine += u64::from((cm - cm.round()).abs() > 0.05);
        long |= (r * 1000.0).round() >= first_mm_code;
    }
    if n > 0 && !long && fine * 4 >= n {
        mm
    } else {
        Unit::Centimetre
    }
}

/// The reason of an invalid `code`: its LMS error code when it is one,
/// else above the maximum range.
fn code_reason(code: i64, unit: Unit) -> Invalid {
    let all_ones = i64::from(unit.all_ones());
    if (i64::from(unit.first_error_code())..=all_ones).contains(&code) {
        Invalid::from_code_offset(u16::try_from(all_ones - code).unwrap_or(u16::MAX))
    } else {
        Invalid::AboveMax
    }
}

/// The frame of `scan` in `unit` (see the [parent](super) docs), its
/// invalid beams counted in `counts`.
pub fn frame_of(scan: &LaserScan, unit: Unit, counts: &mut InvalidCounts) -> Result<Frame> {
    let variant = variant_of(scan)?;
    let n = scan.ranges.len();
    let Ok(mut frame) = Frame::new(variant.geometry(), n) else {
        bail!("{n} ranges: not a frame");
    };
    let per_metre = f64::from(unit.per_metre());
    let first_code = i64::from(unit.first_error_code());
    for (j, &r) in scan.ranges.iter().enumerate() {
        if !r.is_finite() {
            counts.not_finite += 1;
            frame.set_invalid(j, Invalid::NotFinite);
            continue;
        }
        if r < scan.range_min {
            counts.below_min += 1;
            frame.set_invalid(j, Invalid::Zero);
            continue;
        }
        // The unit code the sensor sends for this range.
        let code = (f64::from(r) * per_metre).round() as i64;
        if r > scan.range_max {
            counts.above_max += 1;
            frame.set_invalid(j, code_reason(code, unit));
        } else if code >= first_code {
            counts.error_code += 1;
            frame.set_invalid(j, code_reason(code, unit));
        } else if code == 0 {
            counts.zero += 1;
            frame.set_invalid(j, Invalid::Zero);
        } else {
            // The f32 nearest code / per_metre: the f64 quotient is within
            // half an f64 ulp, far from any f32 rounding midpoint, so this
            // is the f32 the decimal text of the code parses to.
            frame.set_metres(j, (code as f64 / per_metre) as f32);
        }
    }
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(variant: Variant, ranges: Vec<f32>) -> LaserScan {
        let g = variant.geometry();
        LaserScan {
            angle_min: g.first_bearing,
            angle_increment: g.step,
            range_min: 0.0,
            range_max: 81.82,
            ranges,
            ..LaserScan::default()
        }
    }

    #[test]
    fn quantised_ranges_are_the_f32_of_their_decimal_text() {
        for code in 1..8183i64 {
            let text = format!("{}.{:02}", code / 100, code % 100);
            let expect: f32 = text.parse().unwrap();
            let mut counts = InvalidCounts::default();
            let s = scan(Variant::Fov180Res100, vec![expect; 181]);
            let f = frame_of(&s, Unit::Centimetre, &mut counts).unwrap();
            assert_eq!(f.ranges()[0].to_bits(), expect.to_bits(), "{text}");
        }
        for code in (1..32759i64).step_by(7) {
            let text = format!("{}.{:03}", code / 1000, code % 1000);
            let expect: f32 = text.parse().unwrap();
            let mut s = scan(Variant::Fov100Res25, vec![expect; 401]);
            s.range_max = 32.758;
            let f = frame_of(&s, Unit::Millimetre, &mut InvalidCounts::default()).unwrap();
            assert_eq!(f.ranges()[400].to_bits(), expect.to_bits(), "{text}");
        }
    }

    #[test]
    fn the_unit_follows_range_max_then_the_data() {
        let with = |range_max: f32, ranges: Vec<f32>| {
            let mut s = scan(Variant::Fov180Res100, ranges);
            s.range_max = range_max;
            unit_for(&s)
        };
        let cm = vec![1.23f32; 181];
        assert_eq!(with(8.1, cm.clone()), Unit::Millimetre);
        assert_eq!(with(32.758, cm.clone()), Unit::Millimetre);
        assert_eq!(with(32.759, cm.clone()), Unit::Centimetre);
        assert_eq!(with(81.82, cm.clone()), Unit::Centimetre);
        assert_eq!(with(f32::INFINITY, cm), Unit::Centimetre);
        // mm data under a large range_max: a quarter of them not whole cm.
        let mut mixed = vec![1.23f32; 181];
        mixed[..46].fill(1.234);
        assert_eq!(with(81.83, mixed.clone()), Unit::Millimetre);
        mixed[..44].fill(1.23);
        assert_eq!(with(81.83, mixed.clone()), Unit::Centimetre);
        // ... unless a range is beyond what mm can say.
        let mut long = vec![1.234f32; 181];
        long[0] = 40.0;
        assert_eq!(with(81.83, long), Unit::Centimetre);
        // No valid range: cm.
        assert_eq!(with(81.83, vec![f32::INFINITY; 181]), Unit::Centimetre);
    }
}
