//! Shared helpers for the workspace tests: an independent `f64` reference of
//! the smoothing and segmentation (ALGORITHM.md §2–§6) and a reader of the
//! real CARMEN logs.

pub mod carmen;
pub mod reference;
pub mod synth;
