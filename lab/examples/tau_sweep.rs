//! Same-turn windows (ALGORITHM.md §10 (a), `Params::same_turn_windows`,
//! the default since stop 23) against stop 22's windows of consecutive
//! beams, each with the segmentation gate τ (§6) from 9 to 25: split
//! before reject finds the corners that a larger τ no longer marks, so τ
//! trades edges in the windows for splits in §7. Realistic synthetic
//! scenes (`SCANS` per family and σ₀) and the real logs' map truth (every
//! `EVERY`-th frame), pooled (docs/ALGORITHM-v3-section10.md §10.9). On
//! stop 23's defaults (`Params::STOP23`: no anchor gate on the merges), so
//! §10.9's figures stay as measured.
//!
//! `cargo run --release -p lms-lab --example tau_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{print_sweep_over, Adjust};

/// The variants, each applied to stop 23's defaults (the per-data defaults
/// on real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("stop 22: consecutive windows (τ = 9)", |p| {
            on_data(Params::STOP22, p)
        }),
        ("consecutive windows, τ = 16", |p| Params {
            tau: 16.0,
            ..on_data(Params::STOP22, p)
        }),
        ("consecutive windows, τ = 25", |p| Params {
            tau: 25.0,
            ..on_data(Params::STOP22, p)
        }),
        ("stop 23: same-turn windows (τ = 9)", |p| p),
        ("same-turn windows, τ = 12", |p| Params { tau: 12.0, ..p }),
        ("same-turn windows, τ = 16", |p| Params { tau: 16.0, ..p }),
        ("same-turn windows, τ = 25", |p| Params { tau: 25.0, ..p }),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    print_sweep_over(|p| on_data(Params::STOP23, p), &variants(), every, scans)
}
