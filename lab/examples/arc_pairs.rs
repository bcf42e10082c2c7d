//! Pairs of lines on curves (`Params::arc_pairs`; docs/DESIGN.md, "Arcs"):
//! the defaults against the defaults with pairs kept, and the merges'
//! nested-model test (`Params::merge_f_test`, not a default) at several
//! thresholds, on the realistic synthetic scenes (`SCANS` per family and
//! σ₀) and the real logs' map truth (every `EVERY`-th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example arc_pairs -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let variants: Vec<(&'static str, Adjust)> = vec![
        ("defaults", |p| p),
        ("arc_pairs=false", |p| p.with_arc_pairs(false)),
        ("merge_f_test=20", |p| p.with_merge_f_test(20.0)),
        ("merge_f_test=30", |p| p.with_merge_f_test(30.0)),
        ("merge_f_test=50", |p| p.with_merge_f_test(50.0)),
    ];
    print_sweep(&variants, every, scans)
}
