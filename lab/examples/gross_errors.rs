//! The gross errors of the defaults on the realistic synthetic scenes: the
//! matched lines on resolvable pieces with `Δα²/CRB` or `Δr²/CRB` above
//! 10.83 (χ²₁ at 99.9 %), which dominate σΔα/CRB (`lab/src/metrics.rs`).
//! Each is classed by the noise-free hits of its beams: beams on another
//! surface than the piece's (a wall past a corner, a pillar beside the
//! wall), or every beam on the piece's own wall. `--no-anchor-gate` runs
//! the defaults without the merges' anchor gate (`merge_anchor_gate =
//! inf`), `--merge-f-test=F` with the merges' nested-model test
//! (`Params::merge_f_test`), `--list` prints each. docs/DESIGN.md,
//! "Merges".
//!
//! `cargo run --release -p lms-lab --example gross_errors -- [SCANS] [--no-anchor-gate] [--merge-f-test=F] [--list]`

use anyhow::Result;
use lms_core::Params;
use lms_lab::metrics::median;
use lms_lab::realistic::SIGMAS;
use lms_lab::sweep::{count_and_flags, each_scored_scan};

/// χ²₁ at 99.9 %: the evaluation's gross-error limit.
const GROSS: f64 = 10.83;

fn main() -> Result<()> {
    let (scans, args) = count_and_flags(100)?;
    let base = if args.iter().any(|a| a == "--no-anchor-gate") {
        Params::DEFAULT.with_merge_anchor_gate(f32::INFINITY)
    } else {
        Params::DEFAULT
    };
    let list = args.iter().any(|a| a == "--list");
    let f_test = args
        .iter()
        .find_map(|a| a.strip_prefix("--merge-f-test="))
        .map_or(Ok(base.merge_f_test), |s| s.parse())?;
    let base = base.with_merge_f_test(f_test);
    println!("| σ₀ | matched resolvable | gross | with beams on another surface | of those: on an arc | median such beams | all on the piece's wall |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for sigma in SIGMAS {
        let (mut pairs, mut gross, mut arc, mut own) = (0, 0, 0, 0);
        let mut others = Vec::new();
        each_scored_scan(sigma, scans, base, |scan| {
            let (s, truth, x) = (scan.sample, scan.truth, scan.extraction);
            for p in scan.score.pairs.iter().filter(|p| p.resolvable) {
                pairs += 1;
                let (za, zr) = (p.d_alpha * p.d_alpha / p.crb_aa, p.d_r * p.d_r / p.crb_rr);
                if !(za > GROSS || zr > GROSS) {
                    continue;
                }
                gross += 1;
                let (line, piece) = (&x.lines[p.line], &truth.pieces[p.piece]);
                let surface_of = |j: usize| s.truth.hits.get(j).copied().flatten();
                // The piece's wall: the surface of its middle beam's hit.
                let wall = surface_of((piece.first + piece.last) / 2).map(|h| h.surface);
                let beams = usize::from(line.first)..=usize::from(line.last);
                let foreign: Vec<usize> = beams
                    .filter(|&j| s.frame.beams()[j].is_valid())
                    .filter(|&j| surface_of(j).map(|h| h.surface) != wall)
                    .collect();
                let on_arc = foreign.iter().any(|&j| truth.on_arc[j]);
                if foreign.is_empty() {
                    own += 1;
                } else {
                    others.push(foreign.len() as f64);
                    arc += usize::from(on_arc);
                }
                if list {
                    println!(
                        "{} {}: piece {}..{}, line {}..{}, z²α {za:.0}, z²r {zr:.0}, {} beams elsewhere{}",
                        s.family.name(),
                        s.index,
                        piece.first,
                        piece.last,
                        line.first,
                        line.last,
                        foreign.len(),
                        if on_arc { " (arc)" } else { "" }
                    );
                }
            }
        })?;
        println!(
            "| {} mm | {pairs} | {gross} | {} | {arc} | {:.0} | {own} |",
            sigma * 1e3,
            others.len(),
            median(&others)
        );
    }
    Ok(())
}
