//! The frame (metres or LMS units) → `LmsFeatures`.

use core::ffi::c_int;
use core::mem::{align_of, size_of};
use core::ptr::addr_of_mut;

use lms_core::{Extractor, Features, Frame, Invalid, Unit, ValidParams, Variant};

use crate::codes::*;
use crate::params::LmsParams;
use crate::{overlap, pointer_error, usable, Bytes};

/// A scan variant (field of view / resolution): one of the `LMS_FOV*`
/// constants.
pub type LmsVariant = u32;
/// 180° at 1°: 181 beams.
pub const LMS_FOV180_RES100: LmsVariant = 0;
/// 180° at 0.5°: 361 beams.
pub const LMS_FOV180_RES50: LmsVariant = 1;
/// 100° at 1°: 101 beams.
pub const LMS_FOV100_RES100: LmsVariant = 2;
/// 100° at 0.5°: 201 beams.
pub const LMS_FOV100_RES50: LmsVariant = 3;
/// 100° at 0.25°: 401 beams.
pub const LMS_FOV100_RES25: LmsVariant = 4;

/// The sensor's range unit: one of the `LMS_UNIT_*` constants.
pub type LmsUnit = u32;
/// Centimetres (error codes 8183..=8191).
pub const LMS_UNIT_CM: LmsUnit = 0;
/// Millimetres (error codes 32759..=32767, the 32 m mode's).
pub const LMS_UNIT_MM: LmsUnit = 1;
/// Decimetres, 10 cm (error codes 8183..=8191).
pub const LMS_UNIT_DM: LmsUnit = 2;

/// Most beams in one frame (100° at 0.25°).
pub const LMS_MAX_BEAMS: usize = 401;
/// Most lines of one frame.
pub const LMS_MAX_LINES: usize = 64;
/// Most corners of one frame.
pub const LMS_MAX_CORNERS: usize = 63;
/// Size of the private working memory in `LmsFeatures`, in 8-byte words.
pub const LMS_WORKSPACE_WORDS: usize = 1280;

/// A fitted line `x·cos(alpha) + y·sin(alpha) = r` in the sensor frame
/// (x forward, y left).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LmsLine {
    /// Normal direction α (rad), in (−π, π].
    pub alpha: f32,
    /// Distance from the sensor (m), >= 0.
    pub r: f32,
    /// Covariance of (α, r): `{{αα, αr}, {αr, rr}}` (rad², rad·m, m²).
    pub cov: [[f32; 2]; 2],
    /// First beam of the fitted segment.
    pub first: u16,
    /// Last beam of the fitted segment (inclusive).
    pub last: u16,
    /// Valid points in the fit.
    pub points: u16,
    /// Fit quality, ≈ 1 for a true line.
    pub chi2: f32,
    /// First and last points projected onto the line, `{{x, y}, {x, y}}` (m).
    pub endpoints: [[f32; 2]; 2],
}

/// The intersection of two consecutive lines.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LmsCorner {
    /// x (m), forward.
    pub x: f32,
    /// y (m), left.
    pub y: f32,
    /// Covariance of (x, y): `{{xx, xy}, {xy, yy}}` (m²).
    pub cov: [[f32; 2]; 2],
    /// Angle between the lines, in [0°, 90°].
    pub angle_deg: f32,
    /// 1 if `angle_deg >= min_corner_angle_deg` (well-conditioned), else 0.
    pub well_conditioned: u8,
    /// Index of the first line in `lines`.
    pub line_a: u8,
    /// Index of the second line in `lines`.
    pub line_b: u8,
}

/// What a run dropped, rejected or could not store (the core's `Stats`,
/// field for field; the JSON keys of `host-bridge extract`'s `stats`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LmsStats {
    /// Valid beams in the frame.
    pub valid_beams: u16,
    /// Windows that are invalid.
    pub invalid_windows: u16,
    /// Segments shorter than `min_points`.
    pub short_segments: u16,
    /// Segments beyond capacity.
    pub segment_overflow: u16,
    /// Edge points beyond capacity.
    pub edge_overflow: u16,
    /// Segments whose fit failed.
    pub degenerate_fits: u16,
    /// Lines rejected for `chi2 > max_chi2`.
    pub rejected_chi2: u16,
    /// Lines rejected for `length < min_length`.
    pub rejected_short: u16,
    /// Pairs of lines merged into one.
    pub merges: u16,
    /// Lines beyond `LMS_MAX_LINES`.
    pub line_overflow: u16,
    /// Close line pairs that are parallel.
    pub degenerate_corners: u16,
    /// Corners beyond `LMS_MAX_CORNERS`.
    pub corner_overflow: u16,
    /// Segments split in two (split before reject).
    pub splits: u16,
    /// Split halves dropped for fewer than `min_points` beams.
    pub split_short: u16,
    /// Split pieces dropped as still not one straight line.
    pub split_rejected: u16,
    /// Beams at or beyond `max_range`, made invalid.
    pub beyond_max_range: u16,
    /// Lines dropped for an uncertain angle (`max_alpha_sd_deg`).
    pub rejected_wide: u16,
    /// Lines dropped as pieces of an arc.
    pub rejected_arc: u16,
}

/// The names of [`LmsStats`]' fields, in order (checked against the core's).
#[cfg(test)]
const STATS_NAMES: [&str; 18] = [
    "valid_beams",
    "invalid_windows",
    "short_segments",
    "segment_overflow",
    "edge_overflow",
    "degenerate_fits",
    "rejected_chi2",
    "rejected_short",
    "merges",
    "line_overflow",
    "degenerate_corners",
    "corner_overflow",
    "splits",
    "split_short",
    "split_rejected",
    "beyond_max_range",
    "rejected_wide",
    "rejected_arc",
];

/// Private working memory of the pipeline (the frame and the extractor's
/// buffers); its contents are rewritten by every call.
#[repr(C)]
pub struct LmsWorkspace {
    /// Private.
    pub opaque: [u64; LMS_WORKSPACE_WORDS],
}

/// What [`LmsWorkspace`] holds.
struct Workspace {
    frame: Frame,
    extractor: Extractor,
}

const _: () = {
    assert!(size_of::<Workspace>() <= size_of::<LmsWorkspace>());
    assert!(align_of::<Workspace>() <= align_of::<LmsWorkspace>());
    assert!(LMS_MAX_BEAMS == lms_core::MAX_BEAMS);
    assert!(LMS_MAX_LINES == lms_core::MAX_LINES);
    assert!(LMS_MAX_CORNERS == lms_core::MAX_CORNERS);
};

/// The features of one frame, and the working memory that computes them.
/// Caller-provided (about 15 KiB: a static or heap object, not a small
/// stack); every extraction call rewrites all of it, so it needs no
/// initialisation. One `LmsFeatures` serves one call at a time.
#[repr(C)]
pub struct LmsFeatures {
    /// Number of beams of the frame.
    pub n_beams: u32,
    /// Segments found (before the line tests).
    pub n_segments: u32,
    /// Lines in `lines` (the rest are zero).
    pub n_lines: u32,
    /// Corners in `corners` (the rest are zero).
    pub n_corners: u32,
    /// Accepted lines, in scan order.
    pub lines: [LmsLine; LMS_MAX_LINES],
    /// Corners between consecutive lines, in scan order.
    pub corners: [LmsCorner; LMS_MAX_CORNERS],
    /// Counters of everything dropped or rejected.
    pub stats: LmsStats,
    /// Private: the pipeline's working memory. Do not read or write.
    pub workspace: LmsWorkspace,
}

/// The core's variant of a C constant.
pub(crate) fn variant_of(v: LmsVariant) -> Result<Variant, c_int> {
    match v {
        LMS_FOV180_RES100 => Ok(Variant::Fov180Res100),
        LMS_FOV180_RES50 => Ok(Variant::Fov180Res50),
        LMS_FOV100_RES100 => Ok(Variant::Fov100Res100),
        LMS_FOV100_RES50 => Ok(Variant::Fov100Res50),
        LMS_FOV100_RES25 => Ok(Variant::Fov100Res25),
        _ => Err(LMS_ERR_VARIANT),
    }
}

/// The core's unit of a C constant.
pub(crate) fn unit_of(u: LmsUnit) -> Result<Unit, c_int> {
    match u {
        LMS_UNIT_CM => Ok(Unit::Centimetre),
        LMS_UNIT_MM => Ok(Unit::Millimetre),
        LMS_UNIT_DM => Ok(Unit::Decimetre),
        _ => Err(LMS_ERR_UNIT),
    }
}

/// An all-invalid frame of `variant` with `n` beams (3..=the variant's).
pub(crate) fn frame_of(variant: Variant, n: usize) -> Result<Frame, c_int> {
    if n > variant.beams() {
        return Err(LMS_ERR_LENGTH);
    }
    Frame::new(variant.geometry(), n).map_err(|_| LMS_ERR_LENGTH)
}

/// Set beam `j` of `frame` from a raw value in `unit`, as the core decodes
/// a recorded log: 0 is no distance, codes from the unit's first error code
/// up to its all-ones value are invalid with their reason, a value above is
/// refused, every other is `raw / units per metre` (f32).
pub(crate) fn set_units(frame: &mut Frame, j: usize, unit: Unit, raw: u16) -> Result<(), c_int> {
    let all_ones = unit.all_ones();
    if raw > all_ones {
        Err(LMS_ERR_VALUE)
    } else if raw >= unit.first_error_code() {
        frame.set_invalid(j, Invalid::from_code_offset(all_ones - raw));
        Ok(())
    } else {
        // 0 becomes `Invalid::Zero` here.
        frame.set_metres(j, f32::from(raw) / unit.per_metre());
        Ok(())
    }
}

/// The checks shared by both entry points; the validated parameters.
///
/// # Safety
///
/// `params` is NULL or readable; `input` is NULL or readable for `bytes`.
unsafe fn check_common<T>(
    params: *const LmsParams,
    variant: LmsVariant,
    input: *const T,
    n: usize,
    out: *mut LmsFeatures,
) -> Result<(ValidParams, Variant), c_int> {
    if !usable(params) {
        return Err(pointer_error(params));
    }
    if !usable(out) {
        return Err(pointer_error(out));
    }
    let variant = variant_of(variant)?;
    if !(lms_core::frame::MIN_BEAMS..=variant.beams()).contains(&n) {
        return Err(LMS_ERR_LENGTH);
    }
    if !usable(input) {
        return Err(pointer_error(input));
    }
    if overlap(
        Bytes::at(input, n.saturating_mul(size_of::<T>())),
        Bytes::at(out, size_of::<LmsFeatures>()),
    ) {
        return Err(LMS_ERR_OVERLAP);
    }
    // SAFETY: non-null, aligned, readable (checked above, contract); every
    // bit pattern is a valid `LmsParams`.
    let p = unsafe { params.read() };
    Ok((p.validated()?, variant))
}

/// Run the pipeline on the frame that `fill` writes into the workspace of
/// `*out`, and write the features into `*out`.
///
/// # Safety
///
/// `out` is non-null, aligned and writable for one `LmsFeatures`, and no
/// other reference to it is alive.
unsafe fn run_into(
    out: *mut LmsFeatures,
    params: &ValidParams,
    variant: Variant,
    n: usize,
    fill: impl FnOnce(&mut Frame) -> Result<(), c_int>,
) -> c_int {
    let frame = match frame_of(variant, n) {
        Ok(f) => f,
        Err(code) => return code,
    };
    // SAFETY: the workspace of `*out` is large and aligned enough for a
    // `Workspace` (asserted at compile time); its fields are written before
    // they are referenced.
    let ws = unsafe { addr_of_mut!((*out).workspace) }.cast::<Workspace>();
    // SAFETY: as above: `ws` is valid for writes.
    let (frame, ex) = unsafe {
        addr_of_mut!((*ws).frame).write(frame);
        addr_of_mut!((*ws).extractor).write(Extractor::new());
        (&mut (*ws).frame, &mut (*ws).extractor)
    };
    if let Err(code) = fill(frame) {
        return code;
    }
    let features = ex.run(frame, params);
    // SAFETY: the public fields of `*out` are disjoint from the workspace
    // referenced by `features`; `out` is valid for writes.
    unsafe { write_features(out, n, features) };
    LMS_OK
}

/// Copy `features` into the public fields of `*out`; unused slots zero.
///
/// # Safety
///
/// `out` is valid for writes; nothing references its public fields.
unsafe fn write_features(out: *mut LmsFeatures, n: usize, features: &Features) {
    let mut lines = [LmsLine::default(); LMS_MAX_LINES];
    for (slot, l) in lines.iter_mut().zip(features.lines()) {
        *slot = LmsLine {
            alpha: l.alpha,
            r: l.r,
            cov: l.cov.to_array(),
            first: l.first,
            last: l.last,
            points: l.points,
            chi2: l.chi2,
            endpoints: l.endpoints,
        };
    }
    let mut corners = [LmsCorner::default(); LMS_MAX_CORNERS];
    for (slot, c) in corners.iter_mut().zip(features.corners()) {
        *slot = LmsCorner {
            x: c.x,
            y: c.y,
            cov: c.cov.to_array(),
            angle_deg: c.angle_deg,
            well_conditioned: c.well_conditioned.into(),
            line_a: c.line_a,
            line_b: c.line_b,
        };
    }
    let s = features.stats();
    let stats = LmsStats {
        valid_beams: s.valid_beams,
        invalid_windows: s.invalid_windows,
        short_segments: s.short_segments,
        segment_overflow: s.segment_overflow,
        edge_overflow: s.edge_overflow,
        degenerate_fits: s.degenerate_fits,
        rejected_chi2: s.rejected_chi2,
        rejected_short: s.rejected_short,
        merges: s.merges,
        line_overflow: s.line_overflow,
        degenerate_corners: s.degenerate_corners,
        corner_overflow: s.corner_overflow,
        splits: s.splits,
        split_short: s.split_short,
        split_rejected: s.split_rejected,
        beyond_max_range: s.beyond_max_range,
        rejected_wide: s.rejected_wide,
        rejected_arc: s.rejected_arc,
    };
    let count = |k: usize| u32::try_from(k).unwrap_or(u32::MAX);
    // SAFETY: `out` is valid for writes (contract); each field is written
    // through its own raw pointer, never through a reference to `*out`.
    unsafe {
        addr_of_mut!((*out).n_beams).write(count(n));
        addr_of_mut!((*out).n_segments).write(count(features.segments().len()));
        addr_of_mut!((*out).n_lines).write(count(features.lines().len()));
        addr_of_mut!((*out).n_corners).write(count(features.corners().len()));
        addr_of_mut!((*out).lines).write(lines);
        addr_of_mut!((*out).corners).write(corners);
        addr_of_mut!((*out).stats).write(stats);
    }
}

/// Extract the features of one scan given in metres: `ranges[j]` is beam
/// `j`'s range; 0 is no distance, a value that is not finite and positive
/// is invalid. `n` is the variant's number of beams (or fewer, at least 3:
/// e.g. a CARMEN log's 180 or 360 without the last beam). Returns `LMS_OK`
/// with `*out` written, or an error code with `*out` unspecified.
///
/// # Safety
///
/// `params` is NULL or points to a readable `LmsParams`; `ranges` is NULL
/// or readable for `n` floats; `out` is NULL or points to writable memory
/// for one `LmsFeatures` that no other thread uses during the call.
#[no_mangle]
pub unsafe extern "C" fn lms_extract_metres(
    params: *const LmsParams,
    variant: LmsVariant,
    ranges: *const f32,
    n: usize,
    out: *mut LmsFeatures,
) -> c_int {
    // SAFETY: the caller's contract on `params` and `ranges`.
    let (params, variant) = match unsafe { check_common(params, variant, ranges, n, out) } {
        Ok(v) => v,
        Err(code) => return code,
    };
    // SAFETY: `ranges` is non-null, aligned, readable for `n` floats
    // (checked, contract) and does not overlap `*out` (checked).
    let ranges = unsafe { core::slice::from_raw_parts(ranges, n) };
    // SAFETY: `out` is non-null, aligned, writable (checked, contract).
    unsafe {
        run_into(out, &params, variant, n, |frame| {
            for (j, &r) in ranges.iter().enumerate() {
                frame.set_metres(j, r);
            }
            Ok(())
        })
    }
}

/// Extract the features of one scan given as raw LMS values in `unit`, as
/// the core decodes a recorded log: 0 is no distance; a value from the
/// unit's first error code (8183 cm or 10 cm, 32759 mm) up to its all-ones
/// value (8191, 32767) is invalid with the sensor's reason; a value above
/// it is refused (`LMS_ERR_VALUE`; mask a telegram's flag bits first);
/// every other is `raw / units per metre` as a float. `n` as in
/// `lms_extract_metres`.
///
/// # Safety
///
/// As `lms_extract_metres`, with `raw` readable for `n` `uint16_t`.
#[no_mangle]
pub unsafe extern "C" fn lms_extract_units(
    params: *const LmsParams,
    variant: LmsVariant,
    unit: LmsUnit,
    raw: *const u16,
    n: usize,
    out: *mut LmsFeatures,
) -> c_int {
    // SAFETY: the caller's contract on `params` and `raw`.
    let (params, variant) = match unsafe { check_common(params, variant, raw, n, out) } {
        Ok(v) => v,
        Err(code) => return code,
    };
    let unit = match unit_of(unit) {
        Ok(u) => u,
        Err(code) => return code,
    };
    // SAFETY: `raw` is non-null, aligned, readable for `n` values
    // (checked, contract) and does not overlap `*out` (checked).
    let raw = unsafe { core::slice::from_raw_parts(raw, n) };
    // SAFETY: `out` is non-null, aligned, writable (checked, contract).
    unsafe {
        run_into(out, &params, variant, n, |frame| {
            for (j, &v) in raw.iter().enumerate() {
                set_units(frame, j, unit, v)?;
            }
            Ok(())
        })
    }
}

/// The variant of a scan of `n` beams, CARMEN's counts included (180 and
/// 360: the 180° variants without their last beam). `LMS_ERR_VARIANT` for
/// another count.
///
/// # Safety
///
/// `out` is NULL or points to a writable `LmsVariant`.
#[no_mangle]
pub unsafe extern "C" fn lms_variant_for_beams(n: usize, out: *mut LmsVariant) -> c_int {
    if !usable(out) {
        return pointer_error(out);
    }
    let Some(v) = lms_core::carmen::variant_for_beams(n) else {
        return LMS_ERR_VARIANT;
    };
    let code = match v {
        Variant::Fov180Res100 => LMS_FOV180_RES100,
        Variant::Fov180Res50 => LMS_FOV180_RES50,
        Variant::Fov100Res100 => LMS_FOV100_RES100,
        Variant::Fov100Res50 => LMS_FOV100_RES50,
        Variant::Fov100Res25 => LMS_FOV100_RES25,
    };
    // SAFETY: non-null, aligned, writable (checked, contract).
    unsafe { out.write(code) };
    LMS_OK
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::params::lms_params_default;
    use std::boxed::Box;

    fn features() -> Box<LmsFeatures> {
        // SAFETY: every field of LmsFeatures is numbers: all zero is valid.
        unsafe { Box::new(core::mem::zeroed()) }
    }

    /// A wall 2 m ahead, seen at 1°.
    fn wall() -> std::vec::Vec<f32> {
        let g = Variant::Fov180Res100.geometry();
        (0..181)
            .map(|j| {
                let c = g.bearing(j).cos();
                if c > 0.2 {
                    2.0 / c
                } else {
                    0.0
                }
            })
            .collect()
    }

    #[test]
    fn stats_fields_match_the_core() {
        let names: std::vec::Vec<&str> = lms_core::Stats::FIELDS.iter().map(|f| f.0).collect();
        assert_eq!(names, STATS_NAMES);
        std::println!(
            "LmsFeatures {} B, workspace needs {} B of {} B, LmsParams {} B",
            size_of::<LmsFeatures>(),
            size_of::<Workspace>(),
            size_of::<LmsWorkspace>(),
            size_of::<LmsParams>()
        );
    }

    #[test]
    fn a_wall_is_one_line_and_equals_the_core() {
        let ranges = wall();
        let p = lms_params_default();
        let mut out = features();
        // SAFETY: valid pointers and length.
        let code =
            unsafe { lms_extract_metres(&p, LMS_FOV180_RES100, ranges.as_ptr(), 181, &mut *out) };
        assert_eq!(code, LMS_OK);
        assert_eq!(out.n_lines, 1);
        assert!((out.lines[0].r - 2.0).abs() < 1e-3);
        let frame = Frame::from_metres(Variant::Fov180Res100.geometry(), &ranges).unwrap();
        let mut ex = Box::new(Extractor::new());
        let f = ex.run(&frame, &ValidParams::DEFAULT);
        assert_eq!(out.lines[0].alpha.to_bits(), f.lines()[0].alpha.to_bits());
        assert_eq!(out.stats.valid_beams, f.stats().valid_beams);
    }

    #[test]
    fn units_decode_as_the_log_reader() {
        let mut raw = [250u16; 181];
        raw[3] = 8191;
        raw[4] = 0;
        raw[5] = 8190;
        let p = lms_params_default();
        let mut out = features();
        // SAFETY: valid pointers and length.
        let code = unsafe {
            lms_extract_units(
                &p,
                LMS_FOV180_RES100,
                LMS_UNIT_CM,
                raw.as_ptr(),
                181,
                &mut *out,
            )
        };
        assert_eq!(code, LMS_OK);
        assert_eq!(out.stats.valid_beams, 178);
        raw[6] = 8192;
        // SAFETY: as above.
        let code = unsafe {
            lms_extract_units(
                &p,
                LMS_FOV180_RES100,
                LMS_UNIT_CM,
                raw.as_ptr(),
                181,
                &mut *out,
            )
        };
        assert_eq!(code, LMS_ERR_VALUE);
        // SAFETY: as above; mm takes 8192.
        let code = unsafe {
            lms_extract_units(
                &p,
                LMS_FOV180_RES100,
                LMS_UNIT_MM,
                raw.as_ptr(),
                181,
                &mut *out,
            )
        };
        assert_eq!(code, LMS_OK);
    }

    #[test]
    fn bad_arguments_are_codes() {
        let ranges = wall();
        let p = lms_params_default();
        let mut out = features();
        let o: *mut LmsFeatures = &mut *out;
        let r = ranges.as_ptr();
        // SAFETY: every pointer is NULL, misaligned or valid; nothing is read
        // through an invalid one (that is what is tested).
        unsafe {
            assert_eq!(
                lms_extract_metres(core::ptr::null(), 0, r, 181, o),
                LMS_ERR_NULL
            );
            assert_eq!(
                lms_extract_metres(&p, 0, core::ptr::null(), 181, o),
                LMS_ERR_NULL
            );
            assert_eq!(
                lms_extract_metres(&p, 0, r, 181, core::ptr::null_mut()),
                LMS_ERR_NULL
            );
            assert_eq!(lms_extract_metres(&p, 9, r, 181, o), LMS_ERR_VARIANT);
            assert_eq!(lms_extract_metres(&p, 0, r, 182, o), LMS_ERR_LENGTH);
            assert_eq!(lms_extract_metres(&p, 0, r, 2, o), LMS_ERR_LENGTH);
            assert_eq!(lms_extract_metres(&p, 0, r, 180, o), LMS_OK);
            let odd = r.cast::<u8>().add(1).cast::<f32>();
            assert_eq!(lms_extract_metres(&p, 0, odd, 181, o), LMS_ERR_ALIGN);
            let inside = addr_of_mut!((*o).lines).cast::<f32>();
            assert_eq!(lms_extract_metres(&p, 0, inside, 181, o), LMS_ERR_OVERLAP);
            let raw = [100u16; 181];
            assert_eq!(
                lms_extract_units(&p, 0, 7, raw.as_ptr(), 181, o),
                LMS_ERR_UNIT
            );
            let mut v = 99;
            assert_eq!(lms_variant_for_beams(360, &mut v), LMS_OK);
            assert_eq!(v, LMS_FOV180_RES50);
            assert_eq!(lms_variant_for_beams(362, &mut v), LMS_ERR_VARIANT);
        }
        let mut bad = p;
        bad.iterations = 0;
        // SAFETY: valid pointers.
        let code = unsafe { lms_extract_metres(&bad, 0, r, 181, o) };
        assert_eq!(code, LMS_ERR_PARAM_ITERATIONS);
    }
}
