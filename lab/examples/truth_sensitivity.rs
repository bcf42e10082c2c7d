//! How much the real-scan figures depend on the map truth's own choices:
//! the defaults, split-and-merge and the oracle against the settled truth
//! with one setting of `TruthConfig` changed at a time — shorter map walls,
//! a wider band of on-wall hits, cells occupied from fewer frames, sparser
//! walls, no ambiguous beams, the SLAM poses unregistered, and a line's
//! ambiguous beams left out of the matching's overlap — pooled over the
//! logs (docs/DESIGN.md, "Evaluation").
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
    let d = TruthConfig::settled();
    let truths = [
        ("the settled truth", d),
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
            "no ambiguous beams",
            TruthConfig {
                ambiguous_within: 0.0,
                ..d
            },
        ),
        (
            "the SLAM poses (not registered, no leave-one-wall-out)",
            TruthConfig {
                register_rounds: 0,
                leave_one_wall_out: false,
                ..d
            },
        ),
        (
            "ambiguous beams left out of the overlap",
            TruthConfig {
                overlap_without_ambiguous: true,
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
