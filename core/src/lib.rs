//! # lms-core — SLAM features from SICK LMS 2xx scans, without an allocator
//!
//! The crate is in layers; each imports only the layers before it in this
//! list, never a later one (section numbers refer to `ALGORITHM.md`):
//!
//! 1. **Shared types**, used by every layer:
//!    [`frame`] (one scan: ranges in metres with a status per beam, §1),
//!    [`features`] (segments, edges, lines, corners and the counters of what
//!    was dropped, [`Stats`]), [`params`] (the tuning of §9) and [`maths`]
//!    (small fixed-size vectors and symmetric matrices), [`units`] (the
//!    sensor's range unit, [`Unit`]).
//! 2. **The pipeline** ([`pipeline`]): frame → [`pipeline::line_model`] →
//!    [`pipeline::ekf`] → [`pipeline::smoothing`] →
//!    [`pipeline::segmentation`] → [`pipeline::line_fit`] →
//!    [`pipeline::split`] → [`pipeline::corners`]; [`pipeline::extractor`]
//!    owns every buffer and runs the stages ([`Extractor`]).
//! 3. **The wire** ([`telegram`]): LMS 2xx serial telegrams — CRC, framing,
//!    typed requests and replies, `B0` measured values → [`Frame`], and the
//!    co-processor's feature telegrams `D0`–`D5` ← [`Features`].
//! 4. **Devices** ([`device`]): the LMS 2xx model
//!    ([`device::emulator`]), its client's handshake ([`device::client`])
//!    and the co-processor ([`device::coprocessor`]), sans I/O.
//! 5. **Recorded logs** ([`carmen`]): CARMEN `FLASER` lines → [`Frame`]
//!    (per line without allocation; with `std` a streaming reader and the
//!    per-file unit decision).
//!
//! With feature `test-support`, `test_support` holds what the tests,
//! benches, examples and the fuzz crate share: an in-memory serial port, a
//! seeded generator and `open_log` for the shared CARMEN logs.
//!
//! All maths is `f32` through `libm`; nothing allocates; no input panics.
//! Capacities are constants ([`MAX_BEAMS`], [`MAX_LINES`], [`MAX_CORNERS`]);
//! overflow is counted in [`Stats`].
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
// `!(x < limit)` is deliberate throughout: it treats NaN as failing the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// The README's library example runs as a doctest of this crate.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
struct ReadmeDoctests;

pub mod carmen;
pub mod device;
pub mod features;
pub mod frame;
pub mod maths;
pub mod params;
pub mod pipeline;
pub mod telegram;
#[cfg(feature = "test-support")]
pub mod test_support;
pub mod units;

/// Pipeline internals for the evaluation package (`lab/`) and the
/// workspace tests: no stability promise, may change in any release. Off
/// unless feature `unstable-lab`.
#[cfg(feature = "unstable-lab")]
pub mod unstable {
    pub use crate::pipeline::line_fit::fit_line;
    pub use crate::pipeline::merge::{fit_span, try_merge};
    pub use crate::pipeline::segmentation::segment;
}

pub use features::Line;
pub use features::{
    Corner, EdgeIter, Edges, Features, Segment, Stats, MAX_CORNERS, MAX_LINES, MAX_SEGMENTS,
    MAX_WINDOWS,
};
pub use frame::MAX_BEAMS;
pub use frame::{Beam, FovRes, Frame, Geometry, Invalid, Variant};
pub use params::{DataProfile, DataSurvey, ParamError, Params, RangeMode, ValidParams};
pub use pipeline::extractor::{Extractor, Trace};
pub use pipeline::line_fit::FitError;
pub use units::Unit;
