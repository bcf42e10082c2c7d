//! Defaults per data: the range limit of a unit and range
//! mode (ALGORITHM.md v2 §1), and σ from the quantisation seen in the data.
//!
//! [`DataSurvey`] is fed frames (e.g. every frame of a recorded log, or the
//! first few of a stream) and decides a [`DataProfile`]: the unit, the range
//! mode (for mm data from the error-code band the values reach), the
//! quantisation step (the largest of 1 mm, 1 cm, 5 cm, 10 cm that divides
//! 85 % of the non-zero differences, below 0.5 m, of consecutive ranges; a step need not
//! start at 0: some recorders round to 5 cm with an offset) and fill values
//! (a 10 cm bin beyond 20 m much fuller than its neighbours). Its
//! [`DataProfile::params`] gives the [`Params`]. No allocation; f32 only.

use super::Params;
use crate::frame::Frame;
use crate::units::Unit;

/// Range bits of an LMS 2xx range mode (PROTOCOL.md §3): the mm modes 8 m
/// (13 bits), 16 m (14) and 32 m (15); cm and 10 cm data use 13 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RangeMode {
    /// 13 range bits: codes 8183–8191 (8.183 m in mm, 81.83 m in cm).
    Bits13,
    /// 14 range bits (mm 16 m mode): codes 16 375–16 383.
    Bits14,
    /// 15 range bits (mm 32 m mode): codes 32 759–32 767.
    Bits15,
}

impl RangeMode {
    /// The all-ones range value, the last error code.
    pub const fn all_ones(self) -> u16 {
        match self {
            RangeMode::Bits13 => 0x1FFF,
            RangeMode::Bits14 => 0x3FFF,
            RangeMode::Bits15 => 0x7FFF,
        }
    }
}

/// The largest true range of `unit` in `mode` (m): its first error code,
/// `all_ones − 8` (8.183, 16.375 or 32.759 m in mm; 81.83 m in cm).
/// A range at or beyond it is invalid.
pub const fn max_range_of(unit: Unit, mode: RangeMode) -> f32 {
    (mode.all_ones() - 8) as f32 / unit.per_metre()
}

/// What a survey found about a data source.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DataProfile {
    /// Range unit of the source.
    pub unit: Unit,
    /// Range mode (for mm: from the error codes seen).
    pub mode: RangeMode,
    /// Quantisation step of the ranges (m): 0.001, 0.01, 0.05 or 0.1.
    pub step: f32,
    /// The lowest fill value seen (m), if any: ranges from it on are not
    /// measurements.
    pub fill_from: Option<f32>,
}

/// σ for data quantised in `step` metres (m): the LMS 2xx statistical error
/// in mm mode (5 mm) at 1 mm steps, one step (1 cm) for cm data, and
/// `0.6·step` for coarser steps (5 cm: 30 mm). Measured on the shared logs
/// against map-derived truth (`lms-lab truth`): on the 5 cm Acapulco log
/// σ = 17.5 / 20 / 30 mm matched 0.43 / 0.47 / 0.53 of the true wall pieces
/// (FalsePos 0.75 / 0.75 / 0.69); the rounding σ alone (`step/√12`, 14 mm)
/// is too small, since at grazing incidence a rounding step is a step of
/// the whole run of ranges.
pub fn sigma_for_step(step: f32) -> f32 {
    if step <= 0.001 {
        0.005
    } else if step <= 0.01 {
        0.01
    } else {
        0.6 * step
    }
}

impl DataProfile {
    /// The profile of an LMS 2xx in `unit` and `mode` without further
    /// knowledge: the unit's step, no fill values.
    pub const fn of(unit: Unit, mode: RangeMode) -> DataProfile {
        DataProfile {
            unit,
            mode,
            step: 1.0 / unit.per_metre(),
            fill_from: None,
        }
    }

    /// The range limit (m): the mode's largest true range, or the lowest
    /// fill value if that is smaller.
    pub fn max_range(&self) -> f32 {
        let mode = max_range_of(self.unit, self.mode);
        match self.fill_from {
            Some(fill) if fill < mode => fill,
            _ => mode,
        }
    }

    /// [`Params::DEFAULT`] with σ ([`sigma_for_step`]) and `max_range` of
    /// this profile.
    pub fn params(&self) -> Params {
        Params {
            sigma: sigma_for_step(self.step),
            max_range: self.max_range(),
            ..Params::DEFAULT
        }
    }
}

/// Quantisation steps tried, in mm, coarsest first.
const STEPS_MM: [u32; 3] = [100, 50, 10];
/// Consecutive differences up to this (mm) are steps along a surface.
const MAX_DELTA_MM: u64 = 500;
/// Share of non-zero consecutive differences a step must divide.
const STEP_SHARE: f32 = 0.85;
/// Fill-value histogram: 10 cm bins from [`FAR_FROM_M`] to 82 m.
const FAR_BINS: usize = 620;
/// Where the fill-value histogram starts (m).
const FAR_FROM_M: f32 = 20.0;

/// Accumulates the evidence for a [`DataProfile`] over frames.
#[derive(Clone, Debug)]
pub struct DataSurvey {
    unit: Unit,
    beams: u32,
    deltas: u32,
    multiples: [u32; STEPS_MM.len()],
    in_band13: u32,
    beyond13: u32,
    in_band14: u32,
    beyond14: u32,
    far: [u32; FAR_BINS],
}

impl DataSurvey {
    /// An empty survey of data in `unit`.
    pub const fn new(unit: Unit) -> DataSurvey {
        DataSurvey {
            unit,
            beams: 0,
            deltas: 0,
            multiples: [0; STEPS_MM.len()],
            in_band13: 0,
            beyond13: 0,
            in_band14: 0,
            beyond14: 0,
            far: [0; FAR_BINS],
        }
    }

    /// Add the valid beams of `frame`.
    pub fn add(&mut self, frame: &Frame) {
        let mut prev: Option<i64> = None;
        for (b, &d) in frame.beams().iter().zip(frame.ranges()) {
            if !b.is_valid() {
                prev = None;
                continue;
            }
            self.beams = self.beams.saturating_add(1);
            let mm = libm::roundf(d * 1000.0) as i64;
            if let Some(p) = prev {
                let delta = (mm - p).unsigned_abs();
                // Steps along a surface; jumps may join differently rounded values.
                if delta > 0 && delta < MAX_DELTA_MM {
                    self.deltas = self.deltas.saturating_add(1);
                    for (count, &s) in self.multiples.iter_mut().zip(&STEPS_MM) {
                        if delta % u64::from(s) == 0 {
                            *count = count.saturating_add(1);
                        }
                    }
                }
            }
            prev = Some(mm);
            self.mode_evidence(mm);
            if d >= FAR_FROM_M {
                let bin = ((d - FAR_FROM_M) * 10.0) as usize;
                if let Some(c) = self.far.get_mut(bin) {
                    *c = c.saturating_add(1);
                }
            }
        }
    }

    /// Count a range (mm) against the 8 m and 16 m modes' code bands.
    fn mode_evidence(&mut self, mm: i64) {
        let band = |mode: RangeMode| {
            let top = i64::from(mode.all_ones());
            (top - 8..=top).contains(&mm)
        };
        self.in_band13 += u32::from(band(RangeMode::Bits13));
        self.beyond13 += u32::from(mm > i64::from(RangeMode::Bits13.all_ones()));
        self.in_band14 += u32::from(band(RangeMode::Bits14));
        self.beyond14 += u32::from(mm > i64::from(RangeMode::Bits14.all_ones()));
    }

    /// Valid beams seen.
    pub fn beams(&self) -> u32 {
        self.beams
    }

    /// Beams seen at or beyond `max_range` (m; counted from 20 m on, in
    /// 10 cm bins, so `max_range` should be a multiple of 0.1 m there).
    pub fn beams_from(&self, max_range: f32) -> u32 {
        if max_range < FAR_FROM_M {
            return 0;
        }
        let from = libm::roundf((max_range - FAR_FROM_M) * 10.0) as usize;
        self.far.iter().skip(from).sum()
    }

    /// The profile the evidence supports.
    pub fn profile(&self) -> DataProfile {
        let mm = self.unit == Unit::Millimetre;
        let mode = if !mm || (self.in_band13 > 0 && self.beyond13 == 0) {
            RangeMode::Bits13
        } else if self.in_band14 > 0 && self.beyond14 == 0 {
            RangeMode::Bits14
        } else {
            RangeMode::Bits15
        };
        let unit_mm = (1000.0 / self.unit.per_metre()) as u32;
        let mut step_mm = unit_mm.max(1);
        for (&count, &s) in self.multiples.iter().zip(&STEPS_MM) {
            if s > step_mm && self.deltas > 0 && count as f32 >= STEP_SHARE * self.deltas as f32 {
                step_mm = s;
                break;
            }
        }
        DataProfile {
            unit: self.unit,
            mode,
            step: step_mm as f32 / 1000.0,
            fill_from: self.fill_from(),
        }
    }

    /// The lowest 10 cm bin beyond 20 m that holds at least 0.1 % of all
    /// beams and ten times the median of the ten bins on either side of it
    /// (real surfaces spread over many ranges; a fill value does not; the
    /// median, so that a second fill value nearby does not hide the first).
    fn fill_from(&self) -> Option<f32> {
        let least = (self.beams / 1000).max(20);
        for (i, &c) in self.far.iter().enumerate() {
            if c < least {
                continue;
            }
            let mut around = [0u32; 20];
            let mut bins = 0usize;
            for (k, &n) in self
                .far
                .iter()
                .enumerate()
                .skip(i.saturating_sub(11))
                .take(23)
            {
                if (k + 1 < i || k > i + 1) && bins < around.len() {
                    around[bins] = n;
                    bins += 1;
                }
            }
            let around = &mut around[..bins];
            around.sort_unstable();
            let median = around.get(bins / 2).copied().unwrap_or(0);
            if c as f32 >= 10.0 * median as f32 {
                return Some(FAR_FROM_M + i as f32 / 10.0);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Variant;

    #[test]
    fn mode_limits() {
        assert_eq!(max_range_of(Unit::Millimetre, RangeMode::Bits13), 8.183);
        assert_eq!(max_range_of(Unit::Millimetre, RangeMode::Bits14), 16.375);
        assert_eq!(max_range_of(Unit::Millimetre, RangeMode::Bits15), 32.759);
        assert_eq!(max_range_of(Unit::Centimetre, RangeMode::Bits13), 81.83);
    }

    fn frame_of(ranges: impl Fn(usize) -> f32) -> Frame {
        let mut f = Frame::for_variant(Variant::Fov180Res100);
        for j in 0..f.len() {
            f.set_metres(j, ranges(j));
        }
        f
    }

    #[test]
    fn a_16_m_mode_log_read_as_32_m_is_recognised() {
        let mut s = DataSurvey::new(Unit::Millimetre);
        // Ranges 1.001 m … 9.1 m in 1 mm-ish steps, plus the 16 m codes.
        s.add(&frame_of(|j| {
            if j % 10 == 0 {
                16.383
            } else {
                1.0 + j as f32 * 0.0437
            }
        }));
        let p = s.profile();
        assert_eq!(p.mode, RangeMode::Bits14);
        assert_eq!(p.step, 0.001);
        assert_eq!(p.params().max_range, 16.375);
        assert_eq!(p.params().sigma, 0.005);
    }

    #[test]
    fn five_cm_steps_with_an_offset_and_a_fill_value() {
        let mut s = DataSurvey::new(Unit::Centimetre);
        for k in 0..20 {
            s.add(&frame_of(|j| {
                if j % 7 == 0 {
                    51.15
                } else {
                    0.04 + 0.05 * ((j + k) % 60) as f32 + 2.0
                }
            }));
        }
        let p = s.profile();
        assert_eq!(p.mode, RangeMode::Bits13);
        assert!((p.step - 0.05).abs() < 1e-6, "{p:?}");
        let fill = p.fill_from.expect("fill");
        assert!((fill - 51.1).abs() < 1e-3, "{p:?}");
        assert!((p.max_range() - 51.1).abs() < 1e-3);
        assert!(s.beams_from(p.max_range()) > 0);
        assert!((p.params().sigma - 0.03).abs() < 1e-6);
    }

    #[test]
    fn cm_data_without_fill() {
        let mut s = DataSurvey::new(Unit::Centimetre);
        s.add(&frame_of(|j| {
            2.0 + 0.01 * (j % 37) as f32 + 0.03 * (j % 3) as f32
        }));
        let p = s.profile();
        assert_eq!((p.step, p.fill_from), (0.01, None));
        assert_eq!(p.params().max_range, 81.83);
        assert_eq!(p.params().sigma, 0.01);
    }
}
