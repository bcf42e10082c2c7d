//! The turns' offsets out of the fits' χ² (`Params::turn_offsets`;
//! docs/DESIGN.md, "Fits") with and without the merges' anchor gate, the
//! defaults with windows of consecutive beams, and per-turn extraction.
//! Realistic synthetic scenes (`SCANS` per family and σ₀) and the real
//! logs' map truth (every 5th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example turn_offsets_sweep -- [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("turn_offsets=false, merge_anchor_gate=inf", |p| {
            p.with_turn_offsets(false)
                .with_merge_anchor_gate(f32::INFINITY)
        }),
        ("turn_offsets=false (anchor gate only)", |p| {
            p.with_turn_offsets(false)
        }),
        ("merge_anchor_gate=inf (turn offsets only)", |p| {
            p.with_merge_anchor_gate(f32::INFINITY)
        }),
        ("defaults (both)", |p| p),
        ("same_turn_windows=false", |p| {
            p.with_same_turn_windows(false)
        }),
        ("per_turn=true", |p| p.with_per_turn(true)),
    ];
    print_sweep(&v, 5, scans)
}
