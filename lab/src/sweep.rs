//! The variant sweeps of the diagnostic examples: one pair of tables —
//! realistic synthetic scenes and the real logs' map truth — for a list of
//! extraction variants.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use host_bridge::carmen::Scan;
use lms_core::{Extractor, Frame, Params};

use crate::baselines::{run_core, Extraction};
use crate::maptruth::{frame_truth, Map, TruthConfig};
use crate::metrics::{scan_truth, score_lines, Gates, LineScore, ScanTruth, Tally};
use crate::realistic::{realistic_model, sample, DELTA, SIGMAS};
use crate::realtruth::{
    load_with_map, pooled_table, score_frame, LogWithMap, RealTally, ScoredLine,
};
use crate::scenes::{Family, Sample};

/// A change applied to the defaults (the per-data defaults on real logs,
/// σ₀ on synthetic scenes).
pub type Adjust = fn(Params) -> Params;

/// The command line of an example: the first argument that is not a flag
/// (`--…`) as a count (`default` without one), and the flags given.
pub fn count_and_flags(default: usize) -> Result<(usize, Vec<String>)> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map_or(Ok(default), |s| s.parse())?;
    let flags = args.into_iter().filter(|a| a.starts_with("--")).collect();
    Ok((count, flags))
}

/// Print, for each variant, the realistic synthetic scenes' figures
/// (`scans` per family and σ₀) and the real logs' map-truth figures
/// (every `every`-th frame, pooled), as Markdown tables.
pub fn print_sweep(variants: &[(&'static str, Adjust)], every: usize, scans: usize) -> Result<()> {
    let names: Vec<&str> = variants.iter().map(|v| v.0).collect();
    print_sweep_with(&names, every, scans, &|k, ex, frame, params| {
        run_core(ex, frame, &(variants[k].1)(*params))
    })
}

/// One realistic synthetic scan as the diagnostic examples see it: the
/// sample, its truth, what the core extracted and the line score.
pub struct ScoredScan<'a> {
    /// The scene, pose, truth and frame (and family and index).
    pub sample: &'a Sample,
    /// The truth scored against.
    pub truth: &'a ScanTruth,
    /// The core's result.
    pub extraction: &'a Extraction,
    /// The lines' score.
    pub score: &'a LineScore,
}

/// Run the core with `base` (σ set to `sigma`) on the first `scans`
/// realistic synthetic scans of every family at `sigma` and hand each,
/// scored, to `f`.
pub fn each_scored_scan(
    sigma: f64,
    scans: usize,
    base: Params,
    mut f: impl FnMut(&ScoredScan<'_>),
) -> Result<()> {
    let model = realistic_model(sigma);
    let gates = Gates {
        kappa: model.kappa,
        ..Gates::default()
    };
    let params = base.with_sigma(sigma as f32);
    let mut ex = Extractor::new();
    for family in Family::ALL {
        for index in 0..scans {
            let sample = sample(family, index, 1, &model, DELTA)?;
            let truth = scan_truth(&sample.truth, &sample.scene, &params, sigma, &gates);
            let extraction = run_core(&mut ex, &sample.frame, &params);
            let score = score_lines(
                &truth,
                &extraction.lines,
                sample.frame.beams(),
                sigma,
                &gates,
            );
            f(&ScoredScan {
                sample: &sample,
                truth: &truth,
                extraction: &extraction,
                score: &score,
            });
        }
    }
    Ok(())
}

/// Score every `every`-th frame of a log against its map truth: variant
/// `k`'s lines, `extract(k, frame)`, into `tallies[k]`.
pub fn tally_log_frames(
    scans: &[Scan],
    map: &Map,
    cfg: &TruthConfig,
    every: usize,
    tallies: &mut [RealTally],
    mut extract: impl FnMut(usize, &Frame) -> Extraction,
) {
    for scan in scans.iter().step_by(every.max(1)) {
        let truth = frame_truth(scan, map, cfg);
        let valid: Vec<bool> = scan.frame.beams().iter().map(|b| b.is_valid()).collect();
        for (k, t) in tallies.iter_mut().enumerate() {
            let x = extract(k, &scan.frame);
            let lines: Vec<ScoredLine> = x.lines.iter().map(ScoredLine::from).collect();
            score_frame(&truth, &lines, &valid, t);
        }
    }
}

/// Extraction of variant `k` on a frame, from the defaults `params`.
pub type RunVariant<'a> = dyn Fn(usize, &mut Extractor, &Frame, &Params) -> Extraction + 'a;

/// [`print_sweep`] for variants that are more than a parameter change:
/// `run(k, …)` extracts variant `k` (named `names[k]`).
pub fn print_sweep_with(
    names: &[&str],
    every: usize,
    scans: usize,
    run: &RunVariant<'_>,
) -> Result<()> {
    print!("{}", synthetic_table(names, scans, run)?);
    let mut ex = Extractor::new();
    let cfg = TruthConfig::default();
    let mut pooled = vec![RealTally::default(); names.len()];
    for path in crate::real::find_logs(Path::new("../shared/data/carmen"))? {
        let LogWithMap {
            log,
            no_flags: params,
            cfg,
            map,
            ..
        } = load_with_map(&path, &cfg)?;
        // Per log, then pooled: wall ids are per log.
        let mut tallies = vec![RealTally::default(); names.len()];
        tally_log_frames(&log.scans, &map, &cfg, every, &mut tallies, |k, frame| {
            run(k, &mut ex, frame, &params)
        });
        for (p, t) in pooled.iter_mut().zip(&tallies) {
            p.merge(t);
        }
    }
    println!("\nReal logs, every {every}. frame, pooled:\n");
    print!("{}", pooled_table(names, &pooled));
    Ok(())
}

/// The realistic synthetic scenes' table of [`print_sweep_with`] (Markdown):
/// `run(k, …)` extracts variant `k` (named `names[k]`), `scans` per family
/// and σ₀.
pub fn synthetic_table(names: &[&str], scans: usize, run: &RunVariant<'_>) -> Result<String> {
    let mut ex = Extractor::new();
    let mut md = String::from(
        "| σ₀ | method | TruePos | FalsePos | off arcs | σΔα/CRB | σΔr/CRB | gross | lines/scan | corners found | corners false |\n\
         |:---|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for sigma in SIGMAS {
        let model = realistic_model(sigma);
        let gates = Gates {
            kappa: model.kappa,
            ..Gates::default()
        };
        let mut tallies = vec![Tally::default(); names.len()];
        for family in Family::ALL {
            for i in 0..scans {
                let s = sample(family, i, 1, &model, DELTA)?;
                let base = Params::default().with_sigma(sigma as f32);
                let truth = scan_truth(&s.truth, &s.scene, &base, sigma, &gates);
                for (k, t) in tallies.iter_mut().enumerate() {
                    let x = run(k, &mut ex, &s.frame, &base);
                    let (ls, cs) = crate::score(&truth, &x, &s.frame, sigma, &gates);
                    t.add(&ls, &cs, x.segments.len(), 0.0);
                }
            }
        }
        for (name, t) in names.iter().zip(&tallies) {
            let s = t.summary();
            let _ = writeln!(
                md,
                "| {} mm | {name} | {:.3} | {:.3} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} | {:.3} | {:.3} |",
                sigma * 1e3,
                s.true_pos,
                s.false_pos,
                s.false_pos_no_arc,
                s.crb_alpha,
                s.crb_r,
                s.outliers,
                s.lines_per_scan,
                s.corner_rate,
                s.corner_false_pos
            );
        }
    }
    Ok(md)
}
