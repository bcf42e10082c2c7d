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
    load_with_map, pooled_table, run_log, score_frame, LogWithMap, RealMethod, RealTally,
    ScoredLine,
};
use crate::report::f;
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

fn settled_header(md: &mut String, setting: &str) {
    let _ = writeln!(
        md,
        "| log | {setting} | TruePos | ≥ 1 m | 0.5–1 m (pieces) | < 0.5 m | FalsePos | \
         unexplained | coverage | fragmented | walls fragmented | lines / frame |\n\
         |:---|:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
}

fn settled_row(md: &mut String, log: &str, name: &str, t: &RealTally) {
    let s = t.summary();
    let (bad, of) = s.walls_fragmented;
    let _ = writeln!(
        md,
        "| {log} | {name} | {} | {} | {} ({}) | {} | {} | {} | {} | {} | {bad} of {of} | {:.2} |",
        f(s.true_pos, 3),
        f(s.true_pos_1m, 3),
        f(s.true_pos_mid, 3),
        t.pieces_mid,
        f(s.true_pos_short, 3),
        f(s.false_pos, 3),
        f(s.unexplained, 3),
        f(s.coverage, 3),
        f(s.fragmented, 3),
        s.lines_per_frame,
    );
}

/// A sweep on the settled truth (`TruthConfig::settled`, the no-flag
/// parameters per log with each variant's change): every `every`-th frame
/// of every shared log, per log, pooled per resolution (1°, 0.5°) and over
/// all logs; `others` per 1° log and pooled per resolution only; then the
/// realistic synthetic scenes (0.5°, `scans` per family and σ₀) for
/// `variants`. `setting` heads the variants' column. Markdown, with the
/// logs' progress on standard error.
pub fn settled_sweep(
    setting: &str,
    variants: &[(&'static str, Adjust)],
    others: &[(&'static str, Adjust)],
    every: usize,
    scans: usize,
) -> Result<String> {
    let n = variants.len();
    let all: Vec<_> = variants.iter().chain(others).copied().collect();
    let methods: Vec<RealMethod> = all
        .iter()
        .map(|&(name, adjust)| RealMethod::no_flags_with(name, adjust))
        .collect();
    let cfg = TruthConfig::settled();
    // Pooled: [0] 1° logs, [1] 0.5° logs; per variant.
    let mut pooled = vec![vec![RealTally::default(); all.len()]; 2];
    let (mut md, mut other) = (String::new(), String::new());
    settled_header(&mut md, setting);
    settled_header(&mut other, "setting");
    for path in crate::real::find_logs(Path::new("../shared/data/carmen"))? {
        let r = run_log(&path, &methods, every, &cfg, None)?;
        let (beams, coarse) = (r.beams, r.beams <= 181);
        let name = r.name.trim_end_matches("-corrected.log.gz");
        let label = format!("{name} ({}°, {beams})", if coarse { "1" } else { "0.5" });
        for (k, t) in r.tallies.iter().enumerate() {
            if k < n {
                settled_row(&mut md, &label, all[k].0, t);
            } else if coarse {
                settled_row(&mut other, &label, all[k].0, t);
            }
            pooled[usize::from(!coarse)][k].merge(t);
        }
        eprintln!("{label}: {} frames", r.frames);
    }
    let mut out = format!("Settled truth, every {every}. frame, per log:\n\n{md}\n");
    let mut md = String::new();
    settled_header(&mut md, setting);
    for (g, label) in [(0, "1° logs"), (1, "0.5° logs")] {
        for (k, t) in pooled[g].iter().enumerate().take(n) {
            settled_row(&mut md, &format!("**{label}**"), all[k].0, t);
        }
        for (k, t) in pooled[g].iter().enumerate().skip(n) {
            settled_row(&mut other, &format!("**{label}**"), all[k].0, t);
        }
    }
    for (k, t) in pooled[0].iter().enumerate().take(n) {
        let mut both = pooled[1][k].clone();
        both.merge(t);
        settled_row(&mut md, "**all logs**", all[k].0, &both);
    }
    let _ = writeln!(out, "Pooled:\n\n{md}");
    if !others.is_empty() {
        let _ = writeln!(
            out,
            "Other settings at the defaults (1° logs, then pooled):\n\n{other}"
        );
    }
    let names: Vec<&str> = variants.iter().map(|v| v.0).collect();
    let _ = write!(
        out,
        "Realistic synthetic scenes (0.5°), {scans} scans per family and σ₀:\n\n{}",
        synthetic_table(&names, scans, &|k, ex, frame, base| {
            run_core(ex, frame, &(variants[k].1)(*base))
        })?
    );
    Ok(out)
}
