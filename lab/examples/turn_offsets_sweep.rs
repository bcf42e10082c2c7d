//! The turns' offsets in the fits' χ² (`Params::turn_offsets`, ALGORITHM.md
//! §10.4, the default since stop 24) with and without the merges' anchor
//! gate and same-turn windows. Realistic synthetic scenes (`SCANS` per
//! family and σ₀) and the real logs' map truth (every 5th frame), pooled
//! (docs/ALGORITHM-v3-section10.md §10.11).
//!
//! `cargo run --release -p lms-lab --example turn_offsets_sweep -- [SCANS]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("stop 23 (neither)", |p| on_data(Params::STOP23, p)),
        ("anchor gate only", |p| Params {
            turn_offsets: false,
            ..p
        }),
        ("turn offsets only", |p| Params {
            merge_anchor_gate: f32::INFINITY,
            ..p
        }),
        ("defaults (both)", |p| p),
        ("defaults, windows of §2 (no same-turn)", |p| Params {
            same_turn_windows: false,
            ..p
        }),
        ("defaults + per turn (§10 d)", |p| Params {
            per_turn: true,
            ..p
        }),
    ];
    print_sweep(&v, 5, scans)
}
