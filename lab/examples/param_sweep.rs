//! The defaults' other parameters one at a time (docs/DESIGN.md,
//! "Parameters"): τ, the footprint κ, `max_chi2`, `min_points`,
//! `merge_gap_beams`, `corner_gap`, the passes, `max_alpha_sd_deg`, the
//! split's work bound; and ALGORITHM.md v2's changes to v1 (split before
//! reject, shared corner points out of the fits) and additions (the
//! collinear merge, the σ_α gate) turned off. Realistic synthetic scenes
//! (`SCANS` per family and σ₀) and the real logs' map truth (every 5th
//! frame), pooled. None wins every column.
//!
//! `cargo run --release -p lms-lab --example param_sweep -- [SCANS]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("defaults", |p| p),
        ("tau=12", |p| Params { tau: 12.0, ..p }),
        ("tau=16", |p| Params { tau: 16.0, ..p }),
        ("footprint=0.002", |p| Params {
            footprint: 0.002,
            ..p
        }),
        ("footprint=0.004", |p| Params {
            footprint: 0.004,
            ..p
        }),
        ("max_chi2=3", |p| Params { max_chi2: 3.0, ..p }),
        ("max_chi2=5", |p| Params { max_chi2: 5.0, ..p }),
        ("min_points=6", |p| Params { min_points: 6, ..p }),
        ("merge_gap_beams=6", |p| Params {
            merge_gap_beams: 6,
            ..p
        }),
        ("corner_gap=0.3", |p| Params {
            corner_gap: 0.3,
            ..p
        }),
        ("iterations=20", |p| Params {
            iterations: 20,
            ..p
        }),
        ("iterations=40", |p| Params {
            iterations: 40,
            ..p
        }),
        ("max_alpha_sd_deg=1.25", |p| Params {
            max_alpha_sd_deg: 1.25,
            ..p
        }),
        ("split_budget=722", |p| Params {
            split_budget: 722,
            ..p
        }),
        ("split_depth=0 (no split before reject)", |p| Params {
            split_depth: 0,
            ..p
        }),
        ("fit_shared_points=true", |p| Params {
            fit_shared_points: true,
            ..p
        }),
        ("merge_collinear=false", |p| Params {
            merge_collinear: false,
            ..p
        }),
        ("max_alpha_sd_deg=inf", |p| Params {
            max_alpha_sd_deg: f32::INFINITY,
            ..p
        }),
        ("merge_collinear=false, max_alpha_sd_deg=inf", |p| Params {
            merge_collinear: false,
            max_alpha_sd_deg: f32::INFINITY,
            ..p
        }),
    ];
    print_sweep(&v, 5, scans)
}
