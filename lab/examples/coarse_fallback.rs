//! A coarse pass for rough walls (measured, not built into the core): the
//! walls the defaults miss on real scans are mostly walls whose hits scatter
//! 2–3× σ about their own fit (`real_errors`), which no window or χ² test at
//! σ accepts. This runs the extraction a second time at `k·σ` and keeps
//! each coarse line of ≥ `MIN_BEAMS` valid beams of which ≥ 90 % lie on
//! beams no fine line holds — the lines of the beams the fine pass left
//! alone — with and without per-turn extraction; realistic synthetic
//! scenes (100 scans per family and σ₀) and real logs (every 5th frame),
//! pooled (docs/ALGORITHM-v3-section10.md §10.8).
//!
//! `cargo run --release -p lms-lab --example coarse_fallback -- [EVERY] [SCANS]`

use std::path::Path;

use anyhow::Result;
use host_bridge::carmen::{self, UnitMode};
use lms_core::{Extractor, Frame, Params};
use lms_lab::baselines::{run_core, Extraction};
use lms_lab::maptruth::{build_map, frame_truth, TruthConfig};
use lms_lab::metrics::{scan_truth, Gates, Tally};
use lms_lab::realistic::{realistic_model, sample, DELTA, SIGMAS};
use lms_lab::realtruth::{no_flag_params, pooled_table, score_frame, RealTally, ScoredLine};
use lms_lab::scenes::Family;

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
    let params = Params {
        per_turn: v.2,
        ..*params
    };
    let mut x = run_core(ex, frame, &params);
    if v.1 <= 0.0 {
        return x;
    }
    let valid: Vec<bool> = frame.beams().iter().map(|b| b.is_valid()).collect();
    let mut held = vec![false; valid.len()];
    for l in &x.lines {
        held[usize::from(l.first)..=usize::from(l.last)].fill(true);
    }
    let coarse = run_core(
        ex,
        frame,
        &Params {
            sigma: params.sigma * v.1,
            ..params
        },
    );
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
    let mut ex = Extractor::new();
    println!("| σ₀ | method | TruePos | FalsePos | σΔα/CRB | σΔr/CRB | lines/scan |");
    println!("|:---|:---|---:|---:|---:|---:|---:|");
    for sigma in SIGMAS {
        let model = realistic_model(sigma);
        let gates = Gates {
            kappa: model.kappa,
            ..Gates::default()
        };
        let mut tallies = vec![Tally::default(); VARIANTS.len()];
        for family in Family::ALL {
            for k in 0..scans {
                let s = sample(family, k, 1, &model, DELTA)?;
                let base = Params {
                    sigma: sigma as f32,
                    ..Params::default()
                };
                let truth = scan_truth(&s.truth, &s.scene, &base, sigma, &gates);
                for (v, t) in VARIANTS.iter().zip(tallies.iter_mut()) {
                    let x = extract(&mut ex, &s.frame, &base, v);
                    let (ls, cs) = lms_lab::score(&truth, &x, &s.frame, sigma, &gates);
                    t.add(&ls, &cs, x.segments.len(), 0.0);
                }
            }
        }
        for (v, t) in VARIANTS.iter().zip(&tallies) {
            let s = t.summary();
            println!(
                "| {} mm | {} | {:.3} | {:.3} | {:.2} | {:.2} | {:.2} |",
                sigma * 1e3,
                v.0,
                s.true_pos,
                s.false_pos,
                s.crb_alpha,
                s.crb_r,
                s.lines_per_scan
            );
        }
    }
    let cfg = TruthConfig::default();
    let mut pooled = vec![RealTally::default(); VARIANTS.len()];
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let log = carmen::read_log(&path, UnitMode::Auto)?;
        let map = build_map(&log.scans, &cfg);
        let params = no_flag_params(&path)?;
        for scan in log.scans.iter().step_by(every) {
            let truth = frame_truth(scan, &map, &cfg);
            let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
            for (v, t) in VARIANTS.iter().zip(pooled.iter_mut()) {
                let x = extract(&mut ex, &scan.frame, &params, v);
                let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
                score_frame(&truth, &lines, &valid, t);
            }
        }
    }
    let names: Vec<&str> = VARIANTS.iter().map(|v| v.0).collect();
    println!("\nReal logs, every {every}. frame, pooled:\n");
    print!("{}", pooled_table(&names, &pooled));
    Ok(())
}
