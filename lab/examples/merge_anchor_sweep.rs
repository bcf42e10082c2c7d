//! The merges' anchor gate (`Params::merge_anchor_gate`; docs/DESIGN.md,
//! "Merges"): the union of two lines must stay within the gate (χ²₂) of
//! the larger line's own parameters. No gate, 4.61–100, on the defaults:
//! realistic synthetic scenes (`SCANS` per family and σ₀) and the real
//! logs' map truth (every 5th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example merge_anchor_sweep -- [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("merge_anchor_gate=inf (no gate)", |p| {
            p.with_merge_anchor_gate(f32::INFINITY)
        }),
        ("merge_anchor_gate=4.61 (χ²₂ 90 %)", |p| {
            p.with_merge_anchor_gate(4.61)
        }),
        ("merge_anchor_gate=9.21 (99 %)", |p| {
            p.with_merge_anchor_gate(9.21)
        }),
        ("defaults (13.8, χ²₂ 99.9 %)", |p| p),
        ("merge_anchor_gate=30", |p| p.with_merge_anchor_gate(30.0)),
        ("merge_anchor_gate=100", |p| p.with_merge_anchor_gate(100.0)),
    ];
    print_sweep(&v, 5, scans)
}
