//! The sensor's noise model and its readings, with conversions to the LMS
//! raw integer values and to `f32` metres.

use rand::Rng;
use rand_distr::StandardNormal;

/// Raw value of an LMS beam with no echo / not valid (13-bit error code).
pub const RAW_NO_ECHO: u16 = 8191;
/// Raw value for a range above the maximum (13-bit error code), also the
/// first error code: every raw value at or above it is invalid.
pub const RAW_ABOVE_MAX: u16 = 8183;
/// The `f32` marker [`Reading::to_f32`] gives a beam without a return. A
/// range of 0 is invalid (ALGORITHM.md §1).
pub const NO_RETURN_F32: f32 = 0.0;

/// Unit of the LMS range values: the core's one unit type (the sensor's
/// mm, cm or 10 cm mode).
pub use lms_core::Unit;

/// Units per metre (1000, 100 or 10), exactly, as `f64`.
fn per_metre(unit: Unit) -> f64 {
    f64::from(unit.per_metre())
}

/// `metres` rounded to the nearest whole `unit` (m).
pub fn quantise(unit: Unit, metres: f64) -> f64 {
    (metres * per_metre(unit)).round() / per_metre(unit)
}

/// One simulated beam.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// A range in metres (> 0).
    Range(f64),
    /// No echo: nothing within the maximum range, or a dropout.
    NoReturn,
}

impl Reading {
    /// The range in metres, if there is one.
    pub fn metres(self) -> Option<f64> {
        match self {
            Reading::Range(d) => Some(d),
            Reading::NoReturn => None,
        }
    }

    /// `true` for [`Reading::Range`].
    pub fn is_return(self) -> bool {
        matches!(self, Reading::Range(_))
    }

    /// The LMS raw value in `unit`: the range rounded to whole units,
    /// [`RAW_ABOVE_MAX`] if that reaches the error codes (≥ 8183, i.e. from
    /// 8.1825 m in mm mode), [`RAW_NO_ECHO`] without a return.
    pub fn to_raw(self, unit: Unit) -> u16 {
        match self {
            Reading::Range(d) => {
                let v = (d * per_metre(unit)).round();
                if v >= f64::from(RAW_ABOVE_MAX) {
                    RAW_ABOVE_MAX
                } else {
                    // 0 ≤ v < 8183 here, so the cast is exact.
                    v.max(0.0) as u16
                }
            }
            Reading::NoReturn => RAW_NO_ECHO,
        }
    }

    /// The range as `f32` metres, [`NO_RETURN_F32`] without a return.
    pub fn to_f32(self) -> f32 {
        self.to_f32_or(NO_RETURN_F32)
    }

    /// The range as `f32` metres, `marker` without a return.
    pub fn to_f32_or(self, marker: f32) -> f32 {
        self.metres().map_or(marker, |d| d as f32)
    }
}

/// Raw LMS values of a scan (see [`Reading::to_raw`]).
pub fn to_raw(readings: &[Reading], unit: Unit) -> Vec<u16> {
    readings.iter().map(|r| r.to_raw(unit)).collect()
}

/// `f32` metres of a scan, `marker` where there is no return.
pub fn to_f32_metres(readings: &[Reading], marker: f32) -> Vec<f32> {
    readings.iter().map(|r| r.to_f32_or(marker)).collect()
}

/// How the simulated sensor corrupts true ranges: Gaussian range noise,
/// sporadic dropouts, quantisation.
///
/// Every beam — with or without a true return — takes one uniform draw (the
/// dropout) and then one standard-normal draw (the noise), in beam order.
/// So the noise of a beam depends only on the seed and its index, and scans
/// drawn with the same seed but different `sigma` differ only in the scale
/// of their noise (before quantisation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseModel {
    /// Standard deviation of the range noise (m, ≥ 0).
    pub sigma: f64,
    /// Probability that a beam with a return reports none (0 … 1).
    pub dropout: f64,
    /// Round ranges to this unit, or not at all.
    pub quantisation: Option<Unit>,
}

impl NoiseModel {
    /// No noise: readings are the true ranges.
    pub const NONE: NoiseModel = NoiseModel::gaussian(0.0);

    /// Gaussian range noise of `sigma` metres, no dropouts, no quantisation.
    pub const fn gaussian(sigma: f64) -> Self {
        Self {
            sigma,
            dropout: 0.0,
            quantisation: None,
        }
    }

    /// The LMS 2xx in mm mode: σ = 5 mm (ALGORITHM.md §5), ranges in whole mm.
    pub const fn lms_mm() -> Self {
        Self::gaussian(0.005).with_quantisation(Unit::Millimetre)
    }

    /// The same model with dropout probability `p`.
    pub const fn with_dropout(self, p: f64) -> Self {
        Self { dropout: p, ..self }
    }

    /// The same model quantising to `unit`.
    pub const fn with_quantisation(self, unit: Unit) -> Self {
        Self {
            quantisation: Some(unit),
            ..self
        }
    }

    /// The reading of one beam whose true range is `truth` (m); always makes
    /// the two draws described on [`NoiseModel`]. A noisy range that is not
    /// positive after quantisation gives [`Reading::NoReturn`].
    pub fn reading<R: Rng + ?Sized>(&self, truth: Option<f64>, rng: &mut R) -> Reading {
        let u: f64 = rng.random();
        let z: f64 = rng.sample(StandardNormal);
        let Some(d) = truth else {
            return Reading::NoReturn;
        };
        if u < self.dropout {
            return Reading::NoReturn;
        }
        let mut d = d + self.sigma * z;
        if let Some(unit) = self.quantisation {
            d = quantise(unit, d);
        }
        if d > 0.0 {
            Reading::Range(d)
        } else {
            Reading::NoReturn
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn raw_values() {
        assert_eq!(Reading::Range(1.2344).to_raw(Unit::Millimetre), 1234);
        assert_eq!(Reading::Range(1.2346).to_raw(Unit::Millimetre), 1235);
        assert_eq!(Reading::Range(1.2346).to_raw(Unit::Centimetre), 123);
        assert_eq!(Reading::Range(8.182).to_raw(Unit::Millimetre), 8182);
        assert_eq!(
            Reading::Range(8.1826).to_raw(Unit::Millimetre),
            RAW_ABOVE_MAX
        );
        assert_eq!(Reading::Range(30.0).to_raw(Unit::Centimetre), 3000);
        assert_eq!(Reading::NoReturn.to_raw(Unit::Millimetre), RAW_NO_ECHO);
        assert_eq!(Reading::NoReturn.to_raw(Unit::Centimetre), 8191);
        let scan = [Reading::Range(0.5), Reading::NoReturn];
        assert_eq!(to_raw(&scan, Unit::Centimetre), vec![50, 8191]);
    }

    #[test]
    fn f32_values() {
        assert_eq!(Reading::Range(1.5).to_f32(), 1.5);
        assert_eq!(Reading::NoReturn.to_f32(), NO_RETURN_F32);
        let scan = [Reading::Range(2.25), Reading::NoReturn];
        let out = to_f32_metres(&scan, f32::NAN);
        assert_eq!(out[0], 2.25);
        assert!(out[1].is_nan());
    }

    #[test]
    fn quantisation_to_whole_units() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for unit in [Unit::Millimetre, Unit::Centimetre] {
            let model = NoiseModel::gaussian(0.02).with_quantisation(unit);
            for k in 0..1000 {
                let d = model
                    .reading(Some(1.0 + k as f64 * 0.00377), &mut rng)
                    .metres()
                    .unwrap();
                let units = d * per_metre(unit);
                assert!((units - units.round()).abs() < 1e-9, "{d} in {unit:?}");
            }
        }
    }

    #[test]
    fn no_truth_no_return_and_same_stream() {
        // A beam without a true return still consumes its draws, so the
        // following beam sees the same noise either way.
        let model = NoiseModel::gaussian(0.01);
        let mut a = ChaCha8Rng::seed_from_u64(3);
        let mut b = ChaCha8Rng::seed_from_u64(3);
        assert_eq!(model.reading(None, &mut a), Reading::NoReturn);
        model.reading(Some(2.0), &mut b);
        assert_eq!(
            model.reading(Some(1.0), &mut a),
            model.reading(Some(1.0), &mut b)
        );
    }
}
