//! Dropping the lines of arcs (`Params::arc_chain`; docs/DESIGN.md,
//! "Arcs"): the defaults, no arcs dropped, other chain lengths and turn
//! windows, on the realistic synthetic scenes (`SCANS` per family and σ₀)
//! and the real logs' map truth (every `EVERY`-th frame), pooled.
//! `arc_chain = 0` turns the pairs' test (`arc_pairs`) off too; `arc_chain
//! = 2` drops every linked pair whatever a circle says of it.
//!
//! `cargo run --release -p lms-lab --example arc_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{print_sweep, Adjust};

/// The variants, each applied to the defaults (the per-data defaults on
/// real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("defaults (chains of 3, turns 5–40°)", |p| p),
        ("arc_chain=0 (no arcs dropped)", |p| p.with_arc_chain(0)),
        ("arc_chain=4", |p| p.with_arc_chain(4)),
        ("arc_chain=2", |p| p.with_arc_chain(2)),
        ("arc_min_turn_deg=2, arc_max_turn_deg=30", |p| {
            p.with_arc_min_turn_deg(2.0).with_arc_max_turn_deg(30.0)
        }),
        ("arc_min_turn_deg=10, arc_max_turn_deg=60", |p| {
            p.with_arc_min_turn_deg(10.0).with_arc_max_turn_deg(60.0)
        }),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    print_sweep(&variants(), every, scans)
}
