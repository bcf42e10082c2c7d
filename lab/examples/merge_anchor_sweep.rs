//! The merges' anchor gate (`Params::merge_anchor_gate`, stop 24): the union
//! of two lines must stay within the gate (χ²₂) of the larger line's own
//! parameters. On stop 23's defaults (`Params::STOP23`: without the turns'
//! offsets, which came after it; `turn_offsets_sweep` has both), so that
//! docs/ALGORITHM-v3-section10.md §10.10's table is what this prints.
//! Realistic synthetic scenes (`SCANS` per family and σ₀) and the real
//! logs' map truth (every 5th frame), pooled.
//!
//! `cargo run --release -p lms-lab --example merge_anchor_sweep -- [SCANS]`

use anyhow::Result;
use lms_core::params::DEFAULT_MERGE_ANCHOR_GATE;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{print_sweep_over, Adjust};

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let v: Vec<(&'static str, Adjust)> = vec![
        ("stop 23 (no anchor gate)", |p| p),
        ("anchor 4.61 (χ²₂ 90 %)", |p| Params {
            merge_anchor_gate: 4.61,
            ..p
        }),
        ("anchor 9.21 (99 %)", |p| Params {
            merge_anchor_gate: 9.21,
            ..p
        }),
        ("anchor 13.8 (99.9 %, the default)", |p| Params {
            merge_anchor_gate: DEFAULT_MERGE_ANCHOR_GATE,
            ..p
        }),
        ("anchor 30", |p| Params {
            merge_anchor_gate: 30.0,
            ..p
        }),
        ("anchor 100", |p| Params {
            merge_anchor_gate: 100.0,
            ..p
        }),
    ];
    print_sweep_over(|p| on_data(Params::STOP23, p), &v, 5, scans)
}
