//! Return codes and their messages.

use core::ffi::{c_char, c_int, CStr};

use lms_core::params::FIELDS;
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

/// Every code but a field's with its message (the message ends in NUL).
const MESSAGES: [(c_int, &CStr); 14] = [
    (LMS_OK, c"success"),
    (LMS_ERR_NULL, c"a required pointer is NULL"),
    (LMS_ERR_ALIGN, c"a pointer is not aligned for its type"),
    (
        LMS_ERR_VARIANT,
        c"unknown scan variant (or no variant sends that many beams)",
    ),
    (LMS_ERR_UNIT, c"unknown range unit"),
    (
        LMS_ERR_LENGTH,
        c"n must be between 3 and the variant's number of beams",
    ),
    (
        LMS_ERR_VALUE,
        c"a raw value is above the unit's all-ones value (8191 cm, 32767 mm)",
    ),
    (
        LMS_ERR_PRESET,
        c"no preset of that name (default, v3.2, v3.1, v3.0, v2, paper)",
    ),
    (
        LMS_ERR_FLAG,
        c"a flag field of LmsParams is neither 0 nor 1",
    ),
    (
        LMS_ERR_OVERLAP,
        c"the input array overlaps the output struct",
    ),
    (
        LMS_ERR_SURVEY,
        c"the LmsSurvey was not set up by lms_survey_init",
    ),
    (
        LMS_ERR_PARAM_ARC,
        c"arc_chain must be 0 or >= 2, and 0 <= arc_min_turn_deg <= arc_max_turn_deg <= 180",
    ),
    (
        LMS_ERR_PARAM_NOT_IN_BUILD,
        c"an ALGORITHM.md section 10 option (host-only) must keep its default",
    ),
    (LMS_ERR_PARAM_OTHER, c"the parameters are refused"),
];

/// The code of each parameter with one of its own: the numbering of the C
/// ABI (`lms_features.h`), by the parameter's name in
/// [`lms_core::params::FIELDS`]. Their messages are the core's
/// ([`ParamError::OutOfRange`], from the parameter's range there).
const FIELD_CODES: [(&str, c_int); 18] = [
    ("sigma", LMS_ERR_PARAM_SIGMA),
    ("q", LMS_ERR_PARAM_Q),
    ("iterations", LMS_ERR_PARAM_ITERATIONS),
    ("tau", LMS_ERR_PARAM_TAU),
    ("min_points", LMS_ERR_PARAM_MIN_POINTS),
    ("max_chi2", LMS_ERR_PARAM_MAX_CHI2),
    ("min_length", LMS_ERR_PARAM_MIN_LENGTH),
    ("merge_gate", LMS_ERR_PARAM_MERGE_GATE),
    ("corner_gap", LMS_ERR_PARAM_CORNER_GAP),
    ("min_corner_angle_deg", LMS_ERR_PARAM_MIN_CORNER_ANGLE),
    ("split_depth", LMS_ERR_PARAM_SPLIT_DEPTH),
    ("max_range", LMS_ERR_PARAM_MAX_RANGE),
    ("max_alpha_sd_deg", LMS_ERR_PARAM_MAX_ALPHA_SD),
    ("merge_anchor_gate", LMS_ERR_PARAM_MERGE_ANCHOR_GATE),
    ("merge_f_test", LMS_ERR_PARAM_MERGE_F_TEST),
    ("grazing_noise", LMS_ERR_PARAM_GRAZING_NOISE),
    ("fit_sigma", LMS_ERR_PARAM_FIT_SIGMA),
    ("footprint", LMS_ERR_PARAM_FOOTPRINT),
];

/// Room for one parameter's message and its NUL.
const MESSAGE_LEN: usize = 96;

/// Whether `a` and `b` are the same text (`const`).
const fn same(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// `text` written into `out` from `at`; the end.
const fn put(out: &mut [u8; MESSAGE_LEN], at: usize, text: &str) -> usize {
    let text = text.as_bytes();
    let mut i = 0;
    while i < text.len() {
        out[at + i] = text[i];
        i += 1;
    }
    at + text.len()
}

/// The core's message of the parameter `name` out of its range, as
/// [`ParamError::OutOfRange`] displays it, NUL-terminated (`const`: no
/// allocation).
const fn field_message(name: &str) -> [u8; MESSAGE_LEN] {
    let mut i = 0;
    while !same(FIELDS[i].name, name) {
        i += 1;
    }
    let field = &FIELDS[i];
    let mut out = [0; MESSAGE_LEN];
    let mut at = put(&mut out, 0, name);
    at = put(&mut out, at, " must be ");
    at = put(&mut out, at, field.range);
    if let Some(unit) = field.shown_unit() {
        at = put(&mut out, at, " (");
        at = put(&mut out, at, unit);
        at = put(&mut out, at, ")");
    }
    assert!(
        at < MESSAGE_LEN,
        "a parameter's message is longer than MESSAGE_LEN"
    );
    out
}

/// The message of each code of [`FIELD_CODES`], in that order.
static FIELD_MESSAGES: [[u8; MESSAGE_LEN]; FIELD_CODES.len()] = {
    let mut all = [[0; MESSAGE_LEN]; FIELD_CODES.len()];
    let mut i = 0;
    while i < all.len() {
        all[i] = field_message(FIELD_CODES[i].0);
        i += 1;
    }
    all
};

/// The message of a return code: a static, NUL-terminated English string
/// (never NULL; an unknown code gives `"unknown error code"`).
#[no_mangle]
pub extern "C" fn lms_error_message(code: c_int) -> *const c_char {
    let fixed = MESSAGES.iter().find(|(c, _)| *c == code).map(|(_, m)| *m);
    let of_field = || {
        let i = FIELD_CODES.iter().position(|&(_, c)| c == code)?;
        CStr::from_bytes_until_nul(&FIELD_MESSAGES[i]).ok()
    };
    fixed
        .or_else(of_field)
        .unwrap_or(c"unknown error code")
        .as_ptr()
}

/// The code of a parameter error.
pub(crate) fn param_code(e: ParamError) -> c_int {
    match e {
        ParamError::OutOfRange { name, .. } => FIELD_CODES
            .iter()
            .find(|(n, _)| *n == name)
            .map_or(LMS_ERR_PARAM_OTHER, |&(_, code)| code),
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
        let codes: std::vec::Vec<c_int> = MESSAGES
            .iter()
            .map(|(c, _)| *c)
            .chain(FIELD_CODES.iter().map(|(_, c)| *c))
            .collect();
        for (i, code) in codes.iter().enumerate() {
            assert!(!codes[..i].contains(code), "{code}");
            // SAFETY: lms_error_message returns a static NUL-terminated string.
            let text = unsafe { CStr::from_ptr(lms_error_message(*code)) };
            assert!(!text.to_bytes().is_empty());
        }
        // SAFETY: as above.
        let unknown = unsafe { CStr::from_ptr(lms_error_message(12345)) };
        assert_eq!(unknown, c"unknown error code");
    }

    #[test]
    fn a_field_code_names_its_field_and_range() {
        for (name, code) in FIELD_CODES {
            let field = lms_core::params::field(name).expect(name);
            let error = ParamError::OutOfRange {
                name,
                range: field.range,
            };
            assert_ne!(field.bounds, lms_core::params::Range::Any, "{name}");
            // SAFETY: lms_error_message returns a static NUL-terminated string.
            let text = unsafe { CStr::from_ptr(lms_error_message(code)) };
            let text = text.to_str().unwrap();
            assert_eq!(text, std::format!("{error}"));
        }
        let p = lms_core::Params::DEFAULT.with_sigma(-1.0);
        assert_eq!(param_code(p.validate().unwrap_err()), LMS_ERR_PARAM_SIGMA);
        // SAFETY: as above.
        let sigma = unsafe { CStr::from_ptr(lms_error_message(LMS_ERR_PARAM_SIGMA)) };
        assert_eq!(sigma, c"sigma must be finite and > 0 (m)");
    }
}
