//! A coarse pass for rough walls (measured, not built into the core): the
//! walls the defaults miss on real scans are mostly walls whose hits scatter
//! 2–3× σ about their own fit (`real_errors`), which no window or χ² test at
//! σ accepts. This runs the extraction a second time at `k·σ` and keeps
//! each coarse line of ≥ `MIN_BEAMS` valid beams of which ≥ 90 % lie on
//! beams no fine line holds — the lines of the beams the fine pass left
//! alone — with and without per-turn extraction; realistic synthetic
//! scenes (100 scans per family and σ₀) and real logs (every 5th frame),
//! pooled (docs/DESIGN.md, "Open questions").
//!
//! `cargo run --release -p lms-lab --example coarse_fallback -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_core::{Extractor, Frame, Params};
use lms_lab::baselines::{run_core, Extraction};
use lms_lab::sweep::print_sweep_with;

/// Fewest valid beams of a coarse line that is kept.
const MIN_BEAMS: usize = 10;
/// Smallest share of a kept coarse line's valid beams that no fine line holds.
const FREE_SHARE: f64 = 0.9;

/// A variant: the coarse σ factor (0: no coarse pass) and per-turn extraction.
type Variant = (&'static str, f32, bool);

const VARIANTS: [Variant; 6] = [
    ("defaults", 0.0, false),
    ("defaults + coarse 2σ", 2.0, false),
    ("defaults + coarse 2.5σ", 2.5, false),
    ("defaults + coarse 3σ", 3.0, false),
    ("defaults + per turn", 0.0, true),
    ("defaults + per turn + coarse 2.5σ", 2.5, true),
];

/// The fine lines of `params` and the coarse lines on what they leave.
fn extract(ex: &mut Extractor, frame: &Frame, params: &Params, v: &Variant) -> Extraction {
    let params = (*params).with_per_turn(v.2);
    let mut x = run_core(ex, frame, &params);
    if v.1 <= 0.0 {
        return x;
    }
    let valid: Vec<bool> = frame.beams().iter().map(|b| b.is_valid()).collect();
    let mut held = vec![false; valid.len()];
    for l in &x.lines {
        held[usize::from(l.first)..=usize::from(l.last)].fill(true);
    }
    let coarse = run_core(ex, frame, &params.with_sigma(params.sigma * v.1));
    for l in coarse.lines {
        let beams: Vec<usize> = (usize::from(l.first)..=usize::from(l.last))
            .filter(|&j| valid[j])
            .collect();
        let free = beams.iter().filter(|&&j| !held[j]).count();
        if beams.len() >= MIN_BEAMS && free as f64 >= FREE_SHARE * beams.len() as f64 {
            x.lines.push(l);
        }
    }
    x
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let names: Vec<&str> = VARIANTS.iter().map(|v| v.0).collect();
    print_sweep_with(&names, every, scans, &|k, ex, frame, params| {
        extract(ex, frame, params, &VARIANTS[k])
    })
}
