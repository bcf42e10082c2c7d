//! Return codes and their messages.

use core::ffi::{c_char, c_int, CStr};

use lms_core::ParamError;

/// Success.
pub const LMS_OK: c_int = 0;
/// A required pointer is NULL.
pub const LMS_ERR_NULL: c_int = -1;
/// A pointer is not aligned for its type.
pub const LMS_ERR_ALIGN: c_int = -2;
/// The variant is not one of the `LMS_FOV*` constants, or no variant sends
/// that many beams.
pub const LMS_ERR_VARIANT: c_int = -3;
/// The unit is not one of the `LMS_UNIT_*` constants.
pub const LMS_ERR_UNIT: c_int = -4;
/// `n` is not between 3 and the variant's number of beams.
pub const LMS_ERR_LENGTH: c_int = -5;
/// A raw value lies above the unit's all-ones value (8191 cm / 10 cm,
/// 32767 mm): no LMS 2xx sends it in that unit.
pub const LMS_ERR_VALUE: c_int = -6;
/// No preset of that name (or the name is not UTF-8).
pub const LMS_ERR_PRESET: c_int = -7;
/// A flag field of `LmsParams` is neither 0 nor 1.
pub const LMS_ERR_FLAG: c_int = -8;
/// The input array and the output struct overlap.
pub const LMS_ERR_OVERLAP: c_int = -9;
/// The `LmsSurvey` was not set up by `lms_survey_init`.
pub const LMS_ERR_SURVEY: c_int = -10;
/// `sigma` must be finite and > 0 (m).
pub const LMS_ERR_PARAM_SIGMA: c_int = -20;
/// `q` must be finite and >= 0 (m²).
pub const LMS_ERR_PARAM_Q: c_int = -21;
/// `iterations` must be 1..=1000.
pub const LMS_ERR_PARAM_ITERATIONS: c_int = -22;
/// `tau` must be finite and > 0.
pub const LMS_ERR_PARAM_TAU: c_int = -23;
/// `min_points` must be at least 3.
pub const LMS_ERR_PARAM_MIN_POINTS: c_int = -24;
/// `max_chi2` must be finite and > 0.
pub const LMS_ERR_PARAM_MAX_CHI2: c_int = -25;
/// `min_length` must be finite and >= 0 (m).
pub const LMS_ERR_PARAM_MIN_LENGTH: c_int = -26;
/// `merge_gate` must be finite and > 0.
pub const LMS_ERR_PARAM_MERGE_GATE: c_int = -27;
/// `corner_gap` must be finite and >= 0 (m).
pub const LMS_ERR_PARAM_CORNER_GAP: c_int = -28;
/// `min_corner_angle_deg` must be 0..=90.
pub const LMS_ERR_PARAM_MIN_CORNER_ANGLE: c_int = -29;
/// `split_depth` must be at most 16.
pub const LMS_ERR_PARAM_SPLIT_DEPTH: c_int = -30;
/// `max_range` must be > 0 (m; infinity: no limit).
pub const LMS_ERR_PARAM_MAX_RANGE: c_int = -31;
/// `max_alpha_sd_deg` must be > 0 (infinity: no limit).
pub const LMS_ERR_PARAM_MAX_ALPHA_SD: c_int = -32;
/// `merge_anchor_gate` must be > 0 (infinity: no test).
pub const LMS_ERR_PARAM_MERGE_ANCHOR_GATE: c_int = -33;
/// `merge_f_test` must be finite and >= 0.
pub const LMS_ERR_PARAM_MERGE_F_TEST: c_int = -34;
/// `grazing_noise` must be finite and >= 0.
pub const LMS_ERR_PARAM_GRAZING_NOISE: c_int = -35;
/// `fit_sigma` must be finite and >= 0.
pub const LMS_ERR_PARAM_FIT_SIGMA: c_int = -36;
/// `footprint` must be finite and >= 0 (rad).
pub const LMS_ERR_PARAM_FOOTPRINT: c_int = -37;
/// `arc_chain` must be 0 or >= 2, and 0 <= `arc_min_turn_deg` <=
/// `arc_max_turn_deg` <= 180.
pub const LMS_ERR_PARAM_ARC: c_int = -38;
/// A host-only option (`grazing_noise`, `fit_sigma`, `per_turn`,
/// `merge_f_test`) is not at its default: this library leaves them out.
pub const LMS_ERR_PARAM_NOT_IN_BUILD: c_int = -39;
/// The parameters are refused for another reason.
pub const LMS_ERR_PARAM_OTHER: c_int = -40;

/// Every code with its message (the message ends in NUL).
const MESSAGES: [(c_int, &CStr); 31] = [
    (LMS_OK, c"success"),
    (LMS_ERR_NULL, c"a required pointer is NULL"),
    (LMS_ERR_ALIGN, c"a pointer is not aligned for its type"),
    (LMS_ERR_VARIANT, c"unknown scan variant (or no variant sends that many beams)"),
    (LMS_ERR_UNIT, c"unknown range unit"),
    (LMS_ERR_LENGTH, c"n must be between 3 and the variant's number of beams"),
    (LMS_ERR_VALUE, c"a raw value is above the unit's all-ones value (8191 cm, 32767 mm)"),
    (LMS_ERR_PRESET, c"no preset of that name (default, v2, paper)"),
    (LMS_ERR_FLAG, c"a flag field of LmsParams is neither 0 nor 1"),
    (LMS_ERR_OVERLAP, c"the input array overlaps the output struct"),
    (LMS_ERR_SURVEY, c"the LmsSurvey was not set up by lms_survey_init"),
    (LMS_ERR_PARAM_SIGMA, c"sigma must be finite and > 0 (metres)"),
    (LMS_ERR_PARAM_Q, c"q must be finite and >= 0 (m^2)"),
    (LMS_ERR_PARAM_ITERATIONS, c"iterations must be between 1 and 1000"),
    (LMS_ERR_PARAM_TAU, c"tau must be finite and > 0"),
    (LMS_ERR_PARAM_MIN_POINTS, c"min_points must be at least 3"),
    (LMS_ERR_PARAM_MAX_CHI2, c"max_chi2 must be finite and > 0"),
    (LMS_ERR_PARAM_MIN_LENGTH, c"min_length must be finite and >= 0 (metres)"),
    (LMS_ERR_PARAM_MERGE_GATE, c"merge_gate must be finite and > 0"),
    (LMS_ERR_PARAM_CORNER_GAP, c"corner_gap must be finite and >= 0 (metres)"),
    (LMS_ERR_PARAM_MIN_CORNER_ANGLE, c"min_corner_angle_deg must be between 0 and 90"),
    (LMS_ERR_PARAM_SPLIT_DEPTH, c"split_depth must be at most 16"),
    (LMS_ERR_PARAM_MAX_RANGE, c"max_range must be > 0 (metres; inf for no limit)"),
    (LMS_ERR_PARAM_MAX_ALPHA_SD, c"max_alpha_sd_deg must be > 0 (degrees; inf for no limit)"),
    (LMS_ERR_PARAM_MERGE_ANCHOR_GATE, c"merge_anchor_gate must be > 0 (inf for no test)"),
    (LMS_ERR_PARAM_MERGE_F_TEST, c"merge_f_test must be finite and >= 0"),
    (LMS_ERR_PARAM_GRAZING_NOISE, c"grazing_noise must be finite and >= 0"),
    (LMS_ERR_PARAM_FIT_SIGMA, c"fit_sigma must be finite and >= 0 (metres)"),
    (LMS_ERR_PARAM_FOOTPRINT, c"footprint must be finite and >= 0 (radians)"),
    (
        LMS_ERR_PARAM_ARC,
        c"arc_chain must be 0 or >= 2, and 0 <= arc_min_turn_deg <= arc_max_turn_deg <= 180",
    ),
    (
        LMS_ERR_PARAM_NOT_IN_BUILD,
        c"grazing_noise, fit_sigma, per_turn and merge_f_test must keep their defaults (host-only options)",
    ),
];

/// The message of a return code: a static, NUL-terminated English string
/// (never NULL; an unknown code gives `"unknown error code"`).
#[no_mangle]
pub extern "C" fn lms_error_message(code: c_int) -> *const c_char {
    let text = MESSAGES.iter().find(|(c, _)| *c == code).map_or(
        if code == LMS_ERR_PARAM_OTHER {
            c"the parameters are refused"
        } else {
            c"unknown error code"
        },
        |(_, m)| *m,
    );
    text.as_ptr()
}

/// The code of a parameter error.
pub(crate) fn param_code(e: ParamError) -> c_int {
    match e {
        ParamError::Sigma => LMS_ERR_PARAM_SIGMA,
        ParamError::ProcessNoise => LMS_ERR_PARAM_Q,
        ParamError::Iterations => LMS_ERR_PARAM_ITERATIONS,
        ParamError::Tau => LMS_ERR_PARAM_TAU,
        ParamError::MinPoints => LMS_ERR_PARAM_MIN_POINTS,
        ParamError::MaxChi2 => LMS_ERR_PARAM_MAX_CHI2,
        ParamError::MinLength => LMS_ERR_PARAM_MIN_LENGTH,
        ParamError::MergeGate => LMS_ERR_PARAM_MERGE_GATE,
        ParamError::CornerGap => LMS_ERR_PARAM_CORNER_GAP,
        ParamError::MinCornerAngle => LMS_ERR_PARAM_MIN_CORNER_ANGLE,
        ParamError::SplitDepth => LMS_ERR_PARAM_SPLIT_DEPTH,
        ParamError::MaxRange => LMS_ERR_PARAM_MAX_RANGE,
        ParamError::MaxAlphaSd => LMS_ERR_PARAM_MAX_ALPHA_SD,
        ParamError::MergeAnchorGate => LMS_ERR_PARAM_MERGE_ANCHOR_GATE,
        ParamError::MergeFTest => LMS_ERR_PARAM_MERGE_F_TEST,
        ParamError::GrazingNoise => LMS_ERR_PARAM_GRAZING_NOISE,
        ParamError::FitSigma => LMS_ERR_PARAM_FIT_SIGMA,
        ParamError::Footprint => LMS_ERR_PARAM_FOOTPRINT,
        ParamError::Arc => LMS_ERR_PARAM_ARC,
        ParamError::NotInBuild { .. } => LMS_ERR_PARAM_NOT_IN_BUILD,
        _ => LMS_ERR_PARAM_OTHER,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_has_its_own_message() {
        for (i, (code, _)) in MESSAGES.iter().enumerate() {
            assert!(MESSAGES[..i].iter().all(|(c, _)| c != code), "{code}");
            // SAFETY: lms_error_message returns a static NUL-terminated string.
            let text = unsafe { CStr::from_ptr(lms_error_message(*code)) };
            assert!(!text.to_bytes().is_empty());
        }
        // SAFETY: as above.
        let unknown = unsafe { CStr::from_ptr(lms_error_message(12345)) };
        assert_eq!(unknown, c"unknown error code");
    }
}
