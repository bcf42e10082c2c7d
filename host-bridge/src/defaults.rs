//! Defaults per data (issue 14, item 4): the parameters `extract` and `plot`
//! use for a CARMEN log when no flag says otherwise.
//!
//! The whole log is surveyed first ([`lms_core::DataSurvey`]: range mode,
//! quantisation step, fill values); [`lms_core::DataProfile::params`] gives
//! σ and `max_range`; every flag given on the command line overrides them.
//! When the log holds ranges at or beyond `max_range` that would otherwise
//! be valid (fill values, another mode's error codes), one warning line says
//! how many; the pipeline counts them per frame in `stats.beyond_max_range`.

use std::path::Path;

use anyhow::Result;
use lms_core::{DataProfile, DataSurvey, Params};

use crate::carmen::{read_log, UnitMode};
use crate::options::ParamArgs;

/// The parameters for the log at `path`, and a warning line if the log's
/// fill values are caught by the range limit.
pub fn for_log(path: &Path, unit: UnitMode, args: &ParamArgs) -> Result<(Params, Option<String>)> {
    let log = read_log(path, unit)?;
    let mut survey = DataSurvey::new(log.unit);
    for scan in &log.scans {
        survey.add(&scan.frame);
    }
    let profile = survey.profile();
    let params = args.to_params_over(profile.params())?;
    let caught: usize = log
        .scans
        .iter()
        .map(|s| {
            let f = &s.frame;
            f.beams()
                .iter()
                .zip(f.ranges())
                .filter(|(b, &d)| b.is_valid() && d >= params.max_range)
                .count()
        })
        .sum();
    let warning = (caught > 0).then(|| warning_line(path, &profile, &params, caught));
    Ok((params, warning))
}

/// The one warning line for `caught` ranges at or beyond the limit.
fn warning_line(path: &Path, profile: &DataProfile, params: &Params, caught: usize) -> String {
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
