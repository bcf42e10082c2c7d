//! Prototype: σ per log from the residuals of its own lines. The defaults'
//! σ per data comes from the range step (10 mm for 1 cm steps); real walls
//! scatter more (14–40 mm rms about their own fit). Here a first pass over
//! every 10th frame pools the accepted lines' residuals,
//! `s² = Σ χ²_l·(m_l − 2) / Σ (m_l − 2)`, and σ_log = σ·√max(1, s²)
//! (iterated `ROUNDS` times).
//!
//! `cargo run --release -p lms-lab --example sigma_from_lines -- [EVERY]`

use std::path::Path;

use anyhow::Result;
use lms_core::{Extractor, Params};
use lms_lab::baselines::run_core;
use lms_lab::maptruth::TruthConfig;
use lms_lab::realistic::{realistic_model, sample, DELTA, SIGMAS};
use lms_lab::realtruth::{pooled_table, RealTally};
use lms_lab::scenes::Family;
use lms_lab::sweep::tally_log_frames;

/// Pooled residual variance ratio of the lines of `frames` at `params`.
fn pooled_s2<'a>(
    ex: &mut Extractor,
    frames: impl Iterator<Item = &'a lms_core::Frame>,
    params: &Params,
) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for f in frames {
        for l in run_core(ex, f, params).lines {
            let dof = f64::from(l.points) - 2.0;
            num += f64::from(l.chi2) * dof;
            den += dof;
        }
    }
    if den > 0.0 {
        num / den
    } else {
        1.0
    }
}

fn main() -> Result<()> {
    let every: usize = std::env::args().nth(1).map_or(Ok(5), |s| s.parse())?;
    let mut ex = Extractor::new();
    // Synthetic: what the estimator says where σ₀ is known.
    for sigma in SIGMAS {
        let model = realistic_model(sigma);
        for family in Family::ALL {
            let frames: Vec<_> = (0..50)
                .map(|k| sample(family, k, 1, &model, DELTA).map(|s| s.frame))
                .collect::<Result<_>>()?;
            let p = Params {
                sigma: sigma as f32,
                ..Params::DEFAULT
            };
            let s2 = pooled_s2(&mut ex, frames.iter(), &p);
            println!(
                "synthetic σ₀ {} mm {}: s² {s2:.2}, σ̂ {:.1} mm",
                sigma * 1e3,
                family.name(),
                sigma * 1e3 * s2.max(1.0).sqrt()
            );
        }
    }
    let cfg = TruthConfig::default();
    let names = [
        "σ per data",
        "σ from lines (1 round)",
        "σ from lines (2 rounds)",
        "σ from lines, √s² not floored",
    ];
    let mut pooled = vec![RealTally::default(); names.len()];
    for path in lms_lab::real::find_logs(Path::new("../shared/data/carmen"))? {
        let lms_lab::realtruth::LogWithMap {
            log,
            no_flags: base,
            cfg,
            map,
        } = lms_lab::realtruth::load_with_map(&path, &cfg)?;
        let sample_frames = || log.scans.iter().step_by(10).map(|s| &s.frame);
        let s2 = pooled_s2(&mut ex, sample_frames(), &base);
        let one = Params {
            sigma: base.sigma * (s2.max(1.0).sqrt() as f32),
            ..base
        };
        let s2b = pooled_s2(&mut ex, sample_frames(), &one);
        let two = Params {
            sigma: one.sigma * (s2b.max(1.0).sqrt() as f32),
            ..base
        };
        let raw = Params {
            sigma: base.sigma * (s2.sqrt() as f32),
            ..base
        };
        println!(
            "{}: σ {:.1} mm, s² {s2:.2} → {:.1} mm, s² {s2b:.2} → {:.1} mm",
            path.display(),
            base.sigma * 1e3,
            one.sigma * 1e3,
            two.sigma * 1e3
        );
        let variants = [base, one, two, raw];
        let mut tallies = vec![RealTally::default(); names.len()];
        tally_log_frames(&log.scans, &map, &cfg, every, &mut tallies, |k, frame| {
            run_core(&mut ex, frame, &variants[k])
        });
        print!("{}", pooled_table(&names, &tallies));
        for (p, t) in pooled.iter_mut().zip(&tallies) {
            p.merge(t);
        }
    }
    println!("\nPooled:\n");
    print!("{}", pooled_table(&names, &pooled));
    Ok(())
}
