//! The pipeline layer: one frame of ranges in, [`Features`](crate::Features)
//! out, in the order the data flows (section numbers refer to `ALGORITHM.md`).
//!
//! 1. [`line_model`] — the three-point line model and its Jacobian (§2).
//! 2. [`ekf`] — the per-window 3×3 extended Kalman filter and its
//!    Mahalanobis distance `D` (§3).
//! 3. [`smoothing`] — Jacobi smoothing passes weighted by `exp(-D/2)`; the
//!    scale space of iterations and process noise (§4–5).
//! 4. [`segmentation`] — segments and edge points where `D` crosses `tau` (§6).
//! 5. [`line_fit`] — polar lines fitted in the range direction, with
//!    covariance, `chi2`, endpoints (§7).
//! 6. [`split`] — split before reject (§7.4, `Params::split_depth`).
//! 7. [`corners`] — intersections of consecutive lines with covariance,
//!    angle and conditioning (§8).
//! 8. `turns` (feature `section10`) — per-turn extraction and the fusion
//!    of the turns' lines (§10 proposal (d)).
//! 9. [`extractor`] — the one owner of all working buffers, running stages
//!    1–7 for a frame and merging neighbouring lines (§7.6).
//!
//! Every stage reads the shared types of [`crate::frame`] and
//! [`crate::features`] and never a later stage; only the extractor knows
//! them all.

pub mod arcs;
pub mod bearings;
pub mod corners;
pub mod ekf;
pub mod extractor;
pub mod line_fit;
pub mod line_model;
pub(crate) mod merge;
pub mod segmentation;
pub mod smoothing;
pub mod split;
#[cfg(feature = "section10")]
pub mod turns;
