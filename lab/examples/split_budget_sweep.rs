//! The work bound of split before reject (`Params::split_budget`, beams
//! tested per frame; docs/ALGORITHM-v3-section10.md §10.9): no bound and
//! 1, 1.5, 2 and 3 scans' worth, on stop 23's defaults (`Params::STOP23`). Realistic synthetic
//! scenes (100 scans per family and σ₀) and the real logs' map truth
//! (every 5th frame), pooled. The instructions it bounds are counted under
//! QEMU (`tools/qemu-icount/pipeline.sh --replay
//! ../shared/data/carmen/csail-corrected.log.gz --scans 200`).
//!
//! `cargo run --release -p lms-lab --example split_budget_sweep`

use anyhow::Result;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{print_sweep_over, Adjust};
fn main() -> Result<()> {
    let v: Vec<(&'static str, Adjust)> = vec![
        ("no bound", |p| Params {
            split_budget: 0,
            ..p
        }),
        ("361", |p| Params {
            split_budget: 361,
            ..p
        }),
        ("542", |p| Params {
            split_budget: 542,
            ..p
        }),
        ("722", |p| Params {
            split_budget: 722,
            ..p
        }),
        ("1083", |p| Params {
            split_budget: 1083,
            ..p
        }),
    ];
    print_sweep_over(|p| on_data(Params::STOP23, p), &v, 5, 100)
}
