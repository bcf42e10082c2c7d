//! Defaults per data: the parameters `extract` and `plot`
//! use for a CARMEN log when no flag says otherwise.
//!
//! The whole log is surveyed first ([`lms_core::DataSurvey`]: range mode,
//! quantisation step, fill values); [`lms_core::DataProfile::params`] gives
//! σ and `max_range`; every flag given on the command line overrides them.
//! When the log holds ranges at or beyond `max_range` that would otherwise
//! be valid (fill values, another mode's error codes), one warning line says
//! how many; the pipeline counts them per frame in `stats.beyond_max_range`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Result;
use lms_core::{DataProfile, DataSurvey, Params};

use crate::input;
use crate::options::{ParamArgs, UnitArg};

/// The parameters for the log at `path`, and a warning line if the log's
/// fill values are caught by the range limit. `None` for a capture (its
/// telegrams carry their units; the flags alone decide).
///
/// The log at `path` is opened for it ([`for_file`]).
pub fn for_log(
    path: &Path,
    unit: UnitArg,
    args: &ParamArgs,
) -> Result<Option<(Params, Option<String>)>> {
    for_file(&input::open(path, unit)?, args)
}

/// [`for_log`] for a log already open: the survey reads the scans of its
/// head ([`input::ScanFile::head_scans`], the whole log unless it is longer
/// than [`crate::carmen::HEAD_TEXT`]) from memory, up to the first damaged
/// scan, so the input itself is read once. The valid ranges are kept as a
/// histogram of their exact `f32` values (at most one entry per distinct
/// value the unit can express, about 82 000), so the ranges the limit
/// catches are counted exactly whatever `--max-range` says.
pub fn for_file(
    file: &input::ScanFile,
    args: &ParamArgs,
) -> Result<Option<(Params, Option<String>)>> {
    let Some((unit, frames)) = file.survey_frames() else {
        return Ok(None);
    };
    let path = file.path();
    let mut survey = DataSurvey::new(unit);
    // Keyed by `f32::to_bits`, which orders non-negative floats by value.
    let mut valid: BTreeMap<u32, u64> = BTreeMap::new();
    // The survey stops at the first damaged scan: whether that damage
    // matters (it may lie after the selected frames) is for the reading
    // pass to say, with its own message.
    for frame in frames {
        survey.add(&frame);
        for (b, &d) in frame.beams().iter().zip(frame.ranges()) {
            if b.is_valid() {
                *valid.entry(d.to_bits()).or_default() += 1;
            }
        }
    }
    let profile = survey.profile();
    let params = args.to_params_over(profile.params())?;
    let caught: u64 = valid
        .range(params.max_range.max(0.0).to_bits()..)
        .map(|(_, n)| n)
        .sum();
    let warning = (caught > 0).then(|| warning_line(path, &profile, &params, caught));
    Ok(Some((params, warning)))
}

/// The one warning line for `caught` ranges at or beyond the limit.
fn warning_line(path: &Path, profile: &DataProfile, params: &Params, caught: u64) -> String {
    let why = match profile.fill_from {
        Some(fill) if fill <= params.max_range => format!("fill values from {fill:.2} m"),
        _ => format!("at or beyond the {} mode's largest range", profile.unit),
    };
    format!(
        "warning: {}: {caught} ranges at or beyond max_range {} m ({why}) made invalid \
         (counted per frame in stats.beyond_max_range; --max-range to change)",
        path.display(),
        params.max_range
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_override_the_data() {
        let args = ParamArgs {
            sigma: Some(0.02),
            ..ParamArgs::default()
        };
        let base = DataProfile::of(lms_core::Unit::Millimetre, lms_core::RangeMode::Bits14);
        let p = args.to_params_over(base.params()).unwrap();
        assert_eq!((p.sigma, p.max_range), (0.02, 16.375));
        let p = ParamArgs::default().to_params_over(base.params()).unwrap();
        assert_eq!(p.sigma, 0.005);
    }
}
