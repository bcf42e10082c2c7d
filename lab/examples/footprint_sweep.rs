//! The footprint-weighted fits (`Params::footprint`, κ) and the merge
//! across rejected segments (`Params::bridge_merge`) (docs/DESIGN.md,
//! "Fits" and "Merges"): each off, both off, and κ = 2–5 mrad, on the
//! defaults: realistic synthetic scenes (`SCANS` per family and σ₀) and
//! the real logs' map truth (every `EVERY`-th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example footprint_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

/// The variants, each applied to the defaults (the per-data defaults on
/// real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("defaults (footprint=0.003, bridge_merge=true)", |p| p),
        ("footprint=0", |p| p.with_footprint(0.0)),
        ("bridge_merge=false", |p| p.with_bridge_merge(false)),
        ("footprint=0, bridge_merge=false", |p| {
            p.with_footprint(0.0).with_bridge_merge(false)
        }),
        ("footprint=0.002", |p| p.with_footprint(0.002)),
        ("footprint=0.004", |p| p.with_footprint(0.004)),
        ("footprint=0.005", |p| p.with_footprint(0.005)),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    print_sweep(&variants(), every, scans)
}
