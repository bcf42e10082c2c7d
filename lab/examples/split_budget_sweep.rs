//! The work bound of split before reject (`Params::split_budget`, beams
//! tested per frame; docs/DESIGN.md, "Split before reject"): no bound and
//! 1, 1.5 (the default), 2 and 3 scans' worth, on the defaults. Realistic
//! synthetic scenes (100 scans per family and σ₀) and the real logs' map
//! truth (every 5th frame), pooled. The instructions it bounds are counted
//! under QEMU (`tools/qemu-icount/pipeline.sh --replay
//! ../shared/data/carmen/csail-corrected.log.gz --scans 200`).
//!
//! `cargo run --release -p lms-lab --example split_budget_sweep`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

fn main() -> Result<()> {
    let v: Vec<(&'static str, Adjust)> = vec![
        ("split_budget=0 (no bound)", |p| p.with_split_budget(0)),
        ("split_budget=361", |p| p.with_split_budget(361)),
        ("defaults (542)", |p| p),
        ("split_budget=722", |p| p.with_split_budget(722)),
        ("split_budget=1083", |p| p.with_split_budget(1083)),
    ];
    print_sweep(&v, 5, 100)
}
