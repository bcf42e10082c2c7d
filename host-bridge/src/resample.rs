//! Scans re-expressed for another LMS 2xx variant: nearest beam by angle,
//! as `simulate --replay` and `verify` send a log's or a scene's scans.

use lms_core::telegram::{MeasuredValues, RangeBits};
use lms_core::{Frame, Invalid, Unit, Variant};

/// Field of a variant in the 180° frame, in 1/100 °: (first beam, step).
/// A 100° field covers 40°…140° (PROTOCOL.md §2).
pub fn field(variant: Variant) -> (u32, u32) {
    let fov = u32::from(variant.fov_deg());
    ((180 - fov) * 50, u32::from(variant.resolution_centideg()))
}

/// `true` if scans of `source` cover the whole field of `target`.
pub fn covers(source: Variant, target: Variant) -> bool {
    field(target).0 >= field(source).0
}

/// The value words of `frame` (beams of `source`) for `target`, in
/// `units` (13 range bits): target beam `i` takes the nearest beam of the
/// frame by angle (ties to the next one); beams outside the frame are
/// "no echo". Fills all of `out`.
pub fn frame_words(frame: &Frame, source: Variant, target: Variant, units: Unit, out: &mut [u16]) {
    let values = MeasuredValues::from_frame(frame, units, RangeBits::Bits13, 0);
    let values = values.values();
    let not_valid = RangeBits::Bits13.encode_invalid(Invalid::NoEcho);
    let (first_s, res_s) = field(source);
    let (first_t, res_t) = field(target);
    for (i, slot) in out.iter_mut().enumerate() {
        // Angle of target beam i from the right (1/100 °), and the nearest
        // source beam.
        let angle = first_t + i as u32 * res_t;
        *slot = angle
            .checked_sub(first_s)
            .map(|d| ((2 * d + res_s) / (2 * res_s)) as usize)
            .and_then(|j| values.get(j).copied())
            .unwrap_or(not_valid);
    }
}
