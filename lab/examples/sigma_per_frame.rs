//! σ per frame from the data: the robust σ of the frame's range second
//! differences, σ̂ = 1.4826 · median|r[j−1] − 2r[j] + r[j+1]| / √6 over
//! valid triples with |Δ²r| < 0.2 m (jumps left out), used in place of the
//! per-data σ₀ or as a floor above it; the defaults otherwise. Real logs,
//! map truth, pooled (measured to decide whether `Params::sigma` should
//! follow each frame; ALGORITHM-v3-section10.md §10.7).
//!
//! `cargo run --release -p lms-lab --example sigma_per_frame -- [EVERY]`
use anyhow::Result;
use lms_core::{Extractor, Params};
use lms_lab::baselines::run_core;
use lms_lab::maptruth::{frame_truth, TruthConfig};
use lms_lab::realtruth::{pooled_table, score_frame, RealTally, ScoredLine};
use std::path::Path;

/// A variant: the parameters from the per-data defaults and σ̂.
type Variant = (&'static str, fn(&Params, f64) -> Params);

/// σ̂ of `frame` (m) from the `q` quantile of |Δ²r| (0.5: the median).
fn sigma_of(frame: &lms_core::Frame, q: f64) -> f64 {
    let r = frame.ranges();
    let b = frame.beams();
    let mut d: Vec<f64> = Vec::new();
    for j in 1..r.len() - 1 {
        if b[j - 1].is_valid() && b[j].is_valid() && b[j + 1].is_valid() {
            let d2 = f64::from(r[j - 1]) - 2.0 * f64::from(r[j]) + f64::from(r[j + 1]);
            if d2.abs() < 0.2 {
                d.push(d2.abs());
            }
        }
    }
    d.sort_by(f64::total_cmp);
    let m = d.get((q * d.len() as f64) as usize).copied().unwrap_or(0.0);
    m * 1.4826 / 6f64.sqrt()
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(10), |s| s.parse())?;
    let cfg = TruthConfig::default();
    let variants: [Variant; 4] = [
        ("defaults (σ₀ per data)", |p, _| *p),
        ("σ = max(σ₀, σ̂)", |p, s| Params {
            sigma: p.sigma.max(s as f32),
            ..*p
        }),
        ("σ = σ̂ clamped to [σ₀, 2σ₀]", |p, s| Params {
            sigma: (s as f32).clamp(p.sigma, 2.0 * p.sigma),
            ..*p
        }),
        ("σ = max(σ₀, 1.5 σ̂)", |p, s| Params {
            sigma: p.sigma.max(1.5 * s as f32),
            ..*p
        }),
    ];
    let mut pooled = vec![RealTally::default(); variants.len()];
    println!("| log | σ₀ (mm) | σ̂ quartiles over frames (mm) |\n|:---|---:|---:|");
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let lms_lab::realtruth::LogWithMap {
            log,
            no_flags: params,
            cfg,
            map,
        } = lms_lab::realtruth::load_with_map(&path, &cfg)?;
        let mut ex = Extractor::new();
        let mut sig = Vec::new();
        for scan in log.scans.iter().step_by(every) {
            let truth = frame_truth(scan, &map, &cfg);
            let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
            let s = sigma_of(&scan.frame, 0.5);
            sig.push(s);
            for (k, (_, f)) in variants.iter().enumerate() {
                let x = run_core(&mut ex, &scan.frame, &f(&params, s));
                let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
                score_frame(&truth, &lines, &valid, &mut pooled[k]);
            }
        }
        sig.sort_by(f64::total_cmp);
        println!(
            "| {} | {:.0} | {:.1}, {:.1}, {:.1} |",
            path.file_name().unwrap_or_default().to_string_lossy(),
            params.sigma * 1e3,
            sig[sig.len() / 4] * 1e3,
            sig[sig.len() / 2] * 1e3,
            sig[3 * sig.len() / 4] * 1e3
        );
    }
    let n: Vec<&str> = variants.iter().map(|v| v.0).collect();
    println!("\n{}", pooled_table(&n, &pooled));
    Ok(())
}
