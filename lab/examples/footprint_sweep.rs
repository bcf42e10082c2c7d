//! The footprint-weighted fit (`Params::footprint`, ALGORITHM.md §10 (f))
//! and merging across rejected segments (`Params::bridge_merge`, §10 (e)):
//! each alone, together at κ = 2–5 mrad, and with per-turn extraction, on
//! the realistic synthetic scenes (100 scans per family and σ₀) and the
//! real logs' map truth, pooled (`docs/ALGORITHM-v3-section10.md` §10.7).
//! Measured at stop 21, before the lines of arcs were dropped: every
//! variant has `arc_chain: 0` (`arc_sweep` measures that step), and all
//! run on stop 22's windows of consecutive beams (`same_turn_windows:
//! false`; `tau_sweep` measures same-turn windows).
//!
//! `cargo run --release -p lms-lab --example footprint_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{print_sweep_over, Adjust};

/// The variants, each applied to the defaults (the per-data defaults on
/// real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("v2 (Params::V2)", |p| Params {
            footprint: 0.0,
            bridge_merge: false,
            arc_chain: 0,
            ..p
        }),
        ("v2 + bridge", |p| Params {
            footprint: 0.0,
            arc_chain: 0,
            ..p
        }),
        ("v2 + footprint 3 mrad", |p| Params {
            bridge_merge: false,
            arc_chain: 0,
            ..p
        }),
        ("defaults (footprint 3 mrad + bridge)", |p| Params {
            arc_chain: 0,
            ..p
        }),
        ("footprint 2 mrad + bridge", |p| Params {
            footprint: 0.002,
            arc_chain: 0,
            ..p
        }),
        ("footprint 4 mrad + bridge", |p| Params {
            footprint: 0.004,
            arc_chain: 0,
            ..p
        }),
        ("footprint 5 mrad + bridge", |p| Params {
            footprint: 0.005,
            arc_chain: 0,
            ..p
        }),
        ("defaults + per turn", |p| Params {
            per_turn: true,
            arc_chain: 0,
            ..p
        }),
        ("v2 + per turn", |p| Params {
            footprint: 0.0,
            bridge_merge: false,
            per_turn: true,
            arc_chain: 0,
            ..p
        }),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    print_sweep_over(|p| on_data(Params::STOP22, p), &variants(), every, scans)
}
