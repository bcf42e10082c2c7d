//! The merges' candidates against a wall reported twice (docs/DESIGN.md,
//! "Parameters"; the diagnosis: `--example duplicates`): per log and pooled
//! on the settled truth (every `EVERY`-th frame, the no-flag parameters per
//! data with one change), then on the realistic synthetic scenes and on
//! plain Gaussian rooms (σ = 10 and 20 mm, `SCANS` per family, 1 %
//! dropouts, seed 1).
//!
//! `cargo run --release -p lms-lab --example merge_variants -- [EVERY] [SCANS]`

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use lms_core::{Extractor, Params};
use lms_lab::baselines::run_core;
use lms_lab::maptruth::TruthConfig;
use lms_lab::metrics::{scan_truth, Gates, Tally};
use lms_lab::realistic::{realistic_model, sample, DELTA};
use lms_lab::realtruth::{run_log, RealMethod, RealTally};
use lms_lab::scenes::{self, Family, NoiseSpec};
use lms_lab::sweep::Adjust;

/// The variants: the defaults and each candidate.
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("merge_own_beams=false", |p| p.with_merge_own_beams(false)),
        ("merge_own_beams=true", |p| p.with_merge_own_beams(true)),
    ]
}

fn f(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.4}")
    } else {
        "—".into()
    }
}

fn row(md: &mut String, log: &str, name: &str, t: &RealTally) {
    let s = t.summary();
    let (bad, of) = s.walls_fragmented;
    let _ = writeln!(
        md,
        "| {log} | {name} | {} | {} | {} | {} | {} | {} | {} | {} | {bad} of {of} | {:.2} |",
        f(s.true_pos),
        f(s.true_pos_1m),
        f(s.true_pos_mid),
        f(s.false_pos),
        f(s.unexplained),
        f(s.coverage),
        f(s.fragments_dup * s.fragments),
        f(s.fragmented),
        s.lines_per_frame,
    );
}

/// TruePos and FalsePos per variant on the synthetic families at σ = 10
/// and 20 mm, `scans` per family: the realistic sensor model
/// (`realistic = true`, as `lms_lab::sweep::synthetic_table`) or plain
/// Gaussian rooms (mm quantisation, 1 % dropouts, seed 1).
fn synthetic(names: &[&str], adjust: &[Adjust], scans: usize, realistic: bool) -> Result<String> {
    let mut ex = Extractor::new();
    let mut md = String::from(
        "| σ | variant | TruePos | FalsePos | lines/scan |\n|:---|:---|---:|---:|---:|\n",
    );
    for sigma in [0.01, 0.02] {
        let model = realistic_model(sigma);
        let gates = if realistic {
            Gates {
                kappa: model.kappa,
                ..Gates::default()
            }
        } else {
            Gates::default()
        };
        let mut tallies = vec![Tally::default(); names.len()];
        for family in Family::ALL {
            for i in 0..scans {
                let s = if realistic {
                    sample(family, i, 1, &model, DELTA)?
                } else {
                    let noise = NoiseSpec {
                        sigma,
                        dropout: 0.01,
                    };
                    scenes::sample(family, i, 1, noise)?
                };
                let base = Params::default().with_sigma(sigma as f32);
                let truth = scan_truth(&s.truth, &s.scene, &base, sigma, &gates);
                for (k, t) in tallies.iter_mut().enumerate() {
                    let x = run_core(&mut ex, &s.frame, &(adjust[k])(base));
                    let (ls, cs) = lms_lab::score(&truth, &x, &s.frame, sigma, &gates);
                    t.add(&ls, &cs, x.segments.len(), 0.0);
                }
            }
        }
        for (name, t) in names.iter().zip(&tallies) {
            let s = t.summary();
            let _ = writeln!(
                md,
                "| {} mm | {name} | {:.4} | {:.4} | {:.2} |",
                sigma * 1e3,
                s.true_pos,
                s.false_pos,
                s.lines_per_scan
            );
        }
    }
    Ok(md)
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(1), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let vs = variants();
    let names: Vec<&str> = vs.iter().map(|v| v.0).collect();
    let adjust: Vec<Adjust> = vs.iter().map(|v| v.1).collect();
    let methods: Vec<RealMethod> = vs
        .iter()
        .map(|&(name, adjust)| RealMethod::no_flags_with(name, adjust))
        .collect();
    let cfg = TruthConfig::settled();
    let mut pooled = vec![RealTally::default(); vs.len()];
    let mut md = String::from(
        "| log | variant | TruePos | ≥ 1 m | 0.5–1 m | FalsePos | unexplained | coverage | \
         duplicates (of false) | fragmented | walls fragmented | lines / frame |\n\
         |:---|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let r = run_log(&path, &methods, every, &cfg, None)?;
        let name = r.name.trim_end_matches("-corrected.log.gz").to_string();
        for (k, t) in r.tallies.iter().enumerate() {
            row(&mut md, &name, names[k], t);
            pooled[k].merge(t);
        }
        eprintln!("{name}: {} frames", r.frames);
    }
    for (k, t) in pooled.iter().enumerate() {
        row(&mut md, "**all logs**", names[k], t);
    }
    println!("Settled truth, every {every}. frame:\n\n{md}");
    println!(
        "Realistic synthetic scenes (0.5°), {scans} scans per family and σ₀:\n\n{}",
        synthetic(&names, &adjust, scans, true)?
    );
    println!(
        "Plain Gaussian rooms, {scans} scans per family and σ:\n\n{}",
        synthetic(&names, &adjust, scans, false)?
    );
    Ok(())
}
