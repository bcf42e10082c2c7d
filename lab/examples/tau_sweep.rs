//! The windows (docs/DESIGN.md, "Windows"): same-turn windows
//! (`Params::same_turn_windows`, the default) against windows of
//! consecutive beams, each with the segmentation gate τ from 9 to 25. Split
//! before reject finds the corners a larger τ no longer marks, so τ trades
//! edges in the windows for splits in the fits. On the defaults: realistic
//! synthetic scenes (`SCANS` per family and σ₀) and the real logs' map
//! truth (every `EVERY`-th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example tau_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

/// The variants, each applied to the defaults (the per-data defaults on
/// real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("defaults (same-turn windows, τ = 9)", |p| p),
        ("tau=12", |p| p.with_tau(12.0)),
        ("tau=16", |p| p.with_tau(16.0)),
        ("tau=25", |p| p.with_tau(25.0)),
        ("same_turn_windows=false", |p| {
            p.with_same_turn_windows(false)
        }),
        ("same_turn_windows=false, tau=16", |p| {
            p.with_same_turn_windows(false).with_tau(16.0)
        }),
        ("same_turn_windows=false, tau=25", |p| {
            p.with_same_turn_windows(false).with_tau(25.0)
        }),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    print_sweep(&variants(), every, scans)
}
