//! Dropping the lines of arcs (`Params::arc_chain`, issue 14 item 6,
//! docs/ALGORITHM-v3-section10.md §10.8): the defaults, the defaults of stop
//! 21 (no arcs dropped), and other chain lengths and turn windows, on the
//! realistic synthetic scenes (100 scans per family and σ₀) and the real
//! logs' map truth (every 5th frame), pooled. Measured at stop 22: every
//! variant runs on windows of consecutive beams (`same_turn_windows:
//! false`, `Params::STOP22`; `tau_sweep` measures same-turn windows).
//!
//! `cargo run --release -p lms-lab --example arc_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::realtruth::on_data;
use lms_lab::sweep::{print_sweep_over, Adjust};

/// The variants, each applied to the defaults (the per-data defaults on
/// real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("defaults (chains of 3, turns 5–40°)", |p| p),
        ("stop 21 (--arc-chain 0)", |p| Params { arc_chain: 0, ..p }),
        ("chains of 4", |p| Params { arc_chain: 4, ..p }),
        ("chains of 2", |p| Params { arc_chain: 2, ..p }),
        ("turns 2–30°", |p| Params {
            arc_min_turn_deg: 2.0,
            arc_max_turn_deg: 30.0,
            ..p
        }),
        ("turns 10–60°", |p| Params {
            arc_min_turn_deg: 10.0,
            arc_max_turn_deg: 60.0,
            ..p
        }),
        ("defaults + per turn", |p| Params {
            per_turn: true,
            ..p
        }),
        ("stop 21 + per turn", |p| Params {
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
