//! `LmsParams`: every field of `lms_core::Params`, by value.

use core::ffi::{c_char, c_int, CStr};

use lms_core::{Params, ValidParams};

use crate::codes::*;
use crate::{pointer_error, usable};

/// The pipeline's parameters: every field of `lms_core::Params`, in its
/// order and with its meaning (docs/GUIDE.md, "Parameters"). Flags are `uint8_t`,
/// 0 or 1 (any other value is refused with `LMS_ERR_FLAG`). Start from
/// `lms_params_default()` or `lms_params_preset()` and change fields.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmsParams {
    /// Range noise standard deviation (m).
    pub sigma: f32,
    /// Process noise of the smoothing filter (m²).
    pub q: f32,
    /// Smoothing passes (1..=1000).
    pub iterations: u16,
    /// Segmentation gate on the Mahalanobis distance D.
    pub tau: f32,
    /// Smallest segment kept (beams, at least 3).
    pub min_points: u16,
    /// Largest chi-square of an accepted line.
    pub max_chi2: f32,
    /// Shortest accepted line (m).
    pub min_length: f32,
    /// Fit a corner beam shared by two segments into both lines (0/1).
    pub fit_shared_points: u8,
    /// Merge consecutive lines that agree (0/1).
    pub merge: u8,
    /// Most valid beams between two lines that may merge.
    pub merge_gap_beams: u16,
    /// Gate of the merge test (chi-square, 2 dof).
    pub merge_gate: f32,
    /// Largest gap between facing endpoints of two lines made a corner (m).
    pub corner_gap: f32,
    /// Smallest angle of a well-conditioned corner (degrees, 0..=90).
    pub min_corner_angle_deg: f32,
    /// Split before reject: levels (0 off, at most 16).
    pub split_depth: u8,
    /// Largest true range (m): a beam at or beyond it is invalid (INFINITY: no limit).
    pub max_range: f32,
    /// Merge touching, nearly collinear lines whose union fits (0/1).
    pub merge_collinear: u8,
    /// Largest standard deviation of a line's angle (degrees; INFINITY: keep all).
    pub max_alpha_sd_deg: f32,
    /// Host-only option; must stay 0 here.
    pub grazing_noise: f32,
    /// Windows of one mirror turn's beams in the interleaved modes (0/1).
    pub same_turn_windows: u8,
    /// Host-only option; must stay 0 here.
    pub fit_sigma: f32,
    /// Host-only option; must stay 0 here.
    pub per_turn: u8,
    /// Merge two accepted lines across rejected segments (0/1).
    pub bridge_merge: u8,
    /// Beam-footprint term of the fits' range noise (rad; 0 off).
    pub footprint: f32,
    /// Fewest touching lines dropped as an arc (0 off, else at least 2).
    pub arc_chain: u8,
    /// Smallest turn between consecutive lines of an arc (degrees).
    pub arc_min_turn_deg: f32,
    /// Largest turn between consecutive lines of an arc (degrees, at most 180).
    pub arc_max_turn_deg: f32,
    /// Work bound of split before reject per frame (beams; 0: none).
    pub split_budget: u16,
    /// Anchor gate of the merges (chi-square, 2 dof; INFINITY: no test).
    pub merge_anchor_gate: f32,
    /// Line fits' chi-square allows an offset between mirror turns (0/1).
    pub turn_offsets: u8,
    /// Host-only option; must stay 0 here.
    pub merge_f_test: f32,
    /// Drop a pair of touching lines that a circle explains better (0/1).
    pub arc_pairs: u8,
    /// Merges refit the two lines' own beams, leaving out the beams
    /// between them (0/1).
    pub merge_own_beams: u8,
    /// Each line takes the fit, with or without the footprint term, whose
    /// noise model its beams are likelier under (0/1).
    pub footprint_choice: u8,
}

impl From<&Params> for LmsParams {
    fn from(p: &Params) -> LmsParams {
        LmsParams {
            sigma: p.sigma,
            q: p.q,
            iterations: p.iterations,
            tau: p.tau,
            min_points: p.min_points,
            max_chi2: p.max_chi2,
            min_length: p.min_length,
            fit_shared_points: p.fit_shared_points.into(),
            merge: p.merge.into(),
            merge_gap_beams: p.merge_gap_beams,
            merge_gate: p.merge_gate,
            corner_gap: p.corner_gap,
            min_corner_angle_deg: p.min_corner_angle_deg,
            split_depth: p.split_depth,
            max_range: p.max_range,
            merge_collinear: p.merge_collinear.into(),
            max_alpha_sd_deg: p.max_alpha_sd_deg,
            grazing_noise: p.grazing_noise,
            same_turn_windows: p.same_turn_windows.into(),
            fit_sigma: p.fit_sigma,
            per_turn: p.per_turn.into(),
            bridge_merge: p.bridge_merge.into(),
            footprint: p.footprint,
            arc_chain: p.arc_chain,
            arc_min_turn_deg: p.arc_min_turn_deg,
            arc_max_turn_deg: p.arc_max_turn_deg,
            split_budget: p.split_budget,
            merge_anchor_gate: p.merge_anchor_gate,
            turn_offsets: p.turn_offsets.into(),
            merge_f_test: p.merge_f_test,
            arc_pairs: p.arc_pairs.into(),
            merge_own_beams: p.merge_own_beams.into(),
            footprint_choice: p.footprint_choice.into(),
        }
    }
}

/// A flag field: 0 or 1.
fn flag(v: u8) -> Result<bool, c_int> {
    match v {
        0 => Ok(false),
        1 => Ok(true),
        _ => Err(LMS_ERR_FLAG),
    }
}

impl LmsParams {
    /// The core's parameters, validated.
    pub(crate) fn validated(&self) -> Result<ValidParams, c_int> {
        self.core_params()?.validate().map_err(param_code)
    }

    /// The core's parameters, not validated; `LMS_ERR_FLAG` for a flag
    /// that is neither 0 nor 1.
    fn core_params(&self) -> Result<Params, c_int> {
        Ok(Params::DEFAULT
            .with_sigma(self.sigma)
            .with_q(self.q)
            .with_iterations(self.iterations)
            .with_tau(self.tau)
            .with_min_points(self.min_points)
            .with_max_chi2(self.max_chi2)
            .with_min_length(self.min_length)
            .with_fit_shared_points(flag(self.fit_shared_points)?)
            .with_merge(flag(self.merge)?)
            .with_merge_gap_beams(self.merge_gap_beams)
            .with_merge_gate(self.merge_gate)
            .with_corner_gap(self.corner_gap)
            .with_min_corner_angle_deg(self.min_corner_angle_deg)
            .with_split_depth(self.split_depth)
            .with_max_range(self.max_range)
            .with_merge_collinear(flag(self.merge_collinear)?)
            .with_max_alpha_sd_deg(self.max_alpha_sd_deg)
            .with_grazing_noise(self.grazing_noise)
            .with_same_turn_windows(flag(self.same_turn_windows)?)
            .with_fit_sigma(self.fit_sigma)
            .with_per_turn(flag(self.per_turn)?)
            .with_bridge_merge(flag(self.bridge_merge)?)
            .with_footprint(self.footprint)
            .with_arc_chain(self.arc_chain)
            .with_arc_min_turn_deg(self.arc_min_turn_deg)
            .with_arc_max_turn_deg(self.arc_max_turn_deg)
            .with_split_budget(self.split_budget)
            .with_merge_anchor_gate(self.merge_anchor_gate)
            .with_turn_offsets(flag(self.turn_offsets)?)
            .with_merge_f_test(self.merge_f_test)
            .with_arc_pairs(flag(self.arc_pairs)?)
            .with_merge_own_beams(flag(self.merge_own_beams)?)
            .with_footprint_choice(flag(self.footprint_choice)?))
    }
}

/// The default parameters (preset `default`; σ = 5 mm, `max_range` =
/// 81.83 m). For a recorded log, `lms_survey_params` gives σ and
/// `max_range` from its data.
#[no_mangle]
pub extern "C" fn lms_params_default() -> LmsParams {
    LmsParams::from(&Params::DEFAULT)
}

/// Write the preset `name` (`"default"`, `"v3.2"`, `"v3.1"`, `"v3.0"`, `"v2"` or `"paper"`) to `*out`.
/// `LMS_ERR_PRESET` for another name (`*out` unchanged).
///
/// # Safety
///
/// `name` is NULL or a NUL-terminated string; `out` is NULL or points to
/// writable memory for one `LmsParams`.
#[no_mangle]
pub unsafe extern "C" fn lms_params_preset(name: *const c_char, out: *mut LmsParams) -> c_int {
    if name.is_null() {
        return LMS_ERR_NULL;
    }
    if !usable(out) {
        return pointer_error(out);
    }
    // SAFETY: `name` is non-null and NUL-terminated (the caller's contract).
    let name = unsafe { CStr::from_ptr(name) };
    let Some(preset) = name.to_str().ok().and_then(lms_core::params::preset) else {
        return LMS_ERR_PRESET;
    };
    // SAFETY: `out` is non-null, aligned and writable (checked, contract).
    unsafe { out.write(LmsParams::from(&preset.params)) };
    LMS_OK
}

/// Check `*params` as the extraction would: `LMS_OK` or the code of the
/// first field refused.
///
/// # Safety
///
/// `params` is NULL or points to a readable `LmsParams`.
#[no_mangle]
pub unsafe extern "C" fn lms_params_check(params: *const LmsParams) -> c_int {
    if !usable(params) {
        return pointer_error(params);
    }
    // SAFETY: non-null, aligned, readable (checked, contract); every bit
    // pattern is a valid `LmsParams` (numbers only).
    let p = unsafe { params.read() };
    match p.validated() {
        Ok(_) => LMS_OK,
        Err(code) => code,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_round_trip() {
        for preset in &lms_core::params::PRESETS {
            let c = LmsParams::from(&preset.params);
            assert_eq!(*c.validated().unwrap(), preset.params, "{}", preset.name);
        }
        let mut out = lms_params_default();
        // SAFETY: valid C string and output.
        assert_eq!(
            unsafe { lms_params_preset(c"paper".as_ptr(), &mut out) },
            LMS_OK
        );
        assert_eq!(out, LmsParams::from(&Params::PAPER));
        // SAFETY: as above.
        assert_eq!(
            unsafe { lms_params_preset(c"v1".as_ptr(), &mut out) },
            LMS_ERR_PRESET
        );
        // SAFETY: NULL is allowed.
        assert_eq!(
            unsafe { lms_params_preset(core::ptr::null(), &mut out) },
            LMS_ERR_NULL
        );
    }

    /// Every field of `Params` to a value of its own and back: a field
    /// `LmsParams` leaves out, or one it writes to another, fails.
    #[test]
    fn every_field_is_mirrored() {
        let (mut x, mut n, mut b) = (0.0f32, 0u16, false);
        let p = Params::from_sources(
            || {
                x += 1.0;
                x
            },
            || {
                n += 1;
                n
            },
            || {
                b = !b;
                b
            },
        );
        assert_eq!(LmsParams::from(&p).core_params(), Ok(p));
        let flips = Params::from_sources(|| 0.5, || 2, || true);
        assert_eq!(LmsParams::from(&flips).core_params(), Ok(flips));
    }

    #[test]
    fn bad_fields_are_named() {
        let mut p = lms_params_default();
        p.merge = 2;
        // SAFETY: a valid LmsParams.
        assert_eq!(unsafe { lms_params_check(&p) }, LMS_ERR_FLAG);
        p.merge = 1;
        p.sigma = -1.0;
        // SAFETY: as above.
        assert_eq!(unsafe { lms_params_check(&p) }, LMS_ERR_PARAM_SIGMA);
        p.sigma = 0.01;
        p.per_turn = 1;
        // SAFETY: as above.
        let code = unsafe { lms_params_check(&p) };
        assert!(
            code == LMS_ERR_PARAM_NOT_IN_BUILD || code == LMS_OK,
            "{code}"
        );
        // SAFETY: NULL is allowed.
        assert_eq!(unsafe { lms_params_check(core::ptr::null()) }, LMS_ERR_NULL);
    }
}
