//! Shared helpers for the workspace tests: an independent `f64` reference of
//! `docs/ALGORITHM.md` v3 (§1–§6, the line fit of §7 and the corners of §8)
//! and scenes with ground truth. The real CARMEN logs are read through the
//! core's one reader (`lms_core::test_support::open_log`, a dev-dependency
//! feature).

pub mod reference;
pub mod synth;
