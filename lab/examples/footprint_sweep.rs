//! The footprint-weighted fit (`Params::footprint`, ALGORITHM.md §10 (f))
//! and merging across rejected segments (`Params::bridge_merge`, §10 (e)):
//! each alone, together at κ = 2–5 mrad, and with per-turn extraction, on
//! the realistic synthetic scenes (100 scans per family and σ₀) and the
//! real logs' map truth, pooled (`docs/ALGORITHM-v3-section10.md` §10.7).
//!
//! `cargo run --release -p lms-lab --example footprint_sweep -- [EVERY] [SCANS]`

use std::path::Path;

use anyhow::Result;
use lms_core::{Extractor, Params};
use lms_lab::baselines::run_core;
use lms_lab::maptruth::TruthConfig;
use lms_lab::metrics::{scan_truth, Gates, Tally};
use lms_lab::realistic::{realistic_model, sample, DELTA, SIGMAS};
use lms_lab::realtruth::{pooled_over_logs, pooled_table, Base, RealKind, RealMethod, SigmaChoice};
use lms_lab::scenes::Family;

type Adjust = fn(Params) -> Params;

/// The variants, each applied to the defaults (the per-data defaults on
/// real logs, σ₀ on synthetic scenes).
fn variants() -> Vec<(&'static str, Adjust)> {
    vec![
        ("v2 (Params::V2)", |p| Params {
            footprint: 0.0,
            bridge_merge: false,
            ..p
        }),
        ("v2 + bridge", |p| Params {
            footprint: 0.0,
            ..p
        }),
        ("v2 + footprint 3 mrad", |p| Params {
            bridge_merge: false,
            ..p
        }),
        ("defaults (footprint 3 mrad + bridge)", |p| p),
        ("footprint 2 mrad + bridge", |p| Params {
            footprint: 0.002,
            ..p
        }),
        ("footprint 4 mrad + bridge", |p| Params {
            footprint: 0.004,
            ..p
        }),
        ("footprint 5 mrad + bridge", |p| Params {
            footprint: 0.005,
            ..p
        }),
        ("defaults + per turn", |p| Params {
            per_turn: true,
            ..p
        }),
        ("v2 + per turn", |p| Params {
            footprint: 0.0,
            bridge_merge: false,
            per_turn: true,
            ..p
        }),
    ]
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let scans: usize = std::env::args().nth(2).map_or(Ok(100), |s| s.parse())?;
    let vs = variants();
    let mut ex = Extractor::new();
    println!(
        "| σ₀ | method | TruePos | FalsePos | off arcs | σΔα/CRB | σΔr/CRB | gross | lines/scan |"
    );
    println!("|:---|:---|---:|---:|---:|---:|---:|---:|---:|");
    for sigma in SIGMAS {
        let model = realistic_model(sigma);
        let gates = Gates {
            kappa: model.kappa,
            ..Gates::default()
        };
        let mut tallies = vec![Tally::default(); vs.len()];
        for family in Family::ALL {
            for k in 0..scans {
                let s = sample(family, k, 1, &model, DELTA)?;
                let base = Params {
                    sigma: sigma as f32,
                    ..Params::default()
                };
                let truth = scan_truth(&s.truth, &s.scene, &base, sigma, &gates);
                for ((_, adjust), t) in vs.iter().zip(tallies.iter_mut()) {
                    let x = run_core(&mut ex, &s.frame, &adjust(base));
                    let (ls, cs) = lms_lab::score(&truth, &x, &s.frame, sigma, &gates);
                    t.add(&ls, &cs, x.segments.len(), 0.0);
                }
            }
        }
        for ((name, _), t) in vs.iter().zip(&tallies) {
            let s = t.summary();
            println!(
                "| {} mm | {name} | {:.3} | {:.3} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} |",
                sigma * 1e3,
                s.true_pos,
                s.false_pos,
                s.false_pos_no_arc,
                s.crb_alpha,
                s.crb_r,
                s.outliers,
                s.lines_per_scan
            );
        }
    }
    let methods: Vec<RealMethod> = vs
        .iter()
        .map(|&(name, adjust)| RealMethod {
            name,
            kind: RealKind::Core,
            base: Base::NoFlags,
            sigma: SigmaChoice::Base,
            adjust,
        })
        .collect();
    let pooled = pooled_over_logs(
        Path::new("../shared/data/carmen"),
        &methods,
        every,
        &TruthConfig::default(),
    )?;
    let names: Vec<&str> = methods.iter().map(|m| m.name).collect();
    println!("\nReal logs, every {every}. frame, pooled:\n");
    print!("{}", pooled_table(&names, &pooled));
    Ok(())
}
