//! The usefulness gates (docs/DESIGN.md, "Gates") swept on the real logs' map
//! truth: `Params::max_alpha_sd_deg`, `min_points` and `min_length` at
//! the no-flag defaults, with and without per-turn extraction, pooled over
//! every shared log (`UNVERIFIED=1`: against the unverified truth).
//!
//! `cargo run --release -p lms-lab --example gate_sweep -- [EVERY]`

use std::path::Path;

use anyhow::Result;
use lms_lab::maptruth::TruthConfig;
use lms_lab::realtruth::{methods, pooled_over_logs, pooled_table, RealMethod, ORACLE};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let m = RealMethod::no_flags_with;
    let mut ms = vec![
        m("defaults (max_alpha_sd_deg=1.67)", |p| p),
        m("max_alpha_sd_deg=1.0", |p| p.with_max_alpha_sd_deg(1.0)),
        m("max_alpha_sd_deg=0.75", |p| p.with_max_alpha_sd_deg(0.75)),
        m("max_alpha_sd_deg=0.5", |p| p.with_max_alpha_sd_deg(0.5)),
        m("min_points=10", |p| p.with_min_points(10)),
        m("min_points=10, max_alpha_sd_deg=1.0", |p| {
            p.with_min_points(10).with_max_alpha_sd_deg(1.0)
        }),
        m("min_points=15", |p| p.with_min_points(15)),
        m("min_length=0.3", |p| p.with_min_length(0.3)),
        m("min_length=0.5", |p| p.with_min_length(0.5)),
    ];
    ms.extend([
        m("per_turn=true", |p| p.with_per_turn(true)),
        m("per_turn=true, max_alpha_sd_deg=1.0", |p| {
            p.with_per_turn(true).with_max_alpha_sd_deg(1.0)
        }),
        m("per_turn=true, max_alpha_sd_deg=0.75", |p| {
            p.with_per_turn(true).with_max_alpha_sd_deg(0.75)
        }),
        m("per_turn=true, min_points=8", |p| {
            p.with_per_turn(true).with_min_points(8)
        }),
        m("per_turn=true, σ ≥ 15 mm", |p| {
            p.with_per_turn(true).with_sigma(p.sigma.max(0.015))
        }),
        m("per_turn=true, σ ≥ 20 mm", |p| {
            p.with_per_turn(true).with_sigma(p.sigma.max(0.02))
        }),
    ]);
    ms.extend(
        methods()
            .into_iter()
            .filter(|x| x.name == ORACLE || x.name.starts_with("split-and-merge")),
    );
    let cfg = TruthConfig {
        verify: std::env::var("UNVERIFIED").is_err(),
        ..TruthConfig::default()
    };
    let pooled = pooled_over_logs(Path::new("../shared/data/carmen"), &ms, every, &cfg)?;
    let names: Vec<&str> = ms.iter().map(|m| m.name).collect();
    print!("{}", pooled_table(&names, &pooled));
    Ok(())
}
