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
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("defaults", |p| p),
        ("tau=12", |p| p.with_tau(12.0)),
        ("tau=16", |p| p.with_tau(16.0)),
        ("footprint=0.002", |p| p.with_footprint(0.002)),
        ("footprint=0.004", |p| p.with_footprint(0.004)),
        ("max_chi2=3", |p| p.with_max_chi2(3.0)),
        ("max_chi2=5", |p| p.with_max_chi2(5.0)),
        ("min_points=6", |p| p.with_min_points(6)),
        ("merge_gap_beams=6", |p| p.with_merge_gap_beams(6)),
        ("corner_gap=0.3", |p| p.with_corner_gap(0.3)),
        ("iterations=20", |p| p.with_iterations(20)),
        ("iterations=40", |p| p.with_iterations(40)),
        ("max_alpha_sd_deg=1.25", |p| p.with_max_alpha_sd_deg(1.25)),
        ("split_budget=722", |p| p.with_split_budget(722)),
        ("split_depth=0 (no split before reject)", |p| {
            p.with_split_depth(0)
        }),
        ("fit_shared_points=true", |p| p.with_fit_shared_points(true)),
        ("merge_collinear=false", |p| p.with_merge_collinear(false)),
        ("max_alpha_sd_deg=inf", |p| {
            p.with_max_alpha_sd_deg(f32::INFINITY)
        }),
        ("merge_collinear=false, max_alpha_sd_deg=inf", |p| {
            p.with_merge_collinear(false)
                .with_max_alpha_sd_deg(f32::INFINITY)
        }),
    ];
    print_sweep(&v, 5, scans)
}
