//! The grazing term of the windows' noise (`Params::grazing_noise`, ρ;
//! docs/DESIGN.md, "Options that are not defaults"): each window's
//! `σ_w² = σ² + ρ²·min(h², (tan 80°·γ_w·b)²)`, `h = (c − a)/2`. The fits'
//! footprint model `σ_j² = σ² + (ε·d·tan θ)²` puts the same noise on a
//! window at `ρ = ε/γ_w` (`h = b·γ_w·tan θ`): 0.17 at the defaults' ε = 3
//! mrad in every LMS mode (γ_w = 1° with the same-turn windows). ρ from 0
//! (the defaults) to 0.5 on the settled truth (the no-flag parameters per
//! log, only ρ changed; per log, pooled per resolution and over all logs)
//! and the realistic synthetic scenes (0.5°, `SCANS` per family and σ₀).
//! Every frame (`EVERY` = 1, the default) runs in about a minute.
//!
//! `cargo run --release -p lms-lab --example grazing_sweep -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{settled_sweep, Adjust};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let variants: [(&'static str, Adjust); 6] = [
        ("0 (defaults)", |p| p),
        ("0.1", |p| p.with_grazing_noise(0.1)),
        ("0.17 (ε/γ_w)", |p| p.with_grazing_noise(0.17)),
        ("0.25", |p| p.with_grazing_noise(0.25)),
        ("0.35", |p| p.with_grazing_noise(0.35)),
        ("0.5", |p| p.with_grazing_noise(0.5)),
    ];
    print!("{}", settled_sweep("ρ", &variants, &[], every, scans)?);
    Ok(())
}
