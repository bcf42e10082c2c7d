//! The turns' offsets out of the fits' χ² (`Params::turn_offsets`;
//! docs/DESIGN.md, "Fits") with and without the merges' anchor gate, the
//! defaults with windows of consecutive beams, and per-turn extraction.
//! Realistic synthetic scenes (`SCANS` per family and σ₀) and the real
//! logs' map truth (every 5th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example turn_offsets_sweep -- [SCANS]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("turn_offsets=false, merge_anchor_gate=inf", |p| Params {
            turn_offsets: false,
            merge_anchor_gate: f32::INFINITY,
            ..p
        }),
        ("turn_offsets=false (anchor gate only)", |p| Params {
            turn_offsets: false,
            ..p
        }),
        ("merge_anchor_gate=inf (turn offsets only)", |p| Params {
            merge_anchor_gate: f32::INFINITY,
            ..p
        }),
        ("defaults (both)", |p| p),
        ("same_turn_windows=false", |p| Params {
            same_turn_windows: false,
            ..p
        }),
        ("per_turn=true", |p| Params {
            per_turn: true,
            ..p
        }),
    ];
    print_sweep(&v, 5, scans)
}
