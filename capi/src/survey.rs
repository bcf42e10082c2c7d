//! `LmsSurvey`: the data profile of a source (σ and `max_range` from the
//! data, as `host-bridge extract` decides them for a recorded log).

use core::ffi::c_int;
use core::mem::{align_of, size_of};
use core::ptr::addr_of_mut;

use lms_core::{DataSurvey, Unit};

use crate::codes::*;
use crate::extract::{frame_of, set_units, unit_of, variant_of, LmsUnit, LmsVariant};
use crate::params::LmsParams;
use crate::{overlap, pointer_error, usable, Bytes};

/// Size of `LmsSurvey`'s private storage, in 8-byte words.
pub const LMS_SURVEY_WORDS: usize = 352;

/// The evidence of a data source's range unit, range mode, quantisation
/// step and fill values, over its scans (`lms_core::DataSurvey`). Set up by
/// `lms_survey_init`, fed by `lms_survey_add_units`, read by
/// `lms_survey_params`. Opaque: do not read or write its bytes.
#[repr(C)]
pub struct LmsSurvey {
    /// Private.
    pub opaque: [u64; LMS_SURVEY_WORDS],
}

/// Marks storage set up by `lms_survey_init` ("LMSS").
const MAGIC: u32 = 0x4C4D_5353;

/// What [`LmsSurvey`] holds. `unit` is kept as its C code, checked with
/// the magic before `survey` is touched.
#[repr(C)]
struct Survey {
    magic: u32,
    unit: LmsUnit,
    survey: DataSurvey,
}

const _: () = {
    assert!(size_of::<Survey>() <= size_of::<LmsSurvey>());
    assert!(align_of::<Survey>() <= align_of::<LmsSurvey>());
};

/// Set up `*survey` for data in `unit` (no scans yet).
///
/// # Safety
///
/// `survey` is NULL or points to writable memory for one `LmsSurvey`.
#[no_mangle]
pub unsafe extern "C" fn lms_survey_init(survey: *mut LmsSurvey, unit: LmsUnit) -> c_int {
    if !usable(survey) {
        return pointer_error(survey);
    }
    let core_unit = match unit_of(unit) {
        Ok(u) => u,
        Err(code) => return code,
    };
    let s = survey.cast::<Survey>();
    // SAFETY: the storage is large and aligned enough for a `Survey`
    // (asserted at compile time) and writable (contract).
    unsafe {
        addr_of_mut!((*s).survey).write(DataSurvey::new(core_unit));
        addr_of_mut!((*s).unit).write(unit);
        addr_of_mut!((*s).magic).write(MAGIC);
    }
    LMS_OK
}

/// The survey in `storage` and its unit, if `lms_survey_init` set it up.
///
/// # Safety
///
/// `storage` is non-null, aligned and valid for one `LmsSurvey`.
unsafe fn survey_in(storage: *mut LmsSurvey) -> Result<(*mut DataSurvey, Unit), c_int> {
    let s = storage.cast::<Survey>();
    // SAFETY: `Survey` fits the storage; `magic` and `unit` are plain
    // integers, read before `survey` is used.
    let (magic, unit) = unsafe { ((*s).magic, (*s).unit) };
    if magic != MAGIC {
        return Err(LMS_ERR_SURVEY);
    }
    let unit = unit_of(unit).map_err(|_| LMS_ERR_SURVEY)?;
    // SAFETY: as above; the magic says `lms_survey_init` wrote `survey`.
    Ok((unsafe { addr_of_mut!((*s).survey) }, unit))
}

/// Add one scan of raw LMS values in the survey's unit (decoded as
/// `lms_extract_units` decodes them; only its valid beams count).
///
/// # Safety
///
/// `survey` is NULL or points to an `LmsSurvey`; `raw` is NULL or readable
/// for `n` `uint16_t`.
#[no_mangle]
pub unsafe extern "C" fn lms_survey_add_units(
    survey: *mut LmsSurvey,
    variant: LmsVariant,
    raw: *const u16,
    n: usize,
) -> c_int {
    if !usable(survey) {
        return pointer_error(survey);
    }
    let variant = match variant_of(variant) {
        Ok(v) => v,
        Err(code) => return code,
    };
    if !(lms_core::frame::MIN_BEAMS..=variant.beams()).contains(&n) {
        return LMS_ERR_LENGTH;
    }
    if !usable(raw) {
        return pointer_error(raw);
    }
    if overlap(
        Bytes::at(raw, n * 2),
        Bytes::at(survey, size_of::<LmsSurvey>()),
    ) {
        return LMS_ERR_OVERLAP;
    }
    // SAFETY: `survey` is non-null, aligned, valid (checked, contract).
    let (s, unit) = match unsafe { survey_in(survey) } {
        Ok(v) => v,
        Err(code) => return code,
    };
    let mut frame = match frame_of(variant, n) {
        Ok(f) => f,
        Err(code) => return code,
    };
    // SAFETY: non-null, aligned, readable for `n` values (checked,
    // contract), disjoint from the survey (checked).
    let raw = unsafe { core::slice::from_raw_parts(raw, n) };
    for (j, &v) in raw.iter().enumerate() {
        if let Err(code) = set_units(&mut frame, j, unit, v) {
            return code;
        }
    }
    // SAFETY: `s` points to the survey that `lms_survey_init` wrote; no
    // other reference to it is alive.
    unsafe { (*s).add(&frame) };
    LMS_OK
}

/// The default parameters with σ and `max_range` of the surveyed data (the
/// unit's step and range mode, fill values): what `host-bridge extract`
/// uses for a recorded log surveyed over all its scans. For a preset,
/// copy `sigma` and `max_range` from here into it.
///
/// # Safety
///
/// `survey` is NULL or points to an `LmsSurvey`; `out` is NULL or points
/// to writable memory for one `LmsParams`.
#[no_mangle]
pub unsafe extern "C" fn lms_survey_params(survey: *const LmsSurvey, out: *mut LmsParams) -> c_int {
    if !usable(survey) {
        return pointer_error(survey);
    }
    if !usable(out) {
        return pointer_error(out);
    }
    // SAFETY: non-null, aligned, valid (checked, contract); only read.
    let (s, _) = match unsafe { survey_in(survey.cast_mut()) } {
        Ok(v) => v,
        Err(code) => return code,
    };
    // SAFETY: `s` was written by `lms_survey_init`; read only.
    let params = unsafe { (*s).profile() }.params();
    // SAFETY: non-null, aligned, writable (checked, contract).
    unsafe { out.write(LmsParams::from(&params)) };
    LMS_OK
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::extract::{LMS_FOV180_RES100, LMS_UNIT_MM};
    use std::boxed::Box;

    #[test]
    fn a_mm_16_m_log_is_recognised() {
        // SAFETY: all-zero bytes are a valid (uninitialised) survey storage.
        let mut s: Box<LmsSurvey> = unsafe { Box::new(core::mem::zeroed()) };
        let mut p = crate::params::lms_params_default();
        // SAFETY: valid pointers.
        unsafe {
            assert_eq!(lms_survey_params(&*s, &mut p), LMS_ERR_SURVEY);
            assert_eq!(lms_survey_init(&mut *s, LMS_UNIT_MM), LMS_OK);
        }
        let raw: std::vec::Vec<u16> = (0..181u16)
            .map(|j| if j % 10 == 0 { 16383 } else { 1000 + j * 43 })
            .collect();
        // SAFETY: valid pointers and length.
        unsafe {
            assert_eq!(
                lms_survey_add_units(&mut *s, LMS_FOV180_RES100, raw.as_ptr(), 181),
                LMS_OK
            );
            assert_eq!(lms_survey_params(&*s, &mut p), LMS_OK);
        }
        assert_eq!((p.sigma, p.max_range), (0.005, 16.375));
    }
}
