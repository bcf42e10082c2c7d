//! # lms-core — SLAM features from SICK LMS 2xx scans, without an allocator
//!
//! A tour of the pipeline, in the order the data flows (section numbers refer
//! to `ALGORITHM.md`):
//!
//! 1. [`telegram`] — LMS 2xx serial telegrams: CRC, framing, typed requests
//!    and replies, `B0` measured values → [`frame::Frame`].
//! 2. [`frame`] — one scan: ranges in metres with a status per beam (§1).
//! 3. [`line_model`] — the three-point line model and its Jacobian (§2).
//! 4. [`ekf`] — the per-window 3×3 extended Kalman filter and its
//!    Mahalanobis distance `D` (§3).
//! 5. [`smoothing`] — Jacobi smoothing passes weighted by `exp(-D/2)`; the
//!    scale space of iterations and process noise (§4–5).
//! 6. [`segmentation`] — segments and edge points where `D` crosses `tau` (§6).
//! 7. [`line_fit`] — polar lines fitted in the range direction, with
//!    covariance, `chi2`, endpoints and merging (§7).
//! 8. [`corners`] — intersections of consecutive lines with covariance,
//!    angle and conditioning (§8).
//! 9. [`extractor`] — the one owner of all working buffers, running stages
//!    2–8 for a frame with [`params::Params`].
//!
//! All maths is `f32` through `libm`; nothing allocates; no input panics.
//! Capacities are constants ([`frame::MAX_BEAMS`], [`extractor::MAX_LINES`],
//! [`extractor::MAX_CORNERS`]); overflow is counted in [`extractor::Stats`].
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
// `!(x < limit)` is deliberate throughout: it treats NaN as failing the test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod coprocessor;
pub mod corners;
pub mod ekf;
pub mod emulator;
pub mod extractor;
pub mod frame;
pub mod line_fit;
pub mod line_model;
pub mod maths;
pub mod params;
pub mod segmentation;
pub mod smoothing;
pub mod split;
pub mod telegram;

pub use extractor::{Extractor, Features};
pub use frame::{Beam, Frame, Geometry, Invalid, Variant};
pub use params::{ParamError, Params};
