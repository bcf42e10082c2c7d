//! The scale of the defaults (docs/DESIGN.md, "Parameters"): the smoothing
//! passes and the segmentation gate τ. The three-beam mask iterated
//! `iterations` times spreads over about √iterations beams, so 30 passes at
//! 1° smooth over twice the angle they do at 0.5° (where the same-turn
//! windows already take every other beam); fewer passes leave more noise
//! in `D`, which a larger τ answers. Per log of the settled truth (`lms-lab
//! truth`: the no-flag parameters, σ and range limit per data, only the
//! scale changed): preset `v3.1` (30 passes, τ = 9), the defaults (5
//! passes, τ = 12), 4 to 30 passes at τ = 12 and τ from 9 to 14 at 5
//! passes: TruePos overall and by piece length, FalsePos, unexplained
//! lines, coverage, fragmentation; pooled per resolution and over all logs;
//! on the 1° logs also τ, `min_points` and the σ_α gate; and the realistic
//! synthetic scenes (0.5°, `SCANS` per family and σ₀). Every frame (`EVERY`
//! = 1, the default) runs in about a minute.
//!
//! `cargo run --release -p lms-lab --example passes_per_resolution -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_lab::sweep::{settled_sweep, Adjust};

/// The variants: the defaults, preset `v3.1`, then the passes at τ = 12
/// and τ at 5 passes.
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("5, τ 12 (defaults)", |p| p),
        ("30, τ 9 (v3.1)", |p| p.with_iterations(30).with_tau(9.0)),
        ("30, τ 12", |p| p.with_iterations(30)),
        ("12, τ 12", |p| p.with_iterations(12)),
        ("8, τ 12", |p| p.with_iterations(8)),
        ("6, τ 12", |p| p.with_iterations(6)),
        ("4, τ 12", |p| p.with_iterations(4)),
        ("5, τ 9", |p| p.with_tau(9.0)),
        ("5, τ 10", |p| p.with_tau(10.0)),
        ("5, τ 11", |p| p.with_tau(11.0)),
        ("5, τ 14", |p| p.with_tau(14.0)),
    ]
}

/// Other settings a 1° scan might want instead: the shortest segment and
/// the σ_α gate scaled by √2 (half the beams on a wall at 1°).
fn others() -> Vec<(&'static str, Adjust)> {
    vec![
        ("min_points=4", |p| p.with_min_points(4)),
        ("max_alpha_sd_deg=2.36 (√2·5/3)", |p| {
            p.with_max_alpha_sd_deg(2.36)
        }),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    print!(
        "{}",
        settled_sweep("passes, τ", &variants(), &others(), every, scans)?
    );
    Ok(())
}
