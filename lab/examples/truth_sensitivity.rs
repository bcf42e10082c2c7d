//! How much the real-scan figures depend on the map truth's own choices:
//! the defaults, split-and-merge and the oracle against the verified truth
//! with one setting of `TruthConfig` changed at a time — shorter map walls,
//! a wider band of on-wall hits, cells occupied from fewer frames, sparser
//! walls, Δr measured at the line's middle instead of at the foot of its
//! normal — pooled over the logs (docs/DESIGN.md, "Open questions").
//!
//! `cargo run --release -p lms-lab --example truth_sensitivity -- [EVERY]`

use std::path::Path;

use anyhow::Result;
use lms_lab::maptruth::TruthConfig;
use lms_lab::realtruth::{pooled_over_logs, pooled_table, Base, RealKind, RealMethod, SigmaChoice};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(10), |s| s.parse())?;
    let method = |name, kind| RealMethod {
        name,
        kind,
        base: Base::NoFlags,
        sigma: SigmaChoice::Base,
        adjust: |p| p,
    };
    let methods = [
        method("defaults, no flags", RealKind::Core),
        method("split-and-merge (4σ)", RealKind::SplitMerge(4.0)),
        method("oracle", RealKind::Oracle),
    ];
    let names: Vec<&str> = methods.iter().map(|m| m.name).collect();
    let d = TruthConfig::default();
    let truths = [
        ("the truth's defaults", d),
        (
            "map walls from 0.3 m and 6 cells",
            TruthConfig {
                min_wall: 0.3,
                min_votes: 6,
                ..d
            },
        ),
        (
            "on-wall hits within 0.15 m",
            TruthConfig {
                beam_tol: 0.15,
                ..d
            },
        ),
        (
            "cells occupied from 2 frames",
            TruthConfig { min_frames: 2, ..d },
        ),
        (
            "walls from 25 % occupied",
            TruthConfig {
                min_density: 0.25,
                ..d
            },
        ),
        (
            "Δr at the line's middle",
            TruthConfig {
                range_gate_at_middle: true,
                ..d
            },
        ),
    ];
    for (name, cfg) in truths {
        let pooled = pooled_over_logs(Path::new("../shared/data/carmen"), &methods, every, &cfg)?;
        println!(
            "{name} (every {every}. frame):\n\n{}",
            pooled_table(&names, &pooled)
        );
    }
    Ok(())
}
