//! Each line's noise model (`Params::footprint_choice`, ALGORITHM.md §7.9;
//! docs/DESIGN.md, "Fits"): the defaults, which refit each line without
//! the footprint term where its beams are likelier so, against preset
//! `v3.2` (every line keeps the footprint weights) and `footprint = 0`
//! (no footprint term anywhere). First on the settled truth (the no-flag
//! parameters per log, every `EVERY`-th frame) and the realistic synthetic
//! scenes (`SCANS` per family and σ₀), then on the plain Gaussian rooms of
//! `lms-lab evaluate` (sections 1–2: `SCANS` per family, 1 % dropouts,
//! seed 1), where the sensor has no footprint: TruePos, FalsePos, the
//! matched lines' σΔα/CRB and σΔr/CRB, the gross errors, both ratios
//! without them, and the median NEES of the lines (χ²₂: 1.39).
//!
//! `cargo run --release -p lms-lab --example footprint_choice -- [EVERY] [SCANS]`

use anyhow::Result;
use lms_core::{Extractor, Params};
use lms_lab::baselines::run_core;
use lms_lab::metrics::{scan_truth, score_lines, Gates, Tally};
use lms_lab::scenes::{sample, Family, NoiseSpec};
use lms_lab::sweep::{settled_sweep, Adjust};

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(400), |s| s.parse())?;
    let variants: [(&'static str, Adjust); 3] = [
        ("on (defaults)", |p| p),
        ("off (preset v3.2)", |p| p.with_footprint_choice(false)),
        ("footprint = 0", |p| p.with_footprint(0.0)),
    ];
    print!(
        "{}",
        settled_sweep("footprint_choice", &variants, &[], every, scans)?
    );
    println!("\nPlain Gaussian rooms, {scans} scans per family and σ:\n");
    println!("| σ | footprint_choice | TruePos | FalsePos | σΔα/CRB | σΔr/CRB | gross | σΔα/CRB, σΔr/CRB without them | NEES median |");
    println!("|:---|:---|---:|---:|---:|---:|---:|---:|---:|");
    let gates = Gates::default();
    let mut ex = Extractor::new();
    for sigma in [0.01, 0.02] {
        let mut tallies = vec![Tally::default(); variants.len()];
        for family in Family::ALL {
            for k in 0..scans {
                let s = sample(
                    family,
                    k,
                    1,
                    NoiseSpec {
                        sigma,
                        dropout: 0.01,
                    },
                )?;
                let base = Params::DEFAULT.with_sigma(sigma as f32);
                let truth = scan_truth(&s.truth, &s.scene, &base, sigma, &gates);
                for ((_, adjust), t) in variants.iter().zip(tallies.iter_mut()) {
                    let x = run_core(&mut ex, &s.frame, &adjust(base));
                    let ls = score_lines(&truth, &x.lines, s.frame.beams(), sigma, &gates);
                    t.add(&ls, &Default::default(), x.segments.len(), 0.0);
                }
            }
        }
        for ((name, _), t) in variants.iter().zip(&tallies) {
            let m = t.summary();
            println!(
                "| {} mm | {name} | {:.3} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} / {:.2} | {:.2} |",
                sigma * 1e3,
                m.true_pos,
                m.false_pos,
                m.crb_alpha,
                m.crb_r,
                m.outliers,
                m.crb_alpha_inliers,
                m.crb_r_inliers,
                m.nees_line_median
            );
        }
    }
    Ok(())
}
